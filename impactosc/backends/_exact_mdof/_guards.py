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

from ..._util.jit import njit, njit_inline
from ..._util.roots import BISECT, CROSSING, MAX_BRACKET_STEPS, SEARCH_FAILED
from ..._util.roots import decide_jit as decide
from ..._util.roots import refine_from_jit as refine_from
from ..._util.roots import refine_jit as refine
from ._forms import E

__all__ = ["search", "guard_values", "workspace"]

_EPS = 2.0**-52
# Bisection stops at this many ulps of t when neither sign nor monotonicity can be proven.
_MIN_WIDTH_ULPS = 4.0
# A guard within this many ulps of its terms' size at a piece start counts as on its zero.
_START_ULPS = 64.0

# The hot functions take their arrays as arguments, never packed in a tuple: a tuple of arrays
# built or unpacked per evaluation costs an atomic reference count per array, which was a sixth
# of a run's time.


@njit_inline
def _h_exp(terms, g, nt, tau):
    """``(h, h')`` of guard ``g`` at ``tau`` without its rigid-body polynomial and resonant terms:
    ``terms[1 + g, nt] + Re sum_{p < nt} terms[1 + g, p] e^{terms[0, p] tau}`` (:func:`_terms`).

    One array: an array argument costs an atomic reference count at every call, here the
    hottest call of a run.
    """
    h = 0j
    dh = 0j
    if tau == 0.0:  # e^0 = 1: the same sums without the exponentials
        for p in range(nt):
            c = terms[1 + g, p]
            h += c
            dh += terms[0, p] * c
    else:
        for p in range(nt):
            c = terms[1 + g, p]
            if c == 0j:
                continue
            z = terms[0, p]
            e = c * cmath.exp(z * tau)
            h += e
            dh += z * e
    return terms[1 + g, nt].real + h.real, dh.real


@njit
def _h_more(g, lam, omt, rk, rj, RG, poly, tau):
    """The rigid-body polynomial's and the resonant terms' share of guard ``g``'s ``(h, h')`` at ``tau``
    (pieces that have them only: :func:`_h`)."""
    ph = 0.0
    pd = 0.0
    for p in range(poly.shape[1] - 1, -1, -1):  # Horner: the polynomial and its derivative
        pd = pd * tau + ph
        ph = ph * tau + poly[g, p]
    h = 0j
    dh = 0j
    for r in range(rk.shape[0]):
        lk = lam[rk[r]]
        mu = 1j * omt[rj[r]]
        e = E(lk, mu, tau)
        h += RG[g, r] * e
        dh += RG[g, r] * (lk * e + cmath.exp(mu * tau))
    return ph + h.real, pd + dh.real


@njit_inline
def _h(terms, g, nt, more, lam, omt, rk, rj, RG, poly, tau):
    """``(h, h')`` of guard ``g`` at ``tau`` (:func:`_h_exp`, plus :func:`_h_more` when ``more``)."""
    h, d = _h_exp(terms, g, nt, tau)
    if more:
        hm, dm = _h_more(g, lam, omt, rk, rj, RG, poly, tau)
        h += hm
        d += dm
    return h, d


@njit
def _h_state(st, tau):
    """:func:`_h` for the shared root refinement, which passes one state: ``st = (terms, g, nt, more, ...)``."""
    terms, g, nt, more, lam, omt, rk, rj, RG, poly = st
    return _h(terms, g, nt, more, lam, omt, rk, rj, RG, poly, tau)


#: Rows of the per-guard buffer ``G`` of :func:`workspace`: ``h`` and ``h'`` at the start of the
#: guard's next interval, where its search starts, whether ``h`` there is known, its constant part
#: and the sizes of that part (its real parts; its complex terms: the scales of its rounding).
_HA, _DA, _START, _KNOWN, _CST, _WSIZE, _SSIZE = range(7)


@njit
def workspace(ng, nt):
    """Buffers of :func:`search` for up to ``ng`` guards and ``nt`` exponential terms, lent by the
    caller so that a piece allocates nothing: ``(G, S, T, terms, mag)``."""
    return (np.zeros((7, ng)), np.empty((3, _STACK)), np.empty((2, nt)),
            np.empty((ng + 1, nt + 1), dtype=np.complex128), np.empty((ng + 1, nt)))


@njit_inline
def _terms(lam, W, omt, D, c0, G, terms, mag):
    """A piece's guards as sums of exponentials, written into the workspace; returns their number ``nt``.

    ``terms[0, p]``: the exponents every guard shares (one eigenvalue per conjugate pair, whose
    partner's coefficients :func:`._setup.setup_piece` folded to zero, and ``i omega_j`` per
    harmonic); ``terms[1 + g, p]``: guard ``g``'s coefficient of ``e^{terms[0, p] tau}`` and
    ``mag[1 + g, p]`` its size (``mag[0, p]``: the exponent's); ``terms[1 + g, nt]`` and ``G``'s
    row ``_CST``: its constant part (``c0`` and the constant forces' share), ``G``'s rows
    ``_WSIZE``, ``_SSIZE``: the sizes of that part.
    """
    ng = W.shape[0]
    p = 0
    for k in range(lam.shape[0]):
        used = False
        for g in range(ng):
            used = used or W[g, k] != 0j
        if used:
            terms[0, p] = lam[k]
            mag[0, p] = abs(lam[k])
            for g in range(ng):
                terms[1 + g, p] = W[g, k]
                mag[1 + g, p] = abs(W[g, k])
            p += 1
    for g in range(ng):
        G[_CST, g] = c0[g]
        G[_WSIZE, g] = abs(c0[g])
        G[_SSIZE, g] = abs(c0[g])
    for j in range(omt.shape[0]):
        if omt[j] != 0.0:
            terms[0, p] = 1j * omt[j]
            mag[0, p] = omt[j]
            for g in range(ng):
                terms[1 + g, p] = D[g, j]
                mag[1 + g, p] = abs(D[g, j])
            p += 1
        else:
            for g in range(ng):
                G[_CST, g] += D[g, j].real
                G[_WSIZE, g] += abs(D[g, j].real)
                G[_SSIZE, g] += abs(D[g, j])
    for g in range(ng):
        terms[1 + g, p] = G[_CST, g]
    return p


@njit_inline
def _window_terms(g, nt, terms, mag, G, lam, omt, rk, rj, RG, poly, a, b, T):
    """Guard ``g``'s terms on the window ``[a, b]``, for :func:`_slacks` and the ceiling test.

    Fills ``T[0]`` (each oscillating term's largest size on the window: ``|W| e^{max(Re lambda a,
    Re lambda b)}``, ``|D|``) and ``T[1]`` (its ``|lambda|`` or ``omega``) and returns
    ``(count, c2, c3, ceiling)``: the curvature bounds of the terms kept as curvature only
    (rigid-body polynomial, resonant terms; module docstring), and an upper bound of the guard
    on the window: its constant part plus every other term at its largest plus the rounding
    of them all. A ceiling below zero proves the guard does not cross in the window.
    """
    top = G[_CST, g] + poly[g, 0]  # the constant part
    size = G[_WSIZE, g] + abs(poly[g, 0])
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
    for p in range(nt):
        m = mag[1 + g, p]
        if m == 0.0:
            continue
        grow = terms[0, p].real
        if grow != 0.0:
            m *= math.exp(max(grow * a, grow * b))
        T[0, count] = m
        T[1, count] = mag[0, p]
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


@njit_inline
def _slacks(count, c2, c3, T, width):
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
        m, r = T[0, i], T[1, i]
        s2 += min(m * r * r * w2, 2.0 * m)
        s3 += min(m * r * r * r * w2, 2.0 * m * r)
    # the rounding of the sums: a relative margin
    return s2 * (1.0 + 1e-12), s3 * (1.0 + 1e-12)


#: Depth of the bisection stack of :func:`_first_rising` (a window halved down to a few ulps of
#: ``t`` needs well under 100 levels; deeper is a failed search, never an overrun).
_STACK = 160


@njit_inline
def _first_rising(terms, g, nt, more, lam, omt, rk, rj, RG, poly, a, ha, da, b, hmin, S, count, c2, c3, T):
    """First crossing of guard ``g`` from negative to non-negative in ``(a, b]``.

    The bracketing of :func:`impactosc._util.roots.first_rising` (the same decision on every
    interval, :func:`impactosc._util.roots.decide`), with the chord slacks of every interval
    from :func:`_slacks` (small fast terms bounded by their size) instead of one pair of
    derivative bounds for the whole window. Returns ``(found, lo, hi, h(lo), h(hi), h'(lo), h'(hi),
    h(b), h'(b), status)`` as that function does (with the derivatives at the bracket, for
    :func:`_newton_start`); ``status`` is ``SEARCH_FAILED`` on non-finite values, more
    than ``MAX_BRACKET_STEPS`` intervals or a stack deeper than :data:`_STACK` (never a hang).
    ``S``: the stack (right ends of the intervals to come, their ``h`` and ``h'``), rows of length
    :data:`_STACK` the caller lends; ``count, c2, c3, T``: the window's terms (:func:`_window_terms`).
    """
    hb, db = _h(terms, g, nt, more, lam, omt, rk, rj, RG, poly, b)
    end_h, end_d = hb, db
    top = 0
    S[0, 0], S[1, 0], S[2, 0] = b, hb, db
    evaluations = 0
    while top >= 0:
        b, hb, db = S[0, top], S[1, top], S[2, top]
        evaluations += 1
        s2, s3 = _slacks(count, c2, c3, T, b - a)
        if evaluations > MAX_BRACKET_STEPS or not math.isfinite(ha + hb + da + db + s2 + s3):
            return False, a, b, ha, hb, da, db, end_h, end_d, SEARCH_FAILED
        outcome = decide(ha, hb, da, db, s2, s3, b - a, hmin)
        if outcome == CROSSING:
            return True, a, b, ha, hb, da, db, end_h, end_d, 0
        if outcome == BISECT:
            if top + 1 >= _STACK:
                return False, a, b, ha, hb, da, db, end_h, end_d, SEARCH_FAILED
            mid = a + 0.5 * (b - a)
            hm, dm = _h(terms, g, nt, more, lam, omt, rk, rj, RG, poly, mid)
            top += 1
            S[0, top], S[1, top], S[2, top] = mid, hm, dm
        else:
            top -= 1
            a, ha, da = b, hb, db
    return False, a, a, ha, ha, da, da, end_h, end_d, 0


@njit_inline
def _newton_start(lo, hi, hlo, hhi, dlo, dhi):
    """Where the refinement of a bracketed crossing starts: the cubic Hermite interpolant of the
    inverse ``tau(h)`` at ``h = 0``.

    The bracketing proved ``h`` increasing on ``[lo, hi]`` (``h' > 0`` at both ends), so its
    inverse is smooth there, with the slopes ``1 / h'``; the cubic through both ends and slopes
    is off by ``O(w^4)`` where the chord (regula falsi) is off by ``O(w^2)``, which spares about
    one Newton step. Where the slopes are not both positive (an interval decided by its width
    alone) the chord's point.
    """
    dh = hhi - hlo
    s = -hlo / dh
    chord = lo + s * (hi - lo)
    if not (dlo > 0.0 and dhi > 0.0):
        return chord
    s2 = s * s
    s3 = s2 * s
    x = ((2.0 * s3 - 3.0 * s2 + 1.0) * lo + (s3 - 2.0 * s2 + s) * dh / dlo + (3.0 * s2 - 2.0 * s3) * hi
         + (s3 - s2) * dh / dhi)
    return x if lo < x < hi else chord


@njit_inline
def _size(g, nt, terms, mag, G, RG, poly):
    """The sizes of guard ``g``'s terms and of its derivative's at ``tau = 0`` (their rounding scales)."""
    s = G[_SSIZE, g] + abs(poly[g, 0])
    d = abs(poly[g, 1]) if poly.shape[1] > 1 else 0.0
    for p in range(nt):
        s += mag[1 + g, p]
        d += mag[1 + g, p] * mag[0, p]
    for r in range(RG.shape[1]):
        d += abs(RG[g, r])
    return s, d


@njit
def guard_values(lam, W, omt, D, rk, rj, RG, c0, poly, tau):
    """``(h, h')`` of every guard at ``tau`` (for the transition rule and the tests)."""
    ng = W.shape[0]
    G, _, _, terms, mag = workspace(ng, lam.shape[0] + omt.shape[0])
    nt = _terms(lam, W, omt, D, c0, G, terms, mag)
    more = rk.shape[0] > 0 or poly.shape[1] > 1
    hs = np.empty(ng)
    ds = np.empty(ng)
    for g in range(ng):
        hs[g], ds[g] = _h(terms, g, nt, more, lam, omt, rk, rj, RG, poly, tau)
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
    ``st``: the guard's state for :func:`_h_state`.
    """
    tau = _MIN_WIDTH_ULPS * _EPS * max(abs(t0), 1.0)
    prev = 0.0
    while tau < T:
        h, d = _h_state(st, tau)
        if h > tol:
            hl, _ = _h_state(st, prev)
            return _ROOT, refine(_h_state, st, prev, tau, min(hl, -1e-300), h, t0), h, d
        if h < -tol:
            return _BELOW, tau, h, d
        prev = tau
        tau *= 2.0
    return _NEVER, T, 0.0, 0.0


@njit
def search(lam, W, omt, D, rk, rj, RG, c0, cscale, dscale, poly, t0, T, G, S, TT, terms, mag):
    """The first guard that rises through zero in ``(0, T]``: ``(tau, guard, status)``.

    ``guard`` is -1 when none does before ``T``. A guard that starts on its zero (within
    rounding) and falls is not reported at ``tau = 0``; one that starts on or beyond its
    zero and rises is (``tau = 0``). A guard that starts within rounding of its zero and
    not clearly rising (it just fired; a lift-off or a release at the kinetic level, where it
    starts flat) is followed out of the rounding band: its search starts where it has left
    the band downwards (a sign change inside the band is rounding, not a crossing), or it is
    reported where it rises out of the band. ``G, S, TT, terms, mag``: the buffers of
    :func:`workspace`, large enough for this piece.
    """
    ng = W.shape[0]
    nt = _terms(lam, W, omt, D, c0, G, terms, mag)
    more = rk.shape[0] > 0 or poly.shape[1] > 1  # a rigid-body polynomial or resonant terms
    nu = 0.0
    for k in range(lam.shape[0]):
        nu = max(nu, abs(lam[k]))
    for j in range(omt.shape[0]):
        nu = max(nu, omt[j])
    window = math.pi / nu if nu > 0.0 else T
    cand_tau = math.inf  # the first guard that rises out of its rounding band at the start
    cand_g = -1
    for g in range(ng):
        G[_START, g] = 0.0
        G[_KNOWN, g] = 1.0  # G[_HA], G[_DA] hold h, h' at the start of the guard's next interval
        h0, d0 = _h(terms, g, nt, more, lam, omt, rk, rj, RG, poly, 0.0)
        size, dsize = _size(g, nt, terms, mag, G, RG, poly)
        tol = _START_ULPS * _EPS * (size + cscale[g])
        dtol = _START_ULPS * _EPS * (dsize + dscale[g])
        if h0 >= -tol and (d0 > dtol or h0 > tol):
            return 0.0, g, 0
        if h0 >= -tol:
            outcome, tau, h, d = _leave_band((terms, g, nt, more, lam, omt, rk, rj, RG, poly), tol, t0, T)
            if outcome == _ROOT and tau < cand_tau:
                cand_tau, cand_g = tau, g
            G[_START, g] = tau if outcome == _BELOW else T
            G[_HA, g], G[_DA, g] = h, d
            continue
        G[_HA, g], G[_DA, g] = h0, d0
    T_search = min(T, cand_tau)
    a = 0.0
    while a < T_search:
        b = min(T_search, a + window)
        best = math.inf
        best_g = -1
        hmin = _MIN_WIDTH_ULPS * _EPS * (abs(t0) + b)
        for g in range(ng):
            if G[_START, g] >= b:
                continue
            lo_g = max(a, G[_START, g])
            hi_g = min(b, best)  # a crossing after the best one so far cannot win
            if hi_g <= lo_g:
                continue
            count, c2, c3, ceiling = _window_terms(g, nt, terms, mag, G, lam, omt, rk, rj, RG, poly, lo_g, hi_g,
                                                   TT)
            if ceiling < 0.0:
                G[_KNOWN, g] = 0.0  # below zero all the way: nothing to evaluate
                continue
            if G[_KNOWN, g] == 0.0:
                G[_HA, g], G[_DA, g] = _h(terms, g, nt, more, lam, omt, rk, rj, RG, poly, lo_g)
                G[_KNOWN, g] = 1.0
            hit, lo, hi, hlo, hhi, dlo, dhi, hb, db, status = _first_rising(
                terms, g, nt, more, lam, omt, rk, rj, RG, poly, lo_g, G[_HA, g], G[_DA, g], hi_g, hmin, S, count, c2,
                c3, TT)
            if status == SEARCH_FAILED:
                return lo_g, g, status
            if hit:
                st = (terms, g, nt, more, lam, omt, rk, rj, RG, poly)
                x = _newton_start(lo, hi, hlo, hhi, dlo, dhi)
                tau = hi if hhi == 0.0 else refine_from(_h_state, st, lo, hi, x, t0)
                if tau < best:
                    best, best_g = tau, g
            G[_HA, g], G[_DA, g] = hb, db
        if best_g >= 0:
            return best, best_g, 0
        a = b
        window *= 2.0
    if cand_g >= 0:
        return cand_tau, cand_g, 0
    return T, -1, 0
