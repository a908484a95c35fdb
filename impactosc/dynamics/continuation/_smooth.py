"""The smooth special points (fold, branch point, period doubling, Neimark-Sacker): checked where they are located.

A test function of the multipliers changes sign between two points of a branch; Illinois
on the arclength (:func:`._follow.locate_between`) finds where. :func:`vetted` then checks
that the critical multiplier really lies on its critical value there (+1, -1, the unit
circle, to :data:`LOCATED`), and when it does not, locates the zero again in the parameter
itself, where a branch point does not disturb the corrector as it disturbs the arclength
one. Only what neither finds is labelled by what the multipliers do: a jump across the
critical value at a nonsmooth point (a border), or "not located" with its bracket. The
label does not depend on the step the branch took to the point.
"""

from __future__ import annotations

import math

import numpy as np

from ._arclength import Corrected, Settings, correct, illinois, parameter
from ._nodes import Found, Node
from ._points import point_info

__all__ = ["vetted", "critical_miss", "LOCATED", "SMOOTH_TEST_OF"]

#: Largest distance of a located point's critical multiplier from +1 (fold, branch point), -1 (period
#: doubling) or the unit circle (Neimark-Sacker): the yardstick of a smooth crossing.
LOCATED = 1e-6
#: Kinds located on a test function of the multipliers, and the test's name.
SMOOTH_TEST_OF = {"fold": "fold", "branch_point": "fold", "period_doubling": "period_doubling",
                  "neimark_sacker": "neimark_sacker"}
#: A bracket narrower than this (relative to the parameter) is a located point: a critical multiplier
#: still far from its value there has jumped across it.
NARROW = 1e-9


def vetted(problem, f: Found, a: Node, b: Node, settings: Settings) -> Found | None:
    """``f``, located by Illinois between ``a`` and ``b``, where its test function vanishes (module docstring).

    Returns ``f`` as it is when its critical multiplier lies within :data:`LOCATED` of its
    critical value; None at a neutral saddle (the Neimark-Sacker test of more than two
    multipliers vanishes there too: no bifurcation); else ``f`` moved to the zero located in
    the parameter (its ``extra["test"]`` says so); else relabelled a border (the multipliers
    jump across the critical value within a narrow bracket: the map is not smooth there) or
    marked "not located".
    """
    test = SMOOTH_TEST_OF[f.kind]
    if critical_miss(f.node.info.multipliers, test) <= LOCATED:
        return f
    if test == "neimark_sacker" and neutral_saddle(f.node.info.multipliers):
        return None
    va, vb = (float(n.info.tests[test]) for n in (a, b))
    pa, pb = parameter(problem, a.u), parameter(problem, b.u)
    again = None
    # in one parameter only: a boundary's point has more unknowns than a fixed parameter pins
    if len(problem.names) == 1 and all(map(math.isfinite, (va, vb))) and va * vb < 0.0 and pa != pb:
        again = locate_in_parameter(problem, a, b, test, settings)
    if again is not None and critical_miss(again[0].info.multipliers, test) <= LOCATED:
        f.node, f.accuracy = again
        f.extra = {**f.extra, "test": f"{test} (in the parameter)"}
        return f
    if f.accuracy <= NARROW * max(1.0, abs(parameter(problem, f.node.u))):
        return _jump(f, test)
    if len(problem.names) > 1:
        return f  # on a boundary: located as well as its bracket allows
    return _not_located(problem, f, again, test, (pa, pb, va, vb))


def _jump(f: Found, test: str) -> Found:
    """``f`` relabelled a border: its multipliers jump across the critical value instead of crossing it."""
    miss = critical_miss(f.node.info.multipliers, test)
    critical = {"fold": "+1", "period_doubling": "-1"}.get(test, "the unit circle")
    f.kind = "border"
    f.message = (f"the multipliers jump across {critical} here (the nearest is {miss:.2g} from it at the located "
                 "point) though the event signature stays the same: the map is not smooth here (e.g. just past a "
                 "grazing), no smooth bifurcation")
    return f


def _not_located(problem, f: Found, again, test: str, bracket) -> Found:
    """``f`` marked "not located", at the best point reached or the interpolated zero, with its bracket."""
    pa, pb, va, vb = bracket
    name = problem.names[0]
    if again is not None and math.isfinite(float(again[0].info.tests[test])):
        f.node, f.accuracy = again
        where = f"located only to within {f.accuracy:.3g} in {name}"
    elif math.isfinite(va) and math.isfinite(vb) and va != vb:
        f.extra = {**f.extra, "value": pa + va * (pb - pa) / (va - vb)}
        f.accuracy = abs(pb - pa)
        where = (f"somewhere between {name} = {pa!r} and {pb!r}; the parameter given is the zero of the test "
                 "function interpolated between the two branch points")
    else:
        where = f"within {f.accuracy:.3g} in {name}"
    f.message = (f"not located: {f.message}, {where} (the correctors fail next to it; the last point reached has "
                 f"test value {float(f.node.info.tests[test]):.3g} and multipliers "
                 f"{np.round(f.node.info.multipliers, 6)})")
    return f


def neutral_saddle(mus) -> bool:
    """Two real multipliers whose product is 1 (to :data:`LOCATED`): where the bialternate test vanishes, no torus."""
    mus = np.asarray(mus, dtype=complex)
    real = [m.real for m in mus if m.imag == 0.0]
    return any(abs(a * b - 1.0) <= LOCATED for i, a in enumerate(real) for b in real[i + 1:])


def critical_miss(mus, test: str) -> float:
    """Distance of the multiplier nearest the critical value of ``test`` from it (inf when none is defined)."""
    mus = np.asarray(mus, dtype=complex)
    if not np.all(np.isfinite(mus)):
        return math.inf
    if test == "neimark_sacker":
        return float(np.min(np.abs(np.abs(mus) - 1.0))) if np.any(mus.imag != 0.0) else math.inf
    return float(np.min(np.abs(mus - (1.0 if test == "fold" else -1.0))))


def locate_in_parameter(problem, a: Node, b: Node, test: str, settings: Settings):
    """``(node, accuracy)`` at the zero of ``test`` between the branch points ``a`` and ``b``, or None.

    Illinois regula falsi on the parameter; at each value the orbit is corrected with the
    parameter fixed, from the state interpolated between ``a`` and ``b``. Where no orbit
    can be corrected any more (next to the branch point, where it is not isolated), the
    last point computed is kept with the width of the bracket reached as its accuracy.
    """
    d, scale = problem.dimension, problem.scales[0]
    lo, hi = float(a.u[d]), float(b.u[d])
    flo, fhi = (float(n.info.tests[test]) for n in (a, b))
    constraint = np.zeros_like(a.u)
    constraint[d] = 1.0
    best, side = None, 0
    for _ in range(60):
        s = hi - fhi * (hi - lo) / (fhi - flo)
        if not min(lo, hi) < s < max(lo, hi):
            s = 0.5 * (lo + hi)
        w = (s - float(a.u[d])) / (float(b.u[d]) - float(a.u[d]))
        guess = (1.0 - w) * a.u + w * b.u
        guess[d] = s
        c = correct(problem, guess, constraint, settings, max_distance=2.0 * float(np.linalg.norm(b.u - a.u)))
        info = point_info(problem, c.ev) if isinstance(c, Corrected) else None
        value = float(info.tests[test]) if info is not None else math.nan
        if not isinstance(c, Corrected) or info is None or not math.isfinite(value):
            # at the branch point itself the orbit is not isolated (M - I is singular): the
            # bracket reached so far is the accuracy
            return (best, abs(hi - lo) * scale) if best is not None else None
        best = Node(c.u, a.t, c, info, a.arclength)
        lo, flo, hi, fhi, side = illinois(lo, flo, hi, fhi, s, value, side)
        width = abs(hi - lo) * scale
        if value == 0.0 or width <= settings.locate_tol * max(1.0, abs(s * scale)):
            return best, width
    return (best, abs(hi - lo) * scale) if best is not None else None
