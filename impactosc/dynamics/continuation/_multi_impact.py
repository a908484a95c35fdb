"""One impact of a multi-impact orbit grazing a rigid flange: the orbit with one impact fewer beyond it.

As a parameter changes, one impact of an orbit that hits a rigid flange several times a
period can slow down to zero speed: that impact grazes, and beyond it the orbit misses the
wall there while its other impacts go on. Taking the whole flange away (the crossing of a
single contact, :mod:`._grazing`) would take those away too. Instead the flange is taken
away only in a **window** of forcing phase around the grazing impact: the map of one period
is composed of the real map up to the window, the map without the flange across it, and the
real map after it (:class:`WindowedMap`). It is smooth through the grazing of that one
impact, which is the regular zero of ``gap - max X`` over the window (``gap + min X`` for the
lower flange), with its exact gradient (the sensitivity at the extreme, composed with the
Jacobian of the map before the window). The grazing is located as a regular point of the
windowed family by Newton, the family's tangent there points to the side with one impact
fewer, and the first orbit beyond is corrected on the branch's own (real) map.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ._arclength import Corrected, Settings, correct, tangent, unscaled
from ._newton import newton
from ._points import point_info
from ._problem import MapProblem

__all__ = ["WindowedMap", "window_around", "grazing_of_one_impact", "impacts_on"]

#: The window reaches at most this fraction of the forcing phase distance to the nearest other event on that flange.
_WINDOW_SHARE = 0.5
#: The largest half-width of the window (forcing phase, radians).
_WINDOW_MAX = 0.5 * math.pi


def window_around(problem: MapProblem, node, side: int):
    """``(psi, half width)``: the forcing phase of the slowest impact on ``side`` and a window around it, or why not.

    Phases are counted from the section. The window holds no other impact on that flange
    and stays inside the map's span.
    """
    events = impacts_on(node.info, side)
    if len(events) < 2:
        return "the orbit does not hit that flange more than once a period"
    slow = min(events, key=lambda e: abs(float(e.v)))
    omega = problem.section(unscaled(problem, node.u)[1]).Omega
    span_phase = 2.0 * math.pi * problem.n
    others = [abs(float(e.t) - float(slow.t)) * omega for e in events if e is not slow]
    half = min(_WINDOW_SHARE * min(others + [span_phase - o for o in others]), _WINDOW_MAX)
    phase = float(slow.t) * omega
    if phase - half <= 0.0 or phase + half >= span_phase:
        return "the grazing impact lies too close to the section (the window would cross it)"
    return phase, half


def impacts_on(info, side: int) -> list:
    """The impact events of one map period on the flange of ``side``."""
    return [e for e in info.events if str(e.kind) == "impact" and int(np.sign(e.x)) == side]


class WindowedMap:
    """The map of one period with the flange on ``side`` taken away in a window of forcing phase (module docstring).

    ``segments`` are ``(start, stop, windowed)`` in forcing phase (radians) from ``origin``;
    :meth:`around` builds the usual one, a window around a phase. :meth:`evaluate` returns
    ``(image, M, dp, (x, dx/du), evaluations)`` with ``x`` the extreme of ``side X`` inside the
    (last) window and ``dx/du`` its gradient in the scaled unknowns; or a string saying why it
    failed.
    """

    def __init__(self, problem: MapProblem, side: int, segments, origin: float | None = None):
        self.problem, self.side = problem, side
        #: ``(start, stop, without the flange)`` in forcing phase from ``origin`` (default: the section).
        self.segments = [seg for seg in segments if seg[1] > seg[0]]
        self.origin = problem.section_phase if origin is None else float(origin)

    @classmethod
    def around(cls, problem: MapProblem, side: int, centre: float, half: float) -> WindowedMap:
        """The map of one period from the section, the flange taken away in ``centre -+ half``."""
        end = 2.0 * math.pi * problem.n
        return cls(problem, side, [(0.0, centre - half, False), (centre - half, centre + half, True),
                                   (centre + half, end, False)])

    def segment(self, start: float, stop: float, windowed: bool) -> MapProblem:
        """The problem of one segment: its section at its start, its span its share of the period."""
        base = self.problem.virtual(self.side) if windowed else self.problem
        seg = base.at_phase(self.origin + start)
        width = stop - start

        def span(osc) -> float:  # the segment's share of the period: its parameter derivative follows Omega
            return width / osc.Omega

        seg.span = span  # type: ignore[method-assign]
        return seg

    def evaluate(self, z, params):
        k = len(self.problem.names)
        scales = np.asarray(self.problem.scales)
        state = np.asarray(z, float)
        M, dp = np.eye(2), np.zeros((2, k))
        extreme = None
        evs = []
        for start, stop, windowed in self.segments:
            seg = self.segment(start, stop, windowed)
            ev = seg.evaluate(state, params)
            if not ev.ok or ev.singular:
                return f"the windowed map could not be evaluated: {ev.failure or ev.singular}"
            if windowed:
                x, row, sig = ev.recorder.top if self.side > 0 else ev.recorder.bottom
                row = np.asarray(row, float)
                grad = np.concatenate([row @ M, (row @ dp + np.asarray(sig, float)) * scales])
                extreme = (float(x), grad)
            dp = ev.monodromy @ dp + ev.dp
            M = ev.monodromy @ M
            state = ev.image
            evs.append(ev)
        return state, M, dp, extreme, evs


def _newton_grazing(wmap: WindowedMap, u0, tol: float, gap: float):
    """The windowed family's orbit touching the flange in the window: ``(u, (M, dp, gradient, evaluations), step)``."""
    problem, side = wmap.problem, wmap.side
    scales = np.asarray(problem.scales)

    def fun(u):
        z, params = u[:2], tuple(float(s * c) for s, c in zip(u[2:], scales, strict=True))
        out = wmap.evaluate(z, params)
        if isinstance(out, str):
            return out
        image, M, dp, (x, grad), evs = out
        F = np.concatenate([image - z, [gap - side * x]])
        J = np.vstack([np.hstack([M - np.eye(2), dp * scales[None, :]]), -side * grad[None, :]])
        return F, J, (M, dp, grad, evs)

    solved = newton(fun, u0, tol)
    return f"the grazing of one impact was not solved: {solved}" if isinstance(solved, str) else solved


def grazing_of_one_impact(problem: MapProblem, node, side: int, h: float, settings: Settings, bounds):
    """``(u_g, ev_g, info, accuracy, far, case, message)``: one impact of ``node``'s orbit grazing, or why not."""
    if len(problem.names) != 1 or not problem.rigid:
        return "the grazing of one impact of several is crossed on branches in one parameter of a rigid flange"
    window = window_around(problem, node, side)
    if isinstance(window, str):
        return window
    wmap = WindowedMap.around(problem, side, *window)
    gap = problem.flange_gaps[(side + 1) // 2]
    solved = _newton_grazing(wmap, node.u, settings.tol, gap)
    if isinstance(solved, str):
        return solved
    u_g, (M, dp, grad, _), error = solved
    value = u_g[2] * problem.scales[0]
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        return f"the grazing lies beyond the limits, at {problem.names[0]} = {value!r}"
    rows = np.hstack([M - np.eye(2), dp * np.asarray(problem.scales)[None, :]])
    t = tangent(rows)
    slope = float(-side * grad @ t)  # growth of gap - side X_extreme along t
    if abs(slope) < 1e-12:
        return "the windowed family is tangent to the grazing condition (a degenerate grazing)"
    t_fewer = t if slope > 0 else -t
    count = len(impacts_on(node.info, side))
    far = _fewer(problem, u_g, t_fewer, h, settings, side, count - 1)
    if isinstance(far, str):
        return far
    came, went = np.sign(u_g[2] - node.u[2]), np.sign(t_fewer[2])
    case = "persistent" if came == 0 or went == 0 or came == went else "nonsmooth_fold"
    z_g, params_g = u_g[:2], tuple(float(s * c) for s, c in zip(u_g[2:], problem.scales, strict=True))
    ev_g = problem.evaluate(z_g, params_g)
    if not ev_g.ok:
        return f"the grazing orbit could not be run on the real map: {ev_g.failure}"
    info = dataclasses.replace(point_info(problem, ev_g), multipliers=np.full(2, math.nan, dtype=complex),
                               stability="undefined",
                               singular="the map is not differentiable where an impact on a rigid flange grazes (a "
                                        "square-root term, Nordmark 1991)")
    flange = "upper" if side > 0 else "lower"
    what = ("the branch goes on in the same direction of the parameter (a persistent crossing)" if case == "persistent"
            else "the parameter turns back there: the two families meet at the grazing and end together (a "
                 "nonsmooth fold)")
    message = (f"one of the {count} impacts a period on the {flange} flange (rigid) grazes: its speed reaches zero. "
               "Located as a regular point of the map with that flange taken away in a window around that impact "
               f"only (gap - max X over the window = 0); the branch crosses onto the orbits with {count - 1} "
               f"impact{'s' if count - 1 != 1 else ''} a period, and {what}")
    return u_g, ev_g, info, abs(float(error[2])) * problem.scales[0], far, case, message


def _fewer(problem: MapProblem, u_g, direction, h: float, settings: Settings, side: int, count: int):
    """The first orbit of the real map a step from the grazing along ``direction``, ``count`` impacts on ``side``."""
    why = "no step tried"
    step = 2.0 * max(h, 0.01)
    while step > settings.min_step:
        step *= 0.5
        result = correct(problem, u_g + step * direction, direction, settings, max_distance=2.0 * step + 1e-9)
        if not isinstance(result, Corrected):
            why = result
            continue
        info = point_info(problem, result.ev)
        impacts = len(impacts_on(info, side))
        if impacts != count:
            why = f"the corrected orbit has {impacts} impacts on that flange, not {count}"
            continue
        if (result.u[2] - u_g[2]) * direction[2] < 0.0:
            why = "a fold lies within the step"
            continue
        return result
    return f"no orbit with one impact fewer was found past the grazing: {why}"
