"""A whole run streamed into the built-in recorder at once: the arrays of a run replayed from another loop.

The engine's driver feeds :class:`~impactosc.results._solution._Recorder` one smooth piece
and one event at a time; a run that another event loop has already finished (the built-in
member on the hybrid heyoka loop, :mod:`impactosc.backends.heyoka._replay`) hands over its
pieces, events and piece starts as arrays to :func:`bulk`, which streams the same records,
counts, integrals and contact sums, to the last bit: one loop over the run (:func:`_stream`,
compiled by numba where it is installed) does what ``piece``, ``event`` and ``_close`` do, in
their order, with the same operations on the same operands. Without numba the same function
runs as plain Python on lists (the fill of 328 events: about 0.63 ms, against 0.09 ms compiled and
0.22 ms for the numpy version it replaced).
"""

from __future__ import annotations

import numpy as np

from .._util.jit import HAVE_NUMBA, njit
from ..engine._driver import CONTACT_END, CONTACT_START
from ._observables import impact_force_law
from ._solution import EVENT_DTYPE, IMPACT_DTYPE, SEGMENT_DTYPE, _Recorder

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
    every sum is taken in the same order, every product with the same operands
    (:func:`_stream`).

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
    code = _counted(rec, events)
    totals, max_pen, contact_sums, state = _taken(rec)
    osc = rec.osc
    c, power = impact_force_law(osc.K, osc.exponent)
    law = np.array([osc.gap_upper, osc.gap_lower, osc.K, osc.exponent, c, power, osc.beta, osc.zeta])
    n = len(pieces)
    prefix = np.empty((n + 1, 2))
    rows = np.empty((len(events), len(_ROW)))
    inputs = [pieces[name] for name in PIECE_DTYPE.names]  # type: ignore[union-attr]
    inputs += [events["t"], code, events["v"], events["side"], np.asarray(event_pieces, dtype=np.int64), law]
    outputs = [totals, max_pen, contact_sums, state, prefix, rows]
    if HAVE_NUMBA:  # contiguous copies: the fields of a structured array are strided views
        count = _stream(*(np.ascontiguousarray(a) for a in inputs), *outputs)
    else:  # plain Python indexes lists several times faster than arrays
        lists = [a.tolist() for a in outputs]
        count = _stream(*(a.tolist() for a in inputs), *lists)
        totals, max_pen, contact_sums, state, prefix, rows = (np.asarray(a, dtype=float).reshape(b.shape)
                                                              for a, b in zip(lists, outputs, strict=True))
    _given(rec, totals, max_pen, contact_sums, state)
    rec.pieces += n
    rec.streamed_pieces = rec.streamed_pieces or n > 0
    if rec.keep_events:
        rec.event_array = np.concatenate([np.array(rec.events, dtype=EVENT_DTYPE), events]) if rec.events \
            else events
        _impact_table(rec, rows[:count])
    if rec.keep_segments:
        # those recorded before (the start's), then these: filled in place (np.concatenate of structured
        # arrays promotes their fields first, ~15 us)
        before = len(rec.segments)
        table = np.empty(before + len(segments), dtype=SEGMENT_DTYPE)
        table[:before] = rec.segments
        table[before:] = segments
        table["impulse_upper"][before:] = prefix[segment_pieces, 0]
        table["impulse_lower"][before:] = prefix[segment_pieces, 1]
        rec.segment_array = table


def _counted(rec: _Recorder, events: np.ndarray) -> np.ndarray:
    """Count ``events`` by kind and the flange entries into ``rec``; each event's code for :func:`_stream`."""
    kinds = events["kind"]
    code = np.full(len(events), _OTHER, dtype=np.int8)
    for kind in rec.counts:  # a comparison per kind: cheaper than sorting the names
        matches = kinds == kind
        rec.counts[kind] += int(np.count_nonzero(matches))
        if kind == CONTACT_START or kind == CONTACT_END:
            code[matches] = _OPENS if kind == CONTACT_START else _CLOSES
    rec.n_events += len(events)
    starts = events["side"][code == _OPENS]
    rec.entries[1] += int(np.count_nonzero(starts == 1))
    rec.entries[-1] += int(np.count_nonzero(starts == -1))
    return code


def _taken(rec: _Recorder) -> tuple:
    """The running sums of ``rec`` as :func:`_stream` updates them: totals, peak penetrations, contact sums, the
    open contact."""
    totals = np.array([rec.impulse[1], rec.impulse[-1], rec.impulse_sq[1], rec.impulse_sq[-1], rec.contact_time[1],
                       rec.contact_time[-1], rec.slip_path, rec.forcing_work, rec.v_squared])
    state = np.zeros(_OPEN_SIZE)
    if rec._open is not None:
        state[:7] = (1.0, *rec._open)
        state[7:] = rec._open_loss
    return totals, np.array([rec.max_pen[1], rec.max_pen[-1]]), np.array([rec.contact_sums[1], rec.contact_sums[-1]]), \
        state


def _given(rec: _Recorder, totals: np.ndarray, max_pen: np.ndarray, contact_sums: np.ndarray,
           state: np.ndarray) -> None:
    """The running sums :func:`_stream` updated, back into ``rec`` (:func:`_taken`'s inverse)."""
    total = totals.tolist()
    rec.impulse[1], rec.impulse[-1], rec.impulse_sq[1], rec.impulse_sq[-1] = total[:4]
    rec.contact_time[1], rec.contact_time[-1], rec.slip_path, rec.forcing_work, rec.v_squared = total[4:]
    rec.max_pen[1], rec.max_pen[-1] = max_pen.tolist()
    rec.contact_sums[1], rec.contact_sums[-1] = contact_sums.tolist()
    if state[0]:
        t0, side, v_in, peak, impulse, complete, loss_path, loss_vv = state[1:].tolist()
        rec._open = [t0, int(side), v_in, peak, impulse, bool(complete)]
        rec._open_loss = [loss_path, loss_vv]
    else:
        rec._open = None


def _impact_table(rec: _Recorder, closed: np.ndarray) -> None:
    """The contacts :func:`_stream` closed (rows of ``_ROW``) as ``rec``'s impact table and dissipated energies.

    A contact that ``finish`` closes later goes to the lists ``impacts``/``dissipated`` (the Solution joins them).
    """
    table = np.empty(len(closed), dtype=IMPACT_DTYPE)
    for k, name in enumerate(IMPACT_DTYPE.names):  # type: ignore[arg-type]
        table[name] = closed[:, k]  # side and complete cast from the exact floats -1.0/1.0 and 0.0/1.0
    rec.impact_array = np.concatenate([np.array(rec.impacts, dtype=IMPACT_DTYPE), table]) if rec.impacts else table
    rec.dissipated_array = np.concatenate([rec.dissipated, closed[:, -1]]) if rec.dissipated else closed[:, -1]
    rec.impacts.clear()
    rec.dissipated.clear()


#: The event codes :func:`_stream` reads: a contact opened, closed, anything else.
_OPENS, _CLOSES, _OTHER = 0, 1, 2
#: The open contact as :func:`_stream` keeps it: open?, start, side, entry speed, peak penetration,
#: impulse, complete?, slip path, int V^2 (``_Recorder._open`` and ``_open_loss``).
_OPEN_SIZE = 9
#: A closed contact's row (``_Recorder._close``'s impact row, then its dissipated energy).
_ROW = ("start", "end", "side", "v_in", "v_out", "pen", "force", "impulse", "complete", "loss")


@njit
def _stream(t0, x0, t1, x1, region, motion, q, q2, w, vv, ev_t, ev_code, ev_v, ev_side, event_pieces, law, totals,
            max_pen, contact_sums, state, prefix, rows):  # pragma: no cover - compiled (its Python twin is tested)
    """``_Recorder.piece``, ``event`` and ``_close`` of a spring flange over a whole run, in their order.

    The same operations on the same operands as the calls one by one (each sum sequential, in
    the order of the calls), on arrays: ``totals`` (impulse, its square and contact time per
    flange, slip path, forcing work, int V^2), ``max_pen`` and ``contact_sums`` (upper, lower),
    the open contact ``state`` (see ``_OPEN_SIZE``) are updated in place; ``prefix[k]`` gets the
    impulses after ``k`` pieces, ``rows`` the closed contacts (``_ROW``). Returns how many closed.
    ``law``: gaps (upper, lower), ``K``, the exponent, the impact force law ``c |v|^power``,
    ``beta``, ``zeta``.
    """
    gap_upper, gap_lower = law[0], law[1]
    n, m = len(t0), len(ev_t)
    k, count = 0, 0
    prefix[0][0], prefix[0][1] = totals[0], totals[1]
    for i in range(m + 1):
        upto = event_pieces[i] if i < m else n
        while k < upto:
            r = region[k]
            if r != 0:
                j = 0 if r == 1 else 1
                totals[j] += q[k]
                totals[2 + j] += q2[k]
                totals[4 + j] += t1[k] - t0[k]
                # Pieces are monotonic in X, so the deepest point of a piece is at an end.
                a, b = r * x0[k], r * x1[k]
                pen = (b if b > a else a) - (gap_upper if j == 0 else gap_lower)  # Python's max(a, b)
                if pen > max_pen[j]:
                    max_pen[j] = pen
                if state[0] != 0.0:
                    state[5] += q[k]
                    if pen > state[4]:
                        state[4] = pen
                    if motion[k] != 0:
                        state[7] += abs(x1[k] - x0[k])
                    state[8] += vv[k]
            if motion[k] != 0:
                totals[6] += abs(x1[k] - x0[k])
            totals[7] += w[k]
            totals[8] += vv[k]
            k += 1
            prefix[k][0], prefix[k][1] = totals[0], totals[1]
        if i == m:
            break
        if ev_code[i] == 0:
            state[0], state[1], state[2], state[3] = 1.0, ev_t[i], ev_side[i], ev_v[i]
            state[4], state[5], state[6], state[7], state[8] = 0.0, 0.0, 1.0, 0.0, 0.0
        elif ev_code[i] == 1 and state[0] != 0.0:
            _close_contact(ev_t[i], ev_v[i], law, state, contact_sums, rows[count])
            count += 1
    return count


@njit
def _close_contact(t, v, law, state, contact_sums, row):  # pragma: no cover - compiled (its Python twin is tested)
    """``_Recorder._close`` of the open contact ``state`` at ``(t, v)``: its flange's contact sums, its ``row``."""
    K, exponent, c, power, beta, zeta = law[2], law[3], law[4], law[5], law[6], law[7]
    v_in, peak = state[3], state[4]
    pen = 0.0 if 0.0 > peak else peak  # Python's max(peak, 0.0)
    force = K * pen**exponent
    impact = c * abs(v_in) ** power
    loss = beta * state[7] + 2.0 * zeta * state[8]
    sums = contact_sums[0 if state[2] == 1.0 else 1]
    speed = abs(v_in)
    sums[0] += 1.0
    sums[1] += speed
    sums[2] += speed * speed
    sums[3] += force
    sums[4] += state[5]
    sums[5] += impact
    sums[6] += loss
    row[0], row[1], row[2], row[3], row[4] = state[1], t, state[2], v_in, v
    row[5], row[6], row[7], row[8], row[9] = pen, force, state[5], state[6], loss
    state[0] = 0.0
