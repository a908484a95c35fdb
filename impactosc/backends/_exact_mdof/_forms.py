"""The closed form of one piece of a linear mechanical system (compiled).

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
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from ..._util.jit import njit

__all__ = ["RESONANCE", "setup_piece", "modal_at", "zero_at", "state_at", "integrals", "E", "cmv", "rmv", "re_cmv",
           "rdot"]

#: Relative distance ``|mu - lambda| / max(|lambda|, |mu|)`` below which a pair keeps the stable form ``E``.
RESONANCE = 1e-3
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
def E(lam, mu, tau):
    """``(e^{mu tau} - e^{lam tau}) / (mu - lam)``, finite at ``mu = lam``."""
    return cmath.exp(lam * tau) * tau * _phi1((mu - lam) * tau)


# Matrix-vector products of the few-coordinate sizes here as loops: numba's ``@`` calls BLAS, whose
# call and checks cost more than the arithmetic of a 4x8 product (half the time of a piece once).
@njit
def cmv(A, x):
    """``A @ x`` as a complex vector (``A`` complex or real, ``x`` real or complex)."""
    m, n = A.shape
    out = np.empty(m, dtype=np.complex128)
    for i in range(m):
        s = 0j
        for k in range(n):
            s += A[i, k] * x[k]
        out[i] = s
    return out


@njit
def rmv(A, x):
    """``A @ x`` for a real matrix and a real vector."""
    m, n = A.shape
    out = np.empty(m)
    for i in range(m):
        s = 0.0
        for k in range(n):
            s += A[i, k] * x[k]
        out[i] = s
    return out


@njit
def re_cmv(A, x):
    """``Re(A @ x)`` for complex ``A`` and ``x``."""
    m, n = A.shape
    out = np.empty(m)
    for i in range(m):
        s = 0.0
        for k in range(n):
            s += A[i, k].real * x[k].real - A[i, k].imag * x[k].imag
        out[i] = s
    return out


@njit
def rdot(a, b):
    """``a @ b`` for real vectors."""
    s = 0.0
    for k in range(a.shape[0]):
        s += a[k] * b[k]
    return s


@njit
def setup_piece(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, t0, q0, v0):
    """The coefficients of the piece that starts at ``(t0, q0, v0)`` in a mode.

    Returns ``(a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, dscale, poly, Xi, X)``: the
    modal amplitudes of the classical form, the particular amplitudes, the modal forcing, the
    resonance flags, for every guard its exponential, harmonic and resonant coefficients and
    constant, the frequencies (``omt[0] = 0``), the rounding scales of each guard's value and
    derivative at the start (:func:`_rounding_scales`), and the zero-eigenvalue block: each
    guard's polynomial coefficients
    ``poly[g, p]`` (of ``tau^p``) and the block's coordinates
    ``xi = sum_p Xi[p] tau^p + sum_j X[j] e^{i omega_j tau}``.
    """
    m2 = lam.shape[0]
    nh = om.shape[0]
    jt = nh + 1
    omt = np.zeros(jt)
    omt[1:] = om
    n = q0.shape[0]
    eta0 = cmv(gv, v0)
    f0 = np.empty(n)
    for i in range(n):
        s = const[i]
        for m in range(n):
            s -= kmode[i, m] * q0[m]
        f0[i] = s
    beta = np.empty((m2, jt), dtype=np.complex128)
    phase = np.empty(nh, dtype=np.complex128)
    for j in range(nh):
        phase[j] = cmath.exp(1j * om[j] * t0)
    for k in range(m2):
        b = 0j
        for i in range(n):
            b += gin[k, i] * f0[i]
        beta[k, 0] = b
        for j in range(nh):
            b = 0j
            for i in range(n):
                b += gin[k, i] * fh[j, i]
            beta[k, j + 1] = b * phase[j]
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
    W, D, RG, rk, rj = _guard_terms(lam, pair, wk, gu, om, fh, t0, a, P, beta, res, nres)
    ng = wk.shape[0]
    c0 = np.empty(ng)
    for g in range(ng):
        s = gc[g]
        for i in range(n):
            s += ga[g, i] * q0[i]
        c0[g] = s
    cscale, dscale = _rounding_scales(lam, gin, gv, wk, ga, gc, kmode, const, omt, fh, q0, v0, res)
    Xi, X = _zero_block(N, gin0, gv0, om, fh, t0, q0, v0, const, kmode)
    k0 = N.shape[0]
    poly = np.zeros((ng, k0 + 1))
    if k0 > 0:
        for g in range(ng):
            for p in range(k0 + 1):
                poly[g, p] = (wk0[g] @ Xi[p]).real
            for j in range(nh):
                D[g, j + 1] += wk0[g] @ X[j + 1]
    return a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, dscale, poly, Xi, X


@njit
def _rounding_scales(lam, gin, gv, wk, ga, gc, kmode, const, omt, fh, q0, v0, res):
    """Every guard's rounding scales at the piece start: ``(value, derivative)``.

    The closed form rebuilds a guard from the modal state, ``h(0) = c0 + Re sum_k wk_k (eta0_k
    - sum_j P_kj) + ...``, whose terms can be far larger than ``h`` or its terms after they
    cancel: the modal velocities ``gv v0`` of coordinates the guard does not see (a neighbour
    moving fast while the guarded one is at rest), the particular amplitudes of a preloaded
    spring (``const - K q0``, two large forces that cancel). The sizes of these terms before
    the cancellation are the scales of the rounding of ``h(0)`` and ``h'(0)``; without them a
    guard at rest on its zero looks clearly crossed (a reversal or an impact fired again at
    once, with no time passing).
    """
    m2 = lam.shape[0]
    ng = wk.shape[0]
    jt = omt.shape[0]
    n = q0.shape[0]
    f0abs = np.empty(n)  # the size of the terms of const - K q0
    for i in range(n):
        s = abs(const[i])
        for m in range(n):
            s += abs(kmode[i, m] * q0[m])
        f0abs[i] = s
    cscale = np.empty(ng)
    for g in range(ng):
        s = abs(gc[g])
        for i in range(n):
            s += abs(ga[g, i] * q0[i])
        cscale[g] = s
    dscale = np.zeros(ng)
    # |re| + |im| for the size of a complex number: within sqrt(2) of it, and no square root
    for k in range(m2):
        eta_abs = 0.0
        for i in range(n):
            eta_abs += (abs(gv[k, i].real) + abs(gv[k, i].imag)) * abs(v0[i])
        vk = eta_abs
        dk = abs(lam[k]) * eta_abs
        for j in range(jt):
            babs = 0.0
            for i in range(n):
                gki = abs(gin[k, i].real) + abs(gin[k, i].imag)
                babs += gki * (f0abs[i] if j == 0 else abs(fh[j - 1, i].real) + abs(fh[j - 1, i].imag))
            if res[k, j]:
                dk += babs
            else:
                d = abs(1j * omt[j] - lam[k])
                vk += babs / d
                dk += babs * (abs(lam[k]) + omt[j]) / d
        for g in range(ng):
            w = abs(wk[g, k].real) + abs(wk[g, k].imag)
            cscale[g] += w * vk
            dscale[g] += w * dk
    return cscale, dscale


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
def _guard_terms(lam, pair, wk, gu, om, fh, t0, a, P, beta, res, nres):
    """Every guard's exponential, harmonic and resonant coefficients ``(W, D, RG, rk, rj)`` of a piece."""
    m2 = lam.shape[0]
    nh = om.shape[0]
    jt = nh + 1
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
            for i in range(fh.shape[1]):
                s += gu[g, i] * fh[j, i]
            D[g, j + 1] += s * cmath.exp(1j * om[j] * t0)
        for rr in range(nres):
            RG[g, rr] = wk[g, rk[rr]] * beta[rk[rr], rj[rr]]
    return W, D, RG, rk, rj


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
                s += beta[k, j] * E(lam[k], mu, tau)
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
    q = q0 + re_cmv(vq, eta)
    v = re_cmv(vv, eta)
    if xi.shape[0] > 0:
        q += re_cmv(vq0, xi)
        v += re_cmv(vv0, xi)
    return q, v


@njit
def _I(z, tau):
    """``int_0^tau e^{z s} ds = tau phi1(z tau)``, finite at ``z = 0``."""
    return tau * _phi1(z * tau)


@njit
def integrals(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0):
    """``(int f(t).v dt, int v.C v dt)`` over ``[0, tau]``: forcing work and viscous dissipation.

    In closed form when the piece has neither resonant terms nor a zero-eigenvalue block (the
    usual case): ``v = Re sum_p c_p e^{z_p tau}`` (one term per eigenvalue, its conjugate
    partner folded in, and one per harmonic) and ``f = Re sum_j F_j e^{i omega_j tau}``, so with
    ``Re x Re y = Re(x y + x conj(y)) / 2`` both integrals are sums of
    ``int_0^tau e^{z s} ds = tau phi1(z tau)`` (:func:`_integrals_quadrature` otherwise).
    """
    if tau <= 0.0:
        return 0.0, 0.0
    if Xi.shape[1] > 0:
        return _integrals_quadrature(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0)
    m2 = lam.shape[0]
    jt = omt.shape[0]
    n = vv.shape[0]
    for k in range(m2):
        for j in range(jt):
            if res[k, j]:
                return _integrals_quadrature(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh,
                                             t0)
    # the velocity's terms: c[p] e^{z[p] tau}
    c = np.zeros((m2 + jt, n), dtype=np.complex128)
    z = np.zeros(m2 + jt, dtype=np.complex128)
    nt = 0
    for k in range(m2):
        if 0 <= pair[k] < k:
            continue  # folded into its partner: Re(x e^{l t}) + Re(y e^{conj(l) t}) = Re((x + conj(y)) e^{l t})
        for i in range(n):
            c[nt, i] = vv[i, k] * a[k]
            if pair[k] > k:
                c[nt, i] += np.conj(vv[i, pair[k]] * a[pair[k]])
        z[nt] = lam[k]
        nt += 1
    for j in range(jt):
        for i in range(n):
            s = 0j
            for k in range(m2):
                s += vv[i, k] * P[k, j]
            c[nt, i] = s
        z[nt] = 1j * omt[j]
        nt += 1
    work = 0.0
    for j in range(om.shape[0]):
        ph = cmath.exp(1j * om[j] * t0)
        zj = 1j * om[j]
        for p in range(nt):
            fc = 0j
            fcc = 0j
            for i in range(n):
                F = fh[j, i] * ph
                fc += F * c[p, i]
                fcc += F * np.conj(c[p, i])
            work += 0.5 * (fc * _I(zj + z[p], tau) + fcc * _I(zj + np.conj(z[p]), tau)).real
    diss = 0.0
    Cc = np.zeros(n, dtype=np.complex128)
    for p in range(nt):
        for i in range(n):
            s = 0j
            for l in range(n):
                s += csym[i, l] * c[p, l]
            Cc[i] = s  # Cs c_p (Cs symmetric: c_q . Cs c_p = c_p . Cs c_q)
        for q in range(nt):
            cc = 0j
            ccc = 0j
            for i in range(n):
                cc += c[q, i] * Cc[i]
                ccc += np.conj(c[q, i]) * Cc[i]
            diss += 0.5 * (cc * _I(z[p] + z[q], tau) + ccc * _I(z[p] + np.conj(z[q]), tau)).real
    return work, diss


@njit
def _integrals_quadrature(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0):
    """:func:`integrals` by composite 16-node Gauss-Legendre on sub-intervals no longer than half
    the shortest period of the piece (the integrands are sums of exponentials and harmonics),
    for pieces with resonant terms or rigid-body motion.
    """
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
            v = re_cmv(vv, eta)
            if xi.shape[0] > 0:
                v += re_cmv(vv0, xi)
            f = 0.0
            for j in range(om.shape[0]):
                ph = cmath.exp(1j * om[j] * (t0 + s))
                for i in range(v.shape[0]):
                    f += (fh[j, i] * ph).real * v[i]
            wgt = 0.5 * h * _GL_WEIGHTS[p]
            work += wgt * f
            diss += wgt * rdot(v, rmv(csym, v))
    return work, diss
