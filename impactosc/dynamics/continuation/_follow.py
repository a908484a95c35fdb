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
from dataclasses import dataclass

import numpy as np

from ._arclength import Corrected, Settings, correct, illinois, parameter
from ._grazing import approaching
from ._nodes import Found, Node, make_node
from ._nonsmooth import across_section, regular_grazing, try_crossing
from ._points import GUARD, SMOOTH_TESTS, PointInfo, contact_counts, point_info, stick_counts
from ._problem import UNSUPPORTED, MapProblem
from ._smooth import vetted
from ._table import signature_text

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
    return _Walk(problem, start, direction, limits, settings, max_points, extra, verify).run()


class _Walk:
    """One direction of a branch: the accepted points, the current step and what was tried where."""

    def __init__(self, problem, start: Node, direction: int, limits, settings: Settings, max_points: int, extra,
                 verify):
        self.problem, self.direction, self.settings = problem, direction, settings
        self.max_points, self.extra, self.verify = max_points, extra, verify
        self.bounds = [limits] if np.ndim(limits) == 1 else list(limits)
        self.start = start
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
        self.nodes.append(new)
        if settings.on_point is not None:
            settings.on_point(new)
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
        if not problem.nonsmooth_steps:
            guard = _nearest_margin(node.info).removeprefix(GUARD)
            return 2, (f"the branch ends at a grazing of the guard {guard!r} (its last point is {near:.3g} from "
                       "touching it, in distance or crossing speed) and does not cross it: continuation crosses the "
                       f"grazings of the built-in family only; no orbit was corrected past it ({why})")
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


# -- location ----------------------------------------------------------------------------
def _corrected_at(problem, a: Node, t, sigma: float, settings: Settings):
    """The branch point at arclength ``sigma`` from ``a`` along ``t`` (or None)."""
    result = correct(problem, a.u + sigma * t, t, settings, max_distance=2.0 * abs(sigma) + 1e-9)
    return result if isinstance(result, Corrected) else None


def locate_between(problem, a: Node, b: Node, t, settings: Settings, index: int) -> list[Found]:
    """Every special point between the accepted points ``a`` and ``b`` (``b`` follows ``a`` along ``t``)."""
    out: list[Found] = []
    h = float(np.dot(b.u - a.u, t))
    d = problem.dimension
    for name, kind in problem.margin_tests:
        if kind not in settings.locate:
            continue
        va, vb = a.info.test_value(name), b.info.test_value(name)
        if math.isfinite(va) and math.isfinite(vb) and va * vb < 0.0:
            regular = None
            if kind == "grazing" and problem.nonsmooth_steps:
                regular = regular_grazing(problem, a, b, name, settings, index)
            out.append(regular or _illinois(problem, a, t, h, name, kind, va, vb, settings, index))
            out[-1].after = b.info.signature
    if a.info.signature == b.info.signature:
        for kind in SMOOTH_TESTS:
            label = kind
            if kind == "fold" and a.t[d] * b.t[d] > 0.0:
                # a multiplier through +1 while the parameter keeps its direction: no fold but a branch
                # point (in the symmetric guide, typically a symmetry-breaking pitchfork)
                label = "branch_point"
            if label not in settings.locate:
                continue
            va, vb = a.info.test_value(kind), b.info.test_value(kind)
            if math.isfinite(va) and math.isfinite(vb) and va * vb < 0.0:
                checked = vetted(problem, _illinois(problem, a, t, h, kind, label, va, vb, settings, index), a, b,
                                 settings)
                if checked is not None:
                    out.append(checked)
    elif (not any(f.kind in ("grazing", "stick_onset") for f in out)
          and _signature_kind(problem, a.info.signature, b.info.signature) in settings.locate):
        out.append(_bisect_signature(problem, a, b, t, h, settings, index))
    return out


def _illinois(problem, a: Node, t, h: float, name: str, kind: str, va: float, vb: float, settings, index) -> Found:
    lo, hi, flo, fhi = 0.0, h, va, vb
    best, side = None, 0
    d = problem.dimension
    clear = [(0.0, va, a)] if va > 0.0 else []  # (arclength, margin, node) where a guard's margin is positive
    converged = False
    # the corrected points at the bracket's ends: where the branch is steep in the state, or turns at the
    # point (a nonsmooth fold), neither the arclength nor the parameter says how far apart they lie
    u_lo, u_hi = a.u, a.u + h * t
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
        f = node.info.test_value(name)
        best = node
        if not math.isfinite(f):
            break
        if f > 0.0:
            clear.append((s, f, node))
        old_hi = hi
        lo, flo, hi, fhi, side = illinois(lo, flo, hi, fhi, s, f, side)
        u_lo, u_hi = (u_hi if lo == old_hi else u_lo), c.u
        width = float(np.linalg.norm(u_hi - u_lo))
        if f == 0.0 or abs(hi - lo) <= settings.locate_tol or width <= settings.locate_tol * max(1.0, abs(c.u[d])):
            converged = True
            break
    found = _found(problem, kind, best or a, a, float(np.linalg.norm(u_hi - u_lo)), index, name)
    if not converged and name.startswith(GUARD) and len(clear) >= 2:
        _extrapolate_clear_side(problem, found, clear)
    return found


def _extrapolate_clear_side(problem, found: Found, clear) -> None:
    """A user system's grazing located by a secant through the two points nearest it on the side clear of the guard.

    Within about ``graze_tol`` of a grazing the map reports the touch and has no derivative, so
    the corrector cannot evaluate the margin there and the bracket stays ~1e-9 wide. On the
    side where the guard does not fire the margin ``-max h`` is a smooth function of the
    parameter (the extremum of a smooth orbit): its secant zero from the two nearest points
    is exact to the square of their distance from it.
    """
    (_, f0, far), (_, f1, near) = sorted(clear, key=lambda item: item[1])[:2][::-1]
    p0, p1 = parameter(problem, far.u), parameter(problem, near.u)
    if f0 == f1 or p0 == p1:
        return
    value = p1 - f1 * (p1 - p0) / (f1 - f0)
    found.node = near
    found.extra = {**found.extra, "value": value}
    found.accuracy = abs(value - p1)
    found.message += ("; the map reports the touch within ~1e-10 of it, so the parameter is the zero of the margin on "
                      "the clear side, by a secant in the parameter through its two nearest points (accuracy: the "
                      "distance to the nearer)")


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
    kind = _signature_kind(problem, before, after)
    found = _found(problem, kind, best, a, abs(hi - lo), index, "signature")
    found.after = after
    if failed:
        found.message += (f"; located only to within {found.accuracy:.3g} in the parameter (no orbit could be "
                          "corrected inside the final bracket)")
    return found


def _signature_kind(problem, before, after) -> str:
    """What a change of the event signature is: a contact appearing or vanishing, a stick, or another border."""
    if not isinstance(problem, MapProblem):
        return problem.signature_kind(before, after)
    if contact_counts(before) != contact_counts(after):
        return "grazing"
    if stick_counts(before) != stick_counts(after):
        return "stick_onset"
    return "border"


def _found(problem, kind: str, node: Node, a: Node, width: float, index: int, test: str) -> Found:
    before, after = a.info.signature, node.info.signature
    message = _describe(kind, test, node, before, after)
    if kind == "stick_onset" and not isinstance(problem, MapProblem):
        message = (f"the entries into a stick mode change ({problem.stick_entries(before)} to "
                   f"{problem.stick_entries(after)} a period): a sliding bifurcation (di Bernardo et al. 2008, ch. 8)")
    extra = {"test": test}
    if kind == "stick_onset":
        extra["bifurcation"] = "crossing-sliding" if test == "stick_margin" else "sliding"
    if test.startswith(GUARD):
        extra["guard"] = test.removeprefix(GUARD)
    elif test == "signature" and not isinstance(problem, MapProblem):
        changed = problem.changed_guards(before, after)
        if changed:
            extra["guard"] = changed
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
        pair = [m for m in mus if m.imag > 0.0]
        return f"a complex pair crosses the unit circle (|mu| = {abs(pair[0] if pair else mus[0]):.6g}): a torus"
    if kind == "grazing" and test.startswith(GUARD):
        return (f"the orbit touches the guard {test.removeprefix(GUARD)!r} tangentially (its value has an extremum "
                "on zero: a crossing of it appears or vanishes)")
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
    return signature_text(sig)


def _contacts(sig) -> str:
    return _text(tuple(contact_counts(sig).items())) if contact_counts(sig) else "none"
