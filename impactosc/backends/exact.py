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

from .._jit import HAVE_NUMBA, warn_no_numba
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
from . import _exact_piece as _piece
from ._exact_family import FamilyConstants, FamilyPiece, near_resonance
from ._exact_roots import first_rising, refine, search_failed

__all__ = ["run"]

_EPS = 2.0**-52
_TWO_PI = 2.0 * math.pi
# Bisection stops at this many ulps of t when neither the sign nor the monotonicity of a
# guard can be proven (a tangency at rounding level): the ends then decide.
_MIN_WIDTH_ULPS = 4.0


class _ModeConstants:
    """Python view of the compiled constants of an eq. 3 mode (:func:`._exact_piece.mode_constants`)."""

    __slots__ = ("arr", "r", "s", "ref", "w", "w2", "cY", "K", "beta")

    def __init__(self, osc: Oscillator, r: int, s: int):
        self.arr = _piece.mode_constants(osc._p, r, s)
        self.r, self.s, self.ref = r, s, float(r)
        self.w, self.w2, self.cY = (float(self.arr[i]) for i in (_piece.M_W, _piece.M_W2, _piece.M_CY))
        self.K, self.beta = osc.K, osc.beta


class _SlipPiece:
    """Python view of one compiled eq. 3 piece (the closed forms of :mod:`._exact_piece`)."""

    __slots__ = ("mc", "t0", "x0", "v0", "y0", "ps")

    def __init__(self, mc: _ModeConstants, t0: float, x0: float, v0: float):
        self.mc, self.t0, self.x0, self.v0 = mc, t0, x0, v0
        self.y0 = x0 - mc.ref
        self.ps = _piece.piece_state(mc.arr, t0, x0, v0)

    def va(self, tau: float):
        """``(V, Y'')`` at a scalar ``tau``."""
        return _piece.va(self.ps, tau)

    def aj(self, tau: float):
        """``(Y'', Y''')`` at a scalar ``tau``."""
        return _piece.aj(self.ps, tau)

    def yv(self, tau):
        """``(Y, V)`` at a scalar ``tau`` or an array of them."""
        if isinstance(tau, np.ndarray):
            xs, vs, _ = _piece.evaluate_slip(self.mc.arr, self.t0, self.x0, self.v0, tau.ravel())
            return (xs - self.mc.ref).reshape(tau.shape), vs.reshape(tau.shape)
        return _piece.yvp(self.mc.arr, self.ps, tau)[:2]

    def bounds(self, tmax: float, k: int) -> tuple[float, float]:
        """Upper bounds of ``|Y^(k+2)|`` and ``|Y^(k+3)|`` over ``[0, tmax]``."""
        return _piece.bounds(self.mc.arr, self.ps, tmax, k)


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
        if self.family:
            return self._family_piece(mode, t0, x0, v0)
        return _SlipPiece(self._mode_constants(mode.region, mode.motion), t0, x0, v0)

    def _family_piece(self, mode: Mode, t0: float, x0: float, v0: float) -> FamilyPiece:
        return FamilyPiece(self._mode_constants(mode.region, mode.motion), t0, x0, v0)

    # -- one piece -----------------------------------------------------------------------
    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        """Integrate ``mode`` from ``(t, x, v)`` to its first armed guard or ``t_end``.

        Returns ``(t1, x1, v1, guard, impulse, impulse_sq, forcing_work, v_squared, steps)``;
        ``steps`` is 1: a piece is one closed-form evaluation, whatever its length.
        """
        r, s, armed = mode
        if s == 0:
            # The release of a stuck mass is shared by every backend (impactosc._stuck);
            # a stuck piece counts as one closed-form evaluation here too.
            return (*advance_stuck(self.osc, mode, t, x, t_end)[:-1], 1)
        if self.family:
            return self._advance_family(mode, t, x, v, t_end)
        # Eq. 3: the compiled piece, the one the compiled event loop runs too.
        mc = self._mode_constants(r, s)
        t1, x1, v1, guard, q, q2, w, vv, status = _piece.advance_slip(self.osc._p, mc.arr, r, s, int(armed),
                                                                       t, x, v, t_end)
        if status:
            raise FloatingPointError(f"the guard search of the piece from t={t!r} did not converge")
        return t1, x1, v1, guard, q, q2, w, vv, 1

    def _advance_family(self, mode: Mode, t0: float, x0: float, v0: float, t_end: float):
        """A damped or harmonic-sum piece: the algorithm of :func:`._exact_piece.advance_slip`
        on the closed forms of :mod:`._exact_family`, run as Python."""
        p = self._family_piece(mode, t0, x0, v0)
        mc: Any = p.mc
        s, r = mode.motion, mode.region
        gates = guard_gates(mode, self.osc.rigid)
        T = t_end - t0

        # 1. The end guard: s V falling (armed) or s V' falling (after a release).
        end_guard = SLIP_END if gates[SLIP_END] else ACCEL_ZERO
        d = GUARD_DIRECTIONS[end_guard] * s  # h = d * (V or V'), rising through 0
        if end_guard == SLIP_END:
            def fun(_state, tau, va=p.va):
                vv, aa = va(tau)
                return d * vv, d * aa
            k = 1  # h is the first derivative of Y
        else:
            def fun(_state, tau, aj=p.aj):
                aa, jj = aj(tau)
                return d * aa, d * jj
            k = 2
        tau_end, guard = T, NO_GUARD
        # Windows of one fast period keep the derivative bounds tight (they grow with tau
        # at resonance) and the bisection shallow when the piece is short.
        window = _TWO_PI / mc.fastest
        a = 0.0
        ha, da = fun(None, 0.0)
        while a < T:
            b = min(T, a + window)
            M2, M3 = p.bounds(b, k, a)
            hmin = _MIN_WIDTH_ULPS * _EPS * (abs(t0) + b)
            found, lo, hi, hlo, hhi, hb, db, status = first_rising(fun, None, a, ha, da, b, M2, M3, hmin)
            if status:
                raise search_failed(a, b, ha, hb, M2, M3)
            if found:
                tau_end, guard = refine(fun, None, lo, hi, hlo, hhi, t0), end_guard
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
                def gfun(_state, tau, yv=p.yv, scale=scale, level=level):
                    yy, vv = yv(tau)
                    return scale * (yy - level), scale * vv
                tau_f = refine(gfun, None, 0.0, tau1, h0, h1, t0)
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
        if not self.family:
            mc = self._mode_constants(r, mode.motion)
            xs, vs, qs = _piece.evaluate_slip(mc.arr, t0, x, v, np.ravel(tau))
            return xs.reshape(tau.shape), vs.reshape(tau.shape), qs.reshape(tau.shape)
        p = self._family_piece(mode, t0, x, v)
        ys, vs, _, _ = p._yvp(tau)
        xs = p.mc.ref + ys
        qs = np.maximum(p.mc.K * r * p.int_y(tau), 0.0) if r else np.zeros(tau.shape)
        return xs, vs, qs


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        sample_at=(), compiled: bool | None = None) -> Solution:
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
    sample_at : tuple of float
        Sorted sample times (time events).
    compiled : bool or None
        ``None`` (default): run the whole event loop compiled (:mod:`._exact_loop`) where it
        applies, i.e. for eq. 3 with any static friction, when numba is installed; otherwise
        the Python driver :func:`impactosc.engine.drive`, with a one-line hint when only
        numba is missing. ``False`` forces the Python driver (same
        transition rule, same pieces, same results); ``True`` requires the compiled loop
        and raises if it does not apply.

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
    if compiled not in (None, True, False):
        raise TypeError(f"compiled must be None, True or False, got {compiled!r}")
    from . import _exact_loop

    why_not = _exact_loop.unsupported(osc)
    if compiled and why_not:
        raise ValueError(f"compiled=True: the compiled event loop does not run {why_not}; "
                         "use compiled=None to fall back to the Python driver")
    if compiled is not False and not why_not:
        if HAVE_NUMBA:
            return _exact_loop.run(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=sample_at)
        if compiled:
            raise ValueError("compiled=True needs numba: pip install 'impactosc[fast]'")
        warn_no_numba("the exact backend's event loop")
    stepper = _Stepper(osc)
    rec = _Recorder(record, "exact", _Stepper(osc).evaluate)
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
