"""The one transition rule of the hybrid system, and the one driver loop around it.

Every event-locating backend integrates a *smooth piece* of motion in a fixed mode until
the first armed guard fires (or the end time), and hands the guard back here. This module
alone decides what that guard means physically: which mode comes next, whether the mass
sticks, which event is recorded. Backends therefore cannot drift apart in the physics.

Modes
-----
``Mode(region, motion, armed)`` with ``region`` in {-1, 0, +1} (lower flange, free, upper
flange), ``motion`` in {-1, 0, +1} (slip down, stick, slip up) and ``armed`` saying whether
the "slip ends" guard ``motion * V -> 0`` may fire.

Why ``armed``: when a stuck mass is released, ``|f_net| = beta`` exactly, so the
acceleration is zero and the velocity has a *double* root at the release time. Any
rounding in the first Taylor coefficient makes that root look like a fresh "slip ends"
crossing, and the mass would be swallowed back into stick forever. After a release the
"slip ends" guard is disarmed and an "acceleration zero" guard (``motion * V'`` falls to
0) is armed instead: the velocity cannot return to zero before the acceleration has
changed sign, so re-arming there is exact, not a heuristic.

Guards (direction-filtered)
---------------------------
``ENTER_UPPER``  X - gu rises through 0         free region, slipping up
``ENTER_LOWER``  X + gl falls through 0         free region, slipping down
``LEAVE``        region*X - g falls through 0   spring flange region, slipping out of it

``gu = gap_upper`` and ``gl = gap_lower`` are the distances of the flanges from the rest
position (1 and 1 by default: ``X = +-1``), ``g`` the one of the current region; an absent
flange (``inf``) has no guard that can fire.
``SLIP_END``     motion*V falls through 0       slipping, armed
``ACCEL_ZERO``   motion*V' falls through 0      slipping, not armed (internal, no event)
``RELEASE_UP``   f_net - beta_s rises through 0 stuck
``RELEASE_DOWN`` f_net + beta_s falls through 0 stuck

:func:`guard_value` and :func:`guard_gradient` define them numerically, once.
Each piece between two guards is monotonic in X (every turning point is a ``SLIP_END``),
so a flange crossing inside a piece is a simple root: grazing contacts become two simple
roots on either side of a located turning point instead of one double root. For the same
reason only the flange ahead of the motion is armed: the one behind cannot be reached in the
piece, and when the piece starts on it from rest (a release from a wall or a flange surface)
its guard has a multiple root at the start, on which heyoka's root finder gave up with a
warning on stderr.

The model family
----------------
Damping, the power-law spring and harmonic sums change only the vector field of a mode
(:meth:`Oscillator.acceleration`); the backends integrate it, the rule here is the same.
Static friction ``beta_s >= beta`` sets the stick test and the release guards; a release
always starts disarmed (with ``beta_s > beta`` the acceleration jumps to ``beta_s - beta``
and the velocity still cannot return to zero before the acceleration changes sign).
A **rigid flange** has no flange region in motion: ``ENTER_*`` is an impact
``V -> -e V`` (event ``impact``); a mass that keeps no speed at the wall is tested against
it (the internal guard :data:`AT_WALL`) and rests on it in the mode ``(side, 0)`` (event
``contact_start``), whose only armed guard is the release away from the wall (event
``contact_end``). Impacts that accumulate in finite time (chatter, a Zeno point) are
followed until a local model predicts the rest, then resolved by a jump to the
accumulation time (event ``chatter``, ``impactosc._chatter``).
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

from .._util import validation as _v
from ..model import _rule
from ..model._oscillator import Oscillator
from ._chatter import ChatterTracker

__all__ = [
    "Mode",
    "IMPACT",
    "CHATTER",
    "AT_WALL",
    "GUARD_DIRECTIONS",
    "KINEMATIC_GUARD_OFFSET",
    "guard_value",
    "guard_gradient",
    "check_sample_times",
    "EVENT_KINDS",
    "GUARD_NAMES",
    "initial_mode",
    "motion_at_rest",
    "transition",
    "guard_gates",
    "guard_offsets",
    "force_guard_offset",
    "pending_guard",
    "drive",
]

# Event kinds recorded in Solution.events, guard indices and directions: defined with the
# rule itself (impactosc._rule), re-exported here.
from ..model._rule import (
    ACCEL_ZERO,
    AT_WALL,
    ENTER_LOWER,
    ENTER_UPPER,
    EVENT_KINDS,
    GUARD_DIRECTIONS,
    INTEGRITY_ULPS,  # noqa: F401 - re-exported: the allowance of missed_guard
    KINEMATIC_GUARD_OFFSET,
    LEAVE,
    N_GUARDS,
    NO_GUARD,
    NO_KIND,
    RELEASE_DOWN,
    RELEASE_UP,
    SLIP_END,
)

CONTACT_START, CONTACT_END, REVERSAL, STICK, RELEASE = EVENT_KINDS[:5]
#: A rigid flange's instantaneous impact ``V -> -e V`` (a contact of zero duration).
IMPACT = EVENT_KINDS[5]
#: Impacts on a rigid flange accumulating in finite time (a Zeno point), resolved by a jump.
CHATTER = EVENT_KINDS[6]
GUARD_NAMES = (
    "enter_upper",
    "enter_lower",
    "leave",
    "slip_end",
    "accel_zero",
    "release_up",
    "release_down",
)


class Mode(NamedTuple):
    """Discrete state of the hybrid system (see the module docstring)."""

    region: int
    motion: int
    armed: bool = True


def guard_gates(mode: Mode, rigid: bool = False) -> tuple[float, ...]:
    """1.0 for every guard that is armed in ``mode``, 0.0 for the others (order of ``GUARD_NAMES``).

    ``rigid`` selects the gates of a rigid flange (:attr:`Oscillator.rigid`): there a flange
    region is the rest against the wall, which only the release away from it can end.
    """
    return _GATES[rigid][mode]


def _compute_gates(mode: Mode, rigid: bool) -> tuple[float, ...]:
    r, s, armed = mode
    return tuple(float(_rule.gate(rigid, r, s, int(armed), g)) for g in range(N_GUARDS))


_ALL_MODES = [Mode(r, s, a) for r in (-1, 0, 1) for s in (-1, 0, 1) for a in (True, False)]
_GATES = {rigid: {m: _compute_gates(m, rigid) for m in _ALL_MODES} for rigid in (False, True)}
#: The Mode of every ``(region, motion, armed)`` triple the rule returns (armed as 0/1).
_MODES = {(m.region, m.motion, int(m.armed)): m for m in _ALL_MODES}
#: Event kind names by the rule's kind codes (``NO_KIND`` gives None).
_KIND_NAMES = {**dict(enumerate(EVENT_KINDS)), NO_KIND: None}


def motion_at_rest(osc: Oscillator, t: float, x: float) -> tuple[int, bool]:
    """Filippov stick test for a mass at rest at time ``t`` and position ``x``.

    Returns ``(motion, armed)``. The mass sticks when ``|f_net| < beta``; it slips towards
    ``f_net`` when ``|f_net| > beta``. Exactly on the threshold it is released only if
    ``|f_net|`` is about to rise, and then with zero acceleration (``armed=False``, see the
    module docstring). ``f_net`` includes the flange spring (:meth:`Oscillator.net_force`).
    "On the threshold" means within the rounding of ``f_net`` (``impactosc._rule.tie_tolerance``): a
    release root at ``tau ~ 1e-87`` (``beta = 1e-173``, ``f_net = 0``) is beyond any event
    finder. There ``X`` is frozen, so ``f_net`` changes only with the forcing: its first
    derivative decides, and the second where the first is rounding noise (a stationary
    point of the forcing, e.g. ``sin(pi) = 1.2e-16`` in floating point).
    """
    motion, armed = _rule.motion_at_rest(osc._p, float(t), float(x))
    return motion, bool(armed)


def initial_mode(osc: Oscillator, t: float, x: float, v: float) -> Mode:
    """Mode at the initial time. The initial state is not an event (no backend records one there).

    One rule for every backend: the mode the run starts in is decided here and recorded by
    no event, whether the mass starts stuck (no ``stick``), inside or on a spring flange
    moving into it (no ``contact_start``), at rest against a rigid wall (no
    ``contact_start``: the run starts resting on it, and its ``impacts`` row is marked
    incomplete, like a contact already in progress), or released at once (no ``release``).
    What happens *after* the initial state is recorded, also at ``t = 0``: a start on a rigid
    wall moving into it is an ``impact`` at ``t = 0`` (:func:`pending_guard`), since it
    changes the velocity.

    A mass starting exactly on a spring flange's boundary belongs to the flange region if it
    moves into the flange. With ``v == 0`` the stick test of :func:`motion_at_rest` decides
    the motion, as at any other rest point. With a rigid flange a mass at rest on the wall
    rests on it (mode ``(side, 0)``) unless the stick test pulls it away, when it slides
    off in the free region; any other start is in the free region.
    """
    r, s, armed = _rule.initial_mode(osc._p, float(t), float(x), float(v))
    return _MODES[(r, s, armed)]


def transition(osc: Oscillator, mode: Mode, guard: int, t: float, x: float, v: float):
    """The transition rule: what a guard firing at ``(t, x, v)`` in ``mode`` means.

    Returns ``(new_mode, x, v, kind, side)``: the state is snapped onto the guard surface
    (``X = gap_upper`` or ``-gap_lower`` at flange crossings, ``V = 0`` at rest points) so the next piece starts
    exactly on it; ``kind`` is the event kind to record (``None`` for internal guards)
    and ``side`` is +1/-1 for flange events, 0 for friction events. ``v`` is the state after
    the transition: at an :data:`IMPACT` the recorded event keeps the incoming velocity.

    The rule itself is ``impactosc._rule.transition``, the one copy every backend runs
    (compiled with numba). In words, by guard:

    * ``SLIP_END``: the stick test (:func:`motion_at_rest`) gives a ``stick``, a ``reversal``,
      or, at a degenerate tangency where ``V`` and ``V'`` vanish together, a pause without
      an event after which the motion goes on disarmed.
    * ``ENTER_*``: a spring flange's ``contact_start``; a velocity against the motion is a
      turning point passed by rounding and is snapped to 0. On a rigid flange, Newton's
      impact law ``V -> -e V`` (Shaw & Holmes; Brach): an ``impact``; a mass that keeps no
      speed is left at the wall, where :func:`pending_guard` applies the wall's rest test
      (:data:`AT_WALL`). A *touch* (the wall reached at a turning point) is no impact: the
      stick test at the wall gives a ``reversal`` away from it or a rest on it.
    * ``LEAVE``: ``contact_end``.
    * ``ACCEL_ZERO``: re-arms the slip end (no event), or, if the velocity is already back at
      zero (the guard fires a rounding-level offset late), the slip ended here.
    * ``RELEASE_*``: a ``release`` (disarmed); on a rigid wall the resting contact ends
      (``contact_end``) and the mass slides away.
    * ``AT_WALL``: a mass at rest against a rigid flange rests on it (``contact_start``) or,
      pulled away beyond ``beta_s``, slides away at once (no event).
    """
    if not (isinstance(guard, int) and 0 <= guard <= N_GUARDS):
        raise ValueError(f"guard must be one of 0..{N_GUARDS}, got {guard!r}")
    r, s, a, x1, v1, kind, side = _rule.transition(osc._p, mode[0], mode[1], int(mode[2]), guard,
                                                   float(t), float(x), float(v))
    return _MODES[(r, s, a)], x1, v1, _KIND_NAMES[kind], side


def force_guard_offset(osc: Oscillator, t: float, x: float) -> float:
    """Offset of the force guards (release, acceleration zero) at time ``t`` and position ``x``.

    These guards sit at a threshold where ``f_net`` is computed with rounding error;
    offsetting them by the same tolerance as the stick test's tie (:func:`motion_at_rest`)
    makes the event finder and the stick test agree on what "reaching beta" means, so
    rounding noise at a tie cannot fire a spurious release, and a guard that starts on its
    threshold (the acceleration after a release) starts on its near side however large
    ``Omega t`` has grown. The shift of a genuine crossing is of the order of the rounding
    of ``f_net``.
    """
    return _rule.tie_tolerance(osc._p, float(t), float(x), 0.0)


def guard_offsets(osc: Oscillator, t: float, x: float) -> tuple[float, ...]:
    """How far each guard is shifted towards the side it crosses *from* (order of ``GUARD_NAMES``).

    A backend fires guard ``g`` (direction ``d``) at ``g - d * offset = 0``: the kinematic
    guards by :data:`KINEMATIC_GUARD_OFFSET`, the force guards by :func:`force_guard_offset`
    at the start ``(t, x)`` of the piece.
    """
    tie = force_guard_offset(osc, t, x)
    k = KINEMATIC_GUARD_OFFSET
    return (k, k, k, k, tie, tie, tie)


class PieceStepper(Protocol):
    """What an event-locating backend provides to :func:`drive`.

    ``advance`` integrates the smooth vector field of ``mode`` from ``(t, x, v)`` until the
    first armed guard of ``mode`` fires or ``t_end`` is reached, and returns
    ``(t1, x1, v1, guard, impulse, impulse_sq, forcing_work, v_squared, steps)``, or raises an
    ``ArithmeticError``/``RuntimeError`` if it cannot (the run then ends with status -1): ``guard`` is the
    index of the guard that fired or ``NO_GUARD``; the four integrals are over the piece:
    ``int K d^p dt`` (spring flange regions only), ``int (K d^p)^2 dt``,
    ``int V forcing(t) dt`` and ``int V^2 dt`` (the damping loss is ``2 zeta`` times it);
    ``steps`` counts integrator steps. In a stuck piece against a rigid flange the flange
    force is not the backend's business: it returns zero impulses there.
    """

    def advance(self, mode: Mode, t: float, x: float, v: float, t_end: float): ...

    def evaluate(self, mode: Mode, t0: float, x: float, v: float, times):
        """``(X, V, impulse since t0)`` at ``times`` inside the piece that starts at ``t0``."""


#: Consecutive events at one instant after which the loop declares it is stuck.
MAX_EVENTS_AT_ONE_INSTANT = 64


def pending_guard(osc: Oscillator, mode: Mode, fired: int, t: float, x: float, v: float) -> int:
    """A guard that already holds at the start of a piece at ``(t, x, v)``, or ``NO_GUARD``.

    ``fired`` is the guard whose transition produced ``mode``. A velocity that already
    points against the motion (``motion * V < 0``) means the slip ended at this instant: a
    flange crossing located at a turning point on ``|X| = 1`` lands a rounding error past
    it, and the new piece, whose ``SLIP_END`` guard starts past zero, would never see it
    cross (a whole period would run with the wrong vector field). The same holds for a
    flange crossing that lands exactly on the turning point (``V == 0``) when the stick test
    there disagrees with the motion. The ``SLIP_END`` transition then applies the stick test.
    After a turning point, stick or release exactly on a flange boundary (``|X| = 1`` with
    ``V = 0``), the contact guard of the next piece has a *double* root at its start: no
    event finder sees it cross. Here the new motion direction decides: moving out of the
    free zone means the contact starts now; moving back from the boundary into the free
    zone means it ends now. With a rigid flange a mass at rest on the wall is
    tested against it (:data:`AT_WALL`). Part of the transition rule, applied by :func:`drive`.
    """
    return _rule.pending_guard(osc._p, mode[0], mode[1], fired, float(t), float(x), float(v))


def missed_guard(osc: Oscillator, mode: Mode, guard: int, t0: float, x0: float, v0: float,
                 t1: float, x1: float, v1: float) -> str | None:
    """Name of a guard that must have been crossed unseen in the piece just integrated.

    A backstop, not physics. At the start ``(t0, x0, v0)`` the engine's snapped state must
    satisfy the mode exactly: ``motion * V >= 0`` (:func:`pending_guard` sees to it) and the
    region must match ``|X| >= 1`` to rounding. At the end ``(t1, x1, v1)``: in a slipping
    mode the velocity keeps the sign of the motion until ``SLIP_END``, and the flange region
    must match ``|X| > 1`` except on the guard that ends the piece; a piece that stays stuck
    to its end must end with ``|f_net| <= beta``. The allowances are rounding levels of each
    quantity (:data:`INTEGRITY_ULPS` ulps of its scale), not absolute slacks: a wrong region
    or direction is caught however small the motion. A violation means a wrong answer would
    follow, so :func:`drive` stops.
    """
    missed = _rule.missed_guard(osc._p, mode[0], mode[1], guard, float(t0), float(x0), float(v0),
                                float(t1), float(x1), float(v1))
    return None if missed == NO_GUARD else GUARD_NAMES[missed]


def guard_value(osc: Oscillator, mode: Mode, guard: int, t: float, x: float, v: float) -> float:
    """The guard function ``h`` of ``guard`` in ``mode`` at ``(t, x, v)`` (no offset).

    The one numeric definition of the guards (the order of :data:`GUARD_NAMES`); a guard
    fires where ``h`` crosses zero in :data:`GUARD_DIRECTIONS`. Backends that compile or
    solve guards in closed form implement the same functions; analyses (saltation
    matrices, :mod:`impactosc.dynamics`) use this one and :func:`guard_gradient`.
    """
    r, s, _ = mode
    if guard == ENTER_UPPER:
        return x - osc.gap_upper
    if guard == ENTER_LOWER:
        return x + osc.gap_lower
    if guard == LEAVE:
        return r * x - (osc.gap(r) if r else 1.0)  # (r = 0: not a guard of that mode)
    if guard == SLIP_END:
        return s * v
    if guard == ACCEL_ZERO:
        return s * osc._accel_scalar(t, x, v, r, s)
    if guard == RELEASE_UP:
        return osc._net_force_scalar(t, x) - osc.beta_s
    if guard == RELEASE_DOWN:
        return osc._net_force_scalar(t, x) + osc.beta_s
    raise ValueError(f"guard must be one of 0..{N_GUARDS - 1}, got {guard!r}")


def guard_gradient(osc: Oscillator, mode: Mode, guard: int, t: float, x: float, v: float):
    """``((dh/dX, dh/dV), dh/dt)`` of :func:`guard_value`: the normal ``n`` of the saltation matrix.

    The time derivative matters because the forcing makes the force guards move:
    ``S = I + (f+ - f-) n^T / (n . f- + dh/dt)``.
    """
    r, s, _ = mode
    if guard in (ENTER_UPPER, ENTER_LOWER):
        return (1.0, 0.0), 0.0
    if guard == LEAVE:
        return (float(r), 0.0), 0.0
    if guard == SLIP_END:
        return (0.0, float(s)), 0.0
    rate = float(osc.forcing_rate(t))
    if guard == ACCEL_ZERO:
        jac = osc.jacobian(t, x, v, r, s)
        return (s * jac[1, 0], s * jac[1, 1]), s * rate
    if guard in (RELEASE_UP, RELEASE_DOWN):
        # d f_net / dX = d(acceleration)/dX of the slipping vector field in the same region.
        return (float(osc.jacobian(t, x, 0.0, r, 1)[1, 0]), 0.0), rate
    raise ValueError(f"guard must be one of 0..{N_GUARDS - 1}, got {guard!r}")


def stepper_name(stepper) -> str:
    return getattr(stepper, "name", type(stepper).__module__.rsplit(".", 1)[-1])


def drive(stepper: PieceStepper, osc: Oscillator, t_end: float, x0: float, v0: float,
          recorder, max_events: int, sample_at=()) -> None:
    """The event loop shared by every event-locating backend.

    Integrates piece by piece, applies :func:`transition` at every guard (and at once to
    any :func:`pending_guard` it leaves behind), resolves chatter on a rigid flange
    (``impactosc._chatter``) and streams the results into ``recorder``. Stops at
    ``t_end`` (status 0), at ``max_events`` recorded events or when the stepper sets
    ``stopped`` (a limit such as a wall time; its ``stop_message`` is the message) (status 1),
    or when time stops advancing (status -1, a Zeno-like cascade that is not a resolvable
    chatter).

    ``sample_at`` (sorted times in ``[0, t_end]``, see :func:`check_sample_times`) are time
    events: a piece ends exactly there, the state goes to ``recorder.sample`` and the
    motion goes on in the same mode. A recorder with an ``on_transition`` method is told
    of every transition (for saltation matrices, :mod:`impactosc.dynamics`); a chatter jump
    comes with guard ``None`` and kind ``"chatter"`` (the mode goes from the last flight to
    ``Mode(0, 0)`` at the wall, where the rest test follows as an ``AT_WALL`` transition).
    A run that ends inside the tail of a chatter ends with the local model's state there
    (``impactosc._chatter.ChatterJump.state_at``), and so do sample times in the tail.
    """
    # A velocity below the kinematic guard offset is rest: its turning point would lie
    # within ~1e-300 of the start, closer than any guard can resolve (v0 = -5e-324 inside a
    # flange made the exact backend miss it). The stick test then decides the motion.
    t, x, v = 0.0, x0, (0.0 if abs(v0) <= KINEMATIC_GUARD_OFFSET else v0)
    mode = initial_mode(osc, t, x, v)
    recorder.begin(osc, t, x, v, mode)
    chatter = ChatterTracker(osc) if osc.rigid else None
    # A start on a boundary (a rigid wall, a spring flange's surface) is resolved at once.
    mode, x, v, _, _ = _settle(osc, recorder, chatter, mode, pending_guard(osc, mode, NO_GUARD, t, x, v),
                               t, x, v)
    same_instant = 0
    advance = stepper.advance
    p, missed_rule = osc._p, _rule.missed_guard
    stops = iter(sample_at)
    next_stop = next(stops, math.inf)
    while True:
        while next_stop <= t:  # a sample time reached exactly (at the start, or at an event)
            recorder.sample(next_stop, x, v, mode)
            next_stop = next(stops, math.inf)
        t_target = next_stop if next_stop < t_end else t_end
        try:
            t1, x1, v1, guard, q, q2, w, vv, steps = advance(mode, t, x, v, t_target)
        except (ArithmeticError, RuntimeError) as exc:
            # An integrator that gives up (step size underflow, non-finite state) ends the
            # run like scipy's solve_ivp does: status -1, its message, results so far kept.
            recorder.finish(t, x, v, mode, -1, f"the {stepper_name(stepper)} backend failed after t={t!r}: "
                            f"{type(exc).__name__}: {exc}")
            return
        if not (math.isfinite(x1) and math.isfinite(v1) and math.isfinite(t1)):
            recorder.finish(t, x, v, mode, -1, f"integration produced a non-finite state at t={t1!r}")
            return
        recorder.piece(mode, t, x, t1, x1, q, q2, w, vv, steps)
        if getattr(stepper, "stopped", False):
            # The backend stopped early on a limit the user set (e.g. a wall-time limit).
            message = getattr(stepper, "stop_message", "A limit set by the caller was reached.")
            recorder.finish(t1, x1, v1, mode, 1, message)
            return
        missed = missed_rule(p, mode[0], mode[1], guard, t, x, v, t1, x1, v1)
        if missed != NO_GUARD:
            recorder.finish(t1, x1, v1, mode, -1,
                            f"the {stepper_name(stepper)} backend missed a {GUARD_NAMES[missed]} guard in the piece "
                            f"[{t!r}, {t1!r}] (mode {tuple(mode)}); results up to t={t!r} are kept. "
                            "This is a bug: please report it with the parameters.")
            return
        if guard == NO_GUARD and t_target < t_end:
            # A sample time: a time event, not a transition. Same mode, same guards armed.
            t, x, v = t1, x1, v1
            recorder.segment(t, x, v, mode)
            continue
        if guard == NO_GUARD:
            while next_stop <= t1:  # a sample time at t_end itself
                recorder.sample(next_stop, x1, v1, mode)
                next_stop = next(stops, math.inf)
            recorder.finish(t1, x1, v1, mode, 0, "The end time was reached.")
            return
        mode, x1, v1, recorded, jump = _settle(osc, recorder, chatter, mode, guard, t1, x1, v1)
        if jump is not None:
            recorder.segment(t1, x1, v1, mode)  # the last flight followed, where the tail starts
            # Sample times inside the tail of the chatter get the local model's state.
            while next_stop < jump.t_inf and next_stop <= t_end:
                xs, vs, motion, *_ = jump.state_at(next_stop)
                recorder.sample(next_stop, xs, vs, Mode(0, motion, True))
                next_stop = next(stops, math.inf)
            if jump.t_inf > t_end:
                # The run ends inside the tail: its state and totals up to t_end, not the rest
                # at t_inf (the rebound speed there can be 1e-4, far above any tolerance).
                x1, v1, motion = recorder.chatter(jump, t_end)
                recorder.finish(t_end, x1, v1, Mode(0, motion, True), 0,
                                f"The end time was reached inside a chatter on the {_SIDE[jump.side]} flange "
                                f"(its impacts accumulate at t={jump.t_inf!r}, after the end).")
                return
            t1, x1, v1 = jump.t_inf, jump.wall, 0.0
            recorder.chatter(jump, t1)
            hook = getattr(recorder, "on_transition", None)
            if hook is not None:  # the jump itself: no guard, from the last flight to rest at the wall
                hook(t1, mode, None, Mode(0, 0, True), x1, 0.0, x1, 0.0, CHATTER)
            mode, x1, v1, _, _ = _settle(osc, recorder, chatter, Mode(0, 0, True), AT_WALL, t1, x1, v1)
            recorded = True
        same_instant = same_instant + 1 if t1 == t else 0
        t, x, v = t1, x1, v1
        recorder.segment(t, x, v, mode)
        if recorded and recorder.n_events >= max_events:
            recorder.finish(t, x, v, mode, 1,
                            f"The event limit max_events={max_events} was reached at t={t!r}; "
                            "results up to that time are kept.")
            return
        if same_instant > MAX_EVENTS_AT_ONE_INSTANT:
            recorder.finish(t, x, v, mode, -1,
                            f"{same_instant} consecutive events at t={t!r} without time advancing; "
                            "stopped to avoid an endless loop.")
            return


_SIDE = {1: "upper", -1: "lower"}


def _settle(osc: Oscillator, recorder, chatter, mode: Mode, guard: int, t: float, x: float, v: float):
    """Apply ``guard`` and every guard it leaves pending at ``t``; record the events.

    Returns ``(mode, x, v, recorded, jump)``: ``jump`` is a ``impactosc._chatter.ChatterJump``
    when the impacts of a chatter can be resolved from here.
    """
    recorded = False
    jump = None
    hook = getattr(recorder, "on_transition", None)
    p = osc._p
    while guard != NO_GUARD:
        v_before, x_before, mode_before = v, x, mode
        r, s, a, x, v, code, side = _rule.transition(p, mode[0], mode[1], int(mode[2]), guard, t, x, v)
        mode, kind = _MODES[(r, s, a)], _KIND_NAMES[code]
        if hook is not None:
            hook(t, mode_before, guard, mode, x_before, v_before, x, v, kind)
        if kind is not None:
            recorder.event(t, kind, x, v_before if kind == IMPACT else v, side, 1, s)
            recorded = True
            if chatter is not None:
                if kind == IMPACT:
                    jump = chatter.impact(t, side, abs(v_before))
                elif kind != REVERSAL:
                    chatter.interrupt()
                    jump = None
        guard = _rule.pending_guard(p, r, s, guard, t, x, v)
    return mode, x, v, recorded, jump


def check_sample_times(sample_at, t_end: float):
    """Validate ``sample_at``: finite times in ``[0, t_end]``; returns them sorted (a tuple)."""
    if sample_at is None:
        return ()
    import numpy as np

    try:
        arr = np.asarray(sample_at, dtype=float).ravel()
    except (TypeError, ValueError):
        raise TypeError(f"sample_at must be a sequence of times, got {sample_at!r}") from None
    if arr.size and not (np.all(np.isfinite(arr)) and arr.min() >= 0.0 and arr.max() <= t_end):
        raise ValueError(f"sample_at must hold finite times within [0, t_end={t_end!r}], "
                         f"got values in [{float(arr.min())!r}, {float(arr.max())!r}]")
    return tuple(float(t) for t in np.sort(arr))


def check_run_arguments(osc, t_end, x0, v0, max_events):
    """Validate the arguments common to every backend; returns them normalised."""
    if not isinstance(osc, Oscillator):
        raise TypeError(f"osc must be an impactosc.Oscillator, got {type(osc).__name__}")
    t_end = _v.positive("t_end", t_end)
    x0 = _v.real("x0", x0)
    v0 = _v.real("v0", v0)
    if osc.rigid and not -osc.gap_lower <= x0 <= osc.gap_upper:
        if osc.symmetric:
            raise ValueError("x0 must satisfy -1 <= x0 <= 1 with a rigid flange (the walls are at |X| = 1), "
                             f"got {x0!r}")
        raise ValueError(f"x0 must satisfy -gap_lower <= x0 <= gap_upper with a rigid flange (the walls are at "
                         f"X = {-osc.gap_lower!r} and X = {osc.gap_upper!r}), got {x0!r}")
    max_events = _v.integer("max_events", max_events, minimum=1)
    return osc, t_end, x0, v0, max_events
