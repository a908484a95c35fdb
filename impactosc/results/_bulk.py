"""A whole run streamed into the built-in recorder at once: the arrays of a run replayed from another loop.

The engine's driver feeds :class:`~impactosc.results._solution._Recorder` one smooth piece
and one event at a time; a run that another event loop has already finished (the built-in
member on the hybrid heyoka loop, :mod:`impactosc.backends.heyoka._replay`) hands over its
pieces, events and piece starts as arrays to :func:`bulk`, which streams the same records,
counts, integrals and contact sums, to the last bit: every sum is taken in the order the
per-piece calls add it (sequential cumulative sums, contact by contact).
"""

from __future__ import annotations

import numpy as np

from ..engine._driver import CONTACT_END, CONTACT_START
from ._observables import elastic_impact_force, impact_force_law
from ._solution import (
    EVENT_DTYPE,
    SEGMENT_DTYPE,
    _kept,
    _Recorder,
)

__all__ = ["PIECE_DTYPE", "bulk"]

#: The smooth pieces :func:`bulk` takes (the arguments of ``_Recorder.piece``).
PIECE_DTYPE = np.dtype([("t0", "f8"), ("x0", "f8"), ("t1", "f8"), ("x1", "f8"), ("region", "i1"), ("motion", "i1"),
                        ("q", "f8"), ("q2", "f8"), ("w", "f8"), ("vv", "f8")])


def bulk(rec: _Recorder, pieces: np.ndarray, events: np.ndarray, event_pieces: np.ndarray, segments: np.ndarray,
         segment_pieces: np.ndarray) -> None:
    """A whole run of a spring-flange member at once: what ``piece``, ``event`` and ``segment`` would stream.

    After the recorder's ``begin``; only its ``finish`` may follow (the events and piece
    starts are kept in ``event_array`` and ``segment_array`` from here on). The records,
    counts, integrals and contact sums are those of the calls one by one, to the last bit:
    every sum is taken in the same order (sequential cumulative sums, contact by contact),
    every product with the same operands.

    Parameters
    ----------
    pieces : numpy.ndarray of PIECE_DTYPE
        The smooth pieces in time order (the arguments of ``_Recorder.piece``).
    events : numpy.ndarray of EVENT_DTYPE
        The events in time order (the arguments of ``_Recorder.event``).
    event_pieces : numpy.ndarray of int
        How many of ``pieces`` come before each event.
    segments : numpy.ndarray of SEGMENT_DTYPE
        The piece starts after events (``_Recorder.segment``; the impulse fields are filled here).
    segment_pieces : numpy.ndarray of int
        How many of ``pieces`` come before each segment.
    """
    if rec.rigid:
        raise ValueError("bulk: a rigid flange's wall force is integrated piece by piece; use piece()")
    osc = rec.osc
    region, motion = pieces["region"], pieces["motion"]
    x0, x1 = pieces["x0"], pieces["x1"]
    path = np.where(motion != 0, np.abs(x1 - x0), 0.0)
    up, down = region == 1, region == -1
    q, q2, length = pieces["q"], pieces["q2"], pieces["t1"] - pieces["t0"]
    # every running sum in one cumulative sum (column by column, in piece order)
    sums = np.empty((len(pieces) + 1, 9))
    sums[0] = (rec.impulse[1], rec.impulse[-1], rec.impulse_sq[1], rec.impulse_sq[-1], rec.contact_time[1],
               rec.contact_time[-1], rec.slip_path, rec.forcing_work, rec.v_squared)
    for column, (on, values) in enumerate(((up, q), (down, q), (up, q2), (down, q2), (up, length),
                                           (down, length))):
        sums[1:, column] = np.where(on, values, 0.0)
    sums[1:, 6], sums[1:, 7], sums[1:, 8] = path, pieces["w"], pieces["vv"]
    np.cumsum(sums, axis=0, out=sums)
    total = sums[-1].tolist()
    rec.impulse[1], rec.impulse[-1], rec.impulse_sq[1], rec.impulse_sq[-1] = total[:4]
    rec.contact_time[1], rec.contact_time[-1], rec.slip_path, rec.forcing_work, rec.v_squared = total[4:]
    # Pieces are monotonic in X, so the deepest point of a piece is at an end.
    deepest = np.maximum(region * x0, region * x1)
    for side, on in ((1, up), (-1, down)):
        if on.any():
            pen = float(deepest[on].max()) - osc.gap(side)
            if pen > rec.max_pen[side]:
                rec.max_pen[side] = pen
    rec.pieces += len(pieces)
    rec.streamed_pieces = rec.streamed_pieces or len(pieces) > 0
    kinds = events["kind"]
    for kind in rec.counts:  # a comparison per kind: cheaper than sorting the names
        rec.counts[kind] += int(np.count_nonzero(kinds == kind))
    rec.n_events += len(events)
    starts = events["side"][kinds == CONTACT_START]
    rec.entries[1] += int(np.count_nonzero(starts == 1))
    rec.entries[-1] += int(np.count_nonzero(starts == -1))
    _contacts(rec, pieces, path, deepest, events, event_pieces)
    if rec.keep_events:
        rec.event_array = np.concatenate([np.array(rec.events, dtype=EVENT_DTYPE), events]) if rec.events \
            else events
    if rec.keep_segments:
        # those recorded before (the start's), then these: filled in place (np.concatenate of structured
        # arrays promotes their fields first, ~15 us)
        before = len(rec.segments)
        table = np.empty(before + len(segments), dtype=SEGMENT_DTYPE)
        table[:before] = rec.segments
        table[before:] = segments
        table["impulse_upper"][before:] = sums[segment_pieces, 0]
        table["impulse_lower"][before:] = sums[segment_pieces, 1]
        rec.segment_array = table


def _contacts(rec: _Recorder, pieces: np.ndarray, path: np.ndarray, deepest: np.ndarray, events: np.ndarray,
              event_pieces: np.ndarray) -> None:
    """The contacts of :func:`bulk`: their rows and sums, and the one left open at the end in ``_open``."""
    lo, hi, start_event, ends, open_at_end = _spans(rec, events, event_pieces, len(pieces))
    count = len(lo)
    ev_t, ev_v, ev_side = events["t"], events["v"], events["side"]
    if rec._open is not None and count > 0 and start_event[0] < 0:
        # the contact open at the start goes on: its sums so far, its entry
        initial = _kept(rec._open, "the open contact")
        from_start = start_event < 0
        sums = np.array([np.where(from_start, value, 0.0) for value in (initial[4], initial[3], *rec._open_loss)])
        # the contacts opened by an event read it; the one open at the start reads a padding row
        # (a run may have no events at all: a mass that stays inside a flange)
        safe = np.where(from_start, len(ev_t), start_event)
        t_start = np.where(from_start, initial[0], np.append(ev_t, 0.0)[safe])
        side = np.where(from_start, initial[1], np.append(ev_side, 0)[safe]).astype(int)
        v_in = np.where(from_start, initial[2], np.append(ev_v, 0.0)[safe])
        complete = np.where(from_start, bool(initial[5]), True)
    else:
        sums = np.zeros((4, count))
        t_start, side, v_in = ev_t[start_event], ev_side[start_event].astype(int), ev_v[start_event]
        complete = np.ones(count, dtype=bool)
    _insides(rec, pieces, path, deepest, lo, hi, sums)
    impulse, peak, loss_path, loss_vv = sums
    if open_at_end:
        j = count - 1
        rec._open = [float(t_start[j]), int(side[j]), float(v_in[j]), float(peak[j]), float(impulse[j]),
                     bool(complete[j])]
        rec._open_loss = [float(loss_path[j]), float(loss_vv[j])]
    else:
        rec._open = None
    closed = len(ends)
    if closed:
        rows = (t_start[:closed], ev_t[ends], side[:closed], v_in[:closed], ev_v[ends], complete[:closed])
        _close(rec, rows, sums[:, :closed])


def _spans(rec: _Recorder, events: np.ndarray, event_pieces: np.ndarray, n_pieces: int) -> tuple:
    """Each contact's pieces ``[lo, hi)`` and start event (-1: open at the start), the events that close
    contacts, and whether the last contact is still open at the end, as ``event``/``_close`` pair them."""
    kinds = events["kind"]
    marks = np.flatnonzero((kinds == CONTACT_START) | (kinds == CONTACT_END))
    opening = kinds[marks] == CONTACT_START
    # a contact_end closes the contact the event before it opened (or the one open at the start)
    previous = np.concatenate(([rec._open is not None], opening[:-1])) if len(marks) else opening
    closing = ~opening & previous
    ends = marks[closing]
    open_at = marks[np.flatnonzero(closing) - 1] if len(ends) else np.zeros(0, dtype=int)
    lo = event_pieces[open_at] if len(open_at) else np.zeros(0, dtype=int)
    start_event = open_at.copy()
    if rec._open is not None and len(marks) and not opening[0]:
        lo[0], start_event[0] = 0, -1  # the first end closes the contact open at the start
    hi = event_pieces[ends]
    trailing = marks[-1] if len(marks) and opening[-1] else None
    if trailing is not None:
        lo = np.append(lo, event_pieces[trailing])
        hi = np.append(hi, n_pieces)
        start_event = np.append(start_event, trailing)
    elif rec._open is not None and not len(marks):
        lo, hi, start_event = np.array([0]), np.array([n_pieces]), np.array([-1])
    open_at_end = trailing is not None or (rec._open is not None and not len(ends))
    return lo, hi, start_event, ends, open_at_end


def _insides(rec: _Recorder, pieces: np.ndarray, path: np.ndarray, deepest: np.ndarray, lo: np.ndarray,
             hi: np.ndarray, sums: np.ndarray) -> None:
    """Add each contact's pieces to its ``sums`` rows (impulse, peak penetration, slip path, int V^2) in place."""
    osc = rec.osc
    region, motion = pieces["region"], pieces["motion"]
    q, vv = pieces["q"], pieces["vv"]
    pen_all = deepest - np.where(region == 1, osc.gap_upper, np.where(region == -1, osc.gap_lower, 0.0))
    slip_path = np.where(motion != 0, path, 0.0)
    impulse, peak, loss_path, loss_vv = sums
    length = hi - lo
    for k in range(int(length.max()) if len(lo) else 0):
        # the k-th piece of every contact that has one: sums in the order piece() adds them
        sel = np.flatnonzero(k < length)
        at = lo[sel] + k
        inside = region[at] != 0
        if not inside.all():
            sel, at = sel[inside], at[inside]
        impulse[sel] += q[at]
        peak[sel] = np.where(pen_all[at] > peak[sel], pen_all[at], peak[sel])
        loss_path[sel] += slip_path[at]
        loss_vv[sel] += vv[at]


def _close(rec: _Recorder, rows: tuple, sums: np.ndarray) -> None:
    """The closed contacts' impact rows, dissipated energies and contact sums (as ``_Recorder._close`` makes them)."""
    osc = rec.osc
    t_start, t_end, side, v_in, v_out, complete = rows
    impulse, peak, loss_path, loss_vv = sums
    pen = np.maximum(peak, 0.0)
    c, power = impact_force_law(osc.K, osc.exponent)
    if osc.exponent == 1.0:
        force, impact = osc.K * pen, c * np.abs(v_in) ** power
    else:  # the scalar power of _close, contact by contact
        force = np.array([osc.K * d**osc.exponent for d in pen.tolist()])
        impact = np.array([elastic_impact_force(osc.K, osc.exponent, v) for v in v_in.tolist()])
    loss = osc.beta * loss_path + 2.0 * osc.zeta * loss_vv
    speed = np.abs(v_in)
    # the columns of CONTACT_SUMS, contact by contact (one cumulative sum per flange, from its sums so far)
    columns = np.empty((len(pen), 7))
    columns[:, 0] = 1.0
    columns[:, 1], columns[:, 2], columns[:, 3], columns[:, 4] = speed, speed * speed, force, impulse
    columns[:, 5], columns[:, 6] = impact, loss
    for s in (1, -1):
        on = side == s
        count = int(np.count_nonzero(on))
        if count:
            running = np.empty((count + 1, 7))
            running[0] = rec.contact_sums[s]
            running[1:] = columns[on]
            np.cumsum(running, axis=0, out=running)
            rec.contact_sums[s] = running[-1].tolist()
    if rec.keep_events:
        rec.impacts.extend(zip(t_start.tolist(), t_end.tolist(), side.tolist(), v_in.tolist(), v_out.tolist(),
                               pen.tolist(), force.tolist(), impulse.tolist(), complete.tolist(), strict=True))
        rec.dissipated.extend(loss.tolist())
