"""Results that plug in: a run's tables as pandas DataFrames, the run on a uniform grid, plots, SI units.

Every function takes a :class:`~impactosc.solution.Solution` and an optional
:class:`~impactosc.tape.TapeDrive`. Without a drive the results are in the units of the
nondimensional eq. 3 (time ``Lambda = omega_n t``, position ``X = x/L``, force in units of
``k L``); with one they are in SI units (s, m, m/s, N), converted with the drive's scales
(:attr:`~impactosc.tape.TapeDrive.time_scale`, :attr:`~impactosc.tape.TapeDrive.length_scale`,
:attr:`~impactosc.tape.TapeDrive.force_scale`). A Solution does not know the drive it came
from, so the drive is checked against the run: its ``F``, ``Omega``, ``beta`` and ``K`` must
be the run's. Units are in the column names (``"t [s]"``, ``"x [L]"``) and in the
``units`` attributes of xarray variables.

:class:`SolutionFramesMixin` exposes the same functions as methods of a Solution. The
record arrays ``Solution.events``/``Solution.impacts`` stay as they are, for speed.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._util import validation as _v
from ..engine._driver import EVENT_KINDS
from ..model._tape import TapeDrive

if TYPE_CHECKING:  # pandas and xarray are imported by the functions that build frames
    import pandas as pd

__all__ = ["SolutionFramesMixin", "Units", "units_of", "events_frame", "impacts_frame", "to_dataframe", "draw_flanges",
           "resample", "plot_run", "to_si", "SIResults", "BYTES_PER_SAMPLE"]

TABLES = ("events", "impacts")
OUTPUTS = ("xarray", "dataframe")

#: Peak memory of :func:`resample` per grid point, in bytes: the time grid in both units,
#: X, V, the piece impulse, piece indices and masks inside ``Solution.sample``, and the
#: four output columns (with pandas' copies). Measured with tracemalloc: ~110.
BYTES_PER_SAMPLE = 160
#: Cap on the grid when the available memory cannot be read (non-Linux systems).
FALLBACK_MAX_SAMPLES = 50_000_000


@dataclass(frozen=True)
class Units:
    """Scales and unit names of one unit system (nondimensional or SI).

    A nondimensional quantity times its scale is the quantity in ``*_unit``.
    """

    time: float
    length: float
    force: float
    time_unit: str
    length_unit: str
    velocity_unit: str
    force_unit: str
    impulse_unit: str
    energy_unit: str

    @property
    def velocity(self) -> float:
        return self.length / self.time

    @property
    def impulse(self) -> float:
        return self.force * self.time

    @property
    def energy(self) -> float:
        return self.force * self.length


NONDIMENSIONAL = Units(1.0, 1.0, 1.0, "1/omega_n", "L", "L omega_n", "k L", "k L/omega_n", "k L^2")


def _check_drive(sol, drive: TapeDrive) -> None:
    """Raise unless ``drive`` reduces to the oscillator the run was made with (eq. 3)."""
    if not isinstance(drive, TapeDrive):
        raise TypeError(f"drive must be a TapeDrive or None, got {drive!r} of type {type(drive).__name__}")
    osc = sol.oscillator
    for name in ("F", "Omega", "beta", "K"):
        mine, theirs = getattr(drive, name), getattr(osc, name)
        if not math.isclose(mine, theirs, rel_tol=1e-9, abs_tol=1e-300):
            raise ValueError(f"drive does not match the run: drive.{name} = {mine!r} but the run's oscillator has "
                             f"{name} = {theirs!r}; pass the TapeDrive whose .oscillator() was simulated")


def units_of(sol, drive: TapeDrive | None = None) -> Units:
    """The unit system of results of ``sol``: nondimensional without ``drive``, SI with it."""
    if drive is None:
        return NONDIMENSIONAL
    _check_drive(sol, drive)
    return Units(drive.time_scale, drive.length_scale, drive.force_scale, "s", "m", "m/s", "N", "N s", "J")


# -- tables ---------------------------------------------------------------------------------
def events_frame(sol, drive: TapeDrive | None = None) -> pd.DataFrame:
    """``Solution.events`` as a DataFrame, one row per event.

    Columns ``t``, ``x``, ``v`` with their units in the name (``"t [s]"`` or
    ``"t [1/omega_n]"``), ``kind`` (categorical, :data:`~impactosc.engine.EVENT_KINDS`)
    and ``side`` (+1 upper flange, -1 lower, 0 otherwise). Needs ``record="events"`` or
    ``"full"``. ``DataFrame.attrs["units"]`` names the unit system.
    """
    import pandas as pd

    u = units_of(sol, drive)
    ev = sol.events
    df = pd.DataFrame({
        f"t [{u.time_unit}]": ev["t"] * u.time,
        "kind": pd.Categorical(ev["kind"], categories=EVENT_KINDS),
        f"x [{u.length_unit}]": ev["x"] * u.length,
        f"v [{u.velocity_unit}]": ev["v"] * u.velocity,
        "side": ev["side"].astype(np.int8),
    })
    df.attrs["units"] = "SI" if drive is not None else "nondimensional"
    return df


def impacts_frame(sol, drive: TapeDrive | None = None) -> pd.DataFrame:
    """``Solution.impacts`` as a DataFrame, one row per contact, units in the column names.

    Columns: ``start``, ``end``, ``duration`` (time), ``side``, ``entry_velocity``,
    ``exit_velocity``, ``peak_penetration`` (length: ``|X| - 1`` times ``L``),
    ``peak_force`` (force: the member's flange law at its peak, see ``Solution.impacts``),
    ``impulse`` (the integral of the flange force over the contact, force times time) and
    ``complete``. Needs ``record="events"`` or ``"full"``.
    """
    import pandas as pd

    u = units_of(sol, drive)
    im = sol.impacts
    df = pd.DataFrame({
        f"start [{u.time_unit}]": im["start"] * u.time,
        f"end [{u.time_unit}]": im["end"] * u.time,
        f"duration [{u.time_unit}]": (im["end"] - im["start"]) * u.time,
        "side": im["side"].astype(np.int8),
        f"entry_velocity [{u.velocity_unit}]": im["entry_velocity"] * u.velocity,
        f"exit_velocity [{u.velocity_unit}]": im["exit_velocity"] * u.velocity,
        f"peak_penetration [{u.length_unit}]": im["peak_penetration"] * u.length,
        f"peak_force [{u.force_unit}]": im["peak_force"] * u.force,
        f"impulse [{u.impulse_unit}]": im["impulse"] * u.impulse,
        "complete": im["complete"].astype(bool),
    })
    df.attrs["units"] = "SI" if drive is not None else "nondimensional"
    return df


def to_dataframe(sol, table: str = "events", drive: TapeDrive | None = None) -> pd.DataFrame:
    """The ``"events"`` or ``"impacts"`` table of a run as a DataFrame (see :func:`events_frame`)."""
    _v.choice("table", table, TABLES)
    return events_frame(sol, drive) if table == "events" else impacts_frame(sol, drive)


# -- the run on a uniform grid --------------------------------------------------------------
def _available_memory() -> int | None:
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - non-POSIX systems
        return None


def _grid_size(duration: float, dt: float, max_samples: int | None, what: str) -> int:
    steps = duration / dt
    k = math.floor(steps)
    if math.ceil(steps) != k and math.isclose(steps, math.ceil(steps), rel_tol=1e-12):
        k += 1  # t1 is on the grid up to rounding (e.g. 0.3 / 0.1 = 2.9999999999999996)
    n = k + 1
    if max_samples is None:
        avail = _available_memory()
        limit = FALLBACK_MAX_SAMPLES if avail is None else avail // (2 * BYTES_PER_SAMPLE)
        why = ("the fallback cap" if avail is None
               else f"half the available memory ({avail / 1e9:.3g} GB at ~{BYTES_PER_SAMPLE} bytes per sample)")
    else:
        limit = _v.integer("max_samples", max_samples)
        why = "max_samples"
    if n > limit:
        raise ValueError(f"resample: dt={dt!r} over the {what} {duration!r} makes {n:,} samples "
                         f"(~{n * BYTES_PER_SAMPLE / 1e9:.3g} GB), more than {why} allows ({limit:,}); "
                         f"use a larger dt or a shorter window t0/t1")
    return n


def sample_grid(sol, dt: float, drive: TapeDrive | None = None, *, t0: float | None = None,
                t1: float | None = None, max_samples: int | None = None) -> dict:
    """The run at ``t0, t0 + dt, ...`` up to ``t1``, as arrays in the units of :func:`units_of`.

    Returns a dict with ``t`` (in the chosen units), ``Lambda`` (nondimensional time), ``x``,
    ``v``, ``flange_force`` and ``forcing``, and ``units`` (:class:`Units`). See :func:`resample`.
    """
    u = units_of(sol, drive)
    if sol.record != "full":
        raise ValueError(f"resample needs record='full', but this run used record={sol.record!r}; "
                         f"rerun simulate(..., record='full')")
    dt = _v.positive("dt", dt)
    start, stop = sol.t0 * u.time, sol.t_final * u.time
    lo = start if t0 is None else _v.real("t0", t0)
    hi = stop if t1 is None else _v.real("t1", t1)
    # Compare in nondimensional time: the bounds of the run are known there exactly.
    lo_lam, hi_lam = lo / u.time, hi / u.time
    if lo == start:
        lo_lam = sol.t0
    if hi == stop:
        hi_lam = sol.t_final
    if not (sol.t0 <= lo_lam < hi_lam <= sol.t_final):
        raise ValueError(f"the window must satisfy {start!r} <= t0 < t1 <= {stop!r} [{u.time_unit}], "
                         f"got t0={lo!r}, t1={hi!r}")
    n = _grid_size(hi - lo, dt, max_samples, f"window of {u.time_unit}")
    t = np.minimum(lo + dt * np.arange(n), hi)
    lam = np.clip(t / u.time, sol.t0, hi_lam)
    if lo == start:
        lam[0] = sol.t0
    x, v, _, k = sol._evaluate(sol._sample_times(lam, "resample"))
    force = sol._force_at(lam, x, k)  # the member's flange law (a rigid wall's push included)
    osc = sol.oscillator
    return {"t": t, "Lambda": lam, "x": x * u.length, "v": v * u.velocity,
            "flange_force": force * u.force, "forcing": osc.forcing(lam) * u.force, "units": u}


_VARIABLES = {  # name -> (units attribute of Units, long name)
    "x": ("length_unit", "lateral tape position (eq. 3: X = x/L)"),
    "v": ("velocity_unit", "lateral tape velocity"),
    "flange_force": ("force_unit", "flange force of the member's flange law (K d^p, or a rigid wall's push)"),
    "forcing": ("force_unit", "run-out forcing F cos(Omega Lambda + phase) (eq. 3)"),
}


def resample(sol, dt: float, drive: TapeDrive | None = None, *, t0: float | None = None,
             t1: float | None = None, output: str = "xarray", max_samples: int | None = None):
    """The run on a uniform time grid, exactly: position, velocity, flange force and forcing.

    Each grid time is evaluated on the smooth piece that contains it
    (:meth:`Solution.sample <impactosc.solution.Solution.sample>`, which re-integrates the
    piece from its recorded start), so there is no interpolation error. Needs ``record="full"``.

    Parameters
    ----------
    sol : Solution
        A run recorded with ``record="full"``.
    dt : float
        Grid step (> 0): nondimensional (``Lambda``) without ``drive``, seconds with it.
    drive : TapeDrive, optional
        The tape drive of the run, for SI output (s, m, m/s, N). It must reduce to the run's
        oscillator (same ``F``, ``Omega``, ``beta``, ``K``).
    t0, t1 : float, optional
        Window, in the units of ``dt`` (default: the whole run). The grid is ``t0 + k dt``
        for every ``k`` with ``t0 + k dt <= t1``.
    output : {"xarray", "dataframe"}
        An :class:`xarray.Dataset` (coordinate ``t``, plus ``Lambda`` along it; variables
        ``x``, ``v``, ``flange_force``, ``forcing`` with ``units`` and ``long_name``
        attributes), or a :class:`pandas.DataFrame` indexed by ``t`` with the units in the
        column names.
    max_samples : int, optional
        Refuse grids with more points. Default: what fits in half the available memory.

    Raises
    ------
    ValueError
        If the run was not recorded with ``record="full"``, ``dt`` is not positive, the
        window lies outside the run, the grid is too large for memory (the message gives
        the size), or ``drive`` does not match the run.
    """
    import pandas as pd
    import xarray as xr

    _v.choice("output", output, OUTPUTS)
    g = sample_grid(sol, dt, drive, t0=t0, t1=t1, max_samples=max_samples)
    u: Units = g["units"]
    if output == "dataframe":
        cols = {f"{name} [{getattr(u, unit)}]": g[name] for name, (unit, _) in _VARIABLES.items()}
        cols["Lambda [-]"] = g["Lambda"]
        df = pd.DataFrame(cols, index=pd.Index(g["t"], name=f"t [{u.time_unit}]"))
        df.attrs["units"] = "SI" if drive is not None else "nondimensional"
        return df
    data = {name: ("t", g[name], {"units": getattr(u, unit), "long_name": long})
            for name, (unit, long) in _VARIABLES.items()}
    coords = {"t": ("t", g["t"], {"units": u.time_unit, "long_name": "time"}),
              "Lambda": ("t", g["Lambda"], {"units": "1", "long_name": "nondimensional time omega_n t"})}
    osc = sol.oscillator
    attrs = {"backend": sol.backend, "F": osc.F, "Omega": osc.Omega, "beta": osc.beta, "K": osc.K,
             "phase": osc.phase, "units": "SI" if drive is not None else "nondimensional", "dt": float(dt)}
    if drive is not None:
        attrs["drive"] = repr(drive)
    return xr.Dataset(data, coords=coords, attrs=attrs)


# -- SI results -----------------------------------------------------------------------------
@dataclass(frozen=True)
class SIResults:
    """Every result of a run in SI units (see :func:`to_si`).

    Attributes
    ----------
    stats : pandas.Series
        Scalars, units in the index labels: run times, mean/rms/max flange force per flange,
        max penetration, contact time, flange impulse, forcing and friction work, counts.
    events, impacts : pandas.DataFrame or None
        The tables of :func:`events_frame`/:func:`impacts_frame` in SI units (None for a run
        recorded with ``record="stats"``).
    drive : TapeDrive
        The drive used for the conversion.
    """

    stats: pd.Series
    events: pd.DataFrame | None
    impacts: pd.DataFrame | None
    drive: TapeDrive


def to_si(sol, drive: TapeDrive) -> SIResults:
    """Every result of ``sol`` in SI units, with the scales of ``drive`` (time ``1/omega_n``,
    length ``L``, force ``k L``; paper eq. 3).

    The statistics are available in every recording mode; the tables need ``record="events"``
    or more. ``drive`` must reduce to the run's oscillator.
    """
    import pandas as pd

    if drive is None:
        raise TypeError("to_si needs the run's TapeDrive: to_si(sol, drive)")
    u = units_of(sol, drive)
    s: dict[str, float] = {
        "t0 [s]": sol.t0 * u.time, "t_final [s]": sol.t_final * u.time, "t_end [s]": sol.t_end * u.time,
        "x_final [m]": sol.x_final * u.length, "v_final [m/s]": sol.v_final * u.velocity,
    }
    for side, name in ((1, "upper"), (-1, "lower"), (None, "both")):
        s[f"contacts_{name}"] = sol.contact_entries(side)
        s[f"mean_flange_force_{name} [N]"] = sol.mean_flange_force(side) * u.force
        s[f"rms_flange_force_{name} [N]"] = sol.rms_flange_force(side) * u.force
        s[f"max_flange_force_{name} [N]"] = sol.max_flange_force(side) * u.force
        s[f"max_penetration_{name} [m]"] = sol.max_penetration(side) * u.length
        s[f"contact_time_{name} [s]"] = sol.contact_time(side) * u.time
        s[f"flange_impulse_{name} [N s]"] = sol.flange_impulse(side) * u.impulse
    s["forcing_work [J]"] = sol.forcing_work * u.energy
    s["friction_work [J]"] = sol.friction_work * u.energy
    for kind, count in sol.counts.items():
        s[f"count_{kind}"] = count
    stats = pd.Series(s, name="SI", dtype=float)
    tables = sol.record != "stats"
    return SIResults(stats, events_frame(sol, drive) if tables else None,
                     impacts_frame(sol, drive) if tables else None, drive)


# -- plot ---------------------------------------------------------------------------------
#: How each event kind is marked: (marker, colour).
EVENT_MARKERS = {"contact_start": (">", "tab:red"), "contact_end": ("<", "darkred"), "reversal": ("x", "0.4"),
                 "stick": ("o", "tab:blue"), "release": ("^", "tab:green"), "impact": ("v", "tab:red"),
                 "chatter": ("*", "darkred")}
#: Line style of a flange in every figure.
FLANGE_STYLE = {"color": "tab:red", "lw": 0.8, "ls": "--"}


def draw_flanges(ax, osc, *, axis: str = "y", scale: float = 1.0, along=None, label: bool = True) -> None:
    """Draw the flanges of ``osc`` where they are: at ``X = -gap_lower`` and ``X = +gap_upper``.

    One helper for every figure that shows the flanges (``Solution.plot``,
    :func:`~impactosc.results.plot_solution`, :func:`~impactosc.dynamics.plot_bifurcation`,
    ``Section.plot``): the positions come from
    :attr:`Oscillator.flanges <impactosc.Oscillator.flanges>`, and an absent flange
    (``gap = None``/``inf``, a one-sided stop) is not drawn.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    osc : Oscillator or sequence of Oscillator
        The member; with ``along``, one member per abscissa (the flanges may move with a
        parameter, e.g. a tape drive's ``guide_offset``).
    axis : {"y", "x"}
        The axis that shows the position ``X``: ``"y"`` draws horizontal lines (a time series,
        a bifurcation diagram), ``"x"`` vertical ones (a phase plane).
    scale : float
        Multiplies ``X`` (e.g. the clearance in micrometres for a plot in SI units).
    along : array_like, optional
        Abscissae of the members in ``osc`` (only with ``axis="y"``): the flanges are drawn
        as lines through ``(along[i], flange of osc[i])``.
    label : bool
        Label the lines for a legend (rigid wall or spring flange, and its position).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from impactosc import Oscillator
    >>> from impactosc.results import draw_flanges
    >>> fig, ax = plt.subplots()
    >>> draw_flanges(ax, Oscillator(0.5, 1.1, 0.01, 1e4, gap_lower=1.5, gap_upper=0.5))
    """
    if axis not in ("x", "y"):
        raise ValueError(f"axis must be 'x' or 'y' (the axis that shows X), got {axis!r}")
    members = list(osc) if along is not None else [osc]
    if along is not None and (axis != "y" or len(members) != len(along)):
        raise ValueError("along needs axis='y' and one member of osc per abscissa")
    law = "rigid wall" if members[0].rigid else "flange"
    for side in (1, -1):
        positions = np.array([m.flanges[(side + 1) // 2] for m in members], dtype=float) * scale
        if not np.any(np.isfinite(positions)):
            continue  # this flange is absent
        name = "upper" if side == 1 else "lower"
        text = None
        if label:
            fixed = np.all(positions == positions[0])
            text = f"{name} {law}" + (f" (X = {positions[0] / scale:g})" if fixed else "")
        style = FLANGE_STYLE | {"label": text}
        if along is not None and not np.all(positions == positions[0]):
            ax.plot(along, positions, **style)
        elif axis == "y":
            ax.axhline(positions[0], **style)
        else:
            ax.axvline(positions[0], **style)


def plot_run(sol, drive: TapeDrive | None = None, *, n_samples: int = 4000, kinds=EVENT_KINDS, path=None):
    """Time series with the events marked by kind, and the phase plane with the flanges.

    Parameters
    ----------
    sol : Solution
        A run recorded with ``record="full"``.
    drive : TapeDrive, optional
        Plot in SI units (ms, um, m/s) instead of ``Lambda``, ``X``, ``V``.
    n_samples : int
        Dense-output samples on a uniform grid; the event states are added to them.
    kinds : sequence of str
        Event kinds to mark (default all of :data:`~impactosc.engine.EVENT_KINDS`).
    path : str or path-like, optional
        Save the figure there too.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes: position against time with the flanges dashed where they are
        (:func:`draw_flanges`; a rigid wall's impacts and chatters marked like the other
        events), and the phase plane (position, velocity) with the flanges as vertical lines.
    """
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    u = units_of(sol, drive)
    n_samples = _v.integer("n_samples", n_samples, minimum=2)
    for kind in kinds:
        _v.choice("kinds", kind, EVENT_KINDS)
    ev = sol.events
    lam = np.union1d(np.linspace(sol.t0, sol.t_final, n_samples), ev["t"])
    x, v = sol.sample(lam)
    # Readable SI axes: milliseconds and micrometres.
    ts, xs = (1e3 * u.time, 1e6 * u.length) if drive is not None else (1.0, 1.0)
    t_label = "t [ms]" if drive is not None else "Λ = ω_n t [-]"
    x_label = "x [µm]" if drive is not None else "X = x/L [-]"
    v_label = "v [m/s]" if drive is not None else "V = dX/dΛ [-]"
    fig, (ax_t, ax_p) = plt.subplots(2, 1, figsize=(9, 7.5), constrained_layout=True)
    ax_t.plot(lam * ts, x * xs, lw=0.8, color="k", label="position")
    ax_p.plot(x * xs, v * u.velocity, lw=0.6, color="k", label="trajectory")
    draw_flanges(ax_t, sol.oscillator, scale=xs)
    draw_flanges(ax_p, sol.oscillator, axis="x", scale=xs, label=False)
    for kind in kinds:
        sel = ev[ev["kind"] == kind]
        if len(sel):
            marker, colour = EVENT_MARKERS[kind]
            ax_t.plot(sel["t"] * ts, sel["x"] * xs, marker, ms=4, color=colour, ls="none",
                      label=f"{kind} ({len(sel)})")
    ax_t.set_xlabel(t_label)
    ax_t.set_ylabel(x_label)
    ax_t.legend(loc="upper right", fontsize=8)
    ax_t.set_title(sol.summary().replace(": ", ":\n", 1), fontsize=8)
    ax_p.set_xlabel(x_label)
    ax_p.set_ylabel(v_label)
    ax_p.set_title("phase plane", fontsize=9)
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


class SolutionFramesMixin:
    """DataFrames, uniform resampling, plots and SI conversion as methods of a Solution.

    ``Solution`` inherits these; each method calls the free function of the same module.
    """

    def to_dataframe(self, table: str = "events", drive: TapeDrive | None = None) -> pd.DataFrame:
        """The ``"events"`` or ``"impacts"`` table as a DataFrame (:func:`to_dataframe`)."""
        return to_dataframe(self, table, drive)

    def resample(self, dt: float, drive: TapeDrive | None = None, *, t0: float | None = None,
                 t1: float | None = None, output: str = "xarray", max_samples: int | None = None):
        """The run on a uniform grid of step ``dt``, exactly (:func:`resample`)."""
        return resample(self, dt, drive, t0=t0, t1=t1, output=output, max_samples=max_samples)

    def plot(self, drive: TapeDrive | None = None, *, n_samples: int = 4000, kinds=EVENT_KINDS, path=None):
        """Time series with events by kind and the phase plane; returns the Figure (``plot_run``)."""
        return plot_run(self, drive, n_samples=n_samples, kinds=kinds, path=path)

    def to_si(self, drive: TapeDrive) -> SIResults:
        """Every result in SI units with the scales of ``drive`` (:func:`to_si`)."""
        return to_si(self, drive)
