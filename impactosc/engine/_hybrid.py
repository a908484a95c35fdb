"""The transition rule of a user's hybrid system, shared by every event loop that runs one.

A backend integrates in a fixed mode until an armed guard fires; :class:`Switch` then
applies the guard's transition (the reset, then the first candidate mode whose entry
conditions hold), checks whether the new state already lies on a guard of the new mode
that it crosses (two guards at one instant, a reset that lands on a guard), and keeps the
event records. :class:`Accumulation` watches the event times for a Zeno accumulation; a guard
with an accumulation rule (``Guard.accumulation``) is asked instead, at each of its crossings,
whether its events accumulate from there (:meth:`Switch.transition`), and the loops then jump
to the accumulation time and enter the guard's rest mode (:meth:`Switch.rest`). The rigid
flanges of the oscillator family carry the engine's chatter model (:func:`wall_chatter`).
A guard with a transition rule (``Guard.choose``) is asked where its crossing leads instead
of the entry conditions, and whether a state on it at an instant crosses it at all
(:meth:`Switch.choice`): the stops and releases of the oscillator family carry the engine's
stick test at rest (:func:`stick_test`), so that a tie at rest is decided by the forcing's
trend, not by the sign of a rounding error. Both kinds of rule are resolved in
:mod:`impactosc.engine._guard_rules` (re-exported here: ``wall_chatter``, ``stick_test``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..model.hybrid._definition import HybridSystem
from ..model.hybrid._numeric import evaluator, numeric, plan, rules
from ._guard_rules import accumulation_rule, choice_rule, stick_test, wall_chatter

__all__ = ["Switch", "Accumulation", "AccumulationJump", "InstantAccumulation", "wall_chatter", "stick_test",
           "RULED_ZENO_SCALE",
           "check_state", "frozen_modes", "period_jump", "usable_period",
           "frozen_dense", "CROSSING",
           "GRAZING", "MARKER", "REST", "MAX_EVENTS_AT_AN_INSTANT", "START_NUDGE", "TIE"]

#: Event kinds: a guard crossed (its transition applied), a guard's extremum on zero without a
#: crossing (recorded, no transition), a non-terminal guard crossed (recorded only), the
#: accumulation of a guard's events ending in its rest mode (``Guard.rest``).
CROSSING, GRAZING, MARKER, REST = "crossing", "grazing", "marker", "rest"

#: Every event with a direction ``d`` is ``h - d START_NUDGE``: a piece that starts exactly on a
#: guard's zero (a velocity reset to 0 at a slip reversal, a contact closed where ``x - gap``
#: rounds to 0) then starts a hair on the side the guard fires from instead of on zero. heyoka
#: takes an event polynomial whose constant term is exactly 0 to have its root at the step's
#: start, and its bracketing root finder returns that root for the step's first isolating
#: interval, losing a later root in it (``y' = 0.9 - cos t`` from ``y = 0``: its rising root at
#: t = 0.78668 was not found). The shift of an event time, ``START_NUDGE / |h'|``, is far
#: below any representable difference of times; a guard that goes the wrong way by rounding
#: at a piece start (past the nudge) is a root at the start that the loops ignore
#: (:meth:`Switch.leaves`). scipy's ``solve_ivp`` has the same trouble its own way: a guard exactly
#: 0 at the start and still 0 after a first step too short to move it takes both ends of the
#: step for a root, and fires again at the instant of the transition.
START_NUDGE = 1e-300

#: A few rounding units: the rounding of a guard's rate on its zero is estimated as this times its
#: curvature and the system's time scale (:meth:`Switch._heading`).
TIME_ROUNDING = 64.0 * 2.0**-52

#: How far past zero (relative to ``scale + max |y|``, ``HybridSystem.scale``) a guard may go by rounding
#: alone: an excursion this small that turns back is a touch, not a crossing (:meth:`Switch.shallow`).
TIE = 16.0 * 2.0**-52

#: Most transitions applied at one instant before the run stops as an accumulation (status 2).
MAX_EVENTS_AT_AN_INSTANT = 64

#: The factor of the Zeno watch's tolerance for the events of a guard with an accumulation rule: the
#: rule decides (the engine's chatter jumps once its time is known to 1e-12, typically with ~1e-5
#: left, where a watch at ``zeno_tol = 1e-6`` could have declared the accumulation first); the watch,
#: this much finer, only keeps a rule that never answers from running into flights below the
#: rounding of the states, which no event finder resolves (a ball's bounces at 1e-9 apart).
RULED_ZENO_SCALE = 1e-2


class AccumulationJump(NamedTuple):
    """What a guard's accumulation rule answered (``Guard.accumulation``), checked: the run goes on from here."""

    time: float  #: the accumulation time
    state: tuple  #: the states there
    increments: tuple  #: each integral's increment over the flights left out


class InstantAccumulation(Exception):
    """More than :data:`MAX_EVENTS_AT_AN_INSTANT` transitions at one instant (the message says where)."""


class Accumulation:
    """Watches event times for a geometric accumulation (Zeno): intervals shrinking at a steady ratio.

    :meth:`add` returns the estimated accumulation time ``t + dt r / (1 - r)`` when the last
    ``span`` intervals each shrink by a ratio ``r < 1`` steady within 10 %, and the time
    left, ``dt r / (1 - r)``, is below ``tol * (1 + |t|)``; otherwise None.
    """

    def __init__(self, tol: float, span: int = 6):
        self.tol = tol
        self.span = span
        # An interval above quick (1 + |t|) cannot end an accumulation with a ratio r >= 0.01
        # whose time left, dt r / (1 - r), is within tol (1 + |t|): the common case costs one test.
        self.quick = 99.0 * tol
        self.times: list[float] = []
        self.last = -math.inf

    def add(self, t: float, fine: float = 1.0) -> float | None:
        """Note an event at ``t``; the accumulation time, or None. ``fine`` scales the tolerance (see
        :data:`RULED_ZENO_SCALE`)."""
        dt = t - self.last
        self.last = t
        scale = 1.0 + abs(t)
        if dt > self.quick * scale:
            self.times = [t]
            return None
        times = self.times
        times.append(t)
        if len(times) > self.span + 2:
            del times[0]
        if len(times) < self.span + 2:
            return None
        dts = [b - a for a, b in zip(times, times[1:], strict=False)]
        if all(d <= 0.0 for d in dts):
            return t  # every event at one instant
        ratios = [b / a for a, b in zip(dts, dts[1:], strict=False) if a > 0.0]
        if len(ratios) < self.span or not all(0.0 < r < 1.0 for r in ratios) or max(ratios) > 1.1 * min(ratios):
            return None
        r = ratios[-1]
        left = dts[-1] * r / (1.0 - r)
        return t + left if left <= self.tol * fine * scale else None


class Switch:
    """The transitions of one run of ``system`` (its parameter values), and the records they leave.

    Attributes
    ----------
    events : list of tuple
        ``(t, guard, kind, mode_before, mode_after, state_before, state_after)`` with the
        guard and modes as indices and the states as tuples (states then integrals).
    pieces : list of tuple
        ``(t, mode, state)`` at the start of every smooth piece (for dense output).
    jump : tuple or None
        ``(guard, AccumulationJump)`` when a guard's accumulation rule has answered at the last
        transition: the loop goes on at the jump's time in that guard's rest mode (:meth:`rest`)
        and sets it back to None.
    zeno_scale : list of float
        The factor of the Zeno watch's tolerance for each guard's events (:data:`RULED_ZENO_SCALE`
        for a guard with an accumulation rule, else 1).
    ruled : list of bool
        For each guard, whether it has a transition rule (``Guard.choose``, see :meth:`choice`).
    kept : bool
        Set by :meth:`transition` when a guard's transition rule kept the mode: no event, the loop
        goes on as after a rounding root (and sets it back to False).
    """

    def __init__(self, system: HybridSystem, touch_tol: float = 1e-12):
        self.system = system
        self.num = numeric(system)
        self.rules = rules(system)
        self.p = system.parameter_values
        self.n = system.dimension
        self.direction = self.num.direction
        self.terminal = self.num.terminal
        self.to = self.num.to
        self.touch_tol = touch_tol
        #: the size of the states near rest (``HybridSystem.scale``, 1 by default): the absolute part of every
        #: "on zero" tolerance, ``tol (floor + max |y|)``
        self.floor = system.scale_value()
        period = usable_period(system)
        self.time_scale = 1.0 + (period if period is not None and math.isfinite(period) else 0.0)
        # read at every event: bound once (the loops' Python per event is what they cost)
        self._reset = self.rules.reset
        self._entry = self.rules.entry
        self._values = self.rules.values
        self._armed_in = self.num.armed_in
        self._plans = self.rules.plans
        self._modes = len(system.modes)
        self.events: list[tuple] = []
        self.pieces: list[tuple] = []
        self.until_guard, self.until_count, self.seen, self.done = -1, 0, 0, False
        self._second: dict = self.num.second
        self._accumulate = [accumulation_rule(guard.accumulation) for guard in system.guards]
        self.zeno_scale = [1.0 if rule is None else RULED_ZENO_SCALE for rule in self._accumulate]
        self.jump: tuple[int, AccumulationJump] | None = None
        self._choose = [choice_rule(guard, system) for guard in system.guards]
        self.ruled = [rule is not None for rule in self._choose]
        self._chosen: tuple = (None, -1, 0.0, -1, None)  # (state, guard, time, mode, state after) last chosen
        self.kept = False  # set by transition when a guard's rule kept the mode (the loop resets it)

    def initial_mode(self, mode, t: float, y) -> int:
        """The index of ``mode`` (a name), or of the first mode whose entry conditions hold at ``(t, y)``."""
        if mode is not None:
            if not isinstance(mode, str):
                raise TypeError(f"mode must be the name of a mode of {self.system.name}, got {mode!r}")
            return self.system.mode_index(mode)
        for m, entry in enumerate(self.rules.entry):
            if entry is None or all(c >= 0.0 for c in entry(t, y, self.p)):
                # a start on a guard with a transition rule, where its transition would move no state
                # (a start at rest on a stop or a release): the rule's mode, not an event at the start
                g = self.pending(m, t, y)
                if g >= 0 and self.ruled[g]:
                    target, after = self.choice(g, t, y)
                    if target >= 0 and list(after[:self.n]) == list(y[:self.n]):
                        return target
                return m
        raise ValueError(f"{self.system.name}: no mode's entry conditions hold at t={t!r}, state={list(y)}; "
                         "give the initial mode (mode=...)")

    def apply(self, g: int, mode: int, t: float, y: list) -> tuple[int, list]:
        """``(next mode, state after)`` of guard ``g`` firing in ``mode`` at ``(t, y)``.

        Raises
        ------
        RuntimeError
            When no candidate mode's entry conditions hold after the reset (named).
        """
        reset = self._reset[g]
        after = list(y)
        if reset is not None:
            after[:self.n] = reset(t, y, self.p)
        targets = self.to[g]
        if not targets:
            return mode, after
        if len(targets) == 1:
            return targets[0], after
        entry = self._entry
        for m in targets:
            conditions = entry[m]
            if conditions is None or min(conditions(t, after, self.p)) >= 0.0:
                return m, after
        names = [self.system.mode_names[m] for m in targets]
        raise RuntimeError(f"guard {self.system.guard_names[g]!r} fired at t={t!r} with the state {after}, "
                           f"where the entry conditions of none of its modes {names} hold")

    def stop_after(self, guard: str, count: int) -> None:
        """End the run right after the ``count``-th event of ``guard`` (a Poincare section's return)."""
        if guard not in self.system.guard_names:
            raise ValueError(f"until names the guard {guard!r}, which {self.system.name} does not have "
                             f"(its guards are {list(self.system.guard_names)})")
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f"until=({guard!r}, {count!r}): the count must be an integer >= 1")
        self.until_guard, self.until_count = self.system.guard_names.index(guard), count

    def done_message(self) -> str:
        name = self.system.guard_names[self.until_guard]
        return f"The run ended after event {self.until_count} of guard {name!r}, as asked (until=...)."

    def count(self, g: int) -> bool:
        """Note an event of guard ``g``; True when it is the one the run ends after (see :meth:`stop_after`)."""
        if g == self.until_guard:
            self.seen += 1
            if self.seen == self.until_count:
                self.done = True
        return self.done

    def transition(self, g: int, mode: int, t: float, y: list) -> tuple[int, list]:
        """Apply guard ``g`` in ``mode`` at ``(t, y)``, then every guard the new state lies on and crosses.

        Records each event and the new piece; returns ``(mode, state)`` after the last. A guard
        whose transition rule (``Guard.choose``) keeps ``mode`` records nothing and sets
        :attr:`kept` (its crossing was rounding, see :meth:`keeps`). A guard
        with an accumulation rule (``Guard.accumulation``) asks it after its transition; when it
        answers, the transition ends there and :attr:`jump` holds the answer for the loop.

        Raises
        ------
        RuntimeError
            When no candidate mode's entry conditions hold (see :meth:`apply`).
        InstantAccumulation
            After :data:`MAX_EVENTS_AT_AN_INSTANT` transitions at ``t``.
        """
        events, plans, p, touch, modes = self.events, self._plans, self.p, self.touch_tol, self._modes
        self.kept = False
        chained = 0
        before = tuple(y)
        ruled = self.ruled
        floored = self.floor < 1.0  # the generated plans test "on zero" against touch_tol (1 + max |y|)
        while True:
            # the reset, the next mode and whether the state after lies near a guard of it: one
            # generated function per (guard, mode), made on first use (this runs at every event)
            step = plans[g * modes + mode]
            if step is None:
                step = plans[g * modes + mode] = plan(self.num, self.rules, g, mode) or False
            if step:
                target, after, then = step(t, y, p, touch)
                # a guard's transition rule chooses the mode (a tie at rest: not the entry conditions)
                chosen = self._choose[g](t, after, p) if ruled[g] else -1
                if chosen >= 0 and chosen != target:
                    if chosen == mode and not chained:
                        self.kept = True
                        return mode, y  # it keeps the mode: the crossing was rounding (no event, no piece)
                    target, then = chosen, -2  # the rule's mode (its guards asked by pending)
                elif target < 0:
                    self.apply(g, mode, t, y)  # no admissible mode: apply raises the error naming it
                elif then >= 0 and floored:
                    then = -2  # a scale below 1: pending asks, with the system's scale
            else:
                chosen, after = self.choice(g, t, y) if ruled[g] else (-1, y)
                if chosen == mode and not chained:
                    self.kept = True
                    return mode, y
                target, after = (chosen, after) if chosen >= 0 else self.apply(g, mode, t, y)
                then = -2
            state = before if after is y else tuple(after)
            events.append((t, g, CROSSING, mode, target, before, state))
            mode, y = target, after
            chained += 1
            if chained > MAX_EVENTS_AT_AN_INSTANT:
                last = self.system.guard_names[g]
                raise InstantAccumulation(f"More than {MAX_EVENTS_AT_AN_INSTANT} transitions at t={t!r} (the last "
                                          f"by guard {last!r}): events accumulate at one instant.")
            if g == self.until_guard and self.count(g):
                break  # the run ends right after this event
            rule = self._accumulate[g]
            if rule is not None:
                found = rule(t, before, state, p)
                if found is not None:
                    self.jump = (g, self._checked_jump(g, t, found))
                    break  # the run goes on at the accumulation time (the loop calls rest)
            # A guard whose reset is the identity has been crossed, not left on its surface: the
            # state after it lies on it moving its way, and firing it again would count the one
            # crossing twice (up to the instant-accumulation limit).
            g = then if then != -2 else self.pending(mode, t, y, g if self._reset[g] is None else -1)
            if g < 0:
                break
            before = state
        self.pieces.append((t, mode, state))
        return mode, y

    def choice(self, g: int, t: float, y) -> tuple[int, list]:
        """``(mode, state after)`` that guard ``g``'s transition rule (``Guard.choose``) chooses at ``(t, y)``.

        The rule is asked at the state after the guard's reset (a stop's ``v -> 0``); the mode
        is -1 where it leaves the choice to the entry conditions. The last answer is kept (the
        loops' rare paths ask :meth:`keeps` and then :meth:`transition` at the same state; a
        crossing located by a loop goes to :meth:`transition` alone, which asks the rule on the
        state its generated plan resets).

        Raises
        ------
        RuntimeError
            When the rule answers a name that is not a mode of the system (named).
        """
        last = self._chosen
        if last[0] is y and last[1] == g and last[2] == t:
            return last[3], last[4]
        reset = self._reset[g]
        after = list(y)
        if reset is not None:
            after[:self.n] = reset(t, y, self.p)
        target = self._choose[g](t, after, self.p)
        self._chosen = (y, g, t, target, after)
        return target, after

    def keeps(self, g: int, mode: int, t: float, y) -> bool:
        """Whether guard ``g``'s transition rule keeps ``mode`` at ``(t, y)``: its crossing there is rounding.

        A mass that stops where the net force vanishes and then grows the way it moved (a
        frictionless tie at rest) goes on: the stop guard's root is a rounding error of a
        double or triple root, and the loops ignore it (no event), as a root at a piece start
        that :meth:`leaves`.
        """
        return self.ruled[g] and self.choice(g, t, y)[0] == mode

    def _checked_jump(self, g: int, t: float, found) -> AccumulationJump:
        """The answer ``found`` of guard ``g``'s accumulation rule at ``t``, checked, or a RuntimeError naming it."""
        name = self.system.guard_names[g]
        try:
            time, state, *rest = found
            time = float(time)
            state = tuple(float(c) for c in state)
            increments = tuple(float(c) for c in rest[0]) if rest else (0.0,) * len(self.system.integrals)
        except (TypeError, ValueError):
            raise RuntimeError(f"guard {name!r}: its accumulation rule must return None or "
                               f"(time, state[, increments]), got {found!r}") from None
        if len(rest) > 1 or len(state) != self.n or len(increments) != len(self.system.integrals):
            raise RuntimeError(f"guard {name!r}: its accumulation rule returned {found!r}; it must be (time, state) "
                               f"with {self.n} states or (time, state, increments) with {len(self.system.integrals)} "
                               "increments")
        if not (math.isfinite(time) and time >= t and all(map(math.isfinite, state + increments))):
            raise RuntimeError(f"guard {name!r}: its accumulation rule returned the time {time!r} and the state "
                               f"{list(state)} at t={t!r}; the time must be finite and >= t, the state finite")
        return AccumulationJump(time, state, increments)

    def rests(self, g: int) -> bool:
        """Whether an accumulation of guard ``g``'s events leads into a rest mode (``Guard.rest``)."""
        return self.num.rest[g] >= 0

    def rest(self, g: int, mode: int, t: float, y: list, jump: AccumulationJump | None = None) -> tuple[int, list]:
        """Enter guard ``g``'s rest mode at the accumulation time ``t`` from the state ``y`` of its last event.

        Records the ``"rest"`` event and the new piece (and a guard the state then lies on and
        crosses, as :meth:`transition` does); returns ``(mode, state)``. With the ``jump`` of
        the guard's accumulation rule, the state there is the jump's, the integrals moved on
        by its increments (``rest_reset`` is not applied).

        Raises
        ------
        RuntimeError
            When the rest mode's entry conditions do not hold there (named).
        """
        target = self.num.rest[g]
        reset = self.rules.rest_reset[g]
        after = list(y)
        if jump is not None:
            after[:self.n] = jump.state
            for i, step in enumerate(jump.increments):
                after[self.n + i] += step
        elif reset is not None:
            after[:self.n] = reset(t, y, self.p)
        conditions = self._entry[target]
        if conditions is not None and not all(c >= 0.0 for c in conditions(t, after, self.p)):
            raise RuntimeError(f"guard {self.system.guard_names[g]!r}: its events accumulate at t={t!r}, where the "
                               f"entry conditions of its rest mode {self.system.mode_names[target]!r} do not hold "
                               f"(state {after})")
        self.events.append((t, g, REST, mode, target, tuple(y), tuple(after)))
        follow = self.pending(target, t, after)
        if follow >= 0:
            return self.transition(follow, target, t, after)
        self.pieces.append((t, target, tuple(after)))
        return target, after

    def pending(self, mode: int, t: float, y, crossed: int = -1) -> int:
        """A guard armed in ``mode`` that the state ``y`` lies on and crosses now in its direction, else -1.

        On it: ``|h| <= touch_tol (scale + max |y|)``; crossing: the Lie derivative points its way,
        or, where it is zero within the same tolerance (a tangency, such as the slip-end guard
        of a mass just released), the second Lie derivative does. ``crossed`` is a guard
        crossed at this instant without a reset: not fired again. A tangency that still lies
        on the side the guard fires from, farther from zero than the guard moves within a
        rounding of the time (:data:`TIME_ROUNDING`), is ahead, not now: the integrator locates it
        (a mass that turns 1e-12 above a rigid wall falls for ~1e-5 time units before it
        hits it, and its chatter goes on there).
        """
        armed = self._armed_in[mode]
        if not armed:
            return -1
        values = self._values[mode](t, y, self.p)
        if min(map(abs, values)) > self.touch_tol * (self.floor + max(map(abs, y))):  # the common case: on none
            return -1
        values = self.rules.probe[mode](t, y, self.p)
        k = len(armed)
        scale = self.touch_scale(y)
        for i, g in enumerate(armed):
            if abs(values[i]) <= scale and self.terminal[g] and g != crossed:
                d, rate = self.direction[g], values[k + i]
                if abs(rate) > scale:
                    if d == 0 or d * rate > 0.0:
                        return g
                    continue
                if self.ruled[g]:
                    # tangent to a guard with a transition rule (a stop or a release at a tie): the rule
                    # says whether the state crosses it now, not the sign of its rounded curvature
                    target = self.choice(g, t, y)[0]
                    if target >= 0:
                        if target != mode:
                            return g
                        continue
                if d != 0 and d * self._heading(g, mode, t, y, rate) > 0.0 and not self._ahead(g, mode, t, y,
                                                                                            values[i], rate):
                    return g  # tangent to the guard, curving across it
        return -1

    def _ahead(self, g: int, mode: int, t: float, y, h: float, rate: float) -> bool:
        """Whether guard ``g`` (value ``h``, Lie derivative ``rate``) lies on the side it fires from, beyond what it
        moves within a rounding of the time: its crossing is ahead (see :meth:`pending`)."""
        d = self.direction[g]
        if not d * h < 0.0:
            return False
        tau = TIME_ROUNDING * (1.0 + abs(t))
        reach = abs(rate) * tau + 0.5 * abs(self.second_derivative(g, mode, t, y)) * tau * tau
        return -d * h > reach

    def _heading(self, g: int, mode: int, t: float, y, rate: float) -> float:
        """The sign of guard ``g`` just after ``t``, from its zero at ``(t, y)`` with the Lie derivative ``rate``
        (at most ``touch_tol`` in size: a tangency, or a system whose forces are all that small).

        Near its zero ``h(t + s) ~ rate s + h'' s^2 / 2``. The rate decides where it exceeds its
        own rounding, estimated as :data:`TIME_ROUNDING` ``(|t| + tau) |h''|`` (the rate's terms
        change by about ``|h''|`` per unit time over the system's time scale ``tau``, its forcing
        period or 1, and ``|t|`` for the rounding of the time); the curvature decides otherwise.
        Free of the forces' scale: a mass released with ``v = 0`` and a rate that rounding made
        ``1e-16`` (a tape drive's forcing of period 3e4: curvature 9e-6) goes the curvature's way;
        one whose every force is ``1e-53`` (a rate of ``-7e-53``, curvature ``5e-53``) goes the
        rate's way, which a tolerance absolute in the rate took for a tangency.
        """
        second = self.second_derivative(g, mode, t, y)
        if rate != 0.0 and abs(rate) > abs(second) * TIME_ROUNDING * (abs(t) + self.time_scale):
            return rate
        return second

    def touch_scale(self, y) -> float:
        """How close to zero (``touch_tol (scale + max |state|)``, ``HybridSystem.scale``) a guard at the state ``y``
        counts as on it."""
        return self.touch_tol * (self.floor + max(abs(c) for c in y[:self.n]))

    def leaves(self, g: int, mode: int, t: float, y) -> bool:
        """Whether guard ``g``, on zero at ``(t, y)`` in ``mode``, moves away from the side it fires towards.

        The root a solver reports at the start of a piece can be a rounding artefact of a
        double root: a mass released from sticking starts with ``v = 0`` and ``v' = 0``, and
        its slip-end guard ``v`` must not fire there although rounding may make ``v``
        slightly negative. The sign of the first Lie derivative, or of the second where the
        first is zero within ``touch_tol``, says where the guard goes.
        """
        armed = self.num.armed_in[mode]
        if g not in armed:
            return False
        values = self.rules.probe[mode](t, y, self.p)
        k, i = len(armed), armed.index(g)
        d = self.direction[g]
        if d == 0:
            return False
        rate = values[k + i]
        if abs(rate) > self.touch_scale(y):
            return d * rate < 0.0
        return d * self._heading(g, mode, t, y, rate) < 0.0

    def shallow(self, g: int, mode: int, t: float, y) -> bool:
        """Whether guard ``g``, at a root at ``(t, y)`` in ``mode``, goes past zero by rounding only and turns back.

        Near the root ``h(t + s) ~ h' s + h'' s^2 / 2``; where ``h''`` turns it back, the
        excursion past zero is ``h'^2 / (2 |h''|)``. Within :data:`TIE` ``(scale + max |y|)`` that
        is a touch that rounding split into two roots (a stuck mass with ``F = beta_s``
        exactly: ``F cos t + beta_s`` touches zero at ``t = pi`` and its Taylor polynomial
        dips 1e-19 below), not a crossing: the Filippov rule ``|f| <= beta_s`` holds there.
        """
        armed = self.num.armed_in[mode]
        if g not in armed:
            return False
        d = self.direction[g]
        second = self.second_derivative(g, mode, t, y)
        if d == 0 or d * second >= 0.0:
            return False
        rate = self.rules.probe[mode](t, y, self.p)[len(armed) + armed.index(g)]
        return rate * rate <= 2.0 * abs(second) * TIE * (self.floor + max(abs(c) for c in y[:self.n]))

    def second_derivative(self, g: int, mode: int, t: float, y) -> float:
        """``h''`` of guard ``g`` along the flow of ``mode`` at ``(t, y)`` (built on first use)."""
        key = (mode, g)
        fn = self._second.get(key)
        if fn is None:
            num = self.num
            expr = num.lie_derivative(num.lie[key], num.rates[mode])
            label = f"second derivative of guard {self.system.guard_names[g]!r}"
            fn = self._second[key] = evaluator(num, [expr], label)
        return fn(t, y, self.p)[0]

    def guard_value(self, g: int, t: float, y) -> float:
        return self.rules.guard[g](t, y, self.p)[0]


_frozen: dict[tuple, tuple[bool, ...]] = {}


def frozen_modes(system: HybridSystem) -> tuple[bool, ...]:
    """For each mode, whether it is *frozen*: every state's rate is identically zero as an expression.

    In a frozen mode (a mass stuck by friction, a ball resting on the floor) the states stay
    where they are; only the integrals may have rates. With a forcing period ``T`` its guards
    are then functions of the time alone, periodic with period ``T``: a whole period without
    an event means none ever comes, and the loops jump over whole periods
    (:func:`period_jump`) instead of stepping through them. Found once per system structure.
    """
    found = _frozen.get(system.structure)
    if found is None:
        import heyoka as hy

        zero = hy.expression(0.0)
        n = system.dimension
        found = _frozen[system.structure] = tuple(all(r == zero for r in rates[:n]) for rates in numeric(system).rates)
    return found


def usable_period(system: HybridSystem) -> float | None:
    """The system's forcing period, or None without one or where it is not a finite number
    (``2 pi / Omega`` overflows for ``Omega ~ 1e-300``): frozen modes are then stepped through."""
    if system.period is None:
        return None
    try:
        return system.period_value()
    except (ValueError, OverflowError, ZeroDivisionError):
        return None


def period_jump(switch: Switch, mode: int, period: float, t_end: float, t1: float, y1, t2: float,
                y2) -> tuple[float, list] | None:
    """The jump over whole periods of a frozen mode that had no event from ``t1`` to ``t2 = t1 + period``.

    ``(t, y)``: the last whole period before ``t_end`` (``t = t2 + k period``, ``k >= 1``),
    each integral moved on by ``k`` times its increment ``y2 - y1`` over the period just
    integrated, the states as they are. None when there is nothing to jump (less than a
    period left), when the guards of ``mode`` do not take the same values at ``t1`` and
    ``t2`` (the system is not periodic with ``period`` there: no jump, the loop steps on),
    or when a guard lies on zero at ``t2`` (an event at that very instant).
    """
    k = math.floor((t_end - t2) / period)
    if k >= 1 and t2 + k * period > t_end:  # rounded past the end time
        k -= 1
    if k < 1:
        return None
    if switch.num.armed_in[mode]:
        p = switch.p
        values = switch.rules.values[mode]
        a, b = values(t1, list(y1), p), values(t2, list(y2), p)
        scale = switch.floor + max(abs(c) for c in y2)
        # the rounding of the guards' time arguments, ~eps |t| |dh/dt|, with |dh/dt| ~ |h| / period
        slack = 64.0 * 2.0**-52 * (scale + max(map(abs, b))) * (1.0 + abs(t2) / period)
        if any(abs(u - w) > slack for u, w in zip(a, b, strict=True)):
            return None
        if switch.pending(mode, t2, list(y2)) >= 0:
            return None
    n = switch.n
    y = [float(c) for c in y2]
    for i in range(n, len(y)):
        y[i] = y[i] + k * (y[i] - float(y1[i]))
    return t2 + k * period, y


def frozen_dense(system: HybridSystem, period: float | None, mode: int, t_start: float, state, times,
                 integrate) -> np.ndarray:
    """Dense output of a piece from ``(t_start, state)`` in ``mode`` at ``times``, whole periods skipped.

    ``integrate(times)`` integrates the piece (one row per time). In a frozen mode of a system
    with a forcing ``period``, a time ``k`` whole periods and ``r`` past the start is the state
    at ``t_start + r`` with the integrals moved on by ``k`` periods' increments (the states do
    not move): a sample deep into a long stuck phase costs at most a period of integration.
    Elsewhere ``integrate(times)`` itself.
    """
    times = np.asarray(times, dtype=float)
    if period is None or not frozen_modes(system)[mode]:
        return integrate(times)
    whole = np.floor(np.maximum(times - t_start, 0.0) / period)
    if whole.max(initial=0.0) < 1.0:
        return integrate(times)
    within = np.where(whole > 0.0, t_start + ((times - t_start) - whole * period), times)
    out = np.asarray(integrate(np.concatenate((within, [t_start + period]))), dtype=float)
    step = out[-1] - np.asarray(state, dtype=float)
    step[:system.dimension] = 0.0  # the states do not move (rounding aside)
    return out[:-1] + whole[:, None] * step


def finite_state(y) -> bool:
    return all(math.isfinite(c) for c in y)


def check_state(system: HybridSystem, state0) -> list:
    """``state0`` as a list of floats of the system's dimension, or an error naming it."""
    try:
        values = [float(c) for c in np.asarray(state0, dtype=float).ravel()]
    except (TypeError, ValueError):
        raise TypeError(f"state0 must be a sequence of {system.dimension} numbers {list(system.states)}, "
                        f"got {state0!r}") from None
    if len(values) != system.dimension:
        raise ValueError(f"state0 has {len(values)} values, the system {system.name!r} has {system.dimension} states "
                         f"{list(system.states)}")
    if not all(np.isfinite(values)):
        raise ValueError(f"state0 must be finite, got {values}")
    return values
