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

__all__ = ["RESONANCE", "modal_at", "zero_at", "state_at", "integrals", "E", "cmv", "rmv", "re_cmv",
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
def modal_at(lam, pair, a, P, beta, res, omt, tau):
    """The modal coordinates ``eta(tau)`` of the piece (complex).

    One exponential per conjugate pair of eigenvalues (``pair``, :func:`._modes._conjugate_pairs`:
    ``e^{conj(lambda) tau} = conj(e^{lambda tau})``) and one per harmonic, shared by every mode.
    """
    m2 = lam.shape[0]
    jt = omt.shape[0]
    harmonic = np.empty(jt, dtype=np.complex128)
    for j in range(jt):
        harmonic[j] = cmath.exp(1j * omt[j] * tau)
    own = np.empty(m2, dtype=np.complex128)
    eta = np.empty(m2, dtype=np.complex128)
    for k in range(m2):
        p = pair[k]
        own[k] = np.conj(own[p]) if 0 <= p < k else cmath.exp(lam[k] * tau)
        s = a[k] * own[k]
        for j in range(jt):
            if res[k, j]:
                s += beta[k, j] * E(lam[k], 1j * omt[j], tau)
            else:
                s += P[k, j] * harmonic[j]
        eta[k] = s
    return eta


@njit
def zero_at(Xi, X, omt, tau):
    """The zero-eigenvalue block's coordinates ``xi(tau)`` (:func:`._setup._zero_block`)."""
    k0 = Xi.shape[1]
    xi = np.zeros(k0, dtype=np.complex128)
    for p in range(Xi.shape[0] - 1, -1, -1):
        xi = xi * tau + Xi[p]
    for j in range(1, X.shape[0]):
        xi = xi + X[j] * cmath.exp(1j * omt[j] * tau)
    return xi


@njit
def state_at(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, q0, tau):
    """``(q, v)`` at ``tau`` after the piece start: ``q = q0 + Re(Vq eta + Vq0 xi)``, ``v = Re(Vv eta + Vv0 xi)``."""
    eta = modal_at(lam, pair, a, P, beta, res, omt, tau)
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
        return _integrals_quadrature(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh,
                                     t0)
    m2 = lam.shape[0]
    jt = omt.shape[0]
    n = vv.shape[0]
    for k in range(m2):
        for j in range(jt):
            if res[k, j]:
                return _integrals_quadrature(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om,
                                             fh, t0)
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
def _integrals_quadrature(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0):
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
            eta = modal_at(lam, pair, a, P, beta, res, omt, s)
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
