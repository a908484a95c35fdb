"""The exact backend of linear mechanical systems of many degrees of freedom.

Every mode of a :class:`~impactosc.model.MechanicalSystem` whose spring contacts are linear is
a linear ODE with harmonic forcing, so every piece between events has a closed form (modal
decomposition of the reduced first-order system, particular solutions that stay finite at
resonance) and every event time is a root of a sum of damped exponentials and harmonics,
isolated with certified bounds on its derivatives and sizes (:mod:`._guards`). The energy
integrals are in closed form too. With numba installed, one compiled call runs the pieces and
every mode change that needs no decision in Python (springs, impacts that keep the mode,
lift-offs, releases, stick tests) across the modes built so far (:mod:`._closed`); Python builds
a mode the first time it is entered and decides rest on a stop (:mod:`._run`).
"""

from __future__ import annotations

import numpy as np

from ..._util import validation as _v
from ...model._mechanical import MechanicalSystem
from ...results._mechanical import MechanicalSolution

__all__ = ["simulate_mechanical"]


def simulate_mechanical(system: MechanicalSystem, t_end: float, q0, v0, *, max_events: int = 1_000_000,
                        energy: bool = True) -> MechanicalSolution:
    """Simulate a linear mechanical system with contacts and friction exactly, event by event.

    Parameters
    ----------
    system : MechanicalSystem
        The model; its spring contacts must be linear (``exponent == 1``).
    t_end : float
        End time (> 0).
    q0, v0 : array_like
        Initial coordinates and velocities at ``t = 0`` (``q0`` must not penetrate a rigid stop).
    max_events : int
        Stop (status 1) after this many events.
    energy : bool
        Keep the energy terms (forcing work and viscous dissipation by quadrature on every
        piece); ``False`` is faster.

    Returns
    -------
    MechanicalSolution

    Notes
    -----
    The modes (closed forms of every combination of engaged springs, resting stops and friction
    motions the run enters) are built once per system object and kept for its later runs (of the
    last few systems), so a second run of the same system, a sweep of initial states, pays no
    set-up; runs of one system in threads share them safely.

    Raises
    ------
    ValueError
        A nonlinear spring contact, a bad ``t_end``, ``q0`` or ``v0``, or a defective mode.

    Examples
    --------
    A mass on a spring, forced, bouncing on a stop at ``q = 1``:

    >>> import numpy as np
    >>> from impactosc import MechanicalSystem, simulate_mechanical
    >>> from impactosc.model import Contact
    >>> system = MechanicalSystem(M=[[1.0]], K=[[1.0]], harmonics=[([0.5], 1.3, 0.0)],
    ...                           contacts=[Contact([1.0], 1.0, law="rigid", restitution=1.0)])
    >>> sol = simulate_mechanical(system, 20.0, [0.0], [1.2])
    >>> int(sol.events["kind"].tolist().count("impact")) > 0
    True
    >>> abs(sol.energy_balance()["relative"]) < 1e-9
    True
    """
    if not isinstance(system, MechanicalSystem):
        raise TypeError(f"system must be a MechanicalSystem, got {type(system).__name__}")
    bad = [i for i, c in enumerate(system.contacts) if not c.rigid and c.exponent != 1.0]
    if bad:
        raise ValueError(f"the exact backend solves linear spring contacts only: contacts[{bad[0]}].exponent = "
                         f"{system.contacts[bad[0]].exponent!r} (need 1)")
    t_end = _v.positive("t_end", t_end)
    max_events = _v.integer("max_events", max_events)
    q0 = _state("q0", q0, system.n)
    v0 = _state("v0", v0, system.n)
    from ._run import run

    return run(system, t_end, q0, v0, max_events=max_events, energy=bool(energy))


def _state(name: str, value, n: int) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a vector of {n} real numbers, got {value!r}") from None
    if arr.size != n or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be {n} finite numbers (one per coordinate), got {value!r}")
    return arr
