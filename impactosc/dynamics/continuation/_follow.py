"""Following a branch in one direction, and locating the special points between two of its points.

:func:`follow` is the driver loop: predict along the tangent, correct on the
pseudo-arclength hyperplane, adapt the step (grow after a fast corrector, shrink after a
slow or failed one or a sharp turn), stop at a parameter limit (the last point solved
*on* the limit), at ``max_points`` or below ``min_step``, keeping every point computed.
Between two accepted points, a change of sign of a test function or a change of the
event signature is located by :func:`locate_between`: Illinois (regula falsi) on the
arclength for a test function, bisection for the signature, each evaluation a corrected
point; a flange's grazing as a regular point of the contact-free orbits
(:func:`._nonsmooth.regular_grazing`).

Where the map is not smooth the plain predictor-corrector cannot go on, and the loop hands
over (:mod:`._nonsmooth`): a branch about to reach a grazing crosses it into the family on
the other side (:mod:`._grazing`), and an impact that crosses the section is stepped over
by mapping the section state across the impact's reset.
"""

from __future__ import annotations

import math

import numpy as np

from ._arclength import Corrected, Settings, correct, illinois, unscaled
from ._grazing import approaching
from ._nodes import Found, Node, make_node
from ._nonsmooth import across_section, regular_grazing, try_crossing
from ._points import MARGIN_TESTS, SMOOTH_TESTS, PointInfo, contact_counts, point_info, stick_counts
from ._problem import UNSUPPORTED, MapProblem

__all__ = ["Node", "Found", "follow", "locate_between", "LABEL_ORDER"]

#: Cosine of the largest turn of the tangent accepted in one step (about 35 degrees).
MAX_TURN = 0.82
#: Order of special points found between the same two points (for their labels).
LABEL_ORDER = {"grazing": 0, "stick_onset": 1, "border": 2, "fold": 3, "branch_point": 4, "period_doubling": 5,
               "neimark_sacker": 6, "resonant_grazing": 7}
#: A margin this close to zero (nondimensional) at a failed step: the branch ends at the grazing.
GRAZING_NEAR = 1e-3


def follow(problem: MapProblem, start: Node, direction: int, limits, settings: Settings, max_points: int,
           extra=None, verify=None):
    """Follow the branch from ``start`` along ``direction * start.t``.

    ``limits`` is ``(lo, hi)`` of the first parameter, or a list of such pairs, one per free
    parameter (``-inf``/``inf`` for none); ``extra`` adds equations to the corrector (a
    boundary's test function, :mod:`._boundary`); ``verify(corrected) -> str`` checks a
    corrected point before it is accepted ("" to accept, else why not: the step is then
    shortened as after a failed corrector). Returns ``(nodes, found, status,
    message)``: the accepted points after ``start``, the located special points (``Found``,
    ``index`` counted in ``nodes`` with ``start`` as -1).
    """
    bounds = [limits] if np.ndim(limits) == 1 else list(limits)
    nodes: list[Node] = []
    found: list[Found] = []
    t = direction * start.t
    # every later node's tangent points along the travel; so must the start's, or a fold in the
    # first backward step would read as a turn that is none (and the reverse)
    node = start if direction > 0 else Node(start.u, t, start.corrected, start.info, start.arclength)
    h = settings.step
    jumped_last = False
    h_good = h  # the last step that succeeded: the scale of a jump across a grazing
    previous = None  # the point before ``node`` (where the branch came from)
    tried: dict = {"crossing": -1, "section": -1, "failed": -1}  # the point count when each was last tried
    while True:
        if len(nodes) >= max_points:
            return nodes, found, 1, f"stopped after max_points = {max_points} points"
        side = 0 if extra is not None or tried["crossing"] == len(nodes) else approaching(problem, previous, node, h)
        moved = try_crossing(problem, node, side, h, settings, bounds[0], direction, len(nodes) - 1,
                             tried) if side else None
        tried["crossing"] = len(nodes) if side else tried["crossing"]
        if moved is None:
            u_pred, constraint, at_limit = _predict(problem, node.u, t, h, bounds)
            result = correct(problem, u_pred, constraint, settings, extra=extra, max_distance=2.0 * h + 1e-9)
            if verify is not None and isinstance(result, Corrected):
                rejected = verify(result)
                result = f"the point was not verified: {rejected}" if rejected else result
            if isinstance(result, str) and UNSUPPORTED in result:
                return nodes, found, -1, f"the branch stops where its backend cannot go on: {result}"
            turn = 1.0
            if isinstance(result, Corrected):
                new = _advance(problem, node, result, t, direction, extra)
                turn = float(np.dot(new.t, t))
            failed = not isinstance(result, Corrected) or (turn < MAX_TURN and at_limit is None)
            if failed and extra is None:
                moved = _rescue(problem, previous, node, t, h, h_good, settings, bounds[0], direction, len(nodes),
                                tried)
        if moved is not None:
            new, passed = moved
            found.append(passed)
            nodes.append(new)
            previous, node, t, h = node, new, new.t, h_good
            jumped_last = False
            continue
        if failed:
            why = result if not isinstance(result, Corrected) else (
                f"the tangent turned by {math.degrees(math.acos(max(-1.0, min(1.0, turn)))):.0f} degrees")
            h *= 0.5
            if h < settings.min_step:
                jumped = None
                if node.info.nearest_grazing() < GRAZING_NEAR and not jumped_last:
                    jumped, at_limit, h = _jump(problem, node, t, h_good, bounds, settings, extra)
                if jumped is None:
                    status, message = _failed_end(node, why, settings, tried.get("crossing_failure", ""))
                    if status == 2:
                        found.append(_grazing_end(problem, nodes, start, node))
                    return nodes, found, status, message
                result = jumped
                new = _advance(problem, node, result, t, direction, extra)
                jumped_last = True
            else:
                continue
        else:
            jumped_last = False
            h_good = h
        if settings.locate:
            found += locate_between(problem, node, new, t, settings, index=len(nodes) - 1)
        nodes.append(new)
        if settings.on_point is not None:
            settings.on_point(new)
        stop = [f for f in found if f.kind in settings.stop_at]
        if stop:
            return nodes, found, 0, f"stopped at the first {stop[0].kind} point, as asked (stop_at)"
        if at_limit is not None:
            return nodes, found, 0, f"reached the limit {at_limit[0]} = {at_limit[1]!r}"
        iterations = result.iterations if isinstance(result, Corrected) else 3
        if iterations <= 2:
            h = min(h * 1.5, settings.max_step)
        elif iterations >= 5:
            h = max(h * 0.6, settings.min_step)
        previous, node, t = node, new, new.t


def _rescue(problem, previous, node: Node, t, h: float, h_good: float, settings: Settings, bounds, direction: int,
            count: int, tried: dict):
    """After a failed step: across an impact on the section, or across a grazing (each once per point), or None."""
    if tried["section"] != count:
        tried["section"] = count
        moved = across_section(problem, node, t, h_good, settings, count - 1)
        if moved is not None:
            return moved
    if tried["failed"] != count:
        side = approaching(problem, previous, node, h, failed=True)
        if side:
            tried["failed"] = count
            return try_crossing(problem, node, side, h_good, settings, bounds, direction, count - 1, tried)
    return None


def _advance(problem, node: Node, result: Corrected, t, direction: int, extra) -> Node:
    step = float(np.linalg.norm(result.u - node.u))
    return make_node(problem, result, t, node.arclength + direction * step, extra)


def _predict(problem: MapProblem, u, t, h: float, bounds):
    """The predicted point, its constraint row, and ``(name, limit)`` when it lies beyond a limit."""
    u_pred = u + h * t
    for j, (lo, hi) in enumerate(bounds):
        value = u_pred[2 + j] * problem.scales[j]
        if value > hi or value < lo:
            limit = hi if value > hi else lo
            u_pred = u_pred.copy()
            u_pred[2 + j] = limit / problem.scales[j]
            constraint = np.zeros_like(u_pred)
            constraint[2 + j] = 1.0
            return u_pred, constraint, (problem.names[j], limit)
    return u_pred, t, None


def _failed_end(node: Node, why: str, settings: Settings, crossing: str = ""):
    near = node.info.nearest_grazing()
    if near < GRAZING_NEAR:
        tried = (f"; {crossing} (a discontinuous grazing with no family on the other side, or one this crossing "
                 "cannot reach)") if crossing else ""
        return 2, (f"the branch ends at a grazing (its last point is {near:.3g} from touching a flange, in distance "
                   f"or entry speed): no periodic orbit of this family lies beyond it within the minimum step "
                   f"{settings.min_step:g}, nor past it ({why}){tried}")
    return -1, f"the step fell below min_step = {settings.min_step:g}: {why}"


def _grazing_end(problem, nodes, start: Node, node: Node) -> Found:
    """The grazing that ends a branch, extrapolated from its last two points.

    The distance to touching (a clearance, or an entry speed, which vanish linearly in the
    parameter on the side where the orbit exists) is extrapolated to zero by a secant in the
    parameter; the point's accuracy is how far that moved from the last point.
    """
    before = nodes[-2] if len(nodes) >= 2 else start
    g0, g1 = before.info.nearest_grazing(), node.info.nearest_grazing()
    p0, p1 = before.u[2] * problem.scales[0], node.u[2] * problem.scales[0]
    value = p1
    if g1 < g0 and p1 != p0:
        value = p1 - g1 * (p1 - p0) / (g1 - g0)
    found = Found("grazing", node, node.info.signature, node.info.signature, abs(value - p1),
                  f"the branch ends at a grazing: its last point is {g1:.3g} from touching a flange (in distance or "
                  "entry speed); the parameter is extrapolated (a secant through the last two points) to where that "
                  "vanishes", len(nodes) - 1,
                  {"test": "end", "value": value, "margin": _nearest_side(node.info)})
    return found


def _nearest_side(info: PointInfo) -> str:
    """``"upper_margin"`` or ``"lower_margin"``: the flange the orbit is nearest to touching."""
    near = {side: min(abs(info.upper_margin if side > 0 else info.lower_margin), info.approach[side],
                      info.slowest_entry[side]) for side in (1, -1)}
    return "upper_margin" if near[1] <= near[-1] else "lower_margin"


def _jump(problem, node: Node, t, h: float, bounds, settings: Settings, extra):
    """Across a grazing: predictions beyond it, for a branch whose map is singular at the grazing itself."""
    for factor in (0.25, 1.0, 2.0, 4.0):
        step = min(factor * h, settings.max_step)
        u_pred, constraint, at_limit = _predict(problem, node.u, t, step, bounds)
        result = correct(problem, u_pred, constraint, settings, extra=extra, max_distance=2.0 * step)
        if isinstance(result, Corrected):
            return result, at_limit, step
        if step >= settings.max_step:
            break
    return None, None, h


# -- location ----------------------------------------------------------------------------
def _corrected_at(problem, a: Node, t, sigma: float, settings: Settings):
    """The branch point at arclength ``sigma`` from ``a`` along ``t`` (or None)."""
    result = correct(problem, a.u + sigma * t, t, settings, max_distance=2.0 * abs(sigma) + 1e-9)
    return result if isinstance(result, Corrected) else None


def _test_value(info: PointInfo, name: str) -> float:
    if name in SMOOTH_TESTS:
        return float(info.tests[name])
    return float(getattr(info, name))


def locate_between(problem, a: Node, b: Node, t, settings: Settings, index: int) -> list[Found]:
    """Every special point between the accepted points ``a`` and ``b`` (``b`` follows ``a`` along ``t``)."""
    out: list[Found] = []
    h = float(np.dot(b.u - a.u, t))
    same = a.info.signature == b.info.signature
    for name, kind in MARGIN_TESTS:
        if kind not in settings.locate:
            continue
        va, vb = _test_value(a.info, name), _test_value(b.info, name)
        if math.isfinite(va) and math.isfinite(vb) and va * vb < 0.0:
            regular = regular_grazing(problem, a, b, name, settings, index) if kind == "grazing" else None
            out.append(regular or _illinois(problem, a, t, h, name, kind, va, vb, settings, index))
            out[-1].after = b.info.signature
    if same:
        for kind in SMOOTH_TESTS:
            label = kind
            if kind == "fold" and a.t[2] * b.t[2] > 0.0:
                # a multiplier through +1 while the parameter keeps its direction: no fold but a branch
                # point (in the symmetric guide, typically a symmetry-breaking pitchfork)
                label = "branch_point"
            if label not in settings.locate:
                continue
            va, vb = _test_value(a.info, kind), _test_value(b.info, kind)
            if math.isfinite(va) and math.isfinite(vb) and va * vb < 0.0:
                out.append(_smooth_or_jump(_illinois(problem, a, t, h, kind, label, va, vb, settings, index), kind))
    elif (not any(f.kind in ("grazing", "stick_onset") for f in out)
          and _signature_kind(a.info.signature, b.info.signature) in settings.locate):
        out.append(_bisect_signature(problem, a, b, t, h, settings, index))
    return out


#: A located fold / PD / NS point whose critical multiplier is farther than this from +1 / -1 / the unit
#: circle is a jump of the multipliers across it (a nonsmooth point), not a smooth crossing.
SMOOTH_CROSSING = 1e-6


def _smooth_or_jump(found: Found, test: str) -> Found:
    """``found`` relabelled a border when its multipliers jump across the critical value instead of crossing it."""
    mus = found.node.info.multipliers
    if test == "neimark_sacker":
        miss = float(np.min(np.abs(np.abs(mus) - 1.0)))
    else:
        miss = float(np.min(np.abs(mus - (1.0 if test == "fold" else -1.0))))
    p = abs(found.node.u[2])
    if miss <= SMOOTH_CROSSING or found.accuracy > 1e-9 * max(1.0, p):
        return found  # a smooth crossing, or located too coarsely (locate_tol) to tell a jump from it
    critical = {"fold": "+1", "period_doubling": "-1"}.get(test, "the unit circle")
    found.kind = "border"
    found.message = (f"the multipliers jump across {critical} "
                     f"here (the nearest is {miss:.2g} from it at the located point) though the event signature "
                     "stays the same: the map is not smooth here (e.g. just past a grazing), no smooth bifurcation")
    return found


def _illinois(problem, a: Node, t, h: float, name: str, kind: str, va: float, vb: float, settings, index) -> Found:
    lo, hi, flo, fhi = 0.0, h, va, vb
    best, side = None, 0
    for _ in range(80):
        s = hi - fhi * (hi - lo) / (fhi - flo)
        if not lo < s < hi:
            s = 0.5 * (lo + hi)
        c = _corrected_at(problem, a, t, s, settings)
        if c is None:  # no differentiable orbit exactly here (e.g. at the grazing itself): bisect instead
            s = 0.5 * (lo + hi)
            c = _corrected_at(problem, a, t, s, settings)
            if c is None:
                break
        node = Node(c.u, t, c, point_info(problem, c.ev), a.arclength)
        f = _test_value(node.info, name)
        best = node
        if not math.isfinite(f):
            break
        lo, flo, hi, fhi, side = illinois(lo, flo, hi, fhi, s, f, side)
        value = abs(c.u[2] * problem.scales[0])
        width = abs(hi - lo) * abs(t[2]) * problem.scales[0]
        if f == 0.0 or abs(hi - lo) <= settings.locate_tol or width <= settings.locate_tol * max(1.0, value):
            break
    return _found(problem, kind, best or a, a, abs(hi - lo), index, name)


def _bisect_signature(problem, a: Node, b: Node, t, h: float, settings, index) -> Found:
    lo, hi = 0.0, h
    best = b
    failed = False
    for _ in range(60):
        if abs(hi - lo) <= settings.locate_tol:
            break
        s = 0.5 * (lo + hi)
        c = _corrected_at(problem, a, t, s, settings)
        if c is None:
            failed = True
            break
        node = Node(c.u, t, c, point_info(problem, c.ev), a.arclength)
        if node.info.signature == a.info.signature:
            lo = s
        else:
            hi, best = s, node
    before, after = a.info.signature, b.info.signature
    kind = _signature_kind(before, after)
    found = _found(problem, kind, best, a, abs(hi - lo), index, "signature")
    found.after = after
    if failed:
        found.message += (f"; located only to within {found.accuracy:.3g} in the parameter (no orbit could be "
                          "corrected inside the final bracket)")
    return found


def _signature_kind(before, after) -> str:
    """What a change of the event signature is: a contact appearing or vanishing, a stick, or another border."""
    if contact_counts(before) != contact_counts(after):
        return "grazing"
    if stick_counts(before) != stick_counts(after):
        return "stick_onset"
    return "border"


def _found(problem, kind: str, node: Node, a: Node, width: float, index: int, test: str) -> Found:
    _, params = unscaled(problem, node.u)
    before, after = a.info.signature, node.info.signature
    message = _describe(kind, test, node, before, after)
    extra = {"test": test}
    if kind == "stick_onset":
        extra["bifurcation"] = "crossing-sliding" if test == "stick_margin" else "sliding"
    return Found(kind, node, before, after, width * problem.scales[0], message, index, extra)


def _describe(kind: str, test: str, node: Node, before, after) -> str:
    mus = node.info.multipliers
    if kind == "fold":
        return "a multiplier passes through +1 (the branch turns back in the parameter)"
    if kind == "branch_point":
        return ("a multiplier passes through +1 while the branch goes on in the same direction: another branch "
                "crosses here (a symmetric orbit's symmetry-breaking pitchfork, typically)")
    if kind == "period_doubling":
        return "a multiplier passes through -1 (a period-2n branch bifurcates)"
    if kind == "neimark_sacker":
        return f"a complex pair crosses the unit circle (|mu| = {abs(mus[0]):.6g}): a torus"
    if kind == "grazing" and test == "signature":
        return (f"the orbit touches a flange tangentially: its contacts change from {_contacts(before)} to "
                f"{_contacts(after)}")
    if kind == "grazing":
        side = "upper" if test.startswith("upper") else "lower"
        return f"the orbit touches the {side} flange tangentially (a contact appears or vanishes)"
    if kind == "stick_onset" and test == "signature":
        return (f"the stuck segments change ({stick_counts(before)} to {stick_counts(after)} sticks a period) where no "
                "reversal's stick test vanishes: a sliding bifurcation other than at a reversal (adding- or "
                "switching-sliding, di Bernardo et al. 2008, ch. 8)")
    if kind == "stick_onset":
        return ("a reversal turns into a stick: a crossing-sliding bifurcation (the orbit's crossing of the switching "
                "surface V = 0 becomes a segment that sticks on it; di Bernardo et al. 2008, ch. 8)")
    return f"the event signature changes from {_text(before)} to {_text(after)}"


def _text(sig) -> str:
    side = {1: "upper ", -1: "lower ", 0: ""}
    return ", ".join(f"{count} {side[s]}{kind}" for (kind, s), count in sig) or "no events"


def _contacts(sig) -> str:
    return _text(tuple(contact_counts(sig).items())) if contact_counts(sig) else "none"
