"""Codimension-two points on a boundary: located between two points of the followed curve.

A boundary in two parameters (:mod:`._boundary`) is a curve in ``(X, V, p1, p2)``; a
codimension-two point is where a second test function vanishes along it. The tests are
evaluated on the accepted points and a sign change is located by the Illinois variant of
regula falsi on the pseudo-arclength from the point before it, each evaluation a point of
the curve corrected on its own defining equations.

* **Cusp** (``CP``) of a fold curve: the fold's quadratic normal-form coefficient
  ``a = w^T D^2 P (v, v) / 2`` vanishes (Kuznetsov 2004, sec. 8.2). Along the fold curve
  ``g = det(M - I) = 0`` the derivative of ``g`` along the null vector ``v`` of ``M - I`` is
  proportional to ``a``, and the tangent of the curve is ``(v, 0, 0)`` where it vanishes:
  both parameters are extremal there together, and two fold curves meet in the parameter
  plane at a cusp. The test is the first parameter's component of the curve's tangent,
  and a cusp is reported only where the second's changes sign in the same interval (one
  parameter turning alone is a smooth turn of the curve in the plane, no cusp). The curve
  goes on through it: in ``(X, V, p1, p2)`` it is smooth there, and beyond it is the other
  fold curve of the pair.
* **Fold-grazing** (``FG``) and **period-doubling-grazing** (``PDG``) on a rigid flange's
  grazing curve: where a fold or a period-doubling curve of the single-impact orbits meets
  it. Their tests in the impact formulation (:mod:`._impact_curves`: the impact's phase
  ``psi`` and speed ``v`` as unknowns), ``det dR/d(psi, v)`` and ``v det(S M + I)``, are
  evaluated at ``v = 0`` on the grazing orbit. There both reduce to ``(1 + e) a M12`` up to a
  nonzero factor (``a`` the acceleration at the grazing, ``M`` the flight's monodromy from
  it): zero where the square-root term of the grazing map vanishes, the resonant grazing, so
  on a rigid flange FG and PDG come together. The fold test is ``dp/dv`` along the impacting
  family, so the grazing's case (persistent or nonsmooth fold) changes across an FG point.
  A spring flange's map is C^1 at its grazing: no fold curve ends on its grazing curve (a
  stiff one has a cusp next to it instead), and none is reported there.
* **Grazing-stick** (``GS``) on a grazing curve of friction orbits: the stick test
  ``beta_s - |f_net|`` at the velocity zero nearest to sticking vanishes too, where the
  crossing-sliding curve meets the grazing curve. The flange exerts no force at the touch,
  so the grazing condition stays regular and the curve goes on as the grazing of the
  stick-slip orbits.
"""

from __future__ import annotations

import math

import numpy as np

from ._arclength import Corrected, Settings, correct, illinois, jacobian_rows, tangent, unscaled
from ._guard_crossing import GuardImpact, GuardlessProblem
from ._impact_curves import zero_speed_tests
from ._nodes import Found, Node, make_node
from ._points import GUARD
from ._problem import MapProblem

__all__ = ["codim2_points", "cusps", "grazing_points", "grazing_stick_points", "zeros_along",
           "guard_fold_grazing_points"]

#: Illinois iterations at most for one located point.
_LOCATE_STEPS = 60


def codim2_points(curve, kind: str, test: str, nodes: list, extra, settings: Settings, stick_test) -> list:
    """The codimension-two points along the boundary ``nodes`` of a ``kind`` point that solves the test ``test``.

    A fold curve: its cusps. A grazing curve (``test`` a flange's margin): its fold-grazing and
    period-doubling-grazing points (rigid flange) and its grazing-stick points (friction);
    ``stick_test(curve) -> extra(ev, u)`` is the boundary's stick test.
    """
    if kind == "fold":
        return cusps(curve, nodes, extra, settings) if "cusp" in settings.locate else []
    if test.startswith(GUARD) and isinstance(curve, GuardlessProblem):
        return guard_fold_grazing_points(curve, nodes, extra, settings)
    if test not in ("upper_margin", "lower_margin"):
        return []
    side = 1 if test == "upper_margin" else -1
    stick = stick_test(curve)
    return (grazing_points(curve, nodes, extra, settings, side)
            + grazing_stick_points(curve, nodes, extra, settings, side, lambda ev, u: stick(ev, u)[0][0]))


def _oriented(node: Node, chord) -> np.ndarray:
    """The node's tangent pointing along ``chord`` (the travel from one accepted point to the next)."""
    return node.t if float(node.t @ chord) >= 0.0 else -node.t


def _tangent_at(curve, result: Corrected, extra, along) -> np.ndarray:
    rows = np.vstack([jacobian_rows(curve, result.ev), extra(result.ev, result.u)[1]])
    return tangent(rows, along)


def cusps(curve, nodes: list, extra, settings: Settings) -> list:
    """The cusps of a fold curve between its accepted points ``nodes`` (in arclength order), as :class:`Found`."""
    out = []
    # the tangents oriented along the travel, continuously from the first point on
    tangents = [nodes[0].t] if nodes else []
    for node in nodes[1:]:
        tangents.append(node.t if float(node.t @ tangents[-1]) >= 0.0 else -node.t)
    d = curve.dimension  # the tangent's components: the state, then the two parameters
    second = [i for i in range(len(nodes) - 1) if tangents[i][d + 1] * tangents[i + 1][d + 1] < 0.0]
    for i in range(len(nodes) - 1):
        a, b = nodes[i], nodes[i + 1]
        chord = b.u - a.u
        h = float(np.linalg.norm(chord))
        ta, tb = _oriented(a, chord), _oriented(b, chord)
        # the second parameter turns in the same interval, or a neighbour (a node may fall between the two zeros)
        if h == 0.0 or not ta[d] * tb[d] < 0.0 or not any(abs(j - i) <= 1 for j in second):
            continue
        found = _locate_cusp(curve, a, ta, h, extra, settings, ta[d], tb[d])
        if found is not None:
            node, accuracy, t = found
            out.append(Found("cusp", node, a.info.signature, b.info.signature, accuracy, _cusp_message(curve, t), i,
                             {"test": "cusp"}))
    return out


def _locate_cusp(curve, a: Node, ta, h: float, extra, settings: Settings, fa: float, fb: float):
    """``(node, accuracy, tangent)`` where the first parameter's tangent component vanishes between ``a`` and ``b``."""
    d = curve.dimension
    found = _locate_zero(curve, a, ta, h, extra, settings, lambda result, t: float(t[d]), fa, fb)
    if found is None:
        return None
    result, t, width = found
    node = make_node(curve, result, ta, a.arclength + float(np.linalg.norm(result.u - a.u)), extra)
    # the parameters are quadratic in the arclength at a cusp: a bracket of width d places them to O(d^2)
    accuracy = (width**2 + float(t[d + 1]) ** 2) * max(curve.scales)
    return node, accuracy, t


def _cusp_message(curve, t) -> str:
    p1, p2 = curve.names
    d = curve.dimension
    return (f"cusp: the fold's quadratic normal-form coefficient vanishes; {p1} and {p2} turn back together along "
            f"the fold curve (its tangent's parameter components {t[d]:.2g}, {t[d + 1]:.2g}: it runs along the "
            "critical eigenvector), where two fold curves meet and the region of three coexisting orbits between them "
            "ends; the curve goes on along the other fold curve")


def _locate_zero(curve, a: Node, ta, h: float, extra, settings: Settings, value, fa: float, fb: float):
    """``(corrected, tangent, bracket width)`` where ``value(corrected, tangent)`` vanishes on ``a + [0, h] ta``.

    Illinois regula falsi on the arclength from ``a``; each evaluation a point corrected on
    the curve's own equations (``extra``). None where the corrector or the test fails.
    """
    lo, hi, flo, fhi, side = 0.0, h, float(fa), float(fb), 0
    best = None
    for _ in range(_LOCATE_STEPS):
        s = hi - fhi * (hi - lo) / (fhi - flo)
        if not min(lo, hi) < s < max(lo, hi):
            s = 0.5 * (lo + hi)
        result = correct(curve, a.u + s * ta, ta, settings, extra=extra, max_distance=2.0 * h + 1e-9)
        if not isinstance(result, Corrected):
            return None
        t = _tangent_at(curve, result, extra, ta)
        fs = value(result, t)
        if isinstance(fs, str) or not math.isfinite(fs):
            return None
        best = (result, t)
        lo, flo, hi, fhi, side = illinois(lo, flo, hi, fhi, s, fs, side)
        if fs == 0.0 or abs(hi - lo) <= settings.locate_tol:
            break
    return None if best is None else (*best, abs(hi - lo))


# -- fold-grazing and period-doubling-grazing on a rigid flange's grazing curve ------------------------------------
def _zero_speed(curve, side: int, ev, u):
    """The impacting family's fold and PD tests at the grazing orbit ``(ev, u)`` of the virtual curve."""
    rec = ev.recorder
    params = unscaled(curve, u)[1]
    psi = curve.section_phase + curve.section(params).Omega * (rec.top_t if side > 0 else rec.bottom_t)
    # the tests need the map's state derivatives only: the member at these parameters, none of them free (no
    # parameter stencils to run)
    fixed = MapProblem(curve.model(params), (), curve.n, psi, curve.backend, curve.options, stripped=side)
    return zero_speed_tests(fixed, side, np.array([psi, 0.0]))


_GRAZING_KINDS = (("fold_grazing", 0, "fold"), ("period_doubling_grazing", 1, "period doubling"))


def zeros_along(curve, nodes: list, extra, settings: Settings, kind: str, value, message: str, extra_info: dict,
                values=None):
    """Every zero of the test ``value(corrected, tangent) -> float`` between two points of a curve, as :class:`Found`.

    The test is evaluated on the accepted points ``nodes`` (in arclength order; or given, as
    ``values``); each sign change is located by :func:`_locate_zero`. A test that cannot be
    evaluated (a string) at either end of an interval skips it.
    """
    if values is None:
        values = [value(n.corrected, n.t) for n in nodes]
    out = []
    for i in range(len(nodes) - 1):
        va, vb = values[i], values[i + 1]
        if isinstance(va, str) or isinstance(vb, str) or not va * vb < 0.0:
            continue
        a, b = nodes[i], nodes[i + 1]
        chord = b.u - a.u
        h = float(np.linalg.norm(chord))
        ta = _oriented(a, chord)
        found = _locate_zero(curve, a, ta, h, extra, settings, value, va, vb) if h > 0.0 else None
        if found is None:
            continue
        result, t, width = found
        node = make_node(curve, result, ta, a.arclength + float(np.linalg.norm(result.u - a.u)), extra)
        out.append(Found(kind, node, a.info.signature, b.info.signature, width * max(curve.scales), message, i,
                         dict(extra_info)))
    return out


def grazing_points(curve, nodes: list, extra, settings: Settings, side: int) -> list:
    """The fold-grazing and period-doubling-grazing points of a rigid flange's grazing curve, as :class:`Found`."""
    if not curve.rigid or len(nodes) < 2:
        return []
    out = []
    kinds = [k for k in _GRAZING_KINDS if k[0] in settings.locate]
    both = [_zero_speed(curve, side, n.corrected.ev, n.u) for n in nodes] if kinds else []
    for kind, j, name in kinds:

        def value(result, t, j=j):
            tests = _zero_speed(curve, side, result.ev, result.u)
            return tests if isinstance(tests, str) else tests[j]

        out += zeros_along(curve, nodes, extra, settings, kind, value, _grazing_message(name, side),
                           {"test": kind, "side": side}, [v if isinstance(v, str) else v[j] for v in both])
    return out


def grazing_stick_points(curve, nodes: list, extra, settings: Settings, side: int, stick_value) -> list:
    """The grazing-stick points of a grazing curve of friction orbits, as :class:`Found`.

    ``stick_value(ev, u) -> float`` is the stick test ``beta_s - |f_net|`` at the velocity
    zero nearest to sticking (:func:`._boundary.stick_test`): negative while every reversal
    slides on, positive once one sticks. Where it vanishes on the grazing curve, the orbit
    grazes the flange and its reversal there is about to stick at once.
    """
    if "grazing_stick" not in settings.locate or len(nodes) < 2 or math.isnan(nodes[0].info.stick_margin):
        return []  # no friction: no stick test

    def value(result, t):
        return float(stick_value(result.ev, result.u))

    flange = "upper" if side > 0 else "lower"
    message = (f"grazing-stick: the orbit grazes the {flange} flange and a reversal is on the point of sticking at "
               "the same time (both the grazing test gap - max X and the stick test beta_s - |f_net| vanish): the "
               "crossing-sliding curve (stick onset) meets the grazing curve here. On one side the grazing orbit "
               "slides through its reversals, on the other it sticks; the flange exerts no force at the touch, so "
               "the grazing condition stays regular and the grazing curve goes on, as the grazing of the "
               "stick-slip orbits")
    return zeros_along(curve, nodes, extra, settings, "grazing_stick", value, message,
                       {"test": "grazing_stick", "side": side})


def _grazing_message(name: str, side: int) -> str:
    flange = "upper" if side > 0 else "lower"
    what = ("the fold test of the impacting family, det d(return to the wall)/d(phase, speed), vanishes at zero "
            "impact speed: the family's parameter turns there, so the grazing's case changes across this point "
            "(a persistent crossing on one side, a nonsmooth fold on the other)" if name == "fold"
            else "the period-doubling test v det(S M + I) of the impacting family vanishes at zero impact speed")
    return (f"{name}-grazing: a {name} curve of the single-impact orbits meets the grazing curve of the {flange} "
            f"flange here; {what}. On a rigid flange both tests reduce to (1 + e) a M12 at zero speed (a the "
            "acceleration at the grazing, M12 of the flight's monodromy): this is where the square-root term of the "
            f"grazing map vanishes, the resonant grazing at which the {name} curve ends (RG on it); the grazing curve "
            "goes on")


def guard_fold_grazing_points(curve: GuardlessProblem, nodes: list, extra, settings: Settings) -> list:
    """The fold-grazing points of a user system's grazing curve of a guard with a reset, as :class:`Found`.

    The impacting family of the guard (:class:`._guard_crossing.GuardImpact`: unknowns the
    impact time ``t_i``, the state ``y_-`` before it and the parameters) is smooth through zero
    impact speed; its parameter turns where ``dR/d(t_i, y_-)`` is singular. At the grazing
    orbit of each point of the curve that determinant is the fold test; where it vanishes a
    fold curve of the impacting orbits meets the grazing curve (the resonant grazing, where
    the square-root term of the grazing map vanishes), and the grazing's case changes across
    it. A guard without a reset (a spring's entry) has none.
    """
    if "fold_grazing" not in settings.locate or not curve.guard.reset or len(nodes) < 2:
        return []
    d = curve.dimension

    def value(result, t):
        z, params = unscaled(curve, result.u)
        peak = curve.peak(z, params)
        if isinstance(peak, str):
            return peak
        form = GuardImpact(curve, peak[5])
        out = form.residual(np.concatenate([[peak[3]], peak[4][:d], result.u[d:]]))
        return out if isinstance(out, str) else float(np.linalg.det(out[1][:, :d + 1]))

    message = (f"fold-grazing: a fold curve of the orbits that cross the guard {curve.guard.name!r} with its reset "
               "meets its grazing curve here: the fold test of the impacting family, det dR/d(impact time, state "
               "before it), vanishes at zero crossing speed, where the square-root term of the grazing map "
               "vanishes (the resonant grazing); the grazing's case (persistent or nonsmooth fold) changes across "
               "this point, and the grazing curve goes on")
    return zeros_along(curve, nodes, extra, settings, "fold_grazing", value, message,
                       {"test": "fold_grazing", "guard": curve.guard.name})
