"""The nonsmooth steps of a branch: across a grazing, across an impact on the section, a grazing stepped over.

Each is tried by :func:`._follow.follow` where the plain predictor-corrector cannot go on
(:mod:`._grazing` has the crossing's mathematics); each returns the first point beyond and
the special point it passed, or None.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._common import oscillator_of
from ._arclength import Corrected, Settings, correct, unscaled
from ._crossing import cross
from ._grazing import TOUCHES_BOTH, Crossing, contacts_on, crossings_of, locate, stripped_sides
from ._guard_crossing import GuardlessProblem, replace_info_singular
from ._nodes import Found, Node, make_node
from ._points import GUARD, point_info

__all__ = ["across_section", "crossed", "regular_grazing", "try_crossing"]


def try_crossing(problem, node: Node, side: int, h: float, settings: Settings, bounds, direction: int, index: int,
                 why: dict | None = None):
    """``(first point beyond, grazing)`` of a crossing of the grazing of ``side`` from ``node``, or None.

    ``why["crossing_failure"]`` keeps why the last crossing failed (the branch's end says it).
    """
    result = cross(problem, node, side, h, settings, bounds)
    if isinstance(result, Crossing):
        return crossed(problem, node, result, direction, index)
    if why is not None:
        what = f"the guard {side!r}" if isinstance(side, str) else f"the {'upper' if side > 0 else 'lower'} flange"
        why["crossing_failure"] = f"crossing {what}'s grazing failed: {result}"
    return None


#: A section state this close (relative) to a rigid wall, moving at a speed, is an impact on the section.
AT_SECTION = 1e-6


def across_section(problem, node: Node, t, h: float, settings: Settings, index: int):
    """The branch past an impact that crosses the section, or None.

    As the impact's time passes the section's, the orbit goes on continuously but its state
    on the section jumps across the impact's reset: from just after the impact (at the wall,
    moving away at ``e v``) to just before it (at the wall, moving in at ``v``), or back. The
    corrector cannot follow the jump; the state is mapped across the reset and corrected
    with the parameter a step further.
    """
    if not problem.rigid:
        return None
    z = node.u[:2]
    for side in (1, -1):
        gap = problem.walls[(side + 1) // 2]
        if not (math.isfinite(gap) and abs(side * z[0] - gap) <= AT_SECTION * max(1.0, gap) and z[1] != 0.0):
            continue
        e = float(oscillator_of(problem.model(unscaled(problem, node.u)[1])).restitution)
        if side * z[1] < 0.0:  # after the impact: map back to before it
            if e == 0.0:
                return None
            z_new = np.array([side * gap, -z[1] / e])
        else:
            z_new = np.array([side * gap, -e * z[1]])
        for factor in (0.05, 0.2, 1.0):
            u_pred = np.concatenate([z_new, node.u[2:] + factor * h * t[2:]])
            row = np.zeros_like(u_pred)
            row[2] = 1.0
            result = correct(problem, u_pred, row, settings, max_distance=max(1.0, 2.0 * factor * h))
            if not isinstance(result, Corrected) or not math.isfinite(result.u[0]):
                continue
            chord = result.u - node.u
            chord[:2] = 0.0  # the state jumped: the branch goes on along the parameter
            chord = t if not np.any(chord) else chord / np.linalg.norm(chord)
            new = make_node(problem, result, chord, node.arclength + float(np.linalg.norm(result.u[2:] - node.u[2:])))
            if np.dot(new.t[2:], t[2:]) < 0.0:
                new.t = -new.t
            moment = "after" if side * z[1] < 0.0 else "before"
            border = Found("border", new, node.info.signature, new.info.signature, abs(result.u[2] - node.u[2])
                           * problem.scales[0], f"the impact on the {'upper' if side > 0 else 'lower'} flange crosses "
                           f"the section: the orbit goes on continuously, its state on the section jumps from just "
                           f"{moment} the impact across the impact's reset", index,
                           {"test": "section", "side": side})
            return new, border
    return None


def crossed(problem, node: Node, result: Crossing, direction: int, index: int):
    """The first point past a crossed grazing, and the grazing as a located point (:mod:`._grazing`)."""
    far = result.far
    chord = far.u - result.grazing_u  # away from the grazing along the far family (not from ``node``: at a
    chord = chord / np.linalg.norm(chord)  # nonsmooth fold the parameter turns back there)
    graze_arc = node.arclength + direction * float(np.linalg.norm(result.grazing_u - node.u))
    new = make_node(problem, far, chord, graze_arc + direction * float(np.linalg.norm(far.u - result.grazing_u)))
    gnode = Node(result.grazing_u, chord, Corrected(result.grazing_u, result.grazing_ev, 0), result.grazing_info,
                 graze_arc)
    extra: dict
    if isinstance(result.side, str):  # a user system's guard
        extra = {"test": GUARD + result.side, "guard": result.side}
    else:
        extra = {"test": "upper_margin" if result.side > 0 else "lower_margin", "side": result.side}
    graze = Found("grazing", gnode, node.info.signature, new.info.signature, result.accuracy, result.message,
                  index, {**extra, "case": result.case, "virtual": True, "one_of_several": result.one_of_several})
    return new, graze


def regular_grazing(problem, a: Node, b: Node, name: str, settings: Settings, index: int):
    """A grazing between ``a`` and ``b`` located as a regular point of the contact-free orbits, or None.

    Where a step has gone past a grazing the margin's sign change is located on the
    contact-free orbits with the flange taken away (:func:`._grazing.locate`), not by a
    regula falsi across the nonsmooth point: only where one side of the step touches the
    flange in one contact, and the grazing lies between the two points in the parameter.
    """
    if name.startswith(GUARD):
        return _regular_guard_grazing(problem, a, b, name, settings, index)
    side = 1 if name == "upper_margin" else -1
    if len(problem.names) != 1 or problem.stripped:
        return None
    contact = a if float(getattr(a.info, name)) < 0.0 else b
    if contacts_on(contact.info, side) != 1:
        return None
    free = b if contact is a else a
    virtual = problem.virtual(stripped_sides(free.info, side))
    found = locate(virtual, side, free.u, settings.tol)
    if isinstance(found, str):
        return None
    u_g, ev_g, error = found
    lo, hi = sorted((a.u[2], b.u[2]))
    if not lo - 1e-12 <= u_g[2] <= hi + 1e-12:
        return None
    info = point_info(virtual, ev_g)
    if problem.rigid:
        info = dataclasses.replace(info, multipliers=np.full(2, math.nan, dtype=complex), stability="undefined",
                                   singular="the map is not differentiable at a grazing of a rigid flange")
    node = Node(u_g, free.t, Corrected(u_g, ev_g, 0), info, a.arclength)
    flange = "upper" if side > 0 else "lower"
    return Found("grazing", node, a.info.signature, b.info.signature, abs(float(error[2])) * problem.scales[0],
                 f"the orbit grazes the {flange} flange: located as a regular point of the contact-free orbits "
                 "(gap - max X = 0) between two points of the branch", index,
                 {"test": name, "side": side, "virtual": True})


def _regular_guard_grazing(problem, a: Node, b: Node, name: str, settings: Settings, index: int):
    """:func:`regular_grazing` of a user system's guard: on the orbits of the system without it, or None.

    Only where one side of the step crosses the guard once a period and no other guard grazes
    at the same point (the virtual map would not be smooth there).
    """
    guard = name.removeprefix(GUARD)
    if len(problem.names) != 1 or problem.stripped:
        return None
    contact = a if a.info.test_value(name) < 0.0 else b
    if crossings_of(contact.info, guard) != 1:
        return None
    free = b if contact is a else a
    try:
        virtual = GuardlessProblem(problem, guard)
    except ValueError:
        return None
    found = locate(virtual, guard, free.u, settings.tol)
    if isinstance(found, str):
        return None
    u_g, ev_g, error = found
    d = problem.dimension
    lo, hi = sorted((a.u[d], b.u[d]))
    if not lo - 1e-12 <= u_g[d] <= hi + 1e-12:
        return None
    info = point_info(virtual, ev_g)
    if any(abs(m) < TOUCHES_BOTH for m in info.margins.values()):
        return None
    if virtual.guard.reset:
        info = replace_info_singular(info, f"the map is not differentiable where the orbit grazes the guard {guard!r} "
                                           "with its reset (a square-root term, Nordmark 1991)")
    node = Node(u_g, free.t, Corrected(u_g, ev_g, 0), info, a.arclength)
    return Found("grazing", node, a.info.signature, b.info.signature, abs(float(error[d])) * problem.scales[0],
                 f"the orbit touches the guard {guard!r} tangentially: located as a regular point of the orbits of "
                 "the system with that guard taken away (its value at its extremum = 0) between two points of the "
                 "branch", index, {"test": name, "guard": guard, "virtual": True})
