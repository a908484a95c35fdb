"""The closed-form slipping piece of eq. 3 (one harmonic, no damping), compiled once.

:mod:`impactosc.backends.exact` derives the formulas (its module docstring); this module
evaluates them. Everything here is compilable Python (:mod:`impactosc._jit`): the exact
backend's Python stepper and its compiled event loop (:mod:`._exact_loop`) call the same
functions, so there is one copy of the closed form, of the guard search and of the piece
integrals.

A mode's constants and a piece's state are small float arrays (indices ``M_*`` and
``S_*``): :func:`mode_constants` builds the first once per mode, :func:`piece_state` the
second at the start of every piece.
"""

from __future__ import annotations

import math

import numpy as np

from ..._util.jit import njit, njit_inline
from ..._util.roots import SEARCH_FAILED
from ..._util.roots import first_rising_jit as first_rising
from ..._util.roots import refine_jit as refine
from ...model._rule import (
    ACCEL_ZERO,
    ENTER_LOWER,
    ENTER_UPPER,
    GUARD_DIRECTIONS,
    LEAVE,
    NO_GUARD,
    P_BETA,
    P_K,
    P_LOWER,
    P_RIGID,
    P_TERMS,
    P_UPPER,
    SLIP_END,
    gate,
    wall,
)

__all__ = ["mode_constants", "advance_slip", "advance_piece", "evaluate_slip", "evaluate_piece"]

_EPS = 2.0**-52
_TWO_PI = 2.0 * math.pi
# Gauss-Legendre rule for int Y^2: Y^2 has frequencies up to 2 max(w, Omega); on a
# sub-interval of half the shortest period (length L, nu L <= 2 pi) the 16-node error
# term (L nu)^32 (16!)^4 / (33 (32!)^3) is ~1e-29 relative, far below rounding.
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
# Bisection stops at this many ulps of t when neither the sign nor the monotonicity of a
# guard can be proven (a tangency at rounding level): the ends then decide.
_MIN_WIDTH_ULPS = 4.0
# z - sin z = z^3/3! - z^5/5! + ...: nine terms reach z^19/19!, below an ulp of z^3/6 for |z| < 1.
_X_MINUS_SIN_COEFFS = np.array([1.0 / math.factorial(2 * k + 3) for k in reversed(range(9))])

# Mode constants: Y = X - ref, w^2 = 1 + K r^2, cY = -r - beta s (flange) or -beta s (free).
M_REF, M_W, M_W2, M_CY, M_YP, M_F, M_OM, M_SIG, M_DLT, M_K, M_BETA, M_PHASE = range(12)
M_SIZE = 12
# The common header of every piece state (this eq. 3 piece and the damped / harmonic-sum
# piece of _exact_family), read by the one piece algorithm advance_piece: the start, the
# guard shape the search is on, the search window and the constants of the integrals.
(H_T0, H_X0, H_V0, H_Y0, H_DIR, H_SCALE, H_LEVEL, H_END_ORDER, H_WINDOW, H_REF, H_K, H_BETA, H_ZETA) = range(13)
H_SIZE = 13
# Then the eq. 3 piece: the homogeneous amplitudes, the phase at the start, the bound
# amplitudes, the inlined trigonometric constants (S_W .. S_WW2BH), and the mode constants.
(S_AH, S_BH, S_ABOUT, S_C0, S_S0, S_HOM, S_AMP, S_G, S_W, S_OM, S_HSIG, S_HDLT, S_IDLT, S_ISIG, S_FC, S_FSO, S_O2,
 S_W2AH, S_W2BH, S_WW2AH, S_WW2BH) = range(H_SIZE, H_SIZE + 21)
S_MC = H_SIZE + 21
S_SIZE = S_MC + M_SIZE


@njit
def mode_constants(p, r, s):
    """Constants of the slipping mode ``(r, s)`` of the eq. 3 member ``p`` (:func:`impactosc._rule.params`)."""
    mc = np.empty(M_SIZE)
    K, beta = p[P_K], p[P_BETA]
    F, Om, phase = p[P_TERMS], p[P_TERMS + 1], p[P_TERMS + 2]
    w2 = 1.0 + K if r != 0 else 1.0
    w = math.sqrt(w2)
    # Y = X - ref about the flange of region r, at ref = r gap (1 by default); c - w^2 ref with
    # c = K ref - beta s simplifies exactly to -ref - beta s: no K-sized cancellation.
    ref = wall(p, r) if r != 0 else 0.0
    cY = (-ref - beta * s) if r != 0 else -beta * s
    mc[M_REF], mc[M_W], mc[M_W2], mc[M_CY], mc[M_YP] = ref, w, w2, cY, cY / w2
    mc[M_F], mc[M_OM], mc[M_SIG], mc[M_DLT] = F, Om, w + Om, w - Om
    mc[M_K], mc[M_BETA], mc[M_PHASE] = K, beta, phase
    return mc


@njit
def piece_state(mc, t0, x0, v0):
    """The state of the piece that starts at ``(t0, x0, v0)`` in the mode of ``mc``."""
    ps = np.empty(S_SIZE)
    w, w2, Om, F, sig, dlt = mc[M_W], mc[M_W2], mc[M_OM], mc[M_F], mc[M_SIG], mc[M_DLT]
    # The forcing phase at the piece start, evaluated as the engine evaluates the forcing.
    theta0 = Om * t0 + mc[M_PHASE]
    c0, s0 = math.cos(theta0), math.sin(theta0)
    y0 = x0 - mc[M_REF]
    Ah = y0 - mc[M_YP]  # homogeneous amplitudes: Y(0) = y0, V(0) = v0
    Bh = v0 / w
    ps[H_T0], ps[H_X0], ps[H_V0], ps[H_Y0], ps[S_AH], ps[S_BH] = t0, x0, v0, y0, Ah, Bh
    # Where the particular solution Yp ~ -beta s / w^2 dwarfs y0, Y is evaluated about the
    # start point (no cancellation of Yp against Ah, which would lose the digits of y0), else about its centre.
    ps[S_ABOUT] = 1.0 if abs(mc[M_YP]) > abs(y0) else 0.0
    ps[S_C0], ps[S_S0] = c0, s0
    # Amplitudes for the derivative bounds: homogeneous part, and off resonance the
    # free-oscillation amplitude of the classical form with its rounding (NaN at resonance).
    ps[S_HOM] = math.hypot(Ah, Bh)
    ps[S_AMP] = ps[S_G] = math.nan
    if dlt != 0.0:
        G = F / (sig * dlt)
        a = Ah - G * c0
        b = Bh + G * (Om / w) * s0
        ps[S_AMP] = math.hypot(a, b) + 8.0 * _EPS * (abs(Ah) + abs(Bh) + abs(G) * (1.0 + Om / w))
        ps[S_G] = abs(G)
    ps[S_W], ps[S_OM], ps[S_HSIG], ps[S_HDLT] = w, Om, 0.5 * sig, 0.5 * dlt
    ps[S_IDLT] = 1.0 / dlt if dlt != 0.0 else 0.0
    ps[S_ISIG], ps[S_FC], ps[S_FSO], ps[S_O2] = 1.0 / sig, F * c0, F * s0 * Om, Om * Om
    ps[S_W2AH], ps[S_W2BH], ps[S_WW2AH], ps[S_WW2BH] = w2 * Ah, w2 * Bh, w * w2 * Ah, w * w2 * Bh
    ps[H_DIR] = ps[H_SCALE] = ps[H_END_ORDER] = 1.0
    ps[H_LEVEL] = 0.0
    ps[H_WINDOW] = _TWO_PI / w
    ps[H_REF], ps[H_K], ps[H_BETA], ps[H_ZETA] = mc[M_REF], mc[M_K], mc[M_BETA], 0.0
    ps[S_MC:] = mc
    return ps


@njit
def _core(ps, tau):
    # Two angles carry everything: hs = (w + Omega) tau / 2 and hd = (w - Omega) tau / 2, with
    # w tau = hs + hd and Omega tau = hs - hd by the addition theorems (two sin/cos pairs
    # instead of six evaluations: this is the guard search's inner loop).
    w = ps[S_W]
    hs, hd = ps[S_HSIG] * tau, ps[S_HDLT] * tau
    s_h, c_h = math.sin(hs), math.cos(hs)
    s_d, c_d = math.sin(hd), math.cos(hd)
    sw = s_h * c_d + c_h * s_d
    cw = c_h * c_d - s_h * s_d
    idlt = ps[S_IDLT]
    # sin(dlt tau / 2) / dlt -> tau / 2 at resonance: the stable core of Cc, D and Ss.
    sd = s_d * idlt if idlt != 0.0 else 0.5 * tau
    t2 = 2.0 * w * c_h * sd
    Cc = 2.0 * s_h * sd * ps[S_ISIG]  # (cos(Om tau) - cos(w tau)) / (w^2 - Om^2)
    D = (t2 + (s_h * c_d - c_h * s_d)) * ps[S_ISIG]  # Cc'
    return sw, cw, Cc, D


@njit
def va(ps, tau):
    """``(V, Y'')`` at ``tau``."""
    sw, cw, Cc, D = _core(ps, tau)
    FC, FSO = ps[S_FC], ps[S_FSO]
    v = ps[H_V0] * cw - ps[S_W] * ps[S_AH] * sw + FC * D - FSO * Cc
    a2 = -(ps[S_W2AH] * cw + ps[S_W2BH] * sw) + FC * (cw - ps[S_O2] * Cc) - FSO * D
    return v, a2


@njit
def aj(ps, tau):
    """``(Y'', Y''')`` at ``tau``."""
    sw, cw, Cc, D = _core(ps, tau)
    FC, FSO, O2, w = ps[S_FC], ps[S_FSO], ps[S_O2], ps[S_W]
    e = cw - O2 * Cc
    a2 = -(ps[S_W2AH] * cw + ps[S_W2BH] * sw) + FC * e - FSO * D
    a3 = ps[S_WW2AH] * sw - ps[S_WW2BH] * cw + FC * (-w * sw - O2 * D) - FSO * e
    return a2, a3


@njit
def yvp(mc, ps, tau):
    """``(Y, V, P', Y - y0)`` at ``tau`` (see :func:`impactosc.backends.exact` for ``P'``).

    ``Y - y0`` is the displacement as computed, not rounded to the ulps of ``Y``: the
    energy balance of the forcing work cancels ``beta`` sized terms on a short piece with
    a huge ``beta``. Every sine here is evaluated directly (to half an ulp), unlike the
    guard search's :func:`_core`: the state and the flange crossings are located on ``Y``,
    and a grazing contact's entry velocity inherits ``Y``'s rounding divided by that
    velocity (the addition theorems' extra ulp cost 3e-10 of the force at ``v_in^2 = 2e-6``).
    """
    w, Om, F, sig, dlt = mc[M_W], mc[M_OM], mc[M_F], mc[M_SIG], mc[M_DLT]
    y0, v0, Ah, c0, s0 = ps[H_Y0], ps[H_V0], ps[S_AH], ps[S_C0], ps[S_S0]
    sw = math.sin(w * tau)
    cw = math.cos(w * tau)
    hs = 0.5 * sig * tau
    sd = math.sin(0.5 * dlt * tau) / dlt if dlt != 0.0 else 0.5 * tau
    t2 = 2.0 * w * math.cos(hs) * sd
    Cc = 2.0 * math.sin(hs) * sd / sig
    D = (t2 + math.sin(Om * tau)) / sig
    Ss = (sw - t2) / (w * sig)  # (sin(Om tau) - (Om/w) sin(w tau)) / (w^2 - Om^2); Ss' = Om Cc
    dp = c0 * D - s0 * Om * Cc
    forced = (v0 / w) * sw + F * (c0 * Cc - s0 * Ss)
    if ps[S_ABOUT] != 0.0:  # Y = y0 + Ah (cos - 1) + ..., with cos - 1 = -2 sin^2: no Yp added back
        hw = math.sin(0.5 * w * tau)
        dy = forced - 2.0 * Ah * hw * hw
        y = y0 + dy
    else:
        y = mc[M_YP] + (forced + Ah * cw)
        dy = y - y0
    v = v0 * cw - w * Ah * sw + F * dp
    return y, v, dp, dy


@njit
def _x_minus_sin(z):
    """``z - sin(z)`` without cancellation at small ``z``."""
    if abs(z) >= 1.0:
        return z - math.sin(z)
    u = z * z
    series = 0.0
    for c in _X_MINUS_SIN_COEFFS:
        series = c - u * series
    return z * u * series


@njit
def int_y(mc, ps, tau, dp):
    """``int_0^tau Y`` given ``P'(tau) = dp``, in closed form about the start point.

    ``y0 tau + Ah (sin(w tau) - w tau) / w + (v0 / w^2) (1 - cos(w tau)) + F int P``, with
    ``w^2 int P = int cos(Omega t + phase) - P'``: each homogeneous term without
    cancellation, so a short piece with a huge ``beta`` (or ``K``) keeps the relative
    accuracy of its tiny impulse.
    """
    Om, w = mc[M_OM], mc[M_W]
    c0, s0 = ps[S_C0], ps[S_S0]
    if Om != 0.0:
        half = 0.5 * Om * tau
        icos = 2.0 * (c0 * math.cos(half) - s0 * math.sin(half)) * math.sin(half) / Om
    else:
        icos = c0 * tau
    hw = math.sin(0.5 * w * tau)
    hom = ps[H_Y0] * tau - ps[S_AH] * _x_minus_sin(w * tau) / w + 2.0 * (ps[H_V0] / mc[M_W2]) * hw * hw
    return hom + mc[M_F] * (icos - dp) / mc[M_W2]


@njit
def int_y_squared_rule(mc, ps, tau):
    """``int_0^tau Y^2`` by composite 16-node Gauss-Legendre.

    Sub-intervals are no longer than half the period of the fastest frequency (error
    below 1e-19 relative). Eq. 3 has no damping, so ``int V^2`` is never needed here.
    """
    if tau <= 0.0:
        return 0.0
    n = max(1, math.ceil(tau * max(mc[M_W], mc[M_OM]) / math.pi))
    h = tau / n
    sy = 0.0
    for i in range(n):
        left = h * i
        for j in range(_GL_NODES.shape[0]):
            y, _, _, _ = yvp(mc, ps, left + 0.5 * h * (_GL_NODES[j] + 1.0))
            sy += 0.5 * h * _GL_WEIGHTS[j] * (y * y)
    return sy


@njit
def _sin_integral(theta, nu, tau):
    """``int_0^tau sin(theta + nu t) dt`` without cancellation (``2 sin(theta + nu tau/2) sin(nu tau/2) / nu``)."""
    if nu == 0.0:
        return math.sin(theta) * tau
    h = 0.5 * nu * tau
    return 2.0 * math.sin(theta + h) * math.sin(h) / nu


@njit
def _cos_integral(theta, nu, tau):
    """``int_0^tau cos(theta + nu t) dt`` without cancellation."""
    if nu == 0.0:
        return math.cos(theta) * tau
    h = 0.5 * nu * tau
    return 2.0 * math.cos(theta + h) * math.sin(h) / nu


#: The closed form of ``int Y^2`` is taken when its terms are at most this many times the
#: result (its rounding is then below ~1e-13 relative); else the Gauss-Legendre rule.
_SQUARE_CONDITION = 100.0


@njit
def int_y_squared(mc, ps, tau):
    """``int_0^tau Y^2``: in closed form off resonance, where it is well conditioned.

    Off resonance ``Y = Yp + a cos(w t) + b sin(w t) + G cos(Omega t + theta0)`` (the classical
    form, ``G = F / (w^2 - Omega^2)``), and ``Y^2`` integrates term by term into sines of
    half-angles (:func:`_sin_integral`, :func:`_cos_integral`), about 13 trigonometric
    evaluations against ~100 for the 16-node rule. Where the terms nearly cancel (a huge
    ``beta`` makes ``Yp`` and ``a`` dwarf ``Y``; near resonance ``G`` grows), or at resonance,
    the Gauss-Legendre rule of :func:`int_y_squared_rule` on the stable form is used.
    """
    w, Om, F, dlt = mc[M_W], mc[M_OM], mc[M_F], mc[M_DLT]
    if dlt == 0.0 or tau <= 0.0:
        return int_y_squared_rule(mc, ps, tau)
    c0, s0 = ps[S_C0], ps[S_S0]
    theta0 = math.atan2(s0, c0)
    G = F / (mc[M_SIG] * dlt)
    Yp = mc[M_YP]
    a = ps[S_AH] - G * c0
    b = ps[S_BH] + G * (Om / w) * s0
    s1, c1 = math.sin(w * tau), math.cos(w * tau)
    hw = math.sin(0.5 * w * tau)
    i_cc = 0.5 * tau + 0.5 * s1 * c1 / w
    i_ss = 0.5 * tau - 0.5 * s1 * c1 / w
    i_cs = 0.5 * s1 * s1 / w
    i_c = s1 / w
    i_s = 2.0 * hw * hw / w
    i_p = _cos_integral(theta0, Om, tau)  # int cos(phi)
    i_pp = 0.5 * (tau + _cos_integral(2.0 * theta0, 2.0 * Om, tau))  # int cos^2(phi)
    # cos(phi) cos(w t) and cos(phi) sin(w t), phi = theta0 + Omega t, by sum and difference angles.
    i_pc = 0.5 * (_cos_integral(theta0, w + Om, tau) + _cos_integral(-theta0, dlt, tau))
    i_ps = 0.5 * (_sin_integral(theta0, w + Om, tau) + _sin_integral(-theta0, dlt, tau))
    terms = (Yp * Yp * tau + a * a * i_cc + b * b * i_ss + G * G * i_pp + 2.0 * a * b * i_cs,
             2.0 * Yp * (a * i_c + b * i_s + G * i_p), 2.0 * G * (a * i_pc + b * i_ps))
    value = terms[0] + terms[1] + terms[2]
    size = abs(Yp) + abs(a) + abs(b) + abs(G)
    if not value * _SQUARE_CONDITION >= size * size * tau:
        return int_y_squared_rule(mc, ps, tau)
    return value


@njit
def _response_bounds(mc, tmax):
    """Upper bounds of ``|Cc|``, ``|Cc'|`` and ``|Ss|`` over ``[0, tmax]`` (the response from rest)."""
    w, Om, sig, dlt = mc[M_W], mc[M_OM], mc[M_SIG], mc[M_DLT]
    m = min(1.0 / abs(dlt), 0.5 * tmax) if dlt != 0.0 else 0.5 * tmax
    bC = 2.0 * m / sig  # |Cc|
    bD = (2.0 * w * m + 1.0) / sig  # |Cc'|
    bS = min(Om * tmax * bC, (2.0 * w * m + 1.0) / (w * sig))  # |Ss|
    return bC, bD, bS


#: Rounding of a guard as :func:`va` and :func:`aj` compute it, in units of the magnitudes of
#: its terms: a few ulps for the sines of the addition theorems, the products and the sums.
_ROUNDING_ULPS = 8.0


@njit
def rounding(mc, ps, tmax, k):
    """Bounds of the rounding of ``Y^(k)`` (``k`` = 1, 2) as :func:`va` and :func:`aj` compute it.

    Returns ``(at0, rate, cap)``: at offsets up to ``tau <= tmax`` the rounding is at most
    ``min(cap, at0 + rate tau)`` (the local bound of :func:`impactosc._util.roots.first_rising`):
    a few ulps of the magnitudes of the terms that form it, the homogeneous part and the
    response from rest, with ``|sin x| <= |x|``, ``|Cc| <= tau^2 / 2`` and ``|Cc'| <= tau`` near
    the start (``V`` starts at ``v0`` exactly, its terms grow from zero). Where the free
    oscillation is below rounding (a start at rest on ``f_net = 0``) these terms cancel and the
    computed guard is rounding only, however tight :func:`bounds` is.
    """
    w, Om, F = mc[M_W], mc[M_OM], mc[M_F]
    bC, bD, _ = _response_bounds(mc, tmax)
    ac, as_ = F * abs(ps[S_C0]), F * abs(ps[S_S0])
    ah, bh = abs(ps[S_AH]), abs(ps[S_BH])
    if k == 1:  # v0 cw - w Ah sw + F c0 Cc' - F s0 Omega Cc
        at0 = w * bh
        rate = w * ah * (w + Om) + ac + as_ * Om * 0.5 * tmax
        cap = w * (ah + bh) + ac * bD + as_ * Om * bC
    else:  # -w^2 (Ah cw + Bh sw) + F c0 (cw - Omega^2 Cc) - F s0 Omega Cc'
        at0 = w * w * ah + ac
        rate = w * w * bh * (w + Om) + ac * Om * Om * 0.5 * tmax + as_ * Om
        cap = w * w * (ah + bh) + ac * (1.0 + Om * Om * bC) + as_ * Om * bD
    u = _ROUNDING_ULPS * _EPS
    return u * at0, u * rate, u * cap


@njit
def bounds(mc, ps, tmax, k):
    """Upper bounds of ``|Y^(k+2)|`` and ``|Y^(k+3)|`` over ``[0, tmax]``.

    Two valid bounds, the smaller taken: the homogeneous amplitude plus a bound of the
    response from rest (``P'' = F cos - w^2 P``; finite at resonance, grows with ``tmax``
    there), and, off resonance, the classical amplitudes of
    ``a cos + b sin + G cos(Omega tau + theta0)`` (tight when the free oscillation has
    died out, e.g. quasi-static creep), with a margin for the rounding of ``a, b``.
    """
    w, w2, Om, F = mc[M_W], mc[M_W2], mc[M_OM], mc[M_F]
    bC, bD, bS = _response_bounds(mc, tmax)
    ac, as_ = abs(ps[S_C0]), abs(ps[S_S0])
    bP = np.empty(k + 4)
    bP[0] = F * (ac * bC + as_ * bS)
    bP[1] = F * (ac * bD + as_ * Om * bC)
    for j in range(2, k + 4):
        bP[j] = w2 * bP[j - 2] + F * Om ** (j - 2)
    hom, amp = ps[S_HOM], ps[S_AMP]
    j = k + 2
    o2 = hom * w**j + bP[j]
    o3 = hom * w ** (j + 1) + bP[j + 1]
    if not math.isnan(amp):
        o2 = min(o2, amp * w**j + ps[S_G] * Om**j)
        o3 = min(o3, amp * w ** (j + 1) + ps[S_G] * Om ** (j + 1))
    return o2 * (1.0 + 1e-9) + 1e-300, o3 * (1.0 + 1e-9) + 1e-300


# -- the guard functions h(tau), h'(tau) that first_rising / refine search ----------------
# One compiled function per guard shape, selected by the piece state (numba caches a
# function that passes one guard function around, not one that unifies two).
@njit
def _h_end(ps, tau):
    """The end guard: ``d V`` (``H_END_ORDER`` 1, slip end) or ``d V'`` (2, acceleration zero)."""
    d = ps[H_DIR]
    if ps[H_END_ORDER] == 1.0:
        v, a = va(ps, tau)
        return d * v, d * a
    a, j = aj(ps, tau)
    return d * a, d * j


@njit
def _h_position(ps, tau):
    """A flange guard: ``scale (Y - level)``."""
    y, v, _, _ = yvp(ps[S_MC:], ps, tau)
    scale = ps[H_SCALE]
    return scale * (y - ps[H_LEVEL]), scale * v


@njit
def _state_at(ps, tau):
    return yvp(ps[S_MC:], ps, tau)


@njit
def _int_y(ps, tau, dp):
    return int_y(ps[S_MC:], ps, tau, dp)


@njit
def _squares(ps, tau, need_y, need_v):
    # Eq. 3 is undamped (H_ZETA = 0): advance_piece never asks it for int V^2.
    return (int_y_squared(ps[S_MC:], ps, tau) if need_y else 0.0), 0.0


@njit
def _bounds(ps, start, tmax, k):
    return bounds(ps[S_MC:], ps, tmax, k)  # valid on [0, tmax], so on [start, tmax]


@njit
def _rounding(ps, start, tmax, k):
    return rounding(ps[S_MC:], ps, tmax, k)  # valid on [0, tmax], so on [start, tmax]


def _advance_piece(p, ps, r, s, armed, t_end, h_end, h_position, state_at, int_y_of, squares_of, bounds_of,
                   rounding_of):
    """One slipping piece from the start in ``ps`` to its first armed guard or ``t_end``.

    The one piece algorithm of the exact backend, for every closed form: the functions
    (``h_end``, ``h_position``: the guards; ``state_at``: ``(Y, V, P', Y - y0)``; ``int_y_of``,
    ``squares_of``: the integrals; ``bounds_of``: the derivative bounds; ``rounding_of``: bounds of
    the rounding of the computed end guard) are those of the
    piece's family, and ``ps`` starts with the common header (``H_*``). Compiled inlined
    into :func:`advance_slip` and ``_exact_family.advance_family`` (see
    :func:`impactosc._jit.njit_inline`).

    Returns ``(t1, x1, v1, guard, impulse, impulse_sq, forcing_work, v_squared, status)``
    (the integrals of :class:`impactosc.engine.PieceStepper`). ``status`` is
    :data:`SEARCH_FAILED` when the guard search gave up (the state returned is then the start).

    The end guard (``SLIP_END`` when armed, else ``ACCEL_ZERO``) comes first, searched in
    windows (one fast period: tight derivative bounds, a shallow bisection when the piece is
    short). Up to it ``X`` is monotonic (``s V >= 0``), so a flange guard is crossed iff its
    values at the two ends differ in sign, and at most one of them is: a grazing contact (a
    flange crossing just before a turning point) is found whenever the turning point lies
    beyond the flange.
    """
    t0, x0, v0 = ps[H_T0], ps[H_X0], ps[H_V0]
    rigid = p[P_RIGID] != 0.0
    T = t_end - t0
    end_guard = SLIP_END if gate(rigid, r, s, armed, SLIP_END) else ACCEL_ZERO
    ps[H_DIR] = GUARD_DIRECTIONS[end_guard] * s  # h = d * (V or V'), rising through 0
    ps[H_END_ORDER] = 1.0 if end_guard == SLIP_END else 2.0
    k = int(ps[H_END_ORDER])  # h is the k-th derivative of Y
    found = False
    tau_end = T
    a = 0.0
    ha, da = h_end(ps, 0.0)
    while a < T:
        b = min(T, a + ps[H_WINDOW])
        M2, M3 = bounds_of(ps, a, b, k)
        hmin = _MIN_WIDTH_ULPS * _EPS * (abs(t0) + b)
        # Where the end guard cannot leave its rounding level, its end values decide (roots.decide).
        at0, rate, cap = rounding_of(ps, a, b, k)
        hit, lo, hi, hlo, hhi, hb, db, status = first_rising(h_end, ps, a, ha, da, b, M2, M3, hmin, at0, rate, cap)
        if status == SEARCH_FAILED:
            return t0, x0, v0, NO_GUARD, 0.0, 0.0, 0.0, 0.0, status
        if hit:
            found, tau_end = True, refine(h_end, ps, lo, hi, hlo, hhi, t0)
            break
        a, ha, da = b, hb, db
    guard = end_guard if found else NO_GUARD
    t1 = t0 + tau_end if found else t_end
    tau1 = t1 - t0  # the exact offset of the float t1 the engine will see
    y1, v1, dp1, dy = state_at(ps, tau1)
    y0 = ps[H_Y0]
    for fg in (ENTER_UPPER, ENTER_LOWER, LEAVE):
        if not gate(rigid, r, s, armed, fg):
            continue
        # h = scale (Y - level): X - gap_upper and X + gap_lower when free (Y = X), r X - gap =
        # r Y in a flange. An absent flange is at inf: its guard never changes sign.
        level = 0.0 if fg == LEAVE else (p[P_UPPER] if fg == ENTER_UPPER else -p[P_LOWER])
        scale = float(GUARD_DIRECTIONS[fg] * (r if fg == LEAVE else 1))
        h0 = scale * (y0 - level)
        h1 = scale * (y1 - level)
        if h0 < 0.0 <= h1:
            ps[H_SCALE], ps[H_LEVEL] = scale, level
            tau_f = refine(h_position, ps, 0.0, tau1, h0, h1, t0)
            guard = fg
            t1 = t0 + tau_f
            tau1 = t1 - t0
            y1, v1, dp1, dy = state_at(ps, tau1)
            break
    # The state and the integrals at the end of the piece.
    ref, K, zeta = ps[H_REF], ps[H_K], ps[H_ZETA]
    x1 = ref + y1
    y2, vv = squares_of(ps, tau1, r != 0, zeta > 0.0)
    q = q2 = 0.0
    if r != 0:
        # r Y >= 0 all through a flange piece: a negative integral is rounding.
        q = max(K * r * int_y_of(ps, tau1, dp1), 0.0)
        q2 = K * K * y2
    # Energy balance: int V forcing = Delta E + beta s Delta X + 2 zeta int V^2,
    # E = V^2/2 + X^2/2 + K Y^2/2 [r != 0].
    de = 0.5 * (v1 - v0) * (v1 + v0) + 0.5 * dy * (2.0 * ref + y1 + y0)
    if r != 0:
        de += 0.5 * K * dy * (y1 + y0)
    work = de + ps[H_BETA] * s * dy + 2.0 * zeta * vv
    return t1, x1, v1, guard, q, q2, work, vv, 0


#: The compiled piece algorithm, inlined into each family's advance function.
advance_piece = njit_inline(_advance_piece)


@njit
def advance_slip(p, mc, r, s, armed, t0, x0, v0, t_end):
    """One slipping piece of eq. 3 from ``(t0, x0, v0)``: :func:`_advance_piece` on its closed form."""
    ps = piece_state(mc, t0, x0, v0)
    return advance_piece(p, ps, r, s, armed, t_end, _h_end, _h_position, _state_at, _int_y, _squares, _bounds,
                         _rounding)


def _evaluate_piece(ps, taus, state_at, int_y_of):
    """``(X, V, impulse since t0)`` at the offsets ``taus`` of the piece ``ps`` (any family)."""
    n = taus.shape[0]
    xs, vs, qs = np.empty(n), np.empty(n), np.zeros(n)
    r, K = ps[H_REF], ps[H_K]
    for i in range(n):
        y, v, dp, _ = state_at(ps, taus[i])
        xs[i], vs[i] = r + y, v
        if r != 0.0:
            qs[i] = max(K * r * int_y_of(ps, taus[i], dp), 0.0)
    return xs, vs, qs


#: The compiled dense output, inlined into each family's evaluate function.
evaluate_piece = njit_inline(_evaluate_piece)


@njit
def evaluate_slip(mc, t0, x0, v0, taus):
    """``(X, V, impulse since t0)`` at the offsets ``taus`` of the piece that starts at ``(t0, x0, v0)``."""
    return evaluate_piece(piece_state(mc, t0, x0, v0), taus, _state_at, _int_y)
