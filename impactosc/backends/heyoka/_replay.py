"""The built-in family on the one heyoka event loop: a user-system run replayed into a :class:`Solution`.

A member that :func:`~impactosc.model.hybrid.oscillator_system` writes (spring flanges,
kinetic and static friction, damping, harmonics, one or two flanges at any gaps) runs as
that hybrid system on the user systems' heyoka loop (:mod:`impactosc.backends._hybrid_heyoka`),
with the integrals the built-in :class:`~impactosc.Solution` reports (``Q``, ``Q2``, ``W``,
``VV``: ``oscillator_system(osc, energy=True)``). The run's events then feed the built-in
recorder (:class:`~impactosc.results._solution._Recorder`) as the engine's ``drive`` feeds
it: ``begin``, then its smooth pieces (the integrals' increments between two events), events
and piece starts, as arrays in one ``bulk`` call, then ``finish``. The hybrid
modes map onto the engine's ``Mode(region, motion)`` and its guards onto the built-in
event kinds (``contact_start``, ``contact_end``, ``stick``, ``reversal``, ``release``).

Power-law flanges (``K d^p``) can run there too: :func:`~impactosc.model.hybrid.oscillator_system` gives
each flange a boundary-layer mode with an internal edge guard (``LAYER_EDGE``), which the replay
drops (:func:`recorded_crossings`: a contact's pieces across the edge are one piece, its integrals
continuous there), and whose dense output inside a contact goes through the edge with the events on
(:func:`_through_layer`). Rigid flanges run there too: their impact guards carry the engine's chatter rule (the
guard's ``accumulation``, :mod:`impactosc.engine._chatter`), so the run jumps at the impact
where the engine's does, and :func:`_replay_rigid` records impacts, chatter, rest on the wall
and release as the engine does. What the hybrid loop does not express stays on the piece loop
of this package (:func:`piece_loop_reason` says which and why, in one place): power-law
flanges (``d^p`` has no Taylor series at the contact's start: the piece stepper's boundary
layer) and harmonics that are not whole multiples of ``Omega`` (the stuck phase below needs a
forcing periodic with ``2 pi / Omega``) stay there.
A stuck phase costs the hybrid loop at most about three forcing periods of steps whatever its
length: the stick modes are *frozen* (every state's rate zero) and the loop jumps over whole
periods (:func:`~impactosc.engine._hybrid.period_jump`); the piece loop solves each release in
closed form instead (:mod:`impactosc.engine._stuck`).
"""

from __future__ import annotations

from functools import lru_cache
from itertools import chain
from typing import NamedTuple

import numpy as np

from ...engine._chatter import ChatterTracker
from ...engine._driver import (
    CONTACT_END,
    CONTACT_START,
    IMPACT,
    KINEMATIC_GUARD_OFFSET,
    RELEASE,
    REVERSAL,
    STICK,
    Mode,
    initial_mode,
    motion_at_rest,
)
from ...engine._hybrid import CROSSING, REST
from ...model._oscillator import Oscillator
from ...model.hybrid import oscillator_system
from ...results._bulk import PIECE_DTYPE, bulk
from ...results._solution import EVENT_DTYPE, SEGMENT_DTYPE, Solution, _Recorder
from .._hybrid_heyoka import DEFAULT_COOLDOWN, compiled, dense_states, run_counted
from ._ode import log_on_stderr

__all__ = ["piece_loop_reason", "run_on_hybrid_loop"]

#: The scale of the replayed system's integrals (``oscillator_system(integral_scale=...)``): a power of
#: two keeps them exact and out of heyoka's error norm, which is relative to the largest state
#: (unscaled, ``Q2 ~ (K d)^2 t`` reached 1e3 by t = 50 on the contact case, and at tol=1e-2 event
#: times moved by 0.16).
INTEGRAL_SCALE = 2.0**-40

_REGIONS = {"free": 0, "upper": 1, "lower": -1, "upper_layer": 1, "lower_layer": -1}
#: The kind of a power-law flange's boundary-layer edge: an internal event of the hybrid run, no event of the
#: built-in Solution (its two pieces are one piece).
LAYER_EDGE = "layer edge"
_MOTIONS = {"0": 0, "+": 1, "-": -1}


def piece_loop_reason(osc: Oscillator, max_wall_time=None) -> str | None:
    """Why ``osc`` runs on the piece loop rather than the one hybrid loop, or None when it does not.

    The one place that decides the dispatch of the heyoka backend: spring flanges
    (``exponent == 1``) and rigid flanges with a forcing periodic in ``2 pi / Omega`` run on the
    hybrid loop; power-law flanges and harmonics that are not whole multiples of ``Omega`` stay
    on the piece loop (the reasons below). ``max_wall_time`` is accepted by both loops.
    """
    levels = [F for F, _, _ in osc.terms] + [osc.beta, osc.beta_s]
    if 0.0 < max(levels) < TINY_FORCES:
        return (f"forcing and friction levels of at most {TINY_FORCES:g}: the hybrid loop decides a state on a "
                "guard with a tolerance absolute at 1e-12 (1 + |y|), which forces this small fall under (a stuck "
                "mass with F = beta = 1e-45 was released and stuck at one instant for ever)")
    return _hybrid_loop_reason(osc)


#: Forcing and friction levels below which a member stays on the piece loop (see piece_loop_reason).
TINY_FORCES = 1e-9


def _hybrid_loop_reason(osc: Oscillator) -> str | None:
    """What keeps ``osc`` off the hybrid loop (power-law flanges, harmonics that are not whole multiples of Omega).

    Rigid flanges run on it: their impact guards carry the engine's chatter rule
    (:class:`~impactosc.model.hybrid._oscillator_system.WallChatter`) and the replay records the
    engine's events and sums (:func:`_replay_rigid`).
    """
    if osc.exponent != 1.0:
        return "a power-law flange: d^p needs the boundary layer of the piece stepper"
    if not _periodic_forcing(osc):
        return ("harmonics that are not whole multiples of Omega: the forcing is not periodic with the system's "
                "period 2 pi / Omega, so a stuck phase cannot be jumped over whole periods (the hybrid loop would "
                "step through it); the piece loop solves each release in closed form")
    return None


def _periodic_forcing(osc: Oscillator) -> bool:
    """Whether every forcing term repeats with ``2 pi / Omega`` (or none depends on the time)."""
    omegas = [Om for F, Om, _ in osc.terms if F != 0.0]
    if all(Om == 0.0 for Om in omegas):
        return True
    if osc.Omega <= 0.0:
        return False
    ratios = [Om / osc.Omega for Om in omegas]
    return all(r >= 0.5 and abs(r - round(r)) <= 4.0 * 2.0**-52 * r for r in ratios)


@lru_cache(maxsize=64)
def _system(osc: Oscillator):
    """``oscillator_system(osc, energy=True)`` and the built-in mode and event kind of each hybrid mode and guard."""
    system = oscillator_system(osc, energy=True, integral_scale=INTEGRAL_SCALE)
    modes = []
    for name in system.mode_names:
        modes.append(Mode(_REGIONS[name[:-1]], _MOTIONS[name[-1]], True))
    # a power-law flange's layer mode ("upper_layer+") is where a run moving into the flange starts: its
    # layer's edge is ahead, or behind when the start is deeper (oscillator_system's _boundary_layers)
    layered = [i for i, name in enumerate(system.mode_names) if "_layer" in name]
    index = {(m.region, m.motion): i for i, m in enumerate(modes) if i not in layered}
    index.update({(modes[i].region, modes[i].motion): i for i in layered})
    # guard -> (kind, side) by name: "enter upper", "leave lower", "free+ stop", "upper release-", "impact upper",
    # "upper layer in"
    guards: list[tuple[str | None, int]] = []
    for name in system.guard_names:
        if name.endswith(" layer in"):
            guards.append((LAYER_EDGE, _REGIONS[name.split()[0]]))
        elif name.startswith("impact "):
            guards.append((IMPACT, _REGIONS[name[7:]]))
        elif osc.rigid and name.split()[0] in ("upper", "lower"):
            guards.append((CONTACT_END, _REGIONS[name.split()[0]]))  # the release off a rigid wall
        elif name.startswith("enter "):
            guards.append((CONTACT_START, _REGIONS[name[6:]]))
        elif name.startswith("leave "):
            guards.append((CONTACT_END, _REGIONS[name[6:]]))
        elif name.endswith(" stop"):
            guards.append((None, 0))  # stick or reversal: decided by the mode after it
        else:
            guards.append((RELEASE, 0))
    slots = {q: 2 + i for i, q in enumerate(system.integrals)}
    return system, tuple(modes), index, tuple(guards), slots


def run_on_hybrid_loop(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
                       sample_at=(), tol: float, max_wall_time: float | None = None) -> Solution:
    """Run ``osc`` on the one heyoka event loop and replay the run into the built-in :class:`Solution`.

    The arguments are those of :func:`impactosc.backends.heyoka.run` (already checked);
    ``osc`` must be a member that :func:`piece_loop_reason` accepts.
    """
    system, modes, index, guards, slots = _system(osc)
    log_on_stderr(lambda: compiled(system, tol))  # heyoka's warnings on stderr, not in piped output
    v0 = 0.0 if abs(v0) <= KINEMATIC_GUARD_OFFSET else v0  # rest, as the engine's drive takes it
    start = initial_mode(osc, 0.0, x0, v0)
    name = system.mode_names[index[(start.region, start.motion)]]
    # The initial state is not an event (engine.initial_mode): a slip's stop guard does not fire at
    # the start, where the loop would take a speed within its touch tolerance (1e-12) for zero. A
    # slip that starts at rest has a double or triple root of v there (a zero net force that turns,
    # F cos(t + pi) - x = 1 - cos t, stuck and released at t = 0 for ever); one that starts at
    # v0 = 1e-300 against a force stops a step later, recorded at its time as the engine does.
    quiet = f"{name} stop" if start.motion != 0 else None
    hybrid, steps = run_counted(system, t_end, [x0, v0], mode=name, max_events=max_events, tol=tol,
                                max_wall_time=max_wall_time, quiet_at_start=quiet)
    rec = _Recorder(record, "heyoka", _Evaluator(osc, tol))
    _replay(osc, hybrid, rec, modes, guards, slots, start, max_events, t_end)
    rec.steps += steps  # the loop's integrator steps (the replay's pieces carry none)
    if hybrid.status == 1 and "max_wall_time" in hybrid.message:
        rec.message = (f"The wall-time limit max_wall_time={max_wall_time!r} s was reached; "
                       "results up to t_final are kept.")
    if len(sample_at):
        _samples(hybrid, rec, modes, sample_at)
    return Solution(rec, t_end)


def _replay(osc, hybrid, rec: _Recorder, modes, guards, slots, start: Mode, max_events: int, t_end: float) -> None:
    """Feed ``rec`` with the pieces and events of ``hybrid`` as the engine's ``drive`` would, in one bulk call.

    The run's crossings become arrays (pieces between them, events, piece starts) and
    :func:`~impactosc.results._bulk.bulk` takes them at once: the same records and sums as the calls one
    by one (:func:`_replay_each`); a rigid flange's impacts and chatter go one by one (:func:`_replay_rigid`).
    """
    if osc.rigid:
        _replay_rigid(osc, hybrid, rec, modes, guards, slots, start, max_events)
        return
    y0 = hybrid._pieces[0][2]
    events = recorded_crossings(hybrid._raw_events, guards)
    rec.begin(osc, 0.0, y0[0], y0[1], start)
    table = _kinds(modes, guards)
    t, guard, target, states_before, states_after = _crossings(events, guards, table.kind, len(y0))
    n = len(t)
    region = np.concatenate(([start.region], table.region[target]))  # the mode of piece k, after event k - 1
    motion = np.concatenate(([start.motion], table.motion[target]))
    side = table.side[guard]
    kind = np.where(table.kind[guard] >= 0, table.kind[guard], np.where(motion[1:] == 0, _STICK, _REVERSAL))
    walls = np.array([0.0, osc.gap_upper, -osc.gap_lower])
    # a flange crossing is recorded on the flange's surface, as the engine snaps it (the hybrid
    # run keeps the located state, within rounding of it, so that its Jacobians stay those of the flow)
    x = np.where(side != 0, walls[side], states_after[:, 0])
    v = states_after[:, 1]
    # piece k runs from event k - 1 (or the start) to event k (or the end): recorded when it has a length
    t_start = np.concatenate(([0.0], t))
    x_start = np.concatenate(([float(y0[0])], x))
    t_final = hybrid.t_final
    y1 = hybrid.state_final
    t_stop = np.concatenate((t, [t_final]))
    x_stop = np.concatenate((states_before[:, 0], [float(y1[0])]))
    # the integrals' increments over each piece: at its end (before the event) less at its start
    increments = np.empty((n + 1, len(y0)))
    increments[:n] = states_before
    increments[n] = y1[:len(y0)]
    increments[0] -= y0
    increments[1:] -= states_after
    increments[:, 2:] /= INTEGRAL_SCALE  # the integrals (after x, v), integrated scaled
    if "Q" in slots:  # a flange's impulse int K d is >= 0: a touch (d ~ 0 throughout) may integrate d's rounding
        np.maximum(increments[:, slots["Q"]], 0.0, out=increments[:, slots["Q"]])
    kept = t_stop > t_start
    kept[n] = kept[n] or n == 0
    count = int(kept.sum())
    sel = slice(None) if count == n + 1 else kept  # the common case, no two events at an instant: views
    pieces = np.zeros(count, dtype=PIECE_DTYPE)
    pieces["t0"], pieces["x0"], pieces["t1"], pieces["x1"] = t_start[sel], x_start[sel], t_stop[sel], x_stop[sel]
    pieces["region"], pieces["motion"] = region[sel], motion[sel]
    for name in ("q", "q2", "w", "vv"):
        c = slots.get(name.upper(), -1)
        if c >= 0:
            pieces[name] = increments[sel, c]
    counted = np.cumsum(kept)  # pieces recorded up to and including piece k
    recorded = np.zeros(n, dtype=EVENT_DTYPE)
    recorded["t"], recorded["kind"], recorded["x"], recorded["v"] = t, _KIND_NAMES[kind], x, v
    recorded["side"], recorded["count"], recorded["direction"] = side, 1, motion[1:]
    event_pieces = counted[:n]
    # a piece start after the last event at an instant (the engine records none between two)
    last = np.ones(n, dtype=bool)
    last[:-1] = t[1:] != t[:-1]
    starts = int(last.sum())
    at = slice(None) if starts == n else last
    segments = np.zeros(starts, dtype=SEGMENT_DTYPE)
    segments["t"], segments["x"], segments["v"] = t[at], x[at], v[at]
    segments["region"], segments["motion"] = region[1:][at], motion[1:][at]
    segments["armed"] = table.armed[target[at]]
    bulk(rec, pieces, recorded, event_pieces, segments, event_pieces[at])
    mode = modes[int(target[-1])] if n else start
    _finish(hybrid, rec, mode, max_events)


def recorded_crossings(raw_events, guards) -> list:
    """The crossings of a hybrid run that the built-in :class:`Solution` records: all but a power-law
    flange's layer edges (``LAYER_EDGE``), which split a contact's piece without an event.

    The integrals are continuous there (no reset), and each piece's increments are differences
    of the run's integrals between recorded events, so they add up over the layer's sub-pieces.
    """
    return [e for e in raw_events if e[2] == CROSSING and guards[e[1]][0] != LAYER_EDGE]


def _crossings(events: list, guards, kinds: np.ndarray, width: int) -> tuple:
    """The crossing records of a hybrid run as arrays (times, guards, modes after, states before and after),
    each touch of a flange as the reversal it is (:func:`_crossings_without_touches`).

    ``kinds``: each guard's code in ``_KIND_NAMES`` (``_KindTable.kind``). The touches are looked for
    on the arrays (a flange entered, stopped in and left at one instant); a run that has one (rare)
    is merged by :func:`_crossings_without_touches` and read again.
    """
    n = len(events)
    if not n:
        return np.zeros(0), np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros((0, width)), np.zeros((0, width))
    t, guard, _, _, target, before, after = zip(*events, strict=True)
    times, which = np.fromiter(t, float, n), np.fromiter(guard, int, n)
    if n >= 3:
        code, at = kinds[which], times[1:-1]
        touch = (code[:-2] == _START) & (code[1:-1] < 0) & (code[2:] == _END) & (times[:-2] == at) & (at == times[2:])
        if touch.any():
            merged = _crossings_without_touches(events, guards)
            n = len(merged)
            t, guard, _, _, target, before, after = zip(*merged, strict=True)
            times, which = np.fromiter(t, float, n), np.fromiter(guard, int, n)
    # flat first: numpy parses a sequence of tuples into a matrix several times slower
    return (times, which, np.fromiter(target, int, n),
            np.fromiter(chain.from_iterable(before), float, n * width).reshape(n, width),
            np.fromiter(chain.from_iterable(after), float, n * width).reshape(n, width))


def _finish(hybrid, rec: _Recorder, mode: Mode, max_events: int) -> None:
    """The end of the replay: the final state and the built-in status and message."""
    t_final = hybrid.t_final
    y1 = hybrid.state_final
    status, message = hybrid.status, hybrid.message
    if status == 0:
        message = "The end time was reached."
    elif status == 1:
        message = (f"The event limit max_events={max_events} was reached at t={t_final!r}; "
                   "results up to that time are kept.")
    else:
        status, message = -1, f"the heyoka backend failed after t={t_final!r}: {message}"
    rec.finish(t_final, float(y1[0]), float(y1[1]), mode, status, message)


_SIDES = {1: "upper", -1: "lower"}
_KIND_NAMES = np.array([CONTACT_START, CONTACT_END, RELEASE, STICK, REVERSAL])
_START, _END, _RELEASE, _STICK, _REVERSAL = range(len(_KIND_NAMES))


class _KindTable(NamedTuple):
    """The built-in kind and side of each hybrid guard and the region and motion of each hybrid mode, as arrays."""

    kind: np.ndarray  # index into _KIND_NAMES, -1: stick or reversal, decided by the mode after it; -2: a layer edge
    side: np.ndarray
    region: np.ndarray
    motion: np.ndarray
    armed: np.ndarray


@lru_cache(maxsize=64)
def _kinds(modes: tuple, guards: tuple) -> _KindTable:
    codes = {CONTACT_START: _START, CONTACT_END: _END, RELEASE: _RELEASE, None: -1, LAYER_EDGE: -2}
    return _KindTable(np.array([codes[k] for k, _ in guards]), np.array([s for _, s in guards]),
                      np.array([m.region for m in modes]), np.array([m.motion for m in modes]),
                      np.array([m.armed for m in modes]))


def _replay_each(osc, hybrid, rec: _Recorder, modes, guards, slots, start: Mode, max_events: int,
                 t_end: float) -> None:
    """Feed ``rec`` with the pieces and events of ``hybrid`` one call at a time, as the engine's ``drive`` does."""
    if osc.rigid:
        _replay_rigid(osc, hybrid, rec, modes, guards, slots, start, max_events)
        return
    events = _crossings_without_touches(hybrid._raw_events, guards)
    n = len(events)
    y0 = hybrid._pieces[0][2]
    rec.begin(osc, 0.0, y0[0], y0[1], start)
    incr = _piece_increments(hybrid, events, slots)
    # a flange's impulse int K d is >= 0: a touch (d ~ 0 throughout) may integrate d's rounding
    np.maximum(incr[:, 0], 0.0, out=incr[:, 0])
    increments = incr.tolist()
    walls = {1: osc.gap_upper, -1: -osc.gap_lower}
    t_prev, x_prev, mode = 0.0, float(y0[0]), start
    for k in range(n):
        t, g, _, _, b, before, state = events[k]
        if t > t_prev:  # not a second event at one instant (the engine records no piece between them)
            dq, dq2, dw, dvv = increments[k]
            rec.piece(mode, t_prev, x_prev, t, before[0], dq, dq2, dw, dvv, 0)
        kind, side = guards[g]
        mode = modes[b]
        if kind is None:
            kind = STICK if mode.motion == 0 else REVERSAL
        # a flange crossing is recorded on the flange's surface, as the engine snaps it (the hybrid
        # run keeps the located state, within rounding of it, so that its Jacobians stay those of the flow)
        x = walls[side] if side else state[0]
        rec.event(t, kind, x, state[1], side, 1, mode.motion)
        if k + 1 == n or events[k + 1][0] != t:
            rec.segment(t, x, state[1], mode)
        t_prev, x_prev = t, x
    t_final = hybrid.t_final
    y1 = hybrid.state_final
    dq, dq2, dw, dvv = increments[n]
    if t_final > t_prev or n == 0:
        rec.piece(mode, t_prev, x_prev, t_final, float(y1[0]), dq, dq2, dw, dvv, 0)
    _finish(hybrid, rec, mode, max_events)


def _piece_increments(hybrid, events, slots) -> np.ndarray:
    """The increments of ``Q, Q2, W, VV`` (0 where the run has no such integral) over each piece of ``hybrid``:
    from the start or an event of ``events`` (the state after it) to the next event or the end (before it)."""
    y0 = hybrid._pieces[0][2]
    n = len(events)
    ends = np.empty((n + 1, len(y0)))
    after = np.empty((n + 1, len(y0)))
    if n:
        ends[:n] = [e[5] for e in events]
        after[1:] = [e[6] for e in events]
    ends[n] = hybrid.state_final
    after[0] = y0
    incr = np.zeros((n + 1, 4))
    for k, q in enumerate(("Q", "Q2", "W", "VV")):
        c = slots.get(q, -1)
        if c >= 0:
            incr[:, k] = ends[:, c] - after[:, c]
    return incr / INTEGRAL_SCALE


def _replay_rigid(osc, hybrid, rec: _Recorder, modes, guards, slots, start: Mode, max_events: int) -> None:
    """:func:`_replay_each` of a member with rigid flanges: impacts, chatter, rest on the wall and release from it.

    The records of the engine's ``drive``: an ``impact`` at each crossing of a flange's impact guard
    (its incoming velocity; ``contact_start`` after it where no speed is left and the mass rests on
    the wall), a ``contact_start`` where a slip ends on the wall, a ``contact_end`` at the release
    from it, and, where the impact guard's accumulation rule jumped (a ``rest`` event of the run),
    the engine's chatter: its jump from the same impact (the engine's :class:`ChatterTracker`, which
    also counts the impacts followed one by one), its tail's impulse, slip path and impact losses
    (``rec.chatter``), then the rest on the wall. A run that ends inside a tail ends with the local
    model's state there, as the engine's does. The wall's push on a resting mass is the recorder's
    (``wall_force_integrals``), the impacts' impulses and losses come from their velocities.
    """
    events = [e for e in hybrid._raw_events if e[2] == CROSSING or e[2] == REST]
    y0 = hybrid._pieces[0][2]
    rec.begin(osc, 0.0, y0[0], y0[1], start)
    increments = _piece_increments(hybrid, events, slots).tolist()
    walls = {1: osc.gap_upper, -1: -osc.gap_lower}
    tracker = ChatterTracker(osc)
    jump = None  # the engine's jump after the last impact, where it takes one
    t_prev, x_prev, mode = 0.0, float(y0[0]), start
    for k, (t, g, kind, _, b, before, state) in enumerate(events):
        new = modes[b]
        if kind == REST:
            if jump is None:
                # the loop's own watch (events at one instant, a tie the engine's stick test resolves by the
                # forcing's trend): not the engine's answer, so not a result; what came before is kept
                rec.finish(t, before[0], before[1], mode, -1,
                           f"the heyoka backend failed after t={t!r}: events accumulated at one instant there, where "
                           "the engine takes no chatter jump (a degenerate tie of the net force with static "
                           "friction); backend='exact' resolves it")
                return
            if t < jump.t_inf:  # the run ends inside the tail: the local model's state at its end
                x1, v1, motion = rec.chatter(jump, t)
                rec.finish(t, x1, v1, Mode(0, motion, True), 0,
                           f"The end time was reached inside a chatter on the {_SIDES[jump.side]} flange (its "
                           f"impacts accumulate at t={jump.t_inf!r}, after the end).")
                return
            rec.chatter(jump, jump.t_inf)
            x = jump.wall
            rec.event(t, CONTACT_START, x, 0.0, jump.side, 1, 0)
            tracker.interrupt()
            jump = None
            rec.segment(t, x, 0.0, new)
            t_prev, x_prev, mode = t, x, new
            continue
        if t > t_prev:  # not a second event at one instant (the engine records no piece between them)
            dq, dq2, dw, dvv = increments[k]
            rec.piece(mode, t_prev, x_prev, t, before[0], dq, dq2, dw, dvv, 0)
        what, side = guards[g]
        x, v = (walls[side] if side else state[0]), state[1]
        jump = None  # the engine takes a jump right after the impact it comes from, or never
        if what == IMPACT and side * before[1] <= 0.0:  # a touch at a turning point: no impact (the engine's rule)
            v = 0.0
            if new.region:
                rec.event(t, CONTACT_START, x, v, side, 1, 0)
                tracker.interrupt()
            else:
                rec.event(t, REVERSAL, x, v, 0, 1, new.motion)
        elif what == IMPACT:
            away = side * v < -KINEMATIC_GUARD_OFFSET
            rec.event(t, IMPACT, x, before[1], side, 1, -side if away else 0)
            jump = tracker.impact(t, side, abs(before[1]))
            if new.region:  # no speed left: at rest against the wall
                v, jump = 0.0, None
                rec.event(t, CONTACT_START, x, v, side, 1, 0)
                tracker.interrupt()
        elif what is None and new.region:  # a slip that ends on the wall (a touch): at rest against it
            side, v = new.region, 0.0
            # the engine's slip end there first (its stick test: a stick, a reversal, or a pause without an
            # event), then the wall it lies on takes the mass
            motion, _ = motion_at_rest(osc, t, state[0])
            if motion != mode.motion:
                rec.event(t, STICK if motion == 0 else REVERSAL, state[0], v, 0, 1, motion)
            x = walls[side]
            rec.event(t, CONTACT_START, x, v, side, 1, 0)
            tracker.interrupt()
        else:
            if what is None:
                what = STICK if new.motion == 0 else REVERSAL
            rec.event(t, what, x, v, side, 1, new.motion)
            if what != REVERSAL:
                tracker.interrupt()
        mode = new
        if k + 1 == len(events) or events[k + 1][0] != t or events[k + 1][2] == REST:
            rec.segment(t, x, v, mode)
        t_prev, x_prev = t, x
    t_final = hybrid.t_final
    y1 = hybrid.state_final
    dq, dq2, dw, dvv = increments[len(events)]
    if t_final > t_prev or not events:
        rec.piece(mode, t_prev, x_prev, t_final, float(y1[0]), dq, dq2, dw, dvv, 0)
    _finish(hybrid, rec, mode, max_events)


def _tail_states(osc, hybrid, times):
    """The engine's local-model states ``(x, v, motion)`` at those of ``times`` inside a chatter's tail, by index.

    The tail runs from the impact where the engine's chatter model jumps to the accumulation
    time (a ``rest`` event of the hybrid run): the run's dense output there is the last flight,
    which would go through the wall.
    """
    found: dict[int, tuple] = {}
    raw = [e for e in hybrid._raw_events if e[2] == CROSSING or e[2] == REST]
    for i, (t_rest, g, kind, *_) in enumerate(raw):
        if kind != REST or i == 0:
            continue
        t_imp, _, _, _, _, before, _ = raw[i - 1]
        side = 1 if "upper" in hybrid.system.guard_names[g] else -1
        jump = ChatterTracker(osc).impact(t_imp, side, abs(before[1]))
        if jump is None:
            continue
        for j, t in enumerate(times):
            if t_imp < t < min(jump.t_inf, t_rest) or (t_imp < t == t_rest < jump.t_inf):
                found[j] = jump.state_at(t)[:3]
    return found


def _crossings_without_touches(raw_events, guards) -> list:
    """The crossings of a hybrid run, each touch of a flange as the reversal it is.

    A touch (``|X|`` reaches the flange with ``V = 0``, a double root of the contact guard) can
    be located as a flange entered, the stop in it and the flange left, all at one instant:
    a contact of zero length. The engine records a reversal alone; so does the replay: one
    crossing of the stop guard from the mode before the entry to the mode after the exit.
    """
    out = [e for e in raw_events if e[2] == CROSSING]
    kept: list = []
    i, n = 0, len(out)
    while i < n:
        if (i + 2 < n and out[i][0] == out[i + 1][0] == out[i + 2][0] and guards[out[i][1]][0] == CONTACT_START
                and guards[out[i + 1][1]][0] is None and guards[out[i + 2][1]][0] == CONTACT_END):
            enter, stop, leave = out[i:i + 3]
            kept.append((stop[0], stop[1], CROSSING, enter[3], leave[4], enter[5], leave[6]))
            i += 3
        else:
            kept.append(out[i])
            i += 1
    return kept


def _samples(hybrid, rec: _Recorder, modes, sample_at) -> None:
    """The states at the sample times up to where the run got (dense output of its pieces)."""
    times = np.asarray([t for t in sample_at if t <= hybrid.t_final], dtype=float)
    if not times.size:
        return
    states = hybrid.sample(times)
    starts = np.array([p[0] for p in hybrid._pieces])
    which = np.searchsorted(starts, times, side="right") - 1
    tails = _tail_states(rec.osc, hybrid, times.tolist()) if rec.osc.rigid else {}  # inside a chatter's tail
    for j, (t, y, k) in enumerate(zip(times.tolist(), states[:, :2].tolist(), which.tolist(), strict=True)):
        if j in tails:
            x, v, motion = tails[j]
            rec.sample(t, x, v, Mode(0, motion, True))
            continue
        rec.sample(t, y[0], y[1], modes[hybrid._pieces[k][1]])


class _Evaluator:
    """Dense output of the built-in :class:`Solution` from the hybrid system's integrator (picklable)."""

    def __init__(self, osc: Oscillator, tol: float):
        self.osc = osc
        self.tol = tol

    def __call__(self, mode: Mode, t0: float, x: float, v: float, times: np.ndarray):
        system, _, index, _, slots = _system(self.osc)
        state = [x, v] + [0.0] * len(system.integrals)
        times = np.asarray(times, dtype=float)
        m = index[(mode.region, mode.motion)]
        if self.osc.linear or self.osc.rigid or mode.region == 0:
            out = dense_states(system, self.tol, DEFAULT_COOLDOWN, m, t0, state, times)
        else:
            out = _through_layer(system, self.tol, m, t0, state, times)
        q = out[:, slots["Q"]] / INTEGRAL_SCALE if "Q" in slots else np.zeros(times.shape)
        return out[:, 0].copy(), out[:, 1].copy(), np.asarray(q, dtype=float).copy()


def _through_layer(system, tol: float, mode: int, t0: float, state: list, times: np.ndarray) -> np.ndarray:
    """The states (then integrals) at ``times`` of a piece inside a power-law flange, from ``(t0, state)`` in ``mode``.

    Integrated with the events on (the hybrid loop, to the last time): the spring comes on at the
    layer's edge only where a step ends there (``oscillator_system``'s ``_power_law``), which dense
    output with the events off would step over. The times lie in one piece of the built-in
    :class:`Solution` (between two of its events), so only the layer's edge may fire before the last.
    """
    out = np.empty((times.size, len(state)))
    later = times > t0
    out[~later] = state
    if later.any():
        name = system.mode_names[mode]
        quiet = f"{name} stop" if name[-1] != "0" else None  # the piece starts where a slip starts (run_on_hybrid_loop)
        hybrid, _ = run_counted(system, float(times[later].max()), state[:2], mode=name, t0=t0, tol=tol,
                                quiet_at_start=quiet)
        if hybrid.status not in (0, 1):
            raise FloatingPointError(f"heyoka could not re-integrate the piece starting at t={t0!r}: {hybrid.message}")
        out[later] = hybrid.sample(np.minimum(times[later], hybrid.t_final))
    return out
