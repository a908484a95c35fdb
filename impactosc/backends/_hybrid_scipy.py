"""The scipy event loop for user hybrid systems: one ``solve_ivp`` per smooth piece, the cross-check.

The same definition as the heyoka loop, turned into numeric functions (the vector fields,
guards and Lie derivatives of :mod:`impactosc.model.hybrid._numeric`), and the same
transitions (:class:`~impactosc.engine._hybrid.Switch`). Each piece is one ``solve_ivp``
in a fixed mode with every armed guard as a terminal event in its direction, and the
guard's Lie derivative as a terminal event at the extrema that can touch zero: there
the guard's value is checked, as in the heyoka loop. After an extremum of a guard, that
guard's extremum events are off until the next event (scipy would find the same zero again
at the restart). As in the heyoka loop, a guard that fired is off for ``cooldown`` time units
(the located root can lie a rounding error before the surface, where scipy would find it
again at once), and a root at the very start of a piece of a guard that moves away from the
side it fires towards is rounding (:meth:`~impactosc.engine._hybrid.Switch.leaves`): ignored,
that guard cooled the same way, where it used to fire a stop again at the instant of a reversal.
Such a guard is also moved by the rounding band to the side it fires from for the piece (see
:meth:`_Loop.events`), and every event by ``START_NUDGE``. The steps are bounded by a 32nd
of the forcing period where the system has one (``max_step``): in a mode whose state is
constant (stuck) ``solve_ivp``'s steps grow without bound and a guard in the time alone,
seen only at step ends, would be stepped over.
"""

from __future__ import annotations

import math

import numpy as np

from .._util import validation as _v
from ..engine._hybrid import (
    GRAZING,
    MARKER,
    START_NUDGE,
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
from ..model.hybrid._numeric import rules
from ..results._hybrid import STATUS_MESSAGES, HybridSolution

__all__ = ["run_system"]


def _event(fn, index: int, direction: int, shift: float = START_NUDGE):
    nudge = direction * shift  # towards the side it fires from (see START_NUDGE)

    def event(t, y):
        return fn(t, y, None)[index] - nudge

    event.terminal = True  # type: ignore[attr-defined]
    event.direction = direction  # type: ignore[attr-defined]
    return event


#: How long (relative to ``1 + |t|``) a guard's extremum check stays off after one of its extrema.
QUIET_SPAN = 1e-6


class _Loop:
    """The scipy loop's state: where the run is, and what it has found."""

    def __init__(self, system: HybridSystem, switch: Switch, options: dict, zeno_tol: float, graze_tol: float,
                 cooldown: float = 1e-12):
        self.system = system
        self.switch = switch
        self.p = system.parameter_values
        self.options = options
        self.accumulation = Accumulation(zeno_tol)
        self.zeno_tol = zeno_tol
        self.graze_tol = graze_tol
        self.t, self.mode = 0.0, 0
        self.y: list = []
        self.status, self.message = 0, ""
        self.estimate: float | None = None
        self.quiet = -1  # a guard whose extremum the current piece starts at (its extremum event is off)
        self.quiet_until = -math.inf  # ... until then
        self.cooldown = cooldown
        self.cool, self.cool_until = -1, -np.inf  # a guard that fired (or rounded) just now: off until then
        # a frozen mode of a periodic system: (events so far, time, state) where its event-free period began
        self.period = usable_period(system)
        self.frozen = frozen_modes(system) if self.period is not None else ()
        self.window: tuple | None = None

    def polished(self, g: int, t_call: float, y_call: list, te: float, ye: list) -> tuple[float, list]:
        """The crossing of guard ``g`` that ``solve_ivp`` located at ``te`` on its dense output, made accurate.

        DOP853's interpolant is of lower order than its steps: an event found on it was off the
        closed form by 1.5e-9 at ``rtol = 1e-13`` (a guard moving at 0.15). The piece is
        integrated again to ``te`` (its last step ends there: no interpolation), and one Newton
        step on the guard, ``dt = -h / h'``, moves the time and the state (``y + f dt``) onto
        its root. A correction that is not small (beyond ``1e-6 (1 + |te|)``) is not taken, nor one of a
        guard within ten times the absolute tolerance of zero (flights of a chattering ball below it
        are rounding, and a correction there kept them from shrinking: a crawl of 1e-7 per bounce).
        """
        from scipy.integrate import solve_ivp

        field = self.field(self.mode)
        again = solve_ivp(field, (t_call, te), y_call, **self.options)
        if again.status != 0:
            return te, ye
        y = again.y[:, -1].tolist()
        armed = self.switch.num.armed_in[self.mode]
        values = self.switch.rules.probe[self.mode](te, y, self.p)
        i = armed.index(g)
        h, rate = values[i], values[len(armed) + i]
        if abs(h) <= 10.0 * float(np.max(self.options.get("atol", 0.0))):
            return te, ye  # within the solver's absolute accuracy: nothing to correct (a ball's flights of 1e-14)
        if rate == 0.0 or not math.isfinite(h / rate):
            return te, ye
        dt = -h / rate
        if abs(dt) > 1e-6 * (1.0 + abs(te)) or te + dt <= t_call:
            return te, ye
        f = field(te, y)
        return te + dt, [c + float(r) * dt for c, r in zip(y, f, strict=True)]

    def field(self, mode: int):
        fn, p = self.switch.rules.field[mode], self.p
        return lambda t, y: fn(t, y, p)

    def events(self, mode: int, quiet: int, cool: int, t: float, y: list):
        """``(functions, what)``: the events of ``mode`` from ``(t, y)``; ``what[i] = (guard, is_extremum)``.

        ``quiet``: a guard whose extremum event is off; ``cool``: a guard whose crossing is off.
        A guard that starts within rounding of its zero and moves away from the side it fires
        towards is moved by that rounding band (``16 eps (1 + max |y|)``) to the side it fires
        from, for this piece: ``solve_ivp`` only sees sign changes between steps, and a start a
        rounding error on the wrong side would hide a crossing back within the first step
        (a spring contact 1e-12 deep that opens ~1e-6 after it closed). The event time moves by
        the band over ``|h'|``.
        """
        switch, p = self.switch, self.p
        armed = switch.num.armed_in[mode]
        probe = switch.rules.probe[mode]
        k = len(armed)

        def values(t, y, _):
            return probe(t, y, p)

        start = values(t, y, None)
        band = 16.0 * 2.0**-52 * (switch.floor + max(abs(c) for c in y))
        fns, what = [], []
        for i, g in enumerate(armed):
            d = switch.direction[g]
            if g != cool:
                near = d != 0 and abs(start[i]) <= band and switch.leaves(g, mode, t, y)
                fns.append(_event(values, i, d, band if near else START_NUDGE))
                what.append((g, False))
            if switch.terminal[g] and g != quiet:
                fns.append(_event(values, k + i, -d))
                what.append((g, True))
        return fns, what

    def piece(self, t_end: float) -> bool:
        """Integrate one piece and handle its event; False when the run has reached ``t_end`` or failed."""
        from scipy.integrate import solve_ivp

        ruled = self.switch.jump
        if ruled is not None:  # a guard's accumulation rule answered at its last crossing: on in its rest mode
            self.switch.jump = None
            self.rest(ruled[0], ruled[1].time, t_end, ruled[1])
        if self.t >= t_end:  # a rest mode entered at the end
            self.t = t_end
            return False
        t_stop = t_end
        if self.cool >= 0 and self.cool_until < t_stop:
            t_stop = self.cool_until
        if self.quiet >= 0 and self.quiet_until < t_stop:
            t_stop = self.quiet_until  # the extremum checks of the quiet guard come back on there
        cooling = t_stop < t_end
        window_end = np.inf
        if self.frozen and self.frozen[self.mode]:
            # a whole period without an event from window[1] on: none will come (see period_jump)
            if self.window is None or self.window[0] != len(self.switch.events):
                self.window = (len(self.switch.events), self.t, list(self.y))
            window_end = self.window[1] + self.period
            if window_end < t_stop:
                t_stop, cooling = window_end, False
        fns, what = self.events(self.mode, self.quiet, self.cool, self.t, self.y)
        t_call, y_call = self.t, self.y
        sol = solve_ivp(self.field(self.mode), (self.t, t_stop), self.y, events=fns, **self.options)
        self.t, self.y = float(sol.t[-1]), sol.y[:, -1].tolist()
        if sol.status == -1:
            self.status = -1
            self.message = (f"solve_ivp failed at t={self.t!r} in mode {self.system.mode_names[self.mode]!r}: "
                            f"{sol.message}")
            return False
        if sol.status == 0 and t_stop == window_end:
            assert self.window is not None and self.period is not None
            self.t = t_stop
            if self.cool_until <= self.t:
                self.cool = -1
            if self.quiet_until <= self.t:
                self.quiet = -1
            jump = period_jump(self.switch, self.mode, self.period, t_end, self.window[1], self.window[2], self.t,
                               self.y)
            if jump is not None:
                self.t, self.y = jump
            self.switch.pieces.append((self.t, self.mode, tuple(self.y)))
            self.window = (len(self.switch.events), self.t, list(self.y))
            if jump is None:
                self.frozen = ()  # not periodic there (or an event at this instant): no more windows
            return True
        if sol.status == 0:
            self.t = t_stop
            self.cool = -1
            if self.quiet_until <= t_stop:
                self.quiet = -1
            return cooling  # the cooled guard (or the quiet extremum check) is back on; the piece goes on
        i = next(i for i, te in enumerate(sol.t_events) if len(te))
        self.t, self.y = float(sol.t_events[i][0]), sol.y_events[i][0].tolist()
        g, extremum = what[i]
        if not extremum and self.t > t_call:
            self.t, self.y = self.polished(g, t_call, y_call, self.t, self.y)
        self.quiet = -1
        self.cool = -1
        t_start = self.switch.pieces[-1][0]
        if (not extremum and self.t - t_start <= 16.0 * 2.0**-52 * (1.0 + abs(self.t))
                and self.switch.leaves(g, self.mode, self.t, self.y)):
            self.cool, self.cool_until = g, self.t + self.cooldown  # a rounding root at the piece start
            return True
        if not extremum and self.switch.keeps(g, self.mode, self.t, self.y):
            self.cool, self.cool_until = g, self.t + self.cooldown  # its transition rule keeps the mode: rounding
            return True
        if extremum:
            self.extremum(g)
        elif not self.switch.terminal[g]:
            self.switch.events.append((self.t, g, MARKER, self.mode, self.mode, tuple(self.y), tuple(self.y)))
            self.switch.pieces.append((self.t, self.mode, tuple(self.y)))
            self.switch.count(g)
        else:
            try:
                self.mode, self.y = self.switch.transition(g, self.mode, self.t, self.y)
            except InstantAccumulation:
                if not self.switch.rests(g):
                    raise
                self.rest(g, self.t, t_end)
                return True
            self.cool, self.cool_until = g, self.t + self.cooldown
            if self.switch.jump is not None:
                return True  # taken at the next piece's start
            self.estimate = self.accumulation.add(self.t, self.switch.zeno_scale[g])
            if self.estimate is not None and self.switch.rests(g):
                self.rest(g, self.estimate, t_end)
            elif self.estimate is not None:
                self.status = 2
                self.message = (f"Events accumulate (Zeno): intervals shrink geometrically; the run stops at "
                                f"t={self.t!r}, the accumulation time is estimated at {self.estimate!r}.")
        return True

    def rest(self, g: int, t_rest: float, t_end: float, jump=None) -> None:
        """Guard ``g``'s events accumulate at ``t_rest``: its rest mode from there (``Guard.rest``; with the
        ``jump`` of its accumulation rule where it answered, ``Switch.rest``)."""
        self.t = min(t_rest, t_end)
        self.mode, self.y = self.switch.rest(g, self.mode, self.t, self.y, jump)
        self.estimate = None
        self.cool = -1
        self.accumulation = Accumulation(self.zeno_tol)

    def extremum(self, g: int) -> None:
        """Guard ``g`` at an extremum: a crossing lost inside a step, a grazing, or nothing."""
        switch, t, y = self.switch, self.t, self.y
        h = switch.guard_value(g, t, y)
        d = switch.direction[g]
        t_start, _, y_start = switch.pieces[-1]
        if d * h > 0.0 and -d * switch.guard_value(g, t_start, list(y_start)) >= 0.0:
            # the guard went past zero and back within a step: its first root lies between the
            # piece start and this extremum
            t_root, y_root = _first_root(self, g, t_start, list(y_start), t)
            if not switch.keeps(g, self.mode, t_root, y_root):  # (its transition rule may call it rounding)
                self.t, self.y = t_root, y_root
                self.mode, self.y = switch.transition(g, self.mode, self.t, self.y)
                return
        # Its extremum event is off for a moment (scipy would find the zero it starts on again),
        # not for the rest of the piece: a later extremum may show a crossing lost inside a step
        # (a guard y0 - d up through zero and back within one DOP853 step after a minimum: missed).
        self.quiet, self.quiet_until = g, t + QUIET_SPAN * (1.0 + abs(t))
        at_start = t - t_start <= 16.0 * 2.0**-52 * (1.0 + abs(t))  # the extremum the piece starts at
        if not at_start and abs(h) <= self.graze_tol * (switch.floor + max(abs(c) for c in y[:self.system.dimension])):
            switch.events.append((t, g, GRAZING, self.mode, self.mode, tuple(y), tuple(y)))
        now = switch.pending(self.mode, t, y)
        if now >= 0:
            # another guard lies on zero here and crosses it: the new piece would start a rounding error past
            # it, where solve_ivp sees no sign change (a slip's stop at v = 0 where the position's extremum
            # check fired first, v = -7e-20: the mass slipped on against its friction, status 0)
            self.mode, self.y = switch.transition(now, self.mode, t, y)
            self.cool, self.cool_until = now, t + self.cooldown
            return
        switch.pieces.append((t, self.mode, tuple(y)))


def _first_root(loop: _Loop, g: int, t0: float, y0: list, t1: float) -> tuple[float, list]:
    """The root of guard ``g`` in ``(t0, t1]`` of the piece from ``(t0, y0)`` (Brent's method on its dense output)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    dense = solve_ivp(loop.field(loop.mode), (t0, t1), y0, dense_output=True, **loop.options).sol

    def h(s: float) -> float:
        return loop.switch.guard_value(g, s, dense(s).tolist())

    start = t0
    if h(start) == 0.0:  # the piece starts on the guard: step off it
        start = t0 + 1e-3 * (t1 - t0)
    root = brentq(h, start, t1, xtol=4.0 * 2.0**-52 * (1.0 + abs(t1)), rtol=4.0 * 2.0**-52)
    return float(root), dense(root).tolist()


class _Dense:
    """Dense output of a run: a piece integrated again with ``dense_output`` (picklable)."""

    def __init__(self, system: HybridSystem, method: str, rtol: float, atol: float):
        self.system, self.method, self.rtol, self.atol = system, method, rtol, atol

    def __call__(self, mode: int, t_start: float, state, times) -> np.ndarray:
        """The states at ``times`` (a frozen mode's whole periods skipped, see ``frozen_dense``)."""
        return frozen_dense(self.system, usable_period(self.system), mode, t_start, state, times,
                            lambda grid: self._integrated(mode, t_start, state, grid))

    def _integrated(self, mode: int, t_start: float, state, times) -> np.ndarray:
        from scipy.integrate import solve_ivp

        fn, p = rules(self.system).field[mode], self.system.parameter_values
        times = np.asarray(times, dtype=float)
        out = np.tile(np.asarray(state, dtype=float), (times.size, 1))
        later = times > t_start
        if later.any():
            dense = solve_ivp(lambda s, u: fn(s, u, p), (t_start, times[later].max()), list(state),
                              method=self.method, rtol=self.rtol, atol=self.atol, dense_output=True)
            out[later] = dense.sol(times[later]).T
        return out


def run_system(system: HybridSystem, t_end: float, state0, *, mode=None, t0: float = 0.0,
               max_events: int = 1_000_000, method: str = "DOP853", rtol: float = 1e-12, atol: float = 1e-12,
               max_step: float | None = None,
               zeno_tol: float = 1e-6, graze_tol: float = 1e-10, touch_tol: float = 1e-12, cooldown: float = 1e-12,
               until: tuple[str, int] | None = None) -> HybridSolution:
    """Run ``system`` with scipy's ``solve_ivp`` from ``state0`` at ``t0`` to ``t_end`` (see ``simulate_system``)."""
    t0, t_end = _v.real("t0", t0), _v.real("t_end", t_end)
    if not t_end > t0:
        raise ValueError(f"t_end must be > t0={t0!r}, got {t_end!r}")
    options = dict(method=method, rtol=_v.positive("rtol", rtol), atol=_v.positive("atol", atol))
    if max_step is None:
        # solve_ivp sees a guard only by its signs at step ends, and where the state is constant (a
        # stuck mode) its steps grow without bound: a release guard in the time alone would be
        # stepped over (a release by cos t was missed for a whole period).
        period = system.period_value()
        max_step = period / 32.0 if period is not None else np.inf
    if max_step != np.inf:
        options["max_step"] = _v.positive("max_step", max_step)
    max_events = _v.integer("max_events", max_events)
    y = check_state(system, state0) + [0.0] * len(system.integrals)
    switch = Switch(system, _v.positive("touch_tol", touch_tol))
    if until is not None:
        switch.stop_after(*until)
    run = _Loop(system, switch, options, _v.positive("zeno_tol", zeno_tol), _v.positive("graze_tol", graze_tol),
                _v.nonnegative("cooldown", cooldown))
    run.t, run.y, run.mode = t0, y, switch.initial_mode(mode, t0, y)
    switch.pieces.append((t0, run.mode, tuple(y)))
    try:
        g = switch.pending(run.mode, t0, y)
        if g >= 0:
            run.mode, run.y = switch.transition(g, run.mode, t0, y)
        while run.status == 0 and run.piece(t_end):
            if switch.done:
                run.message = switch.done_message()
                break
            if run.status == 0 and len(switch.events) >= max_events:
                run.status = 1
                run.message = f"The event limit max_events={max_events} was reached at t={run.t!r}; results are kept."
    except InstantAccumulation as exc:
        run.status, run.estimate, run.message = 2, run.t, str(exc)
    except RuntimeError as exc:
        run.status, run.message = -1, str(exc)
    return HybridSolution(system, "scipy", t_end, run.t, run.status, run.message or STATUS_MESSAGES[run.status],
                          switch.events, switch.pieces, run.y, run.mode, _Dense(system, method, rtol, atol),
                          run.estimate)
