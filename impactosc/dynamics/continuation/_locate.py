"""Locating the special points between two accepted points of a branch.

A change of sign of a test function (a margin, or a test function of the multipliers) is
located by Illinois on the arclength, each evaluation a corrected point; a smooth point is
then checked on its critical value (:func:`._smooth.vetted`); a change of the event
signature by bisection. A flange's grazing of the built-in family is located as a regular
point of its contact-free orbits (:func:`._nonsmooth.regular_grazing`); a user system's
grazing, where the map reports the touch within ~1e-10 of it, by a secant on the clear side.
"""

from __future__ import annotations

import math

import numpy as np

from ._arclength import Corrected, Settings, correct, illinois, parameter
from ._nodes import Found, Node
from ._nonsmooth import regular_grazing
from ._points import GUARD, SMOOTH_TESTS, contact_counts, point_info, stick_counts
from ._problem import MapProblem
from ._smooth import vetted
from ._table import signature_text

__all__ = ["locate_between"]


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
