"""heyoka backend: Taylor integration with guards located on each step's Taylor polynomial.

Integrators
-----------
One ``taylor_adaptive`` integrator is compiled per *shape* of family member and tolerance
(and per thread), then reused for every run and every sweep point of that shape: the
member's numbers and the mode are runtime parameters ``hy.par[i]``, so only ``pars``, ``time``
and ``state`` change between pieces. A :class:`Shape` holds what changes the expressions:
the number of forcing harmonics, damping or not, and the flange law (linear spring,
power-law spring, rigid). The paper's eq. 3 is :data:`EQ3`; its expressions, parameter
indices and states are those of the single integrator this backend compiled before the
family, so its numerics are unchanged bit for bit (one more state, such as ``int V^2``,
would change heyoka's step sizes: measured, it moved a near-grazing mean force by 3e-10).

In mode ``(r, s)`` (``r2 = r^2``, ``s2 = s^2``, the parameters as in :class:`~impactosc.model.Oscillator`)::

    f     = sum_i F_i cos(Omega_i t + phase_i)
    f_net = f - X - r K d^p,   d = r X - 1    (linear: f - X - K r2 (X - r); rigid: f - X)
    X'    = V,   V' = s2 (f_net - 2 zeta V - beta s)   (the damping term only in damped shapes)

The states are ``X, V``, then for spring flanges the flange impulse ``Q = int K d^p`` and
``Q2 = int (K d^p)^2`` (for rms forces), the forcing work ``W = int V f`` and, in damped
shapes only, ``VV = int V^2`` (the damping loss is ``2 zeta VV``). They are reset at each
piece start, so each piece returns exact increments. A rigid flange has no smooth force:
its states are ``X, V, W[, VV]`` and a mass resting against it is a stuck mode (the
recorder computes the wall's force, see :meth:`Oscillator.wall_force_integrals`).

Every guard of :mod:`impactosc.engine` is a terminal event, direction-filtered and gated:
``gate * g + (1 - gate)`` is the guard ``g`` when the gate is 1 and the constant 1 (which
has no root) when it is 0; the gates are :func:`~impactosc.engine.guard_gates` of the mode.
The releases use the static level ``beta_s``, slipping the kinetic ``beta``, and the
acceleration-zero guard is ``s (f_net - 2 zeta V - beta s)``. heyoka finds event roots on the
Taylor polynomial of each step, so event times are located to machine precision, and a
grazing contact inside a step is found even though the step ends lie on the same side of
the flange.

A stuck piece is not integrated: its release is the closed form of ``impactosc._stuck``.
Long slipping pieces are propagated in chunks so that ``max_wall_time`` can end them.
heyoka logs through spdlog on C's ``stdout``; :func:`integrator` points that log at
``stderr`` (see ``_log_to_stderr``) so that its warnings cannot corrupt piped output.

Power-law flange
----------------
``d^p`` (``p > 1``, computed by heyoka as ``exp(p log d)``) is not analytic at ``d = 0``: its
Taylor coefficients divide by ``d``, so a contact piece starting exactly at ``d = 0`` (the
engine snaps a contact start onto ``|X| = 1``) gets non-finite coefficients, and near
``d = 0`` the radius of convergence is the time left to reach ``d = 0``, so the steps
shrink geometrically. The spring is therefore switched off in the boundary layer
``0 <= d < delta`` with::

    delta = max((u / K)^(1/p), 4 eps),   u = 2^-53 (unit roundoff), eps = 2^-52

Inside the layer the mass moves in the free vector field; a runtime switch ``sigma`` (0 in
the layer, 1 beyond it) and an internal event at ``d = delta`` split a contact piece into
layer and spring sub-pieces within one ``advance`` (invisible to the engine), and heyoka
never evaluates ``d^p`` below ``delta``. The steps still shrink geometrically towards the layer's
edge, so a contact costs ``~ log(d_max / delta)`` steps on either side (measured on the contact
case with ``p = 1.5``: 78 steps per contact against 16 for the linear spring).

Error bound: in the layer the omitted force is ``K d^p < K delta^p = max(u, K (4 eps)^p)``.
The first term, ``u``, is below the rounding of the tape-spring term ``X`` (``|X| >= 1``) that
every evaluation of ``f_net`` already carries; it applies when ``K <= u / (4 eps)^p``
(``K <= 4.2e6`` for ``p = 1.5``, ``K <= 1.4e14`` for ``p = 2``). The floor ``4 eps`` keeps ``d`` a few
ulps above 0 at the layer's edge (``X ~ 1`` is rounded to ``eps / 2``), so ``d^p`` is never taken
of a rounded-away 0; where it applies, ``K (4 eps)^p`` is ``8 / p`` times the error that this
rounding of ``X`` puts into ``K d^p`` at ``d = 4 eps`` in any evaluation of the spring law. Over a
stay of duration ``T`` in the layer the omission moves ``V`` by at most ``K delta^p T`` and ``X`` by
at most ``K delta^p T^2 / 2``, leaves out at most ``K delta^p T`` of the flange impulse and
``K delta^(p+1) / (p+1)`` of the potential energy; a contact entered at speed ``v`` crosses the
layer in ``T ~ delta / v`` (``delta = 5.0e-14`` for ``K = 1e4``, ``p = 1.5``). Measured against
closed forms (tests/test_family_heyoka.py): Hertz contact durations agree to 1e-16 and
impulses to 2e-14 relative.
"""

from __future__ import annotations

import threading
import time
from typing import NamedTuple

import numpy as np

from .. import _validation as _v
from .._stuck import advance_stuck, evaluate_stuck
from ..engine import GUARD_DIRECTIONS, N_GUARDS, NO_GUARD, Mode, drive, guard_gates, guard_offsets
from ..model import Oscillator
from ..solution import Solution, _Recorder

__all__ = ["run", "integrator", "check_tol", "shape_of", "layer_thickness", "Shape", "EQ3", "DEFAULT_TOL",
           "MIN_TOL", "MAX_TOL"]

DEFAULT_TOL = 2.0**-52  # machine epsilon of double precision
# The usable tolerances (measured on the contact case and 150 random oscillators): below
# eps event times do not improve while the Taylor order and the compile time grow with
# -log(tol) (1e-100: 7 s; 1e-200: 37 s, then a failure); at 1e-2 event times are off by
# ~1e-3 and at 0.5 runs end with missed guards.
MIN_TOL = 1e-18
MAX_TOL = 1e-2


class Shape(NamedTuple):
    """What a compiled integrator's expressions depend on; every number is a runtime parameter."""

    harmonics: int  #: forcing terms, the fundamental included (1 for eq. 3)
    damped: bool  #: viscous damping ``2 zeta V``, with the state ``int V^2``
    flange: str  #: ``"linear"`` (``K d``), ``"power"`` (``K d^p``, ``p > 1``) or ``"rigid"``


#: The paper's eq. 3: one harmonic, no damping, linear flange springs.
EQ3 = Shape(1, False, "linear")


def shape_of(osc: Oscillator) -> Shape:
    """The :class:`Shape` of the integrator that runs ``osc``."""
    flange = "rigid" if osc.rigid else ("linear" if osc.exponent == 1.0 else "power")
    return Shape(len(osc.terms), osc.zeta != 0.0, flange)


# Indices into the runtime parameter vector. The first 23 are those of the eq. 3 integrator
# from before the family (same indices, same expressions: same numerics); the family's
# parameters follow, and each shape's vector ends at the last one its expressions use.
_P_F, _P_OMEGA, _P_BETA, _P_K, _P_PHASE, _P_REGION, _P_MOTION, _P_REGION2, _P_MOTION2 = range(9)
_P_GATES = 9  # N_GUARDS gate parameters follow, then N_GUARDS guard offsets
_P_OFFSETS = _P_GATES + N_GUARDS
_P_BETA_S = _P_OFFSETS + N_GUARDS  # static friction level (release guards)
_P_DAMPING = _P_BETA_S + 1  # 2 zeta
_P_EXPONENT = _P_DAMPING + 1  # p of the power-law spring
_P_LAYER = _P_EXPONENT + 1  # delta, the thickness of the power-law boundary layer
_P_SIGMA = _P_LAYER + 1  # 1: spring on (d >= delta); 0: in the layer or free
_P_LAYER_DIR = _P_SIGMA + 1  # r * s: +1 moving deeper into the flange, -1 moving out
_P_LAYER_GATE = _P_LAYER_DIR + 1
_P_HARMONICS = _P_LAYER_GATE + 1  # (F_i, Omega_i, phase_i) of every harmonic after the first

#: The internal event of power-law shapes: ``d`` crossing ``delta`` (never handed to the engine).
_LAYER = N_GUARDS
#: Spring force at the edge of the power-law layer: the unit roundoff (see the module docstring).
_LAYER_FORCE = 2.0**-53
_LAYER_FLOOR = 4.0 * DEFAULT_TOL


def _n_pars(shape: Shape) -> int:
    """Length of the parameter vector: heyoka wants exactly the highest index used, plus one."""
    if shape.harmonics > 1:
        return _P_HARMONICS + 3 * (shape.harmonics - 1)
    if shape.flange == "power":
        return _P_LAYER_GATE + 1
    if shape.damped:
        return _P_DAMPING + 1
    return _P_BETA_S + 1


def _state_names(shape: Shape) -> list[str]:
    return ["X", "V", *(() if shape.flange == "rigid" else ("Q", "Q2")), "W", *(("VV",) if shape.damped else ())]


def layer_thickness(osc: Oscillator) -> float:
    """``delta`` of the power-law boundary layer of ``osc`` (see the module docstring)."""
    return max((_LAYER_FORCE / osc.K) ** (1.0 / osc.exponent), _LAYER_FLOOR)


_cache = threading.local()


def _forces(hy, shape: Shape, X, V, p):
    """Expressions ``(f, f_net, flange force or None, acceleration while slipping)`` of ``shape``."""
    harmonics, damped, flange = shape
    K, r, r2 = p[_P_K], p[_P_REGION], p[_P_REGION2]
    terms = [(p[_P_F], p[_P_OMEGA], p[_P_PHASE])]
    terms += [tuple(p[_P_HARMONICS + 3 * i:_P_HARMONICS + 3 * i + 3]) for i in range(harmonics - 1)]
    forcing = None
    for F, Om, phase in terms:
        term = F * hy.cos(Om * hy.time + phase)
        forcing = term if forcing is None else forcing + term
    if flange == "linear":
        # In region r the compressed flange pushes with -K (X - r); r2 = r*r switches it off when free.
        f_net = forcing - X - K * r2 * (X - r)
        force = K * r2 * (r * X - 1.0)  # flange force magnitude K(|X| - 1) in region r
    elif flange == "power":
        # sigma = 0 (free, or in the boundary layer) evaluates the power at 1, never near 0.
        sigma = p[_P_SIGMA]
        force = K * sigma * (sigma * (r * X - 1.0) + (1.0 - sigma)) ** p[_P_EXPONENT]
        f_net = forcing - X - r * force
    else:
        f_net = forcing - X
        force = None
    accel = (f_net - p[_P_DAMPING] * V if damped else f_net) - p[_P_BETA] * p[_P_MOTION]
    return forcing, f_net, force, accel


def _build(tol: float, shape: Shape = EQ3):
    import heyoka as hy

    X, V, *integrals = hy.make_vars(*_state_names(shape))
    p = [hy.par[i] for i in range(_n_pars(shape))]
    r, s, s2 = p[_P_REGION], p[_P_MOTION], p[_P_MOTION2]
    gates = p[_P_GATES:_P_OFFSETS]
    offsets = p[_P_OFFSETS:_P_BETA_S]
    forcing, f_net, force, accel = _forces(hy, shape, X, V, p)

    rhs = [(X, V), (V, s2 * accel)]
    rest = iter(integrals)
    if force is not None:
        rhs += [(next(rest), force), (next(rest), force * force)]
    rhs.append((next(rest), V * forcing))
    if shape.damped:
        rhs.append((next(rest), V * V))

    beta_s = p[_P_BETA_S]
    guard_exprs = [
        X - 1.0,  # enter upper
        X + 1.0,  # enter lower
        r * X - 1.0,  # leave the flange
        s * V,  # slip ends
        s * accel,  # acceleration zero (re-arms slip end after a release)
        f_net - beta_s,  # release upwards
        f_net + beta_s,  # release downwards
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
    if shape.flange == "power":
        # d crossing delta in the direction of the motion (r s > 0: deeper). Armed only when
        # that edge lies ahead of the mass, so it never starts on its root (_LayeredStepper).
        gate, q = p[_P_LAYER_GATE], p[_P_LAYER_DIR]
        events.append(hy.t_event(gate * (q * (r * X - 1.0 - p[_P_LAYER])) + (1.0 - gate),
                                 direction=hy.event_direction.positive, cooldown=0.0))
    n_states = len(rhs)
    return hy.taylor_adaptive(rhs, [0.0] * n_states, pars=[0.0] * _n_pars(shape), t_events=events, tol=tol,
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


def integrator(tol: float = DEFAULT_TOL, shape: Shape = EQ3):
    """The cached heyoka integrator for ``tol`` and ``shape`` (compiled on first use in each thread)."""
    global _logger_routed
    store = getattr(_cache, "integrators", None)
    if store is None:
        store = _cache.integrators = {}
    key = (tol, shape)
    ta = store.get(key)
    if ta is None:
        if not _logger_routed:
            with _first_build:
                if not _logger_routed:
                    ta = _log_to_stderr(lambda: _build(tol, shape))
                    _logger_routed = True
        if ta is None:
            ta = _build(tol, shape)
        store[key] = ta
    return ta


# Integrator steps per propagate_until call on a long event-free stretch (~4 us each): the
# wall-time limit is checked between two calls. (Ctrl-C needs no chunks: heyoka.py checks
# for signals inside propagate_until, measured 0.2 ms from SIGINT to KeyboardInterrupt.)
_CHUNK_STEPS = 10_000


def _integral_slots(shape: Shape) -> tuple[int, int, int, int]:
    """Where ``(Q, Q2, W, VV)`` sit in the state list of ``shape``; -1 is a 0.0 appended to it."""
    if shape.flange == "rigid":
        return (-1, -1, 2, 3 if shape.damped else -1)
    return (2, 3, 4, 5 if shape.damped else -1)


class _Stepper:
    """Integrates one smooth piece with the cached integrator (see engine.PieceStepper).

    ``_Stepper(ta, osc)`` is a :class:`_LayeredStepper` for a power-law flange.
    A slipping piece is propagated in chunks of about ``_CHUNK_STEPS`` steps, so that a
    wall-time limit can end a long event-free piece: the chunk length in time is learned
    from the steps the last chunk took (seeded from the fastest frequency of the mode). A
    piece shorter than a chunk (the usual case) is a single call. A stuck piece is closed
    form (``impactosc._stuck``): with a constant state heyoka's steps are unbounded and
    the release guards were searched on the Taylor polynomial of ``cos`` over a huge step.
    """

    def __new__(cls, ta, osc: Oscillator, deadline: float | None = None):
        if cls is _Stepper and not osc.linear:
            cls = _LayeredStepper
        return super().__new__(cls)

    def __init__(self, ta, osc: Oscillator, deadline: float | None = None):
        import heyoka as hy

        shape = shape_of(osc)
        if len(ta.pars) != _n_pars(shape) or ta.dim != len(_state_names(shape)):
            raise ValueError(f"the integrator was compiled for another shape than {shape} (the member {osc})")
        self.ta = ta
        self.osc = osc
        self.state = ta.state  # a view onto the integrator's state
        self.pars = pars = ta.pars
        pars[:_P_REGION] = (osc.F, osc.Omega, osc.beta, osc.K, osc.phase)
        member = (osc.beta_s, 2.0 * osc.zeta, osc.exponent, layer_thickness(osc))
        pars[_P_BETA_S:_P_SIGMA] = member[:len(pars) - _P_BETA_S]
        for i, term in enumerate(osc.harmonics):
            pars[_P_HARMONICS + 3 * i:_P_HARMONICS + 3 * i + 3] = term
        self.zeros = (0.0,) * (ta.dim - 2)  # the integrals restart at 0 at each piece start
        self.slots = _integral_slots(shape)
        self.has_impulse = shape.flange != "rigid"
        self.n_events = N_GUARDS + (shape.flange == "power")
        self.time_limit = hy.taylor_outcome.time_limit
        self.mode_pars = {}
        # Chunk length in time, free and in a flange: ~2 steps per 1/omega are measured at
        # tol = eps, so the seed holds at most _CHUNK_STEPS steps and grows to it.
        fastest = max([1.0] + [Om for _, Om, _ in osc.terms])
        self.chunk = [_CHUNK_STEPS * 0.5 / max(fastest, w) for w in (1.0, osc.contact_frequency)]
        self.deadline = deadline  # time.monotonic() after which the run stops (max_wall_time)
        self.stopped = False
        self.stop_message = "The wall-time limit max_wall_time was reached; results up to t_final are kept."

    def _out_of_time(self) -> bool:
        if self.deadline is not None and time.monotonic() > self.deadline:
            self.stopped = True
        return self.stopped

    def _set_mode(self, mode: Mode, t: float, x: float) -> None:
        vals = self.mode_pars.get(mode)
        if vals is None:
            r, s, _ = mode
            vals = self.mode_pars[mode] = (r, s, r * r, s * s, *guard_gates(mode, self.osc.rigid))
        self.pars[_P_REGION:_P_OFFSETS] = vals
        self.pars[_P_OFFSETS:_P_BETA_S] = guard_offsets(self.osc, t, x)

    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        if self.deadline is not None and self._out_of_time():
            # The run ends here: the engine sees `stopped` and ends with status 1.
            return t, x, v, NO_GUARD, 0.0, 0.0, 0.0, 0.0, 0
        if mode.motion == 0:
            return advance_stuck(self.osc, mode, t, x, t_end)
        ta = self.ta
        self._set_mode(mode, t, x)
        ta.time = t
        self.state[:] = (x, v, *self.zeros)
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
                return self._result(t_end, NO_GUARD, steps)
            # A chunk boundary inside the piece: aim the next chunk at _CHUNK_STEPS steps.
            self.chunk[which] = chunk * min(8.0, _CHUNK_STEPS / max(n, 1))
            if self.deadline is not None and self._out_of_time():
                return self._result(ta.time, NO_GUARD, steps)
        code = outcome.value
        if code >= 0 or -code - 1 >= self.n_events:
            raise FloatingPointError(f"heyoka stopped with outcome {outcome!r} at t={ta.time!r}")
        return self._result(ta.time, -code - 1, steps)

    def _result(self, t1: float, guard: int, steps: int):
        """The engine's piece tuple from the integrator's state at ``t1``."""
        st = self.state.tolist()  # Python floats: cheaper to read and to compute with than numpy scalars
        st.append(0.0)  # the value of an integral this shape does not carry
        q, q2, w, vv = self.slots
        return t1, st[0], st[1], guard, st[q], st[q2], st[w], st[vv], steps

    def _set_layer(self, mode: Mode, x: float, sigma: float | None = None) -> None:
        """Power-law shapes only (see :class:`_LayeredStepper`)."""

    def _propagate_grid(self, grid: np.ndarray) -> np.ndarray:
        """States at ``grid[1:]`` (the integrator is at ``grid[0]``)."""
        return np.asarray(self.ta.propagate_grid(grid)[-1])[1:]

    def evaluate(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        """(X, V, impulse since t0) at ``times`` inside one piece, all guards gated off."""
        times = np.asarray(times, dtype=float)
        if mode.motion == 0:
            return evaluate_stuck(self.osc, mode, t0, x, times)
        ta = self.ta
        r, s, _ = mode
        self.pars[_P_REGION:_P_BETA_S] = (r, s, r * r, s * s) + (0.0,) * (2 * N_GUARDS)
        self._set_layer(mode, x)
        # propagate_grid needs a strictly increasing grid: evaluate each distinct time once.
        grid, where = np.unique(times, return_inverse=True)
        later = grid > t0
        ta.time = t0
        self.state[:] = (x, v, *self.zeros)
        out = np.empty((grid.shape[0], 3))
        out[~later] = (x, v, 0.0)
        if np.any(later):
            vals = self._propagate_grid(np.concatenate(([t0], grid[later])))
            if vals.shape[0] != np.count_nonzero(later) or not np.all(np.isfinite(vals[:, :2])):
                raise FloatingPointError(f"heyoka could not re-integrate the piece starting at t={t0!r}")
            out[later, :2] = vals[:, :2]
            out[later, 2] = vals[:, 2] if self.has_impulse else 0.0
        out = out[where.reshape(-1)]
        return out[:, 0].copy(), out[:, 1].copy(), out[:, 2].copy()


class _LayeredStepper(_Stepper):
    """The stepper of a power-law flange: the spring is off in the layer ``d < delta``.

    Within one engine piece the integration may cross ``d = delta`` once (the piece is
    monotonic in ``X``): the internal :data:`_LAYER` event ends a sub-piece there, the switch
    ``sigma`` flips, and the next sub-piece goes on. The integrals add up over sub-pieces.
    """

    def __init__(self, ta, osc: Oscillator, deadline: float | None = None):
        super().__init__(ta, osc, deadline)
        self.delta = layer_thickness(osc)
        self.sigma_next = None  # sigma forced by a layer event (else decided from d)

    def _set_mode(self, mode: Mode, t: float, x: float) -> None:
        super()._set_mode(mode, t, x)
        self._set_layer(mode, x, self.sigma_next)

    def _set_layer(self, mode: Mode, x: float, sigma: float | None = None) -> None:
        r, s, _ = mode
        q = r * s
        d = r * x - 1.0
        if sigma is None:
            # On the layer's edge the motion decides: moving deeper the spring is on.
            sigma = 1.0 if r != 0 and (d > self.delta or (d == self.delta and q > 0)) else 0.0
        elif sigma == 1.0 and not d > 0.0:
            raise FloatingPointError(f"heyoka's layer event left the penetration at d={d!r} <= 0")
        # Armed only with the layer edge ahead: deeper from the layer, or out from the spring.
        gate = 1.0 if (q > 0 and sigma == 0.0) or (q < 0 and sigma == 1.0) else 0.0
        self.pars[_P_SIGMA:_P_HARMONICS] = (sigma, q, gate)

    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        self.sigma_next = None
        q = q2 = w = vv = 0.0
        steps = 0
        while True:
            t, x, v, guard, dq, dq2, dw, dvv, n = super().advance(mode, t, x, v, t_end)
            q, q2, w, vv, steps = q + dq, q2 + dq2, w + dw, vv + dvv, steps + n
            if guard != _LAYER:
                self.sigma_next = None
                return t, x, v, guard, q, q2, w, vv, steps
            # Crossed d = delta: flip the spring; the layer event is then disarmed (one
            # crossing per monotonic piece), so this loop runs at most twice.
            self.sigma_next = 1.0 - self.pars[_P_SIGMA]

    def _propagate_grid(self, grid: np.ndarray) -> np.ndarray:
        ta = self.ta
        pending = grid[1:]
        chunks = []
        while True:
            res = ta.propagate_grid(grid)
            out = np.asarray(res[-1])[1:]
            chunks.append(out)
            pending = pending[out.shape[0]:]
            if res[0].value != -(_LAYER + 1) or not pending.size:
                return np.concatenate(chunks)
            sigma = 1.0 - self.pars[_P_SIGMA]
            self.pars[_P_SIGMA], self.pars[_P_LAYER_GATE] = sigma, 0.0
            start = ta.time
            at_edge = int(np.count_nonzero(pending <= start))  # samples exactly at the layer edge
            if at_edge:
                chunks.append(np.tile(np.asarray(self.state), (at_edge, 1)))
                pending = pending[at_edge:]
                if not pending.size:
                    return np.concatenate(chunks)
            grid = np.concatenate(([start], pending))


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
        return _Stepper(integrator(self.tol, shape_of(self.osc)), self.osc).evaluate(mode, t0, x, v, times)


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
    tol = check_tol(tol)
    deadline = None
    if max_wall_time is not None:
        deadline = time.monotonic() + _v.positive("max_wall_time", max_wall_time)
    stepper = _Stepper(integrator(tol, shape_of(osc)), osc, deadline)
    rec = _Recorder(record, "heyoka", _Evaluator(osc, tol))
    stepper.stop_message = (f"The wall-time limit max_wall_time={max_wall_time!r} s was reached; "
                            "results up to t_final are kept.")
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
