"""Closed-form slipping pieces of the exact backend for damped and harmonic-sum members.

The eq. 3 piece (one harmonic, no damping) lives in :mod:`._exact_piece`; this
module is its generalisation to the linear family: viscous damping ``2 zeta Y'`` and a sum
of harmonics. In region ``r`` with motion ``s`` (``Y = X - r``, see :mod:`.exact`)::

    Y'' + 2 zeta Y' + w^2 Y = cY + sum_i F_i cos(Omega_i t + phase_i),   w^2 = 1 + K r^2.

Solution
--------
``Y = Yc + sum_i Re(Q_i e^{i Omega_i tau}) + Yh(tau)`` with ``Yc = cY / w^2``, the steady
response ``Q_i = F_i e^{i theta0_i} / (w^2 - Omega_i^2 + 2 i zeta Omega_i)`` of each harmonic
(``theta0_i = Omega_i t0 + phase_i``, ``tau = t - t0``) and the homogeneous part::

    Yh = A EC + (B + zeta A) ES,   EC = e^{-zeta tau} C,   ES = e^{-zeta tau} S,

where ``(C, S)`` is ``(cos(wd tau), sin(wd tau) / wd)`` underdamped (``wd^2 = w^2 - zeta^2``),
``(1, tau)`` critically damped and ``(cosh(mu tau), sinh(mu tau) / mu)`` overdamped
(``mu^2 = zeta^2 - w^2``): one formula for the three cases, with no ``1 / wd`` blowing up at
the critical point. ``A, B`` match ``Y(0) = y0, Y'(0) = v0``. Overdamped, ``EC`` and ``ES``
are formed from ``e^{-(zeta -+ mu) tau}`` (``zeta - mu = w^2 / (zeta + mu)``) so nothing
overflows. The k-th derivative of ``Yh`` has the same form with ``(A_k, B_k)`` from
``(A_{k+1}, B_{k+1}) = (B_k, -w^2 A_k - 2 zeta B_k)``. ``Y`` itself is evaluated about the
start point, ``y0 + A (EC - 1) + (B + zeta A) ES + sum_i Re(Q_i (e^{i Omega_i tau} - 1))``,
with ``EC - 1`` and ``e^{i x} - 1`` formed without cancellation (``expm1`` and
``-2 sin^2(x / 2)``), so a huge ``cY`` (huge ``beta``) never cancels against ``A``.

Near a resonance
----------------
Where ``|D_i| = |w^2 - Omega_i^2 + 2 i zeta Omega_i|`` is small the steady response ``Q_i``
is huge and cancels against its share of ``A, B``: ``Y`` loses ``log10(w^2 / |D_i|)``
digits (1.4e-6 in the event times of a ``zeta = 2e-6`` resonance over t = 200).
A harmonic with ``|D_i| < NEAR_RESONANCE w^2`` (so underdamped, ``wd`` close to ``w``)
is therefore kept out of ``Q``, ``A`` and ``B`` and enters as its response from rest,
``Re(P_i g_i(tau))`` with ``P_i = F_i e^{i theta0_i}`` and ``g`` the convolution of
``e^{i Omega tau}`` with the impulse response ``h = ES = (e^{lambda+ tau} - e^{lambda- tau}) / (2 i wd)``::

    g = e^{i Omega tau} tau (phi1(a+ tau) - phi1(a- tau)) / (2 i wd),   phi1(z) = (e^z - 1) / z,

``a+- = lambda+- - i Omega = -zeta + i (+-wd - Omega)``: a divided difference that needs no
division by ``D_i`` (``a+`` is small near resonance and ``phi1`` tends to 1; an exact
undamped resonance is the secular growth ``tau e^{i w tau} / (2 i w)``). Its derivatives
``g_{k+1} = h_k + i Omega g_k`` and its integral ``(tau phi1(i Omega tau) - g_1 - 2 zeta g) / w^2``
(the integrated equation of ``g``) follow without cancellation, and
``|g| <= tau min(tau, 1 / wd)`` bounds it for the guard search. The backend still refuses
``|D_i| < 1e-6 w^2`` (:func:`near_resonance`); eq. 3 itself keeps the resonance-safe piece
of :mod:`.exact`.

Derivative bounds
-----------------
On ``[a, b]``, with ``rho = zeta`` (overdamped ``zeta - mu``) and ``D = e^{-rho a}``:
``|EC| <= D`` and ``0 <= ES <= min(b D, D / wd, max_{[a, b]} tau e^{-rho tau})``
underdamped (``D / (2 mu)`` in place of ``D / wd`` overdamped, neither when critical),
so ``|Y^(k)| <= |A_k| D + |B_k + zeta A_k| max ES + sum_i |Q_i| Omega_i^k`` (a
near-resonant harmonic: ``|P_i|`` times the bound of ``|g_k|`` from those of ``|h_m|``): a bound of
the derivatives of the formula as evaluated, with the rounded ``A`` and ``B``. Taken per
window (``a > 0``), the decay lets the search prove the sign of an overdamped velocity that
creeps to zero.

Integrals
---------
``int Y`` in closed form from the integrated homogeneous equation,
``int ES = -(EC - 1 + zeta ES) / w^2`` and
``int (EC + zeta ES) - tau = (ES - tau) - 2 zeta (EC - 1 + zeta ES) / w^2``;
``int Y^2`` and ``int V^2`` by the Gauss-Legendre rule of :mod:`.exact` on sub-intervals
of half the period of the fastest rate ``max(w, Omega_i, zeta + mu)``.

Layout
------
Compiled once (:mod:`impactosc._jit`) and shared by the exact backend's Python stepper and
its compiled event loop. A mode's constants are a float array (``F_*`` indices, then
``F_PER`` numbers per harmonic: ``F_i, Omega_i, phase_i``, the complex gain ``F_i H_i``, the
near-resonance flag and ``wd - Omega_i``); a piece's
state starts with the common header of :mod:`._exact_piece` (``H_*``), so the one piece
algorithm :func:`._exact_piece.advance_piece` runs both families.
"""

from __future__ import annotations

import math

import numpy as np

from ..._util.jit import njit
from ...model._rule import P_BETA, P_K, P_RIGID, P_TERMS, P_ZETA, wall
from ._piece import (
    H_BETA,
    H_DIR,
    H_END_ORDER,
    H_K,
    H_LEVEL,
    H_REF,
    H_SCALE,
    H_SIZE,
    H_T0,
    H_V0,
    H_WINDOW,
    H_X0,
    H_Y0,
    H_ZETA,
    advance_piece,
    evaluate_piece,
)

__all__ = ["mode_rates", "near_resonance", "mode_constants", "piece_state", "advance_family", "evaluate_family"]

_EPS = 2.0**-52
_TWO_PI = 2.0 * math.pi
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
#: A harmonic with ``|w^2 - Omega_i^2 + 2 i zeta Omega_i| < NEAR_RESONANCE w^2`` takes the
#: near-resonant form (the response from rest as a divided difference, see the module
#: docstring); the steady-response form loses ``log10(w^2 / |D|)`` digits to cancellation,
#: at most 0.6 above this threshold.
NEAR_RESONANCE = 0.25
#: Refusal threshold of :func:`near_resonance` (a steady amplitude over 1e6 times the static one).
RESONANCE_RATIO = 1e-6

# z - sin z and sinh z - z = z^3/3! -+ z^5/5! + ...: nine terms reach z^19/19!, below an ulp for |z| < 1.
_SERIES = np.array([1.0 / math.factorial(2 * k + 3) for k in reversed(range(9))])

# Mode constants; the harmonics follow from F_TERMS, F_PER numbers each: F_i, Omega_i,
# phase_i, the complex gain F_i H_i (Re, Im; 0 for a harmonic near resonance), the flag of
# the near-resonant form and wd - Omega_i.
(F_REF, F_K, F_BETA, F_ZETA, F_W2, F_W, F_CY, F_YC, F_KIND, F_WD, F_MU, F_LO, F_HI, F_FASTEST,
 F_N) = range(15)
F_TERMS = 15
F_PER = 7
# Piece state after the common header: the homogeneous amplitudes (A_k, B_k), k = 0..5, the
# start values of Y^(k), k = 0..3, then per harmonic (G_PER numbers) Q_i = (Re, Im, Omega_i),
# Q_i (i Omega_i)^k, k = 1..3 (Re, Im), the flag of the near-resonant form and
# P_i = F_i e^{i theta0_i} (Re, Im); the mode constants are copied behind (G_MC).
G_AB = H_SIZE  # 12 numbers
G_AT0 = G_AB + 12  # 4 numbers
G_N = G_AT0 + 4
G_Q = G_N + 1
G_PER = 12


def mode_rates(osc, region: int) -> tuple[float, float]:
    """``(w^2, zeta)`` of a slipping mode in ``region``."""
    return (1.0 + osc.K if region and not osc.rigid else 1.0), osc.zeta


def near_resonance(osc) -> str | None:
    """A description of the first harmonic too close to an undamped resonance, or None.

    The near-resonant form follows these too (it agreed with heyoka to 4e-11 at an exact
    undamped resonance); the refusal is kept until the exact backend's tests say otherwise.
    """
    regions = (0,) if osc.rigid else (0, 1)
    for region in regions:
        w2, zeta = mode_rates(osc, region)
        for F, Om, _ in osc.terms:
            if F > 0.0 and Om > 0.0 and abs(complex(w2 - Om * Om, 2.0 * zeta * Om)) < RESONANCE_RATIO * w2:
                where = "in contact" if region else "free"
                return (f"a forcing harmonic at resonance (Omega_i={Om!r}, natural frequency {math.sqrt(w2)!r} "
                        f"{where}, zeta={zeta!r}: steady amplitude over {1 / RESONANCE_RATIO:g} static)")
    return None


@njit
def _odd_tail(z, sign):
    """``z - sin z`` (``sign = 1``) or ``sinh z - z`` (``sign = -1``) without cancellation."""
    if abs(z) >= 1.0:
        return z - math.sin(z) if sign > 0 else math.sinh(z) - z
    u = z * z
    series = 0.0
    for c in _SERIES:
        series = c - sign * u * series
    return z * u * series


@njit
def mode_constants(p, r, s):
    """Constants of the slipping mode ``(r, s)`` of the member ``p`` (:func:`impactosc._rule.params`)."""
    n_all = (p.shape[0] - P_TERMS) // 3
    n = 0
    for i in range(n_all):
        if p[P_TERMS + 3 * i] > 0.0:
            n += 1
    fm = np.empty(F_TERMS + F_PER * n)
    K, beta, z = p[P_K], p[P_BETA], p[P_ZETA]
    w2 = 1.0 + K if r != 0 and p[P_RIGID] == 0.0 else 1.0
    w = math.sqrt(w2)
    ref = wall(p, r) if r != 0 else 0.0  # the flange of region r, at r gap
    cY = (-ref - beta * s) if r != 0 else -beta * s  # as in _exact_piece.mode_constants
    fm[F_REF], fm[F_K], fm[F_BETA], fm[F_ZETA], fm[F_W2], fm[F_W] = ref, K, beta, z, w2, w
    fm[F_CY], fm[F_YC] = cY, cY / w2
    fm[F_WD] = fm[F_MU] = fm[F_LO] = fm[F_HI] = 0.0
    if z < w:
        fm[F_KIND], fm[F_WD] = 0.0, math.sqrt((w - z) * (w + z))
    elif z == w:
        fm[F_KIND] = 1.0
    else:
        mu = math.sqrt((z - w) * (z + w))
        fm[F_KIND], fm[F_MU], fm[F_HI] = 2.0, mu, z + mu
        fm[F_LO] = w2 / (z + mu)  # zeta - mu without cancellation
    fastest = max(w, fm[F_HI])
    j = F_TERMS
    for i in range(n_all):
        F, Om, ph = p[P_TERMS + 3 * i], p[P_TERMS + 3 * i + 1], p[P_TERMS + 3 * i + 2]
        if not F > 0.0:
            continue
        den = complex(w2 - Om * Om, 2.0 * z * Om)
        fm[j], fm[j + 1], fm[j + 2] = F, Om, ph
        if Om > 0.0 and abs(den) < NEAR_RESONANCE * w2:
            # Near resonance (so underdamped, wd close to w): the divided-difference form,
            # with wd - Omega = (w^2 - zeta^2 - Omega^2) / (wd + Omega) without cancellation.
            fm[j + 3] = fm[j + 4] = 0.0
            fm[j + 5], fm[j + 6] = 1.0, ((w - Om) * (w + Om) - z * z) / (fm[F_WD] + Om)
        else:
            gain = F / den  # the complex steady gain F_i H_i
            fm[j + 3], fm[j + 4], fm[j + 5], fm[j + 6] = gain.real, gain.imag, 0.0, 0.0
        fastest = max(fastest, Om)
        j += F_PER
    fm[F_FASTEST], fm[F_N] = fastest, float(n)
    return fm


@njit
def piece_state(fm, t0, x0, v0):
    """The state of the piece that starts at ``(t0, x0, v0)`` in the mode of ``fm``."""
    n = int(fm[F_N])
    g_mc = G_Q + G_PER * n
    ps = np.empty(g_mc + fm.shape[0])
    y0 = x0 - fm[F_REF]
    z, w2 = fm[F_ZETA], fm[F_W2]
    ps[H_T0], ps[H_X0], ps[H_V0], ps[H_Y0] = t0, x0, v0, y0
    ps[H_DIR] = ps[H_SCALE] = ps[H_END_ORDER] = 1.0
    ps[H_LEVEL] = 0.0
    ps[H_WINDOW] = _TWO_PI / fm[F_FASTEST]
    ps[H_REF], ps[H_K], ps[H_BETA], ps[H_ZETA] = fm[F_REF], fm[F_K], fm[F_BETA], z
    ps[G_N] = float(n)
    # Q_i: the steady response of each harmonic at the piece start, and Q_i (i Omega_i)^k
    # (zero for a near-resonant harmonic, whose response from rest P_i g_i is separate).
    sum_re = sum_v = 0.0
    for i in range(n):
        f = F_TERMS + F_PER * i
        Om = fm[f + 1]
        th = Om * t0 + fm[f + 2]  # the phase as the engine evaluates the forcing
        e = complex(math.cos(th), math.sin(th))
        Q = complex(fm[f + 3], fm[f + 4]) * e
        q = G_Q + G_PER * i
        ps[q], ps[q + 1], ps[q + 2] = Q.real, Q.imag, Om
        Qk = Q
        for k in range(3):
            Qk = Qk * complex(0.0, Om)
            ps[q + 3 + 2 * k], ps[q + 4 + 2 * k] = Qk.real, Qk.imag
        ps[q + 9] = fm[f + 5]
        P = fm[f] * e if fm[f + 5] != 0.0 else 0.0 * e
        ps[q + 10], ps[q + 11] = P.real, P.imag
        sum_re += Q.real
        sum_v -= Om * Q.imag  # Re(i Omega Q)
    # (A_k, B_k) for k = 0..5: Y^(k)_h has the form of Y_h with these amplitudes.
    a, b = y0 - fm[F_YC] - sum_re, v0 - sum_v
    for k in range(6):
        ps[G_AB + 2 * k], ps[G_AB + 2 * k + 1] = a, b
        a, b = b, -w2 * a - 2.0 * z * b
    # The derivatives are evaluated about their start values: V(0) is v0 exactly; Y''(0) and
    # Y'''(0) are those of the formula, A_k + sum_i Re(Q_i (i Omega_i)^k), so each evaluated
    # derivative is exactly the derivative of the one below it and the bounds hold for the
    # functions the guard search sees.
    ps[G_AT0], ps[G_AT0 + 1] = y0, v0
    for k in (2, 3):
        acc = ps[G_AB + 2 * k]
        for i in range(n):
            q = G_Q + G_PER * i
            acc += ps[q + 3 + 2 * (k - 1)]
            if ps[q + 9] != 0.0:  # Re(P g_k(0)), g_k the k-th derivative: g_2(0) = 1, g_3(0) = i Omega - 2 zeta
                acc += ps[q + 10] if k == 2 else -2.0 * z * ps[q + 10] - ps[q + 2] * ps[q + 11]
        ps[G_AT0 + k] = acc
    ps[g_mc:] = fm
    return ps


@njit
def _basis(fm, tau):
    """``(EC, ES, EC - 1)`` at ``tau`` (see the module docstring)."""
    z = fm[F_ZETA]
    if fm[F_KIND] == 2.0:
        lo, hi, mu = fm[F_LO], fm[F_HI], fm[F_MU]
        ep, em = math.exp(-lo * tau), math.exp(-hi * tau)
        es = ep * (-math.expm1(-2.0 * mu * tau)) / (2.0 * mu)
        return 0.5 * (ep + em), es, 0.5 * (math.expm1(-lo * tau) + math.expm1(-hi * tau))
    e, em1 = math.exp(-z * tau), math.expm1(-z * tau)
    if fm[F_KIND] == 1.0:
        return e, e * tau, em1
    wd = fm[F_WD]
    c = math.cos(wd * tau)
    h = math.sin(0.5 * wd * tau)
    return e * c, e * math.sin(wd * tau) / wd, em1 * c - 2.0 * h * h


@njit
def _es_minus_tau(fm, tau, es):
    """``ES - tau`` with the small-``tau`` cancellation removed."""
    z = fm[F_ZETA]
    if fm[F_KIND] == 1.0:
        return tau * math.expm1(-z * tau)
    if fm[F_KIND] == 0.0:
        wd = fm[F_WD]
        return -math.exp(-z * tau) * _odd_tail(wd * tau, 1.0) / wd + tau * math.expm1(-z * tau)
    mu = fm[F_MU]
    if mu * tau < 1.0:  # the series where sinh stays finite, else directly
        return math.exp(-z * tau) * _odd_tail(mu * tau, -1.0) / mu + tau * math.expm1(-z * tau)
    return es - tau


@njit
def _mc(ps):
    return ps[G_Q + G_PER * int(ps[G_N]):]


@njit
def _phi1(x, y):
    """``(e^z - 1) / z`` at ``z = x + i y`` without cancellation (1 at ``z = 0``)."""
    if x == 0.0 and y == 0.0:
        return complex(1.0, 0.0)
    h = math.sin(0.5 * y)
    em1 = complex(math.expm1(x) * math.cos(y) - 2.0 * h * h, math.exp(x) * math.sin(y))
    return em1 / complex(x, y)


@njit
def _g01(ps, q, fm, tau, es):
    """``(g, g_1)`` of the near-resonant harmonic at ``q``: the response from rest to ``e^{i Omega tau}``.

    ``g = e^{i Omega tau} tau (phi1(a+ tau) - phi1(a- tau)) / (2 i wd)`` with
    ``a+- = -zeta + i (+-wd - Omega)``, ``phi1(z) = (e^z - 1) / z``: the divided difference
    of the convolution of ``e^{i Omega tau}`` with the impulse response ``ES`` (module
    docstring). Near resonance ``a+ tau`` is small and ``phi1`` tends to 1, so nothing
    cancels; its derivative is ``g_1 = ES + i Omega g``.
    """
    Om = ps[q + 2]
    z, wd = fm[F_ZETA], fm[F_WD]
    dlt = fm[F_TERMS + F_PER * ((q - G_Q) // G_PER) + 6]  # wd - Omega
    d = _phi1(-z * tau, dlt * tau) - _phi1(-z * tau, -(wd + Om) * tau)
    rot = complex(math.cos(Om * tau), math.sin(Om * tau))
    g = rot * d * complex(0.0, -0.5 * tau / wd)
    return g, es + complex(0.0, Om) * g


@njit
def _resonant_delta(ps, q, fm, tau, k, ecm1, es):
    """``Re(P (g_k(tau) - g_k(0)))`` of the near-resonant harmonic at ``q``, ``1 <= k <= 3``.

    ``g_1 = h + i Omega g``, ``g_2 = h_1 + i Omega g_1``, ``g_3 = h_2 + i Omega g_2`` with the
    impulse response ``h = ES``, ``h_1 = EC - zeta ES``, ``h_2 = -2 zeta EC + (2 zeta^2 - w^2) ES``
    (``h(0) = 0``, ``h_1(0) = 1``), each about its start value through ``EC - 1``.
    """
    z, w2 = fm[F_ZETA], fm[F_W2]
    iom = complex(0.0, ps[q + 2])
    g, d = _g01(ps, q, fm, tau, es)  # d = g_k - g_k(0), here k = 1
    if k >= 2:
        d = (ecm1 - z * es) + iom * d
    if k >= 3:
        d = (-2.0 * z * ecm1 + (2.0 * z * z - w2) * es) + iom * d
    return ps[q + 10] * d.real - ps[q + 11] * d.imag


@njit
def _deriv(ps, fm, tau, k, ecm1, es):
    """``Y^(k)`` at ``tau`` for ``1 <= k <= 3``, about its value at the start."""
    a, b = ps[G_AB + 2 * k], ps[G_AB + 2 * k + 1]
    out = a * ecm1 + (b + fm[F_ZETA] * a) * es
    for i in range(int(ps[G_N])):
        q = G_Q + G_PER * i
        if ps[q + 9] != 0.0:
            out += _resonant_delta(ps, q, fm, tau, k, ecm1, es)
            continue
        Om = ps[q + 2]
        cr, ci = ps[q + 3 + 2 * (k - 1)], ps[q + 4 + 2 * (k - 1)]
        h = math.sin(0.5 * Om * tau)
        out += -2.0 * cr * h * h - ci * math.sin(Om * tau)  # Re(Q_k (e^{i Omega tau} - 1))
    return ps[G_AT0 + k] + out


@njit
def va(ps, tau):
    """``(V, Y'')`` at ``tau``."""
    fm = _mc(ps)
    _, es, ecm1 = _basis(fm, tau)
    return _deriv(ps, fm, tau, 1, ecm1, es), _deriv(ps, fm, tau, 2, ecm1, es)


@njit
def aj(ps, tau):
    """``(Y'', Y''')`` at ``tau``."""
    fm = _mc(ps)
    _, es, ecm1 = _basis(fm, tau)
    return _deriv(ps, fm, tau, 2, ecm1, es), _deriv(ps, fm, tau, 3, ecm1, es)


@njit
def state_at(ps, tau):
    """``(Y, V, 0, Y - y0)`` at ``tau`` (the layout of :func:`._exact_piece.advance_piece`)."""
    fm = _mc(ps)
    z = fm[F_ZETA]
    A, B = ps[G_AB], ps[G_AB + 1]
    _, es, ecm1 = _basis(fm, tau)
    dy = A * ecm1 + (B + z * A) * es
    dv = B * ecm1 + (ps[G_AB + 3] + z * B) * es
    for i in range(int(ps[G_N])):
        q = G_Q + G_PER * i
        if ps[q + 9] != 0.0:  # near resonance: Re(P g), Re(P g_1), the response from rest
            g, g1 = _g01(ps, q, fm, tau, es)
            dy = dy + (ps[q + 10] * g.real - ps[q + 11] * g.imag)
            dv = dv + (ps[q + 10] * g1.real - ps[q + 11] * g1.imag)
            continue
        Om = ps[q + 2]
        sn = math.sin(Om * tau)
        h = math.sin(0.5 * Om * tau)
        h2 = 2.0 * h * h
        dy = dy - (ps[q] * h2 + ps[q + 1] * sn)  # Re(Q (e^{i Omega tau} - 1))
        dv = dv - (ps[q + 3] * h2 + ps[q + 4] * sn)
    return ps[H_Y0] + dy, ps[H_V0] + dv, 0.0, dy


@njit
def int_y(ps, tau, dp):
    """``int_0^tau Y`` in closed form (``dp`` is unused)."""
    fm = _mc(ps)
    z, w2 = fm[F_ZETA], fm[F_W2]
    A, B = ps[G_AB], ps[G_AB + 1]
    _, es, ecm1 = _basis(fm, tau)
    g = (ecm1 + z * es) / w2
    out = ps[H_Y0] * tau + A * (_es_minus_tau(fm, tau, es) - 2.0 * z * g) - B * g
    for i in range(int(ps[G_N])):
        q = G_Q + G_PER * i
        Om = ps[q + 2]
        if ps[q + 9] != 0.0:
            # int g = (tau phi1(i Omega tau) - g_1 - 2 zeta g) / w^2 (the integrated equation of g)
            gr, gr1 = _g01(ps, q, fm, tau, es)
            ig = (tau * _phi1(0.0, Om * tau) - gr1 - 2.0 * z * gr) / w2
            out = out + (ps[q + 10] * ig.real - ps[q + 11] * ig.imag)
            continue
        if Om == 0.0:
            continue  # a constant term: Y_i - Y_i(0) = 0
        h = math.sin(0.5 * Om * tau)
        out = out - (ps[q] * _odd_tail(Om * tau, 1.0) + 2.0 * ps[q + 1] * h * h) / Om
    return out


@njit
def squares(ps, tau, need_y, need_v):
    """``(int_0^tau Y^2, int_0^tau V^2)`` by composite 16-node Gauss-Legendre."""
    if tau <= 0.0 or not (need_y or need_v):
        return 0.0, 0.0
    n = max(1, math.ceil(tau * _mc(ps)[F_FASTEST] / math.pi))
    h = tau / n
    sy = sv = 0.0
    for i in range(n):
        left = h * i
        for j in range(_GL_NODES.shape[0]):
            y, v, _, _ = state_at(ps, left + 0.5 * h * (_GL_NODES[j] + 1.0))
            wj = 0.5 * h * _GL_WEIGHTS[j]
            sy += wj * (y * y)
            sv += wj * (v * v)
    return sy, sv


@njit
def _decay_bounds(fm, start, tmax):
    """Upper bounds of ``|EC|`` and ``|ES|`` on ``[start, tmax]`` (see the module docstring)."""
    kind = fm[F_KIND]
    rho = fm[F_LO] if kind == 2.0 else fm[F_ZETA]
    decay = math.exp(-rho * start)
    es = tmax * decay  # |S| <= tau
    if kind == 0.0:
        es = min(es, decay / fm[F_WD])
    elif kind == 2.0:
        es = min(es, 0.5 * decay / fm[F_MU])
    if rho > 0.0:  # tau e^{-rho tau} peaks at 1 / rho
        peak = start * decay if rho * start >= 1.0 else 1.0 / (math.e * rho)
        es = min(es, peak)
    return decay, es


@njit
def bounds(ps, start, tmax, k):
    """Upper bounds of ``|Y^(k+2)|`` and ``|Y^(k+3)|`` over ``[start, tmax]`` (module docstring)."""
    fm = _mc(ps)
    ecb, esb = _decay_bounds(fm, start, tmax)
    z, w2 = fm[F_ZETA], fm[F_W2]
    # |h_m| of the impulse response h = ES (amplitudes (0, 1) through the same recurrence),
    # for the near-resonant harmonics: g_j = sum_{m<j} (i Omega)^(j-1-m) h_m + (i Omega)^j g.
    bh = np.empty(6)
    a, b = 0.0, 1.0
    for m in range(6):
        bh[m] = abs(a) * ecb + abs(b + z * a) * esb
        a, b = b, -w2 * a - 2.0 * z * b
    o = np.zeros(2)
    for m in range(2):
        j = k + 2 + m
        a, b = ps[G_AB + 2 * j], ps[G_AB + 2 * j + 1]
        acc = abs(a) * ecb + abs(b + z * a) * esb
        for i in range(int(ps[G_N])):
            q = G_Q + G_PER * i
            Om = ps[q + 2]
            if ps[q + 9] != 0.0:
                acc += math.hypot(ps[q + 10], ps[q + 11]) * _resonant_bound(fm, q, Om, tmax, bh, j)
                continue
            acc += math.hypot(ps[q], ps[q + 1]) * Om ** j
        o[m] = acc * (1.0 + 1e-9) + 1e-300
    return o[0], o[1]


@njit
def _resonant_bound(fm, q, Om, tmax, bh, j):
    """An upper bound of ``|g_j|`` on ``[start, tmax]`` (``bh``: bounds of ``|h_m|`` there).

    ``|g| <= int_0^tau |h| <= tau min(tau, 1 / wd)`` (and ``<= 1 / (zeta wd)`` damped), or
    from the steady form ``|g| <= (2 + |zeta + i Omega| / wd) / |D|``, ``|D| = |a+| |a-|``.
    """
    z, wd = fm[F_ZETA], fm[F_WD]
    dlt = fm[F_TERMS + F_PER * ((q - G_Q) // G_PER) + 6]
    bg = tmax * min(tmax, 1.0 / wd)
    if z > 0.0:
        bg = min(bg, 1.0 / (z * wd))
    den = math.hypot(z, dlt) * math.hypot(z, wd + Om)
    if den > 0.0:
        bg = min(bg, (2.0 + math.hypot(z, Om) / wd) / den)
    out = Om**j * bg
    for m in range(j):
        out += Om ** (j - 1 - m) * bh[m]
    return out


# -- the guard functions and the piece -------------------------------------------------------
@njit
def _h_end(ps, tau):
    """The end guard: ``d V`` (slip end) or ``d V'`` (acceleration zero), as in :mod:`._exact_piece`."""
    d = ps[H_DIR]
    if ps[H_END_ORDER] == 1.0:
        v, a = va(ps, tau)
        return d * v, d * a
    a, j = aj(ps, tau)
    return d * a, d * j


@njit
def _h_position(ps, tau):
    """A flange guard: ``scale (Y - level)``."""
    y, v, _, _ = state_at(ps, tau)
    scale = ps[H_SCALE]
    return scale * (y - ps[H_LEVEL]), scale * v


@njit
def _rounding(ps, start, tmax, k):
    """No rounding bound for the guard search: each derivative is evaluated about its start
    value (no O(1) terms cancel into it), and its search bisects down to ulps of ``t``."""
    return 0.0, 0.0, 0.0


@njit
def advance_family(p, fm, r, s, armed, t0, x0, v0, t_end):
    """One damped / harmonic-sum slipping piece: :func:`._exact_piece.advance_piece` on these closed forms."""
    ps = piece_state(fm, t0, x0, v0)
    return advance_piece(p, ps, r, s, armed, t_end, _h_end, _h_position, state_at, int_y, squares, bounds,
                         _rounding)


@njit
def evaluate_family(fm, t0, x0, v0, taus):
    """``(X, V, impulse since t0)`` at the offsets ``taus`` of the piece that starts at ``(t0, x0, v0)``."""
    return evaluate_piece(piece_state(fm, t0, x0, v0), taus, state_at, int_y)
