"""The model: one definition of the hybrid system, and the tape drive that sets its parameters.

- :class:`Oscillator`: the nondimensional eq. 3 of the paper and its family (damping, static
  friction, rigid or power-law flanges, harmonic sums): modes, vector fields, guards, the
  stick test. The switching physics itself is written once, in ``_rule.py``, compiled when
  numba is there and shared by every backend and analysis.
- :class:`TapeDrive`: the drive in SI units (paper eq. 1, 4, 5, Fig. 6), mapped onto an
  :class:`Oscillator` by :meth:`TapeDrive.oscillator`.
- :class:`MechanicalSystem`: linear systems of many degrees of freedom with contacts
  (:class:`Contact`: springs or rigid stops with restitution) and Coulomb friction
  (:class:`Friction`).

Importing this package loads neither numba nor heyoka: the compiled rule is imported
when a model first computes a force.
"""

from ._mechanical import CONTACT_LAWS, Contact, Friction, MechanicalSystem
from ._oscillator import FLANGE_LAWS, Oscillator
from ._tape import BENDING_OPTIONS, FIELD_UNITS, TapeDrive

__all__ = ["Oscillator", "TapeDrive", "FLANGE_LAWS", "BENDING_OPTIONS", "FIELD_UNITS", "MechanicalSystem", "Contact",
           "Friction", "CONTACT_LAWS"]
