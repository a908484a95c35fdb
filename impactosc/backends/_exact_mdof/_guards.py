"""Certified root isolation of the guards of a closed-form piece (compiled).

A guard, any linear functional of the state and the forcing, is on a piece (:mod:`._forms`)

    h(tau) = c0 + poly(tau) + Re[ sum_k W_k e^{lambda_k tau} + sum_j D_j e^{i omega_j tau}
                                  + sum_r R_r E(lambda_{k_r}, i omega_{j_r}, tau) ]

(``poly``: the zero-eigenvalue block, rigid-body motion).

Certified root isolation
------------------------
On ``[a, b]`` each term's derivatives are bounded in closed form:
``|d^p/dtau^p W e^{lambda tau}| <= |W| |lambda|^p max(e^{Re lambda a}, e^{Re lambda b})``,
``|D (i omega)^p|`` and, for a resonant term (``E^(p)`` is a divided difference of
``z^p e^{z tau}`` over the segment ``[lambda, mu]``, so the mean-value theorem bounds it by the
derivative in ``z``), ``|R| (p rho^{p-1} + b rho^p) e^{max(Re lambda, 0) b}`` with
``rho = max(|lambda|, |mu|)``; each term's own size bounds it too. On every interval the
smaller of the two bounds per term limits how far ``h`` and ``h'`` stray from their chords
(:func:`_slacks`), and the bracketing of :func:`impactosc._util.roots.first_rising` (here
:func:`_first_rising`, with these per-interval slacks) proves that an interval holds no root,
or exactly one simple crossing (``h'`` of one sign), and bisects otherwise; a tangency (a
grazing) is bisected until its extremum is separated from zero or the interval is a few ulps
wide. So no crossing is missed and none is reported twice.

The guards are searched window by window, so that a guard crossing early spares the search of
the others beyond it; a window starts at half the shortest period of the piece and doubles
while no guard crosses (long quiet pieces: a tape resting on a stiff flange for half a turn of
the reel).
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from ..._util.jit import njit
from ..._util.roots import MAX_BRACKET_STEPS, SEARCH_FAILED
from ..._util.roots import refine_jit as refine
from ._forms import E

__all__ = ["search", "guard_values"]

_EPS = 2.0**-52
# Bisection stops at this many ulps of t when neither sign nor monotonicity can be proven.
_MIN_WIDTH_ULPS = 4.0
# A guard within this many ulps of its terms' size at a piece start counts as on its zero.
_START_ULPS = 64.0


@njit
def _h(st, tau):
    """``(h, h')`` of guard ``st[0]`` at ``tau``."""
    g, lam, W, omt, D, rk, rj, RG, c0, poly = st
    h = 0j
    dh = 0j
    ph = 0.0
    pd = 0.0
    for p in range(poly.shape[1] - 1, -1, -1):  # Horner: the polynomial and its derivative
        pd = pd * tau + ph
        ph = ph * tau + poly[g, p]
    h += ph
    dh += pd
    for k in range(lam.shape[0]):
        if W[g, k] == 0j:
            continue
        e = W[g, k] * cmath.exp(lam[k] * tau)
        h += e
        dh += lam[k] * e
    for j in range(omt.shape[0]):
        if omt[j] == 0.0:
            h += D[g, j]
            continue
        mu = 1j * omt[j]
        e = D[g, j] * cmath.exp(mu * tau)
        h += e
        dh += mu * e
    for r in range(rk.shape[0]):
        lk = lam[rk[r]]
        mu = 1j * omt[rj[r]]
        e = E(lk, mu, tau)
        h += RG[g, r] * e
        dh += RG[g, r] * (lk * e + cmath.exp(mu * tau))
    return c0[g] + h.real, dh.real


@njit
def _window_terms(st, a, b, mags, rates):
    """Guard ``st[0]``'s terms on the window ``[a, b]``, for :func:`_slacks` and the ceiling test.

    Fills ``mags`` (each oscillating term's largest size on the window: ``|W| e^{max(Re lambda a,
    Re lambda b)}``, ``|D|``) and ``rates`` (its ``|lambda|`` or ``omega``) and returns
    ``(count, c2, c3, ceiling)``: the curvature bounds of the terms kept as curvature only
    (rigid-body polynomial, resonant terms; module docstring), and an upper bound of the guard
    on the window: its constant part plus every other term at its largest plus the rounding
    of them all. A ceiling below zero proves the guard does not cross in the window.
    """
    g, lam, W, omt, D, rk, rj, RG, c0, poly = st
    top = c0[g] + poly[g, 0]  # the constant part
    size = abs(c0[g]) + abs(poly[g, 0])
    moving = 0.0  # the other terms at their largest on [a, b]
    c2 = 0.0
    c3 = 0.0
    x = max(abs(a), abs(b))
    for p in range(1, poly.shape[1]):
        moving += abs(poly[g, p]) * x**p
        if p >= 2:
            c2 += abs(poly[g, p]) * p * (p - 1) * x ** (p - 2)
        if p >= 3:
            c3 += abs(poly[g, p]) * p * (p - 1) * (p - 2) * x ** (p - 3)
    count = 0
    for k in range(lam.shape[0]):
        if W[g, k] != 0j:
            m = abs(W[g, k]) * math.exp(max(lam[k].real * a, lam[k].real * b))
            mags[count] = m
            rates[count] = abs(lam[k])
            count += 1
            moving += m
    for j in range(omt.shape[0]):
        if omt[j] == 0.0:
            top += D[g, j].real
            size += abs(D[g, j].real)
        else:
            m = abs(D[g, j])
            mags[count] = m
            rates[count] = omt[j]
            count += 1
            moving += m
    for r in range(rk.shape[0]):
        lk = lam[rk[r]]
        rho = max(abs(lk), omt[rj[r]])
        m = abs(RG[g, r]) * math.exp(max(lk.real, 0.0) * b)
        moving += m * b
        c2 += m * (2.0 * rho + b * rho * rho)
        c3 += m * (3.0 * rho * rho + b * rho * rho * rho)
    ceiling = top + moving + _START_ULPS * _EPS * (size + moving)
    return count, c2, c3, ceiling


@njit
def _slacks(count, c2, c3, mags, rates, width):
    """How far ``h`` and ``h'`` can stray from their chords on an interval of ``width`` in the window
    of :func:`_window_terms`: ``(s2, s3)``.

    Term by term, the smaller of the curvature bound ``max|f''| w^2 / 8`` and the magnitude bound
    ``2 max|f|`` (a term and its chord both stay within ``max|f|``); the same for the derivative.
    A fast, small term (a stiff flange's mode decayed to a ripple) thus costs its amplitude, not
    its curvature, and long intervals of a slow guard are decided at once.
    """
    w2 = 0.125 * width * width
    s2 = c2 * w2
    s3 = c3 * w2
    for i in range(count):
        m, r = mags[i], rates[i]
        s2 += min(m * r * r * w2, 2.0 * m)
        s3 += min(m * r * r * r * w2, 2.0 * m * r)
    # the rounding of the sums: a relative margin
    return s2 * (1.0 + 1e-12), s3 * (1.0 + 1e-12)


#: Depth of the bisection stack of :func:`_first_rising` (a window halved down to a few ulps of
#: ``t`` needs well under 100 levels; deeper is a failed search, never an overrun).
_STACK = 160


@njit
def _first_rising(st, a, ha, da, b, hmin, sb, sh, sd, terms):
    """First crossing of guard ``st[0]`` from negative to non-negative in ``(a, b]``.

    The bracketing of :func:`impactosc._util.roots.first_rising`, with the chord slacks of every
    interval from :func:`_slacks` (small fast terms bounded by their size) instead of one pair of
    derivative bounds for the whole window. Returns ``(found, lo, hi, h(lo), h(hi), h(b), h'(b),
    status)`` as that function does; ``status`` is ``SEARCH_FAILED`` on non-finite values, more
    than ``MAX_BRACKET_STEPS`` intervals or a stack deeper than :data:`_STACK` (never a hang). ``sb, sh, sd``: the stack
    (right ends of the intervals to come, their ``h`` and ``h'``), arrays of length
    :data:`_STACK` the caller lends; ``terms``: the window's terms (:func:`_window_terms`).
    """
    count, c2, c3, mags, rates = terms
    hb, db = _h(st, b)
    end_h, end_d = hb, db
    top = 0
    sb[0], sh[0], sd[0] = b, hb, db
    evaluations = 0
    while top >= 0:
        b, hb, db = sb[top], sh[top], sd[top]
        evaluations += 1
        s2, s3 = _slacks(count, c2, c3, mags, rates, b - a)
        if evaluations > MAX_BRACKET_STEPS or not math.isfinite(ha + hb + da + db + s2 + s3):
            return False, a, b, ha, hb, end_h, end_d, SEARCH_FAILED
        decided = False
        if ha >= 0.0 and hb >= 0.0 and min(ha, hb) > s2:
            decided = True  # h > 0 on [a, b]
        elif ha < 0.0 and hb < 0.0 and max(ha, hb) < -s2:
            decided = True  # h < 0 on [a, b]
        elif min(da, db) > s3:  # h increasing: one crossing at most
            if ha < 0.0 <= hb:
                return True, a, b, ha, hb, end_h, end_d, 0
            decided = True
        elif max(da, db) < -s3:  # h decreasing: it cannot rise through 0
            decided = True
        elif b - a <= hmin:
            if ha < 0.0 <= hb:
                return True, a, b, ha, hb, end_h, end_d, 0
            decided = True
        if decided:
            top -= 1
            a, ha, da = b, hb, db
        else:
            if top + 1 >= _STACK:
                return False, a, b, ha, hb, end_h, end_d, SEARCH_FAILED
            mid = a + 0.5 * (b - a)
            hm, dm = _h(st, mid)
            top += 1
            sb[top], sh[top], sd[top] = mid, hm, dm
    return False, a, a, ha, ha, end_h, end_d, 0


@njit
def _size(st):
    """The sizes of guard ``st[0]``'s terms and of its derivative's at ``tau = 0`` (their rounding scales)."""
    g, lam, W, omt, D, rk, rj, RG, c0, poly = st
    s = abs(c0[g]) + abs(poly[g, 0])
    d = abs(poly[g, 1]) if poly.shape[1] > 1 else 0.0
    for k in range(lam.shape[0]):
        s += abs(W[g, k])
        d += abs(W[g, k] * lam[k])
    for j in range(omt.shape[0]):
        s += abs(D[g, j])
        d += abs(D[g, j]) * omt[j]
    for r in range(rk.shape[0]):
        d += abs(RG[g, r])
    return s, d


@njit
def guard_values(lam, W, omt, D, rk, rj, RG, c0, poly, tau):
    """``(h, h')`` of every guard at ``tau`` (for the transition rule and the tests)."""
    ng = W.shape[0]
    hs = np.empty(ng)
    ds = np.empty(ng)
    for g in range(ng):
        hs[g], ds[g] = _h((g, lam, W, omt, D, rk, rj, RG, c0, poly), tau)
    return hs, ds


#: How a guard that starts inside its rounding band leaves it (:func:`_leave_band`).
_BELOW, _ROOT, _NEVER = 0, 1, 2


@njit
def _leave_band(st, tol, t0, T):
    """Follow a guard that starts within ``tol`` of its zero out of that band: ``(outcome, tau, h, h')``.

    It just fired, was just armed, or starts flat (a lift-off, a release at the kinetic
    level, where the contact force and the acceleration vanish). Steps of doubling length
    from a few ulps: leaving the band downwards (``_BELOW``) starts the certified search at
    ``tau``; leaving it upwards is a crossing (``_ROOT``, located in the last step; e.g. a stop
    hit again at once); a sign change inside the band is rounding, not a crossing.
    """
    tau = _MIN_WIDTH_ULPS * _EPS * max(abs(t0), 1.0)
    prev = 0.0
    while tau < T:
        h, d = _h(st, tau)
        if h > tol:
            hl, _ = _h(st, prev)
            return _ROOT, refine(_h, st, prev, tau, min(hl, -1e-300), h, t0), h, d
        if h < -tol:
            return _BELOW, tau, h, d
        prev = tau
        tau *= 2.0
    return _NEVER, T, 0.0, 0.0


@njit
def search(lam, W, omt, D, rk, rj, RG, c0, cscale, dscale, poly, armed, t0, T):
    """The first armed guard that rises through zero in ``(0, T]``: ``(tau, guard, status)``.

    ``guard`` is -1 when none does before ``T``. A guard that starts on its zero (within
    rounding) and falls is not reported at ``tau = 0``; one that starts on or beyond its
    zero and rises is (``tau = 0``). A guard that starts within rounding of its zero and
    not clearly rising (it just fired; a lift-off or a release at the kinetic level, where it
    starts flat) is followed out of the rounding band: its search starts where it has left
    the band downwards (a sign change inside the band is rounding, not a crossing), or it is
    reported where it rises out of the band.
    """
    ng = W.shape[0]
    nu = 0.0
    for k in range(lam.shape[0]):
        nu = max(nu, abs(lam[k]))
    for j in range(omt.shape[0]):
        nu = max(nu, omt[j])
    window = math.pi / nu if nu > 0.0 else T
    ha = np.zeros(ng)
    da = np.zeros(ng)
    start = np.zeros(ng)
    cand_tau = math.inf  # the first guard that rises out of its rounding band at the start
    cand_g = -1
    for g in range(ng):
        if not armed[g]:
            continue
        st = (g, lam, W, omt, D, rk, rj, RG, c0, poly)
        h0, d0 = _h(st, 0.0)
        size, dsize = _size(st)
        tol = _START_ULPS * _EPS * (size + cscale[g])
        dtol = _START_ULPS * _EPS * (dsize + dscale[g])
        if h0 >= -tol and (d0 > dtol or h0 > tol):
            return 0.0, g, 0
        if h0 >= -tol:
            outcome, tau, h, d = _leave_band(st, tol, t0, T)
            if outcome == _ROOT and tau < cand_tau:
                cand_tau, cand_g = tau, g
            start[g] = tau if outcome == _BELOW else T
            ha[g], da[g] = h, d
            continue
        ha[g], da[g] = h0, d0
    T_search = min(T, cand_tau)
    known = np.ones(ng, dtype=np.bool_)  # ha, da hold h, h' at the start of the guard's next interval
    sb = np.empty(_STACK)
    sh = np.empty(_STACK)
    sd = np.empty(_STACK)
    mags = np.empty(lam.shape[0] + omt.shape[0])
    rates = np.empty(lam.shape[0] + omt.shape[0])
    a = 0.0
    while a < T_search:
        b = min(T_search, a + window)
        best = math.inf
        best_g = -1
        hmin = _MIN_WIDTH_ULPS * _EPS * (abs(t0) + b)
        for g in range(ng):
            if not armed[g] or start[g] >= b:
                continue
            lo_g = max(a, start[g])
            hi_g = min(b, best)  # a crossing after the best one so far cannot win
            if hi_g <= lo_g:
                continue
            st = (g, lam, W, omt, D, rk, rj, RG, c0, poly)
            count, c2, c3, ceiling = _window_terms(st, lo_g, hi_g, mags, rates)
            if ceiling < 0.0:
                known[g] = False  # below zero all the way: nothing to evaluate
                continue
            if not known[g]:
                ha[g], da[g] = _h(st, lo_g)
                known[g] = True
            hit, lo, hi, hlo, hhi, hb, db, status = _first_rising(st, lo_g, ha[g], da[g], hi_g, hmin, sb, sh,
                                                                  sd, (count, c2, c3, mags, rates))
            if status == SEARCH_FAILED:
                return lo_g, g, status
            if hit:
                tau = refine(_h, st, lo, hi, hlo, hhi, t0)
                if tau < best:
                    best, best_g = tau, g
            ha[g], da[g] = hb, db
        if best_g >= 0:
            return best, best_g, 0
        a = b
        window *= 2.0
    if cand_g >= 0:
        return cand_tau, cand_g, 0
    return T, -1, 0
