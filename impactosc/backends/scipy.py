"""scipy backend: ``solve_ivp`` restarted at every event, the independent cross-check of heyoka.

Each smooth piece of motion is integrated in a fixed mode by :func:`scipy.integrate.solve_ivp`
on the same five-component state as the heyoka backend: ``X``, ``V``, the flange impulse
``Q = int K r^2 (r X - 1)``, its square integral ``Q2`` and the forcing work
``W = int V F cos(Omega t + phase)``. The armed guards of :mod:`impactosc.engine` are terminal
events; the engine's transition rule decides what they mean. The numerics (Runge-Kutta or
implicit multistep, interpolant root finding) share nothing with heyoka's Taylor series,
which is what makes agreement between the two a check of both.

scipy locates an event only where the event function changes sign *between two step ends*,
and it fires an event that is exactly zero at the start of a solve. Both are wrong for an
event-driven hybrid system, and this module corrects them instead of trusting smaller steps:

* **Roots inside one step.** Every piece is monotonic in ``X`` (each turning point is a
  ``SLIP_END`` guard), so a flange crossing is a simple root in the piece. When the piece
  ends at a turning point beyond the flange, the last step straddled the crossing and the
  turning point and scipy saw no sign change of ``X - 1``. After every solve, each armed
  guard is compared between the start of the last step and the end of the piece; a guard
  that is past zero there was crossed unseen, and its root is located on the dense output
  (:func:`scipy.optimize.brentq`) and the piece is re-integrated to it. The same blind spot
  can hide a stick: ``s V`` dipping below zero and back within one step. In slipping modes
  with ``SLIP_END`` armed, the minima of ``s V`` (``s V'`` rising through zero) are watched
  as non-terminal events, and a minimum below zero is a missed ``SLIP_END``.
* **Roots at the restart.** The engine snaps the state onto the guard surface at every event,
  so the next piece starts with some guards exactly zero (``X = 1`` after a contact starts,
  ``V = 0`` after a reversal, ``V' = 0`` after a release). scipy's test ``g_old <= 0 <= g_new``
  fires such a guard whenever it is back through zero at the end of the first step, and
  brentq then returns the start time itself. Two measures: (a) at the start time a guard
  that is zero (or past zero by rounding) reports a value on its near side, so it fires
  only by a genuine crossing after the start; (b) position guards starting on the flange
  surface are not handed to scipy at all, because near the start ``X - 1`` cancels to
  exactly 0 on the interpolant and brentq would stop there anyway. Their fate is decided
  by the sign of ``X'``: moving away, the monotonic piece cannot bring them back; moving
  across, they fire at once (the engine's loop guard catches any cascade).
* **Stuck pieces.** While stuck the vector field is constant, the error estimate is zero
  and the steps grow tenfold each time, so a release window shorter than a step would be
  stepped over, and a mass stuck for ever would still be stepped through. A stuck piece
  is not integrated at all: its release is the closed form shared by every backend
  (``impactosc._stuck.release_time``, an arccos of the harmonic forcing).
"""

from __future__ import annotations

import math
import sys

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .._util import validation as _v
from ..engine._driver import (
    ACCEL_ZERO,
    ENTER_LOWER,
    ENTER_UPPER,
    GUARD_DIRECTIONS,
    LEAVE,
    NO_GUARD,
    RELEASE_DOWN,
    RELEASE_UP,
    SLIP_END,
    Mode,
    drive,
    force_guard_offset,
    guard_gates,
)
from ..engine._stuck import advance_stuck, evaluate_stuck
from ..model._oscillator import Oscillator
from ..results._solution import Solution, _Recorder

__all__ = ["run", "check_tolerances", "METHODS", "DEFAULT_METHOD", "DEFAULT_RTOL", "DEFAULT_ATOL"]

#: The integrators of :func:`scipy.integrate.solve_ivp` that can be selected by name.
METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
#: Methods that use a Jacobian: they get the exact one (every mode is a linear ODE).
_IMPLICIT = ("Radau", "BDF", "LSODA")
DEFAULT_METHOD = "DOP853"
# Tight enough for a cross-check. The hardest case is a near-grazing contact: its entry
# time moves by dX / V_entry, so with V_entry ~ 1e-3 an error of 1e-12 in X is 1e-9 in time.
# Measured against heyoka (max event-time difference, DOP853): rtol = atol = 1e-12 gives
# 5e-11 on the contact case but 1.4e-8 at v0 = 1.000001 (K=24, free); rtol=1e-13 with
# atol=1e-15 gives 1e-12 and 4e-11 for 1.7x the steps of 1e-12. atol matters most: V, Q, Q2
# and W all start each piece at zero.
DEFAULT_RTOL = 1e-13
DEFAULT_ATOL = 1e-15
# The usable tolerances. scipy silently raises rtol to 100 eps (with a warning): refuse
# instead of running at a tolerance other than the one asked for. Measured on 60 random
# oscillators (t_end = 20): rtol = atol = 1e-2 already ends a run with a missed guard and
# 0.1 or 0.5 a third of them, 1e-3 none. Small atol slows the integrals, which start
# every piece at 0 (30 oscillators, rtol = 1e-13): atol = 1e-15 6.5 s, 1e-18 8.4 s,
# 1e-20 ~50 s, 1e-25 over 5 minutes.
_MIN_RTOL = 100 * sys.float_info.epsilon
_MAX_RTOL = 1e-3
_MIN_ATOL = 1e-18
_MAX_ATOL = 1e-3


def check_tolerances(rtol, atol) -> tuple[float, float]:
    """``(rtol, atol)`` as floats in their usable ranges, or an error naming the parameter."""
    out = []
    for name, value, lo, hi, why in (
        ("rtol", rtol, _MIN_RTOL, _MAX_RTOL, "100 * machine epsilon is the smallest scipy honours"),
        ("atol", atol, _MIN_ATOL, _MAX_ATOL, "below 1e-18 the steps collapse on the integrals"),
    ):
        x = _v.real(name, value)
        if not lo <= x <= hi:
            raise ValueError(f"{name} must be in [{lo!r}, {hi!r}] for the scipy backend, got {x!r} "
                             f"({why}; above {hi!r} events are missed)")
        out.append(x)
    return out[0], out[1]

# A guard that starts a piece at zero or past zero in its firing direction, by at most this,
# is taken to start on the guard surface (a restart after a snapped event). Snapped guards
# are exactly zero; unsnapped ones (the acceleration after a release) are off by rounding,
# ~1e-13 for the forces of this model. A genuine value this close to zero is a tangency,
# where either answer is within the tolerances.
_START_ZERO = 1e-9
# What such a guard reports at the start time: the sign of its near side, and a magnitude
# that stands for the 0 it really is (brentq's first secant step then lands next to it).
_NEAR_SIDE = 1e-300

# Guards on the position alone: X is monotonic in every piece, so they cross at most once.
_POSITION_GUARDS = (ENTER_UPPER, ENTER_LOWER, LEAVE)
# Index of the auxiliary "minimum of s V" event, appended after the engine's guards.
_SV_MIN = -2


def _guard_functions(osc: Oscillator, mode: Mode):
    """The vector field and the guard functions ``g(t, y)`` of ``mode`` (engine order).

    The state is ``(X, V, Q, Q2, W[, VV])``: position, velocity, and the integrals of the
    flange force, of its square, of the forcing power and, with damping only, of ``V^2``
    (the damping loss; without damping the step-size control stays that of eq. 3).
    The vector field is the model's own (:meth:`Oscillator.acceleration`): this backend
    shares no numerics with heyoka, but the same definition of every family member.
    """
    r, s, _ = mode
    accel = osc._accel_scalar
    region_force = osc._region_force_scalar
    forcing = osc._forcing_scalar
    f_net = osc._net_force_scalar
    beta, beta_s, zeta = osc.beta, osc.beta_s, osc.zeta

    damped = osc.zeta != 0.0

    def fun(t, y):
        x, v = y[0], y[1]
        force = region_force(x, r)
        out = [v if s else 0.0, accel(t, x, v, r, s), force, force * force, v * forcing(t)]
        if damped:
            out.append(v * v)
        return out

    def jac(t, y):
        x, v = y[0], y[1]
        j = np.zeros((6, 6) if damped else (5, 5))
        j[:2, :2] = osc.jacobian(t, x, v, r, s)
        # d(K d^p)/dX = r K p d^(p-1) in a spring flange region, 0 elsewhere.
        dforce = -(j[1, 0] + 1.0) * r if (s and r) else 0.0
        force = region_force(x, r)
        j[2, 0] = dforce
        j[3, 0] = 2.0 * force * dforce
        j[4, 1] = forcing(t)
        if damped:
            j[5, 1] = 2.0 * v
        return j

    upper, lower = osc.gap_upper, osc.gap_lower
    gap = osc.gap(r) if r else 0.0
    guards = {
        ENTER_UPPER: lambda t, y: y[0] - upper,
        ENTER_LOWER: lambda t, y: y[0] + lower,
        LEAVE: lambda t, y: r * y[0] - gap,
        SLIP_END: lambda t, y: s * y[1],
        # The force guards carry the engine's offset (engine.force_guard_offset): the stick test
        # and the event finder then agree on what "reaching beta" means, and a guard on an
        # f_net that vanishes identically (F = 0 at equilibrium) is not the zero function,
        # which "crossed" everywhere and crawled through 250000 stick/release pairs.
        ACCEL_ZERO: lambda t, y: s * accel(t, y[0], y[1], r, s) + force_guard_offset(osc, t, y[0]),
        RELEASE_UP: lambda t, y: f_net(t, y[0]) - beta_s - force_guard_offset(osc, t, y[0]),
        RELEASE_DOWN: lambda t, y: f_net(t, y[0]) + beta_s + force_guard_offset(osc, t, y[0]),
    }
    del beta, zeta
    gates = guard_gates(mode, osc.rigid)
    # Only the armed guards go to scipy: a gated-off guard must not stop the piece, and an
    # absent flange (gap inf) has none.
    absent = {ENTER_UPPER: upper == math.inf, ENTER_LOWER: lower == math.inf}
    armed = [(i, guards[i], GUARD_DIRECTIONS[i]) for i in range(len(gates)) if gates[i] and not absent.get(i)]
    if s != 0 and gates[SLIP_END]:
        # s V has a local minimum where s V' rises through 0; below zero it hid a slip end.
        armed.append((_SV_MIN, guards[ACCEL_ZERO], 1))
    return fun, jac, armed


def _started(g, d: int, t0: float):
    """Wrap guard ``g`` of direction ``d`` for a solve starting at ``t0`` (see the module docstring)."""

    def event(t, y):
        val = g(t, y)
        if t == t0 and d * val >= 0.0 and abs(val) <= _START_ZERO:
            return -d * _NEAR_SIDE
        return val

    return event


class _Stepper:
    """Integrates one smooth piece with ``solve_ivp`` (see :class:`engine.PieceStepper`)."""

    def __init__(self, osc: Oscillator, method: str, rtol: float, atol: float):
        self.osc = osc
        self.options = {"method": method, "rtol": rtol, "atol": atol}
        self.implicit = method in _IMPLICIT
        self._modes: dict = {}

    def _start(self, x: float, v: float) -> tuple:
        """The state at a piece start: the integrals restart at zero."""
        return (x, v, 0.0, 0.0, 0.0, 0.0) if self.osc.zeta else (x, v, 0.0, 0.0, 0.0)

    def __getstate__(self):
        # The per-mode closures are a cache: a Solution pickles without them.
        return {"osc": self.osc, "options": self.options, "implicit": self.implicit}

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._modes = {}

    def _mode(self, mode: Mode):
        entry = self._modes.get(mode)
        if entry is None:
            entry = self._modes[mode] = _guard_functions(self.osc, mode)
        return entry

    def _solve(self, fun, jac, t0, t1, y0, events=None, dense=False):
        opts = dict(self.options)
        if self.implicit:
            opts["jac"] = jac
        sol = solve_ivp(fun, (t0, t1), y0, events=events, dense_output=dense, **opts)
        if sol.status == -1:
            raise FloatingPointError(f"scipy {self.options['method']} failed on the piece starting at t={t0!r}: "
                                     f"{sol.message}")
        return sol

    # -- one piece ---------------------------------------------------------------------
    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        if not t < t_end:
            # An event exactly at t_end: nothing left to integrate.
            return t, x, v, NO_GUARD, 0.0, 0.0, 0.0, 0.0, 0
        if mode.motion == 0:
            return advance_stuck(self.osc, mode, t, x, t_end)
        fun, jac, armed = self._mode(mode)
        return self._advance(mode, fun, jac, armed, t, self._start(x, v), t_end)

    def _advance(self, mode, fun, jac, armed, t0, y0, t_stop):
        """Solve from ``t0`` to the first armed guard or ``t_stop``, correcting scipy's misses."""
        r, s, _ = mode
        x0, v0 = y0[0], y0[1]
        watched = []
        for idx, g, d in armed:
            if idx in _POSITION_GUARDS:
                g0 = g(t0, y0)
                if d * g0 >= 0.0 and abs(g0) <= _START_ZERO:
                    # Starting on the flange surface (snapped there by the engine). Near it
                    # X - 1 cancels to exactly 0 on the dense output, so scipy's root finder
                    # would return the start time. The sign of X' decides instead (X'' has the
                    # sign of the motion when V = 0): moving away, the piece is monotonic in X
                    # and cannot come back; moving across, the guard fires now.
                    trend = (v0 if v0 != 0.0 else s) * (r if idx == LEAVE else 1)
                    if d * trend > 0:
                        return t0, x0, v0, idx, 0.0, 0.0, 0.0, 0.0, 0
                    continue
            watched.append((idx, g, d))
        armed = watched
        events = []
        for idx, g, d in armed:
            ev = _started(g, d, t0)
            ev.terminal = idx != _SV_MIN  # the minimum watch only records, it never stops
            ev.direction = d
            events.append(ev)
        sol = self._solve(fun, jac, t0, t_stop, y0, events)
        steps = len(sol.t) - 1
        fired = NO_GUARD
        for (idx, _, _d), te in zip(armed, sol.t_events, strict=True):
            if idx >= 0 and len(te):
                fired = idx
        t1 = float(sol.t[-1])
        missed = self._missed(sol, armed, events, fired, t0, t_stop, y0, fun, jac)
        if missed is not None:
            fired, t1, extra_steps = missed
            steps += extra_steps
            if not t1 > t0:
                return t0, y0[0], y0[1], fired, 0.0, 0.0, 0.0, 0.0, steps
            # Re-integrate to the root so the state there is a step end, not an interpolant.
            sol = self._solve(fun, jac, t0, t1, y0)
            steps += len(sol.t) - 1
        y1 = sol.y[:, -1]
        # int V^2 is integrated as a state: on a tiny piece its rounding can leave it at
        # -1e-42, and the damping loss 2 zeta int V^2 must not turn into a gain.
        v_squared = max(float(y1[5]), 0.0) if len(y1) > 5 else 0.0
        return (t1, float(y1[0]), float(y1[1]), fired, float(y1[2]), float(y1[3]), float(y1[4]),
                v_squared, steps)

    def _missed(self, sol, armed, events, fired, t0, t_stop, y0, fun, jac):
        """The earliest guard crossing scipy stepped over, as ``(guard, time, steps)``, or None."""
        t1 = float(sol.t[-1])
        if not t1 > t0:
            return None
        y1 = sol.y[:, -1]
        ta = float(sol.t[-2]) if len(sol.t) > 1 else t0
        ya = sol.y[:, -2] if len(sol.t) > 1 else np.asarray(y0, dtype=float)
        # (guard, left end of a bracket with the guard on its near side, right end past it)
        brackets = []
        for (idx, _, d), ev in zip(armed, events, strict=True):
            if idx == _SV_MIN or idx == fired:
                continue
            # Crossed between the start of the last step and the end of the piece, unseen:
            # the piece ended (at a turning point, or at another guard) inside that step.
            h_a, h_1 = d * ev(ta, ya), d * ev(t1, y1)
            if h_1 > 0.0 and h_a <= 0.0 and ta < t1:
                brackets.append((idx, ta, t1, h_a, h_1, ev, d))
        by_guard = {idx: k for k, (idx, _, _d) in enumerate(armed)}
        if _SV_MIN in by_guard:
            k = by_guard[_SV_MIN]
            s_slip = events[by_guard[SLIP_END]]
            for tm, ym in zip(sol.t_events[k], sol.y_events[k], strict=True):
                if s_slip(tm, ym) < 0.0:
                    # The step holding this minimum started with s V >= 0 (else scipy had seen it).
                    j = max(int(np.searchsorted(sol.t, tm, side="left")) - 1, 0)
                    lo = float(sol.t[j])
                    h_lo = -s_slip(lo, sol.y[:, j]) if j > 0 else -s_slip(t0, np.asarray(y0, dtype=float))
                    brackets.append((SLIP_END, lo, float(tm), h_lo, -s_slip(tm, ym), s_slip, -1))
                    break
        if not brackets:
            return None
        # The dense output of the very same step sequence: same span, same events.
        dense = self._solve(fun, jac, t0, t_stop, y0, events, dense=True)
        best = None
        for idx, lo, hi, h_lo, h_hi, ev, d in brackets:
            # The bracket ends keep the values that flagged the miss (step ends and event
            # states), so the sign change brentq needs is the one that was seen.
            def h(t, ev=ev, d=d, lo=lo, hi=hi, h_lo=h_lo, h_hi=h_hi):
                if t == lo:
                    return h_lo
                if t == hi:
                    return h_hi
                return d * ev(t, dense.sol(t))

            root = brentq(h, lo, hi, xtol=4 * sys.float_info.epsilon, rtol=4 * sys.float_info.epsilon)
            if best is None or root < best[1]:
                best = (idx, root)
        return best[0], best[1], len(dense.t) - 1

    # -- dense output ------------------------------------------------------------------
    def evaluate(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        """(X, V, impulse since t0) at ``times`` inside one piece, re-integrated without guards."""
        times = np.asarray(times, dtype=float)
        if mode.motion == 0:
            return evaluate_stuck(self.osc, mode, t0, x, times)
        # solve_ivp needs a strictly increasing t_eval: evaluate each distinct time once.
        grid, where = np.unique(times, return_inverse=True)
        where = where.reshape(-1)
        n = grid.shape[0]
        xs, vs, qs = np.full(n, x, dtype=float), np.full(n, v, dtype=float), np.zeros(n)
        later = grid > t0
        if np.any(later):
            fun, jac, _ = self._mode(mode)
            sol = solve_ivp(fun, (t0, float(grid[-1])), self._start(x, v), t_eval=grid[later],
                            **self.options, **({"jac": jac} if self.implicit else {}))
            if (sol.status == -1 or sol.y.shape[1] != np.count_nonzero(later)
                    or not np.all(np.isfinite(sol.y[:3]))):
                raise FloatingPointError(f"scipy could not re-integrate the piece starting at t={t0!r}")
            xs[later], vs[later], qs[later] = sol.y[0], sol.y[1], sol.y[2]
        return xs[where], vs[where], qs[where]


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        sample_at=(), method: str = DEFAULT_METHOD, rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL) -> Solution:
    """Run ``osc`` from ``(x0, v0)`` to ``t_end`` with :func:`scipy.integrate.solve_ivp`.

    Parameters
    ----------
    osc : Oscillator
        The model.
    t_end : float
        End time (> 0).
    x0, v0 : float
        Initial position and velocity.
    record : {"full", "events", "stats"}
        What the :class:`~impactosc.Solution` keeps.
    max_events : int
        Event limit (see :func:`impactosc.simulate`).
    method : str, optional
        One of ``"RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"``. The implicit ones get
        the exact Jacobian of each mode.
    rtol, atol : float, optional
        scipy's relative and absolute tolerances: ``rtol`` in ``[100 eps, 1e-3]`` (100 eps
        is the smallest scipy honours), ``atol`` in ``[1e-18, 1e-3]``. The defaults
        ``rtol=1e-13, atol=1e-15`` put DOP853's event times within about 1e-10 of heyoka's
        on the test cases, near-grazing included.

    Returns
    -------
    Solution

    Raises
    ------
    ValueError
        If ``method`` is unknown or a tolerance is outside its range.
    TypeError
        If a tolerance is not a real number.
    """
    method = _v.choice("method", method, METHODS)
    rtol, atol = check_tolerances(rtol, atol)
    stepper = _Stepper(osc, method, rtol, atol)
    rec = _Recorder(record, "scipy", stepper.evaluate)
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
