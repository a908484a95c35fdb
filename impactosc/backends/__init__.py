"""Backends: each integrates smooth pieces and locates guards; the engine owns the physics.

:func:`simulate` is the one entry point for a single run. A backend is looked up by name in
:data:`BACKENDS` and imported when it is first used, so that a missing optional dependency
fails with an install hint only then, and so that ``import impactosc`` costs nothing.

- ``heyoka``: Taylor integrator, one compiled integrator with the mode as runtime parameters.
- ``scipy``: ``solve_ivp`` restarted at every event, the independent cross-check.
- ``exact``: closed-form pieces (compiled), the ground truth (subfolder ``exact/``).
- ``rk4``: the paper's fixed-step method, no events (subfolder ``rk4/``).

``"auto"`` is not a backend but a choice among them, member by member
(:func:`resolve_backend`): the default of :func:`impactosc.sweep`.
"""

from ._registry import AUTO, BACKENDS, get_backend, resolve_backend
from ._simulate import DEFAULT_MAX_EVENTS, simulate

__all__ = ["simulate", "get_backend", "resolve_backend", "BACKENDS", "AUTO", "DEFAULT_MAX_EVENTS"]
