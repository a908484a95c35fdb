"""Crossing a grazing, a flange's or a user system's guard's: which one the branch reaches, and the guard's crossing.

:func:`approaching` and :func:`cross` are what the follow loop calls: they hand a flange of
the built-in family to :mod:`._grazing` and a user system's guard to the same steps written
for it here. A guard's grazing is located on the orbits of the system with the guard taken
away (:class:`._guard_crossing.GuardlessProblem`, by :func:`._grazing.locate`); the branch
goes on beyond it back along those orbits (from contact), into the crossings of a guard with
a reset by its impact formulation (:class:`._guard_crossing.GuardImpact`), or along the
virtual family for a guard without one, and corrects the far point on its own problem.
"""

from __future__ import annotations

import math

import numpy as np

from ._arclength import Corrected, Settings, correct, unscaled
from ._grazing import (
    FAR_STEP,
    NEAR,
    TOUCHES_BOTH,
    Crossing,
    beyond,
    crossings_of,
    grazing_near,
    margin,
)
from ._grazing import approaching as flange_approaching
from ._grazing import cross as flange_cross
from ._guard_crossing import GuardImpact, GuardlessProblem, replace_info_singular
from ._newton import along, halving
from ._points import GUARD, point_info
from ._problem import MapProblem

__all__ = ["approaching", "cross", "guard_near", "cross_guard"]


def approaching(problem, previous, node, h: float, failed: bool = False):
    """The flange (+1, -1) or the user system's guard (its name) whose grazing the branch reaches next (0 or "": none).

    See :func:`._grazing.approaching` and :func:`guard_near`.
    """
    if isinstance(problem, MapProblem):
        return flange_approaching(problem, previous, node, h, failed)
    if previous is None or problem.stripped:
        return ""
    return guard_near(problem, previous, node, float(np.linalg.norm(node.u - previous.u)), h, failed)


def cross(problem, node, side, h: float, settings: Settings, bounds=None):
    """Cross the grazing of ``side`` (a flange, or a user system's guard by name): a :class:`Crossing` or why not."""
    if isinstance(side, str):
        if len(problem.names) != 1:
            return "crossing a grazing is done on branches in one parameter"
        return cross_guard(problem, node, side, h, settings, bounds)
    return flange_cross(problem, node, side, h, settings, bounds)


def guard_near(problem, previous, node, ds: float, h: float, failed: bool) -> str:
    """The guard of a user system whose grazing the branch reaches within its next step ("": none).

    As :func:`approaching` for a flange: a margin shrinking towards zero within :data:`NEAR`, reached
    by the secant within 1.5 steps (or the step has just failed); a guard crossed more than once a
    period is not one about to vanish.
    """
    for name, kind in problem.margin_tests:
        guard = name.removeprefix(GUARD)
        m0, m1 = margin(previous.info, guard), margin(node.info, guard)
        if kind != "grazing" or not (math.isfinite(m0) and math.isfinite(m1)) or abs(m1) >= NEAR \
                or abs(m1) >= abs(m0) or m0 * m1 <= 0:
            continue
        if m1 < 0.0 and (crossings_of(node.info, guard) != 1 or crossings_of(previous.info, guard) != 1):
            continue
        if failed or abs(m1) <= 1.5 * h * abs(m1 - m0) / max(ds, 1e-300):
            return guard
    return ""


def cross_guard(problem, node, guard: str, h: float, settings: Settings, bounds):
    """:func:`cross` for the grazing of a user system's guard: a :class:`Crossing`, or a string saying why not.

    The same three steps as a flange's: the grazing located on the orbits of the system with the
    guard taken away (:class:`GuardlessProblem`), the first point beyond it (back along those
    orbits when the branch comes from contact, into contact by the impact formulation of the
    guard's reset, or along the virtual family for a guard without one), and the label.
    """
    from_contact = margin(node.info, guard) < 0.0
    if from_contact and crossings_of(node.info, guard) != 1:
        return (f"the guard {guard!r} fires {crossings_of(node.info, guard)} times a period: the grazing of one "
                "crossing of several is crossed on the built-in family only")
    try:
        virtual = GuardlessProblem(problem, guard)
    except ValueError as exc:
        return str(exc)
    found = grazing_near(problem, virtual, node, guard, h, settings, bounds)
    if isinstance(found, str):
        return found
    u_g, ev_g, error, t_free = found
    info = point_info(virtual, ev_g)
    also = sorted(name.removeprefix(GUARD) for name, m in info.margins.items() if abs(m) < TOUCHES_BOTH)
    if also:
        return (f"the orbit grazes the guard {guard!r} and, at the same point, {', '.join(map(repr, also))} (a "
                "symmetric orbit, say): several guards grazed at once are not crossed on a user system")
    d = problem.dimension
    with_reset = bool(virtual.guard.reset)
    if from_contact:
        far = beyond(problem, u_g, t_free, h, settings, guard, want_contact=False)
        far = far if isinstance(far, str) else (far, np.sign(t_free[d]))
    elif with_reset:
        far = _beyond_impact(problem, virtual, u_g, h, settings)
    else:
        far = beyond(problem, u_g, -t_free, h, settings, guard, want_contact=True)
        far = far if isinstance(far, str) else (far, -np.sign(t_free[d]))
    if isinstance(far, str):
        return far
    far, went = far
    came = np.sign(u_g[d] - node.u[d])
    case = "persistent" if came == 0 or went == 0 or came == went else "nonsmooth_fold"
    if with_reset:
        info = replace_info_singular(info, f"the map is not differentiable where the orbit grazes the guard {guard!r}"
                                           " with its reset (a square-root term, Nordmark 1991)")
    into = "onto the orbits that cross" if not from_contact else "off"
    what = ("the branch goes on in the same direction of the parameter (a persistent crossing)" if case == "persistent"
            else "the parameter turns back there: the families on either side meet at the grazing and end together "
                 "(a nonsmooth fold)")
    message = (f"the orbit touches the guard {guard!r} tangentially: located as a regular point of the orbits of the "
               f"system with that guard taken away (its value at its extremum = 0); the branch crosses {into} the "
               f"guard, and {what}")
    return Crossing(guard, u_g, ev_g, info, abs(float(error[d])) * problem.scales[0], far, case, message)


def _beyond_impact(problem, virtual: GuardlessProblem, u_g, h: float, settings: Settings):
    """``(first orbit that crosses the guard, direction of the parameter)`` past its grazing, or why not.

    The impact formulation of the guard's reset (:class:`GuardImpact`) is stepped from the grazing
    orbit towards a positive crossing speed, then its orbit corrected on the branch's own problem.
    """
    d = problem.dimension
    z_g, params_g = unscaled(virtual, u_g)  # type: ignore[arg-type]
    peak = virtual.peak(z_g, params_g)
    if isinstance(peak, str):
        return f"the grazing orbit could not be run again: {peak}"
    t_touch, y_touch, mode = peak[3:]
    form = GuardImpact(virtual, mode)
    w_g = np.concatenate([[t_touch], y_touch[:d], u_g[d:]])
    out = form.residual(w_g)
    if isinstance(out, str):
        return out
    t_w = np.linalg.svd(out[1])[2][-1]
    why = "no step tried"
    for sign in (1.0, -1.0):
        for step in halving(max(h, FAR_STEP), settings.min_step):
            found = along(form.residual, w_g, sign * t_w, step, settings.tol)
            if isinstance(found, str):
                why = found
                continue
            w = found[0]
            speed = form.speed(w)
            if speed <= 0.0:
                why = f"the crossing speed past the grazing is {speed:.3g}"
                break  # the other direction along the impacting family
            z = form.section_state(w)
            if isinstance(z, str):
                why = z
                continue
            u_pred = np.concatenate([z, w[1 + d:]])
            chord = (u_pred - u_g) / np.linalg.norm(u_pred - u_g)
            result = correct(problem, u_pred, chord, settings, max_distance=2.0 * step + 1e-9)
            if not isinstance(result, Corrected):
                why = result
                continue
            if margin(point_info(problem, result.ev), virtual.guard.name) >= 0.0:
                why = "the corrected orbit does not cross the guard"
                continue
            return result, float(np.sign(w[1 + d] - w_g[1 + d]))
    return f"no orbit crossing the guard was found past the grazing: {why}"


