"""Following a branch in one direction.

:func:`follow` is the driver loop: predict along the tangent, correct on the
pseudo-arclength hyperplane, adapt the step (grow after a fast corrector, shrink after a
slow or failed one or a sharp turn), stop at a parameter limit (the last point solved
*on* the limit), at ``max_points`` or below ``min_step``, keeping every point computed.
Between two accepted points the special points are located by
:func:`._locate.locate_between`. The loop asks its problem what it is (the built-in
family's :class:`._problem.MapProblem`, a user system's :class:`._hybrid_problem.SystemProblem`):
its dimension, its margins, and whether it takes the nonsmooth steps below.

Where the map is not smooth the plain predictor-corrector cannot go on, and the loop hands
over (:mod:`._nonsmooth`): a branch about to reach a grazing crosses it into the family on
the other side (:mod:`._grazing`), and an impact that crosses the section is stepped over
by mapping the section state across the impact's reset.

A closed curve (an isola of periodic orbits, a closed fold curve in two parameters) would
run round to ``max_points``: the loop stops where the chord between two accepted points
passes its start again, travelling the way it left (:data:`CLOSED`, status 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._arclength import Corrected, Settings, correct, parameter
from ._crossing import approaching
from ._locate import locate_between
from ._nodes import Found, Node, make_node
from ._nonsmooth import across_section, try_crossing
from ._points import GUARD, PointInfo
from ._problem import UNSUPPORTED, MapProblem

__all__ = ["Node", "Found", "follow", "locate_between", "LABEL_ORDER"]

#: Cosine of the largest turn of the tangent accepted in one step (about 35 degrees).
MAX_TURN = 0.82
#: Order of special points found between the same two points (for their labels).
LABEL_ORDER = {"grazing": 0, "stick_onset": 1, "border": 2, "fold": 3, "branch_point": 4, "period_doubling": 5,
               "neimark_sacker": 6, "resonant_grazing": 7}
#: A margin this close to zero (nondimensional) at a failed step: the branch ends at the grazing.
GRAZING_NEAR = 1e-3
#: The start of the message of a direction that ended on its start: the curve is closed.
CLOSED = "the curve is closed"
#: A chord passing the start within this fraction of its length has come round to it.
RETURN_SHARE = 0.1


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
    return _Walk(problem, start, direction, limits, settings, max_points, extra, verify).run()


class _Walk:
    """One direction of a branch: the accepted points, the current step and what was tried where."""

    def __init__(self, problem, start: Node, direction: int, limits, settings: Settings, max_points: int, extra,
                 verify):
        self.problem, self.direction, self.settings = problem, direction, settings
        self.max_points, self.extra, self.verify = max_points, extra, verify
        self.bounds = [limits] if np.ndim(limits) == 1 else list(limits)
        self.start = start
        self.travel0 = direction * start.t  # the way the walk leaves its start (a closed curve arrives so)
        self.nodes: list[Node] = []
        self.found: list[Found] = []
        self.t = direction * start.t
        # every later node's tangent points along the travel; so must the start's, or a fold in the
        # first backward step would read as a turn that is none (and the reverse)
        self.node = start if direction > 0 else Node(start.u, self.t, start.corrected, start.info, start.arclength)
        self.previous: Node | None = None  # the point before ``node`` (where the branch came from)
        self.h = settings.step
        self.h_good = self.h  # the last step that succeeded: the scale of a jump across a grazing
        self.jumped_last = False
        self.tried: dict = {"crossing": -1, "section": -1, "failed": -1}  # point count when each was last tried

    def run(self):
        while True:
            if len(self.nodes) >= self.max_points:
                return self.nodes, self.found, 1, f"stopped after max_points = {self.max_points} points"
            moved = self._cross_ahead()
            attempt = None
            if moved is None:
                attempt = self._step()
                if isinstance(attempt, tuple) and attempt and attempt[0] == "end":
                    return attempt[1]
                if attempt.failed and self.extra is None:
                    moved = self._rescue()
            if moved is not None:
                self._moved(*moved)
                continue
            if attempt.failed:
                outcome = self._after_failure(attempt)
                if outcome is None:
                    continue  # the step was halved: try again
                if outcome[0] == "end":
                    return outcome[1]
                attempt = outcome[1]
            else:
                self.jumped_last = False
                self.h_good = self.h
            end = self._accept(attempt)
            if end is not None:
                return end

    def _returned(self, new: Node) -> bool:
        """The step to ``new`` came round to the start, travelling the way the walk left it (a closed curve)."""
        if len(self.nodes) < 3:
            return False
        chord = new.u - self.node.u
        return float(chord @ self.travel0) > 0.0 and _passes(self.node.u, new.u, self.start.u)

    # -- one step ----------------------------------------------------------------------
    def _cross_ahead(self):
        """Across a grazing the branch reaches within its next step (the built-in family's), or None."""
        problem, count = self.problem, len(self.nodes)
        if not problem.nonsmooth_steps or self.extra is not None or self.tried["crossing"] == count:
            return None
        side = approaching(problem, self.previous, self.node, self.h)
        if not side:
            return None
        self.tried["crossing"] = count
        return try_crossing(problem, self.node, side, self.h, self.settings, self.bounds[0], self.direction,
                            count - 1, self.tried)

    def _step(self):
        """A predicted and corrected point: an :class:`_Attempt`, or ``("end", result)`` where the backend stops."""
        problem, settings = self.problem, self.settings
        u_pred, constraint, at_limit = _predict(problem, self.node.u, self.t, self.h, self.bounds)
        result = correct(problem, u_pred, constraint, settings, extra=self.extra, max_distance=2.0 * self.h + 1e-9)
        if self.verify is not None and isinstance(result, Corrected):
            rejected = self.verify(result)
            result = f"the point was not verified: {rejected}" if rejected else result
        if isinstance(result, str) and UNSUPPORTED in result:
            return ("end", (self.nodes, self.found, -1, f"the branch stops where its backend cannot go on: {result}"))
        new, turn = None, 1.0
        if isinstance(result, Corrected):
            new = _advance(problem, self.node, result, self.t, self.direction, self.extra)
            turn = float(np.dot(new.t, self.t))
        failed = not isinstance(result, Corrected) or (turn < MAX_TURN and at_limit is None)
        return _Attempt(new, result, at_limit, failed, turn)

    def _rescue(self):
        """After a failed step: across an impact on the section, or across a grazing (each once per point), or None."""
        if not self.problem.nonsmooth_steps:
            return None
        return _rescue(self.problem, self.previous, self.node, self.t, self.h, self.h_good, self.settings,
                       self.bounds[0], self.direction, len(self.nodes), self.tried)

    def _moved(self, new: Node, passed: Found) -> None:
        """A nonsmooth step was taken: ``new`` beyond the special point ``passed``."""
        self.found.append(passed)
        self.nodes.append(new)
        self.previous, self.node, self.t, self.h = self.node, new, new.t, self.h_good
        self.jumped_last = False

    def _after_failure(self, attempt: _Attempt):
        """The step is halved; below ``min_step``, a jump across a grazing or the end of the branch.

        Returns None (try again with the halved step), ``("end", result)`` or ``("jumped", attempt)``.
        """
        problem, settings, node = self.problem, self.settings, self.node
        result = attempt.result
        why = result if not isinstance(result, Corrected) else (
            f"the tangent turned by {math.degrees(math.acos(max(-1.0, min(1.0, attempt.turn)))):.0f} degrees")
        self.h *= 0.5
        if self.h >= settings.min_step:
            return None
        jumped, at_limit = None, None
        if node.info.nearest_grazing() < GRAZING_NEAR and not self.jumped_last:
            jumped, at_limit, self.h = _jump(problem, node, self.t, self.h_good, self.bounds, settings, self.extra)
        if jumped is None:
            status, message = _failed_end(problem, node, why, settings, self.tried.get("crossing_failure", ""))
            if status == 2:
                self.found.append(_grazing_end(problem, self.nodes, self.start, node))
            return "end", (self.nodes, self.found, status, message)
        self.jumped_last = True
        new = _advance(problem, node, jumped, self.t, self.direction, self.extra)
        return "jumped", _Attempt(new, jumped, at_limit, False, 1.0)

    def _accept(self, attempt: _Attempt):
        """Accept ``attempt.new``: special points since the last point, limits, the next step's size; an end or None."""
        settings, new = self.settings, attempt.new
        assert new is not None  # an attempt that did not fail has its point
        if settings.locate:
            self.found += locate_between(self.problem, self.node, new, self.t, settings, index=len(self.nodes) - 1)
        returned = self._returned(new)
        self.nodes.append(new)
        if settings.on_point is not None:
            settings.on_point(new)
        if returned:
            return self.nodes, self.found, 0, (f"{CLOSED}: it returned to its start after {len(self.nodes)} points "
                                               f"(arclength {abs(new.arclength - self.start.arclength):.6g})")
        stop = [f for f in self.found if f.kind in settings.stop_at]
        if stop:
            return self.nodes, self.found, 0, f"stopped at the first {stop[0].kind} point, as asked (stop_at)"
        if attempt.at_limit is not None:
            name, limit = attempt.at_limit
            return self.nodes, self.found, 0, f"reached the limit {name} = {limit!r}"
        iterations = attempt.result.iterations if isinstance(attempt.result, Corrected) else 3
        if iterations <= 2:
            self.h = min(self.h * 1.5, settings.max_step)
        elif iterations >= 5:
            self.h = max(self.h * 0.6, settings.min_step)
        self.previous, self.node, self.t = self.node, new, new.t
        return None


def _passes(a, b, point) -> bool:
    """The chord from ``a`` to ``b`` passes ``point`` within :data:`RETURN_SHARE` of its length."""
    chord = b - a
    length2 = float(chord @ chord)
    if length2 == 0.0:
        return False
    s = min(1.0, max(0.0, float((point - a) @ chord) / length2))
    return float(np.linalg.norm(a + s * chord - point)) <= RETURN_SHARE * math.sqrt(length2)


@dataclass(eq=False)
class _Attempt:
    """One predicted-corrected step: the new point (None if the corrector failed), why, and where it ended."""

    new: Node | None
    result: Corrected | str
    at_limit: tuple | None  #: ``(name, limit)`` when the step was cut at a parameter limit
    failed: bool
    turn: float  #: cosine of the tangent's turn


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
    d = problem.dimension
    for j, (lo, hi) in enumerate(bounds):
        value = u_pred[d + j] * problem.scales[j]
        if value > hi or value < lo:
            limit = hi if value > hi else lo
            u_pred = u_pred.copy()
            u_pred[d + j] = limit / problem.scales[j]
            constraint = np.zeros_like(u_pred)
            constraint[d + j] = 1.0
            return u_pred, constraint, (problem.names[j], limit)
    return u_pred, t, None


def _failed_end(problem, node: Node, why: str, settings: Settings, crossing: str = ""):
    near = node.info.nearest_grazing()
    if near < GRAZING_NEAR:
        if not isinstance(problem, MapProblem):
            guard = _nearest_margin(node.info).removeprefix(GUARD)
            tried = f"; {crossing}" if crossing else ""
            return 2, (f"the branch ends at a grazing of the guard {guard!r} (its last point is {near:.3g} from "
                       "touching it, in distance or crossing speed) and does not cross it: no orbit was corrected "
                       f"past it ({why}){tried}")
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
    p0, p1 = parameter(problem, before.u), parameter(problem, node.u)
    value = p1
    if g1 < g0 and p1 != p0:
        value = p1 - g1 * (p1 - p0) / (g1 - g0)
    margin = _nearest_margin(node.info)
    extra = {"test": "end", "value": value, "margin": margin}
    what = "a flange"
    if margin.startswith(GUARD):
        extra["guard"] = margin.removeprefix(GUARD)
        what = f"the guard {extra['guard']!r}"
    return Found("grazing", node, node.info.signature, node.info.signature, abs(value - p1),
                 f"the branch ends at a grazing: its last point is {g1:.3g} from touching {what} (in distance or "
                 "entry speed); the parameter is extrapolated (a secant through the last two points) to where that "
                 "vanishes", len(nodes) - 1, extra)


def _nearest_margin(info: PointInfo) -> str:
    """The name of the margin nearest zero: the flange (``"upper_margin"``, ``"lower_margin"``) or guard."""
    if info.approach:
        near = {side: min(abs(info.upper_margin if side > 0 else info.lower_margin), info.approach[side],
                          info.slowest_entry[side]) for side in (1, -1)}
        return "upper_margin" if near[1] <= near[-1] else "lower_margin"
    finite = {name: abs(m) for name, m in info.margins.items() if math.isfinite(m)}
    return min(finite, key=finite.__getitem__) if finite else ""


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
