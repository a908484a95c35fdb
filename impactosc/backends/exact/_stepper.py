"""The exact backend's closed-form pieces, stepped one at a time by :func:`impactosc.engine.drive`.

Python views of the compiled pieces (:mod:`._piece` for eq. 3, :mod:`._family` for damping
and harmonic sums): the Python driver, dense output of the compiled loop, and the
dynamics toolkit's tangent runs step with :class:`_Stepper`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...engine._driver import Mode
from ...engine._stuck import advance_stuck, evaluate_stuck
from ...model._oscillator import Oscillator
from . import _family, _piece


class _ModeConstants:
    """Python view of the compiled constants of an eq. 3 mode (:func:`._exact_piece.mode_constants`)."""

    __slots__ = ("arr", "r", "s", "ref", "w", "w2", "cY")

    def __init__(self, osc: Oscillator, r: int, s: int):
        self.arr = _piece.mode_constants(osc._p, r, s)
        self.r, self.s, self.ref = r, s, float(self.arr[_piece.M_REF])  # the wall of region r (0 when free)
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

    #: The backend the driver's messages name (the module's name, ``_stepper``, before).
    name = "exact"

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
            qs = self.osc.K * (r * x - self.osc.gap(r)) * tau if r else np.zeros(tau.shape)
            return xs, vs, qs
        mc = self._mode_constants(r, mode.motion)
        if self.family:
            xs, vs, qs = _family.evaluate_family(mc, t0, x, v, np.ravel(tau))
        else:
            xs, vs, qs = _piece.evaluate_slip(mc.arr, t0, x, v, np.ravel(tau))
        return xs.reshape(tau.shape), vs.reshape(tau.shape), qs.reshape(tau.shape)
