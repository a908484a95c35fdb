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

from .._common import oscillator_of
from ..saltation import vector_field
from ._arclength import Corrected, Settings, correct, step_past, tangent, unscaled
from ._newton import along, halving, newton
from ._points import point_info
from ._problem import MapProblem

__all__ = ["WindowedMap", "window_around", "window_near_touch", "grazing_of_one_impact", "grazing_of_new_impact",
           "impacts_on"]

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


def _windowed_grazing(problem: MapProblem, node, side: int, window, settings: Settings, bounds):
    """The grazing on the map windowed ``window = (centre, half width)`` around ``side``'s impact, or why not.

    ``_newton_grazing``'s ``(u_g, (M, dp, grad, evaluations), error)`` from ``node``'s point, refused
    when the grazing's parameter lies beyond ``bounds``.
    """
    wmap = WindowedMap.around(problem, side, *window)
    gap = problem.flange_gaps[(side + 1) // 2]
    solved = _newton_grazing(wmap, node.u, settings.tol, gap)
    if isinstance(solved, str):
        return solved
    value = solved[0][2] * problem.scales[0]
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        return f"the grazing lies beyond the limits, at {problem.names[0]} = {value!r}"
    return solved


def grazing_of_one_impact(problem: MapProblem, node, side: int, h: float, settings: Settings, bounds):
    """``(u_g, ev_g, info, accuracy, far, case, message)``: one impact of ``node``'s orbit grazing, or why not."""
    if len(problem.names) != 1 or not problem.rigid:
        return "the grazing of one impact of several is crossed on branches in one parameter of a rigid flange"
    window = window_around(problem, node, side)
    if isinstance(window, str):
        return window
    solved = _windowed_grazing(problem, node, side, window, settings, bounds)
    if isinstance(solved, str):
        return solved
    u_g, (M, dp, grad, _), error = solved
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
    params_g = tuple(float(s * c) for s, c in zip(u_g[2:], problem.scales, strict=True))
    crossed = _crossed(problem, u_g, params_g, np.sign(u_g[2] - node.u[2]), np.sign(t_fewer[2]),
                       "the map is not differentiable where an impact on a rigid flange grazes (a square-root "
                       "term, Nordmark 1991)")
    if isinstance(crossed, str):
        return crossed
    ev_g, info, case, what = crossed
    flange = "upper" if side > 0 else "lower"
    message = (f"one of the {count} impacts a period on the {flange} flange (rigid) grazes: its speed reaches zero. "
               "Located as a regular point of the map with that flange taken away in a window around that impact "
               f"only (gap - max X over the window = 0); the branch crosses onto the orbits with {count - 1} "
               f"impact{'s' if count - 1 != 1 else ''} a period, and {what}")
    return u_g, ev_g, info, abs(float(error[2])) * problem.scales[0], far, case, message


def _crossed(problem: MapProblem, u_g, params: tuple, came: float, went: float, singular: str):
    """``(evaluation, point info, case, what the case means)`` of a grazing orbit crossed, or why not.

    ``came``/``went``: the parameter's direction into and out of the grazing (0: unknown). The
    point's multipliers are NaN and ``singular`` says why: the map has no Jacobian there.
    """
    case = "persistent" if came == 0 or went == 0 or came == went else "nonsmooth_fold"
    ev_g = problem.evaluate(u_g[:2], params)
    if not ev_g.ok:
        return f"the grazing orbit could not be run on the real map: {ev_g.failure}"
    info = dataclasses.replace(point_info(problem, ev_g), multipliers=np.full(2, math.nan, dtype=complex),
                               stability="undefined", singular=singular)
    what = ("the branch goes on in the same direction of the parameter (a persistent crossing)" if case == "persistent"
            else "the parameter turns back there: the two families meet at the grazing and end together (a "
                 "nonsmooth fold)")
    return ev_g, info, case, what


def _fewer(problem: MapProblem, u_g, direction, h: float, settings: Settings, side: int, count: int):
    """The first orbit of the real map a step from the grazing along ``direction``, ``count`` impacts on ``side``."""

    def refusal(result: Corrected) -> str | None:
        impacts = len(impacts_on(point_info(problem, result.ev), side))
        if impacts != count:
            return f"the corrected orbit has {impacts} impacts on that flange, not {count}"
        if (result.u[2] - u_g[2]) * direction[2] < 0.0:
            return "a fold lies within the step"
        return None

    found = step_past(problem, u_g, direction, max(h, 0.01), settings, refusal)
    if isinstance(found, Corrected):
        return found
    return f"no orbit with one impact fewer was found past the grazing: {found}"


# -- the other way: a turning point of an impacting orbit reaches the wall (one impact more) ------------------------
def window_near_touch(problem: MapProblem, node, side: int):
    """``(phase, half width)`` of the turning point nearest the flange of ``side`` that does not reach it, or why not.

    Phases are counted from the section; the window holds no impact on that flange.
    """
    turns = [e for e in node.info.events if str(e.kind) == "reversal" and side * float(e.x) > 0.0]
    impacts = impacts_on(node.info, side)
    if not turns or not impacts:
        return "no turning point next to the flange of an impacting orbit"
    near = max(turns, key=lambda e: side * float(e.x))
    omega = problem.section(unscaled(problem, node.u)[1]).Omega
    span_phase = 2.0 * math.pi * problem.n
    others = [abs(float(e.t) - float(near.t)) * omega for e in impacts]
    half = min(_WINDOW_SHARE * min(others + [span_phase - o for o in others]), _WINDOW_MAX)
    phase = float(near.t) * omega
    if phase - half <= 0.0 or phase + half >= span_phase:
        return "the turning point lies too close to the section (the window would cross it)"
    return phase, half


class _NewImpact:
    """The orbits with one more impact, its phase ``psi`` and speed ``v`` as unknowns (like ``ImpactFormulation``).

    The orbit leaves the wall at ``(side gap, -side e v)`` at forcing phase ``psi`` and must
    return to it after the map's span at speed ``v``; its other impacts happen on the way.
    The flange is taken away in windows of half-width ``d`` at the start and the end, where
    the orbit does not touch the wall but leaves it and arrives at it: the run is smooth in
    ``(psi, v)`` through ``v = 0``, the grazing orbit.
    """

    def __init__(self, problem: MapProblem, side: int, d: float):
        self.problem, self.side, self.d = problem, side, d
        self.gap = problem.flange_gaps[(side + 1) // 2]

    def _params(self, w) -> tuple:
        return tuple(float(s * c) for s, c in zip(w[2:], self.problem.scales, strict=True))

    def _start(self, w):
        e = float(oscillator_of(self.problem.model(self._params(w))).restitution)
        return np.array([self.side * self.gap, -self.side * e * float(w[1])]), e

    def residual(self, w):
        """``(R, dR/dw, evaluations)`` or why not."""
        params, side = self._params(w), self.side
        end = 2.0 * math.pi * self.problem.n
        wmap = WindowedMap(self.problem, side, [(0.0, self.d, True), (self.d, end - self.d, False),
                                                (end - self.d, end, True)], origin=float(w[0]))
        z0, e = self._start(w)
        out = wmap.evaluate(z0, params)
        if isinstance(out, str):
            return out
        state, M, dp, _, evs = out
        R = np.array([state[0] - side * self.gap, state[1] - side * float(w[1])])
        first, last = wmap.segment(*wmap.segments[0]), wmap.segment(*wmap.segments[-1])
        sec0, sec1 = first.section(params), last.section(params)
        motion = 1 if z0[1] > 0 else -1 if z0[1] < 0 else -side
        f_start = np.array([z0[1], sec0._accel_scalar(0.0, z0[0], z0[1], 0, motion)])
        rec = evs[-1].recorder
        f_end = np.array(vector_field(sec1, last.span(sec1), rec.x_final, rec.v_final, rec.final_mode))
        d_psi = (f_end - M @ f_start) / sec0.Omega
        d_v = M @ np.array([0.0, -side * e]) - np.array([0.0, side])
        return R, np.column_stack([d_psi, d_v, dp * np.asarray(self.problem.scales)[None, :]]), evs

    def section_state(self, w) -> np.ndarray | str:
        """The orbit's state on the problem's section, run from its new impact."""
        dphi = (self.problem.section_phase - float(w[0])) % (2.0 * math.pi)
        z0, _ = self._start(w)
        if dphi == 0.0:
            return z0
        segments = [(0.0, min(self.d, dphi), True), (self.d, dphi, False)]
        out = WindowedMap(self.problem, self.side, segments, origin=float(w[0])).evaluate(z0, self._params(w))
        return out if isinstance(out, str) else out[0]


def grazing_of_new_impact(problem: MapProblem, node, side: int, h: float, settings: Settings, bounds):
    """``(u_g, ev_g, info, accuracy, far, case, message)``: a turning point of ``node``'s orbit touching, or why not."""
    if len(problem.names) != 1 or not problem.rigid:
        return "a new impact of an impacting orbit is crossed on branches in one parameter of a rigid flange"
    window = window_near_touch(problem, node, side)
    if isinstance(window, str):
        return window
    centre, half = window
    solved = _windowed_grazing(problem, node, side, window, settings, bounds)
    if isinstance(solved, str):
        return solved
    u_g, (M, dp, grad, evs), error = solved
    params = unscaled(problem, u_g)[1]
    omega = problem.section(params).Omega
    rec = evs[1].recorder
    psi_g = problem.section_phase + (centre - half) + omega * (rec.top_t if side > 0 else rec.bottom_t)
    d = 0.5 * min(psi_g - problem.section_phase - (centre - half), problem.section_phase + centre + half - psi_g)
    count = len(impacts_on(node.info, side))
    far = _more(problem, _NewImpact(problem, side, d), np.concatenate([[psi_g, 0.0], u_g[2:]]), u_g, h, settings,
                side, count + 1)
    if isinstance(far, str):
        return far
    far, went = far
    crossed = _crossed(problem, u_g, params, np.sign(u_g[2] - node.u[2]), went,
                       "the map is not differentiable where an orbit grazes a rigid flange (a square-root term, "
                       "Nordmark 1991)")
    if isinstance(crossed, str):
        return crossed
    ev_g, info, case, what = crossed
    flange = "upper" if side > 0 else "lower"
    message = (f"a turning point of the orbit, which hits the {flange} flange (rigid) {count} time"
               f"{'s' if count != 1 else ''} a period, grazes the flange: a new impact is born. Located as a regular "
               "point of the map with that flange taken away in a window around the turning point only (gap - max X "
               f"over the window = 0); the branch crosses onto the orbits with {count + 1} impacts a period (entered "
               f"with the new impact's phase and speed as unknowns), and {what}")
    return u_g, ev_g, info, abs(float(error[2])) * problem.scales[0], far, case, message


def _more(problem: MapProblem, form: _NewImpact, w_g, u_g, h: float, settings: Settings, side: int, count: int):
    """``(first orbit with one impact more, direction of the parameter)`` past the grazing, or why not."""
    out = form.residual(w_g)
    if isinstance(out, str):
        return out
    t_w = np.linalg.svd(out[1])[2][-1]
    t_w = t_w if t_w[1] > 0.0 else -t_w
    if abs(t_w[1]) < 1e-12:
        return "the family with the new impact leaves the grazing with zero impact speed (a degenerate grazing)"
    why = "no step tried"
    for step in halving(max(h, 0.01), settings.min_step):
        found = along(form.residual, w_g, t_w, step, settings.tol)
        if isinstance(found, str):
            why = found
            continue
        w = found[0]
        if w[1] <= 0.0:
            why = f"the new impact's speed past the grazing is {w[1]:.3g}"
            continue
        z = form.section_state(w)
        if isinstance(z, str):
            why = z
            continue
        u_pred = np.concatenate([z, w[2:]])
        chord = (u_pred - u_g) / np.linalg.norm(u_pred - u_g)
        result = correct(problem, u_pred, chord, settings, max_distance=2.0 * step + 1e-9)
        if not isinstance(result, Corrected):
            why = result
            continue
        impacts = len(impacts_on(point_info(problem, result.ev), side))
        if impacts != count:
            why = f"the corrected orbit has {impacts} impacts on that flange, not {count}"
            continue
        return result, float(np.sign(t_w[2]))
    return f"no orbit with one impact more was found past the grazing: {why}"
