"""The scipy event loop for user hybrid systems: one ``solve_ivp`` per smooth piece, the cross-check.

The same definition as the heyoka loop, turned into numeric functions (the vector fields,
guards and Lie derivatives of :mod:`impactosc.model.hybrid._numeric`), and the same
transitions (:class:`~impactosc.engine._hybrid.Switch`). Each piece is one ``solve_ivp``
in a fixed mode with every armed guard as a terminal event in its direction, and the
guard's Lie derivative as a terminal event at the extrema that can touch zero: there
the guard's value is checked, as in the heyoka loop. After an extremum of a guard, that
guard's extremum events are off until the next event (scipy would find the same zero again
at the restart).
"""

from __future__ import annotations

import numpy as np

from .._util import validation as _v
from ..engine._hybrid import GRAZING, MARKER, Accumulation, InstantAccumulation, Switch, check_state
from ..model.hybrid._definition import HybridSystem
from ..model.hybrid._numeric import rules
from ..results._hybrid import STATUS_MESSAGES, HybridSolution

__all__ = ["run_system"]


def _event(fn, index: int, direction: int):
    def event(t, y):
        return fn(t, y, None)[index]

    event.terminal = True  # type: ignore[attr-defined]
    event.direction = direction  # type: ignore[attr-defined]
    return event


class _Piecewise:
    """The loop's state between pieces."""

    def __init__(self, system: HybridSystem, switch: Switch, options: dict):
        self.system = system
        self.switch = switch
        self.p = system.parameter_values
        self.options = options

    def field(self, mode: int):
        fn, p = self.switch.rules.field[mode], self.p
        return lambda t, y: fn(t, y, p)

    def events(self, mode: int, quiet: int):
        """``(functions, what)``: the events of ``mode``; ``what[i] = (guard, is_extremum)``."""
        switch, p = self.switch, self.p
        armed = switch.num.armed_in[mode]
        probe = switch.rules.probe[mode]
        k = len(armed)

        def values(t, y, _):
            return probe(t, y, p)

        fns, what = [], []
        for i, g in enumerate(armed):
            d = switch.direction[g]
            fns.append(_event(values, i, d))
            what.append((g, False))
            if switch.terminal[g] and g != quiet:
                fns.append(_event(values, k + i, -d))
                what.append((g, True))
        return fns, what


def _first_root(loop: _Piecewise, switch: Switch, mode: int, g: int, t0: float, y0: list, t1: float, method: str,
                rtol: float, atol: float) -> tuple[float, list]:
    """The root of guard ``g`` in ``(t0, t1]`` of the piece from ``(t0, y0)`` (Brent's method on its dense output)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    dense = solve_ivp(loop.field(mode), (t0, t1), y0, method=method, rtol=rtol, atol=atol, dense_output=True).sol

    def h(s: float) -> float:
        return switch.guard_value(g, s, dense(s).tolist())

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
               zeno_tol: float = 1e-6, graze_tol: float = 1e-10, touch_tol: float = 1e-12,
               until: tuple[str, int] | None = None) -> HybridSolution:
    """Run ``system`` with scipy's ``solve_ivp`` from ``state0`` at ``t0`` to ``t_end`` (see ``simulate_system``)."""
    from scipy.integrate import solve_ivp

    t0, t_end = _v.real("t0", t0), _v.real("t_end", t_end)
    if not t_end > t0:
        raise ValueError(f"t_end must be > t0={t0!r}, got {t_end!r}")
    rtol, atol = _v.positive("rtol", rtol), _v.positive("atol", atol)
    max_events = _v.integer("max_events", max_events)
    accumulation = Accumulation(_v.positive("zeno_tol", zeno_tol))
    graze_tol = _v.positive("graze_tol", graze_tol)
    y = check_state(system, state0) + [0.0] * len(system.integrals)
    switch = Switch(system, _v.positive("touch_tol", touch_tol))
    if until is not None:
        switch.stop_after(*until)
    loop = _Piecewise(system, switch, {})
    n = system.dimension
    t, current = t0, switch.initial_mode(mode, t0, y)
    switch.pieces.append((t, current, tuple(y)))
    status, message, estimate = 0, "", None

    def transition(g: int, t: float, y: list, current: int):
        return switch.transition(g, current, t, y)

    quiet = -1
    try:
        g = switch.pending(current, t, y)
        if g >= 0:
            current, y = transition(g, t, y, current)
        while status == 0:
            fns, what = loop.events(current, quiet)
            sol = solve_ivp(loop.field(current), (t, t_end), y, method=method, rtol=rtol, atol=atol, events=fns)
            if sol.status == -1:
                status = -1
                message = (f"solve_ivp failed at t={float(sol.t[-1])!r} in mode {system.mode_names[current]!r}: "
                           f"{sol.message}")
                t, y = float(sol.t[-1]), sol.y[:, -1].tolist()
                break
            t, y = float(sol.t[-1]), sol.y[:, -1].tolist()
            if sol.status == 0:
                t = t_end
                break
            fired = [i for i, te in enumerate(sol.t_events) if len(te)]
            i = fired[0]
            y = sol.y_events[i][0].tolist()
            t = float(sol.t_events[i][0])
            g, extremum = what[i]
            quiet = -1
            if extremum:
                h = switch.guard_value(g, t, y)
                d = switch.direction[g]
                t_start, _, y_start = switch.pieces[-1]
                at_start = t - t_start <= 16.0 * 2.0**-52 * (1.0 + abs(t))  # the extremum the piece starts at
                if d * h > 0.0 and -d * switch.guard_value(g, t_start, list(y_start)) >= 0.0:
                    # the guard went past zero and back within a step: its first root lies
                    # between the piece start and this extremum
                    t, y = _first_root(loop, switch, current, g, t_start, list(y_start), t, method, rtol, atol)
                    current, y = transition(g, t, y, current)
                else:
                    quiet = g
                    if not at_start and abs(h) <= graze_tol * (1.0 + max(abs(c) for c in y[:n])):
                        switch.events.append((t, g, GRAZING, current, current, tuple(y), tuple(y)))
                    switch.pieces.append((t, current, tuple(y)))
            elif not switch.terminal[g]:
                switch.events.append((t, g, MARKER, current, current, tuple(y), tuple(y)))
                switch.pieces.append((t, current, tuple(y)))
                switch.count(g)
            else:
                current, y = transition(g, t, y, current)
                estimate = accumulation.add(t)
                if estimate is not None:
                    status = 2
                    message = (f"Events accumulate (Zeno): intervals shrink geometrically; the run stops at t={t!r}, "
                               f"the accumulation time is estimated at {estimate!r}.")
            if switch.done:
                message = switch.done_message()
                break
            if status == 0 and len(switch.events) >= max_events:
                status = 1
                message = f"The event limit max_events={max_events} was reached at t={t!r}; results are kept."
    except InstantAccumulation as exc:
        status, estimate, message = 2, t, str(exc)
    except RuntimeError as exc:
        status, message = -1, str(exc)
    evaluate = _Dense(system, method, rtol, atol)
    return HybridSolution(system, "scipy", t_end, t, status, message or STATUS_MESSAGES[status], switch.events,
                          switch.pieces, y, current, evaluate, estimate)
