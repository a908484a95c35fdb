"""A tape path's critical clearance at a guide, continued as a grazing boundary in SI parameters.

The critical clearance of a guide (:func:`impactosc.sweeps.critical_clearance`) is the
clearance at which the steady motion of the path, with that guide's flanges taken away, just
touches a flange: the grazing of the flange's guard. Here it is a curve followed by
continuation instead of measured point by point: the path's mechanical system with the
guide's flanges left out, written as a user system (:func:`~impactosc.model.hybrid.mechanical_system`),
gets the flange as a guard ``q_g - gap`` (``-q_g - gap`` below) whose gap is a parameter,
and the grazing boundary of that guard (:mod:`._boundary`: the guard's value at its extremum
on the orbits without it vanishes) is followed in ``(gap, omega)``, then read in SI units:
``clearance = gap L + offset`` (``gap L - offset`` below) and ``speed = omega omega_n D / 2``.
Every point is a periodic orbit that grazes the flange, corrected to the Newton tolerance.
"""

from __future__ import annotations

import math
import re

import numpy as np

from ..._util import validation as _v
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

#: The path parameters a critical-clearance boundary is followed in (the first is always the clearance).
PATH_BOUNDARY_PARAMETERS = ("clearance", "speed")
#: Forcing periods simulated from rest before Newton's method looks for the steady orbit.
SETTLE_PERIODS = 30


def _flange_system(path: TapePath, g: int, flange: str, phase: float) -> HybridSystem:
    """The path without guide ``g``'s flanges, with the flange of ``flange`` back as a guard (its gap a parameter)."""
    base = mechanical_system(path.mechanical_system(phase, leave_out_flanges=(g,)), energy=False)
    n = base.dimension
    q = symbols(f"q{g}")
    sign = 1.0 if flange == "upper" else -1.0
    witness = Guard(f"guide {g} {flange} flange", sign * q - symbols("gap"), 1, armed=base.mode_names,
                    terminal=False)
    modes = [HybridMode(m.name, tuple(m.field[:n]), entry=m.entry, integrands=dict(m.integrands))
             for m in base.modes]
    return HybridSystem(base.states, {**dict(base.parameters), "gap": 0.0}, modes, list(base.guards) + [witness],
                        integrals=base.integrals, period=base.period, name=f"tape path, guide {g} {flange} flange")


def _check(path, guide, parameters, limits, flange) -> tuple:
    if not isinstance(path, TapePath):
        raise TypeError(f"path must be a TapePath, got {path!r} of type {type(path).__name__}")
    g = path.check_guide(guide)
    if tuple(parameters) != PATH_BOUNDARY_PARAMETERS:
        raise ValueError(f"parameters must be {PATH_BOUNDARY_PARAMETERS} (the clearance against the tape speed: "
                         f"the parameters the path's user system carries), got {parameters!r}")
    d = path.drive
    if d.runout_harmonics or any(gd.roller_runout != 0.0 for gd in path.guides):
        raise ValueError("path: the speed moves every forcing frequency together, and the path's run-out has more "
                         "than one (runout_harmonics or a roller's run-out); a boundary in speed is followed for the "
                         "pack's run-out alone")
    if not isinstance(limits, dict) or not limits or set(limits) - set(PATH_BOUNDARY_PARAMETERS):
        raise ValueError(f"limits must be a dict of 'clearance' and/or 'speed': (lo, hi) in SI units, got {limits!r}")
    sides = path.guide_drive(g).flange_sides
    if flange not in ("auto", "upper", "lower"):
        raise ValueError(f"flange must be 'auto', 'upper' or 'lower', got {flange!r}")
    if flange != "auto" and sides not in ("both", flange):
        raise ValueError(f"flange={flange!r}: guide {g} has flange_sides={sides!r}")
    return g, sides


def critical_clearance_boundary(path: TapePath, guide: int, parameters=PATH_BOUNDARY_PARAMETERS, limits=None, *,
                                flange: str = "auto", phase: float = 0.0, step: float = 0.05,
                                max_step: float = 0.2, max_points: int = 200, tol: float = 1e-10):
    """A guide's critical clearance as a curve against the tape speed, followed by continuation (SI units).

    The curve is the grazing boundary of the guide's flange: at each speed, the clearance at
    which the steady motion of the path with that guide's flanges taken away (every other
    guide keeps its flanges and friction) just touches the flange; a smaller clearance is
    contact (:func:`impactosc.sweeps.critical_clearance` measures the same point by point).
    It is started from the steady periodic orbit at the path's speed, made to graze by
    setting the gap to its extreme deflection, and followed in both directions as the
    boundary of that grazing in ``(gap, forcing frequency)`` (the built-in family's and a user
    system's boundaries use the same follow loop).

    Parameters
    ----------
    path : TapePath
        Its drive's run-out the only forcing (no ``runout_harmonics`` or roller run-out: the
        speed would move their frequencies too), ``damping_ratio > 0`` (a steady orbit).
    guide : int
        The guide (0 to ``path.n - 1``).
    parameters : (str, str)
        ``("clearance", "speed")``.
    limits : dict
        ``{"speed": (lo, hi)}`` in m/s and/or ``{"clearance": (lo, hi)}`` in m: the curve ends
        where it reaches one.
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
        Dimension ``point`` (in arclength order): ``clearance`` (m), ``speed`` (m/s), the
        grazing ``orbit``'s state on the section (nondimensional, dimension ``state``);
        ``attrs``: ``guide``, ``flange``, ``status`` (0: both ends reached a limit; else
        :class:`~impactosc.dynamics.continuation.Branch`'s status), ``message``.

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
    >>> ds = critical_clearance_boundary(path, 1, limits={"speed": (3.0, 5.0)})
    >>> ds.attrs["status"], ds.clearance.attrs["units"], float(ds.speed.min()), float(ds.speed.max())
    (0, 'm', 3.0, 5.0)
    """
    import xarray as xr

    g, sides = _check(path, guide, parameters, limits, flange)
    phase = _v.real("phase", phase)
    settings = Settings(_v.positive("step", step), 1e-7, _v.positive("max_step", max_step),
                        _v.integer("max_points", max_points, minimum=1), _v.positive("tol", tol), 8, frozenset(),
                        1e-12)
    L = path.length_scale
    offset = path.guide_drive(g).guide_offset
    # omega = speed * to_omega: the reel turns at omega_r = 2 V / D (eq. 1), nondimensional over omega_scale
    to_omega = path.drive.omega_r / path.drive.speed / path.omega_scale
    flanges = [f for f in ("upper", "lower") if sides in ("both", f)] if flange == "auto" else [flange]
    starts = [_grazing_start(path, g, f, phase) for f in flanges]
    f_side, system, z0, gap = max(starts, key=lambda s: s[3] * L + (offset if s[0] == "upper" else -offset))
    sign = 1.0 if f_side == "upper" else -1.0
    system = system.with_parameters(gap=gap)
    bounds = []
    for name, to_nd in (("clearance", lambda c: (c - sign * offset) / L), ("speed", lambda v: v * to_omega)):
        if name in limits:
            lo, hi = (_v.real(f"limits[{name!r}][{i}]", x) for i, x in enumerate(limits[name]))
            if not lo < hi:
                raise ValueError(f"limits[{name!r}] must have lo < hi, got {limits[name]!r}")
            bounds.append((to_nd(lo), to_nd(hi)))
        else:
            bounds.append((-math.inf, math.inf))
    omega = system.parameters[system.parameter_names.index("omega0")][1]
    for name, value, (lo, hi) in (("clearance", gap, bounds[0]), ("speed", omega, bounds[1])):
        if not lo <= value <= hi:
            raise ValueError(f"the start's {name} lies outside limits[{name!r}]: the path's critical clearance and "
                             "speed must lie within them")
    scales = (max(abs(gap), 1e-3), max(abs(omega), *(hi - lo for lo, hi in bounds[1:] if math.isfinite(hi - lo))))
    real = SystemProblem(HybridMap(system, names=("gap", "omega0")), scales)
    curve = GuardlessProblem(real, system.guards[-1].name)
    branch = follow_curve(curve, z0, "grazing", GUARD + curve.guard.name, guard_test(curve), bounds, settings, 0,
                          ("gap", "omega0"))
    gaps = np.array([p.parameters["gap"] for p in branch.points])
    omegas = np.array([p.parameters["omega0"] for p in branch.points])
    states = np.array([p.state for p in branch.points]).reshape(len(branch.points), system.dimension)
    return xr.Dataset(
        {"clearance": ("point", gaps * L + sign * offset, {"units": "m", "long_name": f"critical clearance of guide "
                                                                                      f"{g}'s {f_side} flange"}),
         "speed": ("point", omegas / to_omega, {"units": "m/s", "long_name": "tape speed"}),
         "orbit": (("point", "state"), states, {"long_name": "grazing orbit on the section (nondimensional)"})},
        coords={"state": list(system.states)},
        attrs={"guide": g, "flange": f_side, "status": int(branch.status),
               "message": _in_si(branch.message, L, sign * offset, to_omega)})


def _in_si(message: str, L: float, offset: float, to_omega: float) -> str:
    """The branch's message with its nondimensional parameters (``gap``, ``omega0``) in SI units."""
    def clearance(match):
        return f"clearance = {float(match.group(1)) * L + offset!r} m"

    def speed(match):
        return f"speed = {float(match.group(1)) / to_omega!r} m/s"

    number = r"([-+0-9.eE]+(?:e[-+]?[0-9]+)?)"
    return re.sub(r"omega0 = " + number, speed, re.sub(r"\bgap = " + number, clearance, message))


def _grazing_start(path: TapePath, g: int, flange: str, phase: float):
    """``(flange, system, z, gap)``: the steady orbit at the path's parameters and the gap at which it grazes."""
    system = _flange_system(path, g, flange, phase)
    hmap = HybridMap(system)
    T = hmap.period()
    free = GuardlessProblem(SystemProblem(hmap.with_names(("gap",))), system.guards[-1].name)
    sol = simulate_system(free.hmap.system, SETTLE_PERIODS * T, [0.0] * system.dimension)
    if sol.status != 0:
        raise RuntimeError(f"critical_clearance_boundary: the settling run from rest failed: {sol.message}")
    orbit = periodic_orbit_of(free.hmap, sol.state_final[:system.dimension])
    if orbit.status != 0:
        raise RuntimeError(f"critical_clearance_boundary: no steady orbit of the path at its speed (status "
                           f"{orbit.status}): {orbit.message}")
    peak = free.peak(orbit.z, (0.0,))
    if isinstance(peak, str):
        raise RuntimeError(f"critical_clearance_boundary: the steady orbit's extreme at guide {g}: {peak}")
    return flange, system, np.asarray(orbit.z, float), -float(peak[0])  # psi = gap - sign q at the extreme
