"""A located special point followed in two parameters: the boundary a design chart draws.

The unknowns are ``(X, V, p1, p2)``; the equations ``P^n(z; p) - z = 0`` and the point's
defining test function ``psi(z, p) = 0`` (:mod:`._points`), with a pseudo-arclength
constraint: a curve in the ``(p1, p2)`` plane. A grazing's test is the distance
``gap - max X`` (``gap + min X``) of the contact-free orbit from the flange, on the orbits
of the model with that flange taken away (:meth:`MapProblem.virtual`): they are smooth
through the grazing, for a rigid flange too, where the real orbit's map has a square-root
term and every impacting orbit has ``max X = gap``. Its gradient is exact, read off the
Jacobian and the parameter sensitivity at the extreme of ``X`` (a velocity zero, where the
time of the extreme does not matter to first order). The
other tests (stick margin, ``det(M -+ I)``) are differentiated by central differences of
the test along the map's own derivatives, each a map evaluation.
"""

from __future__ import annotations

import math

import numpy as np

from .._common import check_parameter, parameter_value
from ..hybrid_map import HybridMap
from ._arclength import Corrected, Settings, correct, scaled, unscaled
from ._assembly import assemble, check_limits
from ._codim2 import codim2_points
from ._grazing import grazing_test, stripped_sides
from ._guard_crossing import GuardlessProblem
from ._hybrid_problem import SystemProblem
from ._impact_curves import fold_curve, single_impact_side
from ._points import GUARD, SMOOTH_TESTS, point_info
from ._problem import MapProblem

__all__ = ["boundary"]

#: Kinds of special point that have a boundary in two parameters.
BOUNDARY_KINDS = ("grazing", "stick_onset", "fold", "period_doubling", "neimark_sacker")
_FD_STEP = 1e-7


def boundary(point, names: tuple, limits, settings: Settings, backend, options):
    """The curve of ``point`` (a :class:`~._branch.SpecialPoint`) in the two parameters ``names``."""
    problem, node, extra_info = point.context
    if not isinstance(problem, MapProblem):
        return system_boundary(point, names, limits, settings)
    if point.kind not in BOUNDARY_KINDS:
        raise ValueError(f"a {point.kind!r} point has no boundary to follow; the kinds that do: "
                         f"{', '.join(BOUNDARY_KINDS)}")
    if extra_info.get("one_of_several"):
        raise ValueError(f"the grazing {point.label!r} is one impact of several on its flange; its boundary (the "
                         "grazing condition over a window around that impact) is not followed in two parameters yet")
    if len(names) != 2 or names[0] == names[1]:
        raise ValueError(f"parameter must be two distinct names for a boundary, got {names!r}")
    here = problem.model(unscaled(problem, node.u)[1])
    for name in names:
        check_parameter(here, name)
    bounds = _bounds(names, limits, here)
    curve = MapProblem(here, names, problem.n, problem.section_phase, backend or problem.backend,
                       options or problem.options)
    test = extra_info.get("margin", extra_info.get("test", point.kind))  # an end: the margin of its flange
    if isinstance(test, tuple | list) or test not in _TESTS:
        # located by a change of the event signature: the test of its kind
        test = _grazed_side(point) if point.kind == "grazing" else {"stick_onset": "stick_margin"}.get(point.kind,
                                                                                                       point.kind)
    if test in ("upper_margin", "lower_margin"):
        # the grazing is where the contact-free orbit touches the flange: a regular zero of gap - max X on
        # the orbits with that flange taken away, whichever side the point was located from
        side = 1 if test == "upper_margin" else -1
        real = curve.evaluate(np.array([point.x, point.v]), curve.values())
        curve = curve.virtual(stripped_sides(point_info(curve, real), side) if real.ok else side)
    z0 = np.array([point.x, point.v])
    if point.kind in ("fold", "period_doubling") and curve.rigid:
        # a fold or a period doubling of single-impact orbits: followed in the impact's phase and speed, through
        # to zero speed
        side = single_impact_side(curve, curve.evaluate(z0, curve.values()))
        followed = (fold_curve(curve, z0, curve.values(), side, bounds, settings, point.kind) if side
                    else "no single impact")
        if not isinstance(followed, str):
            nodes, found, ends, nb = followed
            return assemble(curve, nodes, found, ends, nb)
    return follow_curve(curve, z0, point.kind, test, _extra(curve, test), bounds, settings,
                         problem.orbit_events or 0, names)


def follow_curve(curve, z0, kind: str, test: str, extra, bounds, settings: Settings, orbit_events: int, names):
    """The boundary through ``z0`` of the curve problem ``curve`` with its test ``extra``: both ways, verified."""
    from ._follow import CLOSED, follow, make_node

    d = curve.dimension
    u0 = scaled(curve, z0, curve.values())
    fix = np.zeros_like(u0)
    fix[d + 1] = 1.0  # the second parameter held at its value: solve for the first
    curve.limit_events(orbit_events)
    result = correct(curve, u0, fix, settings, extra=extra)
    if not isinstance(result, Corrected):
        return assemble(curve, [], [], [(-1, f"the {kind} point could not be solved in {names}: {result}")], 0)
    start = make_node(curve, result, None, 0.0, extra)
    if start.t[d + 1] < 0.0:
        start.t = -start.t
    plain = Settings(settings.step, settings.min_step, settings.max_step, settings.max_points, settings.tol,
                     settings.max_iter, frozenset(), settings.locate_tol)
    verify = _verifier(curve, extra, settings)
    rejected = verify(result)
    if rejected:
        return assemble(curve, [], [], [(-1, f"the {kind} point solved in {names} was not verified: "
                                             f"{rejected}")], 0)
    back = follow(curve, start, -1, bounds, plain, settings.max_points, extra, verify)
    if back[3].startswith(CLOSED):  # the curve came round: going the other way would go round again
        nodes, ends = list(reversed(back[0])) + [start], [tuple(back[2:])]
    else:
        fwd = follow(curve, start, 1, bounds, plain, settings.max_points, extra, verify)
        nodes = list(reversed(back[0])) + [start] + fwd[0]
        ends = [tuple(back[2:]), tuple(fwd[2:])]
    found = codim2_points(curve, kind, test, nodes, extra, settings, stick_test)
    return assemble(curve, nodes, found, ends, len(back[0]))


def system_boundary(point, names: tuple, limits, settings: Settings):
    """The curve of a special point of a user system's branch in two of its parameters.

    A grazing of a guard: the zero of the guard's value at its extremum on the orbits of the
    system with that guard taken away (:class:`._guard_crossing.GuardlessProblem`), smooth
    through the grazing whichever side the point was located from; a fold, period doubling or
    Neimark-Sacker point: its test function of the monodromy matrix, differenced as for the
    built-in family. Cusps of a fold curve are located; the codimension-two points written
    for a flange (fold-, period-doubling-grazing, grazing-stick) are not.
    """
    problem, node, extra_info = point.context
    if point.kind not in ("grazing",) + SMOOTH_TESTS:
        raise ValueError(f"a {point.kind!r} point of a user system has no boundary followed in two parameters; the "
                         f"kinds that do: grazing, {', '.join(SMOOTH_TESTS)}")
    if len(names) != 2 or names[0] == names[1]:
        raise ValueError(f"parameter must be two distinct names for a boundary, got {names!r}")
    z, params = unscaled(problem, node.u)
    here = problem.model(params)
    for name in names:
        if name not in here.parameter_names:
            raise ValueError(f"parameter must name parameters of the system {here.name!r}; the parameters are "
                             f"{list(here.parameter_names)}, got {name!r}")
    values = dict(here.parameters)
    bounds = _bounds(names, limits, None, values)
    h = problem.hmap
    # each parameter scaled by the larger of its value and the span of its limits (as a branch's): a parameter
    # that starts at 0 crosses its range in a few dozen steps
    scales = [max(abs(values[name]), hi - lo if math.isfinite(hi - lo) else 0.0, 1e-3)
              for name, (lo, hi) in zip(names, bounds, strict=True)]
    curve = SystemProblem(HybridMap(here, h.iterates, names=names, mode=h.mode, t0=h.t0, tol=h.tol,
                                    max_time=h.max_time), scales)
    test = point.kind
    if point.kind == "grazing":
        guard = str(extra_info.get("guard", ""))
        if not guard or "," in guard:
            raise ValueError(f"the grazing {point.label!r} names no single guard ({guard!r}): its boundary cannot be "
                             "followed")
        curve = GuardlessProblem(curve, guard)
        test = GUARD + guard
    return follow_curve(curve, z, point.kind, test, _extra(curve, test), bounds, settings, problem.orbit_events,
                         names)


#: The test functions a boundary solves (a margin of :mod:`._points` or a smooth test).
_TESTS = ("upper_margin", "lower_margin", "stick_margin") + SMOOTH_TESTS


def _grazed_side(point) -> str:
    """The margin of the flange a grazing point touches (from its contacts before and after)."""
    sides = {side for (kind, side), _ in tuple(point.before) + tuple(point.after)
             if kind in ("impact", "contact_start", "chatter")}
    return "lower_margin" if sides == {-1} else "upper_margin"


def _bounds(names, limits, here, values=None):
    if not isinstance(limits, dict):
        raise TypeError(f"limits of a boundary must be a dict of name: (lo, hi) for either parameter, got {limits!r}")
    unknown = set(limits) - set(names)
    if unknown or not limits:
        raise ValueError(f"limits must name one or both of {names}, got {sorted(limits)!r}")
    def value(name):
        return values[name] if values is not None else parameter_value(here, name)

    return [check_limits(name, limits[name], value(name)) if name in limits else (-math.inf, math.inf)
            for name in names]


def _extra(curve, test: str):
    """``extra(ev, u) -> (psi, gradient row)`` of the test ``test`` (a grazing: on the virtual orbits)."""
    if test.startswith(GUARD):
        return guard_test(curve)
    if test in ("upper_margin", "lower_margin"):
        return grazing_test(curve, 1 if test == "upper_margin" else -1)
    if test == "stick_margin":
        return stick_test(curve)

    def value(ev):
        info = point_info(curve, ev)
        return float(info.tests[test]) if test in SMOOTH_TESTS else float(getattr(info, test))

    def differenced(ev, u):
        psi = value(ev)
        grad = np.zeros(len(u))
        for i in range(len(u)):
            du = np.zeros(len(u))
            du[i] = _FD_STEP
            z1, p1 = unscaled(curve, u + du)
            z0, p0 = unscaled(curve, u - du)
            e1, e0 = curve.evaluate(z1, p1), curve.evaluate(z0, p0)
            if not (e1.ok and e0.ok) or e1.singular or e0.singular:
                grad[i] = math.nan
                continue
            grad[i] = (value(e1) - value(e0)) / (2.0 * _FD_STEP)
        return np.array([psi]), grad[None, :]

    return differenced


def guard_test(curve: GuardlessProblem):
    """The grazing test of a user system's guard (:meth:`GuardlessProblem.grazing_test`), NaN where it fails."""

    def test(ev, u):
        out = curve.grazing_test(ev, u)
        if isinstance(out, str):
            return np.array([math.nan]), np.full((1, len(u)), math.nan)
        return out

    return test


#: Relative step of the central differences of the net force in time and position (an algebraic expression).
_FORCE_STEP = 1e-6


def stick_test(curve: MapProblem):
    """``extra(ev, u) -> (psi, row)``: the stick test ``beta_s - |f_net|`` at the velocity zero nearest to sticking.

    The onset of sticking (the crossing-sliding bifurcation) is where the largest
    ``beta_s - |f_net|`` over the velocity zeros of the sliding mass vanishes: negative while
    every reversal slides on, positive once one of them sticks (the stick event's own test).
    At a velocity zero ``X`` is stationary, so ``dX/du`` is the state's sensitivity there;
    the zero's time moves by ``-dV/du / a`` (``a`` the acceleration before it), which moves
    the forcing in ``f_net``; and ``f_net`` and ``beta_s`` depend on the parameters directly.
    The gradient is exact up to the central differences of the algebraic ``f_net``.
    """
    scales = np.asarray(curve.scales)

    def test(ev, u):
        rec = ev.recorder
        if not rec.turns:
            return np.array([math.nan]), np.full((1, len(u)), math.nan)
        osc = rec.osc
        best = None
        for t, x, mode, jac, sigma in rec.turns:
            f = osc._net_force_scalar(t, x)
            psi = osc.beta_s - abs(f)
            if best is None or psi > best[0]:
                best = (psi, t, x, mode, jac, sigma, f)
        psi, t, x, mode, jac, sigma, f = best
        a = osc._accel_scalar(t, x, 0.0, mode.region, mode.motion)
        ht = _FORCE_STEP * max(1.0, abs(t))
        hx = _FORCE_STEP * max(1.0, abs(x))
        f_t = (osc._net_force_scalar(t + ht, x) - osc._net_force_scalar(t - ht, x)) / (2.0 * ht)
        f_x = (osc._net_force_scalar(t, x + hx) - osc._net_force_scalar(t, x - hx)) / (2.0 * hx)
        dx = np.concatenate([[jac[0], jac[1]], sigma[0] * scales])
        dv = np.concatenate([[jac[2], jac[3]], sigma[1] * scales])
        dt = -dv / a if a != 0.0 else np.full(len(u), math.nan)
        df = f_t * dt + f_x * dx
        sign = 1.0 if f >= 0.0 else -1.0
        grad = -sign * df
        for j, stencil in enumerate(rec.stencils):
            direct = stencil.derivative(lambda m: m.beta_s - sign * m._net_force_scalar(t, x))
            grad[2 + j] += direct * scales[j]
        return np.array([psi]), grad[None, :]

    return test


#: A boundary point's defining equations must hold to this many times ``tol`` (no acceptance on the
#: corrector's rounding floor), and its orbit, rerun on the model with every flange, must return to
#: within this relative distance (a grazing orbit touches its flange there: a rigid one at a speed of
#: the order of the rounding, whose impact moves the state by as much).
VERIFY_TOL = 10.0
VERIFY_ORBIT = 1e-6


def _verifier(curve: MapProblem, extra, settings: Settings):
    """``verify(corrected) -> str``: the point's equations re-evaluated, its orbit rerun on the real model."""
    real = curve.unstripped if isinstance(curve, GuardlessProblem) else curve.virtual(0) if curve.stripped else curve

    def verify(result) -> str:
        ev = result.ev
        z, params = unscaled(curve, result.u)
        value = np.atleast_1d(extra(ev, result.u)[0])
        size = max(1.0, float(np.linalg.norm(z)))
        residual = float(np.linalg.norm(np.concatenate([ev.residual, value])))
        if not residual <= VERIFY_TOL * settings.tol * size:
            return f"its equations hold to {residual:.3g} only (tolerance {settings.tol:g})"
        rerun = real.evaluate(z, params)
        if not rerun.ok:
            return f"its orbit could not be rerun: {rerun.failure}"
        miss = float(np.linalg.norm(rerun.residual))
        if not miss <= VERIFY_ORBIT * size:
            return f"its orbit, rerun, misses its start by {miss:.3g}"
        return ""

    return verify
