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
"""

from __future__ import annotations

import numpy as np

from ._arclength import Corrected, Settings, correct, illinois, jacobian_rows, tangent
from ._nodes import Found, Node, make_node

__all__ = ["cusps"]

#: Illinois iterations at most for one located point.
_LOCATE_STEPS = 60


def _oriented(node: Node, chord) -> np.ndarray:
    """The node's tangent pointing along ``chord`` (the travel from one accepted point to the next)."""
    return node.t if float(node.t @ chord) >= 0.0 else -node.t


def _tangent_at(curve, result: Corrected, extra, along) -> np.ndarray:
    rows = np.vstack([jacobian_rows(curve, result.ev), extra(result.ev, result.u)[1]])
    return tangent(rows, along)


def cusps(curve, nodes: list, extra, settings: Settings) -> list:
    """The cusps of a fold curve between its accepted points ``nodes`` (in arclength order), as :class:`Found`."""
    out = []
    for i in range(len(nodes) - 1):
        a, b = nodes[i], nodes[i + 1]
        chord = b.u - a.u
        h = float(np.linalg.norm(chord))
        if h == 0.0:
            continue
        ta, tb = _oriented(a, chord), _oriented(b, chord)
        if not (ta[2] * tb[2] < 0.0 and ta[3] * tb[3] < 0.0):
            continue
        found = _locate_cusp(curve, a, ta, h, extra, settings, ta[2], tb[2])
        if found is not None:
            node, accuracy, t = found
            out.append(Found("cusp", node, a.info.signature, b.info.signature, accuracy, _cusp_message(curve, t), i,
                             {"test": "cusp"}))
    return out


def _locate_cusp(curve, a: Node, ta, h: float, extra, settings: Settings, fa: float, fb: float):
    """``(node, accuracy, tangent)`` where the first parameter's tangent component vanishes between ``a`` and ``b``."""
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
        best = (result, t)
        value = float(t[2])
        lo, flo, hi, fhi, side = illinois(lo, flo, hi, fhi, s, value, side)
        if value == 0.0 or abs(hi - lo) <= settings.locate_tol:
            break
    if best is None:
        return None
    result, t = best
    node = make_node(curve, result, ta, a.arclength + float(np.linalg.norm(result.u - a.u)), extra)
    # the parameters are quadratic in the arclength at a cusp: a bracket of width d places them to O(d^2)
    accuracy = abs(hi - lo) ** 2 * max(curve.scales) + abs(float(t[3])) ** 2 * max(curve.scales)
    return node, accuracy, t


def _cusp_message(curve, t) -> str:
    p1, p2 = curve.names
    return (f"cusp: the fold's quadratic normal-form coefficient vanishes; {p1} and {p2} turn back together along "
            f"the fold curve (its tangent's parameter components {t[2]:.2g}, {t[3]:.2g}: it runs along the critical "
            "eigenvector), where two fold curves meet and the region of three coexisting orbits between them ends; "
            "the curve goes on along the other fold curve")
