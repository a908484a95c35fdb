"""A :class:`~impactosc.MechanicalSystem` on the user systems' loops, read as a :class:`MechanicalSolution`.

``simulate(system, t_end, q0, v0, backend="heyoka" | "scipy")`` runs the system's form as a
user hybrid system (:func:`~impactosc.model.hybrid.mechanical_system`) and hands back the
same result type as the exact n-DOF backend, so that every reader of a run (the tape path's
:class:`~impactosc.TapePathRun`, the energy identity, ``sample``) takes any backend: the
events in the exact backend's vocabulary (:func:`~impactosc.model.hybrid._mechanical_system.event_of`),
the state after each, dense output from the run's own integrator, and the energy terms from
the integrals the form declares (``work``, ``damping``, ``friction``) and the kinetic energy
lost at each impact. Nothing of the dynamics is computed here.
"""

from __future__ import annotations

import numpy as np

from ..model._mechanical import MechanicalSystem
from ..results._mechanical import MechanicalSolution

__all__ = ["run_as_system", "as_mechanical"]


def run_as_system(system: MechanicalSystem, t_end: float, q0, v0, *, backend: str, max_events: int,
                  energy: bool = True, **options) -> MechanicalSolution:
    """Run ``system`` on ``backend`` (``"heyoka"`` or ``"scipy"``) through its user-system form.

    ``q0``, ``v0``: ``n`` numbers each; ``**options`` are the user-system loop's
    (``impactosc.backends._hybrid.simulate_system``).
    """
    from ..model.hybrid import mechanical_system
    from ._hybrid import simulate_system

    n = system.n
    q = np.broadcast_to(np.asarray(q0, dtype=float), (n,))
    v = np.broadcast_to(np.asarray(v0, dtype=float), (n,))
    sol = simulate_system(mechanical_system(system, energy=energy), t_end, np.concatenate([q, v]), backend=backend,
                          max_events=max_events, **options)
    return as_mechanical(system, sol, energy=energy)


def as_mechanical(system: MechanicalSystem, sol, *, energy: bool = True) -> MechanicalSolution:
    """The :class:`~impactosc.results.HybridSolution` ``sol`` of ``mechanical_system(system)`` as a
    :class:`MechanicalSolution` (the module docstring says what is read from where)."""
    from ..model.hybrid._mechanical_system import event_of

    n = system.n
    rows = []
    lost = 0.0
    pieces = sol.pieces  # named on each access: read once
    e0 = float(system.energy(pieces[0][2][:n], pieces[0][2][n:2 * n]))
    e_max = abs(e0)
    for e in sol.events:
        if e.kind != "crossing":  # a grazing or a marker changes nothing
            continue
        kind, index = event_of(system, e.guard, e.mode_after)
        before, after = np.asarray(e.state_before[:2 * n]), np.asarray(e.state_after[:2 * n])
        rows.append((e.t, kind, index, after[:n], after[n:]))
        if kind == "impact":
            lost += 0.5 * float(before[n:] @ system.M @ before[n:] - after[n:] @ system.M @ after[n:])
        e_max = max(e_max, abs(float(system.energy(after[:n], after[n:]))))
    y1 = sol.state_final
    q1, v1 = y1[:n], y1[n:2 * n]
    terms: dict[str, float] = {}
    if energy:
        e1 = float(system.energy(q1, v1))
        terms = {**{k: float(sol.integrals[k]) for k in ("work", "damping", "friction")}, "impacts": lost,
                 "delta_energy": e1 - e0, "energy_max": max(e_max, abs(e1))}
    starts = np.array([p[0] for p in pieces], dtype=float)

    def evaluate(piece: int, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        states = sol.sample(np.minimum(starts[piece] + offsets, sol.t_final))
        return states[:, :n], states[:, n:2 * n]

    return MechanicalSolution(n=n, t_end=sol.t_end, events=rows, pieces=starts, evaluator=evaluate, t=sol.t_final,
                              q=q1, v=v1, status=sol.status, message=sol.message, energy=terms)
