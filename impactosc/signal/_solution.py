"""Simulated LTM records: a tape-drive run as a record and its contacts as the impacts.

Package-private: re-exported by :mod:`impactosc.signal`.
"""

from __future__ import annotations

import numpy as np

from ._analysis import LTMAnalysis, analyze

__all__ = ["from_solution", "contact_times", "analyze_solution"]


def from_solution(sol, drive, dt: float, *, t0: float | None = None, t1: float | None = None,
                  max_samples: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A simulated tape-drive run as an LTM record ``(t [s], x [m])`` sampled every ``dt`` seconds.

    Exact samples of the run (``resample`` of :mod:`impactosc.results`), so a run recorded with
    ``record="full"`` is needed and ``drive`` must be the run's :class:`~impactosc.TapeDrive`.
    ``t0``/``t1`` (s) select a window. The samples are points, not averages: content above
    ``1/(2 dt)`` (e.g. the tape's natural frequency) aliases, as in a sensor without an
    anti-aliasing filter; choose ``dt`` below half the period of interest.
    """
    from ..results._frames import sample_grid

    if drive is None:
        raise TypeError("from_solution needs the run's TapeDrive for SI units: from_solution(sol, drive, dt)")
    g = sample_grid(sol, dt, drive, t0=t0, t1=t1, max_samples=max_samples)
    return g["t"], g["x"]


def contact_times(sol, drive) -> np.ndarray:
    """Times (s) of every contact entry and exit of a run, sorted: the simulated impacts.

    Starts and ends of contacts cut by the start or end of the run are left out (they are
    not impacts). Needs ``record="events"`` or more.
    """
    from ..results._frames import units_of

    u = units_of(sol, drive)
    im = sol.impacts
    starts = im["start"][im["start"] > sol.t0]
    ends = im["end"][im["complete"]]
    return np.sort(np.concatenate((starts, ends))) * u.time


def analyze_solution(sol, drive, dt: float, *, t0: float | None = None, t1: float | None = None,
                     **analyze_options) -> LTMAnalysis:
    """:func:`analyze` on a simulated run (:func:`from_solution`), with its contacts as the impacts.

    Contact entries and exits inside the window (:func:`contact_times`) are the impact
    times the bursts are matched with.
    """
    t, x = from_solution(sol, drive, dt, t0=t0, t1=t1)
    times = contact_times(sol, drive)
    times = times[(times >= t[0]) & (times <= t[-1])]
    return analyze(t, x, impact_times=times, **analyze_options)
