"""Crossing a grazing: a branch goes on into the family on the other side of a flange's grazing.

At a grazing the stroboscopic map ``P`` is not smooth: a rigid flange adds a square-root
term (Nordmark 1991; the saltation matrix of an impact at speed ``V`` grows like ``1/V``),
a stiff spring flange a steep ``d^{3/2}`` one. A corrector on ``P(z; p) = z`` cannot step
over it. Two changes of unknowns make both sides regular up to and through the grazing
itself (the idea of VIVID, Ghosh & Simpson 2025, and of COCO's ``hspo`` segments):

* the **virtual** contact-free orbits, the map of the model with the grazed flange taken
  away (:meth:`MapProblem.virtual`): smooth through the grazing, which is the regular zero
  of ``gap - max X`` (``gap + min X`` below) along them, its gradient exact (the
  sensitivity at the extreme, where ``V = 0``);
* for a rigid flange the **impact formulation** of the impacting orbits: unknowns the
  forcing phase ``psi`` of the impact, the impact speed ``v`` and the parameters; the orbit
  leaves the wall at ``(gap, -e v)`` and must return to it after ``n`` periods at speed
  ``v``. It is smooth in ``v`` through ``v = 0``, where it is the grazing orbit.

:func:`cross` locates the grazing on the virtual family (a regular point: Newton on
``[P - z, gap - max X]``), takes the tangent of the family on the far side (the impact
formulation's with ``dv > 0``, the virtual one's pointing into the flange for a spring, or
away from it back to contact-free orbits), steps along it and corrects the far point with
the branch's own problem. Whether the parameter goes on in the same direction (a
*persistent* crossing) or turns back (a *nonsmooth fold*: the two families meet at the
grazing and annihilate) is said in the grazing's label. Only the map, its derivatives, the
vector field and one event quantity (the impact speed) enter.

The pieces that do not depend on the kind of map (:func:`margin`, :func:`locate`,
:func:`grazing_near`, :func:`beyond`) also serve a user system's guards, whose crossing
(:mod:`._crossing`) has its own virtual map and impact formulation (:mod:`._guard_crossing`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._common import oscillator_of
from ..saltation import vector_field
from ._arclength import Corrected, Settings, correct, jacobian_rows, step_past, tangent, unscaled
from ._multi_impact import grazing_of_new_impact, grazing_of_one_impact, impacts_on
from ._newton import along, halving
from ._newton import newton as _newton
from ._points import GUARD, PointInfo, point_info
from ._problem import BOTH, MapEvaluation, MapProblem

__all__ = ["approaching", "cross", "grazing_test", "Crossing", "margin", "contacts_on", "locate", "stripped_sides",
           "crossings_of", "grazing_near", "beyond", "NEAR", "FAR_STEP", "TOUCHES_BOTH"]

#: A flange margin (distance, penetration or impact speed) below which a branch moving towards the
#: grazing hands over to :func:`cross` once its next step would reach it.
NEAR = 0.05
#: The first step (scaled arclength) tried from a grazing into the family beyond it.
FAR_STEP = 0.01
#: The farthest (scaled) a grazing located from a branch's last point may lie (besides ten steps).
REACH = 0.2


@dataclasses.dataclass(eq=False)
class Crossing:
    """A grazing crossed: the grazing orbit (on the virtual family) and the first point beyond it."""

    side: int | str  #: the flange (+1, -1), or a user system's guard
    grazing_u: np.ndarray  #: the grazing's unknowns (z, scaled parameters) on the virtual family
    grazing_ev: MapEvaluation  #: the virtual map's evaluation there
    grazing_info: PointInfo
    accuracy: float  #: last Newton correction of the first parameter at the grazing
    far: Corrected  #: the first point beyond, corrected on the branch's own problem
    case: str  #: "persistent" (the parameter goes on) or "nonsmooth_fold" (it turns back)
    message: str
    #: One impact of several on that flange grazed (:mod:`._multi_impact`), not the orbit's only contact.
    one_of_several: bool = False


def margin(info: PointInfo, side) -> float:
    """Signed distance of an orbit from grazing the flange of ``side`` (negative once it is reached).

    ``side`` is +1 or -1 for a flange of the built-in family, a guard's name for a user system.
    """
    if isinstance(side, str):
        return float(info.margins.get(GUARD + side, math.nan))
    return info.upper_margin if side > 0 else info.lower_margin


def crossings_of(info: PointInfo, guard: str) -> int:
    """How often a user system's orbit crosses ``guard`` in one map period."""
    return sum(count for (name, _), count in info.signature if name == guard)


def approaching(problem: MapProblem, previous, node, h: float, failed: bool = False) -> int:
    """The side of the flange whose grazing the branch reaches within its next step (0: none).

    ``previous`` and ``node`` are the last two accepted points (Nodes). The margin of a side
    must shrink towards zero between them and be within :data:`NEAR`; then the grazing is
    near when the secant reaches zero within 1.5 steps, or the step has just failed.
    """
    if previous is None or problem.stripped:
        return 0
    ds = float(np.linalg.norm(node.u - previous.u))
    for side in (1, -1):
        if math.isinf(problem.walls[(side + 1) // 2]):
            continue
        m0, m1 = margin(previous.info, side), margin(node.info, side)
        if not (math.isfinite(m0) and math.isfinite(m1)) or abs(m1) >= NEAR or abs(m1) >= abs(m0) or m0 * m1 <= 0:
            continue
        if m1 < 0.0 and contacts_on(node.info, side) != 1 and not _only_impacts(problem, node.info, side):
            continue  # several contacts with a spring flange: not one about to vanish (taking the flange away is wrong)
        if m1 < 0.0 and contacts_on(node.info, side) != contacts_on(previous.info, side):
            continue  # the branch has just crossed from another family: its margins do not compare
        rate = abs(m1 - m0) / max(ds, 1e-300)
        if failed or abs(m1) <= 1.5 * h * rate:
            return side
    for side in (1, -1):
        if _touch_near(problem, previous, node, side, ds, h, failed):
            return side
    return 0


def _touch_near(problem: MapProblem, previous, node, side: int, ds: float, h: float, failed: bool) -> bool:
    """A turning point of an orbit that hits a rigid flange approaches it (a new impact is about to be born)."""
    if not problem.rigid or math.isinf(problem.walls[(side + 1) // 2]) or contacts_on(node.info, side) < 1 \
            or not _only_impacts(problem, node.info, side) or abs(margin(node.info, side)) < NEAR \
            or contacts_on(previous.info, side) != contacts_on(node.info, side):
        return False  # (the last condition: the branch has just crossed from another family)
    a0, a1 = previous.info.approach.get(side, math.inf), node.info.approach.get(side, math.inf)
    if not (math.isfinite(a0) and math.isfinite(a1)) or a1 >= NEAR or a1 >= a0:
        return False
    return failed or a1 <= 1.5 * h * abs(a1 - a0) / max(ds, 1e-300)


def _only_impacts(problem: MapProblem, info: PointInfo, side: int) -> bool:
    """Every contact with the flange of ``side`` is an impact on a rigid wall (one of them may graze alone)."""
    return problem.rigid and len(impacts_on(info, side)) == contacts_on(info, side)


def stripped_sides(info: PointInfo, side: int) -> int:
    """The flanges to take away for the grazing of ``side``: that one, or both where the orbit does not touch the other.

    A flange the orbit stays clear of (or only touches, to :data:`TOUCHES_BOTH`) does not change
    it; taken away too, it cannot spoil the virtual map where the orbit grazes both at once
    (the symmetric guide's contact-free orbit).
    """
    other = margin(info, -side)
    return BOTH if math.isfinite(other) and other >= -TOUCHES_BOTH else side


def contacts_on(info: PointInfo, side: int) -> int:
    """How many impacts, contacts or chatters with the flange of ``side`` one map period has."""
    return sum(count for (kind, s), count in info.signature
               if s == side and kind in ("impact", "contact_start", "chatter"))


def grazing_test(virtual, side):
    """``extra(ev, u) -> (psi, row)``: ``gap - side X_extreme`` on the virtual map and its exact gradient.

    For a user system (``side`` a guard's name, ``virtual`` a :class:`GuardlessProblem`): minus the
    guard's value at its extremum nearest to firing (:meth:`GuardlessProblem.grazing_test`).
    """
    if isinstance(side, str):
        return virtual.grazing_test
    gap = virtual.flange_gaps[(side + 1) // 2]
    scales = np.asarray(virtual.scales)

    def test(ev, u):
        rec = ev.recorder
        x, row, sig = rec.top if side > 0 else rec.bottom
        psi = gap - side * x
        grad = -side * np.concatenate([np.asarray(row, float), np.asarray(sig, float) * scales])
        return np.array([psi]), grad[None, :]

    return test


def locate(virtual, side: int | str, u0, tol: float):
    """The grazing orbit of one free parameter: ``(u, ev, last step)`` on the virtual family, or why not."""
    test = grazing_test(virtual, side)

    def fun(u):
        z, params = unscaled(virtual, u)
        ev = virtual.evaluate(z, params)
        if not ev.ok or ev.singular:
            return f"the virtual orbit could not be evaluated: {ev.failure or ev.singular}"
        out = test(ev, u)
        if isinstance(out, str):
            return f"the grazing test could not be evaluated: {out}"
        value, row = out
        return np.concatenate([ev.residual, value]), np.vstack([jacobian_rows(virtual, ev), row]), ev

    return _newton(fun, u0, tol)


class ImpactFormulation:
    """The impacting orbits of a rigid flange with the impact's phase and speed as unknowns (module docstring).

    Unknowns ``w = (psi, v, s_1 .. s_k)``: forcing phase of the impact, impact speed, scaled
    parameters. Residual ``[X(nT) - side gap, V(nT) - side v]`` of the virtual map from
    ``(side gap, -side e v)`` on the section at ``psi``.
    """

    def __init__(self, virtual: MapProblem, side: int):
        self.virtual, self.side = virtual, side
        self.gap = virtual.flange_gaps[(side + 1) // 2]

    def residual(self, w):
        psi, v = float(w[0]), float(w[1])
        problem = self.virtual.at_phase(psi)
        params = tuple(float(s * c) for s, c in zip(w[2:], problem.scales, strict=True))
        sec = problem.section(params)
        e = oscillator_of(self.virtual.model(params)).restitution
        z0 = np.array([self.side * self.gap, -self.side * e * v])
        ev = problem.evaluate(z0, params)
        if not ev.ok or ev.singular:
            return f"the impacting orbit could not be evaluated: {ev.failure or ev.singular}"
        rec = ev.recorder
        F = np.array([rec.x_final - self.side * self.gap, rec.v_final - self.side * v])
        span = problem.span(sec)
        f_end = np.array(vector_field(sec, span, rec.x_final, rec.v_final, rec.final_mode))
        a0 = sec._accel_scalar(0.0, z0[0], z0[1], 0, 1 if z0[1] > 0 else -1 if z0[1] < 0 else -self.side)
        f_start = np.array([z0[1], a0])
        d_psi = (f_end - ev.monodromy @ f_start) / sec.Omega
        d_v = ev.monodromy @ np.array([0.0, -self.side * e]) - np.array([0.0, self.side])
        J = np.column_stack([d_psi, d_v, ev.dp * np.asarray(problem.scales)[None, :]])
        return F, J, ev


def cross(problem: MapProblem, node, side: int, h: float, settings: Settings, bounds=None):
    """Cross the grazing of the flange on ``side`` from ``node``: a :class:`Crossing`, or a string saying why not.

    ``bounds`` are the ``(lo, hi)`` limits of the parameter: a grazing beyond them is not crossed.
    Three steps: the grazing located on the virtual family (:func:`_grazing_near`), the first
    point of the family beyond it (:func:`_far_side`), and the label saying which case it is
    (:func:`_crossing_message`).
    """
    if len(problem.names) != 1:
        return "crossing a grazing is done on branches in one parameter"
    virtual = problem.virtual(stripped_sides(node.info, side))
    from_contact = margin(node.info, side) < 0.0
    new_impact = (problem.rigid and from_contact and abs(margin(node.info, side)) >= NEAR
                  and node.info.approach.get(side, math.inf) < NEAR and _only_impacts(problem, node.info, side))
    if new_impact or (from_contact and contacts_on(node.info, side) > 1):
        crossing = grazing_of_new_impact if new_impact else grazing_of_one_impact
        one = crossing(problem, node, side, h, settings, bounds)
        if isinstance(one, str):
            return one
        u_g, ev_g, info, accuracy, far, case, message = one
        return Crossing(side, u_g, ev_g, info, accuracy, far, case, message, one_of_several=True)
    found = grazing_near(problem, virtual, node, side, h, settings, bounds)
    if isinstance(found, str):
        return found
    u_g, ev_g, error, t_free = found
    far = _far_side(problem, ev_g, u_g, t_free, side, h, settings, from_contact)
    if isinstance(far, str):
        return far
    far, went = far
    came = np.sign(u_g[2] - node.u[2])
    case = "persistent" if came == 0 or went == 0 or came == went else "nonsmooth_fold"
    info = point_info(virtual, ev_g)
    if problem.rigid:
        info = dataclasses.replace(info, multipliers=np.full(2, math.nan, dtype=complex), stability="undefined",
                                   singular="the map is not differentiable at a grazing of a rigid flange (a "
                                            "square-root term, Nordmark 1991)")
    message = _crossing_message(side, problem.rigid, from_contact, case, _grazes_other(virtual, ev_g, side))
    return Crossing(side, u_g, ev_g, info, abs(float(error[2])) * problem.scales[0], far, case, message)


def grazing_near(problem, virtual, node, side: int | str, h: float, settings: Settings, bounds):
    """``(u_g, ev_g, error, t_free)``: the grazing the branch reaches, located on the virtual family, or why not.

    ``t_free`` is the virtual family's tangent at the grazing, oriented towards the contact-free
    side (``gap - max X`` growing along it).
    """
    found = locate(virtual, side, node.u, settings.tol)
    if isinstance(found, str):
        return f"the grazing could not be located on the contact-free orbits: {found}"
    u_g, ev_g, error = found
    distance = float(np.linalg.norm(u_g - node.u))
    if distance > max(10.0 * h, REACH):
        return f"the grazing located is {distance:.3g} away from the branch's last point: not the one it reaches"
    d = problem.dimension
    value = u_g[d] * problem.scales[0]
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        return f"the grazing lies beyond the limits, at {problem.names[0]} = {value!r}"
    rows = jacobian_rows(virtual, ev_g)
    out = grazing_test(virtual, side)(ev_g, u_g)
    if isinstance(out, str):
        return f"the grazing test could not be evaluated at the grazing: {out}"
    row = out[1]
    t_v = np.linalg.svd(rows)[2][-1]
    slope = float(row[0] @ t_v)
    if abs(slope) < 1e-12:
        return "the contact-free family is tangent to the flange's grazing condition here (a degenerate grazing)"
    return u_g, ev_g, error, (t_v if slope > 0 else -t_v)


def _far_side(problem: MapProblem, ev_g, u_g, t_free, side: int, h: float, settings: Settings, from_contact: bool):
    """``(first point beyond the grazing, direction of the parameter there)``, or why there is none.

    From contact: back along the contact-free family. Into a rigid flange: the impact
    formulation. Into a spring flange: the same (a stiff spring's contacting orbits are close
    to those of an elastic impact, e = 1, regular in the impact formulation), else for a
    softer one the virtual family's tangent into the flange.
    """
    if from_contact:
        far = beyond(problem, u_g, t_free, h, settings, side, want_contact=False)
        return far if isinstance(far, str) else (far, np.sign(t_free[2]))
    far = _beyond_rigid(problem, problem.virtual(side), ev_g, u_g, side, h, settings)
    if not isinstance(far, str):
        return far[0], np.sign(far[1])
    if problem.rigid:
        return far
    far = beyond(problem, u_g, -t_free, h, settings, side, want_contact=True)
    return far if isinstance(far, str) else (far, -np.sign(t_free[2]))


def _crossing_message(side: int, rigid: bool, from_contact: bool, case: str, grazes_other: bool) -> str:
    """What a crossed grazing's label says: the flange, its law, the direction and the case."""
    flange = "upper" if side > 0 else "lower"
    law = "rigid" if rigid else "spring"
    into = "into contact with" if not from_contact else "off"
    what = ("the branch goes on in the same direction of the parameter (a persistent crossing)" if case == "persistent"
            else "the parameter turns back there: the contact-free and the contacting family meet at the grazing "
                 "and end together (a nonsmooth fold, the discontinuous grazing case)")
    message = (f"the orbit grazes the {flange} flange ({law}): located as a regular point of the contact-free "
               f"orbits (gap - max X = 0); the branch crosses {into} the flange, and {what}")
    if grazes_other:
        message += ("; the orbit touches the other flange at the same point (a symmetric orbit grazing both at once, "
                    "where the families that contact either flange or both meet): the branch follows one of them")
    return message


#: The other flange's margin below which a grazing orbit touches both flanges at once.
TOUCHES_BOTH = 1e-8


def _grazes_other(virtual: MapProblem, ev, side: int) -> bool:
    """The grazing orbit also touches the flange opposite ``side`` (within :data:`TOUCHES_BOTH`)."""
    gap = virtual.flange_gaps[(1 - side) // 2]
    if not math.isfinite(gap):
        return False
    x = ev.recorder.bottom[0] if side > 0 else ev.recorder.top[0]
    return abs(gap + side * x) < TOUCHES_BOTH * max(1.0, gap)


def beyond(problem, u_g, direction, h, settings, side, want_contact: bool):
    """The first point of the branch's own family a step ``h`` from the grazing along ``direction``."""

    def refusal(result: Corrected) -> str | None:
        m = margin(point_info(problem, result.ev), side)
        if (m < 0.0) != want_contact:
            return f"the corrected point lies on the wrong side of the grazing (margin {m:.3g})"
        t_far = tangent(jacobian_rows(problem, result.ev), direction)
        d = problem.dimension
        if (result.u[d] - u_g[d]) * direction[d] < 0.0 or t_far[d] * direction[d] < 0.0:
            return "a fold lies within the step"  # the family turned back in the parameter: locate it normally
        return None

    # from a step the branch came with (not less than FAR_STEP: right past a stiff flange's grazing the map is
    # steep and its orbits' contacts near-tangent, a corrector struggles there), halved when it fails
    found = step_past(problem, u_g, direction, max(h, FAR_STEP), settings, refusal)
    return found if isinstance(found, Corrected) else f"no orbit was found beyond the grazing: {found}"


def _beyond_rigid(problem, virtual, ev_g, u_g, side, h, settings):
    """The first impacting orbit past a rigid flange's grazing (the impact formulation, then the branch's own)."""
    rec = ev_g.recorder
    t_touch = rec.top_t if side > 0 else rec.bottom_t
    sec = virtual.section(unscaled(virtual, u_g)[1])
    psi = virtual.section_phase + sec.Omega * t_touch
    form = ImpactFormulation(virtual, side)
    w_g = np.concatenate([[psi, 0.0], u_g[2:]])
    out = form.residual(w_g)
    if isinstance(out, str):
        return out
    _, J, _ = out
    t_w = np.linalg.svd(J)[2][-1]
    if t_w[1] < 0.0:
        t_w = -t_w
    if abs(t_w[1]) < 1e-12:
        return "the impacting family leaves the grazing with zero impact speed (a degenerate grazing)"
    why = "no step tried"
    for step in halving(max(h, FAR_STEP), settings.min_step):
        found = along(form.residual, w_g, t_w, step, settings.tol)
        if isinstance(found, str):
            why = found
            continue
        w, (ev, Jw), _ = found
        if w[1] <= 0.0:
            why = f"the impact speed past the grazing is {w[1]:.3g}"
            continue
        t_far = np.linalg.svd(Jw)[2][-1]
        if (w[2] - w_g[2]) * t_w[2] < 0.0 or float(t_far @ t_w) * t_far[2] * t_w[2] < 0.0:
            why = "a fold lies within the step"  # the family turned back in the parameter: locate it normally
            continue
        z = _section_state(virtual, ev, w)
        u_pred = np.concatenate([z, w[2:]])
        chord = u_pred - u_g
        chord /= np.linalg.norm(chord)
        result = correct(problem, u_pred, chord, settings, max_distance=2.0 * step + 1e-9)
        if isinstance(result, Corrected) and margin(point_info(problem, result.ev), side) < 0.0:
            return result, float(t_w[2])
        why = result if isinstance(result, str) else "the corrected orbit does not hit the flange"
    return f"no impacting orbit was found past the grazing: {why}"


def _section_state(virtual: MapProblem, ev, w) -> np.ndarray:
    """The impacting orbit's state on the branch's section (its phase), from its run of the impact formulation.

    The run from the impact is contact-free until it returns to the wall at its end, so the
    virtual run's state at the section time is the real orbit's.
    """
    from ...backends._simulate import simulate

    problem = virtual.at_phase(float(w[0]))
    params = tuple(float(s * c) for s, c in zip(w[2:], problem.scales, strict=True))
    sec = problem.section(params)
    dt = ((virtual.section_phase - float(w[0])) % (2.0 * math.pi)) / sec.Omega
    z0 = ev.z
    if dt == 0.0:
        return np.array([ev.recorder.x_final, ev.recorder.v_final])
    sol = simulate(sec, dt, float(z0[0]), float(z0[1]), backend=virtual.backend, record="stats", **virtual.options)
    return np.array([sol.x_final, sol.v_final])
