"""User-defined piecewise-smooth (hybrid) systems of any dimension.

- :class:`HybridSystem`: named states and parameters, :class:`HybridMode` (a vector field, a
  domain, integrands) and :class:`Guard` (an expression, a direction, the modes in which it
  is armed, the next mode and a reset map); :func:`symbols` makes the named variables.
- :func:`stick_slip`: the slip and stick modes of a degree of freedom with Coulomb friction
  (a Filippov stick mode with its release guards), from a friction law.
- :func:`oscillator_system`: a member of the paper's oscillator family written as such a system.
- :func:`mechanical_system`: a linear :class:`~impactosc.model.MechanicalSystem` of many degrees
  of freedom (contacts, Coulomb friction) written as such a system.

The expressions are heyoka's; this package imports heyoka when a system is built.
"""

from ._definition import DIRECTIONS, Guard, HybridMode, HybridSystem, symbols
from ._friction import stick_slip
from ._mechanical_system import mechanical_system
from ._oscillator_system import oscillator_system

__all__ = ["HybridSystem", "HybridMode", "Guard", "symbols", "stick_slip", "oscillator_system", "mechanical_system",
           "DIRECTIONS"]
