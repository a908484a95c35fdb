"""exact backend: closed-form pieces and rigorously bracketed guard roots.

Every mode of the hybrid system is linear with harmonic forcing, so a smooth piece has a
closed form and needs no time stepping at all. This is the ground truth the other
backends are tested against, and the fast path for long stick and creep phases: a stuck
mass is released where ``F cos(Omega t + phase) = restoring(x) +- beta``, an arccos.

Slipping piece
--------------
In region ``r`` with motion ``s`` the position is written relative to ``ref`` (``r`` in a
flange, 0 when free), ``Y = X - ref``, so the flange penetration ``r Y`` is computed
without cancelling against 1::

    Y'' + w^2 Y = cY + F cos(Omega t + phase),   w^2 = 1 + K r^2,
    cY = -r - beta s (flange) or -beta s (free).

With ``tau = t - t0`` and ``theta0 = Omega t0 + phase``::

    Y(tau) = Yp + Ah cos(w tau) + Bh sin(w tau) + F (cos(theta0) Cc(tau) - sin(theta0) Ss(tau)),
    Cc = (cos(Omega tau) - cos(w tau)) / (w^2 - Omega^2),
    Ss = (sin(Omega tau) - (Omega/w) sin(w tau)) / (w^2 - Omega^2).

where ``Yp = cY / w^2``, ``Ah = y0 - Yp``, ``Bh = v0 / w``. Where ``|Yp| > |y0|`` (huge
``beta``: ``Yp ~ -beta s / w^2``) the same motion is evaluated about the start point,
``Y = y0 - 2 Ah sin^2(w tau / 2) + ...``, so ``Yp`` never cancels against ``Ah`` (see
``_SlipPiece``); the velocity is ``v0 cos(w tau) - w Ah sin(w tau) + ...`` in both forms.

``Cc`` and ``Ss`` (the response to the forcing from rest) are evaluated through
``sin((w - Omega) tau / 2) / (w - Omega)``, which tends to ``tau / 2``: there is no
cancellation near resonance and the exact resonance ``w == Omega`` (``Omega = 1`` free,
``Omega = sqrt(1 + K)`` in contact) is the same formula. The homogeneous part uses ``tau``,
never the absolute time, so nothing degrades at large ``t``.

Damping and harmonic sums (the linear family of issue #10) use the closed-form pieces of
``impactosc.backends._exact_family`` (under-, critically and over-damped, the steady
response of each harmonic); a stuck piece with a harmonic sum uses ``impactosc._stuck``.
A power-law flange, or a harmonic within ``1e-6`` of an (almost) undamped resonance, is
refused with a ``ValueError``.

Guards
------
The armed guards and their directions come from :func:`impactosc.engine.guard_gates` and
:data:`impactosc.engine.GUARD_DIRECTIONS`. A guard ``g`` with direction ``d`` fires at the
first ``tau > 0`` where ``h = d g`` passes from negative to non-negative; a root exactly at
the piece start therefore fires only if ``h`` was negative before it, which is never the
case at ``tau = 0`` (the engine snaps the state onto the guard surface it came from).

The piece first locates its "end" guard (``SLIP_END`` when armed, else ``ACCEL_ZERO``):
``h`` is a sum of sinusoids at ``w`` and ``Omega`` (times ``tau`` at resonance), bracketed by
recursive bisection with rigorous derivative bounds: on ``[a, b]`` a function with
``|h''| <= M2`` stays within ``M2 (b - a)^2 / 8`` of its chord, which excludes intervals of
one sign, and ``|h'''| <= M3`` applied to ``h'`` proves monotonicity, so a bracket holds a
single crossing. Near a double root (a tangency) the bisection goes on until the extremum
separates the two crossings; only below a few ulps of ``t`` do the end values decide.
Up to that end guard ``X`` is monotonic (``s V >= 0``), so the flange guards are simple
sign tests at the two ends and one bracketed root, and a grazing contact (a flange
crossing just before a turning point) is found whenever the turning point lies beyond the
flange. Brackets are refined by safeguarded Newton (bisection whenever a Newton step
leaves the bracket or converges slowly) to one ulp of ``t``.

Integrals
---------
Over a flange piece, ``int K (r X - 1) dt = K r int Y dt`` in closed form about the start
point (``y0 tau - Ah (w tau - sin(w tau)) / w + ...``, see ``_SlipPiece.int_y``); ``int (K (r X - 1))^2 dt`` by 16-node
Gauss-Legendre quadrature on sub-intervals no longer than half the period of the fastest
frequency ``max(w, Omega)`` (error below 1e-19 relative, see ``_GL_NODES``); the forcing
work ``int V F cos(Omega t + phase) dt`` from the energy balance
``dE/dt = V (F cos(Omega t + phase) - beta s)``, i.e. ``Delta E + beta s Delta X``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._stuck import advance_stuck, evaluate_stuck
from ..engine import (
    ACCEL_ZERO,
    ENTER_LOWER,
    ENTER_UPPER,
    GUARD_DIRECTIONS,
    LEAVE,
    NO_GUARD,
    SLIP_END,
    Mode,
    drive,
    guard_gates,
)
from ..model import Oscillator
from ..solution import Solution, _Recorder
from ._exact_family import FamilyConstants, FamilyPiece, near_resonance

__all__ = ["run"]

_EPS = 2.0**-52
_TWO_PI = 2.0 * math.pi
# Gauss-Legendre rule for int Y^2: Y^2 has frequencies up to 2 max(w, Omega); on a
# sub-interval of half the shortest period (length L, nu L <= 2 pi) the 16-node error
# term (L nu)^32 (16!)^4 / (33 (32!)^3) is ~1e-29 relative, far below rounding.
_GL_N = 16
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(_GL_N)
# Bisection stops at this many ulps of t when neither the sign nor the monotonicity of a
# guard can be proven (a tangency at rounding level): the ends then decide.
_MIN_WIDTH_ULPS = 4.0
# Intervals one guard search may examine in one window: a few hundred are typical (a
# tangency bisected down to ulps takes ~100 per level); far more means useless bounds.
_MAX_BRACKET_STEPS = 100_000


class _ModeConstants:
    """Per-mode constants of a slipping piece (see the module docstring)."""

    __slots__ = ("r", "s", "ref", "w", "w2", "cY", "Yp", "F", "Om", "sig", "dlt", "K", "beta")

    def __init__(self, osc: Oscillator, r: int, s: int):
        self.r, self.s = r, s
        self.ref = float(r)
        self.K, self.beta, self.F, self.Om = osc.K, osc.beta, osc.F, osc.Omega
        self.w2 = 1.0 + osc.K if r else 1.0
        self.w = math.sqrt(self.w2)
        # c - w^2 r with c = K r - beta s simplifies exactly to -r - beta s: no K-sized cancellation.
        self.cY = (-r - osc.beta * s) if r else -osc.beta * s
        self.Yp = self.cY / self.w2
        self.sig = self.w + osc.Omega
        self.dlt = self.w - osc.Omega


def _kernel(mc: _ModeConstants, y0, v0, Ah, about_start, c0, s0, tau, sin, cos):
    """``(Y, V, P', Y - y0)`` at ``tau`` after the piece start (scalar or array).

    ``Y - y0`` is the displacement as computed, not rounded to the ulps of ``Y``: the
    energy balance of the forcing work, ``Delta E + beta s (Y - y0)``, cancels ``beta`` sized
    terms on a short piece with a huge ``beta``. ``P'`` is the velocity of the response to
    the forcing from rest (``V = v0 cos(w tau) - w Ah sin(w tau) + F P'``). ``about_start``
    selects the form of ``Y`` (see ``_SlipPiece``). ``sin`` and ``cos`` are those of
    :mod:`math` for scalars or of NumPy for arrays.
    """
    w, Om, F, sig, dlt = mc.w, mc.Om, mc.F, mc.sig, mc.dlt
    sw = sin(w * tau)
    cw = cos(w * tau)
    hs = 0.5 * sig * tau
    # sin(dlt tau / 2) / dlt -> tau / 2 at resonance: the stable core of Cc, D and Ss.
    sd = sin(0.5 * dlt * tau) / dlt if dlt != 0.0 else 0.5 * tau
    t2 = 2.0 * w * cos(hs) * sd
    Cc = 2.0 * sin(hs) * sd / sig  # (cos(Om tau) - cos(w tau)) / (w^2 - Om^2)
    D = (t2 + sin(Om * tau)) / sig  # Cc'
    Ss = (sw - t2) / (w * sig)  # (sin(Om tau) - (Om/w) sin(w tau)) / (w^2 - Om^2); Ss' = Om Cc
    dp = c0 * D - s0 * Om * Cc
    forced = (v0 / w) * sw + F * (c0 * Cc - s0 * Ss)
    if about_start:  # Y = y0 + Ah (cos - 1) + ..., with cos - 1 = -2 sin^2: no Yp added back
        hw = sin(0.5 * w * tau)
        dy = forced - 2.0 * Ah * hw * hw
        y = y0 + dy
    else:
        y = mc.Yp + (forced + Ah * cw)
        dy = y - y0
    v = v0 * cw - w * Ah * sw + F * dp
    return y, v, dp, dy


def _x_minus_sin(z):
    """``z - sin(z)`` without cancellation at small ``z`` (scalar or array)."""
    arr = isinstance(z, np.ndarray)
    if not arr and abs(z) >= 1.0:
        return z - math.sin(z)
    u = z * z
    series = 0.0
    for c in _X_MINUS_SIN_COEFFS:
        series = c - u * series
    series = z * u * series
    return np.where(np.abs(z) < 1.0, series, z - np.sin(z)) if arr else series


# z - sin z = z^3/3! - z^5/5! + ...: nine terms reach z^19/19!, below an ulp of z^3/6 for |z| < 1.
_X_MINUS_SIN_COEFFS = tuple(1.0 / math.factorial(2 * k + 3) for k in reversed(range(9)))


class _SlipPiece:
    """The closed-form motion of one slipping piece from ``(t0, x0, v0)``.

    The scalar methods ``va`` and ``aj`` are the hot path of the guard search: they inline
    the trigonometric core of :func:`_kernel` and its derivatives
    (``Cc'' = D' = cos(w tau) - Omega^2 Cc`` and ``Ss' = Omega Cc``).
    """

    __slots__ = ("mc", "t0", "x0", "v0", "y0", "Ah", "Bh", "about_start", "c0", "s0", "theta0", "_k", "_hom",
                 "_amp", "_G")

    def __init__(self, mc: _ModeConstants, phase: float, t0: float, x0: float, v0: float):
        self.mc = mc
        self.t0, self.x0, self.v0 = t0, x0, v0
        # The forcing phase at the piece start, evaluated as the engine evaluates the forcing.
        self.theta0 = mc.Om * t0 + phase
        self.c0 = math.cos(self.theta0)
        self.s0 = math.sin(self.theta0)
        self.y0 = x0 - mc.ref
        self.Ah = self.y0 - mc.Yp  # homogeneous amplitudes: Y(0) = y0, V(0) = v0
        self.Bh = v0 / mc.w
        # Y about its centre, Yp + Ah cos(w tau) + ..., is rounded like max(|Yp|, |Ah|); about
        # the start point, y0 + Ah (cos(w tau) - 1) + ..., like |y0| + 2 |Ah| sin^2(w tau / 2).
        # Where the particular solution Yp = cY / w^2 ~ -beta s / w^2 dwarfs y0 the first
        # cancels Yp against Ah: with beta = 1e8 the position was rounded to 1e-8 while the
        # mass slid 1e-9 (issue 14). The start-point form is taken there, the centred
        # form (half the rounding over a long free half-period) elsewhere.
        self.about_start = abs(mc.Yp) > abs(self.y0)
        w, w2 = mc.w, mc.w2
        # Amplitudes for the derivative bounds (see ``bounds``): homogeneous part, and off
        # resonance the free-oscillation amplitude of the classical form with its rounding.
        self._hom = math.hypot(self.Ah, self.Bh)
        self._amp = self._G = None
        if mc.dlt != 0.0:
            G = mc.F / (mc.sig * mc.dlt)
            a = self.Ah - G * self.c0
            b = self.Bh + G * (mc.Om / w) * self.s0
            self._amp = math.hypot(a, b) + 8.0 * _EPS * (abs(self.Ah) + abs(self.Bh) + abs(G) * (1.0 + mc.Om / w))
            self._G = abs(G)
        self._k = (w, mc.Om, 0.5 * mc.sig, 0.5 * mc.dlt, 1.0 / mc.dlt if mc.dlt != 0.0 else 0.0,
                   1.0 / mc.sig, mc.F * self.c0, mc.F * self.s0 * mc.Om, mc.Om * mc.Om,
                   w2 * self.Ah, w2 * self.Bh, w * w2 * self.Ah, w * w2 * self.Bh)

    def _core(self, tau: float):
        w, Om, hsig, hdlt, idlt, isig = self._k[:6]
        sw = math.sin(w * tau)
        cw = math.cos(w * tau)
        sd = math.sin(hdlt * tau) * idlt if idlt != 0.0 else 0.5 * tau
        hs = hsig * tau
        t2 = 2.0 * w * math.cos(hs) * sd
        Cc = 2.0 * math.sin(hs) * sd * isig
        D = (t2 + math.sin(Om * tau)) * isig
        return sw, cw, Cc, D

    def va(self, tau: float):
        """``(V, Y'')`` at a scalar ``tau``."""
        sw, cw, Cc, D = self._core(tau)
        k = self._k
        w, FC, FSO, O2 = k[0], k[6], k[7], k[8]
        v = self.v0 * cw - w * self.Ah * sw + FC * D - FSO * Cc
        a2 = -(k[9] * cw + k[10] * sw) + FC * (cw - O2 * Cc) - FSO * D
        return v, a2

    def aj(self, tau: float):
        """``(Y'', Y''')`` at a scalar ``tau``."""
        sw, cw, Cc, D = self._core(tau)
        k = self._k
        w, FC, FSO, O2 = k[0], k[6], k[7], k[8]
        e = cw - O2 * Cc
        a2 = -(k[9] * cw + k[10] * sw) + FC * e - FSO * D
        a3 = k[11] * sw - k[12] * cw + FC * (-w * sw - O2 * D) - FSO * e
        return a2, a3

    def yv(self, tau):
        """``(Y, V)`` at a scalar ``tau`` or an array of them."""
        return self._yvp(tau)[:2]

    def _yvp(self, tau):
        if isinstance(tau, np.ndarray):
            return _kernel(self.mc, self.y0, self.v0, self.Ah, self.about_start, self.c0, self.s0, tau, np.sin, np.cos)
        return _kernel(self.mc, self.y0, self.v0, self.Ah, self.about_start, self.c0, self.s0, tau, math.sin, math.cos)

    def int_y(self, tau, dp):
        """``int_0^tau Y`` given ``P'(tau) = dp`` (closed form about the start point, scalar or array).

        ``y0 tau + Ah (sin(w tau) - w tau) / w + (v0 / w^2) (1 - cos(w tau)) + F int P``, with
        ``w^2 int P = int cos(Omega t + phase) - P'`` (the forced response from rest). Each
        homogeneous term is computed without cancellation, so a short piece with a huge
        ``beta`` (or ``K``) keeps the relative accuracy of its tiny impulse; the integrated
        equation of motion ``(cY tau + F int cos - (V - v0)) / w^2`` cancelled ``cY tau``
        against ``V - v0`` there.
        """
        mc = self.mc
        Om, w = mc.Om, mc.w
        arr = isinstance(tau, np.ndarray)
        sin, cos = (np.sin, np.cos) if arr else (math.sin, math.cos)
        if Om != 0.0:
            half = 0.5 * Om * tau
            icos = 2.0 * (self.c0 * cos(half) - self.s0 * sin(half)) * sin(half) / Om
        else:
            icos = self.c0 * tau
        hw = sin(0.5 * w * tau)
        z_sin = _x_minus_sin(w * tau)
        hom = self.y0 * tau - self.Ah * z_sin / w + 2.0 * (self.v0 / mc.w2) * hw * hw
        return hom + mc.F * (icos - dp) / mc.w2

    def int_squares(self, tau: float) -> tuple[float, float]:
        """``(int_0^tau Y^2, int_0^tau V^2)`` by composite Gauss-Legendre (see ``_GL_NODES``)."""
        if tau <= 0.0:
            return 0.0, 0.0
        mc = self.mc
        fastest = max(mc.w, mc.Om)
        n = max(1, math.ceil(tau * fastest / math.pi))
        h = tau / n
        left = h * np.arange(n)[:, None]
        nodes = left + 0.5 * h * (_GL_NODES[None, :] + 1.0)
        y, v = self.yv(nodes.ravel())
        weights = 0.5 * h * np.tile(_GL_WEIGHTS, n)
        return float(weights @ (y * y)), float(weights @ (v * v))

    def bounds(self, tmax: float, k: int) -> tuple[float, float]:
        """Upper bounds of ``|Y^(k+2)|`` and ``|Y^(k+3)|`` over ``[0, tmax]``.

        Two valid bounds, the smaller taken: the homogeneous amplitude plus a bound of the
        response from rest (``P'' = F cos - w^2 P``; finite at resonance, grows with
        ``tmax`` there), and, off resonance, the classical amplitudes of
        ``a cos + b sin + G cos(Omega tau + theta0)`` (tight when the free oscillation has
        died out, e.g. quasi-static creep), with a margin for the rounding of ``a, b``.
        """
        mc = self.mc
        w, w2, Om, F, sig, dlt = mc.w, mc.w2, mc.Om, mc.F, mc.sig, mc.dlt
        c0, s0 = self.c0, self.s0
        m = min(1.0 / abs(dlt), 0.5 * tmax) if dlt != 0.0 else 0.5 * tmax
        bC = 2.0 * m / sig  # |Cc|
        bD = (2.0 * w * m + 1.0) / sig  # |Cc'|
        bS = min(Om * tmax * bC, (2.0 * w * m + 1.0) / (w * sig))  # |Ss|
        ac, as_ = abs(c0), abs(s0)
        bP = [F * (ac * bC + as_ * bS), F * (ac * bD + as_ * Om * bC)]
        for j in range(2, k + 4):
            bP.append(w2 * bP[j - 2] + F * Om ** (j - 2))
        out = []
        for j in (k + 2, k + 3):
            o = self._hom * w**j + bP[j]
            if self._amp is not None:
                o = min(o, self._amp * w**j + self._G * Om**j)
            out.append(o * (1.0 + 1e-9) + 1e-300)
        return out[0], out[1]


def _first_rising(fun, a: float, ha: float, da: float, b: float, M2: float, M3: float, hmin: float):
    """First crossing of ``h`` from negative to non-negative in ``(a, b]``.

    ``fun(tau) -> (h, h')``; ``ha, da`` are its values at ``a``; ``M2 >= |h''|`` and
    ``M3 >= |h'''|`` on ``[a, b]``. Returns ``(lo, hi, h(lo), h(hi))`` bracketing the crossing
    with ``h`` monotonic on it, or ``None``, plus the values at ``b`` for the next window.
    The right ends of the still unexplored intervals sit on a stack, so intervals are
    examined strictly left to right and the first crossing is the one returned.
    """
    hb, db = fun(b)
    end = (hb, db)
    stack = [(b, hb, db)]
    evaluations = 0
    while stack:
        b, hb, db = stack[-1]
        width = b - a
        evaluations += 1
        if evaluations > _MAX_BRACKET_STEPS or not math.isfinite(ha + hb + da + db + M2 + M3):
            # Never a hang: non-finite values or bounds would send the bisection down to
            # ulp-wide intervals over the whole window. The engine ends the run (status -1).
            raise FloatingPointError(f"the guard search on [{a!r}, {b!r}] did not converge "
                                     f"(h={ha!r}..{hb!r}, h'={da!r}..{db!r}, bounds M2={M2!r}, M3={M3!r})")
        slack2 = 0.125 * M2 * width * width  # max distance of h from its chord
        decided = False
        if ha >= 0.0 and hb >= 0.0 and min(ha, hb) > slack2:
            decided = True  # h > 0 on [a, b]
        elif ha < 0.0 and hb < 0.0 and max(ha, hb) < -slack2:
            decided = True  # h < 0 on [a, b]
        else:
            slack3 = 0.125 * M3 * width * width
            if min(da, db) > slack3:  # h increasing: one crossing at most
                if ha < 0.0 <= hb:
                    return (a, b, ha, hb), end
                decided = True
            elif max(da, db) < -slack3:  # h decreasing: it cannot rise through 0
                decided = True
            elif width <= hmin:
                if ha < 0.0 <= hb:
                    return (a, b, ha, hb), end
                decided = True
        if decided:
            stack.pop()
            a, ha, da = b, hb, db
        else:
            mid = a + 0.5 * width
            hm, dm = fun(mid)
            stack.append((mid, hm, dm))
    return None, end


def _refine(fun, lo: float, hi: float, hlo: float, hhi: float, t0: float) -> float:
    """Root of ``h = fun(tau)[0]`` in a bracket where it rises through 0 (``hlo < 0 <= hhi``).

    Safeguarded Newton (``fun`` also returns ``h'``): a Newton step is taken when it stays
    inside the shrinking bracket and converges fast enough, a bisection otherwise, so the
    iteration is as robust as bisection and converges quadratically near the root. It
    stops when the step is below one ulp of ``t0 + tau``.
    """
    if hhi == 0.0:
        return hi
    tol = _EPS * (abs(t0) + hi)
    x = lo - hlo * (hi - lo) / (hhi - hlo)  # regula falsi start
    if not lo < x < hi:
        x = 0.5 * (lo + hi)
    dx_old = hi - lo
    for _ in range(200):  # bisection alone needs < 1100 halvings from any float bracket; Newton far fewer
        h, dh = fun(x)
        if h == 0.0:
            return x
        if h < 0.0:
            lo = x
        else:
            hi = x
        if dh > 0.0:
            step = h / dh
            if abs(step) <= tol:  # converged: the last Newton correction is below one ulp
                return min(max(x - step, lo), hi)
            xn = x - step
        else:
            xn = math.nan
        if lo < xn < hi and abs(2.0 * h) <= abs(dx_old * dh):
            dx = x - xn
        else:
            xn = 0.5 * (lo + hi)
            dx = hi - lo
        dx_old = dx
        if abs(dx) <= tol:
            return xn
        x = xn
    return x


class _Stepper:
    """Closed-form pieces for :func:`impactosc.engine.drive` (see ``engine.PieceStepper``)."""

    def __init__(self, osc: Oscillator):
        self.osc = osc
        # Damping or a harmonic sum: the family piece (``_exact_family``); eq. 3 keeps its own.
        self.family = bool(osc.zeta or osc.harmonics)
        self.consts: dict[tuple[int, int], Any] = {}

    def _mode_constants(self, r: int, s: int) -> Any:
        mc = self.consts.get((r, s))
        if mc is None:
            kind = FamilyConstants if self.family else _ModeConstants
            mc = self.consts[(r, s)] = kind(self.osc, r, s)
        return mc

    def _slip_piece(self, mode: Mode, t0: float, x0: float, v0: float) -> _SlipPiece | FamilyPiece:
        mc = self._mode_constants(mode.region, mode.motion)
        if self.family:
            return FamilyPiece(mc, t0, x0, v0)
        return _SlipPiece(mc, self.osc.phase, t0, x0, v0)

    # -- one piece -----------------------------------------------------------------------
    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        """Integrate ``mode`` from ``(t, x, v)`` to its first armed guard or ``t_end``.

        Returns ``(t1, x1, v1, guard, impulse, impulse_sq, forcing_work, steps)``; ``steps``
        is 1: a piece is one closed-form evaluation, whatever its length.
        """
        if mode.motion == 0:
            # The release of a stuck mass is shared by every backend (impactosc._stuck);
            # a stuck piece counts as one closed-form evaluation here too.
            return (*advance_stuck(self.osc, mode, t, x, t_end)[:-1], 1)
        return self._advance_slip(mode, t, x, v, t_end)

    def _advance_slip(self, mode: Mode, t0: float, x0: float, v0: float, t_end: float):
        p = self._slip_piece(mode, t0, x0, v0)
        mc: Any = p.mc  # _ModeConstants (eq. 3) or FamilyConstants
        s, r = mode.motion, mode.region
        gates = guard_gates(mode, self.osc.rigid)
        T = t_end - t0

        # 1. The end guard: s V falling (armed) or s V' falling (after a release).
        end_guard = SLIP_END if gates[SLIP_END] else ACCEL_ZERO
        d = GUARD_DIRECTIONS[end_guard] * s  # h = d * (V or V'), rising through 0
        if end_guard == SLIP_END:
            def fun(tau, va=p.va):
                vv, aa = va(tau)
                return d * vv, d * aa
            k = 1  # h is the first derivative of Y
        else:
            def fun(tau, aj=p.aj):
                aa, jj = aj(tau)
                return d * aa, d * jj
            k = 2
        tau_end, guard = T, NO_GUARD
        # Windows of one fast period keep the derivative bounds tight (they grow with tau
        # at resonance) and the bisection shallow when the piece is short.
        window = _TWO_PI / (mc.fastest if self.family else mc.w)
        a = 0.0
        ha, da = fun(0.0)
        while a < T:
            b = min(T, a + window)
            M2, M3 = p.bounds(b, k, a) if self.family else p.bounds(b, k)
            hmin = _MIN_WIDTH_ULPS * _EPS * (abs(t0) + b)
            bracket, (hb, db) = _first_rising(fun, a, ha, da, b, M2, M3, hmin)
            if bracket is not None:
                tau_end, guard = _refine(fun, *bracket, t0), end_guard
                break
            a, ha, da = b, hb, db
        t1 = t_end if guard == NO_GUARD else t0 + tau_end
        tau1 = t1 - t0  # the exact offset of the float t1 the engine will see
        y1, v1, dp1, dy = p._yvp(tau1)

        # 2. X is monotonic on [0, tau1] (s V >= 0 there), so a flange guard is crossed iff
        #    its values at the two ends differ in sign, and at most one of them is.
        for fg in (ENTER_UPPER, ENTER_LOWER, LEAVE):
            if not gates[fg]:
                continue
            # h = scale (Y - level): X - 1 and X + 1 when free (Y = X), r X - 1 = r Y in a flange.
            level = 0.0 if fg == LEAVE else (1.0 if fg == ENTER_UPPER else -1.0)
            scale = GUARD_DIRECTIONS[fg] * (r if fg == LEAVE else 1)
            h0 = scale * (p.y0 - level)
            h1 = scale * (y1 - level)
            if h0 < 0.0 <= h1:
                def gfun(tau, yv=p.yv, scale=scale, level=level):
                    yy, vv = yv(tau)
                    return scale * (yy - level), scale * vv
                tau_f = _refine(gfun, 0.0, tau1, h0, h1, t0)
                guard = fg
                t1 = t0 + tau_f
                tau1 = t1 - t0
                y1, v1, dp1, dy = p._yvp(tau1)
                break

        # 3. The state and the integrals at the end of the piece.
        x1 = mc.ref + y1
        q = q2 = 0.0
        y2, vv = p.int_squares(tau1)
        if r:
            # r Y >= 0 all through a flange piece: a negative integral is rounding.
            q = max(mc.K * r * p.int_y(tau1, dp1), 0.0)
            q2 = mc.K * mc.K * y2
        # Energy balance: int V forcing = Delta E + beta s Delta X + 2 zeta int V^2,
        # E = V^2/2 + X^2/2 + K Y^2/2 [r != 0].
        y0 = p.y0
        de = 0.5 * (v1 - v0) * (v1 + v0) + 0.5 * dy * (2.0 * mc.ref + y1 + y0)
        if r:
            de += 0.5 * mc.K * dy * (y1 + y0)
        work = de + mc.beta * s * dy + 2.0 * self.osc.zeta * vv
        return t1, x1, v1, guard, q, q2, work, vv, 1

    # -- dense output --------------------------------------------------------------------
    def evaluate(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        """``(X, V, impulse since t0)`` at ``times`` inside the piece starting at ``(t0, x, v)``."""
        times = np.asarray(times, dtype=float)
        tau = times - t0
        r = mode.region
        if mode.motion == 0 and self.osc.harmonics:
            return evaluate_stuck(self.osc, mode, t0, x, times)
        if mode.motion == 0:
            xs = np.full(tau.shape, x)
            vs = np.zeros(tau.shape)
            qs = self.osc.K * (r * x - 1.0) * tau if r else np.zeros(tau.shape)
            return xs, vs, qs
        p = self._slip_piece(mode, t0, x, v)
        ys, vs, dps, _ = p._yvp(tau)
        xs = p.mc.ref + ys
        qs = np.maximum(p.mc.K * r * p.int_y(tau, dps), 0.0) if r else np.zeros(tau.shape)
        return xs, vs, qs


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        sample_at=()) -> Solution:
    """Run ``osc`` from ``(x0, v0)`` to ``t_end`` with closed-form pieces.

    Parameters
    ----------
    osc : Oscillator
        The model.
    t_end : float
        End time (> 0).
    x0, v0 : float
        Initial state at ``t = 0``.
    record : {"full", "events", "stats"}
        What the :class:`~impactosc.solution.Solution` keeps.
    max_events : int
        Stop after this many recorded events.

    Returns
    -------
    Solution
        ``n_steps`` counts pieces: each is one closed-form evaluation.
    """
    missing = [f for f in osc.unsupported() if f.startswith("a power-law")]
    if osc.zeta or osc.harmonics:
        resonant = near_resonance(osc)
        if resonant:
            missing.append(resonant)
    if missing:
        raise ValueError(f"the exact backend does not support {', '.join(missing)} yet; "
                         "use backend='heyoka' or backend='scipy'")
    stepper = _Stepper(osc)
    rec = _Recorder(record, "exact", _Stepper(osc).evaluate)
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
