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

A stuck piece is not integrated: its release is the closed form of :mod:`impactosc._stuck`.
Long slipping pieces are propagated in chunks so that ``max_wall_time`` can end them.
heyoka logs through spdlog on C's ``stdout``; :func:`integrator` points that log at
``stderr`` (see :func:`_log_to_stderr`) so that its warnings cannot corrupt piped output.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from .. import _validation as _v
from .._stuck import advance_stuck, evaluate_stuck
from ..engine import GUARD_DIRECTIONS, N_GUARDS, NO_GUARD, Mode, drive, guard_gates, guard_offsets
from ..model import Oscillator
from ..solution import Solution, _Recorder

__all__ = ["run", "integrator", "check_tol", "DEFAULT_TOL", "MIN_TOL", "MAX_TOL"]

DEFAULT_TOL = 2.0**-52  # machine epsilon of double precision
# The usable tolerances (measured on the contact case and 150 random oscillators): below
# eps event times do not improve while the Taylor order and the compile time grow with
# -log(tol) (1e-100: 7 s; 1e-200: 37 s, then a failure); at 1e-2 event times are off by
# ~1e-3 and at 0.5 runs end with missed guards.
MIN_TOL = 1e-18
MAX_TOL = 1e-2

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


def _log_to_stderr(build):
    """Call ``build()`` with C's ``stdout`` pointing at ``stderr``, so heyoka's logger goes there.

    heyoka logs through spdlog to a sink on C's ``stdout``; its warnings (e.g. root finding
    during event detection) would corrupt tables and piped output. The sink takes the
    ``FILE *`` that ``stdout`` holds when heyoka creates its logger, on the first
    integrator built in the process: during that one build ``stdout`` holds ``stderr``.
    Python's own ``sys.stdout`` is not a C ``FILE *`` and is unaffected. If heyoka's logger
    already exists (created by an earlier heyoka call outside impactosc), it keeps stdout.
    """
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        for out_name, err_name in (("stdout", "stderr"), ("__stdoutp", "__stderrp")):  # glibc/musl, macOS
            try:
                out = ctypes.c_void_p.in_dll(libc, out_name)
                err = ctypes.c_void_p.in_dll(libc, err_name)
                break
            except ValueError:
                continue
        else:
            return build()
    except (OSError, TypeError, AttributeError):  # no C library to reach (e.g. Windows): leave it
        return build()
    saved = out.value
    out.value = err.value
    try:
        return build()
    finally:
        out.value = saved


_first_build = threading.Lock()
_logger_routed = False


def integrator(tol: float = DEFAULT_TOL):
    """The cached heyoka integrator for ``tol`` (compiled on first use in each thread)."""
    global _logger_routed
    store = getattr(_cache, "integrators", None)
    if store is None:
        store = _cache.integrators = {}
    ta = store.get(tol)
    if ta is None:
        if not _logger_routed:
            with _first_build:
                if not _logger_routed:
                    ta = _log_to_stderr(lambda: _build(tol))
                    _logger_routed = True
        if ta is None:
            ta = _build(tol)
        store[tol] = ta
    return ta


# Integrator steps per propagate_until call on a long event-free stretch (~4 us each): the
# wall-time limit is checked between two calls. (Ctrl-C needs no chunks: heyoka.py checks
# for signals inside propagate_until, measured 0.2 ms from SIGINT to KeyboardInterrupt.)
_CHUNK_STEPS = 10_000


class _Stepper:
    """Integrates one smooth piece with the cached integrator (see engine.PieceStepper).

    A slipping piece is propagated in chunks of about ``_CHUNK_STEPS`` steps, so that a
    wall-time limit can end a long event-free piece: the chunk length in time is learned
    from the steps the last chunk took (seeded from the fastest frequency of the mode). A
    piece shorter than a chunk (the usual case) is a single call. A stuck piece is closed
    form (:mod:`impactosc._stuck`): with a constant state heyoka's steps are unbounded and
    the release guards were searched on the Taylor polynomial of ``cos`` over a huge step.
    """

    def __init__(self, ta, osc: Oscillator, deadline: float | None = None):
        import heyoka as hy

        self.ta = ta
        self.osc = osc
        self.state = ta.state  # a view onto the integrator's state
        self.pars = ta.pars
        self.pars[:_P_REGION] = (osc.F, osc.Omega, osc.beta, osc.K, osc.phase)
        self.time_limit = hy.taylor_outcome.time_limit
        self.mode_pars = {}
        # Chunk length in time, free and in a flange: ~2 steps per 1/omega are measured at
        # tol = eps, so the seed holds at most _CHUNK_STEPS steps and grows to it.
        self.chunk = [_CHUNK_STEPS * 0.5 / max(1.0, osc.Omega, w) for w in (1.0, osc.contact_frequency)]
        self.deadline = deadline  # time.monotonic() after which the run stops (max_wall_time)
        self.stopped = False

    def _set_mode(self, mode: Mode, x: float) -> None:
        vals = self.mode_pars.get(mode)
        if vals is None:
            r, s, _ = mode
            vals = self.mode_pars[mode] = (r, s, r * r, s * s, *guard_gates(mode, self.osc.rigid))
        self.pars[_P_REGION:_P_OFFSETS] = vals
        self.pars[_P_OFFSETS:] = guard_offsets(self.osc, x)

    def _out_of_time(self) -> bool:
        if time.monotonic() > self.deadline:
            self.stopped = True
        return self.stopped

    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        if self.deadline is not None and self._out_of_time():
            # The run ends here: the engine sees `stopped` and ends with status 1.
            return t, x, v, NO_GUARD, 0.0, 0.0, 0.0, 0.0, 0
        if mode.motion == 0:
            return advance_stuck(self.osc, mode, t, x, t_end)
        ta = self.ta
        self._set_mode(mode, x)
        ta.time = t
        st = self.state
        st[:] = (x, v, 0.0, 0.0, 0.0)
        which = int(mode.region != 0)
        steps = 0
        while True:
            chunk = self.chunk[which]
            t_stop = min(t_end, ta.time + chunk)
            res = ta.propagate_until(t_stop)
            outcome, n = res[0], res[3]
            steps += n
            if outcome != self.time_limit:
                break
            if t_stop == t_end:
                # heyoka keeps time in double-length arithmetic; its leading part can land an
                # ulp past t_end. The run ends at t_end exactly.
                return t_end, st[0], st[1], NO_GUARD, st[2], st[3], st[4], 0.0, steps
            # A chunk boundary inside the piece: aim the next chunk at _CHUNK_STEPS steps.
            self.chunk[which] = chunk * min(8.0, _CHUNK_STEPS / max(n, 1))
            if self.deadline is not None and self._out_of_time():
                return ta.time, st[0], st[1], NO_GUARD, st[2], st[3], st[4], 0.0, steps
        code = outcome.value
        if code >= 0 or -code - 1 >= N_GUARDS:
            raise FloatingPointError(f"heyoka stopped with outcome {outcome!r} at t={ta.time!r}")
        return ta.time, st[0], st[1], -code - 1, st[2], st[3], st[4], 0.0, steps

    def evaluate(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        """(X, V, impulse since t0) at ``times`` inside one piece, all guards gated off."""
        times = np.asarray(times, dtype=float)
        if mode.motion == 0:
            return evaluate_stuck(self.osc, mode, t0, x, times)
        ta = self.ta
        r, s, _ = mode
        self.pars[_P_REGION:] = (r, s, r * r, s * s) + (0.0,) * (2 * N_GUARDS)
        # propagate_grid needs a strictly increasing grid: evaluate each distinct time once.
        grid, where = np.unique(times, return_inverse=True)
        later = grid > t0
        ta.time = t0
        self.state[:] = (x, v, 0.0, 0.0, 0.0)
        out = np.empty((grid.shape[0], 3))
        out[~later] = (x, v, 0.0)
        if np.any(later):
            res = ta.propagate_grid(np.concatenate(([t0], grid[later])))
            vals = np.asarray(res[-1])[1:]
            if vals.shape[0] != np.count_nonzero(later) or not np.all(np.isfinite(vals[:, :3])):
                raise FloatingPointError(f"heyoka could not re-integrate the piece starting at t={t0!r}")
            out[later] = vals[:, :3]
        out = out[where.reshape(-1)]
        return out[:, 0].copy(), out[:, 1].copy(), out[:, 2].copy()


class _Evaluator:
    """Re-integrates pieces for :meth:`Solution.sample` with the cached integrator of ``tol``.

    Holds only the model and the tolerance, so a :class:`Solution` pickles (process pools,
    dask, caches); the integrator is looked up, or compiled, in the process that samples.
    """

    def __init__(self, osc: Oscillator, tol: float):
        self.osc = osc
        self.tol = tol

    def __call__(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        # The integrator may have served other runs since: a fresh _Stepper reloads this
        # run's parameters.
        return _Stepper(integrator(self.tol), self.osc).evaluate(mode, t0, x, v, times)


def check_tol(tol) -> float:
    """``tol`` as a float in [MIN_TOL, MAX_TOL], or a ``TypeError``/``ValueError`` naming it."""
    tol = _v.real("tol", tol)
    if not MIN_TOL <= tol <= MAX_TOL:
        raise ValueError(f"tol must be in [{MIN_TOL!r}, {MAX_TOL!r}] for the heyoka backend, got {tol!r}: "
                         "below about machine epsilon (2.2e-16) a double-precision run gains nothing while "
                         "the Taylor order and the compile time grow (tol=1e-200 compiles for ~40 s and "
                         "fails); above 1e-2 event times are off by more than 1e-3")
    return tol


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        sample_at=(), tol: float = DEFAULT_TOL, max_wall_time: float | None = None) -> Solution:
    """Run ``osc`` from ``(x0, v0)`` to ``t_end`` with heyoka.

    Parameters
    ----------
    osc, t_end, x0, v0, record, max_events
        See :func:`impactosc.simulate`.
    tol : float, optional
        heyoka's relative and absolute tolerance, in ``[MIN_TOL, MAX_TOL] = [1e-18, 1e-2]``
        (default: machine epsilon).
    max_wall_time : float or None, optional
        Stop after this many seconds of wall time (checked between pieces and between
        chunks of ~``_CHUNK_STEPS`` integrator steps), with ``status = 1``, a message and
        the results up to ``t_final`` kept. ``None`` (default): no limit.

    Returns
    -------
    Solution
    """
    missing = osc.unsupported()
    if missing:
        raise ValueError(f"the heyoka backend does not support {', '.join(missing)} yet; use backend='scipy'")
    tol = check_tol(tol)
    deadline = None
    if max_wall_time is not None:
        deadline = time.monotonic() + _v.positive("max_wall_time", max_wall_time)
    stepper = _Stepper(integrator(tol), osc, deadline)
    rec = _Recorder(record, "heyoka", _Evaluator(osc, tol))
    stepper.stop_message = (f"The wall-time limit max_wall_time={max_wall_time!r} s was reached; "
                            "results up to t_final are kept.")
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
