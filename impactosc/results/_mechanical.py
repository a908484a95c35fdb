"""The result of a run of a :class:`~impactosc.model.MechanicalSystem`: events, dense output, energy.

Shaped like :class:`~impactosc.results.Solution`: an events table, ``sample(t)``, a status
and a message, and ``energy_balance()``. The backend hands it the records and a function
that evaluates a piece in closed form at given times (the results layer computes nothing
of the dynamics itself).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["MechanicalSolution", "MECHANICAL_EVENT_KINDS", "event_dtype"]

#: Event kinds: a spring contact closes / opens, an impact on a rigid stop, the rebounds on a
#: stop accumulate and the system comes to rest on it, it lifts off, a friction coordinate
#: sticks, reverses its slip, or is released.
MECHANICAL_EVENT_KINDS = ("contact_start", "contact_end", "impact", "rest", "lift", "stick", "reversal", "release")

def event_dtype(n: int) -> np.dtype:
    """The record of one event of an ``n``-coordinate run: ``t``, ``kind``, ``index``, ``q``, ``v``."""
    return np.dtype([("t", float), ("kind", "U13"), ("index", int), ("q", float, (n,)), ("v", float, (n,))])


#: A piece evaluator: ``(piece index, offsets from its start) -> (q, v)`` of shapes ``(len, n)``.
PieceEvaluator = Callable[[int, np.ndarray], tuple[np.ndarray, np.ndarray]]


class MechanicalSolution:
    """Events, dense output and energy terms of one run of a mechanical system.

    Attributes
    ----------
    t : float
        The time the run reached (``t_end`` when it succeeded).
    q, v : ndarray
        The state at ``t``.
    status : int
        0: reached ``t_end``; 1: stopped at ``max_events``; 2 (heyoka and scipy only): the
        rebounds on a stop accumulate, which their loops do not sum into rest (the message
        estimates the accumulation time); -1: the guard search or the integration failed
        (the message says where); what was computed up to there is kept.
    message : str
    n_pieces : int
        Smooth pieces (closed-form pieces on the exact backend).

    Examples
    --------
    >>> import numpy as np
    >>> from impactosc import MechanicalSystem, simulate_mechanical
    >>> from impactosc.model import Contact
    >>> system = MechanicalSystem(M=np.eye(1), K=[[1.0]], harmonics=[([0.5], 1.3, 0.0)],
    ...                           contacts=[Contact([1.0], 1.0, law="rigid", restitution=0.9)])
    >>> sol = simulate_mechanical(system, 50.0, [0.0], [1.2])
    >>> sol.status, bool(sol.events["kind"][0] == "impact")
    (0, True)
    >>> q, v = sol.sample([1.0, 2.0])
    >>> q.shape
    (2, 1)
    """

    def __init__(self, *, n: int, t_end: float, events: Sequence[tuple] | np.ndarray, pieces: np.ndarray,
                 evaluator: PieceEvaluator, t: float, q: np.ndarray, v: np.ndarray, status: int, message: str,
                 energy: dict[str, float]):
        self.n = n
        self.t_end = float(t_end)
        dtype = event_dtype(n)
        if isinstance(events, np.ndarray):  # records the backend made in bulk
            self._events = events.astype(dtype, copy=False).view(np.recarray)
        else:
            self._events = np.array([tuple(e) for e in events], dtype=dtype).view(np.recarray)
        self._pieces = pieces  # start times, sorted
        self._evaluator = evaluator
        self.t = float(t)
        self.q = np.array(q, dtype=float)
        self.v = np.array(v, dtype=float)
        self.status = int(status)
        self.message = message
        self.n_pieces = int(pieces.shape[0])
        self._energy = dict(energy)

    @property
    def success(self) -> bool:
        """True when the run reached ``t_end``."""
        return self.status == 0

    @property
    def events(self) -> np.recarray:
        """One row per event: ``t``, ``kind`` (``MECHANICAL_EVENT_KINDS``), ``index`` (the
        contact, or the friction entry), and the state ``q``, ``v`` just after it (after the
        impulse of an impact). Events of one instant (an impact and the rest it ends in, a
        stick test that releases another coordinate) follow one another in the order taken."""
        return self._events

    def __repr__(self) -> str:
        return (f"MechanicalSolution(n={self.n}, t={self.t:.6g}, events={len(self._events)}, "
                f"status={self.status}, message={self.message!r})")

    def sample(self, t) -> tuple[np.ndarray, np.ndarray]:
        """``(q, v)`` at the times ``t`` (within ``[0, t]`` of the run), each of shape ``(len(t), n)``.

        Evaluated in closed form on the piece that holds each time; at an event time the
        state after the event.
        """
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        if ts.ndim != 1 or not np.all(np.isfinite(ts)):
            raise ValueError(f"t must be finite times (a scalar or a 1-D array), got {t!r}")
        if ts.size and (ts.min() < 0.0 or ts.max() > self.t):
            raise ValueError(f"t must lie in [0, {self.t!r}] (the time the run reached), got "
                             f"[{ts.min()!r}, {ts.max()!r}]")
        q = np.empty((ts.size, self.n))
        v = np.empty((ts.size, self.n))
        idx = np.searchsorted(self._pieces, ts, side="right") - 1
        idx = np.clip(idx, 0, max(self.n_pieces - 1, 0))
        for i in np.unique(idx):
            sel = idx == i
            q[sel], v[sel] = self._evaluator(int(i), ts[sel] - self._pieces[i])
        return q, v

    def energy_balance(self) -> dict[str, float]:
        """The energy identity ``forcing work = Delta E + damping + friction + impact losses``.

        Keys: ``work`` (``int f(t) . q' dt``), ``delta_energy`` (kinetic + elastic, including
        engaged spring contacts), ``damping`` (``int q' . C q' dt``), ``friction``
        (``sum mu_k |Delta q_j|`` while slipping), ``impacts`` (kinetic energy lost at impacts
        and when the rebounds on a stop are summed into rest), ``residual`` (work minus the
        rest) and ``relative`` (the residual over the largest term).
        """
        e = dict(self._energy)
        if not e:
            raise ValueError("this run kept no energy terms (energy=False)")
        residual = e["work"] - e["delta_energy"] - e["damping"] - e["friction"] - e["impacts"]
        scale = max(abs(e[k]) for k in ("work", "delta_energy", "damping", "friction", "impacts", "energy_max"))
        e["residual"] = residual
        e["relative"] = abs(residual) / scale if scale > 0 else 0.0
        return e
