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
    Mode,
    drive,
)
from ..model import Oscillator
from ..solution import Solution, _Recorder
from . import _exact_family as _family
from . import _exact_piece as _piece
from ._exact_family import near_resonance

__all__ = ["run"]

_EPS = 2.0**-52
_TWO_PI = 2.0 * math.pi
# Bisection stops at this many ulps of t when neither the sign nor the monotonicity of a
# guard can be proven (a tangency at rounding level): the ends then decide.
_MIN_WIDTH_ULPS = 4.0


class _ModeConstants:
    """Python view of the compiled constants of an eq. 3 mode (:func:`._exact_piece.mode_constants`)."""

    __slots__ = ("arr", "r", "s", "ref", "w", "w2", "cY")

    def __init__(self, osc: Oscillator, r: int, s: int):
        self.arr = _piece.mode_constants(osc._p, r, s)
        self.r, self.s, self.ref = r, s, float(r)
        self.w, self.w2, self.cY = (float(self.arr[i]) for i in (_piece.M_W, _piece.M_W2, _piece.M_CY))


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


class _FamilyPiece:
    """Python view of one compiled damped / harmonic-sum piece (:mod:`._exact_family`)."""

    __slots__ = ("fm", "t0", "x0", "v0", "y0", "ps")

    def __init__(self, fm: np.ndarray, t0: float, x0: float, v0: float):
        self.fm, self.t0, self.x0, self.v0 = fm, t0, x0, v0
        self.ps = _family.piece_state(fm, t0, x0, v0)
        self.y0 = x0 - float(fm[_family.F_REF])

    def va(self, tau: float):
        """``(V, Y'')`` at a scalar ``tau``."""
        return _family.va(self.ps, tau)

    def aj(self, tau: float):
        """``(Y'', Y''')`` at a scalar ``tau``."""
        return _family.aj(self.ps, tau)

    def yv(self, tau):
        """``(Y, V)`` at a scalar ``tau`` or an array of them."""
        if isinstance(tau, np.ndarray):
            xs, vs, _ = _family.evaluate_family(self.fm, self.t0, self.x0, self.v0, tau.ravel())
            return (xs - self.fm[_family.F_REF]).reshape(tau.shape), vs.reshape(tau.shape)
        return _family.state_at(self.ps, tau)[:2]

    def bounds(self, tmax: float, k: int, start: float = 0.0) -> tuple[float, float]:
        """Upper bounds of ``|Y^(k+2)|`` and ``|Y^(k+3)|`` over ``[start, tmax]``."""
        return _family.bounds(self.ps, start, tmax, k)


class _Stepper:
    """Closed-form pieces for :func:`impactosc.engine.drive` (see ``engine.PieceStepper``).

    Every piece is the compiled one (:mod:`._exact_piece` for eq. 3, :mod:`._exact_family`
    for damping and harmonic sums), the one the compiled event loop runs too.
    """

    def __init__(self, osc: Oscillator):
        self.osc = osc
        # Damping or a harmonic sum: the family piece (``_exact_family``); eq. 3 keeps its own.
        self.family = bool(osc.zeta or osc.harmonics)
        self.consts: dict[tuple[int, int], Any] = {}

    def _mode_constants(self, r: int, s: int) -> Any:
        mc = self.consts.get((r, s))
        if mc is None:
            if self.family:
                mc = _family.mode_constants(self.osc._p, r, s)
            else:
                mc = _ModeConstants(self.osc, r, s)
            self.consts[(r, s)] = mc
        return mc

    def _slip_piece(self, mode: Mode, t0: float, x0: float, v0: float) -> _SlipPiece | _FamilyPiece:
        mc = self._mode_constants(mode.region, mode.motion)
        if self.family:
            return _FamilyPiece(mc, t0, x0, v0)
        return _SlipPiece(mc, t0, x0, v0)

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
        mc = self._mode_constants(r, s)
        if self.family:
            out = _family.advance_family(self.osc._p, mc, r, s, int(armed), t, x, v, t_end)
        else:
            out = _piece.advance_slip(self.osc._p, mc.arr, r, s, int(armed), t, x, v, t_end)
        t1, x1, v1, guard, q, q2, w, vv, status = out
        if status:
            raise FloatingPointError(f"the guard search of the piece from t={t!r} did not converge")
        # Python floats: without numba the closed forms run as Python on NumPy arrays.
        return float(t1), float(x1), float(v1), int(guard), float(q), float(q2), float(w), float(vv), 1

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
        mc = self._mode_constants(r, mode.motion)
        if self.family:
            xs, vs, qs = _family.evaluate_family(mc, t0, x, v, np.ravel(tau))
        else:
            xs, vs, qs = _piece.evaluate_slip(mc.arr, t0, x, v, np.ravel(tau))
        return xs.reshape(tau.shape), vs.reshape(tau.shape), qs.reshape(tau.shape)


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
        ``None`` (default): run the whole event loop compiled (``impactosc.backends._exact_loop``) when numba
        is installed, else the Python driver :func:`impactosc.engine.drive` with a one-line
        hint. ``False`` forces the Python driver (same transition rule, same pieces, same
        results); ``True`` requires the compiled loop (a ``ValueError`` without numba).

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
    if compiled is not False:
        if HAVE_NUMBA:
            from . import _exact_loop

            return _exact_loop.run(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=sample_at)
        if compiled:
            raise ValueError("compiled=True needs numba: pip install 'impactosc[fast]'")
        warn_no_numba("the exact backend's event loop")
    stepper = _Stepper(osc)
    rec = _Recorder(record, "exact", stepper.evaluate)
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
