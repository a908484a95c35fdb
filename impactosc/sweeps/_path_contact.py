"""Where contact starts on a tape path: a guide's critical clearance, its chart and its boundary in SI units.

A guide's **critical clearance** is the largest clearance at which the tape touches that
guide's flanges: the steady-state extreme lateral deflection at the guide with its flanges
taken away (every other guide keeps its flanges and friction), plus or minus the guide's
offset. It is measured by simulating the transient out on the exact n-DOF backend and
taking the extremes over whole turns of the reel (samples, polished, then checked by the
backend's certified guard search for a peak between the samples); without friction and contact the motion is
the linear chain's harmonic response, ``|H(i w) f|`` at the guide, and the measurement
reproduces it (tests check this closed form).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from .._util import validation as _v
from ..backends._exact_mdof import simulate_mechanical
from ..backends._simulate import DEFAULT_MAX_EVENTS
from ..model._mechanical import Contact, MechanicalSystem
from ..model._tape_path import TapePath
from ..model._tape_path_file import check_parameter, parameter_units
from ._path_grid import assemble_paths, plan_paths, run_paths
from ._point import STATUS_EXCEPTION

__all__ = ["steady_deflection", "critical_clearance", "critical_clearance_chart", "contact_boundary",
           "SETTLE_DECADES", "MAX_SETTLE_SECONDS"]

#: The transient is simulated out over the time its slowest mode takes to decay by
#: ``10**SETTLE_DECADES`` (modal damping: ``exp(-zeta w_min t)``), rounded up to whole reel turns.
SETTLE_DECADES = 14.0
#: Default limit in seconds of tape motion on the settle time: a lightly damped chain whose
#: transient outlasts it is refused by name rather than simulated for hours.
MAX_SETTLE_SECONDS = 2.0
#: Relative margin beyond a located extreme at which a probe contact checks for a higher peak
#: between the samples (see ``_unsampled_peaks``): a peak higher by more than this is found.
PROBE_MARGIN = 1e-9
#: Probe runs before the extremes are declared uncertain (each finds one higher peak).
MAX_PROBES = 8

CONTACT_RESULTS = {
    "critical_clearance": ("m", "critical clearance: the largest at which the tape touches the guide's flanges"),
    "critical_clearance_upper": ("m", "critical clearance of the upper flange (max deflection + offset)"),
    "critical_clearance_lower": ("m", "critical clearance of the lower flange (-min deflection - offset)"),
    "max_deflection": ("m", "steady-state maximum lateral deflection at the guide, its flanges taken away"),
    "min_deflection": ("m", "steady-state minimum lateral deflection at the guide, its flanges taken away"),
    "settle_time": ("s", "time simulated before the measured turns"),
}


def _settle_seconds(path: TapePath, max_settle: float) -> float:
    """Seconds for the slowest mode's transient to fall by ``10**SETTLE_DECADES``, in whole reel turns."""
    zeta = path.drive.damping_ratio
    if not zeta > 0.0:
        raise ValueError(f"path.drive.damping_ratio must be > 0 for a steady state (the transient of an undamped "
                         f"chain never dies out), got {zeta!r}")
    M, K = np.diag(path.mass_matrix), path.stiffness_matrix
    w_min = math.sqrt(max(float(np.linalg.eigvalsh(K / np.sqrt(np.outer(M, M)))[0]), 0.0))
    turn = 2.0 * math.pi / path.drive.omega_r
    seconds = math.ceil(SETTLE_DECADES * math.log(10.0) / (zeta * w_min) / turn) * turn
    if seconds > max_settle:
        raise ValueError(f"path.drive.damping_ratio = {zeta!r}: the transient takes {seconds:.4g} s of tape motion "
                         f"to die out, more than max_settle = {max_settle!r} s; raise the damping or max_settle")
    return seconds


def steady_deflection(path: TapePath, guide: int, *, phase: float = 0.0, turns: int = 1, samples: int = 512,
                      max_events: int = DEFAULT_MAX_EVENTS, max_settle: float = MAX_SETTLE_SECONDS
                      ) -> dict[str, Any]:
    """Steady-state extremes of the lateral deflection at a guide whose flanges are taken away (SI units).

    The path (every other guide with its flanges and friction) runs from rest for the settle
    time (the slowest mode's transient down by ``10**SETTLE_DECADES``, in whole turns of the
    reel), then ``turns`` whole turns are sampled at ``samples`` points per turn and every
    extreme is polished by a bounded scalar search on the closed form, then checked over the
    turns by the exact backend's certified guard search (two probe contacts just beyond the
    extremes: a contact start is a higher peak between the samples, polished and checked
    again), so a narrow peak (the tape ringing after another guide's contact) is not missed. A roller's run-out turns
    at its own frequency: the motion is then not periodic in the reel's turn, and the
    extremes of the measured turns approach the true ones as ``turns`` grows.

    Parameters
    ----------
    path : TapePath
        Needs ``drive.damping_ratio > 0`` (else no steady state).
    guide : int
        The guide (0 to ``path.n - 1``).
    phase : float
        The reel's angle at ``t = 0`` in radians.
    turns, samples : int
        Reel turns measured, samples per turn (>= 16).
    max_events : int
        Event limit of the run.
    max_settle : float
        Longest settle time in seconds of tape motion (> 0): a chain damped so lightly that
        its transient outlasts it raises a ``ValueError`` (naming ``damping_ratio``).

    Returns
    -------
    dict
        ``max``, ``min`` (m: the guide's coordinate, from the guide's axis, positive towards
        the upper flange), ``critical_clearance_upper`` (``max + offset``),
        ``critical_clearance_lower`` (``-min - offset``), ``critical_clearance`` (the larger
        of the flanges the guide has), ``settle_time`` (s), ``status`` (0: the run reached
        its end) and ``message``.
    """
    if not isinstance(path, TapePath):
        raise TypeError(f"path must be a TapePath, got {path!r} of type {type(path).__name__}")
    g = path.check_guide(guide)
    turns = _v.integer("turns", turns)
    samples = _v.integer("samples", samples, minimum=16)
    settle = _settle_seconds(path, _v.positive("max_settle", max_settle))
    turn = 2.0 * math.pi / path.drive.omega_r
    system = path.mechanical_system(phase, leave_out_flanges=(g,))
    t0, t1 = path.seconds_to_time(settle), path.seconds_to_time(settle + turns * turn)
    dt = (t1 - t0) / (turns * samples)
    # One sample step beyond the turns at both ends: an extreme at a turn's edge is polished across it.
    sol = simulate_mechanical(system, t1 + dt, np.zeros(path.n), np.zeros(path.n), max_events=max_events)
    out: dict[str, Any] = {"settle_time": settle, "status": int(sol.status), "message": str(sol.message)}
    if sol.status != 0:
        return out | dict.fromkeys(("max", "min", "critical_clearance", "critical_clearance_upper",
                                    "critical_clearance_lower"), math.nan)
    t = np.linspace(t0, t1, turns * samples + 1)
    extremes = [_peak(sol, g, 1.0, t), _peak(sol, g, -1.0, t)]
    status, message = _unsampled_peaks(system, sol, g, (t0, t1), extremes, max_events)
    if status != 0:
        return out | {"status": status, "message": message} | dict.fromkeys(
            ("max", "min", "critical_clearance", "critical_clearance_upper", "critical_clearance_lower"), math.nan)
    L = path.length_scale
    q_max, q_min = extremes[0] * L, extremes[1] * L
    gd = path.guide_drive(g)
    upper, lower = q_max + gd.guide_offset, -q_min - gd.guide_offset
    present = [c for c, side in ((upper, "upper"), (lower, "lower")) if gd.flange_sides in ("both", side)]
    return out | {"max": q_max, "min": q_min, "critical_clearance_upper": upper, "critical_clearance_lower": lower,
                  "critical_clearance": max(present)}


def _peak(sol, g: int, sign: float, t: np.ndarray) -> float:
    """The largest ``sign * q_g`` (times ``sign``) over the samples ``t``, polished by a bounded search
    around the largest sample (one sample spacing each way) on the closed form."""
    from scipy.optimize import minimize_scalar

    q = sol.sample(t)[0][:, g]
    k = int(np.argmax(sign * q))
    spacing = float(t[1] - t[0])
    res = minimize_scalar(lambda s: -sign * float(sol.sample([s])[0][0, g]), bounds=(t[k] - spacing, t[k] + spacing),
                          method="bounded", options={"xatol": 1e-10 * max(abs(float(t[-1])), 1.0)})
    return sign * max(sign * float(q[k]), -float(res.fun))


def _unsampled_peaks(system, sol, g: int, window: tuple[float, float], extremes: list, max_events: int
                     ) -> tuple[int, str]:
    """Raise ``extremes`` (``[max, min]`` of ``q_g`` over ``window``, from samples) to any peak between the samples.

    Sampling misses a peak narrower than its spacing (another guide's contact sets the tape
    ringing at a natural frequency far above the run-out's). The exact backend's guard search
    is certified (no crossing missed), so the flangeless system is run over the window again
    from its state at the window's start with two probe contacts on the guide just beyond the
    extremes (``PROBE_MARGIN`` relative): a contact start is a higher peak, polished where it
    happens, and the probes move out to it; none, and the extremes hold. The probes change
    nothing before their first contact, the only event read. Returns ``(status, message)``:
    non-zero when a probe run failed, or the peaks kept rising for ``MAX_PROBES`` runs.
    """
    t0, t1 = window
    q0, v0 = (a[0] for a in sol.sample([t0]))
    # the forcing from the window's start: cos(w (t0 + s) + phi)
    harmonics = [(f, w, phi + w * t0) for f, w, phi in system.harmonics]
    unit = np.eye(system.n)[g]
    base = len(system.contacts)
    for _ in range(MAX_PROBES):
        margin = PROBE_MARGIN * max(abs(extremes[0]), abs(extremes[1]), 1e-300)
        probes = [Contact(unit, extremes[0] + margin, law="spring", stiffness=1.0),
                  Contact(-unit, -extremes[1] + margin, law="spring", stiffness=1.0)]
        probe = MechanicalSystem(M=system.M, C=system.C, K=system.K, harmonics=harmonics,
                                 contacts=[*system.contacts, *probes], friction=system.friction)
        run = simulate_mechanical(probe, t1 - t0, q0, v0, max_events=max_events, energy=False)
        ev = run.events
        hit = np.flatnonzero((ev["kind"] == "contact_start") & (ev["index"] >= base))
        if hit.size == 0:
            return (0, "") if run.status == 0 else (int(run.status), f"the probe run failed: {run.message}")
        k = int(hit[0])
        side = 0 if int(ev["index"][k]) == base else 1
        sign = 1.0 if side == 0 else -1.0
        # the peak follows the crossing of the probe's level within the ringing's quarter period
        t_hit = t0 + float(ev["t"][k])
        near = np.linspace(t_hit, min(t_hit + (t1 - t0) / 64.0, t1), 257)
        extremes[side] = sign * max(sign * extremes[side], sign * _peak(sol, g, sign, near))
    return -1, (f"the deflection's peaks at guide {g} kept rising past {MAX_PROBES} probes of the exact guard search; "
                "the extremes are not certain")


def critical_clearance(path: TapePath, guide: int, **options) -> float:
    """The largest clearance in m at which the tape touches guide ``guide``'s flanges (steady state).

    :func:`steady_deflection`'s ``critical_clearance``; ``options`` are its keywords.

    Raises
    ------
    RuntimeError
        The run did not reach its end (its status and message).

    Examples
    --------
    >>> from impactosc import Guide, TapeDrive, TapePath
    >>> from impactosc.sweeps import critical_clearance
    >>> path = TapePath(TapeDrive(friction=0.0, damping_ratio=0.05),
    ...                 [Guide(0.02, clearance=300e-6), Guide(0.05, clearance=30e-6)], end_span=0.03)
    >>> c = critical_clearance(path, 1)              # m
    >>> bool(1e-6 < c < path.drive.runout)
    True
    """
    res = steady_deflection(path, guide, **options)
    if res["status"] != 0:
        raise RuntimeError(f"critical_clearance: the run ended with status {res['status']}: {res['message']}")
    return float(res["critical_clearance"])


def _contact_failure(status: int, message: str) -> dict:
    out: dict[str, Any] = dict.fromkeys(CONTACT_RESULTS, math.nan)
    return out | {"status": status, "message": message}


def _chart_point(fields: dict, guide: int, options: dict) -> dict:
    """One point of :func:`critical_clearance_chart`; never raises."""
    try:
        res = steady_deflection(TapePath.from_dict(fields), guide, **options)
    except Exception as exc:  # noqa: BLE001 - a point's failure is recorded, not raised
        return _contact_failure(STATUS_EXCEPTION, f"{type(exc).__name__}: {exc}")
    return _contact_failure(res["status"], res["message"]) | {
        k: res[k] for k in ("critical_clearance", "critical_clearance_upper", "critical_clearance_lower",
                            "settle_time")} | {"max_deflection": res["max"], "min_deflection": res["min"]}


def _options(phase, turns, samples, max_events) -> dict:
    return {"phase": _v.real("phase", phase), "turns": _v.integer("turns", turns),
            "samples": _v.integer("samples", samples, minimum=16), "max_events": _v.integer("max_events", max_events)}


def critical_clearance_chart(path: TapePath, guide: int, grid: Mapping, *, phase: float = 0.0, turns: int = 1,
                             samples: int = 512, max_events: int = DEFAULT_MAX_EVENTS, executor=None,
                             progress: bool = True) -> xr.Dataset:
    """A guide's critical clearance over a grid of path parameters (e.g. speed x tension), in SI units.

    Every point is :func:`steady_deflection` of ``path.with_parameter(...)`` at ``guide``, run
    on the runner of :func:`sweep_path` (``executor``, ``progress`` as there). Contact starts
    at a point when the guide's clearance falls below ``critical_clearance`` there: the
    chart's contour at a clearance is that clearance's contact boundary
    (:func:`contact_boundary` finds it by a root search).

    Parameters
    ----------
    path : TapePath
    guide : int
    grid : dict
        ``{parameter: values}`` as in :func:`sweep_path` (``"speed"``, ``"tension"``,
        ``"pack_diameter"``, ``"guide<i>_<field>"``...).
    phase, turns, samples, max_events
        As in :func:`steady_deflection`.

    Returns
    -------
    xarray.Dataset
        A dimension per grid key; ``critical_clearance``, ``critical_clearance_upper``,
        ``critical_clearance_lower``, ``max_deflection``, ``min_deflection`` (m),
        ``settle_time`` (s), ``status``, ``message``; ``attrs``: ``guide``, the options.

    Examples
    --------
    >>> from impactosc import Guide, TapeDrive, TapePath
    >>> from impactosc.sweeps import critical_clearance_chart
    >>> path = TapePath(TapeDrive(friction=0.0, damping_ratio=0.05),
    ...                 [Guide(0.02, clearance=300e-6), Guide(0.05, clearance=30e-6)], end_span=0.03)
    >>> ds = critical_clearance_chart(path, 1, {"speed": [2.0, 8.0], "tension": [0.5, 1.0]},
    ...                               executor="serial", progress=False, samples=64)
    >>> ds.critical_clearance.dims, ds.critical_clearance.attrs["units"]
    (('speed', 'tension'), 'm')
    """
    opts = _options(phase, turns, samples, max_events)
    if not isinstance(path, TapePath):
        raise TypeError(f"path must be a TapePath, got {path!r} of type {type(path).__name__}")
    g = path.check_guide(guide)
    settings = json.loads(json.dumps({"guide": g, **opts}, sort_keys=True))
    plan = plan_paths(path, grid, settings)
    results = run_paths(plan, _chart_point, (g, opts), _contact_failure, kind="critical clearance chart",
                        executor=executor, progress=progress)
    return assemble_paths(plan, results, {}, CONTACT_RESULTS, {"guide": g, **opts})


BOUNDARY_RESULTS = {"iterations": ("1", "steady-state runs of the root search")}


def _boundary_point(fields: dict, guide: int, vary: str, bracket: tuple, clearance: float, xtol: float,
                    options: dict) -> dict:
    """One point of :func:`contact_boundary`: the root in ``vary`` of ``critical clearance - clearance``."""
    from scipy.optimize import brentq

    out: dict[str, Any] = {"boundary": math.nan, "iterations": math.nan}
    base = TapePath.from_dict(fields)
    calls = []

    def excess(value: float) -> float:
        res = steady_deflection(base.with_parameter(vary, value), guide, **options)
        calls.append(value)
        if res["status"] != 0:
            raise RuntimeError(f"at {vary} = {value!r}: status {res['status']}, {res['message']}")
        return float(res["critical_clearance"]) - clearance

    try:
        lo, hi = excess(bracket[0]), excess(bracket[1])
        if lo * hi > 0.0:
            return out | {"iterations": float(len(calls)), "status": STATUS_EXCEPTION,
                          "message": f"no contact boundary in {vary} in [{bracket[0]!r}, {bracket[1]!r}]: critical "
                                     f"clearance minus clearance is {lo!r} m and {hi!r} m at its ends (same sign)"}
        root = brentq(excess, bracket[0], bracket[1], xtol=xtol, rtol=4 * np.finfo(float).eps)
    except Exception as exc:  # noqa: BLE001 - a point's failure is recorded, not raised
        return out | {"iterations": float(len(calls)), "status": STATUS_EXCEPTION,
                      "message": f"{type(exc).__name__}: {exc}"}
    return out | {"boundary": float(root), "iterations": float(len(calls)), "status": 0, "message": ""}


def contact_boundary(path: TapePath, guide: int, vary: str, bracket, along: Mapping | None = None, *,
                     clearance: float | None = None, xtol: float | None = None, phase: float = 0.0, turns: int = 1,
                     samples: int = 512, max_events: int = DEFAULT_MAX_EVENTS, executor=None,
                     progress: bool = True) -> xr.Dataset:
    """Where contact starts at a guide: the value of ``vary`` at which its critical clearance equals its clearance.

    For every point of ``along`` (a grid of other path parameters), a bracketed root search
    (Brent's method) in ``vary`` over ``bracket`` of ``critical_clearance - clearance``, each
    evaluation a :func:`steady_deflection` run. With the chart's two parameters this is the
    contour of :func:`critical_clearance_chart` at ``clearance``, found to ``xtol`` instead of
    read off a grid.

    Parameters
    ----------
    path : TapePath
    guide : int
    vary : str
        The parameter solved for (a name of :meth:`~impactosc.TapePath.with_parameter`).
    bracket : (float, float)
        Its search interval; the sign of ``critical_clearance - clearance`` must differ at the
        ends (else that point's status is -2 with both values in its message).
    along : dict or None
        ``{parameter: values}`` of the other parameters (:func:`sweep_path`'s grid).
    clearance : float or None
        The clearance in m (default: the guide's in ``path``).
    xtol : float or None
        Absolute tolerance on the root (default ``1e-9 * |bracket|``).
    phase, turns, samples, max_events, executor, progress
        As in :func:`critical_clearance_chart`.

    Returns
    -------
    xarray.Dataset
        A dimension per key of ``along``; ``boundary`` (the root, in ``vary``'s units),
        ``iterations``, ``status``, ``message``; ``attrs``: ``guide``, ``vary``, ``clearance``.

    Examples
    --------
    >>> from impactosc import Guide, TapeDrive, TapePath
    >>> from impactosc.sweeps import contact_boundary
    >>> path = TapePath(TapeDrive(friction=0.0, damping_ratio=0.05),
    ...                 [Guide(0.02, clearance=300e-6), Guide(0.05, clearance=30e-6)], end_span=0.03)
    >>> ds = contact_boundary(path, 1, "pack_diameter", (0.045, 0.095), {"speed": [4.0]},
    ...                       executor="serial", progress=False, samples=64)
    >>> ds.boundary.attrs["units"], int(ds.status.sel(speed=4.0))
    ('m', 0)
    """
    opts = _options(phase, turns, samples, max_events)
    if not isinstance(path, TapePath):
        raise TypeError(f"path must be a TapePath, got {path!r} of type {type(path).__name__}")
    g = path.check_guide(guide)
    check_parameter(vary, path.n)
    if along and vary in along:
        raise ValueError(f"vary {vary!r} is also a key of along: the root search sets it")
    if isinstance(bracket, str | bytes) or np.ndim(bracket) != 1 or len(bracket) != 2:
        raise ValueError(f"bracket must be two numbers (lo, hi), got {bracket!r}")
    lo, hi = (_v.real(f"bracket[{i}]", b) for i, b in enumerate(bracket))
    if not lo < hi:
        raise ValueError(f"bracket must have lo < hi, got {bracket!r}")
    c = path.guide_drive(g).clearance if clearance is None else _v.positive("clearance", clearance)
    tol = 1e-9 * (hi - lo) if xtol is None else _v.positive("xtol", xtol)
    settings = json.loads(json.dumps({"guide": g, "vary": vary, "bracket": [lo, hi], "clearance": c, "xtol": tol,
                                      **opts}, sort_keys=True))
    plan = plan_paths(path, along, settings)
    results = run_paths(plan, _boundary_point, (g, vary, (lo, hi), c, tol, opts),
                        lambda status, message: {"boundary": math.nan, "iterations": math.nan, "status": status,
                                                 "message": message},
                        kind="contact boundary", executor=executor, progress=progress, batch=False)
    units, name = parameter_units(vary)
    ds = assemble_paths(plan, results, {}, {"boundary": (units, f"contact boundary: {name}"), **BOUNDARY_RESULTS},
                        {"guide": g, "vary": vary, "clearance": c, "clearance_units": "m", "bracket": [lo, hi],
                         "xtol": tol, **opts})
    return ds
