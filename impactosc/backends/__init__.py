"""Backends: each integrates smooth pieces and locates guards; the engine owns the physics.

:func:`simulate` is the one entry point for a single run. A backend is looked up by name in
:data:`BACKENDS` and imported when it is first used, so that a missing optional dependency
fails with an install hint only then, and so that ``import impactosc`` costs nothing.

- ``heyoka``: Taylor integrator, one compiled integrator with the mode as runtime parameters.
- ``scipy``: ``solve_ivp`` restarted at every event, the independent cross-check.
- ``exact``: closed-form pieces (compiled), the ground truth (subfolder ``exact/``).
- ``rk4``: the paper's fixed-step method, no events (subfolder ``rk4/``).
"""

from ._registry import BACKENDS, get_backend
from ._simulate import DEFAULT_MAX_EVENTS, simulate

__all__ = ["simulate", "get_backend", "BACKENDS", "DEFAULT_MAX_EVENTS"]
