"""Poincare sections: stroboscopic (once per forcing period) and event sections (at every contact, stick, ...).

Sampling is exact. A stroboscopic section is one run with a *time event* at every section
time (``simulate(..., sample_at=...)``): the engine ends a smooth piece exactly there and
records the state, so a sample is a point of the run, not an interpolation. An event
section takes the states the engine located at the events of one kind (``Solution.events``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._util import validation as _v
from ..backends._simulate import simulate
from ..engine._driver import EVENT_KINDS
from ._common import check_base, forcing_period, forcing_phase, oscillator_of, section_offset

__all__ = ["Section", "stroboscopic_section", "event_section", "detect_period"]


@dataclass(eq=False)
class Section:
    """Points of a Poincare section.

    Attributes
    ----------
    kind : str
        ``"stroboscopic"`` or the event kind of an event section.
    t, x, v : ndarray
        Time and state of every point.
    phase : ndarray
        Forcing phase ``(Omega t + phase) mod 2 pi`` of the fundamental at every point.
    side : ndarray of int
        Flange side of the event (+1 upper, -1 lower, 0 none; 0 for stroboscopic points).
    period : float
        The forcing period.
    status, message : int, str
        Of the run (``Solution.status``/``message``): a run that stopped early keeps its points.
    oscillator : Oscillator
    """

    kind: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    phase: np.ndarray
    side: np.ndarray
    period: float
    status: int
    message: str
    oscillator: object

    def __len__(self) -> int:
        return int(self.t.size)

    def to_xarray(self):
        """The section as an :class:`xarray.Dataset`.

        Dimension ``period`` (stroboscopic: the index of the forcing period since the start)
        or ``event`` (an event section), with variables ``t``, ``x``, ``v``, ``phase`` (and
        ``side`` for an event section).
        """
        import xarray as xr

        if self.kind == "stroboscopic":
            dim = "period"
            index = np.rint((self.t - self.t[0]) / self.period).astype(np.int64) + self._first_period()
        else:
            dim = "event"
            index = np.arange(self.t.size)
        data = {
            "t": (dim, self.t, {"units": "1", "long_name": "time Lambda = omega_n t"}),
            "x": (dim, self.x, {"units": "1", "long_name": "position X = x/L"}),
            "v": (dim, self.v, {"units": "1", "long_name": "velocity V = dX/dLambda"}),
            "phase": (dim, self.phase, {"units": "rad", "long_name": "forcing phase (Omega t + phase) mod 2 pi"}),
        }
        if self.kind != "stroboscopic":
            data["side"] = (dim, self.side, {"long_name": "flange side (+1 upper, -1 lower, 0 none)"})
        attrs = {"section": self.kind, "forcing_period": self.period, "status": self.status,
                 "message": self.message, "oscillator": repr(self.oscillator)}
        return xr.Dataset(data, coords={dim: index}, attrs=attrs)

    def _first_period(self) -> int:
        return int(math.floor(self.t[0] / self.period + 1e-9)) if self.t.size else 0

    def plot(self, ax=None, **scatter):
        """The section in the ``(X, V)`` plane, the flanges dashed where the member has them.

        ``scatter`` options go to ``Axes.scatter``; the flanges come from
        :func:`impactosc.results.draw_flanges` (an absent flange is not drawn).
        """
        from .._util.optional import require_matplotlib
        from ..results import draw_flanges

        plt = require_matplotlib()

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 4))
        opts = {"s": 6, "c": "C0"} | scatter
        ax.scatter(self.x, self.v, **opts)
        draw_flanges(ax, self.oscillator, axis="x", label=False)
        ax.set_xlabel("X = x/L")
        ax.set_ylabel("V = dX/dLambda")
        ax.set_title(f"{self.kind} section ({len(self)} points)", fontsize=10)
        return ax


def _check_counts(transient_periods, periods):
    return (_v.integer("transient_periods", transient_periods, minimum=0), _v.integer("periods", periods))


def stroboscopic_section(osc, periods: int, *, transient_periods: int = 0, x0: float = 0.95, v0: float = 0.0,
                         phase: float | None = None, backend: str = "heyoka", **options) -> Section:
    """The state once per forcing period, at the forcing phase ``phase``.

    One run of ``transient_periods + periods`` forcing periods (plus the offset of the
    section phase) with a time event at every section time after the transient.

    Parameters
    ----------
    osc : Oscillator or TapeDrive
    periods : int
        Points to record (>= 1).
    transient_periods : int
        Forcing periods discarded first.
    x0, v0 : float
        Initial state at time 0.
    phase : float, optional
        Forcing phase ``(Omega t + phase) mod 2 pi`` of the section; default the phase at t = 0.
    backend : str
        Any backend that supports ``sample_at`` (not ``rk4``); ``**options`` are its options.
    """
    check_base(osc)
    osc = oscillator_of(osc)
    transient_periods, periods = _check_counts(transient_periods, periods)
    T = forcing_period(osc)
    t_s = section_offset(osc, phase)
    times = t_s + T * np.arange(transient_periods, transient_periods + periods)
    t_end = float(times[-1]) if times[-1] > 0.0 else T  # one sample at t = 0: any positive end
    sol = simulate(osc, t_end, _v.real("x0", x0), _v.real("v0", v0), backend=backend,
                   record="stats", sample_at=times, **options)
    s = sol.samples
    return Section("stroboscopic", np.asarray(s.t, float), np.asarray(s.x, float), np.asarray(s.v, float),
                   forcing_phase(osc, s.t), np.zeros(len(s), dtype=np.int8), T, sol.status, sol.message, osc)


def event_section(osc, periods: int, kind: str = "contact_start", *, side: int | None = None,
                  transient_periods: int = 0, x0: float = 0.95, v0: float = 0.0, backend: str = "heyoka",
                  **options) -> Section:
    """The states at every event of one kind (a contact start on one flange, every stick, ...).

    Parameters
    ----------
    osc : Oscillator or TapeDrive
    periods : int
        Forcing periods to record events over (after the transient).
    kind : str
        One of the event kinds (:data:`impactosc.EVENT_KINDS`): ``contact_start`` (spring
        flange), ``impact`` (rigid flange), ``stick``, ``release``, ``reversal``, ``contact_end``.
    side : {+1, -1, None}
        Keep only events on that flange (``None``: both; friction events have side 0).
    transient_periods, x0, v0, backend, **options
        As :func:`stroboscopic_section`.
    """
    check_base(osc)
    osc = oscillator_of(osc)
    transient_periods, periods = _check_counts(transient_periods, periods)
    if kind not in EVENT_KINDS:
        raise ValueError(f"kind must be one of {', '.join(map(repr, EVENT_KINDS))}, got {kind!r}")
    if side is not None and (isinstance(side, bool) or side not in (1, -1)):
        raise ValueError(f"side must be +1 (upper flange), -1 (lower flange) or None (both), got {side!r}")
    T = forcing_period(osc)
    t_start = transient_periods * T
    sol = simulate(osc, t_start + periods * T, _v.real("x0", x0), _v.real("v0", v0), backend=backend,
                   record="events", **options)
    ev = sol.events
    keep = (ev.kind == kind) & (ev.t >= t_start)
    if side is not None:
        keep &= ev.side == side
    ev = ev[keep]
    return Section(kind, np.asarray(ev.t, float), np.asarray(ev.x, float), np.asarray(ev.v, float),
                   forcing_phase(osc, ev.t), np.asarray(ev.side, np.int8), T, sol.status, sol.message, osc)


def detect_period(x, v, *, max_period: int = 32, tol: float = 1e-6) -> int | None:
    """The smallest ``n`` for which a stroboscopic sequence repeats every ``n`` points, or None.

    Compares the last ``n`` points with the ``n`` before them (``|dz| <= tol``); needs at
    least ``2 n`` points. None: no period up to ``max_period`` (quasi-periodic, chaotic, or
    a transient not yet over).

    Raises
    ------
    TypeError, ValueError
        Unless ``x`` and ``v`` are 1-D sequences of finite numbers of the same length,
        ``max_period`` an integer >= 1 and ``tol`` a finite number >= 0.
    """
    max_period = _v.integer("max_period", max_period)
    tol = _v.nonnegative("tol", tol)
    arrays = []
    for name, a in (("x", x), ("v", v)):
        try:
            arr = np.asarray(a, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a 1-D sequence of real numbers, got {a!r}") from None
        if arr.ndim != 1:
            raise ValueError(f"{name} must be one-dimensional (one point of the section per entry), got shape "
                             f"{arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"{name} must be finite, got {float(arr[bad[0]])!r} at index {bad[0]}")
        arrays.append(arr)
    if arrays[0].size != arrays[1].size:
        raise ValueError(f"x and v must have the same length (one (X, V) point per entry), got {arrays[0].size} "
                         f"and {arrays[1].size}")
    z = np.column_stack(arrays)
    for n in range(1, max_period + 1):
        if z.shape[0] < 2 * n:
            return None
        if np.max(np.abs(z[-n:] - z[-2 * n:-n])) <= tol:
            return n
    return None
