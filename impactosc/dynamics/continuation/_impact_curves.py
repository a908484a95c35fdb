"""Fold and period-doubling curves of single-impact orbits of a rigid flange, in the impact's phase and speed.

On the stroboscopic section the monodromy matrix of an impacting orbit grows like ``1/v``
(``v`` the impact speed) and its fold test with it: a fold curve in two parameters crawls
as it approaches zero impact speed, and stops short of where it ends. In the impact
formulation (:class:`._grazing.ImpactFormulation`: unknowns the impact's forcing phase
``psi``, its speed ``v`` and the parameters; residual ``R`` of the return to the wall) the
family is smooth through ``v = 0``, and a fold of the family is where the parameter is
extremal along it: where ``dR/d(psi, v)`` is singular,

    g(w) = det dR/d(psi, v) = 0,

a smooth condition through ``v = 0`` as well. A period doubling is where the monodromy
``S M`` (``M`` of the flight from the wall back to it, ``S`` the impact's saltation matrix,
``~1/v``) has a multiplier -1: ``v det(S M + I) = 0``, smooth through ``v = 0`` too. A curve is followed by
pseudo-arclength on ``[R; g] = 0`` in ``w = (psi, v, s_1, s_2)``; where ``v`` reaches zero the
fold meets the grazing: the **resonant grazing** point, where the square-root term of the
grazing map vanishes (the forcing frequency a rational multiple of the damped natural one,
Ghosh & Simpson 2025). It is located as the regular zero of the unknown ``v`` and the curve
ends there, labelled. Every point is verified as an orbit of the real model on the
branch's section before it is accepted.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._common import oscillator_of
from ._arclength import Corrected, Settings, scaled
from ._grazing import ImpactFormulation, _newton, _section_state
from ._nodes import Found, Node
from ._points import point_info
from ._problem import MapProblem

__all__ = ["single_impact_side", "fold_curve", "zero_speed_tests"]

_FD = 1e-7
_NAMES = {"fold": "fold", "period_doubling": "period doubling"}
#: An orbit rerun from a point of the curve must return to within this relative distance.
VERIFY_ORBIT = 1e-8


def single_impact_side(curve: MapProblem, ev) -> int:
    """The side of a rigid flange an orbit hits exactly once a map period, touching nothing else (0: none)."""
    if not curve.rigid or not ev.ok:
        return 0
    events: Any = point_info(curve, ev).events
    kinds = [(str(e.kind), int(np.sign(e.x))) for e in events]
    impacts = [side for kind, side in kinds if kind == "impact"]
    others = [kind for kind, _ in kinds if kind in ("contact_start", "chatter", "stick")]
    return impacts[0] if len(impacts) == 1 and not others else 0


class _CurveSystem:
    """``[R(w); g(w)]`` and its Jacobian (module docstring); ``g`` the fold's or the period doubling's test."""

    def __init__(self, virtual: MapProblem, side: int, kind: str):
        self.form = ImpactFormulation(virtual, side)
        self.kind = kind

    def _g(self, w):
        out = self.form.residual(w)
        if isinstance(out, str):
            return out
        F, J, ev = out
        if self.kind == "fold":
            return F, J, float(np.linalg.det(J[:, :2])), ev
        return F, J, self._period_doubling(w, ev), ev

    def _period_doubling(self, w, ev) -> float:
        """``v det(S M + I)``: smooth through ``v = 0`` (``S`` the impact's saltation matrix, ``M`` the free flight's).

        ``S = [[-e, 0], [(a+ + e a-) / V-, -e]]`` with ``V- = side v``, so ``v S`` is regular and
        ``v det(S M + I) = v (e^2 det M - e tr M + 1) + side (a+ + e a-) M_12``.
        """
        problem = self.form.virtual.at_phase(float(w[0]))
        params = tuple(float(s * c) for s, c in zip(w[2:], problem.scales, strict=True))
        sec = problem.section(params)
        e = oscillator_of(self.form.virtual.model(params)).restitution
        v, side, gap = float(w[1]), self.form.side, self.form.gap
        span = problem.span(sec)
        motion = side if v != 0.0 else -side
        a_minus = sec._accel_scalar(span, side * gap, side * v, 0, motion)
        a_plus = sec._accel_scalar(span, side * gap, -side * e * v, 0, -motion if v != 0.0 else -side)
        M = ev.monodromy
        return float(v * (e * e * np.linalg.det(M) - e * np.trace(M) + 1.0) + side * (a_plus + e * a_minus) * M[0, 1])

    def __call__(self, w):
        base = self._g(w)
        if isinstance(base, str):
            return base
        F, J, g, ev = base
        grad = np.zeros(len(w))
        for i in range(len(w)):
            d = np.zeros(len(w))
            d[i] = _FD * max(1.0, abs(w[i]))
            up, down = self._g(w + d), self._g(w - d)
            if isinstance(up, str) or isinstance(down, str):
                return up if isinstance(up, str) else down
            grad[i] = (up[2] - down[2]) / (2.0 * d[i])
        return np.concatenate([F, [g]]), np.vstack([J, grad[None, :]]), ev


def zero_speed_tests(virtual: MapProblem, side: int, w) -> tuple[float, float] | str:
    """``(fold test, period-doubling test)`` of the impacting family at ``w = (psi, v, s...)``, or why not.

    At zero impact speed (a grazing orbit) both reduce to ``(1 + e) a M_12`` up to a positive
    factor (``a`` the acceleration at the grazing, ``M`` the flight's monodromy from it); the
    fold test is ``det dR/d(psi, v)``, proportional to ``d p / d v`` along the impacting family,
    so its sign says on which side of the grazing the family lies.
    """
    fold = _CurveSystem(virtual, side, "fold")._g(w)
    if isinstance(fold, str):
        return fold
    F, J, g, ev = fold
    return g, _CurveSystem(virtual, side, "period_doubling")._period_doubling(w, ev)


def fold_curve(curve: MapProblem, z0, params0, side: int, bounds, settings: Settings, kind: str = "fold"):
    """Follow the fold (or the period doubling, ``kind``) through ``(z0, params0)`` in the impact formulation.

    Returns ``(nodes, found, ends, start_index)`` for :func:`._assembly.assemble`, or a
    string saying why the start could not be solved.
    """
    virtual = curve.virtual(side)
    system = _CurveSystem(virtual, side, kind)
    start = _start(curve, virtual, z0, params0)
    if isinstance(start, str):
        return start
    solved = _newton(lambda w: _with_row(system, w, np.eye(len(start))[3], start), start, settings.tol)
    if isinstance(solved, str):
        return f"the fold could not be solved in the impact formulation: {solved}"
    w0 = solved[0]
    t0 = _tangent(system, w0, None)
    if isinstance(t0, str):
        return t0
    if t0[3] < 0.0:
        t0 = -t0
    node0 = _node(curve, virtual, w0, solved[1], t0, 0.0)
    if isinstance(node0, str):
        return f"the fold's orbit was not verified: {node0}"
    sides = [_follow(curve, virtual, system, w0, d * t0, d, bounds, settings, kind) for d in (-1, 1)]
    back, fwd = sides
    nodes = list(reversed(back[0])) + [node0] + fwd[0]
    nb = len(back[0])
    found = [_reindexed(f, nb - 1 - f.index - 1) for f in back[1]] + [_reindexed(f, nb + 1 + f.index) for f in fwd[1]]
    return nodes, found, [back[2], fwd[2]], nb


def _reindexed(found: Found, index: int) -> Found:
    found.index = index
    return found


def _start(curve: MapProblem, virtual: MapProblem, z0, params0):
    """``w`` of the orbit through ``z0``: its impact's phase and speed, from a run of the real model."""
    ev = curve.evaluate(np.asarray(z0, float), params0)
    if not ev.ok:
        return f"the fold's orbit could not be run: {ev.failure}"
    events: Any = point_info(curve, ev).events
    impacts = [e for e in events if str(e.kind) == "impact"]
    if len(impacts) != 1:
        return "the fold's orbit does not hit the flange exactly once a period"
    sec = curve.section(params0)
    psi = curve.section_phase + sec.Omega * float(impacts[0].t)
    return np.concatenate([[psi, abs(float(impacts[0].v))], np.asarray(params0) / np.asarray(curve.scales)])


def _with_row(system, w, row, w_pred):
    out = system(w)
    if isinstance(out, str):
        return out
    F, J, ev = out
    return np.concatenate([F, [float(row @ (w - w_pred))]]), np.vstack([J, row[None, :]]), ev


def _tangent(system, w, previous):
    out = system(w)
    if isinstance(out, str):
        return out
    t = np.linalg.svd(out[1])[2][-1]
    if previous is not None and float(t @ previous) < 0.0:
        t = -t
    return t / np.linalg.norm(t)


def _node(curve: MapProblem, virtual: MapProblem, w, ev, t, arclength: float):
    """The point as a :class:`Node` of ``curve`` (its state on the section, rerun on the real model)."""
    z = _section_state(virtual, ev, w)
    params = tuple(float(s * c) for s, c in zip(w[2:], curve.scales, strict=True))
    real = curve.evaluate(z, params)
    if not real.ok or real.singular:
        return real.failure or real.singular
    miss = float(np.linalg.norm(real.residual))
    if not miss <= VERIFY_ORBIT * max(1.0, float(np.linalg.norm(z))):
        return f"its orbit, rerun, misses its start by {miss:.3g}"
    u = scaled(curve, z, params)
    return Node(u, np.concatenate([[0.0, 0.0], t[2:]]), Corrected(u, real, 0), point_info(curve, real), arclength)


def _follow(curve, virtual, system, w0, t, direction: int, bounds, settings: Settings, kind: str):
    """One direction of the fold curve: ``(nodes, found, (status, message))``."""
    nodes: list[Node] = []
    found: list[Found] = []
    w, h = w0, settings.step
    arclength = 0.0
    while len(nodes) < settings.max_points:
        w_pred = w + h * t
        limit = _beyond(w_pred, curve, bounds)
        row = t
        if limit is not None:
            j, value = limit
            w_pred = w + (value / curve.scales[j] - w[2 + j]) / t[2 + j] * t
            row = np.zeros(len(w))
            row[2 + j] = 1.0
        solved = _newton(lambda x, row=row, w_pred=w_pred: _with_row(system, x, row, w_pred), w_pred, settings.tol)
        if isinstance(solved, str) or np.linalg.norm(solved[0] - w_pred) > 2.0 * h:
            h *= 0.5
            if h < settings.min_step:
                why = solved if isinstance(solved, str) else "the corrector left the curve"
                return nodes, found, (-1, f"the step fell below min_step = {settings.min_step:g}: {why}")
            continue
        w_new, ev = solved[0], solved[1]
        if w_new[1] < 0.0:  # the fold's impact speed reaches zero within the step: the resonant grazing
            end = _resonant_grazing(curve, virtual, system, w, w_new, settings, len(nodes) - 1, kind)
            if isinstance(end, str):
                return nodes, found, (-1, end)
            found.append(end)
            return nodes, found, (0, f"the {_NAMES[kind]} curve ends at a resonant grazing (labelled): its orbit's "
                                     "impact speed reaches zero, and its continuation lies on inadmissible orbits")
        t_new = _tangent(system, w_new, t)
        if isinstance(t_new, str):
            return nodes, found, (-1, t_new)
        arclength += direction * float(np.linalg.norm(w_new - w))
        node = _node(curve, virtual, w_new, ev, t_new, arclength)
        if isinstance(node, str):
            h *= 0.5
            if h < settings.min_step:
                return nodes, found, (-1, f"a point of the fold curve was not verified: {node}")
            continue
        nodes.append(node)
        w, t = w_new, t_new
        if limit is not None:
            name = curve.names[limit[0]]
            return nodes, found, (0, f"reached the limit {name} = {limit[1]!r}")
        h = min(1.5 * h, settings.max_step)
    return nodes, found, (1, f"stopped after max_points = {settings.max_points} points")


def _beyond(w, curve, bounds):
    for j, (lo, hi) in enumerate(bounds):
        value = w[2 + j] * curve.scales[j]
        if value > hi or value < lo:
            return j, hi if value > hi else lo
    return None


def _resonant_grazing(curve, virtual, system, w_a, w_b, settings, index, kind):
    """The fold curve's point of zero impact speed between ``w_a`` and ``w_b``, as a located point."""
    row = np.zeros(len(w_a))
    row[1] = 1.0
    guess = w_a + (w_a[1] / (w_a[1] - w_b[1])) * (w_b - w_a)
    solved = _newton(lambda x: _with_row(system, x, row, np.zeros(len(w_a))), guess, settings.tol)
    if isinstance(solved, str):
        return f"the resonant grazing could not be located: {solved}"
    w, ev, error = solved
    z = _section_state(virtual, ev, w)
    params = tuple(float(s * c) for s, c in zip(w[2:], curve.scales, strict=True))
    u = scaled(curve, z, params)
    sec = virtual.section(params)
    virtual_ev = virtual.evaluate(z, params)
    info = point_info(virtual, virtual_ev) if virtual_ev.ok and not virtual_ev.singular else None
    if info is None:
        return "the resonant grazing's orbit could not be evaluated"
    period = 2.0 * math.pi / sec.Omega
    node = Node(u, np.zeros(len(u)), Corrected(u, virtual_ev, 0), info, 0.0)
    side = virtual.stripped
    flange = "upper" if side > 0 else "lower"
    message = (f"resonant grazing: the {_NAMES[kind]} of the single-impact orbits meets the grazing of the {flange} "
               f"flange (zero impact speed), where the square-root term of the grazing map vanishes (the period "
               f"{period:.12g} of the forcing resonates with the damped free motion); the {_NAMES[kind]} curve ends "
               "here")
    accuracy = abs(float(error[2])) * curve.scales[0]
    return Found("resonant_grazing", node, (), (), accuracy, message, index,
                 {"test": "upper_margin" if side > 0 else "lower_margin", "side": side})
