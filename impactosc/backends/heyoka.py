"""heyoka backend: Taylor integration with guards located on each step's Taylor polynomial.

One ``taylor_adaptive`` integrator per tolerance (and per thread) is compiled once and
reused for every run and every sweep point: the model parameters and the mode are runtime
parameters ``hy.par[i]``, so only ``pars``, ``time`` and ``state`` change between pieces.

Every guard of :mod:`impactosc.engine` is a terminal event, direction-filtered and gated:
``gate * g + (1 - gate)`` is the guard ``g`` when the gate is 1 and the constant 1 (which
has no root) when it is 0. heyoka finds event roots on the Taylor polynomial of each step,
so event times are located to machine precision, and a grazing contact inside a step is
found even though the step ends lie on the same side of the flange.

Three quadrature states ride along: the flange impulse ``Q = int K(|X|-1)``, its square
integral ``Q2`` (for rms forces) and the forcing work ``W = int V F cos(Omega t + phase)``.
They are reset at each piece start, so each piece returns exact increments.
"""

from __future__ import annotations

import threading

import numpy as np

from .. import _validation as _v
from ..engine import GUARD_DIRECTIONS, N_GUARDS, NO_GUARD, Mode, drive, guard_gates, guard_offsets
from ..model import Oscillator
from ..solution import Solution, _Recorder

__all__ = ["run", "integrator", "DEFAULT_TOL"]

DEFAULT_TOL = 2.0**-52  # machine epsilon of double precision

# Indices into the runtime parameter vector.
_P_F, _P_OMEGA, _P_BETA, _P_K, _P_PHASE, _P_REGION, _P_MOTION, _P_REGION2, _P_MOTION2 = range(9)
_P_GATES = 9  # N_GUARDS gate parameters follow, then N_GUARDS guard offsets
_P_OFFSETS = _P_GATES + N_GUARDS
_N_PARS = _P_OFFSETS + N_GUARDS

_cache = threading.local()


def _build(tol: float):
    import heyoka as hy

    X, V, Q, Q2, W = hy.make_vars("X", "V", "Q", "Q2", "W")
    p = [hy.par[i] for i in range(_N_PARS)]
    F, Om, beta, K, phase = p[_P_F], p[_P_OMEGA], p[_P_BETA], p[_P_K], p[_P_PHASE]
    r, s, r2, s2 = p[_P_REGION], p[_P_MOTION], p[_P_REGION2], p[_P_MOTION2]
    gates = p[_P_GATES:_P_OFFSETS]
    offsets = p[_P_OFFSETS:]

    forcing = F * hy.cos(Om * hy.time + phase)
    # In region r the compressed flange pushes with -K (X - r); r2 = r*r switches it off when free.
    f_net = forcing - X - K * r2 * (X - r)
    accel = f_net - beta * s
    force = K * r2 * (r * X - 1.0)  # flange force magnitude K(|X| - 1) in region r

    rhs = [(X, V), (V, s2 * accel), (Q, force), (Q2, force * force), (W, V * forcing)]

    guard_exprs = [
        X - 1.0,  # enter upper
        X + 1.0,  # enter lower
        r * X - 1.0,  # leave the flange
        s * V,  # slip ends
        s * accel,  # acceleration zero (re-arms slip end after a release)
        f_net - beta,  # release upwards
        f_net + beta,  # release downwards
    ]
    direction = {1: hy.event_direction.positive, -1: hy.event_direction.negative}
    # cooldown=0: after a guard fires the engine changes the mode, which gates that guard
    # off or flips its sign, so there is nothing to re-trigger; an automatic cooldown
    # could hide a genuine second event shortly after the first.
    # Each guard is shifted by engine.guard_offsets towards the side it crosses from: the
    # engine snaps the state onto guard surfaces, and heyoka, seeing a root exactly at
    # tau = 0 that its direction filter drops, skips the guard's next root if it falls in
    # the same step (measured: a quick second turning point was lost). The offset is a
    # separate term so that constant folding cannot absorb it into the 1.0 of X - 1.
    events = [
        hy.t_event(g * expr + (1.0 - g) - d * off * g, direction=direction[d], cooldown=0.0)
        for g, expr, off, d in zip(gates, guard_exprs, offsets, GUARD_DIRECTIONS, strict=True)
    ]
    return hy.taylor_adaptive(rhs, [0.0] * 5, pars=[0.0] * _N_PARS, t_events=events, tol=tol,
                              compact_mode=False)


def integrator(tol: float = DEFAULT_TOL):
    """The cached heyoka integrator for ``tol`` (compiled on first use in each thread)."""
    store = getattr(_cache, "integrators", None)
    if store is None:
        store = _cache.integrators = {}
    ta = store.get(tol)
    if ta is None:
        ta = store[tol] = _build(tol)
    return ta


class _Stepper:
    """Integrates one smooth piece with the cached integrator (see engine.PieceStepper)."""

    def __init__(self, ta, osc: Oscillator):
        import heyoka as hy

        self.ta = ta
        self.osc = osc
        self.state = ta.state  # a view onto the integrator's state
        self.pars = ta.pars
        self.pars[:_P_REGION] = (osc.F, osc.Omega, osc.beta, osc.K, osc.phase)
        self.time_limit = hy.taylor_outcome.time_limit
        self.mode_pars = {}

    def _set_mode(self, mode: Mode, t: float, x: float) -> None:
        vals = self.mode_pars.get(mode)
        if vals is None:
            r, s, _ = mode
            vals = self.mode_pars[mode] = (r, s, r * r, s * s, *guard_gates(mode))
        self.pars[_P_REGION:_P_OFFSETS] = vals
        self.pars[_P_OFFSETS:] = guard_offsets(self.osc, t, x)

    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        ta = self.ta
        self._set_mode(mode, t, x)
        ta.time = t
        self.state[:] = (x, v, 0.0, 0.0, 0.0)
        res = ta.propagate_until(t_end)
        outcome = res[0]
        st = self.state
        if outcome == self.time_limit:
            # heyoka keeps time in double-length arithmetic; its leading part can land an
            # ulp past t_end. The run ends at t_end exactly.
            return t_end, st[0], st[1], NO_GUARD, st[2], st[3], st[4], res[3]
        code = outcome.value
        if code >= 0 or -code - 1 >= N_GUARDS:
            raise FloatingPointError(f"heyoka stopped with outcome {outcome!r} at t={ta.time!r}")
        return ta.time, st[0], st[1], -code - 1, st[2], st[3], st[4], res[3]

    def evaluate(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        """(X, V, impulse since t0) at ``times`` inside one piece, all guards gated off."""
        ta = self.ta
        r, s, _ = mode
        self.pars[_P_REGION:] = (r, s, r * r, s * s) + (0.0,) * (2 * N_GUARDS)
        order = np.argsort(times)
        grid = np.concatenate(([t0], times[order]))
        ta.time = t0
        self.state[:] = (x, v, 0.0, 0.0, 0.0)
        res = ta.propagate_grid(grid)
        out = np.asarray(res[-1])[1:]
        if out.shape[0] != len(times) or not np.all(np.isfinite(out[:, :3])):
            raise FloatingPointError(f"heyoka could not re-integrate the piece starting at t={t0!r}")
        xs, vs, qs = (np.empty(len(times)) for _ in range(3))
        xs[order], vs[order], qs[order] = out[:, 0], out[:, 1], out[:, 2]
        return xs, vs, qs


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        tol: float = DEFAULT_TOL) -> Solution:
    """Run ``osc`` from ``(x0, v0)`` to ``t_end`` with heyoka. ``tol`` is heyoka's relative and
    absolute tolerance (default: machine epsilon); it must lie in (0, 1)."""
    tol = _v.real("tol", tol)
    if not 0.0 < tol < 1.0:
        raise ValueError(f"tol must satisfy 0 < tol < 1, got {tol!r}")
    ta = integrator(tol)
    stepper = _Stepper(ta, osc)

    def evaluator(mode, t0, x, v, times):
        # The integrator may have served other runs since: reload this run's parameters.
        s = _Stepper(integrator(tol), osc)
        return s.evaluate(mode, t0, x, v, times)

    rec = _Recorder(record, "heyoka", evaluator)
    drive(stepper, osc, t_end, x0, v0, rec, max_events)
    return Solution(rec, t_end)


