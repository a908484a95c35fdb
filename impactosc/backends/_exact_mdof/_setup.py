"""The set-up of one piece (compiled): what a mode fixes once, and what each piece start adds.

A piece's closed form (:mod:`._forms`) needs the modal forcing ``beta``, the particular
amplitudes ``P = beta / (i omega_j - lambda_k)``, the modal amplitudes ``a = eta(0) - sum_j P``
and, per guard, its exponential, harmonic and resonant coefficients and rounding scales. Of
these, everything but the start state's share depends on the mode only: the resonance flags and
the reciprocals ``1 / (i omega_j - lambda_k)``, the harmonic forces' modal images, each guard's
harmonic coefficients (up to the phase ``e^{i omega_j t0}``) and the rounding scales' linear
maps of ``|q0|`` and ``|v0|``. :func:`mode_constants` computes them once per mode (a row of the
compiled mode table); :func:`setup_piece` adds the start state's share.
"""

from __future__ import annotations

import cmath

import numpy as np

from ..._util.jit import njit
from ._forms import RESONANCE, cmv

__all__ = ["mode_constants", "setup_piece"]


@njit
def mode_constants(lam, gin, gv, wk, ga, gu, gc, kmode, const, om, fh):
    """What every piece of a mode shares: ``(omt, res, inv_d, rk, rj, Gh, Dh, cs0, csq, csv, ds0, dsq,
    dsv, poly0, Xi0, X0)``.

    ``omt``: the frequencies (``omt[0] = 0``, the constant forces); ``res[k, j]``: the pair
    ``(lambda_k, i omega_j)`` keeps the stable form ``E`` (:data:`._forms.RESONANCE`), ``rk, rj``
    its indices; ``inv_d[k, j] = 1 / (i omega_j - lambda_k)`` (0 at resonance); ``Gh[k, j]``: the
    modal image of harmonic ``j``'s force; ``Dh[g, j]``: guard ``g``'s coefficient of
    ``e^{i omega_j tau}`` for a piece starting at phase 0 (its particular solution and its direct
    dependence on the force); the rounding scales of :func:`_rounding_scales` as
    ``cs0 + csq |q0| + csv |v0|`` (and ``ds*`` for the derivative: they are affine in ``|q0|``,
    ``|v0|``); and the zero-eigenvalue block's empty coefficients for a mode without one.
    """
    m2 = lam.shape[0]
    nh = om.shape[0]
    jt = nh + 1
    n = kmode.shape[0]
    ng = wk.shape[0]
    omt = np.zeros(jt)
    omt[1:] = om
    res = np.zeros((m2, jt), dtype=np.bool_)
    inv_d = np.zeros((m2, jt), dtype=np.complex128)
    nres = 0
    for k in range(m2):
        for j in range(jt):
            d = 1j * omt[j] - lam[k]
            if abs(d) <= RESONANCE * max(abs(lam[k]), omt[j]):
                res[k, j] = True
                nres += 1
            else:
                inv_d[k, j] = 1.0 / d
    rk = np.empty(nres, dtype=np.int64)
    rj = np.empty(nres, dtype=np.int64)
    r = 0
    for k in range(m2):
        for j in range(jt):
            if res[k, j]:
                rk[r], rj[r] = k, j
                r += 1
    Gh = np.empty((m2, nh), dtype=np.complex128)
    for j in range(nh):
        Gh[:, j] = cmv(gin, fh[j])
    Dh = np.empty((ng, nh), dtype=np.complex128)
    for g in range(ng):
        for j in range(nh):
            s = 0j
            for k in range(m2):
                s += wk[g, k] * Gh[k, j] * inv_d[k, j + 1]
            for i in range(n):
                s += gu[g, i] * fh[j, i]
            Dh[g, j] = s
    zero = np.zeros(n)
    cs0, ds0 = _rounding_scales(lam, gin, gv, wk, ga, gc, kmode, const, omt, fh, zero, zero, res)
    csq = np.empty((ng, n))
    csv = np.empty((ng, n))
    dsq = np.empty((ng, n))
    dsv = np.empty((ng, n))
    for i in range(n):
        unit = np.zeros(n)
        unit[i] = 1.0
        c, d = _rounding_scales(lam, gin, gv, wk, ga, gc, kmode, const, omt, fh, unit, zero, res)
        csq[:, i] = c - cs0  # the scales only add non-negative terms: the differences are >= 0
        dsq[:, i] = d - ds0
        c, d = _rounding_scales(lam, gin, gv, wk, ga, gc, kmode, const, omt, fh, zero, unit, res)
        csv[:, i] = c - cs0
        dsv[:, i] = d - ds0
    poly0 = np.zeros((ng, 1))
    Xi0 = np.zeros((1, 0), dtype=np.complex128)
    X0 = np.zeros((jt, 0), dtype=np.complex128)
    return omt, res, inv_d, rk, rj, Gh, Dh, cs0, csq, csv, ds0, dsq, dsv, poly0, Xi0, X0


@njit
def setup_piece(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gc, kmode, const, om, fh, constants, t0, q0, v0):
    """The coefficients of the piece that starts at ``(t0, q0, v0)`` in a mode (``constants``: its
    :func:`mode_constants`).

    Returns ``(a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, dscale, poly, Xi, X)``: the
    modal amplitudes of the classical form, the particular amplitudes, the modal forcing, the
    resonance flags, for every guard its exponential, harmonic and resonant coefficients and
    constant, the frequencies (``omt[0] = 0``), the rounding scales of each guard's value and
    derivative at the start (:func:`_rounding_scales`), and the zero-eigenvalue block: each
    guard's polynomial coefficients ``poly[g, p]`` (of ``tau^p``) and the block's coordinates
    ``xi = sum_p Xi[p] tau^p + sum_j X[j] e^{i omega_j tau}``.
    """
    omt, res, inv_d, rk, rj, Gh, Dh, cs0, csq, csv, ds0, dsq, dsv, poly0, Xi0, X0 = constants
    m2 = lam.shape[0]
    nh = om.shape[0]
    jt = nh + 1
    n = q0.shape[0]
    ng = wk.shape[0]
    nres = rk.shape[0]
    phase = np.empty(nh, dtype=np.complex128)
    for j in range(nh):
        phase[j] = cmath.exp(1j * om[j] * t0)
    f0 = np.empty(n)  # const - K q0 in real numbers first: a preloaded spring's two forces cancel there
    for i in range(n):
        s = const[i]
        for m in range(n):
            s -= kmode[i, m] * q0[m]
        f0[i] = s
    beta = np.empty((m2, jt), dtype=np.complex128)
    P = np.empty((m2, jt), dtype=np.complex128)
    a = np.empty(m2, dtype=np.complex128)
    for k in range(m2):
        b = 0j
        e = 0j
        for i in range(n):
            b += gin[k, i] * f0[i]
            e += gv[k, i] * v0[i]
        beta[k, 0] = b
        for j in range(nh):
            beta[k, j + 1] = Gh[k, j] * phase[j]
        for j in range(jt):
            P[k, j] = beta[k, j] * inv_d[k, j]  # 0 at resonance, where E holds the term
            e -= P[k, j]
        a[k] = e
    W = np.empty((ng, m2), dtype=np.complex128)
    D = np.empty((ng, jt), dtype=np.complex128)
    RG = np.empty((ng, nres), dtype=np.complex128)
    c0 = np.empty(ng)
    cscale = np.empty(ng)
    dscale = np.empty(ng)
    for g in range(ng):
        for k in range(m2):
            W[g, k] = wk[g, k] * a[k]
        # A conjugate pair in one term: Re(W1 e^{l t} + W2 e^{conj(l) t}) = Re((W1 + conj(W2)) e^{l t}),
        # half the exponentials in the guard search (whose loops skip the zero partner).
        for k in range(m2):
            if pair[k] > k:
                W[g, k] += np.conj(W[g, pair[k]])
                W[g, pair[k]] = 0j
        s = 0j
        for k in range(m2):
            s += wk[g, k] * P[k, 0]
        D[g, 0] = s
        for j in range(nh):
            D[g, j + 1] = Dh[g, j] * phase[j]
        for r in range(nres):
            RG[g, r] = wk[g, rk[r]] * beta[rk[r], rj[r]]
        s = gc[g]
        cs = cs0[g]
        ds = ds0[g]
        for i in range(n):
            s += ga[g, i] * q0[i]
            cs += csq[g, i] * abs(q0[i]) + csv[g, i] * abs(v0[i])
            ds += dsq[g, i] * abs(q0[i]) + dsv[g, i] * abs(v0[i])
        c0[g] = s
        cscale[g] = cs
        dscale[g] = ds
    k0 = N.shape[0]
    if k0 == 0:
        return a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, dscale, poly0, Xi0, X0
    Xi, X = _zero_block(N, gin0, gv0, om, fh, t0, q0, v0, const, kmode)
    poly = np.zeros((ng, k0 + 1))
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
    f0abs = _abs_affine(const, kmode, q0)  # the size of the terms of const - K q0
    cscale = _abs_affine(gc, ga, q0)
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
def _abs_affine(c, A, x):
    """``|c_i| + sum_m |A_im x_m|`` for each row: the size of the terms of ``c + A x`` before they cancel."""
    out = np.empty(c.shape[0])
    for i in range(c.shape[0]):
        s = abs(c[i])
        for m in range(x.shape[0]):
            s += abs(A[i, m] * x[m])
        out[i] = s
    return out

