"""Results of a run: streamed statistics, the event and impact tables, dense output.

A Solution pickles in every recording mode (process pools, dask, caches); its dense
output re-integrates with the backend's evaluator, which holds only the model and the
options. What is kept is chosen with ``record``:

``"full"``    events, impacts and the start of every smooth piece, so that
              :meth:`Solution.sample` and windowed averages can re-integrate any piece.
``"events"``  events and impacts only.
``"stats"``   counts, integrals and sums over the contacts (:meth:`Solution.contact_sums`)
              only: memory stays flat however many events occur.

Averages are integrals, not samples: the flange impulse, the integral of the member's
flange force (``K d^p`` on the penetration ``d = (|X| - 1)+`` of a spring flange; the wall's
push on a mass resting against a rigid flange, plus the impulses ``(1 + e)|V|`` of its
impacts) is integrated by the backend over every piece, per flange, in every recording mode.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeVar

import numpy as np

from .._util import validation as _v
from ..engine._driver import CHATTER, CONTACT_END, CONTACT_START, EVENT_KINDS, IMPACT, Mode
from ..model._oscillator import Oscillator
from ._frames import SolutionFramesMixin
from ._observables import elastic_impact_force

__all__ = ["Solution", "RECORD_OPTIONS", "EVENT_DTYPE", "IMPACT_DTYPE", "CONTACT_SUMS"]

RECORD_OPTIONS = ("full", "events", "stats")

#: The per-flange sums over contacts streamed in every recording mode (units of eq. 3), in
#: the order of the recorder's and the compiled loop's slots: see :meth:`Solution.contact_sums`.
CONTACT_SUMS = ("contacts", "entry_speed", "entry_speed_sq", "peak_force", "impulse", "impact_force", "dissipated")
(S_CONTACTS, S_SPEED, S_SPEED_SQ, S_PEAK, S_IMPULSE, S_IMPACT_FORCE, S_DISSIPATED) = range(len(CONTACT_SUMS))

EVENT_DTYPE = np.dtype([("t", "f8"), ("kind", "U13"), ("x", "f8"), ("v", "f8"), ("side", "i1"), ("count", "i8"),
                        ("direction", "i1")])
IMPACT_DTYPE = np.dtype(
    [
        ("start", "f8"),
        ("end", "f8"),
        ("side", "i1"),
        ("entry_velocity", "f8"),
        ("exit_velocity", "f8"),
        ("peak_penetration", "f8"),
        ("peak_force", "f8"),
        ("impulse", "f8"),
        ("complete", "?"),
    ]
)
SAMPLE_DTYPE = np.dtype([("t", "f8"), ("x", "f8"), ("v", "f8"), ("region", "i1"), ("motion", "i1")])
SEGMENT_DTYPE = np.dtype(
    [
        ("t", "f8"),
        ("x", "f8"),
        ("v", "f8"),
        ("region", "i1"),
        ("motion", "i1"),
        ("armed", "?"),
        ("impulse_upper", "f8"),
        ("impulse_lower", "f8"),
    ]
)

#: Evaluates one smooth piece: (mode, t_start, x_start, v_start, times) -> (x, v, impulse).
PieceEvaluator = Callable[[Mode, float, float, float, np.ndarray], tuple]

_T = TypeVar("_T")


def _kept(value: _T | None, what: str) -> _T:
    """``value``, which the recording mode keeps; its caller has checked that mode (``Solution._need``).

    ``None`` here is a broken invariant (a table the mode keeps was not recorded), not a
    user error, hence the ``RuntimeError``.
    """
    if value is None:
        raise RuntimeError(f"Solution: {what} was not recorded although this run's record mode keeps it")
    return value


class _Recorder:
    """Streams a run into counters and, depending on ``record``, tables.

    The engine's driver loop calls ``begin``, then ``piece``/``event``/``segment`` as the
    run proceeds, then ``finish``; a run replayed from another event loop can hand over all
    its pieces and events at once (``begin``, :func:`impactosc.results._bulk.bulk`, ``finish``:
    the same records and sums). Only the tables asked for grow with the run.
    """

    def __init__(self, record: str, backend: str, evaluator: PieceEvaluator | None):
        self.record = record
        self.backend = backend
        self.evaluator = evaluator
        self.keep_events = record != "stats"
        self.keep_segments = record == "full"
        self.events: list[tuple] = []
        self.impacts: list[tuple] = []
        self.segments: list[tuple] = []
        # _bulk.bulk keeps the events and piece starts as structured arrays (with those of the lists before)
        self.event_array: np.ndarray | None = None
        self.segment_array: np.ndarray | None = None
        # and the contacts it closed with their dissipated energies (those closed after it, by finish, follow in
        # impacts and dissipated)
        self.impact_array: np.ndarray | None = None
        self.dissipated_array: np.ndarray | None = None
        self.counts = dict.fromkeys(EVENT_KINDS, 0)
        self.entries = {1: 0, -1: 0}
        self.n_events = 0
        self.impulse = {1: 0.0, -1: 0.0}
        self.impulse_sq = {1: 0.0, -1: 0.0}
        self.contact_time = {1: 0.0, -1: 0.0}
        self.max_pen = {1: 0.0, -1: 0.0}
        # The peak wall push of a rigid flange (a spring's peak force follows max_pen). Not yet
        # streamed: the compiled exact loop must stream it too (see the tests).
        self.max_force = {1: 0.0, -1: 0.0}
        self.forcing_work = 0.0
        self.slip_path = 0.0
        self.v_squared = 0.0  # int V^2: the damping loss is 2 zeta times it
        self.impact_loss = 0.0  # sum (1 - e^2) V^2 / 2 over rigid impacts
        self.rigid = False
        self.steps = 0
        self.pieces = 0
        self._open: list | None = None  # [start, side, entry_v, peak_pen, impulse, complete]
        # The open contact's slip path and int V^2 (its friction and damping losses).
        self._open_loss = [0.0, 0.0]
        # Sums over the contacts per flange (CONTACT_SUMS), and each contact's dissipated
        # energy beside the impact rows when they are kept.
        self.contact_sums = {1: [0.0] * len(CONTACT_SUMS), -1: [0.0] * len(CONTACT_SUMS)}
        self.dissipated: list[float] = []
        self.streamed_pieces = False  # piece() was called: the contact sums saw the contacts' insides
        self.samples: list[tuple] = []  # exact states at the requested sample times
        self.tails: list = []  # chatter jumps, for dense output inside their tails

    def begin(self, osc: Oscillator, t: float, x: float, v: float, mode: Mode) -> None:
        self.osc = osc
        self.rigid = osc.rigid
        self.t0, self.x0, self.v0, self.mode0 = t, x, v, mode
        if mode.region != 0:
            # A run that starts inside a flange: a contact in progress, not an event.
            self._open = [t, mode.region, v, mode.region * x - osc.gap(mode.region), 0.0, False]
            self._open_loss = [0.0, 0.0]
        self.segment(t, x, v, mode)

    def piece(self, mode: Mode, t0: float, x0: float, t1: float, x1: float,
              q: float, q2: float, w: float, vv: float, steps: int) -> None:
        r = mode.region
        if r != 0 and self.rigid:
            # Resting against a rigid wall: the wall's force is the push it takes.
            q, q2, peak = self.osc.wall_force_integrals(r, t0, t1)
            self.impulse[r] += q
            self.impulse_sq[r] += q2
            self.contact_time[r] += t1 - t0
            self.max_force[r] = max(self.max_force[r], peak)
            if self._open is not None:
                self._open[4] += q
                self._open[3] = max(self._open[3], peak)
        elif r != 0:
            self.impulse[r] += q
            self.impulse_sq[r] += q2
            self.contact_time[r] += t1 - t0
            # Pieces are monotonic in X, so the deepest point of a piece is at an end.
            pen = max(r * x0, r * x1) - self.osc.gap(r)
            if pen > self.max_pen[r]:
                self.max_pen[r] = pen
            op = self._open
            if op is not None:
                op[4] += q
                if pen > op[3]:
                    op[3] = pen
                if mode.motion != 0:
                    self._open_loss[0] += abs(x1 - x0)
                self._open_loss[1] += vv
        if mode.motion != 0:
            self.slip_path += abs(x1 - x0)
        self.forcing_work += w
        self.v_squared += vv
        self.steps += steps
        self.pieces += 1
        self.streamed_pieces = True

    def event(self, t: float, kind: str, x: float, v: float, side: int, count: int = 1, direction: int = 0) -> None:
        self.counts[kind] += 1
        self.n_events += 1
        if self.keep_events:
            self.events.append((t, kind, x, v, side, count, direction))
        if kind == CONTACT_START:
            self.entries[side] += 1
            self._open = [t, side, v, 0.0, 0.0, True]
            self._open_loss = [0.0, 0.0]
        elif kind == CONTACT_END and self._open is not None:
            self._close(t, v)
        elif kind == IMPACT:
            # A rigid flange's impact: impulse (1 + e)|V|, kinetic energy (1 - e^2) V^2 / 2 lost.
            e = self.osc.restitution
            impulse = (1.0 + e) * abs(v)
            self.entries[side] += 1
            self.impulse[side] += impulse
            loss = 0.5 * (1.0 - e * e) * v * v
            self.impact_loss += loss
            self._add_contact(side, v, math.inf, impulse, math.inf, loss)
            if self.keep_events:
                self.impacts.append((t, t, side, v, -e * v, 0.0, math.inf, impulse, True))
                self.dissipated.append(loss)

    def chatter(self, jump, t: float) -> tuple[float, float, int]:
        """Add the resolved tail of a chatter (``impactosc._chatter.ChatterJump``) up to ``t``.

        ``t`` is the accumulation time, where the ``chatter`` event is recorded (its
        ``count`` is the number of impacts followed one by one), or the end of the run when
        that comes first: then only the impacts and flights of the tail before ``t`` are
        added. The forcing works on the tail's net displacement (zero at the accumulation
        time). Returns the local model's ``(x, v, motion)`` at ``t``.
        """
        side = jump.side
        if self.keep_segments:
            self.tails.append(jump)
        x, v, motion, impulse, path, loss = jump.state_at(t)
        self.impulse[side] += impulse
        self.slip_path += path
        self.impact_loss += loss
        # The tail starts and ends on the wall (at jump.wall = side * gap, not at +-1).
        self.forcing_work += self.osc._forcing_scalar(jump.t0) * (x - jump.wall)
        if t >= jump.t_inf:
            self.event(jump.t_inf, CHATTER, jump.wall, 0.0, side, jump.impacts, 0)
        return x, v, motion

    def _close(self, t: float, v: float) -> None:
        start, side, v_in, pen, imp, complete = _kept(self._open, "the open contact being closed")
        osc = self.osc
        if self.rigid:
            peak, pen = pen, 0.0  # a resting contact keeps its peak wall force in the slot
            impact_force = loss = 0.0  # at rest on the wall: no impact, nothing dissipated
        else:
            pen = max(pen, 0.0)
            peak = osc.K * pen**osc.exponent
            impact_force = elastic_impact_force(osc.K, osc.exponent, v_in)
            # Friction times the slip path and damping 2 zeta int V^2 over the contact's pieces.
            loss = osc.beta * self._open_loss[0] + 2.0 * osc.zeta * self._open_loss[1]
        self._add_contact(side, v_in, peak, imp, impact_force, loss)
        if self.keep_events:
            self.impacts.append((start, t, side, v_in, v, pen, peak, imp, complete))
            self.dissipated.append(loss)
        self._open = None

    def _add_contact(self, side: int, v_in: float, peak: float, impulse: float, impact_force: float,
                     loss: float) -> None:
        """Add one contact (a row of the impact table) to its flange's :data:`CONTACT_SUMS`."""
        sums = self.contact_sums[side]
        speed = abs(v_in)
        sums[S_CONTACTS] += 1.0
        sums[S_SPEED] += speed
        sums[S_SPEED_SQ] += speed * speed
        sums[S_PEAK] += peak
        sums[S_IMPULSE] += impulse
        sums[S_IMPACT_FORCE] += impact_force
        sums[S_DISSIPATED] += loss

    def sample(self, t: float, x: float, v: float, mode: Mode) -> None:
        """The exact state at a requested sample time (a time event of the run)."""
        self.samples.append((t, x, v, mode.region, mode.motion))

    def segment(self, t: float, x: float, v: float, mode: Mode) -> None:
        if self.keep_segments:
            self.segments.append((t, x, v, mode.region, mode.motion, mode.armed,
                                  self.impulse[1], self.impulse[-1]))

    def finish(self, t: float, x: float, v: float, mode: Mode, status: int, message: str) -> None:
        if self._open is not None:
            self._open[5] = False
            self._close(t, math.nan)
        self.t_final, self.x_final, self.v_final, self.mode_final = t, x, v, mode
        self.status, self.message = status, message


class Solution(SolutionFramesMixin):
    """The result of :func:`impactosc.simulate`.

    Attributes
    ----------
    oscillator : Oscillator
        The model that was run.
    backend : str
        Name of the backend that produced the result.
    t_end : float
        Requested end time; ``t_final`` is the time actually reached.
    t_final, x_final, v_final : float
        Final time and state.
    final_mode : tuple
        The hybrid mode at ``t_final``, an ``impactosc.Mode(region, motion, armed)``:
        ``region`` -1/0/+1 (in the lower flange, free, in the upper flange; with a rigid
        flange +-1 means at rest against that wall), ``motion`` -1/0/+1 (slipping down,
        stuck, slipping up) and ``armed`` (False just after a release, until the
        acceleration changes sign).
    status : int
        0: ``t_end`` was reached; 1: a limit set by the caller was reached,
        ``max_events`` or the heyoka backend's ``max_wall_time`` (results up to
        ``t_final`` are kept); -1: the integration failed (see ``message``).
    samples : numpy.recarray
        The exact states at the times asked for with ``simulate(..., sample_at=...)``:
        fields ``t, x, v, region, motion`` (time events of the run, not interpolations).
    message : str
        Human-readable reason for ``status``.
    counts : dict
        Number of events of each kind (``contact_start``, ``contact_end``, ``reversal``,
        ``stick``, ``release``, and with a rigid flange ``impact`` and ``chatter``), counted
        in every recording mode.
    forcing_work, friction_work, damping_work, impact_loss : float
        The terms of the energy identity over the run (see :meth:`energy_balance`).
    record : str
        What was kept: ``"full"``, ``"events"`` or ``"stats"``.
    """

    def __init__(self, rec: _Recorder, t_end: float):
        self.oscillator = rec.osc
        self.backend = rec.backend
        self.record = rec.record
        self.t_end = t_end
        self.t0, self.x0, self.v0 = rec.t0, rec.x0, rec.v0
        self.t_final, self.x_final, self.v_final = rec.t_final, rec.x_final, rec.v_final
        self.final_mode = rec.mode_final
        self.status, self.message = rec.status, rec.message
        self.counts = dict(rec.counts)
        self.n_steps, self.n_pieces = rec.steps, rec.pieces
        self.forcing_work = rec.forcing_work
        self.friction_work = self.oscillator.beta * rec.slip_path
        self.damping_work = 2.0 * self.oscillator.zeta * rec.v_squared
        self.impact_loss = rec.impact_loss
        self._entries = dict(rec.entries)
        self._impulse = dict(rec.impulse)
        self._impulse_sq = dict(rec.impulse_sq)
        self._contact_time = dict(rec.contact_time)
        self._max_pen = dict(rec.max_pen)
        self._max_force = dict(rec.max_force)
        # The contact sums hold only where the backend streamed its pieces through the recorder
        # (rk4 hands over its own totals and rows): else None, and the impact table decides.
        contacts = sum(rec.contact_sums[s][S_CONTACTS] for s in (1, -1)) + sum(rec.entries.values())
        streamed = rec.streamed_pieces or contacts == 0
        self._contact_sums = {s: tuple(rec.contact_sums[s]) for s in (1, -1)} if streamed else None
        impacts: list | np.ndarray = rec.impacts
        dissipated: list | np.ndarray = rec.dissipated
        if rec.impact_array is not None and rec.dissipated_array is not None:  # _bulk.bulk's, then finish's
            impacts = np.concatenate([rec.impact_array, np.array(rec.impacts, dtype=IMPACT_DTYPE)]) if rec.impacts \
                else rec.impact_array
            dissipated = np.concatenate([rec.dissipated_array, rec.dissipated]) if rec.dissipated \
                else rec.dissipated_array
        self._dissipated = (np.array(dissipated, dtype=float)
                            if streamed and rec.keep_events and len(dissipated) == len(impacts) else None)
        self._evaluator = rec.evaluator
        events = rec.events if rec.event_array is None else rec.event_array
        self._events = _records(events, EVENT_DTYPE) if rec.keep_events else None
        self._impacts = _records(impacts, IMPACT_DTYPE) if rec.keep_events else None
        segments = rec.segments if rec.segment_array is None else rec.segment_array
        self._segments = np.asarray(segments, dtype=SEGMENT_DTYPE) if rec.keep_segments else None
        self._tails = tuple(rec.tails)
        self.samples = (np.rec.array(rec.samples, dtype=SAMPLE_DTYPE) if len(rec.samples)
                        else np.recarray((0,), dtype=SAMPLE_DTYPE))

    # -- status ------------------------------------------------------------------------
    @property
    def success(self) -> bool:
        """True when the run reached ``t_end``."""
        return self.status == 0

    def __repr__(self) -> str:
        return (f"Solution(backend={self.backend!r}, status={self.status}, t_final={self.t_final:.6g}, "
                f"counts={self.counts})")

    # -- tables ------------------------------------------------------------------------
    def _need(self, level: str, what: str) -> None:
        order = RECORD_OPTIONS.index
        if order(self.record) > order(level):
            raise ValueError(f"{what} needs record={level!r} or more, but this run used "
                             f"record={self.record!r}; rerun simulate(..., record={level!r})")

    @property
    def events(self) -> np.recarray:
        """One record per event: fields ``t, kind, x, v, side, count, direction``.

        ``x, v`` are the state at the event, after it, except at an ``impact``, whose ``v``
        is the velocity *before* the impact (the one after it is ``-e v``: see
        ``impacts``). ``side`` is +1/-1 at a flange, 0 otherwise. ``count`` is 1, except
        for a ``chatter`` event: the number of impacts of the sequence followed one by one
        before the jump to their accumulation point (the infinitely many remaining ones are
        not events). ``direction`` is the motion after the event: +1 slipping up, -1 slipping
        down, 0 at rest (after a ``stick``, a ``chatter`` or a rest on a rigid wall); after a
        ``release`` or a ``reversal`` it is the direction the mass slips in. The initial
        state is not an event: a run that starts stuck, inside a flange or at rest against a
        rigid wall records none at ``t = 0``; what follows it does (an impact at ``t = 0``).
        """
        self._need("events", "Solution.events")
        return _kept(self._events, "the event table")

    @property
    def impacts(self) -> np.recarray:
        """One row per contact: ``start, end, side, entry_velocity, exit_velocity,
        peak_penetration, peak_force, impulse, complete``.

        Forces are in units of ``k L`` and follow the member's flange law. A spring flange:
        ``peak_force = K * peak_penetration**p`` (``p`` the ``exponent``) and ``impulse`` the
        integral of ``K d^p`` over the contact. A rigid flange: an impact is a row with
        ``start == end``, ``peak_penetration`` 0, ``peak_force`` inf and ``impulse``
        ``(1 + e)|V|``; a mass resting against the wall is a row with ``peak_penetration``
        0, ``peak_force`` the wall's peak push and ``impulse`` the integral of the push.
        ``complete`` is False for a contact in progress at the start or end of the run
        (then ``exit_velocity`` is NaN if it had not ended).
        """
        self._need("events", "Solution.impacts")
        return _kept(self._impacts, "the impact table")

    # -- contact statistics, streamed in every recording mode -----------------------------
    @staticmethod
    def _sides(side) -> tuple[int, ...]:
        if side is None:
            return (1, -1)
        if isinstance(side, bool) or side not in (1, -1):
            raise ValueError(f"side must be +1 (upper flange), -1 (lower flange) or None (both), got {side!r}")
        return (int(side),)

    def contact_entries(self, side: int | None = None) -> int:
        """Number of contacts that started during the run on ``side`` (+1, -1, or None for both)."""
        return sum(self._entries[s] for s in self._sides(side))

    def contact_sums(self, side: int | None = None) -> dict[str, float]:
        """Sums over the contacts of ``side`` (+1, -1, or None for both), streamed in every recording mode.

        One term per row of :attr:`impacts` (contacts that started in the run, and one in
        progress at its start), in the units of eq. 3, so that
        :func:`impactosc.results.contact_observables` needs no table and a sweep
        (``record="stats"``) can report per-impact means and rates:

        ``contacts`` (their number), ``entry_speed`` (``sum |V_in|``), ``entry_speed_sq``
        (``sum V_in^2``, twice the kinetic energy brought in), ``peak_force`` (``sum K d_max^p``;
        inf with a rigid impact), ``impulse`` (``sum`` of the contacts' impulses; a chatter's
        accumulated tail is in :meth:`flange_impulse` but in no row), ``impact_force`` (``sum``
        of :func:`impactosc.results.elastic_impact_force` of the entry speeds; inf with a rigid
        impact) and ``dissipated`` (``sum`` of the energy each contact took: ``(1 - e^2) V^2/2``
        per rigid impact; for a spring flange ``beta`` times the slip path plus ``2 zeta int V^2``
        over the contact's pieces, the friction and damping terms of :meth:`energy_balance`
        restricted to the contact, as exact as the backend's own integrals).

        Raises
        ------
        ValueError
            A run whose backend did not stream its pieces through the recorder (``rk4``)
            and had contacts: use :func:`impactosc.results.contact_table` of a
            ``record="events"`` run instead.

        Examples
        --------
        >>> import impactosc
        >>> osc = impactosc.Oscillator(F=0.0, Omega=1.0, beta=0.0, K=1e4)
        >>> sol = impactosc.simulate(osc, 3.0, 0.0, 2.0, backend="exact", record="stats")
        >>> sums = sol.contact_sums(1)
        >>> sums["contacts"], round(sums["entry_speed"] / sums["contacts"], 6)   # V_in = sqrt(2^2 - 1)
        (2.0, 1.732051)
        """
        sides = self._sides(side)
        if self._contact_sums is None:
            raise ValueError(f"contact_sums: the {self.backend} backend does not stream the insides of its "
                             "contacts; use impactosc.results.contact_table(sol) of a run with record='events'")
        return {name: sum(self._contact_sums[s][i] for s in sides) for i, name in enumerate(CONTACT_SUMS)}

    def contact_time(self, side: int | None = None) -> float:
        """Total time spent in contact with ``side``: a spring flange compressed, or resting on a rigid one."""
        return sum(self._contact_time[s] for s in self._sides(side))

    def max_penetration(self, side: int | None = None) -> float:
        """Deepest penetration ``max(|X| - 1)`` into ``side`` over the run (0 without contact, or rigid)."""
        return max(self._max_pen[s] for s in self._sides(side))

    def max_flange_force(self, side: int | None = None) -> float:
        """Peak flange force over the run, in units of ``k L``, by the member's flange law.

        A spring flange: ``K * max_penetration**p`` (``p`` the ``exponent``; the law grows
        with the penetration, so this is its peak). A rigid flange: the peak of the wall's
        push on a mass resting against it; its impacts are impulses (in
        :meth:`flange_impulse`, and rows with ``peak_force`` inf in :attr:`impacts`), not
        counted here. 0 without contact.
        """
        osc = self.oscillator
        sides = self._sides(side)
        if osc.rigid:
            return max(self._max_force[s] for s in sides)
        pen = self.max_penetration(side)
        return osc.K * (pen if osc.exponent == 1.0 else pen**osc.exponent)

    def rms_flange_force(self, side: int | None = None) -> float:
        """Root mean square of the flange force over the whole run, in units of ``k L``.

        The force of the member's flange law (see :meth:`max_flange_force`); the impulses of
        a rigid flange's impacts have no finite square and are left out. NaN for a run of
        zero duration (one that failed at its start, see ``status``).
        """
        dur = self.t_final - self.t0
        sq = sum(self._impulse_sq[s] for s in self._sides(side))
        return math.sqrt(sq / dur) if dur > 0 else math.nan

    def flange_impulse(self, side: int | None = None, t0: float | None = None,
                       t1: float | None = None) -> float:
        """Integral of the flange force over ``[t0, t1]`` (default: the whole run), in units of ``k L``.

        The force of the member's flange law: ``K d^p`` on the penetration ``d = (|X| - 1)+``
        of a spring flange; for a rigid flange the wall's push on a mass resting against it
        plus the impulses ``(1 + e)|V|`` of the impacts in the window. ``side`` is +1 (upper
        flange), -1 (lower) or None (both). Exact integrals, not sums of samples.
        """
        sides = self._sides(side)
        if t0 is None and t1 is None:  # the whole run, also one of zero duration
            return sum(self._impulse[s] for s in sides)
        t0, t1 = self._window(t0, t1)
        if t0 == self.t0 and t1 == self.t_final:
            return sum(self._impulse[s] for s in sides)
        self._need("full", "a flange impulse over a partial window")
        return sum(self._cumulative_impulse(s, t1) - self._cumulative_impulse(s, t0) for s in sides)

    def mean_flange_force(self, side: int | None = None, t0: float | None = None,
                          t1: float | None = None) -> float:
        """Time average of the flange force over ``[t0, t1]``, in units of ``k L``.

        The force is that of :meth:`flange_impulse` (the member's flange law). This is
        the quantity the paper averages over 1 s (its Fig. 7 and 8). ``side`` is
        +1 (upper flange), -1 (lower) or None (both). The default window is the whole run;
        on a run of zero duration (one that failed at its start, see ``status``) the
        average over it is NaN. It is computed from the exactly integrated impulse, not
        from samples.
        """
        self._sides(side)  # a bad side is an error even on an empty run
        if t0 is None and t1 is None and not self.t_final > self.t0:
            return math.nan
        lo, hi = self._window(t0, t1)
        return self.flange_impulse(side, lo, hi) / (hi - lo)

    def _window(self, t0, t1) -> tuple[float, float]:
        lo = self.t0 if t0 is None else _v.real("t0", t0)
        hi = self.t_final if t1 is None else _v.real("t1", t1)
        if not (self.t0 <= lo < hi <= self.t_final):
            raise ValueError(f"the window [t0, t1] must satisfy {self.t0!r} <= t0 < t1 <= t_final={self.t_final!r}, "
                             f"got t0={lo!r}, t1={hi!r}")
        return lo, hi

    # -- dense output ------------------------------------------------------------------
    def _segment_index(self, t: np.ndarray) -> np.ndarray:
        return np.searchsorted(_kept(self._segments, "the piece starts")["t"], t, side="right") - 1

    def _evaluate(self, t: np.ndarray):
        """State and piece impulse at times ``t`` (already validated to lie in the run).

        Each distinct time is evaluated once: repeated times are legitimate input, and the
        backends re-integrate on strictly increasing grids.
        """
        t, where = np.unique(t, return_inverse=True)
        where = where.reshape(-1)
        x, v, q, k = self._evaluate_distinct(t)
        return x[where], v[where], q[where], k[where]

    def _evaluate_distinct(self, t: np.ndarray):
        seg = _kept(self._segments, "the piece starts")
        k = self._segment_index(t)
        x = np.empty_like(t)
        v = np.empty_like(t)
        q = np.zeros_like(t)
        at_start = t == seg["t"][k]
        x[at_start] = seg["x"][k[at_start]]
        v[at_start] = seg["v"][k[at_start]]
        at_end = t == self.t_final
        for j in np.unique(k[~at_start & ~at_end]):
            sel = (k == j) & ~at_start & ~at_end
            s = seg[j]
            mode = Mode(int(s["region"]), int(s["motion"]), bool(s["armed"]))
            evaluator = _kept(self._evaluator, "the piece evaluator")
            xs, vs, qs = evaluator(mode, float(s["t"]), float(s["x"]), float(s["v"]), t[sel])
            x[sel], v[sel], q[sel] = xs, vs, qs
        for jump in self._tails:
            # Inside the tail of a chatter the last flight's piece would run through the wall:
            # the jump's local model holds the motion there.
            for i in np.flatnonzero((t > jump.t0) & (t < jump.t_inf) & ~at_end):
                x[i], v[i] = jump.state_at(float(t[i]))[:2]
        if np.any(at_end & ~at_start):
            # The run's final state; the impulse of its last piece from the stored totals.
            last = seg[k[at_end][0]]
            r = int(last["region"])
            cum = float(last["impulse_upper" if r == 1 else "impulse_lower"]) if r else 0.0
            x[at_end & ~at_start], v[at_end & ~at_start] = self.x_final, self.v_final
            q[at_end & ~at_start] = self._impulse[r] - cum if r else 0.0
        return x, v, q, k

    def sample(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Position and velocity ``(X, V)`` at the requested times.

        Exact at event times (the recorded event states); in between, each smooth piece
        is re-integrated by the backend that produced the run. Needs ``record="full"``.
        """
        t_arr = self._sample_times(t, "Solution.sample")
        x, v, _, _ = self._evaluate(t_arr)
        if np.ndim(t) == 0:
            return x[0], v[0]
        return x, v

    def _sample_times(self, t, what: str) -> np.ndarray:
        """``t`` as a 1-d float array, checked to lie in the run (which must be recorded in full)."""
        self._need("full", what)
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        if t_arr.size and (not np.all(np.isfinite(t_arr)) or t_arr.min() < self.t0
                           or t_arr.max() > self.t_final):
            raise ValueError(f"sample times must be finite and within [{self.t0!r}, t_final={self.t_final!r}], "
                             f"got values in [{t_arr.min()!r}, {t_arr.max()!r}]")
        return t_arr

    def flange_force(self, t):
        """Magnitude of the flange force at times ``t``, in units of ``k L``. Needs ``record="full"``.

        The member's flange law at the state of :meth:`sample`: ``K d^p`` on the penetration
        ``d = (|X| - 1)+`` of a spring flange; for a rigid flange the wall's push on a mass
        resting against it (``max(side f_net, 0)``, see
        :meth:`Oscillator.wall_force_integrals`)
        and 0 in flight (its impacts are impulses, see :meth:`flange_impulse`).
        """
        t_arr = self._sample_times(t, "Solution.flange_force")
        x, _, _, k = self._evaluate(t_arr)
        force = self._force_at(t_arr, x, k)
        return force[0] if np.ndim(t) == 0 else force

    def _force_at(self, t: np.ndarray, x: np.ndarray, k: np.ndarray) -> np.ndarray:
        """The flange force at times ``t`` with states ``x`` on the pieces ``k`` (see :meth:`flange_force`)."""
        osc = self.oscillator
        if not osc.rigid:
            return osc.flange_force(x)
        region = _kept(self._segments, "the piece starts")["region"][k].astype(float)
        resting = region != 0.0
        force = np.zeros_like(t)
        if np.any(resting):
            r = region[resting]
            force[resting] = np.maximum(r * osc.net_force(t[resting], r), 0.0)
        return force

    def _cumulative_impulse(self, side: int, t: float) -> float:
        if t == self.t_final:
            return self._impulse[side]
        t_arr = np.array([t])
        _, _, q, k = self._evaluate(t_arr)
        seg = _kept(self._segments, "the piece starts")[k[0]]
        cum = float(seg["impulse_upper" if side == 1 else "impulse_lower"])
        if int(seg["region"]) == side and self.oscillator.rigid:
            # Resting against a rigid wall: the piece evaluators know no wall force (the
            # recorder integrates the wall's push per piece); integrate it up to t the same way.
            cum += self.oscillator.wall_force_integrals(side, float(seg["t"]), t)[0]
        elif int(seg["region"]) == side:
            cum += float(q[0])
        for jump in self._tails:  # the impacts of a chatter tail before t
            if jump.side == side and jump.t0 < t < jump.t_inf:
                cum += jump.state_at(t)[3]
        return cum

    # -- what a flange sensor sees (results/_observables.py) -----------------------------
    def contact_observables(self, drive=None) -> dict:
        """Impact rate, per-impact means, mean and rms force, AE proxies per flange (SI with ``drive``).

        See :func:`impactosc.results.contact_observables` for the definitions.
        """
        from ._observables import contact_observables

        return contact_observables(self, drive)

    # -- energy ------------------------------------------------------------------------
    def energy_balance(self) -> dict[str, float]:
        """The terms of the energy identity over the run, and its residual.

        ``E(t_final) - E(t0) = W_forcing - beta path - 2 zeta int V^2 - sum (1 - e^2) V_impact^2 / 2``
        with ``E = V^2/2 + X^2/2 + K d^(p+1)/(p+1)`` (:meth:`Oscillator.energy`). Every term is
        integrated by the backend (or summed by the engine at impacts), independently of
        ``E``, so a small ``residual`` checks the run.

        Returns
        -------
        dict
            ``energy_start``, ``energy_end``, ``forcing_work``, ``friction_work`` (kinetic
            ``beta`` times the slip path), ``damping_work``, ``impact_loss``, ``residual``
            (left side minus right side) and ``scale`` (the largest term, to judge it by).
        """
        osc = self.oscillator
        e0 = float(osc.energy(self.x0, self.v0))
        e1 = float(osc.energy(self.x_final, self.v_final))
        terms = {"energy_start": e0, "energy_end": e1, "forcing_work": self.forcing_work,
                 "friction_work": self.friction_work, "damping_work": self.damping_work,
                 "impact_loss": self.impact_loss}
        terms["residual"] = (e1 - e0) - (self.forcing_work - self.friction_work - self.damping_work
                                         - self.impact_loss)
        terms["scale"] = max(abs(v) for v in terms.values())
        return terms

    # -- reports -----------------------------------------------------------------------
    def summary(self) -> str:
        """One line: backend, status, event counts and mean flange force per flange.

        A run that did not reach ``t_end`` adds its ``message``.
        """
        c = self.counts
        line = (f"[{self.backend}] t_final={self.t_final:.6g} status={self.status}: "
                f"{self.contact_entries(1)} upper / {self.contact_entries(-1)} lower contacts, "
                f"{c['reversal']} reversals, {c['stick']} sticks, {c['release']} releases; "
                f"mean flange force upper={self.mean_flange_force(1):.6g} "
                f"lower={self.mean_flange_force(-1):.6g} (units of kL)")
        return line if self.status == 0 else f"{line}; {self.message}"

    def event_table(self, limit: int | None = 20) -> str:
        """The event list as fixed-width text (the first ``limit`` rows; None for all)."""
        ev = self.events
        rows = [f"{'t':>14} {'kind':<14} {'x':>12} {'v':>12} {'side':>4}"]
        for e in ev[:_check_limit(limit)]:
            rows.append(f"{_cell(e.t, 14, 8)} {e.kind:<14} {_cell(e.x, 12, 8)} {_cell(e.v, 12, 8)} {e.side:4d}")
        if limit is not None and len(ev) > limit:
            rows.append(f"... {len(ev) - limit} more events")
        return "\n".join(rows)

    def impact_table(self, limit: int | None = 20) -> str:
        """The impact list as fixed-width text (the first ``limit`` rows; None for all)."""
        im = self.impacts
        rows = [f"{'start':>12} {'end':>12} {'side':>4} {'v_in':>10} {'v_out':>10} "
                f"{'penetration':>12} {'peak force':>11} {'impulse':>10}"]
        for i in im[:_check_limit(limit)]:
            rows.append(f"{_cell(i.start, 12, 6)} {_cell(i.end, 12, 6)} {i.side:4d} "
                        f"{_cell(i.entry_velocity, 10, 6)} {_cell(i.exit_velocity, 10, 6)} "
                        f"{i.peak_penetration:12.4e} {_cell(i.peak_force, 11, 6)} {_cell(i.impulse, 10, 6)}")
        if limit is not None and len(im) > limit:
            rows.append(f"... {len(im) - limit} more impacts")
        return "\n".join(rows)


def _check_limit(limit) -> int | None:
    """``limit`` of the tables: None (all rows) or an integer >= 0."""
    return None if limit is None else _v.integer("limit", limit, minimum=0)


def _cell(value: float, width: int, decimals: int) -> str:
    """``value`` in fixed point in ``width`` characters, or in scientific notation if it does not fit."""
    text = f"{value:{width}.{decimals}f}"
    if len(text) > width:
        text = f"{value:{width}.{max(width - 8, 0)}e}"
    return text


def _records(rows, dtype: np.dtype) -> np.recarray:
    """A table as a record array: from a structured array (``_bulk.bulk``, the exact loop) or a list of tuples."""
    if isinstance(rows, np.ndarray):
        return np.asarray(rows, dtype=dtype).view(np.recarray)
    return np.rec.array(rows, dtype=dtype) if len(rows) else np.recarray((0,), dtype=dtype)

