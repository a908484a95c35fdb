"""heyoka backend: Taylor integration with guards located on each step's Taylor polynomial.

Which loop runs a member
------------------------
:func:`run` dispatches in one place (``piece_loop_reason`` in ``backends/heyoka/_replay.py``).
A member with spring or rigid flanges and a forcing periodic in ``2 pi / Omega`` (the paper's
eq. 3 and most of the family) runs on the hybrid loop of user systems
(``backends/_hybrid_heyoka.py``) as :func:`~impactosc.model.hybrid.oscillator_system`, its events
replayed into the built-in :class:`~impactosc.Solution`. Power-law flanges and harmonics that are
not whole multiples of ``Omega`` still run on the piece loop that the rest of this module describes (a
piece stepper driven by the engine's ``drive``); ``piece_loop_reason`` says why for each.

Integrators
-----------
The integrators are compiled per *shape* of family member and tolerance (and per thread),
then reused for every run and every sweep point of that shape: the member's numbers and
the mode are runtime parameters ``hy.par[i]``, so only ``pars``, ``time`` and ``state``
change between pieces. A :class:`Shape` holds what changes the expressions: the number of
forcing harmonics, damping or not, and the flange law (linear spring, power-law spring,
rigid). Each shape has one integrator per *mode family* (:class:`Integrators`): slipping
between the flanges, and slipping with a spring flange compressed. Each carries only the
guards its modes can arm and the states it needs (no flange impulse between the flanges),
so a step evaluates nothing that cannot matter. The paper's eq. 3 is :data:`EQ3`. Its
vector field, guards, parameter values and states in each family are those of the single
integrator with all seven guards that this backend compiled before, so its numerics are
unchanged bit for bit (measured; a power-law flange's free pieces, which no longer carry the
spring term that the switch ``sigma = 0`` zeroed, differ by rounding: 1 ulp in 3 of the 328
event states of the Hertz contact case, its event times and mean and rms forces unchanged).
One more state, such as ``int V^2``, would change heyoka's step sizes (measured, it moved a
near-grazing mean force by 3e-10).

In mode ``(r, s)`` (``r2 = r^2``, ``s2 = s^2``, the parameters as in :class:`~impactosc.model.Oscillator`)::

    f     = sum_i F_i cos(Omega_i t + phase_i)
    f_net = f - X - r K d^p,   d = r X - g    (linear: f - X - K r2 (X - r g); rigid: f - X)
    X'    = V,   V' = s2 (f_net - 2 zeta V - beta s)   (the damping term only in damped shapes)

with ``g`` the distance of the flange of region ``r`` (``gap_upper``/``gap_lower``, 1 by
default) and the guards ``X - gap_upper``, ``X + gap_lower``, ``r X - g``: every position is a
runtime parameter, and an absent flange's guard is gated off.

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

A fast crossing needs a thicker layer. Near ``d = delta`` the ``n``-th
Taylor coefficient of ``d^p`` is about ``d^p (v / d)^n``; at heyoka's order ~20 (``tol = eps``)
it overflows once ``v / delta`` exceeds ~1e14 (a contact entered at ``v = 30`` with
``delta = 4 eps``: ``err_nf_state``). What the omission costs while the mass crosses the
layer at speed ``v`` is not the force but the velocity it changes, ``K delta^(p+1) / ((p+1) v)``
(``d ~ v tau``), so the layer is as thick as keeps that below ``u v`` (:func:`layer_thickness`)::

    delta(v) = max(delta, min(((p + 1) u v^2 / K)^(1/(p+1)), 1e-6))

Then ``v / delta(v) <= (K / ((p+1) u))^(1/(p+1)) v^((p-1)/(p+1))`` (about 7e10 for ``K = 1e6``,
``p = 1``), far from the overflow. A mass that turns inside the layer (entered at ``v``, turned
by a free-field deceleration ``a > v^2 / (2 delta)``) misses at most ``4 (p+1) u v``. Moving in,
``v`` is the speed at the piece start; moving out, the edge is placed for an upper estimate of
the exit speed and moves in, once the mass gets there, to the edge of the speed it has.
Measured on a grid of ``p`` in [1 + 1e-9, 2], ``K`` in [1e2, 1e6] and entry speeds up to 50
(damped, forced, with friction): every run finishes, event times within 1.4e-10 of scipy's
DOP853 at ``rtol = 1e-13`` (tests/test_regressions_issue20_events.py).
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..._util import validation as _v
from ..._util.notice import notice
from ...engine._driver import (
    ACCEL_ZERO,
    ENTER_LOWER,
    ENTER_UPPER,
    N_GUARDS,
    NO_GUARD,
    Mode,
    drive,
    force_guard_offset,
    guard_gates,
    guard_offsets,
)
from ...engine._stuck import advance_stuck, evaluate_stuck
from ...model._layout import P_AMPLITUDE as _P_AMPLITUDE
from ...model._oscillator import Oscillator
from ...results._solution import Solution, _Recorder
from .._hybrid_heyoka import DEFAULT_COOLDOWN, compiled
from ._ode import (
    _P_LAYER,
    _P_LAYER_GATE,
    _P_OFFSETS,
    _P_SIGMA,
    DEFAULT_TOL,
    EQ3,
    FAMILY_GUARDS,
    FLANGE,
    LAYER,
    Integrators,
    Shape,
    _build,  # noqa: F401 - re-exported: the benchmarks time a cold compile with it
    integral_slots,
    integrator,
    layer_thickness,
    log_on_stderr,
    parameter_values,
    shape_of,
)
from ._replay import _system, piece_loop_reason, run_on_hybrid_loop

__all__ = ["run", "compiled_integrator", "integrator", "check_tol", "shape_of", "layer_thickness", "Shape",
           "Integrators", "EQ3", "DEFAULT_TOL", "MIN_TOL", "MAX_TOL"]

# The usable tolerances (measured on the contact case and 150 random oscillators): below
# eps event times do not improve while the Taylor order and the compile time grow with
# -log(tol) (1e-100: 7 s; 1e-200: 37 s, then a failure); at 1e-2 event times are off by
# ~1e-3 and at 0.5 runs end with missed guards.
MIN_TOL = 1e-18
MAX_TOL = 1e-2

# Integrator steps per propagate_until call on a long event-free stretch (~1 us each): the
# wall-time limit is checked between two calls. (Ctrl-C needs no chunks: heyoka.py checks
# for signals inside propagate_until, measured 0.2 ms from SIGINT to KeyboardInterrupt.)
_CHUNK_STEPS = 10_000


class _Family:
    """One family's integrator as the stepper drives it: views onto its parameters and state."""

    __slots__ = ("ta", "pars", "state", "zeros", "slots", "events", "rows")

    def __init__(self, ta, shape: Shape, family: int):
        self.ta = ta
        self.pars = ta.pars  # views onto the integrator's buffers
        self.state = ta.state
        self.zeros = (0.0,) * (ta.dim - 2)  # the integrals restart at 0 at each piece start
        self.slots = integral_slots(shape, family)
        # The guard of each event index; power-law shapes add the internal layer event.
        self.events = FAMILY_GUARDS[family] + ((LAYER,) if family == FLANGE and shape.flange == "power" else ())
        self.rows: dict[Mode, tuple[np.ndarray, bool]] = {}


class _Stepper:
    """Integrates one smooth piece with the cached integrators (see engine.PieceStepper).

    ``_Stepper(integrators, osc)`` is a :class:`_LayeredStepper` for a power-law flange.
    A slipping piece runs on the integrator of its mode family (free, or in a spring
    flange), whose parameter vector is loaded with one array copy: the rows of the modes
    are precomputed, and only the offset of the acceleration-zero guard, which depends on
    ``x`` and is armed only after a release, is written apart.
    A slipping piece is propagated in chunks of about ``_CHUNK_STEPS`` steps, so that a
    wall-time limit can end a long event-free piece: the chunk length in time is learned
    from the steps the last chunk took (seeded from the fastest frequency of the mode). A
    piece shorter than a chunk (the usual case) is a single call. A stuck piece is closed
    form (``impactosc._stuck``): with a constant state heyoka's steps are unbounded and
    the release guards were searched on the Taylor polynomial of ``cos`` over a huge step.
    """

    def __new__(cls, integrators: Integrators, osc: Oscillator, deadline: float | None = None):
        if cls is _Stepper and not osc.linear:
            cls = _LayeredStepper
        return super().__new__(cls)

    def __init__(self, integrators: Integrators, osc: Oscillator, deadline: float | None = None):
        import heyoka as hy

        shape = shape_of(osc)
        if getattr(integrators, "shape", None) != shape:
            raise ValueError(f"the integrators were compiled for another shape than {shape} (the member {osc}): "
                             f"{getattr(integrators, 'shape', integrators)!r}")
        self.osc = osc
        self.families = [_Family(integrators.ta[f], shape, f) for f in sorted(integrators.ta)]
        self.time_limit = hy.taylor_outcome.time_limit
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

    def _row(self, fam: _Family, mode: Mode, gated: bool = True) -> tuple[np.ndarray, bool]:
        """The parameter vector of ``mode`` and whether its acceleration-zero offset is armed.

        The gates are :func:`~impactosc.engine.guard_gates` (all 0 when ``gated`` is False, to
        re-integrate a piece without events); the offsets those of
        :func:`~impactosc.engine.guard_offsets`, with the force guards' offset, the only one
        that depends on ``x``, left 0: a gated-off guard is the constant 1 whatever its offset
        (``g * off`` with ``g = 0``), and an armed one gets it in :meth:`_set_mode`.
        """
        gates = guard_gates(mode, self.osc.rigid) if gated else (0.0,) * N_GUARDS
        if gated and not self.osc.symmetric:  # an absent flange (gap inf) has no guard
            gates = tuple(0.0 if (g == ENTER_UPPER and self.osc.gap_upper == math.inf)
                          or (g == ENTER_LOWER and self.osc.gap_lower == math.inf) else on
                          for g, on in enumerate(gates))
        missing = [g for g in range(N_GUARDS) if gates[g] and g not in fam.events]
        if missing:  # the engine arms a guard this family was not compiled with
            raise RuntimeError(f"mode {tuple(mode)} arms guards {missing} that its heyoka integrator lacks")
        offsets = list(guard_offsets(self.osc, 0.0, 0.0))
        offsets[ACCEL_ZERO:] = (0.0,) * (N_GUARDS - ACCEL_ZERO)
        vals = parameter_values(self.osc, mode, gates, offsets)[:len(fam.pars)]
        return np.array(vals, dtype=float), bool(gates[ACCEL_ZERO])

    def _set_mode(self, fam: _Family, mode: Mode, t: float, x: float, v: float = 0.0) -> None:
        """Load the parameters of ``mode`` for a piece starting at ``(x, v)``: one array copy."""
        entry = fam.rows.get(mode)
        if entry is None:
            entry = fam.rows[mode] = self._row(fam, mode)
        row, accel_zero_armed = entry
        fam.pars[:] = row
        if accel_zero_armed:
            fam.pars[_P_OFFSETS + ACCEL_ZERO] = force_guard_offset(self.osc, t, x)

    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        if self.deadline is not None and self._out_of_time():
            # The run ends here: the engine sees `stopped` and ends with status 1.
            return t, x, v, NO_GUARD, 0.0, 0.0, 0.0, 0.0, 0
        if mode.motion == 0:
            return advance_stuck(self.osc, mode, t, x, t_end)
        which = mode.region != 0
        fam = self.families[which]
        self._set_mode(fam, mode, t, x, v)
        ta = fam.ta
        ta.time = t
        fam.state[:] = (x, v, *fam.zeros)
        chunks = self.chunk
        time_limit = self.time_limit
        steps = 0
        while True:
            chunk = chunks[which]
            t_stop = t + chunk
            if t_stop >= t_end:
                t_stop = t_end
            res = ta.propagate_until(t_stop)
            outcome = res[0]
            steps += res[3]
            if outcome != time_limit:
                break
            if t_stop == t_end:
                # heyoka keeps time in double-length arithmetic; its leading part can land an
                # ulp past t_end. The run ends at t_end exactly.
                return self._result(fam, t_end, NO_GUARD, steps)
            # A chunk boundary inside the piece: aim the next chunk at _CHUNK_STEPS steps.
            chunks[which] = chunk * min(8.0, _CHUNK_STEPS / max(res[3], 1))
            t = ta.time
            if self.deadline is not None and self._out_of_time():
                return self._result(fam, t, NO_GUARD, steps)
        index = -outcome.value - 1
        if not 0 <= index < len(fam.events):
            raise FloatingPointError(f"heyoka stopped with outcome {outcome!r} at t={ta.time!r}")
        return self._result(fam, ta.time, fam.events[index], steps)

    @staticmethod
    def _result(fam: _Family, t1: float, guard: int, steps: int):
        """The engine's piece tuple from the integrator's state at ``t1``."""
        st = fam.state.tolist()  # Python floats: cheaper to read and to compute with than numpy scalars
        st.append(0.0)  # the value of an integral this family does not carry
        q, q2, w, vv = fam.slots
        return t1, st[0], st[1], guard, st[q], st[q2], st[w], st[vv], steps

    def _set_layer(self, fam: _Family, mode: Mode, x: float, v: float, layer=None) -> None:
        """Power-law shapes only (see :class:`_LayeredStepper`)."""

    def _propagate_grid(self, fam: _Family, grid: np.ndarray) -> np.ndarray:
        """States at ``grid[1:]`` (the integrator is at ``grid[0]``)."""
        return np.asarray(fam.ta.propagate_grid(grid)[-1])[1:]

    def evaluate(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        """(X, V, impulse since t0) at ``times`` inside one piece, all guards gated off."""
        times = np.asarray(times, dtype=float)
        if mode.motion == 0:
            return evaluate_stuck(self.osc, mode, t0, x, times)
        fam = self.families[mode.region != 0]
        fam.pars[:] = self._row(fam, mode, gated=False)[0]
        self._set_layer(fam, mode, x, v)
        # propagate_grid needs a strictly increasing grid: evaluate each distinct time once.
        grid, where = np.unique(times, return_inverse=True)
        later = grid > t0
        fam.ta.time = t0
        fam.state[:] = (x, v, *fam.zeros)
        out = np.empty((grid.shape[0], 3))
        out[~later] = (x, v, 0.0)
        if np.any(later):
            vals = self._propagate_grid(fam, np.concatenate(([t0], grid[later])))
            if vals.shape[0] != np.count_nonzero(later) or not np.all(np.isfinite(vals[:, :2])):
                raise FloatingPointError(f"heyoka could not re-integrate the piece starting at t={t0!r}")
            out[later, :2] = vals[:, :2]
            out[later, 2] = vals[:, fam.slots[0]] if fam.slots[0] >= 0 else 0.0
        out = out[where.reshape(-1)]
        return out[:, 0].copy(), out[:, 1].copy(), out[:, 2].copy()


class _LayeredStepper(_Stepper):
    """The stepper of a power-law flange: the spring is off in the layer ``d < delta``.

    Within one engine piece the integration crosses the layer's edge at most once each way
    (the piece is monotonic in ``X``): the internal layer event ends a sub-piece there, the
    switch ``sigma`` flips, and the next sub-piece goes on. The integrals add up over
    sub-pieces. Only the flange family has the spring, the switch and the layer event.
    ``delta`` depends on the speed at the edge (:func:`layer_thickness`): moving in it is
    the speed at the piece start; moving out the edge is first put at the thickness for an
    upper estimate of the exit speed (:meth:`_exit_speed`), and when the mass reaches it the
    edge moves in to the thickness of the speed it has there, if that is thinner
    (:meth:`_after_layer`; at most :data:`_MAX_LAYER_MOVES` moves).
    """

    def __init__(self, integrators: Integrators, osc: Oscillator, deadline: float | None = None):
        super().__init__(integrators, osc, deadline)
        self.delta = layer_thickness(osc)
        self.layer_next = None  # (sigma, delta, gate) set by a layer event (else decided at the piece start)

    def _set_mode(self, fam: _Family, mode: Mode, t: float, x: float, v: float = 0.0) -> None:
        super()._set_mode(fam, mode, t, x, v)
        self._set_layer(fam, mode, x, v, self.layer_next)

    def _exit_speed(self, x: float, v: float, d: float) -> float:
        """An upper estimate of the speed at the flange surface of a mass at depth ``d`` moving out.

        The spring's energy ``K d^(p+1) / (p+1)`` and the work of the largest other forces
        (forcing amplitude, tape spring, friction) over ``d``, added to the kinetic energy.
        """
        osc = self.osc
        p = osc.exponent
        work = osc.K * d ** (p + 1.0) / (p + 1.0) + (osc._p[_P_AMPLITUDE] + abs(x) + osc.beta) * d
        return (v * v + 2.0 * work) ** 0.5

    def _set_layer(self, fam: _Family, mode: Mode, x: float, v: float, layer=None) -> None:
        r, s, _ = mode
        if r == 0:
            return  # the free family has no spring
        q = r * s
        d = r * x - self.osc.gap(r)
        if layer is None:
            if q > 0:
                # Moving deeper: the edge is that of the entry speed; on it the spring is on.
                delta = layer_thickness(self.osc, abs(v))
                sigma = 1.0 if d >= delta else 0.0
            else:
                delta = layer_thickness(self.osc, self._exit_speed(x, v, max(d, 0.0)))
                sigma = 1.0 if d > delta else 0.0
            # Armed only with the layer edge ahead: deeper from the layer, or out from the spring.
            gate = 1.0 if (q > 0 and sigma == 0.0) or (q < 0 and sigma == 1.0) else 0.0
        else:
            sigma, delta, gate = layer
            if sigma == 1.0 and not d > 0.0:
                raise FloatingPointError(f"heyoka's layer event left the penetration at d={d!r} <= 0")
        self.delta = delta
        fam.pars[_P_LAYER] = delta
        fam.pars[_P_SIGMA:_P_LAYER_GATE + 1] = (sigma, q, gate)

    def _after_layer(self, pars, x: float, v: float, moves: int):
        """``(sigma, delta, gate)`` after the layer event at ``(x, v)``, the ``moves``-th of the piece.

        Moving in, the spring comes on. Moving out, the edge moves in to the thickness of the
        speed the mass has reached if that is thinner than where it is (the spring stays on,
        the event armed again), else the spring goes off for the rest of the way out.
        """
        sigma, delta = pars[_P_SIGMA], pars[_P_LAYER]
        if sigma == 0.0:
            return 1.0, delta, 0.0
        needed = layer_thickness(self.osc, abs(v))
        if moves < _MAX_LAYER_MOVES and needed < 0.5 * delta:
            return 1.0, needed, 1.0
        return 0.0, delta, 0.0

    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float):
        self.layer_next = None
        q = q2 = w = vv = 0.0
        steps = moves = 0
        while True:
            t, x, v, guard, dq, dq2, dw, dvv, n = super().advance(mode, t, x, v, t_end)
            q, q2, w, vv, steps = q + dq, q2 + dq2, w + dw, vv + dvv, steps + n
            if guard != LAYER:
                self.layer_next = None
                return t, x, v, guard, q, q2, w, vv, steps
            # Reached the layer's edge: flip the spring, or move the edge (see _after_layer).
            moves += 1
            self.layer_next = self._after_layer(self.families[FLANGE].pars, x, v, moves)

    def _propagate_grid(self, fam: _Family, grid: np.ndarray) -> np.ndarray:
        ta, pars = fam.ta, fam.pars
        pending = grid[1:]
        chunks = []
        moves = 0
        while True:
            res = ta.propagate_grid(grid)
            out = np.asarray(res[-1])[1:]
            chunks.append(out)
            pending = pending[out.shape[0]:]
            index = -res[0].value - 1
            if not (0 <= index < len(fam.events) and fam.events[index] == LAYER) or not pending.size:
                return np.concatenate(chunks)
            moves += 1
            sigma, delta, gate = self._after_layer(pars, fam.state[0], fam.state[1], moves)
            pars[_P_LAYER] = delta
            pars[_P_SIGMA], pars[_P_LAYER_GATE] = sigma, gate
            start = ta.time
            at_edge = int(np.count_nonzero(pending <= start))  # samples exactly at the layer edge
            if at_edge:
                chunks.append(np.tile(np.asarray(fam.state), (at_edge, 1)))
                pending = pending[at_edge:]
                if not pending.size:
                    return np.concatenate(chunks)
            grid = np.concatenate(([start], pending))


#: Times the edge of a power-law layer may move in during one piece moving out (see _LayeredStepper).
_MAX_LAYER_MOVES = 4


class _Evaluator:
    """Re-integrates pieces for :meth:`Solution.sample` with the cached integrators of ``tol``.

    Holds only the model and the tolerance, so a :class:`Solution` pickles (process pools,
    dask, caches); the integrators are looked up, or compiled, in the process that samples.
    """

    def __init__(self, osc: Oscillator, tol: float):
        self.osc = osc
        self.tol = tol

    def __call__(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        # The integrators may have served other runs since: a fresh _Stepper reloads this
        # run's parameters.
        return _Stepper(integrator(self.tol, shape_of(self.osc)), self.osc).evaluate(mode, t0, x, v, times)


def compiled_integrator(osc: Oscillator, tol: float = DEFAULT_TOL):
    """The compiled heyoka integrator that runs ``osc`` (compiled on the first call, then reused).

    ``osc`` runs as :func:`~impactosc.model.hybrid.oscillator_system` on the hybrid loop, whose
    integrator is compiled once per system structure and tolerance (``backends/_hybrid_heyoka.py``,
    ``compiled``): members that differ only in their numbers (``F``, ``Omega``, ``beta``, ``K``,
    gaps...) share it, because every number is a runtime parameter. Call it to take the compile
    (0.1-1 s, logged once per structure) out of a first timed run. The process's first heyoka
    integrator is built with heyoka's log on ``stderr``, so its warnings never reach piped output.

    Parameters
    ----------
    osc : Oscillator
        The member (any member that ``simulate(osc, backend="heyoka")`` runs).
    tol : float, optional
        heyoka's tolerance, in ``[MIN_TOL, MAX_TOL]`` (default: machine epsilon).

    Returns
    -------
    object
        The hybrid loop's compiled system (its ``taylor_adaptive`` is ``.ta``): the same object
        for every member of one structure at one tolerance.

    Examples
    --------
    >>> import impactosc as io
    >>> from impactosc.backends.heyoka import compiled_integrator
    >>> a = compiled_integrator(io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4))
    >>> a is compiled_integrator(io.Oscillator(F=0.3, Omega=0.7, beta=0.02, K=1e3))
    True
    """
    system = _system(osc)[0]
    tol = check_tol(tol)
    return log_on_stderr(lambda: compiled(system, tol, DEFAULT_COOLDOWN))


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
        chunks of 10,000 integrator steps), with ``status = 1``, a message and
        the results up to ``t_final`` kept. ``None`` (default): no limit.

    Returns
    -------
    Solution
    """
    tol = check_tol(tol)
    started = time.monotonic()
    if piece_loop_reason(osc, max_wall_time) is None:
        sol = run_on_hybrid_loop(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=sample_at,
                                 tol=tol, max_wall_time=max_wall_time)
        if sol.status != -1:
            return sol
        # The hybrid loop failed where the piece loop may not: degenerate ties it cannot yet decide
        # as the engine's stick test does (a frictionless mass at rest on a flange's surface under a
        # forcing of period 6e12, stopped and reversed at one instant 64 times). The run is redone
        # on the piece loop, and the first such fallback of the process is logged.
        notice("heyoka-piece-fallback",
               f"impactosc: the heyoka backend's hybrid loop failed on {osc!r} from x0={x0!r}, v0={v0!r} "
               f"({sol.message}); the run was redone on its piece loop (logged once per process)")
        if max_wall_time is not None:
            max_wall_time = max(max_wall_time - (time.monotonic() - started), 1e-3)
    deadline = None
    if max_wall_time is not None:
        deadline = time.monotonic() + _v.positive("max_wall_time", max_wall_time)
    stepper = _Stepper(integrator(tol, shape_of(osc)), osc, deadline)
    rec = _Recorder(record, "heyoka", _Evaluator(osc, tol))
    stepper.stop_message = (f"The wall-time limit max_wall_time={max_wall_time!r} s was reached; "
                            "results up to t_final are kept.")
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
