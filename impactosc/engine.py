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
``ENTER_UPPER``  X - 1 rises through 0        free region, slipping
``ENTER_LOWER``  X + 1 falls through 0        free region, slipping
``LEAVE``        region*X - 1 falls through 0 flange region, slipping
``SLIP_END``     motion*V falls through 0     slipping, armed
``ACCEL_ZERO``   motion*V' falls through 0    slipping, not armed (internal, no event)
``RELEASE_UP``   f_net - beta rises through 0 stuck
``RELEASE_DOWN`` f_net + beta falls through 0 stuck

Each piece between two guards is monotonic in X (every turning point is a ``SLIP_END``),
so a flange crossing inside a piece is a simple root: grazing contacts become two simple
roots on either side of a located turning point instead of one double root.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

from . import _validation as _v
from .model import Oscillator

__all__ = [
    "Mode",
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

# Event kinds recorded in Solution.events
CONTACT_START = "contact_start"
CONTACT_END = "contact_end"
REVERSAL = "reversal"
STICK = "stick"
RELEASE = "release"
EVENT_KINDS = (CONTACT_START, CONTACT_END, REVERSAL, STICK, RELEASE)

# Guard indices: the order is the contract between this module and the backends.
ENTER_UPPER, ENTER_LOWER, LEAVE, SLIP_END, ACCEL_ZERO, RELEASE_UP, RELEASE_DOWN = range(7)
GUARD_NAMES = (
    "enter_upper",
    "enter_lower",
    "leave",
    "slip_end",
    "accel_zero",
    "release_up",
    "release_down",
)
N_GUARDS = len(GUARD_NAMES)
#: Direction of each guard: +1 fires on a rising crossing, -1 on a falling one.
GUARD_DIRECTIONS = (1, -1, -1, -1, -1, 1, -1)

#: The state has not reached a guard: the piece ended at the requested end time.
NO_GUARD = -1


class Mode(NamedTuple):
    """Discrete state of the hybrid system (see the module docstring)."""

    region: int
    motion: int
    armed: bool = True


def guard_gates(mode: Mode) -> tuple[float, ...]:
    """1.0 for every guard that is armed in ``mode``, 0.0 for the others (order of ``GUARD_NAMES``)."""
    return _GATES[mode]


def _compute_gates(mode: Mode) -> tuple[float, ...]:
    r, s, armed = mode
    moving = s != 0
    return (
        float(moving and r == 0),
        float(moving and r == 0),
        float(moving and r != 0),
        float(moving and armed),
        float(moving and not armed),
        float(not moving),
        float(not moving),
    )


_ALL_MODES = [Mode(r, s, a) for r in (-1, 0, 1) for s in (-1, 0, 1) for a in (True, False)]
_GATES = {m: _compute_gates(m) for m in _ALL_MODES}


def motion_at_rest(osc: Oscillator, t: float, x: float) -> tuple[int, bool]:
    """Filippov stick test for a mass at rest at time ``t`` and position ``x``.

    Returns ``(motion, armed)``. The mass sticks when ``|f_net| < beta``; it slips towards
    ``f_net`` when ``|f_net| > beta``. Exactly on the threshold it is released only if
    ``|f_net|`` is about to rise, and then with zero acceleration (``armed=False``, see the
    module docstring). ``f_net`` includes the flange spring (:meth:`Oscillator.net_force`).
    """
    f = osc._net_force_scalar(t, x)
    b = osc.beta
    af = abs(f)
    # Within the rounding of f_net of the threshold counts as on it: a release root at
    # tau ~ 1e-87 (beta = 1e-173, f_net = 0) is beyond any event finder (heyoka's gives up).
    tie = _tie_tolerance(osc, t, x, f)
    if af < b - tie:
        return 0, True
    if af > b + tie:
        return (1 if f > 0.0 else -1), True
    # On the threshold (|f_net| == beta, possibly 0 == 0 without friction). X is frozen,
    # so f_net changes only with the forcing: look at its first derivative, and at the
    # second where the first is rounding noise (a stationary point of the forcing, e.g.
    # sin(pi) = 1.2e-16 in floating point).
    theta = osc.Omega * t + osc.phase
    d1 = -osc.F * osc.Omega * math.sin(theta)
    d2 = -osc.F * osc.Omega * osc.Omega * math.cos(theta)
    noise = 8.0 * _EPS * osc.F * osc.Omega * (1.0 + abs(theta))
    trend = d1 if abs(d1) > noise else d2
    if abs(f) > tie:
        if f * trend > 0.0:
            return (1 if f > 0.0 else -1), False
        return 0, True
    if trend != 0.0:  # beta == 0 and f_net == 0: the mass moves the way f_net starts to point
        return (1 if trend > 0.0 else -1), False
    return 0, True


_EPS = 2.0**-52


def _tie_tolerance(osc: Oscillator, t: float, x: float, f: float) -> float:
    """Rounding level of f_net at ``(t, x)``: a few ulps of every term that forms it.

    The forcing ``F cos(Omega t + phase)`` is rounded like ``F`` times its phase error, and
    the phase ``Omega t + phase`` is rounded to an ulp of its largest part: at
    ``Omega t ~ 200`` that is ~6e-15 F, far above an ulp of ``F`` (a force guard offset by
    less than it could start a piece on the wrong side of zero, and heyoka then dropped
    its next root: issue 14). The spring terms and ``f_net`` itself are rounded to an ulp.
    """
    pen = abs(x) - 1.0
    spring = abs(x) + (osc.K * pen if pen > 0.0 else 0.0)
    forcing = osc.F * (1.0 + abs(osc.Omega * t) + abs(osc.phase))
    # The floor keeps a force guard from being the zero polynomial when f_net vanishes
    # identically (F = 0 at equilibrium): that guard "crossed" everywhere and crawled
    # through 250000 stick/release pairs in half a time unit.
    return max(4.0 * _EPS * max(forcing, spring, abs(f)), KINEMATIC_GUARD_OFFSET)


def initial_mode(osc: Oscillator, t: float, x: float, v: float) -> Mode:
    """Mode at the initial time (not an event).

    A mass starting exactly on a flange boundary belongs to the flange region if it moves
    into the flange. With ``v == 0`` the stick test of :func:`motion_at_rest` decides the
    motion, as at any other rest point.
    """
    if v > 0.0:
        motion, armed = 1, True
    elif v < 0.0:
        motion, armed = -1, True
    else:
        motion, armed = motion_at_rest(osc, t, x)
    if x > 1.0 or (x == 1.0 and motion > 0):
        region = 1
    elif x < -1.0 or (x == -1.0 and motion < 0):
        region = -1
    else:
        region = 0
    return Mode(region, motion, armed)


def transition(osc: Oscillator, mode: Mode, guard: int, t: float, x: float, v: float):
    """The transition rule: what a guard firing at ``(t, x, v)`` in ``mode`` means.

    Returns ``(new_mode, x, v, kind, side)``: the state is snapped onto the guard surface
    (``X = +-1`` at flange crossings, ``V = 0`` at rest points) so the next piece starts
    exactly on it; ``kind`` is the event kind to record (``None`` for internal guards)
    and ``side`` is +1/-1 for flange events, 0 for friction events.
    """
    r, s, armed = mode
    if guard == SLIP_END:
        s_new, armed_new = motion_at_rest(osc, t, x)
        if s_new == 0:
            return Mode(r, 0, True), x, 0.0, STICK, 0
        if s_new == s:
            # Degenerate tangency (V and V' vanish together): the mass pauses and goes on.
            return Mode(r, s, False), x, 0.0, None, 0
        return Mode(r, s_new, armed_new), x, 0.0, REVERSAL, 0
    if guard == ENTER_UPPER:
        return Mode(1, s, armed), 1.0, v, CONTACT_START, 1
    if guard == ENTER_LOWER:
        return Mode(-1, s, armed), -1.0, v, CONTACT_START, -1
    if guard == LEAVE:
        return Mode(0, s, armed), float(r), v, CONTACT_END, r
    if guard == ACCEL_ZERO:
        if s * v <= 0.0:
            # The guard fires a rounding-level offset late (see guard_offsets): if the
            # velocity is already back at zero, the slip ended here.
            return transition(osc, Mode(r, s, True), SLIP_END, t, x, 0.0)
        return Mode(r, s, True), x, v, None, 0
    if guard == RELEASE_UP:
        return Mode(r, 1, False), x, 0.0, RELEASE, 0
    if guard == RELEASE_DOWN:
        return Mode(r, -1, False), x, 0.0, RELEASE, 0
    raise ValueError(f"guard must be one of 0..{N_GUARDS - 1}, got {guard!r}")


#: Offset of the kinematic guards (X -+ 1, V): it only keeps an exactly snapped guard
#: off zero at a piece start, where heyoka drops the guard's next root in the same step.
KINEMATIC_GUARD_OFFSET = 1e-300


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
    return _tie_tolerance(osc, t, x, 0.0)


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
    ``(t1, x1, v1, guard, impulse, impulse_sq, forcing_work, steps)``, or raises an
    ``ArithmeticError``/``RuntimeError`` if it cannot (the run then ends with status -1): ``guard`` is the
    index of the guard that fired or ``NO_GUARD``; the three integrals are over the piece:
    ``int K(|X|-1) dt`` (flange regions only), ``int (K(|X|-1))^2 dt`` and
    ``int V F cos(Omega t + phase) dt``; ``steps`` counts integrator steps.
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
    cross (issue 14: a whole period ran with the wrong vector field). The same holds for a
    flange crossing that lands exactly on the turning point (``V == 0``) when the stick test
    there disagrees with the motion. The ``SLIP_END`` transition then applies the stick test.
    After a turning point, stick or release exactly on a flange boundary (``|X| = 1`` with
    ``V = 0``), the contact guard of the next piece has a *double* root at its start: no
    event finder sees it cross. Here the new motion direction decides: moving out of the
    free zone means the contact starts now; moving back from the boundary into the free
    zone means it ends now. Part of the transition rule, applied by :func:`drive`.
    """
    r, s, _ = mode
    if s == 0:
        return NO_GUARD
    if s * v < 0.0:
        return SLIP_END
    if v == 0.0 and fired in (ENTER_UPPER, ENTER_LOWER, LEAVE) and motion_at_rest(osc, t, x)[0] != s:
        return SLIP_END
    if r == 0:
        if s > 0 and x >= 1.0:
            return ENTER_UPPER
        if s < 0 and x <= -1.0:
            return ENTER_LOWER
    elif s == -r and r * x <= 1.0:
        return LEAVE
    return NO_GUARD


#: Rounding allowance of the integrity checks of :func:`missed_guard`, in ulps of the
#: scale of the quantity checked (far above the rounding of a closed form or of a Taylor
#: polynomial evaluated at its root, far below any violation that changes the motion).
INTEGRITY_ULPS = 64.0


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
    r, s, _ = mode
    if s == 0:
        if guard == NO_GUARD:
            f = osc._net_force_scalar(t1, x1)
            if abs(f) > osc.beta + 2.0 * INTEGRITY_ULPS * _tie_tolerance(osc, t1, x1, f):
                return "release_up" if f > 0 else "release_down"
        return None
    if s * v0 < 0.0:
        return GUARD_NAMES[SLIP_END]
    # The region test against |X| = 1 with an allowance of ulps of X (the cheap test first).
    if r == 0:
        far = abs(x0) if guard in (ENTER_UPPER, ENTER_LOWER) else max(abs(x0), abs(x1))
        if far > 1.0 and far - 1.0 > INTEGRITY_ULPS * _EPS * max(abs(x0), abs(x1)):
            return "enter_upper" if x1 > 0 else "enter_lower"
    else:
        near = r * x0 if guard == LEAVE else min(r * x0, r * x1)
        if near < 1.0 and 1.0 - near > INTEGRITY_ULPS * _EPS * max(1.0, abs(x0), abs(x1)):
            return GUARD_NAMES[LEAVE]
    if guard != SLIP_END and s * v1 < 0.0:
        # V is rounded like the largest velocity the piece can reach from its start: the
        # start velocity plus the largest acceleration (the piece is monotonic in X, so the
        # restoring force peaks at an end) over the piece, and over one ulp of t1.
        w2 = 1.0 + osc.K if r else 1.0
        accel = osc.F + osc.beta + 1.0 + w2 * max(abs(x0 - r), abs(x1 - r))
        tol_v = INTEGRITY_ULPS * _EPS * (abs(v0) + accel * (t1 - t0 + abs(t1) * _EPS))
        if s * v1 < -tol_v:
            return GUARD_NAMES[SLIP_END]
    return None


def stepper_name(stepper) -> str:
    return getattr(stepper, "name", type(stepper).__module__.rsplit(".", 1)[-1])


def drive(stepper: PieceStepper, osc: Oscillator, t_end: float, x0: float, v0: float,
          recorder, max_events: int) -> None:
    """The event loop shared by every event-locating backend.

    Integrates piece by piece, applies :func:`transition` at every guard (and at once to
    any :func:`pending_guard` it leaves behind) and streams the results into
    ``recorder``. Stops at ``t_end`` (status 0), at ``max_events`` recorded events
    (status 1) or when time stops advancing (status -1, a Zeno-like cascade).
    """
    # A velocity below the kinematic guard offset is rest: its turning point would lie
    # within ~1e-300 of the start, closer than any guard can resolve (v0 = -5e-324 inside a
    # flange made the exact backend miss it). The stick test then decides the motion.
    t, x, v = 0.0, x0, (0.0 if abs(v0) <= KINEMATIC_GUARD_OFFSET else v0)
    mode = initial_mode(osc, t, x, v)
    recorder.begin(osc, t, x, v, mode)
    same_instant = 0
    advance = stepper.advance
    while True:
        try:
            t1, x1, v1, guard, q, q2, w, steps = advance(mode, t, x, v, t_end)
        except (ArithmeticError, RuntimeError) as exc:
            # An integrator that gives up (step size underflow, non-finite state) ends the
            # run like scipy's solve_ivp does: status -1, its message, results so far kept.
            recorder.finish(t, x, v, mode, -1, f"the {stepper_name(stepper)} backend failed after t={t!r}: "
                            f"{type(exc).__name__}: {exc}")
            return
        if not (math.isfinite(x1) and math.isfinite(v1) and math.isfinite(t1)):
            recorder.finish(t, x, v, mode, -1, f"integration produced a non-finite state at t={t1!r}")
            return
        recorder.piece(mode, t, x, t1, x1, q, q2, w, steps)
        missed = missed_guard(osc, mode, guard, t, x, v, t1, x1, v1)
        if missed:
            recorder.finish(t1, x1, v1, mode, -1,
                            f"the {stepper_name(stepper)} backend missed a {missed} guard in the piece "
                            f"[{t!r}, {t1!r}] (mode {tuple(mode)}); results up to t={t!r} are kept. "
                            "This is a bug: please report it with the parameters.")
            return
        if guard == NO_GUARD:
            recorder.finish(t1, x1, v1, mode, 0, "The end time was reached.")
            return
        recorded = False
        while guard != NO_GUARD:
            mode, x1, v1, kind, side = transition(osc, mode, guard, t1, x1, v1)
            if kind is not None:
                recorder.event(t1, kind, x1, v1, side)
                recorded = True
            guard = pending_guard(osc, mode, guard, t1, x1, v1)
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


def check_run_arguments(osc, t_end, x0, v0, max_events):
    """Validate the arguments common to every backend; returns them normalised."""
    if not isinstance(osc, Oscillator):
        raise TypeError(f"osc must be an impactosc.Oscillator, got {type(osc).__name__}")
    t_end = _v.positive("t_end", t_end)
    x0 = _v.real("x0", x0)
    v0 = _v.real("v0", v0)
    max_events = _v.integer("max_events", max_events, minimum=1)
    return osc, t_end, x0, v0, max_events
