"""A tape path's critical clearance at a guide, continued as a grazing boundary in SI parameters.

The critical clearance of a guide (:func:`impactosc.sweeps.critical_clearance`) is the
clearance at which the steady motion of the path, with that guide's flanges taken away, just
touches a flange: the grazing of the flange's guard. Here it is a curve followed by
continuation instead of measured point by point: the path's mechanical system with the
guide's flanges left out, written as a user system (:func:`~impactosc.model.hybrid.mechanical_system`),
gets the flange as a guard ``q_g - gap`` (``-q_g - gap`` below) whose gap is a parameter,
and the grazing boundary of that guard (:mod:`._boundary`: the guard's value at its extremum
on the orbits without it vanishes) is followed in ``(gap, omega)`` or ``(gap, run-out scale)``,
then read in SI units: ``clearance = gap L + offset`` (``gap L - offset`` below),
``speed = omega omega_n D / 2``, ``runout = scale runout_0``.
Every point is a periodic orbit that grazes the flange, corrected to the Newton tolerance.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np

from ..._util import validation as _v
from ...backends._exact_mdof import simulate_mechanical
from ...backends._hybrid import simulate_system
from ...model._tape_path import TapePath
from ...model.hybrid._definition import Guard, HybridMode, HybridSystem, symbols
from ...model.hybrid._mechanical_system import mechanical_system
from ..hybrid_map import HybridMap, periodic_orbit_of
from ._arclength import Settings
from ._boundary import follow_curve, guard_test
from ._guard_crossing import GuardlessProblem
from ._hybrid_problem import SystemProblem
from ._points import GUARD

__all__ = ["critical_clearance_boundary", "PATH_BOUNDARY_PARAMETERS"]

#: The path parameters a critical-clearance boundary is followed against (the first is always the clearance),
#: each with its parameter of the path's user system and what turns the SI value into it.
PATH_BOUNDARY_PARAMETERS = ("speed", "runout")
#: Forcing periods simulated from rest before Newton's method looks for the steady orbit.
SETTLE_PERIODS = 30


def _flange_system(path: TapePath, g: int, flange: str, phase: float) -> HybridSystem:
    """The path without guide ``g``'s flanges, with the flange of ``flange`` back as a guard (its gap a parameter).

    The pack's run-out harmonics (``cos(omega_h t + phase_h)`` of :func:`mechanical_system`, the
    first ``1 + len(runout_harmonics)``) are multiplied by the parameter ``runout_scale`` (1: the
    path's run-out), wherever they appear: the vector fields, a stick test's entry conditions,
    a release guard.
    """
    import heyoka as hy

    base = mechanical_system(path.mechanical_system(phase, leave_out_flanges=(g,)), energy=False)
    n = base.dimension
    scale = symbols("runout_scale")
    pack = {}
    for h in range(1 + len(path.drive.runout_harmonics)):
        wave = hy.cos(symbols(f"omega{h}") * hy.time + symbols(f"phase{h}"))
        pack[wave] = scale * wave

    def scaled(e):
        return hy.subs(e, pack)

    q = symbols(f"q{g}")
    sign = 1.0 if flange == "upper" else -1.0
    witness = Guard(f"guide {g} {flange} flange", sign * q - symbols("gap"), 1, armed=base.mode_names,
                    terminal=False)
    modes = [HybridMode(m.name, tuple(scaled(f) for f in m.field[:n]), entry=tuple(scaled(c) for c in m.entry),
                        integrands=dict(m.integrands)) for m in base.modes]
    guards = [dataclasses.replace(gd, expression=scaled(gd.expression)) for gd in base.guards]
    return HybridSystem(base.states, {**dict(base.parameters), "runout_scale": 1.0, "gap": 0.0}, modes,
                        guards + [witness], integrals=base.integrals, period=base.period,
                        name=f"tape path, guide {g} {flange} flange")


def _check(path, guide, parameters, limits, flange) -> tuple:
    if not isinstance(path, TapePath):
        raise TypeError(f"path must be a TapePath, got {path!r} of type {type(path).__name__}")
    g = path.check_guide(guide)
    if isinstance(parameters, str) or len(tuple(parameters)) != 2 or tuple(parameters)[0] != "clearance" \
            or tuple(parameters)[1] not in PATH_BOUNDARY_PARAMETERS:
        raise ValueError(f"parameters must be ('clearance', p) with p one of {PATH_BOUNDARY_PARAMETERS} (the "
                         f"path's parameters its user system carries: not the tension, which changes every matrix), "
                         f"got {parameters!r}")
    other = tuple(parameters)[1]
    d = path.drive
    if other == "speed" and (d.runout_harmonics or any(gd.roller_runout != 0.0 for gd in path.guides)):
        raise ValueError("path: the speed moves every forcing frequency together, and the path's run-out has more "
                         "than one (runout_harmonics or a roller's run-out); a boundary in speed is followed for the "
                         "pack's run-out alone")
    if other == "runout" and d.runout == 0.0:
        raise ValueError("path.drive.runout is 0: a boundary in the run-out is started from the path's run-out")
    if not isinstance(limits, dict) or not limits or set(limits) - {"clearance", other}:
        raise ValueError(f"limits must be a dict of 'clearance' and/or {other!r}: (lo, hi) in SI units, got "
                         f"{limits!r}")
    sides = path.guide_drive(g).flange_sides
    if flange not in ("auto", "upper", "lower"):
        raise ValueError(f"flange must be 'auto', 'upper' or 'lower', got {flange!r}")
    if flange != "auto" and sides not in ("both", flange):
        raise ValueError(f"flange={flange!r}: guide {g} has flange_sides={sides!r}")
    return g, sides, other


def critical_clearance_boundary(path: TapePath, guide: int, parameters=("clearance", "speed"), limits=None, *,
                                flange: str = "auto", phase: float = 0.0, step: float = 0.05,
                                max_step: float = 0.2, max_points: int = 200, tol: float = 1e-10):
    """A guide's critical clearance as a curve against the tape speed or the run-out, by continuation (SI units).

    The curve is the grazing boundary of the guide's flange: at each speed (or run-out), the
    clearance at which the steady motion of the path with that guide's flanges taken away
    (every other guide keeps its flanges and friction) just touches the flange; a smaller
    clearance is contact (:func:`impactosc.sweeps.critical_clearance` measures the same point
    by point). It is started from the steady periodic orbit at the path's parameters, made to
    graze by setting the gap to its extreme deflection, and followed both ways as the boundary
    of that grazing in ``(gap, p)`` (the follow loop of every boundary, the built-in family's
    and a user system's).

    The extreme deflection is located exactly along the orbit (the extrema of the guard's value
    are events of the Taylor integrator), as :func:`~impactosc.sweeps.critical_clearance`
    locates it by samples checked with the exact backend's certified guard search (a peak
    between the samples, where another guide's contact sets the tape ringing, is found).
    Such a path is nonlinear, and a map period takes many
    events: each point then costs far more than a measurement (11 points in about 200 s,
    against about a second for the linear path). The curve is that of the periodic orbit it
    starts from (the one a run from rest settles near).

    Parameters
    ----------
    path : TapePath
        ``damping_ratio > 0`` (a steady orbit). Against the speed, the pack's run-out must be
        the only forcing (no ``runout_harmonics`` or roller run-out: the speed would move
        their frequencies too).
    guide : int
        The guide (0 to ``path.n - 1``).
    parameters : (str, str)
        ``("clearance", "speed")`` (m/s) or ``("clearance", "runout")`` (m: the pack's run-out,
        its harmonics scaled with it). The tension is not one: it changes every matrix of the
        path, which its user system holds as numbers.
    limits : dict
        ``{p: (lo, hi)}`` and/or ``{"clearance": (lo, hi)}`` in SI units: the curve ends where it
        reaches one.
    flange : {"auto", "upper", "lower"}
        The flange whose grazing is followed; ``"auto"``: the one the tape reaches first at the
        start (the larger critical clearance, as :func:`~impactosc.sweeps.critical_clearance`).
    phase : float
        The reel's angle at ``t = 0`` (rad).
    step, max_step, max_points, tol
        Continuation's arclength steps (scaled units), points per direction and Newton tolerance.

    Returns
    -------
    xarray.Dataset
        Dimension ``point`` (in arclength order): ``clearance`` (m), the other parameter (SI),
        the grazing ``orbit``'s state on the section (nondimensional, dimension ``state``);
        ``attrs``: ``guide``, ``flange``, ``status`` (0: both ends reached a limit; else
        :class:`~impactosc.dynamics.continuation.Branch`'s status), ``message`` (in SI units).

    Raises
    ------
    TypeError, ValueError
        For a bad path, guide, parameter, limit or flange, naming it; RuntimeError when no
        steady orbit is found at the start.

    Examples
    --------
    >>> from impactosc import Guide, TapeDrive, TapePath
    >>> from impactosc.dynamics.continuation import critical_clearance_boundary
    >>> path = TapePath(TapeDrive(friction=0.0, damping_ratio=0.05),
    ...                 [Guide(0.02, clearance=300e-6), Guide(0.05, clearance=30e-6)], end_span=0.03)
    >>> ds = critical_clearance_boundary(path, 1, ("clearance", "speed"), {"speed": (3.0, 5.0)})
    >>> ds.attrs["status"], ds.clearance.attrs["units"], float(ds.speed.min()), float(ds.speed.max())
    (0, 'm', 3.0, 5.0)
    """
    import xarray as xr

    g, sides, other = _check(path, guide, parameters, limits, flange)
    phase = _v.real("phase", phase)
    settings = Settings(_v.positive("step", step), 1e-7, _v.positive("max_step", max_step),
                        _v.integer("max_points", max_points, minimum=1), _v.positive("tol", tol), 8, frozenset(),
                        1e-12)
    L = path.length_scale
    offset = path.guide_drive(g).guide_offset
    # the other parameter of the user system and its value per SI unit: the reel turns at omega_r = 2 V / D
    # (eq. 1), nondimensional over omega_scale; the run-out multiplies the pack's harmonics
    name, per_si, unit = (("omega0", path.drive.omega_r / path.drive.speed / path.omega_scale, "m/s")
                          if other == "speed" else ("runout_scale", 1.0 / path.drive.runout, "m"))
    flanges = [f for f in ("upper", "lower") if sides in ("both", f)] if flange == "auto" else [flange]
    starts = _grazing_starts(path, g, flanges, phase)
    f_side, system, z0, gap = max(starts, key=lambda s: s[3] * L + (offset if s[0] == "upper" else -offset))
    sign = 1.0 if f_side == "upper" else -1.0
    system = system.with_parameters(gap=gap)
    value = dict(system.parameters)[name]
    bounds = []
    for key, to_nd, here in (("clearance", lambda c: (c - sign * offset) / L, gap),
                             (other, lambda x: x * per_si, value)):
        lo, hi = -math.inf, math.inf
        if key in limits:
            lo, hi = (_v.real(f"limits[{key!r}][{i}]", x) for i, x in enumerate(limits[key]))
            if not lo < hi:
                raise ValueError(f"limits[{key!r}] must have lo < hi, got {limits[key]!r}")
            lo, hi = to_nd(lo), to_nd(hi)
            if not lo <= here <= hi:
                raise ValueError(f"the start's {key} lies outside limits[{key!r}]: the path's critical clearance and "
                                 f"{other} must lie within them")
        bounds.append((lo, hi))
    span = bounds[1][1] - bounds[1][0]
    scales = (max(abs(gap), 1e-3), max(abs(value), span if math.isfinite(span) else 0.0, 1e-12))
    real = SystemProblem(HybridMap(system, names=("gap", name)), scales)
    curve = GuardlessProblem(real, system.guards[-1].name)
    branch = follow_curve(curve, z0, "grazing", GUARD + curve.guard.name, guard_test(curve), bounds, settings, 0,
                          ("gap", name))
    gaps = np.array([p.parameters["gap"] for p in branch.points])
    values = np.array([p.parameters[name] for p in branch.points])
    states = np.array([p.state for p in branch.points]).reshape(len(branch.points), system.dimension)
    long_name = "tape speed" if other == "speed" else "pack run-out"
    return xr.Dataset(
        {"clearance": ("point", gaps * L + sign * offset, {"units": "m", "long_name": f"critical clearance of guide "
                                                                                      f"{g}'s {f_side} flange"}),
         other: ("point", values / per_si, {"units": unit, "long_name": long_name}),
         "orbit": (("point", "state"), states, {"long_name": "grazing orbit on the section (nondimensional)"})},
        coords={"state": list(system.states)},
        attrs={"guide": g, "flange": f_side, "status": int(branch.status),
               "message": _in_si(branch.message, name, L, sign * offset, other, per_si, unit)})


def _in_si(message: str, name: str, L: float, offset: float, other: str, per_si: float, unit: str) -> str:
    """The branch's message with its nondimensional parameters (``gap`` and ``name``) in SI units."""
    def clearance(match):
        return f"clearance = {float(match.group(1)) * L + offset!r} m"

    def value(match):
        return f"{other} = {float(match.group(1)) / per_si!r} {unit}"

    number = r"([-+0-9.eE]+(?:e[-+]?[0-9]+)?)"
    return re.sub(rf"\b{name} = " + number, value, re.sub(r"\bgap = " + number, clearance, message))


def _grazing_starts(path: TapePath, g: int, flanges, phase: float) -> list:
    """``(flange, system, z, gap)`` per flange: the steady orbit at the path's parameters, and the gap it grazes at.

    The orbit is the same for every flange (the path without the guide's flanges): settled from
    rest on the exact n-DOF backend (the heyoka loop where that refuses the path), then solved
    by Newton's method on the map.
    """
    systems = [_flange_system(path, g, flange, phase) for flange in flanges]
    frees = [GuardlessProblem(SystemProblem(HybridMap(s, names=("gap",))), s.guards[-1].name) for s in systems]
    free = frees[0]
    n = systems[0].dimension
    T = free.hmap.period()
    try:
        settled = simulate_mechanical(path.mechanical_system(phase, leave_out_flanges=(g,)), SETTLE_PERIODS * T,
                                      np.zeros(n // 2), np.zeros(n // 2))
        status, message = settled.status, settled.message
        q, v = settled.sample([SETTLE_PERIODS * T])[:2]
        state = np.concatenate([q[0], v[0]])
    except ValueError:
        run = simulate_system(free.hmap.system, SETTLE_PERIODS * T, [0.0] * n)
        status, message, state = run.status, run.message, run.state_final[:n]
    if status != 0:
        raise RuntimeError(f"critical_clearance_boundary: the settling run from rest failed: {message}")
    orbit = periodic_orbit_of(free.hmap, state)
    if orbit.status != 0:
        raise RuntimeError(f"critical_clearance_boundary: no steady orbit of the path at its parameters (status "
                           f"{orbit.status}): {orbit.message}")
    out = []
    for flange, system, virtual in zip(flanges, systems, frees, strict=True):
        peak = virtual.peak(orbit.z, (0.0,))
        if isinstance(peak, str):
            raise RuntimeError(f"critical_clearance_boundary: the steady orbit's extreme at guide {g}: {peak}")
        out.append((flange, system, np.asarray(orbit.z, float), -float(peak[0])))  # psi = gap - sign q there
    return out
