"""The closed form of one piece of a linear mechanical system, and its certified guard search (compiled).

In a mode the reduced first-order state ``Y = (z, z')`` obeys ``Y' = A Y + b(t)`` with
``b(t) = Re sum_j beta_j e^{i omega_j t}`` (``omega_0 = 0``: the constant forces). In the
eigenbasis ``A = V diag(lambda) V^-1`` each modal coordinate solves
``eta_k' = lambda_k eta_k + sum_j beta_kj e^{i omega_j tau}``, so

    eta_k(tau) = e^{lambda_k tau} eta_k(0) + sum_j beta_kj E(lambda_k, i omega_j, tau),
    E(lambda, mu, tau) = (e^{mu tau} - e^{lambda tau}) / (mu - lambda) = e^{lambda tau} tau phi1((mu - lambda) tau),

with ``phi1(z) = (e^z - 1) / z``, finite at resonance (``mu = lambda``: ``E = tau e^{lambda tau}``).
Off resonance ``E`` splits into the classical form ``P (e^{mu tau} - e^{lambda tau})`` with
``P = beta / (mu - lambda)``; a pair with ``|mu - lambda|`` below :data:`RESONANCE` times
``max(|lambda|, |mu|)`` keeps the stable ``E`` (its amplitudes would cancel). A guard,
any linear functional of the state and the forcing, is then

    h(tau) = c0 + Re[ sum_k W_k e^{lambda_k tau} + sum_j D_j e^{i omega_j tau}
                      + sum_r R_r E(lambda_{k_r}, i omega_{j_r}, tau) ].

Certified root isolation
------------------------
On ``[a, b]`` each term's derivatives are bounded in closed form:
``|d^p/dtau^p W e^{lambda tau}| <= |W| |lambda|^p max(e^{Re lambda a}, e^{Re lambda b})``,
``|D (i omega)^p|`` and, for a resonant term (``E^(p)`` is a divided difference of
``z^p e^{z tau}`` over the segment ``[lambda, mu]``, so the mean-value theorem bounds it by the
derivative in ``z``), ``|R| (p rho^{p-1} + b rho^p) e^{max(Re lambda, 0) b}`` with
``rho = max(|lambda|, |mu|)``. With ``M2 >= |h''|`` and ``M3 >= |h'''|`` the bracketing of
:func:`impactosc._util.roots.first_rising` proves that an interval holds no root, or exactly
one simple crossing (``h'`` of one sign), and bisects otherwise; a tangency (a grazing) is
bisected until its extremum is separated from zero or the interval is a few ulps wide. So
no crossing is missed and none is reported twice.
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from ..._util.jit import njit
from ..._util.roots import SEARCH_FAILED
from ..._util.roots import first_rising_jit as first_rising
from ..._util.roots import refine_jit as refine

__all__ = ["RESONANCE", "setup_piece", "search", "state_at", "integrals", "guard_values"]

_EPS = 2.0**-52
#: Relative distance ``|mu - lambda| / max(|lambda|, |mu|)`` below which a pair keeps the stable form ``E``.
RESONANCE = 1e-3
# Bisection stops at this many ulps of t when neither sign nor monotonicity can be proven.
_MIN_WIDTH_ULPS = 4.0
# A guard within this many ulps of its terms' size at a piece start counts as on its zero.
_START_ULPS = 64.0
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
# phi1(z) = sum z^k / (k+1)!, k = 0..12: below an ulp for |z| < 0.25.
_PHI1_COEFFS = np.array([1.0 / math.factorial(k + 1) for k in reversed(range(13))])


@njit
def _phi1(z):
    """``(e^z - 1) / z`` for complex ``z``, without cancellation near 0."""
    if abs(z) < 0.25:
        s = 0j
        for c in _PHI1_COEFFS:
            s = c + z * s
        return s
    return (cmath.exp(z) - 1.0) / z


@njit
def _E(lam, mu, tau):
    """``(e^{mu tau} - e^{lam tau}) / (mu - lam)``, finite at ``mu = lam``."""
    return cmath.exp(lam * tau) * tau * _phi1((mu - lam) * tau)


@njit
def setup_piece(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, t0, q0, v0):
    """The coefficients of the piece that starts at ``(t0, q0, v0)`` in a mode.

    Returns ``(a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, poly, Xi, X)``: the modal
    amplitudes of the classical form, the particular amplitudes, the modal forcing, the
    resonance flags, for every guard its exponential, harmonic and resonant coefficients and
    constant, the frequencies (``omt[0] = 0``), the size of the terms of each constant (its
    rounding scale), and the zero-eigenvalue block: each guard's polynomial coefficients
    ``poly[g, p]`` (of ``tau^p``) and the block's coordinates
    ``xi = sum_p Xi[p] tau^p + sum_j X[j] e^{i omega_j tau}``.
    """
    m2 = lam.shape[0]
    nh = om.shape[0]
    jt = nh + 1
    omt = np.zeros(jt)
    omt[1:] = om
    eta0 = gv @ (v0 + 0j)
    f0 = const - kmode @ q0
    beta = np.empty((m2, jt), dtype=np.complex128)
    beta[:, 0] = gin @ (f0 + 0j)
    for j in range(nh):
        beta[:, j + 1] = gin @ (fh[j] * cmath.exp(1j * om[j] * t0))
    P = np.zeros((m2, jt), dtype=np.complex128)
    res = np.zeros((m2, jt), dtype=np.bool_)
    a = eta0.copy()
    nres = 0
    for k in range(m2):
        for j in range(jt):
            mu = 1j * omt[j]
            d = mu - lam[k]
            if abs(d) <= RESONANCE * max(abs(lam[k]), omt[j]):
                res[k, j] = True
                nres += 1
            else:
                P[k, j] = beta[k, j] / d
                a[k] -= P[k, j]
    ng = wk.shape[0]
    W = np.empty((ng, m2), dtype=np.complex128)
    D = np.zeros((ng, jt), dtype=np.complex128)
    rk = np.empty(nres, dtype=np.int64)
    rj = np.empty(nres, dtype=np.int64)
    RG = np.zeros((ng, nres), dtype=np.complex128)
    r = 0
    for k in range(m2):
        for j in range(jt):
            if res[k, j]:
                rk[r], rj[r] = k, j
                r += 1
    c0 = ga @ q0 + gc
    cscale = np.abs(ga) @ np.abs(q0) + np.abs(gc)
    for g in range(ng):
        for k in range(m2):
            W[g, k] = wk[g, k] * a[k]
        # A conjugate pair in one term: Re(W1 e^{l t} + W2 e^{conj(l) t}) = Re((W1 + conj(W2)) e^{l t}),
        # half the exponentials in the guard search (whose loops skip the zero partner).
        for k in range(m2):
            if pair[k] > k:
                W[g, k] += np.conj(W[g, pair[k]])
                W[g, pair[k]] = 0j
        for j in range(jt):
            s = 0j
            for k in range(m2):
                s += wk[g, k] * P[k, j]
            D[g, j] = s
        for j in range(nh):  # the guard's direct dependence on the harmonic forces
            s = 0j
            for i in range(q0.shape[0]):
                s += gu[g, i] * fh[j, i]
            D[g, j + 1] += s * cmath.exp(1j * om[j] * t0)
        for rr in range(nres):
            RG[g, rr] = wk[g, rk[rr]] * beta[rk[rr], rj[rr]]
    Xi, X = _zero_block(N, gin0, gv0, om, fh, t0, q0, v0, const, kmode)
    k0 = N.shape[0]
    poly = np.zeros((ng, k0 + 1))
    for g in range(ng):
        for p in range(k0 + 1):
            poly[g, p] = (wk0[g] @ Xi[p]).real
        for j in range(nh):
            D[g, j + 1] += wk0[g] @ X[j + 1]
    return a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, poly, Xi, X


@njit
def _zero_block(N, gin0, gv0, om, fh, t0, q0, v0, const, kmode):
    """The zero-eigenvalue block ``xi' = N xi + beta_0 + sum_j beta_j e^{i omega_j tau}`` (``N`` nilpotent).

    Its solution is a polynomial plus harmonics: with ``X_j = (i omega_j - N)^-1 beta_j`` and
    ``x = xi(0) - sum_j X_j``,
    ``xi = sum_p tau^p (N^p x + N^(p-1) beta_0) / p! + sum_j X_j e^{i omega_j tau}``
    (``N^k0 = 0`` ends the sum at ``p = k0``): rigid-body motion, a multiple root of the
    characteristic polynomial that an eigenbasis cannot hold.
    """
    k0 = N.shape[0]
    nh = om.shape[0]
    Xi = np.zeros((k0 + 1, k0), dtype=np.complex128)
    X = np.zeros((nh + 1, k0), dtype=np.complex128)
    if k0 == 0:
        return Xi, X
    x = gv0 @ (v0 + 0j)
    b0 = gin0 @ (const - kmode @ q0 + 0j)
    eye = np.eye(k0) + 0j
    for j in range(nh):
        bj = gin0 @ (fh[j] * cmath.exp(1j * om[j] * t0))
        X[j + 1] = np.linalg.solve(1j * om[j] * eye - N, bj)
        x = x - X[j + 1]
    np_x = x
    np_b = b0
    fact = 1.0
    Xi[0] = x
    for p in range(1, k0 + 1):
        fact *= p
        Xi[p] = (N @ np_x + np_b) / fact
        np_x = N @ np_x
        np_b = N @ np_b
    return Xi, X


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
        mu = 1j * omt[j]
        e = D[g, j] * cmath.exp(mu * tau)
        h += e
        dh += mu * e
    for r in range(rk.shape[0]):
        lk = lam[rk[r]]
        mu = 1j * omt[rj[r]]
        E = _E(lk, mu, tau)
        h += RG[g, r] * E
        dh += RG[g, r] * (lk * E + cmath.exp(mu * tau))
    return c0[g] + h.real, dh.real


@njit
def _bounds(st, a, b):
    """``M2 >= |h''|`` and ``M3 >= |h'''|`` of guard ``st[0]`` on ``[a, b]`` (module docstring)."""
    g, lam, W, omt, D, rk, rj, RG, c0, poly = st
    m2 = 0.0
    m3 = 0.0
    x = max(abs(a), abs(b))
    for p in range(2, poly.shape[1]):
        m2 += abs(poly[g, p]) * p * (p - 1) * x ** (p - 2)
        if p >= 3:
            m3 += abs(poly[g, p]) * p * (p - 1) * (p - 2) * x ** (p - 3)
    for k in range(lam.shape[0]):
        r = abs(lam[k])
        grow = math.exp(max(lam[k].real * a, lam[k].real * b))
        w = abs(W[g, k]) * grow * r * r
        m2 += w
        m3 += w * r
    for j in range(omt.shape[0]):
        w = abs(D[g, j]) * omt[j] * omt[j]
        m2 += w
        m3 += w * omt[j]
    for r in range(rk.shape[0]):
        lk = lam[rk[r]]
        rho = max(abs(lk), omt[rj[r]])
        grow = math.exp(max(lk.real, 0.0) * b)
        w = abs(RG[g, r]) * grow
        m2 += w * (2.0 * rho + b * rho * rho)
        m3 += w * (3.0 * rho * rho + b * rho * rho * rho)
    # the rounding of the sums: a relative margin
    return m2 * (1.0 + 1e-12), m3 * (1.0 + 1e-12)


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


@njit
def search(lam, W, omt, D, rk, rj, RG, c0, cscale, poly, armed, t0, T):
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
        dtol = _START_ULPS * _EPS * dsize
        if h0 >= -tol and (d0 > dtol or h0 > tol):
            return 0.0, g, 0
        if h0 >= -tol:
            # Inside the rounding band of its zero and not clearly rising (it just fired, was
            # just armed, or starts flat): step out geometrically until it leaves the band. A
            # sign change inside the band is rounding, not a crossing; leaving it upwards is
            # the crossing (e.g. a stop hit again at once), downwards starts the search there.
            tau = _MIN_WIDTH_ULPS * _EPS * max(abs(t0), 1.0)
            prev = 0.0
            while tau < T:
                h, d = _h(st, tau)
                if h > tol:
                    hl, _ = _h(st, prev)
                    root = refine(_h, st, prev, tau, min(hl, -1e-300), h, t0)
                    if root < cand_tau:
                        cand_tau, cand_g = root, g
                    break
                if h < -tol:
                    break
                prev = tau
                tau *= 2.0
            if tau >= T or h > tol:
                start[g] = T  # no crossing to search for (beyond T, or the candidate above)
                continue
            start[g], ha[g], da[g] = tau, h, d
            continue
        ha[g], da[g] = h0, d0
    T_search = min(T, cand_tau)
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
            st = (g, lam, W, omt, D, rk, rj, RG, c0, poly)
            M2, M3 = _bounds(st, lo_g, b)
            hit, lo, hi, hlo, hhi, hb, db, status = first_rising(_h, st, lo_g, ha[g], da[g], b, M2, M3, hmin)
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
    if cand_g >= 0:
        return cand_tau, cand_g, 0
    return T, -1, 0


@njit
def modal_at(lam, a, P, beta, res, omt, tau):
    """The modal coordinates ``eta(tau)`` of the piece (complex)."""
    m2 = lam.shape[0]
    eta = np.empty(m2, dtype=np.complex128)
    for k in range(m2):
        s = a[k] * cmath.exp(lam[k] * tau)
        for j in range(omt.shape[0]):
            mu = 1j * omt[j]
            if res[k, j]:
                s += beta[k, j] * _E(lam[k], mu, tau)
            else:
                s += P[k, j] * cmath.exp(mu * tau)
        eta[k] = s
    return eta


@njit
def zero_at(Xi, X, omt, tau):
    """The zero-eigenvalue block's coordinates ``xi(tau)`` (:func:`_zero_block`)."""
    k0 = Xi.shape[1]
    xi = np.zeros(k0, dtype=np.complex128)
    for p in range(Xi.shape[0] - 1, -1, -1):
        xi = xi * tau + Xi[p]
    for j in range(1, X.shape[0]):
        xi = xi + X[j] * cmath.exp(1j * omt[j] * tau)
    return xi


@njit
def state_at(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, q0, tau):
    """``(q, v)`` at ``tau`` after the piece start: ``q = q0 + Re(Vq eta + Vq0 xi)``, ``v = Re(Vv eta + Vv0 xi)``."""
    eta = modal_at(lam, a, P, beta, res, omt, tau)
    xi = zero_at(Xi, X, omt, tau)
    q = q0 + np.ascontiguousarray((vq @ eta + vq0 @ xi).real)
    v = np.ascontiguousarray((vv @ eta + vv0 @ xi).real)
    return q, v


@njit
def integrals(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0):
    """``(int f(t).v dt, int v.C v dt)`` over ``[0, tau]``: forcing work and viscous dissipation.

    Composite 16-node Gauss-Legendre on sub-intervals no longer than half the shortest
    period of the piece (the integrands are sums of exponentials and harmonics).
    """
    if tau <= 0.0:
        return 0.0, 0.0
    nu = 0.0
    for k in range(lam.shape[0]):
        nu = max(nu, abs(lam[k]))
    for j in range(omt.shape[0]):
        nu = max(nu, 2.0 * omt[j])
    n = max(1, math.ceil(tau * nu / math.pi))
    h = tau / n
    work = 0.0
    diss = 0.0
    for i in range(n):
        left = h * i
        for p in range(_GL_NODES.shape[0]):
            s = left + 0.5 * h * (_GL_NODES[p] + 1.0)
            eta = modal_at(lam, a, P, beta, res, omt, s)
            xi = zero_at(Xi, X, omt, s)
            v = np.ascontiguousarray((vv @ eta + vv0 @ xi).real)
            f = 0.0
            for j in range(om.shape[0]):
                ph = cmath.exp(1j * om[j] * (t0 + s))
                for i in range(v.shape[0]):
                    f += (fh[j, i] * ph).real * v[i]
            wgt = 0.5 * h * _GL_WEIGHTS[p]
            work += wgt * f
            diss += wgt * (v @ (csym @ v))
    return work, diss


@njit
def advance(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, vq, vv, vq0, vv0, csym,
            t0, q0, v0, t_end, energy):
    """One piece from ``(t0, q0, v0)`` to its first guard or ``t_end``, in one compiled call.

    Returns ``(tau, guard, status, q1, v1, work, dissipation)`` (:func:`setup_piece`,
    :func:`search`, :func:`state_at`, and with ``energy`` :func:`integrals`).
    """
    a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, poly, Xi, X = setup_piece(
        lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, t0, q0, v0)
    armed = np.ones(W.shape[0], dtype=np.bool_)
    tau, g, status = search(lam, W, omt, D, rk, rj, RG, c0, cscale, poly, armed, t0, t_end - t0)
    if status != 0:
        return tau, g, status, q0, v0, 0.0, 0.0
    if g < 0:
        tau = t_end - t0
    q1, v1 = state_at(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, q0, tau)
    work = diss = 0.0
    if energy:
        work, diss = integrals(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0)
    return tau, g, status, q1, v1, work, diss


@njit
def run_mode(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, vq, vv, vq0, vv0, csym,
             guard_kind, guard_index, impact_kind, normals, mn, nmn, restitution, gaps, mn_norm, any_resting,
             fr_coord, fr_motion, fr_kinetic, f0, M, bound_forces, k_norm, c_norm, chatter_height, push_margin,
             t, q, v, t_end, energy, ev_t, ev_index, ev_q, ev_v, pc_t, pc_q, pc_v):
    """Pieces of one mode, with the impacts that keep the mode resolved here, compiled.

    An impact on a rigid stop keeps the mode when no stop rests, the impulse reverses no
    friction coordinate and the rebound is too fast for rest (the cheap bound of the push of
    the Python rule): those are applied here (``v -> v - (1 + e) (n.v) M^-1 n / (n.M^-1 n)``)
    and recorded in ``ev_*``, every piece start in ``pc_*``. Any other event, ``t_end``, a
    full buffer or a failed search returns to the Python rule with the state at the event.

    Returns ``(n_events, n_pieces, tau, guard, status, t, q, v, work, dissipation, friction,
    impact_loss, energy_scale)``.
    """
    n_ev = 0
    n_pc = 0
    work = diss = fric = loss = 0.0
    escale = 0.0
    cap = ev_t.shape[0]
    while True:
        tau, g, st, q1, v1, w, d = advance(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om,
                                           fh, vq, vv, vq0, vv0, csym, t, q, v, t_end, energy)
        pc_t[n_pc] = t
        pc_q[n_pc] = q
        pc_v[n_pc] = v
        n_pc += 1
        if st != 0:
            return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        t1 = t + tau if g >= 0 else t_end
        if energy:
            work += w + f0 @ (q1 - q)
            diss += d
            for i in range(fr_coord.shape[0]):
                fric += fr_kinetic[i] * fr_motion[i] * (q1[fr_coord[i]] - q[fr_coord[i]])
            escale = max(escale, 0.5 * abs(v1 @ (M @ v1)) + 0.5 * abs(q1 @ (kmode @ q1)))
        t, q, v = t1, q1, v1
        if g < 0 or guard_kind[g] != impact_kind or tau == 0.0 or any_resting or n_ev >= cap or n_pc >= cap:
            return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        c = guard_index[g]
        u = normals[c] @ v
        vn = v - (1.0 + restitution[c]) * u / nmn[c] * mn[c] if u > 0.0 else v.copy()
        for i in range(fr_coord.shape[0]):
            s = 1 if vn[fr_coord[i]] > 0.0 else (-1 if vn[fr_coord[i]] < 0.0 else 0)
            if s != fr_motion[i]:
                return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        if restitution[c] < 1.0:
            wn = -(normals[c] @ vn)
            if wn <= 0.0:
                return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
            forces = bound_forces + k_norm * np.abs(q).sum() + c_norm * np.abs(vn).sum()
            if wn * wn <= 2.0 * push_margin * mn_norm[c] * forces * chatter_height * max(1.0, gaps[c]):
                return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        if energy:
            loss += 0.5 * ((v - vn) @ (M @ (v + vn)))
        v = vn
        ev_t[n_ev] = t
        ev_index[n_ev] = c
        ev_q[n_ev] = q
        ev_v[n_ev] = v
        n_ev += 1
