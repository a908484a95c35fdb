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
and release as the engine does. This is the heyoka backend's only loop: every member runs here.
A stuck phase costs the hybrid loop at most about three forcing periods of steps whatever its
length when the forcing is periodic with ``2 pi / Omega``: the stick modes are *frozen* (every
state's rate zero) and the loop jumps over whole periods
(:func:`~impactosc.engine._hybrid.period_jump`). Harmonics that are not whole multiples of
``Omega`` have no such period: the loop steps through the stuck phase, at a cost in proportion
to its length.
"""

from __future__ import annotations

import math
import threading
from functools import lru_cache
from itertools import chain
from typing import NamedTuple

import numpy as np

from ...engine._chatter import ChatterTracker
from ...engine._driver import (
    AT_WALL,
    CHATTER,
    CONTACT_END,
    CONTACT_START,
    ENTER_LOWER,
    ENTER_UPPER,
    IMPACT,
    KINEMATIC_GUARD_OFFSET,
    LEAVE,
    NO_GUARD,
    RELEASE,
    RELEASE_DOWN,
    RELEASE_UP,
    REVERSAL,
    SLIP_END,
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
from .._hybrid_heyoka import DEFAULT_COOLDOWN, dense_states, run_counted

__all__ = ["run_on_hybrid_loop", "drive_on_hybrid_loop"]

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


@lru_cache(maxsize=64)
def _engine_guards(guard_names: tuple[str, ...]) -> tuple[int, ...]:
    """The engine's guard index of each hybrid guard (``NO_GUARD``: none), for a recorder's ``on_transition``.

    The table beside ``_system``'s kinds: the hybrid guards of
    :func:`~impactosc.model.hybrid.oscillator_system` by name, onto the guards of the engine's
    transition rule (:data:`~impactosc.engine.GUARD_NAMES`) that the saltation matrices read
    (``dynamics.saltation``: the guard's normal and time rate). A flange's entry and a rigid
    flange's impact are ``ENTER_UPPER``/``ENTER_LOWER``, its exit ``LEAVE``, a slip's stop
    ``SLIP_END``, a release (from a stick, or from rest on a rigid wall) ``RELEASE_UP`` or
    ``RELEASE_DOWN`` by the direction of the force it follows. A guard of none of these forms
    (an internal one, with no counterpart in the engine) gives ``NO_GUARD``: the replay tells the
    recorder of no transition there.
    """
    sides = {"upper": (ENTER_UPPER, LEAVE), "lower": (ENTER_LOWER, LEAVE)}
    table = []
    for name in guard_names:
        words = name.split()
        if len(words) == 2 and words[0] in ("enter", "impact") and words[1] in sides:
            table.append(sides[words[1]][0])
        elif len(words) == 2 and words[0] == "leave" and words[1] in sides:
            table.append(LEAVE)
        elif words[-1] == "stop":
            table.append(SLIP_END)
        elif words[-1] == "release+":
            table.append(RELEASE_UP)
        elif words[-1] == "release-":
            table.append(RELEASE_DOWN)
        else:
            table.append(NO_GUARD)
    return tuple(table)


#: The systems of the members run so far, one per structure (:func:`_member_system`), with the lock that
#: guards the dict (threads of a sweep).
_STRUCTURES: dict = {}
_STRUCTURES_LOCK = threading.Lock()
_MAX_STRUCTURES = 64


def _member_system(osc: Oscillator):
    """``_system(osc)``, built once per structure of member and given ``osc``'s values as runtime parameters.

    A continuation or a sweep runs a new member at every point: building its
    :func:`~impactosc.model.hybrid.oscillator_system` (expressions, checks) took 2 ms, twice
    the map evaluation it served. Members that differ only in the values that system keeps
    as parameters (``F, Omega, phase, beta, beta_s, K, zeta, e, gap_upper, gap_lower`` and the
    harmonics' ``F2, Omega2, phase2, ...``: the oscillator's own names, as ``oscillator_system``
    says) share one system, copied with their values (:meth:`HybridSystem.with_parameters`).
    The key is conservative (whatever decides a branch of ``oscillator_system``, and more:
    flange law and exponent, the number of forcing terms and which are static or zero, damping,
    friction, which flanges exist); a system whose parameters are not all among those names is
    built for its member as before.
    """
    key = (osc.flange, osc.exponent, tuple((F == 0.0, Om == 0.0) for F, Om, _ in osc.terms), osc.zeta == 0.0,
           osc.beta == 0.0, osc.beta_s == osc.beta, math.isinf(osc.gap_upper), math.isinf(osc.gap_lower),
           osc.K == 0.0, osc.restitution == 0.0)
    with _STRUCTURES_LOCK:
        built = _STRUCTURES.get(key)
    if built is None:
        built = _system(osc)
        with _STRUCTURES_LOCK:
            if len(_STRUCTURES) >= _MAX_STRUCTURES:  # e.g. a sweep of the exponent: the oldest goes
                del _STRUCTURES[next(iter(_STRUCTURES))]
            _STRUCTURES.setdefault(key, built)
    values = {"beta": osc.beta, "beta_s": osc.beta_s, "K": osc.K, "zeta": osc.zeta, "e": osc.restitution,
              "gap_upper": osc.gap_upper, "gap_lower": osc.gap_lower}
    for i, (F, Om, ph) in enumerate(osc.terms):
        tag = "" if i == 0 else str(i + 1)
        values[f"F{tag}"], values[f"Omega{tag}"], values[f"phase{tag}"] = F, Om, ph
    system, *tables = built
    names = system.parameter_names
    if not all(name in values for name in names):
        return _system(osc)
    return (system.with_parameters(**{name: values[name] for name in names}), *tables)


def _run(osc: Oscillator, t_end: float, x0: float, v0: float, max_events: int, tol: float,
         max_wall_time: float | None):
    """``(hybrid, steps, start)``: ``osc`` run on the one heyoka loop from the engine's initial mode."""
    system, _, index, _, _ = _member_system(osc)
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
    return hybrid, steps, start


def _wall_time_message(hybrid, rec: _Recorder, max_wall_time: float | None) -> None:
    if hybrid.status == 1 and "max_wall_time" in hybrid.message:
        rec.message = (f"The wall-time limit max_wall_time={max_wall_time!r} s was reached; "
                       "results up to t_final are kept.")


def run_on_hybrid_loop(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
                       sample_at=(), tol: float, max_wall_time: float | None = None) -> Solution:
    """Run ``osc`` on the one heyoka event loop and replay the run into the built-in :class:`Solution`.

    The arguments are those of :func:`impactosc.backends.heyoka.run` (already checked);
    ``osc`` must be a member that :func:`~impactosc.model.hybrid.oscillator_system` writes.
    """
    _, modes, _, guards, slots = _member_system(osc)
    hybrid, steps, start = _run(osc, t_end, x0, v0, max_events, tol, max_wall_time)
    rec = _Recorder(record, "heyoka", _Evaluator(osc, tol))
    _replay(osc, hybrid, rec, modes, guards, slots, start, max_events, t_end)
    rec.steps += steps  # the loop's integrator steps (the replay's pieces carry none)
    _wall_time_message(hybrid, rec, max_wall_time)
    if len(sample_at):
        _samples(hybrid, rec, modes, sample_at)
    return Solution(rec, t_end)


def drive_on_hybrid_loop(osc: Oscillator, t_end: float, x0: float, v0: float, rec, *, max_events: int,
                         sample_at=(), tol: float, max_wall_time: float | None = None) -> None:
    """Run ``osc`` on the one heyoka event loop and feed ``rec`` every call the engine's ``drive`` would make.

    The heyoka counterpart of :func:`impactosc.engine.drive` for any engine recorder (a
    :class:`~impactosc.results._solution._Recorder`, or one of the dynamics toolkit's: the
    tangent dynamics' Jacobian, the continuation's parameter sensitivities, the contact onset's
    watch): ``begin``; the smooth pieces, events and piece starts (``piece``, ``event``,
    ``segment``) one call at a time, with ``on_transition(t, mode_before, guard, mode_after,
    x_before, v_before, x_after, v_after, kind)`` before each event where the recorder has that
    method (``guard`` the engine's index of the hybrid guard, :func:`_engine_guards`); a rigid
    flange's ``chatter`` with the engine's two transitions around it (guard None, then the wall's
    rest test ``AT_WALL``); ``sample`` at each of ``sample_at`` (sorted times in ``[0, t_end]``)
    with the piece cut there as ``drive`` cuts it (``piece`` up to the time, ``segment`` and
    ``sample`` there, the same mode on); ``finish``. The whole run is integrated first, so an
    exception the recorder raises (a watch that stops at a contact) ends the replay, not the run.

    Parameters
    ----------
    osc, t_end, x0, v0, max_events, tol, max_wall_time
        As :func:`run_on_hybrid_loop` (already checked).
    rec
        The recorder.
    sample_at : sequence of float, optional
        The sample stops, sorted (:func:`impactosc.engine.check_sample_times`).
    """
    _, modes, _, guards, slots = _member_system(osc)
    hybrid, steps, start = _run(osc, t_end, x0, v0, max_events, tol, max_wall_time)
    _replay_each(osc, hybrid, rec, modes, guards, slots, start, max_events, t_end, stops=sample_at)
    rec.steps += steps
    _wall_time_message(hybrid, rec, max_wall_time)


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
                 t_end: float, stops=()) -> None:
    """Feed ``rec`` with the pieces and events of ``hybrid`` one call at a time, as the engine's ``drive`` does.

    With the engine's transitions (``rec.on_transition``, where it has it) and the sample
    ``stops`` cut into the pieces (:class:`_Stops`): :func:`drive_on_hybrid_loop`.
    """
    if osc.rigid:
        _replay_rigid(osc, hybrid, rec, modes, guards, slots, start, max_events, stops)
        return
    events = _crossings_without_touches(recorded_crossings(hybrid._raw_events, guards), guards)
    n = len(events)
    y0 = hybrid._pieces[0][2]
    rec.begin(osc, 0.0, y0[0], y0[1], start)
    incr = _piece_increments(hybrid, events, slots)
    # a flange's impulse int K d is >= 0: a touch (d ~ 0 throughout) may integrate d's rounding
    np.maximum(incr[:, 0], 0.0, out=incr[:, 0])
    increments = incr.tolist()
    walls = {1: osc.gap_upper, -1: -osc.gap_lower}
    hook = getattr(rec, "on_transition", None)
    engine = _engine_guards(hybrid.system.guard_names)
    cut = _Stops(hybrid, rec, stops, slots) if len(stops) else None
    t_prev, x_prev, mode = 0.0, float(y0[0]), start
    for k in range(n):
        t, g, _, _, b, before, state = events[k]
        t_prev, x_prev = _piece_to(rec, cut, mode, t_prev, x_prev, t, before, increments[k])
        kind, side = guards[g]
        new = modes[b]
        if kind is None:
            kind = STICK if new.motion == 0 else REVERSAL
        # a flange crossing is recorded on the flange's surface, as the engine snaps it (the hybrid
        # run keeps the located state, within rounding of it, so that its Jacobians stay those of the flow)
        x = walls[side] if side else state[0]
        if hook is not None and engine[g] != NO_GUARD:
            hook(t, mode, engine[g], new, before[0], before[1], x, state[1], kind)
        mode = new
        rec.event(t, kind, x, state[1], side, 1, mode.motion)
        if k + 1 == n or events[k + 1][0] != t:
            rec.segment(t, x, state[1], mode)
        t_prev, x_prev = t, x
        if cut is not None:
            cut.moved(state, x)
    t_final = hybrid.t_final
    y1 = hybrid.state_final
    dq, dq2, dw, dvv = increments[n]
    if cut is not None:
        cut.reached(t_prev, mode)
        t_prev, x_prev = cut.split(mode, t_prev, x_prev, t_final)
        dq, dq2, dw, dvv = cut.increments(y1, increments[n])
    if t_final > t_prev or n == 0:
        rec.piece(mode, t_prev, x_prev, t_final, float(y1[0]), dq, dq2, dw, dvv, 0)
    if cut is not None and hybrid.status == 0:
        cut.moved(y1, float(y1[0]))
        cut.reached(t_final, mode)  # a sample time at the end itself
    _finish(hybrid, rec, mode, max_events)


class _Stops:
    """The sample stops of the engine's ``drive`` on a replayed run: each cuts the piece it falls in.

    ``drive`` ends a piece at a sample time (``piece`` up to it), starts the next one there in
    the same mode (``segment``) and hands the state to ``sample``; a time that an event or the
    start reaches exactly is sampled with the state after it. The states at the stops come from
    the run's dense output (:meth:`HybridSolution.sample`), the pieces' integrals from the same
    rows. A replay keeps its place here: the state where the current piece starts
    (:meth:`moved`) and the next stop.
    """

    def __init__(self, hybrid, rec, stops, slots):
        t_final = hybrid.t_final
        self.times = [float(t) for t in stops if t <= t_final]
        self.states = hybrid.sample(self.times).tolist() if self.times else []
        self.rec = rec
        self.next = 0
        self.columns = [slots.get(q, -1) for q in ("Q", "Q2", "W", "VV")]
        self.start = list(hybrid._pieces[0][2])  # the state where the current piece starts
        self.v = float(self.start[1])
        self.cut = False  # the current piece has been cut at a stop

    def moved(self, state, x: float) -> None:
        """A piece starts after an event (or the run ends) at ``state``, recorded at position ``x``."""
        self.start = list(state)
        self.start[0] = x
        self.v = float(state[1])
        self.cut = False

    def reached(self, t: float, mode: Mode) -> None:
        """Sample the stops at or before ``t``, where a piece starts: the state there, in ``mode``."""
        while self.next < len(self.times) and self.times[self.next] <= t:
            self.rec.sample(self.times[self.next], self.start[0], self.v, mode)
            self.next += 1

    def split(self, mode: Mode, t0: float, x0: float, t1: float) -> tuple[float, float]:
        """Cut the piece from ``(t0, x0)`` at the stops before ``t1``; the start ``(t, x)`` of what is left."""
        while self.next < len(self.times) and self.times[self.next] < t1:
            ts, y = self.times[self.next], self.states[self.next]
            dq, dq2, dw, dvv = self.increments(y, None)
            self.rec.piece(mode, t0, x0, ts, y[0], dq, dq2, dw, dvv, 0)
            self.rec.segment(ts, y[0], y[1], mode)
            self.start, self.v, self.cut = list(y), y[1], True
            self.rec.sample(ts, y[0], y[1], mode)
            self.next += 1
            t0, x0 = ts, y[0]
        return t0, x0

    def increments(self, end, whole):
        """The integrals' increments from the current piece's start to ``end``: ``whole`` where it was not cut."""
        if not self.cut and whole is not None:
            return whole
        out = [(end[c] - self.start[c]) / INTEGRAL_SCALE if c >= 0 else 0.0 for c in self.columns]
        out[0] = max(out[0], 0.0)  # a flange's impulse int K d is >= 0 (as the whole pieces' are)
        return out

    def tail(self, jump, t: float) -> None:
        """The stops inside a chatter's tail, up to ``t``: the engine's local-model state there."""
        while (self.next < len(self.times) and self.times[self.next] < jump.t_inf
               and self.times[self.next] <= t):
            ts = self.times[self.next]
            x, v, motion = jump.state_at(ts)[:3]
            self.rec.sample(ts, x, v, Mode(0, motion, True))
            self.next += 1


def _piece_to(rec: _Recorder, cut, mode: Mode, t_prev: float, x_prev: float, t: float, before, increment):
    """Record the piece of ``mode`` from ``(t_prev, x_prev)`` up to the event at ``t`` (state ``before``), as
    ``drive`` does: cut at the sample stops in it (``cut``, a :class:`_Stops` or None), none between two
    events at one instant. Returns where the recorded pieces got to, ``(t_prev, x_prev)``."""
    if cut is not None:
        cut.reached(t_prev, mode)
        t_prev, x_prev = cut.split(mode, t_prev, x_prev, t)
    if t > t_prev:  # not a second event at one instant (the engine records no piece between them)
        dq, dq2, dw, dvv = increment if cut is None else cut.increments(before, increment)
        rec.piece(mode, t_prev, x_prev, t, before[0], dq, dq2, dw, dvv, 0)
    return t_prev, x_prev


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


def _replay_rigid(osc, hybrid, rec: _Recorder, modes, guards, slots, start: Mode, max_events: int,
                  stops=()) -> None:
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
    ``rec.on_transition`` (where the recorder has it) is told of each of the engine's transitions
    in the same order, and the sample ``stops`` cut the pieces (:class:`_Stops`; inside a tail the
    local model's state), as in :func:`_replay_each`.
    """
    events = [e for e in hybrid._raw_events if e[2] == CROSSING or e[2] == REST]
    y0 = hybrid._pieces[0][2]
    rec.begin(osc, 0.0, y0[0], y0[1], start)
    increments = _piece_increments(hybrid, events, slots).tolist()
    walls = {1: osc.gap_upper, -1: -osc.gap_lower}
    tracker = ChatterTracker(osc)
    hook = getattr(rec, "on_transition", None) or _told_nothing
    engine = _engine_guards(hybrid.system.guard_names)
    cut = _Stops(hybrid, rec, stops, slots) if len(stops) else None
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
            if cut is not None:
                cut.tail(jump, t)
            if t < jump.t_inf:  # the run ends inside the tail: the local model's state at its end
                x1, v1, motion = rec.chatter(jump, t)
                rec.finish(t, x1, v1, Mode(0, motion, True), 0,
                           f"The end time was reached inside a chatter on the {_SIDES[jump.side]} flange (its "
                           f"impacts accumulate at t={jump.t_inf!r}, after the end).")
                return
            rec.chatter(jump, jump.t_inf)
            x = jump.wall
            at_wall = Mode(0, 0, True)
            hook(t, mode, None, at_wall, x, 0.0, x, 0.0, CHATTER)  # the jump: no guard, into rest at the wall
            hook(t, at_wall, AT_WALL, new, x, 0.0, x, 0.0, CONTACT_START)  # the wall's rest test
            rec.event(t, CONTACT_START, x, 0.0, jump.side, 1, 0)
            tracker.interrupt()
            jump = None
            rec.segment(t, x, 0.0, new)
            t_prev, x_prev, mode = t, x, new
            if cut is not None:
                cut.moved(state, x)
                cut.v = 0.0
            continue
        t_prev, x_prev = _piece_to(rec, cut, mode, t_prev, x_prev, t, before, increments[k])
        what, side = guards[g]
        x, v = (walls[side] if side else state[0]), state[1]
        jump = None  # the engine takes a jump right after the impact it comes from, or never
        if what == IMPACT and side * before[1] <= 0.0:  # a touch at a turning point: no impact (the engine's rule)
            v = 0.0
            if new.region:
                hook(t, mode, engine[g], new, before[0], before[1], x, v, CONTACT_START)
                rec.event(t, CONTACT_START, x, v, side, 1, 0)
                tracker.interrupt()
            else:
                hook(t, mode, engine[g], new, before[0], before[1], x, v, REVERSAL)
                rec.event(t, REVERSAL, x, v, 0, 1, new.motion)
        elif what == IMPACT:
            away = side * v < -KINEMATIC_GUARD_OFFSET
            # the engine's impact leaves a mass without speed at the wall (Mode(0, 0)), where its rest test follows
            hook(t, mode, engine[g], new if away else Mode(0, 0, True), before[0], before[1], x,
                 v if away else 0.0, IMPACT)
            rec.event(t, IMPACT, x, before[1], side, 1, -side if away else 0)
            jump = tracker.impact(t, side, abs(before[1]))
            if new.region:  # no speed left: at rest against the wall
                v, jump = 0.0, None
                hook(t, Mode(0, 0, True), AT_WALL, new, x, v, x, v, CONTACT_START)
                rec.event(t, CONTACT_START, x, v, side, 1, 0)
                tracker.interrupt()
        elif what is None and new.region:  # a slip that ends on the wall (a touch): at rest against it
            side, v = new.region, 0.0
            # the engine's slip end there first (its stick test: a stick, a reversal, or a pause without an
            # event), then the wall it lies on takes the mass
            motion, _ = motion_at_rest(osc, t, state[0])
            turn = (STICK if motion == 0 else REVERSAL) if motion != mode.motion else None
            hook(t, mode, SLIP_END, Mode(0, motion, True), before[0], before[1], state[0], v, turn)
            if turn is not None:
                rec.event(t, turn, state[0], v, 0, 1, motion)
            x = walls[side]
            hook(t, Mode(0, motion, True), AT_WALL, new, x, v, x, v, CONTACT_START)
            rec.event(t, CONTACT_START, x, v, side, 1, 0)
            tracker.interrupt()
        else:
            if what is None:
                what = STICK if new.motion == 0 else REVERSAL
            if engine[g] != NO_GUARD:
                hook(t, mode, engine[g], new, before[0], before[1], x, v, what)
            rec.event(t, what, x, v, side, 1, new.motion)
            if what != REVERSAL:
                tracker.interrupt()
        mode = new
        if k + 1 == len(events) or events[k + 1][0] != t or events[k + 1][2] == REST:
            rec.segment(t, x, v, mode)
        t_prev, x_prev = t, x
        if cut is not None:
            cut.moved(state, x)
            cut.v = v
    t_final = hybrid.t_final
    y1 = hybrid.state_final
    dq, dq2, dw, dvv = increments[len(events)]
    if cut is not None:
        cut.reached(t_prev, mode)
        t_prev, x_prev = cut.split(mode, t_prev, x_prev, t_final)
        dq, dq2, dw, dvv = cut.increments(y1, increments[len(events)])
    if t_final > t_prev or not events:
        rec.piece(mode, t_prev, x_prev, t_final, float(y1[0]), dq, dq2, dw, dvv, 0)
    if cut is not None and hybrid.status == 0:
        cut.moved(y1, float(y1[0]))
        cut.reached(t_final, mode)  # a sample time at the end itself
    _finish(hybrid, rec, mode, max_events)


def _told_nothing(*transition) -> None:
    """The ``on_transition`` of a recorder that has none."""


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
        system, _, index, _, slots = _member_system(self.osc)
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
