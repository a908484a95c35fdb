"""The result of a run of a user's hybrid system: events, dense output, status, integrals."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["HybridEvent", "HybridSolution", "STATUS_MESSAGES"]

#: What each status means (the message adds the specifics).
STATUS_MESSAGES = {
    0: "The end time was reached.",
    1: "The event limit max_events was reached; results up to t_final are kept.",
    2: "Events accumulate (Zeno): the run stops at t_final; accumulation_time estimates where they pile up.",
    -1: "The integration failed; results up to t_final are kept.",
}


class HybridEvent(NamedTuple):
    """One event: its time, the guard, what happened, the modes and the states on each side."""

    t: float
    guard: str
    kind: str  #: "crossing" (the transition applied), "grazing", "marker" or "rest" (see Guard.rest)
    mode_before: str
    mode_after: str
    state_before: tuple
    state_after: tuple


class HybridSolution:
    """The run of a :class:`~impactosc.HybridSystem` from :func:`impactosc.simulate`.

    Attributes
    ----------
    system : HybridSystem
    backend : str
    t_end, t_final : float
        The requested end time and where the run stopped.
    status : int
        0 end reached, 1 event limit, 2 accumulation of events (Zeno) with
        ``accumulation_time`` estimated, -1 failure (results up to ``t_final`` kept).
    message : str
    events : list of HybridEvent
    state_final : numpy.ndarray
        States then integrals at ``t_final``.
    mode_final : str
    accumulation_time : float or None
    integrals : dict
        Each declared integral's value at ``t_final`` (from 0 at the start).
    """

    def __init__(self, system, backend: str, t_end: float, t_final: float, status: int, message: str,
                 events, pieces, state_final, mode_final: int, evaluate, accumulation_time=None):
        names = system.mode_names
        self.system = system
        self.backend = backend
        self.t_end = t_end
        self.t_final = float(t_final)
        self.status = status
        self.message = message
        self._raw_events = events  # named on first use (a run's loop keeps indices)
        self._events: list[HybridEvent] | None = None
        self._pieces = pieces
        self.state_final = np.asarray(state_final, dtype=float)
        self.mode_final = names[mode_final]
        self.accumulation_time = accumulation_time
        n = system.dimension
        self.integrals = {q: float(self.state_final[n + i]) for i, q in enumerate(system.integrals)}
        self._evaluate = evaluate

    @property
    def events(self) -> list[HybridEvent]:
        """Every event in time order (:class:`HybridEvent`: guards and modes by name)."""
        if self._events is None:
            names, guards = self.system.mode_names, self.system.guard_names
            self._events = [HybridEvent(t, guards[g], kind, names[a], names[b], tuple(before), tuple(after))
                            for t, g, kind, a, b, before, after in self._raw_events]
        return self._events

    @property
    def pieces(self) -> list[tuple[float, str, tuple]]:
        """``(t, mode, state)`` at the start of every smooth piece (states then integrals)."""
        names = self.system.mode_names
        return [(t, names[m], tuple(y)) for t, m, y in self._pieces]

    @property
    def success(self) -> bool:
        return self.status == 0

    def event_times(self, guard: str | None = None, kind: str = "crossing") -> np.ndarray:
        """The times of the events of ``kind`` (and of ``guard`` when given)."""
        return np.array([e.t for e in self.events if e.kind == kind and (guard is None or e.guard == guard)])

    def event_table(self):
        """The events as a pandas DataFrame: ``t, guard, kind, mode_before, mode_after``, then each
        state before (``<name>-``) and after (``<name>+``)."""
        import pandas as pd

        names = list(self.system.states) + list(self.system.integrals)
        rows = []
        for e in self.events:
            row = {"t": e.t, "guard": e.guard, "kind": e.kind, "mode_before": e.mode_before,
                   "mode_after": e.mode_after}
            row.update({f"{s}-": c for s, c in zip(names, e.state_before, strict=True)})
            row.update({f"{s}+": c for s, c in zip(names, e.state_after, strict=True)})
            rows.append(row)
        columns = ["t", "guard", "kind", "mode_before", "mode_after"] + [f"{s}-" for s in names] + \
            [f"{s}+" for s in names]
        return pd.DataFrame(rows, columns=columns)

    def sample(self, times) -> np.ndarray:
        """The states and integrals at ``times`` (in ``[0, t_final]``), one row per time.

        Each piece is integrated again from its start (dense output from the same
        integrator). At an event time the state after the event is returned.
        """
        times = np.atleast_1d(np.asarray(times, dtype=float))
        t0 = self._pieces[0][0]
        if times.size and (times.min() < t0 or times.max() > self.t_final):
            raise ValueError(f"sample: times must lie in [{t0!r}, t_final={self.t_final!r}], "
                             f"got [{times.min()!r}, {times.max()!r}]")
        starts = np.array([p[0] for p in self._pieces])
        which = np.searchsorted(starts, times, side="right") - 1
        out = np.empty((times.size, len(self.state_final)))
        for k in np.unique(which):
            at = np.nonzero(which == k)[0]
            t_start, mode, state = self._pieces[k]
            out[at] = self._evaluate(mode, t_start, state, times[at])
        return out

    def __repr__(self) -> str:
        return (f"HybridSolution({self.system.name!r}, backend={self.backend!r}, status={self.status}, "
                f"t_final={self.t_final!r}, events={len(self.events)})")
