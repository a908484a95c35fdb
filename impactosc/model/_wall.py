"""The force of a rigid flange on a mass resting against it (the wall's push).

Part of the model: :meth:`impactosc.Oscillator.wall_force_integrals` and the exact
backend's compiled loop both call :func:`wall_force_integrals` here.
"""

from __future__ import annotations

import math

import numpy as np

from .._util.jit import njit
from .._util.roots import refine_jit as refine
from ._rule import P_TERMS, forcing, forcing_derivatives, gap

__all__ = ["wall_force_integrals"]

_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)


@njit
def _h_push(st, tau):
    """``sign (side f_net(t0 + tau, side))`` and its rate; ``st = [t0, side, sign, p...]``."""
    t, side, sign = st[0] + tau, st[1], st[2]
    d1, _, _ = forcing_derivatives(st[3:], t)
    return sign * (side * forcing(st[3:], t) - gap(st[3:], side)), sign * side * d1


@njit
def _h_fall(st, tau):
    """``-side f_net'`` (rising through 0 at a maximum of the push) and its rate."""
    t, side = st[0] + tau, st[1]
    d1, d2, _ = forcing_derivatives(st[3:], t)
    return -side * d1, -side * d2


@njit
def _push(st, t):
    return st[1] * forcing(st[3:], t) - gap(st[3:], st[1])  # side * f_net at the wall X = side gap (rigid: no spring)


@njit
def wall_force_integrals(p, side, t0, t1):
    """Force of a rigid flange on a mass resting against it over ``[t0, t1]`` (see the model).

    The wall takes the push ``P(t) = max(side * f_net(t, side), 0)``. Returns
    ``(int P dt, int P^2 dt, max P)``. The roots of the push are bracketed on a grid finer
    than a quarter period of the fastest harmonic and refined to an ulp
    (:func:`impactosc.backends._exact_roots.refine`), so each integral is over a smooth
    stretch (composite 16-node Gauss-Legendre); the maximum is taken at the ends and at the
    maxima of the push inside (roots of the forcing rate, refined the same way).
    """
    if not t1 > t0:
        return 0.0, 0.0, 0.0
    fastest = 0.0
    for i in range(P_TERMS, p.shape[0], 3):
        if p[i] > 0.0:
            fastest = max(fastest, p[i + 1])
    n = max(1, math.ceil((t1 - t0) * fastest / (0.25 * math.pi)))
    st = np.empty(3 + p.shape[0])
    st[0], st[1], st[2] = t0, float(side), 1.0
    st[3:] = p
    grid = np.linspace(t0, t1, n + 1)
    g = np.empty(n + 1)
    rate = np.empty(n + 1)
    for i in range(n + 1):
        g[i] = _push(st, grid[i])
        rate[i] = side * forcing_derivatives(p, grid[i])[0]
    cuts = np.empty(2 * n + 2)
    nc = 0
    cuts[nc] = t0
    nc += 1
    peak = max(0.0, g.max())
    for i in range(n):
        lo, hi = grid[i] - t0, grid[i + 1] - t0
        if g[i] * g[i + 1] < 0.0:
            st[2] = 1.0 if g[i] < 0.0 else -1.0  # refine wants h rising through 0
            cuts[nc] = t0 + refine(_h_push, st, lo, hi, st[2] * g[i], st[2] * g[i + 1], t0)
            nc += 1
        if 0 < i and g[i] == 0.0:  # a root on the grid itself
            cuts[nc] = grid[i]
            nc += 1
        if rate[i] > 0.0 and rate[i + 1] < 0.0:  # a maximum of the push inside
            top = t0 + refine(_h_fall, st, lo, hi, -rate[i], -rate[i + 1], t0)
            peak = max(peak, _push(st, top))
    cuts[nc] = t1
    nc += 1
    cuts = np.sort(cuts[:nc])
    total = total_sq = 0.0
    for c in range(nc - 1):
        a, b = cuts[c], cuts[c + 1]
        if not b > a:
            continue
        m = max(1, math.ceil((b - a) * fastest / math.pi))
        h = (b - a) / m
        for i in range(m):
            for j in range(_GL_NODES.shape[0]):
                val = max(_push(st, a + h * (i + 0.5 * (_GL_NODES[j] + 1.0))), 0.0)
                wj = 0.5 * h * _GL_WEIGHTS[j]
                total += wj * val
                total_sq += wj * (val * val)
    return total, total_sq, peak
