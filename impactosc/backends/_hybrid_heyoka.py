"""The heyoka event loop for user hybrid systems: one compiled integrator per system, transitions in callbacks.

The integrator
--------------
One ``taylor_adaptive`` per system structure and tolerance (cached, reused across runs and
parameter values). Its runtime parameters are the system's parameters, one indicator per
mode and one switch ``on`` for the events::

    pars = [p_1 .. p_P, [mode == 1] .. [mode == M], on]
    y'   = sum_m [mode == m] f_m(y, t; p)          (modes with the same rate share its term)

Every guard ``h`` is a terminal event ``a h + (1 - a)`` gated by ``a = on * sum of the
indicators of the modes that arm it`` (the constant 1, which has no root, where it is not
armed), filtered by its direction, so heyoka locates it on each step's Taylor polynomial.
A guard's extrema are where its Lie derivative ``h' = dh/dt + grad h . f`` vanishes; that
derivative, gated the same way, is a second terminal event (minima for a guard that fires
falling, maxima for one that fires rising): at each the guard's value is checked, so a
guard that touches zero without changing sign (a grazing) is recorded, and one that went
past zero and back without a located root (a double root lost to rounding) is applied at
its first root, found on the piece again (:func:`_first_root`).

Events are shared: guards and extremum checks with the same expression and direction are
one event whatever the modes, and events armed in disjoint sets of modes are merged into
one whose expression is the active mode's (a gated sum, like the vector field). A step
then isolates the roots of a few polynomials (eq. 3 with friction and two spring flanges:
4 events for its 16 guards and their extremum checks), and the callback dispatches on the mode.

The loop
--------
The whole run is one ``propagate_until``: each terminal event's callback applies the
transition (the engine's :class:`~impactosc.engine._hybrid.Switch`: reset, entry
conditions, a guard the new state lies on), writes the new state and two indicators, and
records the event, in a few microseconds of Python per event. A callback that returns
False stops the run: the event limit, an accumulation of events, a failed transition.

Frozen modes
------------
In a *frozen* mode every state's rate is identically zero (a mass stuck by friction):
heyoka would step through it a fraction of a forcing period at a time, for ever if it
never ends. With a forcing period ``T`` its guards are functions of the time alone,
periodic with ``T``, and their extrema recur every period (extremum checks, above): the
callbacks of the events armed in a frozen mode then also call a watch
(:class:`_FrozenWatch`), which notes the first call and, at a call a period or more later
with no event in between, stops the propagation; none will ever fire, and the loop jumps to
the last whole period before ``t_end`` (:func:`~impactosc.engine._hybrid.period_jump`, the
integrals moved on by whole periods' increments, one period integrated again) and integrates
the rest. A stuck phase of any length costs at most about three periods of steps, and the
loop pays nothing elsewhere. A frozen mode with no event that depends on the time gets a
tick of its own, ``sin(2 pi t / T)`` rising through zero, in a shared event.

``max_wall_time`` splits the one ``propagate_until`` into calls of at most
:data:`WALL_TIME_STEPS` steps and checks the clock between them: heyoka's steps do not
depend on the previous one, so the run is the same, step for step.
"""

from __future__ import annotations

import math
import threading
import time
from contextlib import contextmanager

import numpy as np

from .._util import validation as _v
from .._util.cache import BuiltOnce
from .._util.heyoka_log import log_on_stderr, root_finding_muted
from .._util.notice import notice
from ..engine._hybrid import (
    CROSSING,
    GRAZING,
    MARKER,
    START_NUDGE,
    TIE,
    Accumulation,
    InstantAccumulation,
    Switch,
    check_state,
    frozen_dense,
    frozen_modes,
    period_jump,
    usable_period,
)
from ..model.hybrid._definition import HybridSystem
from ..model.hybrid._numeric import Numeric, gated_sum, numeric
from ..results._hybrid import STATUS_MESSAGES, HybridSolution

__all__ = ["run_system", "run_counted", "compiled", "CompiledSystem", "dense_states", "WALL_TIME_STEPS"]

DEFAULT_TOL = 2.0**-52
#: The usable tolerances (those of the built-in heyoka backend: below eps nothing improves while
#: the Taylor order and the compile time grow; above 1e-2 events are off by more than 1e-3).
MIN_TOL, MAX_TOL = 1e-18, 1e-2
#: How long (in the system's time unit) an event is ignored after it fired: longer than the
#: rounding roots a reset leaves next to the surface (a ball bounced off ``x = 0`` restarts at
#: ``x ~ 1e-17``: a spurious root ``1e-17 / v`` later, which also defeats heyoka's polynomial
#: root isolation), far shorter than the intervals of an accumulation when it is declared
#: (``zeno_tol``). heyoka's automatic cooldown is not used: it grows like ``1 / |h'|`` and, at
#: the double root of a release from sticking, hid the next genuine stop for seconds.
DEFAULT_COOLDOWN = 1e-12
#: Integrator steps between two looks at the clock when a run has ``max_wall_time`` (~1 us a step:
#: the limit is overrun by ~10 ms at most; each look costs one more ``propagate_until`` call, ~5 us).
WALL_TIME_STEPS = 10_000


class _Holder:
    """The run that the callbacks of a cached integrator serve (one at a time per thread's integrator)."""

    __slots__ = ("run",)

    def __init__(self):
        self.run = None


class _Callback:
    """The callback of one heyoka event (a slot): the guard crossing and the extremum checks it stands for.

    ``cross[mode]`` is the guard that crosses when the slot's expression has its root in
    ``mode``; ``extrema[mode]`` the guards whose extremum it is there (their values are
    checked first). heyoka copies callbacks deeply; ``__deepcopy__`` returns the object
    itself so that every copy reaches the same holder.
    """

    __slots__ = ("holder", "cross", "extrema")

    def __init__(self, holder: _Holder):
        self.holder = holder
        self.cross: dict[int, int] | list[int] = {}
        self.extrema: dict[int, list[int]] | list[list[int] | None] = {}

    def freeze(self, modes: int) -> _Callback:
        """Turn the dictionaries into lists indexed by mode (read at every event)."""
        cross, extrema = self.cross, self.extrema
        assert isinstance(cross, dict) and isinstance(extrema, dict)
        self.cross = [cross.get(m, -1) for m in range(modes)]
        self.extrema = [extrema.get(m) for m in range(modes)]
        return self

    def __deepcopy__(self, memo):
        return self

    def __call__(self, ta, d_sgn) -> bool:
        run = self.holder.run
        mode = run.mode
        g = self.cross[mode]
        checks = self.extrema[mode]
        if checks is not None:
            if not run.extremum(ta, checks):
                return False
            if run.mode != mode:
                return True
        return run.crossing(ta, g) if g >= 0 else True


class _FrozenWatch:
    """Watches the events of the frozen modes for a whole period without a transition (module docstring).

    Called by the callbacks of the frozen modes' events after they did their work. Keeps the
    event and piece counts, the time and the state at its first call; at a call a period or
    more later with the same counts (no event in between) it notes ``jump = (t1, y1)`` and
    stops the propagation, and the loop jumps (:func:`_propagate`).
    """

    __slots__ = ("holder", "period", "last", "jump", "off")

    def __init__(self, holder: _Holder):
        self.holder = holder
        self.period = math.inf
        self.reset()

    def reset(self, off: bool = False) -> None:
        self.last: tuple | None = None
        self.jump: tuple | None = None
        self.off = off

    def __deepcopy__(self, memo):
        return self  # heyoka copies callbacks deeply: every copy watches the one run (see _Callback)

    def __call__(self, ta) -> bool:
        if self.off:
            return True
        switch = self.holder.run.switch
        mark = (len(switch.events), len(switch.pieces))
        last = self.last
        if last is None or last[0] != mark:
            self.last = (mark, ta.time, ta.state.copy())
        elif ta.time - last[1] >= self.period:
            self.jump = (last[1], last[2])
            return False
        return True


class _WatchedCallback(_Callback):
    """A shared event's callback that, in the frozen modes, also calls the :class:`_FrozenWatch`."""

    __slots__ = ("watch", "frozen", "watched")

    def __init__(self, holder: _Holder, watch: _FrozenWatch, modes):
        super().__init__(holder)
        self.watch = watch
        self.frozen = set(modes)
        self.watched: list[bool] = []

    def freeze(self, modes: int) -> _Callback:
        self.watched = [m in self.frozen for m in range(modes)]
        return super().freeze(modes)

    def __call__(self, ta, d_sgn) -> bool:
        run = self.holder.run
        mode = run.mode
        go = _Callback.__call__(self, ta, d_sgn)  # named, not super(): this runs at every event
        if go and run.mode == mode and self.watched[mode]:  # not a transition: an extremum check, a marker
            return self.watch(ta)
        return go


class CompiledSystem:
    """The cached integrator of one system structure and tolerance, and what the loop reads from it."""

    def __init__(self, system: HybridSystem, tol: float, cooldown: float = 0.0):
        import heyoka as hy

        num: Numeric = numeric(system)
        self.num = num
        P, M = num.n_params, len(system.modes)
        self.P, self.M = P, M
        ind = [hy.par[P + m] for m in range(M)]
        n_all = len(num.states)
        rates = [gated_sum([num.rates[m][i] for m in range(M)], ind) for i in range(n_all)]
        self.holder = _Holder()
        frozen = {m for m, f in enumerate(frozen_modes(system)) if f}
        self.watch: _FrozenWatch | None = None
        watch = None
        if system.period is not None and frozen:
            self.watch = _FrozenWatch(self.holder)
            watch = (self.watch, frozen, hy.sin(2.0 * math.pi * hy.time / num.with_params(system.period)))
        events = _events(system, num, ind, hy.par[P + M], self.holder, cooldown, watch)
        # pars left out: heyoka sizes them to the highest index the expressions use (see load)
        self.ta = hy.taylor_adaptive(list(zip(num.states, rates, strict=True)), [0.0] * n_all, t_events=events,
                                     tol=tol, compact_mode=False)
        self.has_events = bool(events)
        self.pars = self.ta.pars
        self.state = self.ta.state

    def load(self, params, mode: int, on: float) -> None:
        """The parameters, ``mode``'s indicator and the events' switch (indices the expressions do not use
        are not in heyoka's vector: a parameter used nowhere, a mode with no rate and no guard, no guards)."""
        pars = self.pars
        size = len(pars)
        pars[:] = 0.0
        used = min(self.P, size)
        pars[:used] = params[:used]
        for index, value in ((self.P + mode, 1.0), (self.P + self.M, on)):
            if index < size:
                pars[index] = value


def _events(system: HybridSystem, num: Numeric, ind, on, holder: _Holder, cooldown: float, watch=None) -> list:
    """The heyoka events of every guard and extremum check, shared as the module docstring says.

    ``watch``: ``(watch, frozen modes, period wave)``: the callbacks of the events armed in a
    frozen mode call the watch; a frozen mode without an event that depends on the time (its
    guards' extrema recur every period) gets a tick, the wave rising through zero once a period.
    """
    import heyoka as hy

    # One slot per distinct (expression, direction): the guards that share it in different
    # modes, and the extremum checks whose Lie derivative it is.
    slots: dict[tuple[object, int], tuple] = {}

    def slot(expr, d):
        key = (expr, d)  # the expression, not its text (heyoka cuts str() after ~1000 characters)
        if key not in slots:
            slots[key] = (expr, d, set(), _Callback(holder))
        return slots[key]

    for g, guard in enumerate(system.guards):
        d = guard.direction
        for m in num.armed[g]:
            _, _, modes, cb = slot(num.guards[g], d)
            modes.add(m)
            cb.cross[m] = g
            lie = num.lie[(m, g)]
            if not guard.terminal or (not hy.get_variables(lie) and "t" not in _words(str(lie))):
                continue  # a marker, or a constant rate: no extremum to check
            # the extrema that can touch zero from the side the guard fires from
            _, _, modes, cb = slot(lie, -d)
            modes.add(m)
            cb.extrema.setdefault(m, []).append(g)
    # Slots armed in disjoint sets of modes share one event: its expression is the active
    # mode's (a gated sum, like the vector field), so a step isolates the roots of a few
    # polynomials, not one per guard (eq. 3: 20 slots in 4 events).
    bins: list[tuple[int, set, list]] = []  # (direction, modes, slots)
    members = list(slots.values())
    if watch is not None:
        # the modes whose events recur with the time: an extremum check with the time in it
        timed = {m for expr, _, modes, cb in members for m in modes
                 if cb.extrema.get(m) and "t" in _words(str(expr))}
        untimed = watch[1] - timed
        if untimed:
            members.append((watch[2], 1, untimed, _Callback(holder)))
    for expr, d, modes, cb in members:
        for b_d, b_modes, b_slots in bins:
            if b_d == d and not (b_modes & modes):
                b_modes.update(modes)
                b_slots.append((expr, modes, cb))
                break
        else:
            bins.append((d, set(modes), [(expr, modes, cb)]))
    direction = {1: hy.event_direction.positive, -1: hy.event_direction.negative, 0: hy.event_direction.any}
    events = []
    for d, modes, binned in bins:
        watched = modes & watch[1] if watch is not None else set()
        merged = _WatchedCallback(holder, watch[0], watched) if watched else _Callback(holder)  # type: ignore[index]
        terms = []
        for expr, ms, cb in binned:
            merged.cross.update(cb.cross)  # type: ignore[union-attr]
            merged.extrema.update(cb.extrema)  # type: ignore[union-attr, arg-type]
            terms.append(_indicator(sorted(ms), ind) * expr)
        armed = on * _indicator(sorted(modes), ind)
        value = on * (terms[0] if len(terms) == 1 else hy.sum(terms))
        # moved by START_NUDGE to the side it fires from (below zero for a rising event)
        merged.freeze(len(system.modes))
        events.append(hy.t_event(value + (1.0 - armed) - d * START_NUDGE, direction=direction[d], callback=merged,
                                 cooldown=cooldown))
    return events


def _indicator(modes: list[int], ind):
    """``sum of [mode == m]`` over ``modes``: 1 in those modes, 0 elsewhere."""
    import heyoka as hy

    return ind[modes[0]] if len(modes) == 1 else hy.sum([ind[m] for m in modes])


def _words(text: str) -> set[str]:
    return set(text.replace("(", " ").replace(")", " ").replace(",", " ").split())


_cache: BuiltOnce[_Instances] = BuiltOnce()


def compiled(system: HybridSystem, tol: float = DEFAULT_TOL, cooldown: float = DEFAULT_COOLDOWN) -> CompiledSystem:
    """The first :class:`CompiledSystem` of ``system`` at ``tol`` (compiled once per structure and tolerance).

    It warms the store up (a run does not wait for the compiler then); runs take an instance with
    :func:`checked_out`, which may be this one or another of the same structure.
    """
    return _pool(system, tol, cooldown).first


class _Instances:
    """The compiled integrators of one structure: one per run going on at a time.

    A run holds its instance (the integrator's state, parameters and callbacks are the run's)
    and gives it back at its end. Runs in several threads at once each get their own: the first
    instance compiles (seconds, said once), the others are built from heyoka's in-memory JIT
    cache (about 10 ms for eq. 3), so threads do not wait on each other's runs.
    """

    def __init__(self, build):
        self._build = build
        self.first = build()
        self._free = [self.first]
        self._lock = threading.Lock()

    def take(self) -> CompiledSystem:
        with self._lock:
            if self._free:
                return self._free.pop()
        return self._build()

    def give_back(self, comp: CompiledSystem) -> None:
        with self._lock:
            self._free.append(comp)


def _pool(system: HybridSystem, tol: float, cooldown: float) -> _Instances:
    key = (system.structure, tol, cooldown)

    def first() -> _Instances:
        notice(f"hybrid-compile:{hash(key)}",
               f"impactosc: heyoka is compiling the integrator of the system {system.name!r} "
               f"(tol={tol:g}); this process compiles it once and reuses it for every run and parameter value")
        # the process's first heyoka build also creates heyoka's logger: on stderr, not in piped output
        return log_on_stderr(lambda: _Instances(lambda: CompiledSystem(system, tol, cooldown)))

    return _cache.get(key, first)


@contextmanager
def checked_out(system: HybridSystem, tol: float, cooldown: float):
    """A :class:`CompiledSystem` of ``system`` that no other run uses until the ``with`` block ends."""
    pool = _pool(system, tol, cooldown)
    comp = pool.take()
    try:
        yield comp
    finally:
        pool.give_back(comp)


class _Run:
    """One run's state as the callbacks see it."""

    def __init__(self, comp: CompiledSystem, switch: Switch, mode: int, max_events: int, zeno_tol: float,
                 graze_tol: float):
        self.comp = comp
        self.switch = switch
        self.mode = mode
        self.max_events = max_events
        self.accumulation = Accumulation(zeno_tol)
        self.graze_tol = graze_tol
        self.status = 0
        self.message = ""
        self.accumulation_time: float | None = None
        self.P = comp.P
        self.pars = comp.pars
        self.n = switch.n
        self.missed: tuple[int, float] | None = None  # (guard, time of the extremum past its zero)
        self.resting: tuple[int, float] | None = None  # (guard, accumulation time) where its rest mode begins
        self.zeno_tol = zeno_tol
        self.at_start = 16.0 * 2.0**-52  # a root this close (relative) to the piece start is at its start
        # the states a transition can change (resets change states, never integrals)
        self.reset_slots = range(self.n)
        self.ta, self.state = comp.ta, comp.ta.state
        self.guard_values = switch.rules.guard
        # in a frozen mode a guard is a function of the time alone and may touch zero exactly
        # (a stuck mass with F = beta_s): its crossings are checked for a touch split by rounding
        self.frozen = frozen_modes(switch.system)
        # the guards each mode arms that another guard's event may have to check (see lost)
        num = switch.num
        self.others = [tuple(i for i, g in enumerate(num.armed_in[m]) if num.terminal[g] and num.direction[g])
                       for m in range(len(switch.system.modes))]
        self.armed = num.armed_in
        self.mode_values = switch.rules.values
        # read at every event: bound once (the same lists as the switch's, which only appends to them)
        self.terminal, self.pieces, self.events = switch.terminal, switch.pieces, switch.events

    def transition(self, g: int, t: float, y: list) -> list:
        """Apply guard ``g`` (and what follows at the same instant), switch the indicators; the state after.

        Raises the errors of :meth:`Switch.transition`.
        """
        mode, y = self.switch.transition(g, self.mode, t, y)
        self.switch_to(mode)
        return y

    def switch_to(self, mode: int) -> None:
        """Move the mode indicators of the integrator to ``mode``."""
        pars = self.comp.pars
        pars[self.P + self.mode] = 0.0
        pars[self.P + mode] = 1.0
        self.mode = mode

    def crossing(self, ta, g: int) -> bool:
        """Guard ``g`` located at the integrator's time: apply its transition (the Python of every event)."""
        t = ta.time
        state = self.state if ta is self.ta else ta.state  # the cached view: ta.state makes a new array
        y = state.tolist()
        switch = self.switch
        mode = self.mode
        if not self.terminal[g]:
            self.events.append((t, g, MARKER, mode, mode, tuple(y), tuple(y)))
            return not switch.count(g) and self._go_on(t)
        if t - self.pieces[-1][0] <= self.at_start * (1.0 + abs(t)) and switch.leaves(g, mode, t, y):
            return True  # a rounding root at the start of the piece (see Switch.leaves)
        if self.frozen[mode] and switch.shallow(g, mode, t, y):
            return True  # a touch that rounding split into two roots (Switch.shallow): its extremum check records it
        others = self.others[mode]  # the check needs a guard besides g (which may have no direction: not in them)
        if others and (len(others) > 1 or self.armed[mode][others[0]] != g) and self.lost(g, t, y):
            return False  # an earlier crossing of another guard was not located: the loop applies it first
        try:
            target, after = switch.transition(g, mode, t, y)
        except InstantAccumulation as exc:
            if switch.rests(g):
                self.resting = (g, t)  # the loop enters the rest mode (see _propagate)
                return False
            self.status, self.message, self.accumulation_time = 2, str(exc), t
            return False
        except RuntimeError as exc:
            self.status, self.message = -1, str(exc)
            return False
        if switch.kept:
            switch.kept = False
            return True  # the guard's transition rule kept the mode (a tie at rest): a rounding root, no event
        if target != mode:
            pars, P = self.pars, self.P
            pars[P + mode] = 0.0
            pars[P + target] = 1.0
            self.mode = target
        if after is not y:
            for i in self.reset_slots:  # element by element: a slice assignment from a list costs more
                state[i] = after[i]
        if switch.done or switch.jump is not None:
            return False  # the event the run was to end after (until=...), or an accumulation rule's jump
        accumulation = self.accumulation
        if t - accumulation.last > accumulation.quick * (1.0 + abs(t)):
            accumulation.last = t  # add()'s common case: an interval too long to end an accumulation
            accumulation.times.clear()
            accumulation.times.append(t)
        else:
            estimate = accumulation.add(t, switch.zeno_scale[g])
            if estimate is not None and switch.rests(g):
                self.resting = (g, estimate)  # the loop enters the rest mode (see _propagate)
                return False
            if estimate is not None:
                self.status = 2
                self.accumulation_time = estimate
                self.message = (f"Events accumulate (Zeno): intervals shrink geometrically; the run stops at "
                                f"t={t!r}, the accumulation time is estimated at {estimate!r}.")
                return False
        if len(self.events) >= self.max_events:
            return self._go_on(t)
        return True

    def lost(self, g: int, t: float, y: list) -> bool:
        """Whether another guard of the mode is past zero on the side it fires towards at ``g``'s event.

        It was not there at the piece start (:meth:`_started_before`) and fires when it gets
        there, so it crossed zero inside the piece without an event: heyoka's polynomial root
        finder can fail on a step ("too many iterations", then it ignores that event in that
        step), and an event that another guard shares (merged events) is in its cooldown right
        after that guard fired (a mass released on a flange's surface whose exit root lies
        1e-75 later). Sets ``missed`` for the loop, which applies that guard at its first root
        (:func:`_first_root`); the event of ``g``, later, is found again.
        """
        mode = self.mode
        switch = self.switch
        values = self.mode_values[mode](t, y, switch.p)
        scale = switch.touch_scale(y)
        armed, direction = self.armed[mode], switch.direction
        for i in self.others[mode]:
            other = armed[i]
            if (other != g and direction[other] * values[i] > scale and self._started_before(other)
                    and not self._crossed_at_start(other)):
                self.missed = (other, t)
                return True
        return False

    def _crossed_at_start(self, g: int) -> bool:
        """Whether the current piece starts with a crossing of ``g`` (still armed: its reset kept it on zero)."""
        switch = self.switch
        t0 = switch.pieces[-1][0]
        for event in reversed(switch.events):
            if event[0] != t0:
                return False
            if event[1] == g and event[2] == CROSSING:
                return True
        return False

    def _go_on(self, t: float) -> bool:
        if len(self.switch.events) >= self.max_events:
            self.status = 1
            self.message = f"The event limit max_events={self.max_events} was reached at t={t!r}; results are kept."
            return False
        return True

    def extremum(self, ta, guards) -> bool:
        """Check the values of ``guards`` at one of their extrema: a grazing, or a crossing lost to rounding."""
        t = ta.time
        switch = self.switch
        if t - switch.pieces[-1][0] <= self.at_start * (1.0 + abs(t)):
            # An extremum at the piece start: the tangency it starts with, or rounding (a mass
            # released with v' = 0 moves ~1e-32 the wrong way before it turns), not a crossing
            # lost inside a step nor a grazing.
            return True
        y = (self.state if ta is self.ta else ta.state).tolist()
        values, direction = self.guard_values, switch.direction
        p = switch.p
        size = switch.floor + max(map(abs, y[:self.n]))  # (HybridSystem.scale)
        tie = TIE * size
        for g in guards:
            h = values[g](t, y, p)[0]
            d = direction[g]
            # in a frozen mode an excursion within rounding is a touch (Switch.shallow), not a lost crossing
            if d * h > (tie if self.frozen[self.mode] else 0.0) and self._started_before(g):
                # Past zero and back within a step, its roots not located (rounding): stop the
                # propagation; the loop applies the guard at its first root (see _first_root).
                self.missed = (g, t)
                return False
            if abs(h) <= self.graze_tol * size:
                switch.events.append((t, g, GRAZING, self.mode, self.mode, tuple(y), tuple(y)))
                if not self._go_on(t):
                    return False
        return True

    def _started_before(self, g: int) -> bool:
        """Whether the guard was on the side it fires from at the start of the current piece."""
        t0, mode, y0 = self.switch.pieces[-1]
        return -self.switch.direction[g] * self.switch.guard_value(g, t0, list(y0)) >= 0.0


def check_tol(tol) -> float:
    """``tol`` as a float in ``[MIN_TOL, MAX_TOL]``, or an error naming it."""
    tol = _v.real("tol", tol)
    if not MIN_TOL <= tol <= MAX_TOL:
        raise ValueError(f"tol must be in [{MIN_TOL!r}, {MAX_TOL!r}] for the heyoka loop, got {tol!r}: below about "
                         "machine epsilon a double-precision run gains nothing while the Taylor order and the compile "
                         "time grow; above 1e-2 event times are off by more than 1e-3")
    return tol


def run_system(system: HybridSystem, t_end: float, state0, *, mode=None, t0: float = 0.0,
               max_events: int = 1_000_000, tol: float = DEFAULT_TOL, cooldown: float = DEFAULT_COOLDOWN,
               zeno_tol: float = 1e-6, graze_tol: float = 1e-10, touch_tol: float = 1e-12,
               until: tuple[str, int] | None = None, max_wall_time: float | None = None) -> HybridSolution:
    """Run ``system`` with heyoka from ``state0`` at ``t0`` to ``t_end`` (see ``simulate_system``)."""
    return run_counted(system, t_end, state0, mode=mode, t0=t0, max_events=max_events, tol=tol, cooldown=cooldown,
                       zeno_tol=zeno_tol, graze_tol=graze_tol, touch_tol=touch_tol, until=until,
                       max_wall_time=max_wall_time)[0]


def run_counted(system: HybridSystem, t_end: float, state0, *, mode=None, t0: float = 0.0,
                max_events: int = 1_000_000, tol: float = DEFAULT_TOL, cooldown: float = DEFAULT_COOLDOWN,
                zeno_tol: float = 1e-6, graze_tol: float = 1e-10, touch_tol: float = 1e-12,
                until: tuple[str, int] | None = None,
                max_wall_time: float | None = None, quiet_at_start: str | None = None) -> tuple[HybridSolution, int]:
    """:func:`run_system`, and the number of integrator steps the run took (the built-in ``Solution.n_steps``).

    ``quiet_at_start``: a guard that the initial state does not fire even where it lies on it
    (the built-in engine's slip-end guard after a release at the start: its double or triple
    root there is where the slip begins, see ``engine.initial_mode``).
    """
    t0 = _v.real("t0", t0)
    t_end = _v.real("t_end", t_end)
    if not t_end > t0:
        raise ValueError(f"t_end must be > t0={t0!r}, got {t_end!r}")
    tol = check_tol(tol)
    max_events = _v.integer("max_events", max_events)
    zeno_tol = _v.positive("zeno_tol", zeno_tol)
    y0 = check_state(system, state0) + [0.0] * len(system.integrals)
    cooldown = _v.nonnegative("cooldown", cooldown)
    switch = Switch(system, _v.positive("touch_tol", touch_tol))
    if until is not None:
        switch.stop_after(*until)
    deadline = None
    if max_wall_time is not None:
        deadline = time.monotonic() + _v.positive("max_wall_time", max_wall_time)
    mode0 = switch.initial_mode(mode, t0, y0)
    with checked_out(system, tol, cooldown) as comp:
        run = _Run(comp, switch, mode0, max_events, zeno_tol, _v.positive("graze_tol", graze_tol))
        comp.holder.run = run
        try:
            quiet = system.guard_names.index(quiet_at_start) if quiet_at_start is not None else -1
            with root_finding_muted():  # what heyoka's root finder gives up on, the lost-crossing check finds
                steps = _propagate(run, comp, t0, y0, t_end, deadline, quiet)
        finally:
            comp.holder.run = None
        ta = comp.ta
        t_final = ta.time if run.status or switch.done else t_end
        state_final = ta.state.copy()
    if run.status == 1 and deadline is not None and not run.message:
        run.message = (f"The wall-time limit max_wall_time={max_wall_time!r} s was reached at t={t_final!r}; "
                       "results up to t_final are kept.")
    solution = HybridSolution(system, "heyoka", t_end, t_final, run.status,
                              run.message or STATUS_MESSAGES[run.status], switch.events, switch.pieces, state_final,
                              run.mode, _Dense(system, tol, cooldown), run.accumulation_time)
    return solution, steps


def _stalled(t_start: float, t_now: float, steps: int) -> bool:
    """Whether ``steps`` integrator steps from ``t_start`` to ``t_now`` averaged at most 16 ulps of the time.

    Steps that short are at the rounding of the time: the run would go on without getting anywhere (a
    power-law contact entered at 30 with ``K = 1e6`` took 10,000 steps per 1e-12 of time, for ever).
    """
    return abs(t_now - t_start) <= steps * 16.0 * math.ulp(max(abs(t_start), abs(t_now), 1e-300))


def _propagate(run: _Run, comp: CompiledSystem, t0: float, y0: list, t_end: float,
               deadline: float | None = None, quiet: int = -1) -> int:
    """The run from ``(t0, y0)``: the transitions at the start, then one ``propagate_until`` (more after a
    lost root, a frozen mode's jump, or every :data:`WALL_TIME_STEPS` steps with a ``deadline``); its end
    is in ``run.status``/``run.message`` and the integrator's time and state. Returns the number of steps.
    A guard's accumulation (its rule's jump, :attr:`~impactosc.engine._hybrid.Switch.jump`, or the Zeno
    watch's estimate) goes on in its rest mode at the accumulation time (at ``t_end`` if that comes first).

    ``deadline``: the ``time.monotonic()`` after which the run stops with status 1 (its message is
    written by the caller); ``quiet``: a guard the initial state does not fire (see :func:`run_counted`).
    """
    import heyoka as hy

    ta, switch = comp.ta, run.switch
    comp.load(switch.system.parameter_values, run.mode, 1.0)
    ta.time = t0
    ta.state[:] = y0
    switch.pieces.append((t0, run.mode, tuple(y0)))
    watch = comp.watch
    period = math.nan
    if watch is not None:
        found = usable_period(switch.system)
        watch.reset(off=found is None)
        period = watch.period = found if found is not None else math.inf
    # in chunks of steps, always: the clock is checked between them with a deadline, and the time's
    # progress always (steps at the rounding of the time make no progress: see _stalled)
    max_steps = WALL_TIME_STEPS
    last_missed: tuple[int, float] | None = None  # the last crossing lost to rounding and applied
    step_limit, time_limit = hy.taylor_outcome.step_limit, hy.taylor_outcome.time_limit
    steps = 0

    def rest(g: int, t_rest: float, jump=None) -> None:
        """Guard ``g``'s events accumulate at ``t_rest``: on from there in its rest mode (``Switch.rest``, with
        the ``jump`` of its accumulation rule where it answered)."""
        mode, y = switch.rest(g, run.mode, t_rest, ta.state.tolist(), jump)
        run.switch_to(mode)
        ta.time = t_rest
        ta.state[:] = y
        ta.reset_cooldowns()
        run.accumulation = Accumulation(run.zeno_tol)

    try:
        g = switch.pending(run.mode, t0, y0, quiet)
        ta.state[:] = run.transition(g, t0, y0) if g >= 0 else y0
        if comp.has_events:
            ta.reset_cooldowns()
        while True:
            if switch.jump is not None and not run.status and not switch.done:
                g, jump = switch.jump  # a guard's accumulation rule answered at its last crossing
                switch.jump = None
                rest(g, min(jump.time, t_end), jump)
                continue
            t_chunk = ta.time
            res = ta.propagate_until(t_end, max_steps=max_steps)
            outcome = res[0]
            steps += res[3]
            if outcome == step_limit and not run.status:
                if deadline is not None and time.monotonic() > deadline:
                    run.status = 1
                    break
                if _stalled(t_chunk, ta.time, res[3]):
                    run.status = -1
                    run.message = (f"the integrator's steps fell to the rounding of the time at t={ta.time!r} "
                                   f"(in mode {switch.system.mode_names[run.mode]!r}): the last {res[3]} steps "
                                   f"advanced it by {ta.time - t_chunk!r}. The vector field is singular where the "
                                   "run is (a pole ahead, a non-analytic force such as d^p at d = 0 approached "
                                   "faster than the time resolves), or the time is too large for the system's "
                                   "time scale; results up to t_final are kept.")
                    break
                continue
            if watch is not None and watch.jump is not None and not run.status and not switch.done:
                _jump(comp, run, watch, period, t_end)
                continue
            if run.resting is not None and not run.status and not switch.done:
                # a guard's events accumulated: its rest mode from the accumulation time on
                g, t_rest = run.resting
                run.resting = None
                rest(g, min(t_rest, t_end))
                continue
            if switch.jump is not None and not run.status and not switch.done:
                continue  # an accumulation rule's jump, taken at the top
            at_end = run.missed is None and not run.status and not switch.done and outcome == time_limit
            if at_end and run.others[run.mode]:
                # the last piece has no event after it to notice a crossing lost inside it (Run.lost)
                run.lost(-1, ta.time, ta.state.tolist())
            if run.missed is None or run.status or switch.done:
                break
            g, t_past = run.missed
            run.missed = None
            y_past = ta.state.tolist()  # the propagation stopped at t_past
            hair = switch.direction[g] * switch.guard_value(g, t_past, y_past) <= switch.touch_scale(y_past)
            t_root, y_root, at_once = _first_root(comp, run, g, t_past)
            t_start, _, y_start = switch.pieces[-1]
            # (only a guard a hair past zero: one far past it has crossed, whatever rounding says
            # of its derivatives at the start: a slip at v0 = -2e-64 with v' = v'' = 0 there was
            # taken on to v = 0.075 in the wrong mode, friction pushing it along)
            if t_root <= t_start and not at_once and hair and switch.leaves(g, run.mode, t_start, list(y_start)):
                # The "root" is the piece start, where the guard moves away from the side it fires
                # towards (a release with v = v' = 0: rounding took v a hair the wrong way, and back):
                # not a crossing. Applying it re-entered the same piece at the same instant, for ever.
                if at_end:
                    break
                continue
            if switch.keeps(g, run.mode, t_root, y_root):
                # the guard's transition rule keeps the mode there (a slip from a tie at rest whose speed
                # rounding took a hair below zero and back): not a crossing, the run goes on from t_past
                if at_end:
                    break
                continue
            if (g, t_root) == last_missed:
                raise RuntimeError(f"guard {switch.system.guard_names[g]!r}: the crossing lost to rounding at "
                                   f"t={t_root!r} was found again after its transition")
            last_missed = (g, t_root)
            ta.time = t_root
            ta.state[:] = run.transition(g, t_root, y_root)
    except InstantAccumulation as exc:
        run.status, run.message, run.accumulation_time = 2, str(exc), ta.time
        return steps
    except Exception as exc:  # no admissible mode, a callback's error or heyoka's: keep what was computed
        if run.status == 0:
            run.status = -1
            run.message = str(exc) if type(exc) is RuntimeError else f"{type(exc).__name__}: {exc}"
        return steps
    if switch.done and run.status == 0:
        run.message = switch.done_message()
    elif run.status == 0 and outcome != hy.taylor_outcome.time_limit:
        # not a callback's stop: a non-finite state (err_nf_state) or another failure
        run.status = -1
        run.message = f"heyoka stopped with {outcome!r} at t={ta.time!r} in mode {switch.system.mode_names[run.mode]!r}"
    return steps


def _jump(comp: CompiledSystem, run: _Run, watch: _FrozenWatch, period: float, t_end: float) -> None:
    """A whole period in a frozen mode without an event from ``watch.jump = (t1, y1)`` on: on to the
    last whole period before ``t_end`` (:func:`~impactosc.engine._hybrid.period_jump`).

    The state a period after ``t1`` is integrated again from ``(t1, y1)``, events off (the
    integrals' increment over exactly one period); the run goes on from the jump, or from where
    it stopped when there is nothing to jump (the watch is then off for the rest of the run).
    """
    ta, switch = comp.ta, run.switch
    t1, y1 = watch.jump  # type: ignore[misc]
    t_now, y_now = ta.time, ta.state.copy()
    on = comp.P + comp.M
    events_on = on < len(comp.pars)
    if events_on:
        comp.pars[on] = 0.0
    try:
        ta.time = t1
        ta.state[:] = y1
        ta.propagate_until(t1 + period)
        y2 = ta.state.tolist()
    finally:
        if events_on:
            comp.pars[on] = 1.0
    jump = period_jump(switch, run.mode, period, t_end, t1, y1, t1 + period, y2)
    if jump is not None and jump[0] >= t_now:
        ta.time = jump[0]
        ta.state[:] = jump[1]
        switch.pieces.append((jump[0], run.mode, tuple(jump[1])))
        ta.reset_cooldowns()
        watch.reset()
    else:
        ta.time = t_now
        ta.state[:] = y_now
        watch.reset(off=True)


def _first_root(comp: CompiledSystem, run: _Run, g: int, t1: float) -> tuple[float, list, bool]:
    """The first root of guard ``g`` between the current piece's start and ``t1`` (Brent's method).

    ``(t, state, at_once)``: ``at_once`` when the guard lies on zero at the piece start and is
    past it a thousandth of the piece later (its root is the start, whatever rounding says of
    its derivatives there).

    The guard's value at ``t`` comes from a copy of the integrator, events off, propagated
    from the piece start: a rare path (a double root that the Taylor polynomial's root
    isolation lost), so its cost does not matter.
    """
    from copy import copy

    from scipy.optimize import brentq

    t0, mode, y0 = run.switch.pieces[-1]
    ta = copy(comp.ta)
    ta.pars[comp.P + comp.M] = 0.0  # events off

    def state(s: float) -> list:
        ta.time = t0
        ta.state[:] = y0
        if s > t0:
            ta.propagate_until(s)
        return ta.state.tolist()

    def h(s: float) -> float:
        return run.switch.guard_value(g, s, state(s))

    start = t0
    if h(t0) == 0.0:
        start = t0 + 1e-3 * (t1 - t0)
        if run.switch.direction[g] * h(start) > 0.0:
            # on zero at the piece start and already past it: the guard left zero its way at once
            # (a mass at rest on a flange's surface whose every derivative up to the fourth is
            # zero: no tolerance on the derivatives told which way it goes); the crossing is there
            return t0, list(y0), True
    root = float(brentq(h, start, t1, xtol=4.0 * 2.0**-52 * (1.0 + abs(t1)), rtol=4.0 * 2.0**-52))
    return root, state(root), False


class _Dense:
    """Dense output of a run: a piece integrated again, events off (picklable: the integrator is looked up)."""

    def __init__(self, system: HybridSystem, tol: float, cooldown: float):
        self.system, self.tol, self.cooldown = system, tol, cooldown

    def __call__(self, mode: int, t_start: float, state, times) -> np.ndarray:
        return _dense(self.system, self.tol, self.cooldown, self.system.parameter_values, mode, t_start, state,
                      times)


def dense_states(system: HybridSystem, tol: float, cooldown: float, mode: int, t_start: float, state,
                 times) -> np.ndarray:
    """The states (then integrals) at ``times`` of a piece of ``system`` in ``mode`` from ``(t_start, state)``.

    Dense output from the system's cached integrator with its events off; a time before
    ``t_start`` gets ``state``. One row per time.
    """
    return _dense(system, tol, cooldown, system.parameter_values, mode, t_start, state, times)


def _dense(system: HybridSystem, tol: float, cooldown: float, params, mode: int, t_start: float, state,
           times) -> np.ndarray:
    """The states at ``times`` (not before ``t_start``) in ``mode`` from ``state``, events off.

    A frozen mode's whole periods are skipped (:func:`~impactosc.engine._hybrid.frozen_dense`).
    """
    period = None
    if system.period is not None and frozen_modes(system)[mode]:
        values = dict(zip(system.parameter_names, params, strict=True))
        period = usable_period(system.with_parameters(**values))
    return frozen_dense(system, period, mode, t_start, state, times,
                        lambda grid: _integrated(system, tol, cooldown, params, mode, t_start, state, grid))


def _integrated(system: HybridSystem, tol: float, cooldown: float, params, mode: int, t_start: float, state,
                times: np.ndarray) -> np.ndarray:
    """:func:`_dense` by integration from ``t_start`` to every time."""
    times = np.asarray(times, dtype=float)
    grid, where = np.unique(times, return_inverse=True)
    out = np.empty((grid.size, len(state)))
    with checked_out(system, tol, cooldown) as comp:
        comp.load(params, mode, 0.0)
        ta = comp.ta
        ta.time = t_start
        ta.state[:] = state
        later = grid > t_start
        out[~later] = state
        if later.any():
            res = ta.propagate_grid(np.concatenate(([t_start], grid[later])))
            out[later] = np.asarray(res[-1])[1:]
    return out[where.reshape(-1)]
