"""The exact backend's event loop, compiled: :func:`impactosc.engine.drive` without Python per event.

For every linear member (eq. 3, static friction, damping, harmonic sums, rigid flanges
with restitution) every piece is a closed form (:mod:`._piece`, :mod:`._family`), every
release a closed form or a bracketed root (:mod:`impactosc.engine._stuck`), and a chatter a
closed-form jump (:mod:`impactosc.engine._chatter`), so the whole loop runs in numba: the
pieces, the guard search, the transition rule (:mod:`impactosc.model._rule`, the copy every
backend calls), the chatter tracker and the
recording of statistics, events, contacts, segments and samples.

The loop is :func:`impactosc.engine.drive` step for step (same order of rule calls, same
stop conditions and messages); ``tests/test_exact_compiled.py`` checks that the two drivers
give the same solution, field by field. Transition hooks (:mod:`impactosc.dynamics`'
tangent runs) drive the Python loop themselves.
"""

from __future__ import annotations

import math
from typing import Any, cast

import numpy as np

from ..._util.jit import njit
from ...engine._chatter import J_IMPACTS, J_SIDE, J_SIZE, J_T0, J_T_INF, J_WALL, ChatterJump, jump_state, predict_jump
from ...engine._driver import GUARD_NAMES, MAX_EVENTS_AT_ONE_INSTANT, Mode
from ...engine._stuck import release_one_harmonic, release_sum
from ...model import _rule
from ...model._oscillator import Oscillator
from ...model._rule import (
    AT_WALL,
    CHATTER,
    CONTACT_END,
    CONTACT_START,
    EVENT_KINDS,
    IMPACT,
    KINEMATIC_GUARD_OFFSET,
    NO_GUARD,
    NO_KIND,
    P_BETA,
    P_BETA_S,
    P_K,
    P_RESTITUTION,
    P_RIGID,
    P_TERMS,
    P_ZETA,
    RELEASE_DOWN,
    RELEASE_UP,
    REVERSAL,
    forcing,
)
from ...model._wall import wall_force_integrals
from ...results._observables import impact_force_law
from ...results._solution import (
    CONTACT_SUMS,
    EVENT_DTYPE,
    IMPACT_DTYPE,
    SAMPLE_DTYPE,
    SEGMENT_DTYPE,
    Solution,
    _Recorder,
)
from ._family import advance_family
from ._family import mode_constants as family_constants
from ._piece import M_SIZE, SEARCH_FAILED, advance_slip, mode_constants

__all__ = ["run"]

# Accumulators (float): impulse, impulse^2, contact time and peak penetration per flange
# (upper, lower), forcing work, slip path, int V^2, impact losses; then the sums over the
# contacts of the upper flange, then of the lower one (results._solution.CONTACT_SUMS, named
# here in this file's own order: numba freezes these constants into its cache of this file).
(A_IMP_UP, A_IMP_LO, A_SQ_UP, A_SQ_LO, A_CT_UP, A_CT_LO, A_PEN_UP, A_PEN_LO, A_WORK, A_SLIP, A_VSQ, A_LOSS) = range(12)
A_SUMS = 12
SUMS = ("contacts", "entry_speed", "entry_speed_sq", "peak_force", "impulse", "impact_force", "dissipated")
S_CONTACTS, S_SPEED, S_SPEED_SQ, S_PEAK, S_IMPULSE, S_IMPACT_FORCE, S_DISSIPATED = range(7)
N_SUMS = 7
N_ACC = A_SUMS + 2 * N_SUMS
# Counters (int): events by kind (0..6), then entries per flange, events, pieces, steps.
C_ENTRIES_UP, C_ENTRIES_LO, C_EVENTS, C_PIECES, C_STEPS = range(7, 12)
# The open contact: start, side, entry velocity, peak penetration, impulse, complete, and its
# slip path and int V^2 (its friction and damping losses).
O_START, O_SIDE, O_VIN, O_PEN, O_IMP, O_COMPLETE, O_PATH, O_VSQ = range(8)
# A row of the contacts table: the impact table's fields (IMPACT_DTYPE), then the energy dissipated.
N_CONTACT_COLUMNS = 10
# How the loop ended (the messages are the engine's, written in Python from these codes).
DONE, EVENT_LIMIT, FAILED, NON_FINITE, MISSED, SAME_INSTANT, CHATTER_END = range(7)
# The loop's steps: settle the start; a piece and its transitions; the rest after a chatter.
START, PIECE, JUMP = range(3)


@njit
def _append(table, n, row):
    """Write ``row`` at ``n`` in ``table``, doubling it when full; returns the table."""
    if n >= table.shape[0]:
        grown = np.empty((2 * table.shape[0], table.shape[1]))
        grown[:n] = table[:n]
        table = grown
    for j in range(row.shape[0]):
        table[n, j] = row[j]
    return table


@njit
def _set_row(row, t, x, v, r, s):
    """A row of the samples table: ``(t, x, v, region, motion)``."""
    row[0], row[1], row[2], row[3], row[4] = t, x, v, r, s


@njit
def _add_segment(segments, n, row, t, x, v, r, s, a, acc):
    """Append a segment ``(t, x, v, region, motion, armed, impulse up, impulse down)``; returns the table."""
    row[0], row[1], row[2], row[3], row[4], row[5] = t, x, v, r, s, a
    row[6], row[7] = acc[A_IMP_UP], acc[A_IMP_LO]
    return _append(segments, n, row)


@njit
def _chatter_totals(p, jump, t, acc):
    """Add the resolved tail of a chatter up to ``t`` (``_Recorder.chatter``); returns ``(x, v, motion)``."""
    side = int(jump[J_SIDE])
    x, v, motion, impulse, path, loss = jump_state(jump, t)
    acc[A_IMP_UP if side > 0 else A_IMP_LO] += impulse
    acc[A_SLIP] += path
    acc[A_LOSS] += loss
    # The forcing works on the tail's net displacement (zero at the accumulation time).
    acc[A_WORK] += forcing(p, jump[J_T0]) * (x - jump[J_WALL])
    return x, v, motion


@njit
def _loop(p, t_end, x0, v0, max_events, keep_events, keep_segments, stops, impact_law):
    """Run the member ``p`` from ``(x0, v0)``; returns the final state, the records and how the loop ended.

    ``stops`` are the sorted sample times (time events: a piece ends there, the state is
    recorded and the motion goes on in the same mode). ``impact_law`` is the ``(c, q)`` of
    the elastic impact force ``c |V|^q`` (:func:`impactosc.results.impact_force_law`).
    """
    rigid = p[P_RIGID] != 0.0
    F, Om, phase, beta_s = p[P_TERMS], p[P_TERMS + 1], p[P_TERMS + 2], p[P_BETA_S]
    e = p[P_RESTITUTION]
    n_terms = (p.shape[0] - P_TERMS) // 3
    constant = True  # impactosc.Oscillator.constant_forcing
    for i in range(n_terms):
        if p[P_TERMS + 3 * i] != 0.0 and p[P_TERMS + 3 * i + 1] != 0.0:
            constant = False
    # Damping or a harmonic sum: the pieces of _exact_family; eq. 3 keeps its own.
    family = p[P_ZETA] != 0.0 or n_terms > 1
    size = family_constants(p, 0, 1).shape[0] if family else M_SIZE
    mcs = np.empty((3, 3, size))
    for r in (-1, 0, 1):
        for s in (-1, 1):
            mcs[r + 1, s + 1] = family_constants(p, r, s) if family else mode_constants(p, r, s)
    acc = np.zeros(N_ACC)
    cnt = np.zeros(12, dtype=np.int64)
    events = np.empty((64 if keep_events else 1, 7))
    contacts = np.empty((16 if keep_events else 1, N_CONTACT_COLUMNS))
    segments = np.empty((64 if keep_segments else 1, 8))
    samples = np.empty((max(stops.shape[0], 1), 5))
    tails = np.empty((4 if keep_segments else 1, J_SIZE))
    n_ev = n_co = n_seg = n_sa = n_ta = 0
    next_stop = stops[0] if stops.shape[0] > 0 else math.inf
    row6, row8, row9 = np.empty(7), np.empty(8), np.empty(N_CONTACT_COLUMNS)  # row6: an event row (7 fields)
    op = np.zeros(8)
    is_open = False
    jump = np.empty(J_SIZE)
    ch_side = ch_count = 0  # the chatter tracker (impactosc._chatter.ChatterTracker)
    info = np.zeros(3)  # missed guard / failing times, for the messages

    t, x, v = 0.0, x0, (0.0 if abs(v0) <= KINEMATIC_GUARD_OFFSET else v0)
    r, s, a = _rule.initial_mode(p, t, x, v)
    if r != 0:  # a run that starts inside a flange: a contact in progress, not an event
        pen0 = r * x - _rule.gap(p, r)
        op[O_START], op[O_SIDE], op[O_VIN], op[O_PEN], op[O_IMP], op[O_COMPLETE] = t, r, v, pen0, 0.0, 0.0
        op[O_PATH], op[O_VSQ] = 0.0, 0.0
        is_open = True
    start = (r, s, a)
    if keep_segments:
        segments = _add_segment(segments, n_seg, row8, t, x, v, r, s, a, acc)
        n_seg += 1
    guard = _rule.pending_guard(p, r, s, NO_GUARD, t, x, v)
    same_instant = 0
    status = DONE
    step = START  # START: settle the start; PIECE: a piece, then its transitions; JUMP: after a chatter
    t1, x1, v1 = t, x, v
    while True:
        if step == PIECE:
            while next_stop <= t:  # a sample time reached exactly (at the start, or at an event)
                _set_row(samples[n_sa], next_stop, x, v, r, s)
                n_sa += 1
                next_stop = stops[n_sa] if n_sa < stops.shape[0] else math.inf
            t_target = next_stop if next_stop < t_end else t_end
            # -- one piece ------------------------------------------------------------
            if s == 0:
                # A stuck mass: released in closed form (impactosc._stuck), one evaluation.
                spring = x + r * _rule.region_force(p, x, r)
                up = _rule.gate(rigid, r, s, a, RELEASE_UP)
                down = _rule.gate(rigid, r, s, a, RELEASE_DOWN)
                if constant:
                    t1, guard = t_target, NO_GUARD
                elif n_terms == 1:
                    t1, guard = release_one_harmonic(F, Om, phase, beta_s, spring, up, down, t, t_target)
                else:
                    t1, guard, failed = release_sum(p, spring, beta_s, up, down, t, t_target)
                    if failed == SEARCH_FAILED:
                        status = FAILED
                        break
                tau = t1 - t
                force = _rule.region_force(p, x, r)
                x1, v1, q, q2, w, vv = x, 0.0, force * tau, force * force * tau, 0.0, 0.0
            else:
                if family:
                    out = advance_family(p, mcs[r + 1, s + 1], r, s, a, t, x, v, t_target)
                else:
                    out = advance_slip(p, mcs[r + 1, s + 1], r, s, a, t, x, v, t_target)
                t1, x1, v1, guard, q, q2, w, vv, failed = out
                if failed == SEARCH_FAILED:
                    status = FAILED
                    break
            if not (math.isfinite(x1) and math.isfinite(v1) and math.isfinite(t1)):
                status, info[0] = NON_FINITE, t1
                break
            # The piece's statistics (impactosc.solution._Recorder.piece).
            if r != 0:
                k = 0 if r > 0 else 1
                if rigid:
                    # Resting against a rigid wall: the wall's force is the push it takes.
                    q, q2, peak = wall_force_integrals(p, r, t, t1)
                    acc[A_IMP_UP + k] += q
                    acc[A_SQ_UP + k] += q2
                    acc[A_CT_UP + k] += t1 - t
                    acc[A_PEN_UP + k] = max(acc[A_PEN_UP + k], peak)  # no penetration: the slot keeps the peak push
                    if is_open:
                        op[O_IMP] += q
                        op[O_PEN] = max(op[O_PEN], peak)  # a resting contact keeps its peak force there
                else:
                    acc[A_IMP_UP + k] += q
                    acc[A_SQ_UP + k] += q2
                    acc[A_CT_UP + k] += t1 - t
                    pen = max(r * x, r * x1) - _rule.gap(p, r)  # pieces are monotonic in X: the deepest point is an end
                    if pen > acc[A_PEN_UP + k]:
                        acc[A_PEN_UP + k] = pen
                    if is_open:
                        op[O_IMP] += q
                        if pen > op[O_PEN]:
                            op[O_PEN] = pen
                        if s != 0:
                            op[O_PATH] += abs(x1 - x)
                        op[O_VSQ] += vv
            if s != 0:
                acc[A_SLIP] += abs(x1 - x)
            acc[A_WORK] += w
            acc[A_VSQ] += vv
            cnt[C_STEPS] += 1
            cnt[C_PIECES] += 1
            missed = _rule.missed_guard(p, r, s, guard, t, x, v, t1, x1, v1)
            if missed != NO_GUARD:
                status, info[0], info[1] = MISSED, missed, t
                t, x, v = t1, x1, v1
                break
            if guard == NO_GUARD and t_target < t_end:
                # A sample time: a time event, not a transition. Same mode, same guards armed.
                t, x, v = t1, x1, v1
                if keep_segments:
                    segments = _add_segment(segments, n_seg, row8, t, x, v, r, s, a, acc)
                    n_seg += 1
                continue
            if guard == NO_GUARD:
                while next_stop <= t1:  # a sample time at t_end itself
                    _set_row(samples[n_sa], next_stop, x1, v1, r, s)
                    n_sa += 1
                    next_stop = stops[n_sa] if n_sa < stops.shape[0] else math.inf
                t, x, v = t1, x1, v1
                break
        # -- the transitions at t1 (impactosc.engine._settle) ------------------------------
        recorded = False
        have_jump = False
        while guard != NO_GUARD:
            v_before = v1
            r, s, a, x1, v1, kind, side = _rule.transition(p, r, s, a, guard, t1, x1, v1)
            if kind != NO_KIND:
                recorded = True
                v_event = v_before if kind == IMPACT else v1  # an impact keeps the incoming velocity
                cnt[kind] += 1
                cnt[C_EVENTS] += 1
                if keep_events:
                    row6[0], row6[1], row6[2], row6[3], row6[4], row6[5] = t1, kind, x1, v_event, side, 1.0
                    row6[6] = s  # the direction of motion after the event
                    events = _append(events, n_ev, row6)
                    n_ev += 1
                if kind == CONTACT_START:
                    cnt[C_ENTRIES_UP if side > 0 else C_ENTRIES_LO] += 1
                    op[O_START], op[O_SIDE], op[O_VIN] = t1, side, v_event
                    op[O_PEN], op[O_IMP], op[O_COMPLETE] = 0.0, 0.0, 1.0
                    op[O_PATH], op[O_VSQ] = 0.0, 0.0
                    is_open = True
                elif kind == CONTACT_END and is_open:
                    _close_contact(row9, op, t1, v_event, p, impact_law, acc)
                    if keep_events:
                        contacts = _append(contacts, n_co, row9)
                        n_co += 1
                    is_open = False
                elif kind == IMPACT:
                    # Impulse (1 + e)|V|, kinetic energy (1 - e^2) V^2 / 2 lost.
                    impulse = (1.0 + e) * abs(v_event)
                    cnt[C_ENTRIES_UP if side > 0 else C_ENTRIES_LO] += 1
                    acc[A_IMP_UP if side > 0 else A_IMP_LO] += impulse
                    loss = 0.5 * (1.0 - e * e) * v_event * v_event
                    acc[A_LOSS] += loss
                    _add_contact(acc, side, v_event, math.inf, impulse, math.inf, loss)
                    if keep_events:
                        row9[0], row9[1], row9[2], row9[3], row9[4] = t1, t1, side, v_event, -e * v_event
                        row9[5], row9[6], row9[7], row9[8], row9[9] = 0.0, math.inf, impulse, 1.0, loss
                        contacts = _append(contacts, n_co, row9)
                        n_co += 1
                if rigid:  # the chatter tracker
                    if kind == IMPACT:
                        if side != ch_side:
                            ch_side, ch_count = side, 0
                        ch_count += 1
                        have_jump = predict_jump(p, t1, side, abs(v_before), ch_count, jump)
                    elif kind != REVERSAL:
                        ch_side = ch_count = 0
                        have_jump = False
            guard = _rule.pending_guard(p, r, s, guard, t1, x1, v1)
        if step == START:  # the start: no segment, no limits (as in the Python driver)
            t, x, v = t1, x1, v1
            step = PIECE
            continue
        if step == PIECE and have_jump:
            # Impacts accumulating in finite time: jump to the accumulation point (the engine's drive).
            if keep_segments:
                segments = _add_segment(segments, n_seg, row8, t1, x1, v1, r, s, a, acc)
                n_seg += 1
                tails = _append(tails, n_ta, jump)
                n_ta += 1
            t_inf, side = jump[J_T_INF], int(jump[J_SIDE])
            while next_stop < t_inf and next_stop <= t_end:  # samples in the tail: the local model
                xs, vs, motion, _, _, _ = jump_state(jump, next_stop)
                _set_row(samples[n_sa], next_stop, xs, vs, 0, motion)
                n_sa += 1
                next_stop = stops[n_sa] if n_sa < stops.shape[0] else math.inf
            if t_inf > t_end:
                # The run ends inside the tail: its state and totals up to t_end.
                x, v, motion = _chatter_totals(p, jump, t_end, acc)
                t, r, s, a = t_end, 0, motion, 1
                status, info[0], info[1] = CHATTER_END, side, t_inf
                break
            _chatter_totals(p, jump, t_inf, acc)
            cnt[CHATTER] += 1
            cnt[C_EVENTS] += 1
            if keep_events:
                row6[0], row6[1], row6[2], row6[3] = t_inf, CHATTER, jump[J_WALL], 0.0
                row6[4], row6[5], row6[6] = side, jump[J_IMPACTS], 0.0
                events = _append(events, n_ev, row6)
                n_ev += 1
            t1, x1, v1 = t_inf, jump[J_WALL], 0.0
            r, s, a, guard = 0, 0, 1, AT_WALL  # at rest on the wall: its rest test follows
            step = JUMP
            continue
        if step == JUMP:
            recorded = True
            step = PIECE
        same_instant = same_instant + 1 if t1 == t else 0
        t, x, v = t1, x1, v1
        if keep_segments:
            segments = _add_segment(segments, n_seg, row8, t, x, v, r, s, a, acc)
            n_seg += 1
        if recorded and cnt[C_EVENTS] >= max_events:
            status = EVENT_LIMIT
            break
        if same_instant > MAX_EVENTS_AT_ONE_INSTANT:
            status, info[0] = SAME_INSTANT, same_instant
            break
    if is_open:  # a contact in progress at the end: incomplete, no exit velocity
        op[O_COMPLETE] = 0.0
        _close_contact(row9, op, t, math.nan, p, impact_law, acc)
        if keep_events:
            contacts = _append(contacts, n_co, row9)
            n_co += 1
    final = np.array([t, x, v])
    modes = np.array([start[0], start[1], start[2], r, s, a], dtype=np.int64)
    return (final, modes, status, info, acc, cnt, events[:n_ev].copy(), contacts[:n_co].copy(),
            segments[:n_seg].copy(), samples[:n_sa].copy(), tails[:n_ta].copy())


@njit
def _close_contact(row, op, t, v, p, impact_law, acc):
    """Close the contact ``op`` (``_Recorder._close``): its row of the contacts table in ``row``, sums in ``acc``."""
    if p[P_RIGID] != 0.0:  # a resting contact keeps its peak wall force in the penetration slot
        pen, peak = 0.0, op[O_PEN]
        impact_force = loss = 0.0  # at rest on the wall: no impact, nothing dissipated
    else:
        pen = max(op[O_PEN], 0.0)
        peak = p[P_K] * pen
        impact_force = impact_law[0] * abs(op[O_VIN]) ** impact_law[1]
        loss = p[P_BETA] * op[O_PATH] + 2.0 * p[P_ZETA] * op[O_VSQ]
    _add_contact(acc, int(op[O_SIDE]), op[O_VIN], peak, op[O_IMP], impact_force, loss)
    row[0], row[1], row[2], row[3], row[4] = op[O_START], t, op[O_SIDE], op[O_VIN], v
    row[5], row[6], row[7], row[8], row[9] = pen, peak, op[O_IMP], op[O_COMPLETE], loss


@njit
def _add_contact(acc, side, v_in, peak, impulse, impact_force, loss):
    """Add one contact to its flange's sums in ``acc`` (``_Recorder._add_contact``)."""
    j = A_SUMS + (0 if side > 0 else N_SUMS)
    speed = abs(v_in)
    acc[j + S_CONTACTS] += 1.0
    acc[j + S_SPEED] += speed
    acc[j + S_SPEED_SQ] += speed * speed
    acc[j + S_PEAK] += peak
    acc[j + S_IMPULSE] += impulse
    acc[j + S_IMPACT_FORCE] += impact_force
    acc[j + S_DISSIPATED] += loss


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        sample_at=()) -> Solution:
    """Run eq. 3 with the compiled loop; the :class:`~impactosc.solution.Solution` of the Python driver."""
    from ._stepper import _Stepper

    keep_events, keep_segments = record != "stats", record == "full"
    final, modes, status, info, acc, cnt, events, contacts, segments, samples, tails = _loop(
        osc._p, float(t_end), float(x0), float(v0), int(max_events), keep_events, keep_segments,
        np.asarray(sample_at, dtype=float), np.array(impact_force_law(osc.K, osc.exponent)))
    t, x, v = (float(a) for a in final)
    start = Mode(int(modes[0]), int(modes[1]), bool(modes[2]))
    mode = Mode(int(modes[3]), int(modes[4]), bool(modes[5]))
    rec = _Recorder(record, "exact", _Stepper(osc).evaluate)
    rec.osc, rec.rigid = osc, osc.rigid
    rec.t0, rec.x0, rec.v0, rec.mode0 = 0.0, float(x0), (0.0 if abs(v0) <= KINEMATIC_GUARD_OFFSET else float(v0)), start
    rec.counts = {kind: int(cnt[i]) for i, kind in enumerate(EVENT_KINDS)}
    rec.entries = {1: int(cnt[C_ENTRIES_UP]), -1: int(cnt[C_ENTRIES_LO])}
    rec.n_events, rec.pieces, rec.steps = int(cnt[C_EVENTS]), int(cnt[C_PIECES]), int(cnt[C_STEPS])
    rec.impulse = {1: float(acc[A_IMP_UP]), -1: float(acc[A_IMP_LO])}
    rec.impulse_sq = {1: float(acc[A_SQ_UP]), -1: float(acc[A_SQ_LO])}
    rec.contact_time = {1: float(acc[A_CT_UP]), -1: float(acc[A_CT_LO])}
    rec.max_pen = {1: float(acc[A_PEN_UP]), -1: float(acc[A_PEN_LO])}
    if osc.rigid:  # a rigid flange has no penetration: its slots kept the peak wall push
        rec.max_force, rec.max_pen = rec.max_pen, {1: 0.0, -1: 0.0}
    rec.forcing_work, rec.slip_path, rec.v_squared = float(acc[A_WORK]), float(acc[A_SLIP]), float(acc[A_VSQ])
    rec.impact_loss = float(acc[A_LOSS])
    rec.contact_sums = {side: [float(acc[A_SUMS + (0 if side > 0 else N_SUMS) + SUMS.index(name)])
                               for name in CONTACT_SUMS] for side in (1, -1)}
    rec.streamed_pieces = bool(cnt[C_PIECES] > 0)
    # The recorder's tables are lists of rows; Solution takes any sequence of rows, and
    # record arrays built here in one go cost nothing per event.
    if keep_events:
        table = _table(EVENT_DTYPE, events, EVENT_DTYPE.names or ())
        table["kind"] = np.asarray(EVENT_KINDS)[events[:, 1].astype(np.int64)]
        rec.events = cast(Any, table)
        rec.impacts = cast(Any, _table(IMPACT_DTYPE, contacts, IMPACT_DTYPE.names or ()))
        rec.dissipated = [float(a) for a in contacts[:, N_CONTACT_COLUMNS - 1]]
    if keep_segments:
        rec.segments = cast(Any, _table(SEGMENT_DTYPE, segments, SEGMENT_DTYPE.names or ()))
    rec.samples = cast(Any, _table(SAMPLE_DTYPE, samples, SAMPLE_DTYPE.names or ()))
    rec.tails = [ChatterJump.from_row(row) for row in tails]
    rec.finish(t, x, v, mode, *_outcome(status, info, t, mode, max_events))
    return Solution(rec, t_end)


def _table(dtype: np.dtype, rows: np.ndarray, names) -> np.recarray:
    """The float rows of the compiled loop as a record array of ``dtype`` (columns ``names`` in order)."""
    out = np.recarray((rows.shape[0],), dtype=dtype)
    for j, name in enumerate(names):
        if name != "kind":
            out[name] = rows[:, j]
    return out


def _outcome(status: int, info: np.ndarray, t: float, mode: Mode, max_events: int) -> tuple[int, str]:
    """``(status, message)`` of the Solution: the Python driver's, word for word."""
    if status == DONE:
        return 0, "The end time was reached."
    if status == EVENT_LIMIT:
        return 1, (f"The event limit max_events={max_events} was reached at t={t!r}; "
                   "results up to that time are kept.")
    if status == FAILED:
        return -1, (f"the exact backend failed after t={t!r}: FloatingPointError: "
                    f"the guard search of the piece from t={t!r} did not converge")
    if status == NON_FINITE:
        return -1, f"integration produced a non-finite state at t={float(info[0])!r}"
    if status == CHATTER_END:
        flange = "upper" if info[0] > 0 else "lower"
        return 0, (f"The end time was reached inside a chatter on the {flange} flange "
                   f"(its impacts accumulate at t={float(info[1])!r}, after the end).")
    if status == MISSED:
        start = float(info[1])
        return -1, (f"the exact backend missed a {GUARD_NAMES[int(info[0])]} guard in the piece "
                    f"[{start!r}, {t!r}] (mode {tuple(mode)}); results up to t={start!r} are kept. "
                    "This is a bug: please report it with the parameters.")
    return -1, (f"{int(info[0])} consecutive events at t={t!r} without time advancing; "
                "stopped to avoid an endless loop.")
