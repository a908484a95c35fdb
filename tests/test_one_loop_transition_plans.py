"""The generated transition of each (guard, mode) decides as the separate rules do.

``model.hybrid._numeric.plan`` composes the reset, the entry conditions and the check for a
guard the new state lies on into one generated function per (guard, mode), for the event
loops' speed; here its answers are compared with :meth:`Switch.apply` and
:meth:`Switch.pending` on states drawn on and near the guards (exact zeros included).
"""

from __future__ import annotations

import heyoka as hy
import numpy as np
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, stick_slip, symbols
from impactosc.engine._hybrid import Switch
from impactosc.model.hybrid import oscillator_system
from impactosc.model.hybrid._numeric import plan


def _ball() -> HybridSystem:
    x, v, g, e = symbols("x v g e")
    return HybridSystem("x v", {"g": 9.81, "e": 0.8}, [HybridMode("flight", {x: v, v: -g})],
                        [Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})])


def _crossing() -> HybridSystem:
    y, c = symbols("y c")
    return HybridSystem("y", {"c": 0.9}, [HybridMode("a", {y: c - hy.cos(hy.time)})],
                        [Guard("up", y, 1, armed="a", to="a")])


def _friction() -> HybridSystem:
    v, A, K, S = symbols("v A K S")
    modes, guards = stick_slip("m", v, A * hy.cos(hy.time), K, S)
    return HybridSystem("v", {"A": 1.3, "K": 0.8, "S": 1.2}, modes, guards)


SYSTEMS = {
    "eq3": lambda: oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)),
    "eq3 static friction": lambda: oscillator_system(impactosc.Oscillator(F=0.3, Omega=0.7, beta=0.1, beta_static=0.2,
                                                                          K=50.0, zeta=0.05)),
    "eq3 rigid": lambda: oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, flange="rigid",
                                                                restitution=0.8)),
    "ball": _ball,
    "crossing": _crossing,
    "friction": _friction,
}


def _reference(switch: Switch, g: int, mode: int, t: float, y: list):
    """``(target, after, next)`` from the separate rules, or the error they raise."""
    try:
        target, after = switch.apply(g, mode, t, y)
    except RuntimeError:
        return -1, None, None
    crossed = g if switch.rules.reset[g] is None else -1
    return target, after, switch.pending(target, t, after, crossed)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_each_plan_decides_as_apply_and_pending(name):
    system = SYSTEMS[name]()
    switch = Switch(system)
    num, rules = switch.num, switch.rules
    rng = np.random.default_rng(7)
    n_all = len(num.states)
    checked = 0
    for g, modes in enumerate(num.armed):
        for mode in modes:
            step = plan(num, rules, g, mode)
            assert step is not None, (name, system.guard_names[g])
            for k in range(200):
                y = list(rng.uniform(-2.0, 2.0, n_all))
                # on a guard's zero, exactly or within the touch tolerance, with a zero velocity at times
                if k % 4 == 0:
                    y[min(1, n_all - 1)] = 0.0
                if k % 3 == 0 and system.dimension > 1:
                    y[0] = float(rng.choice([1.0, -1.0, 1.0 + 1e-13]))
                t = float(rng.uniform(0.0, 10.0))
                want_target, want_after, want_next = _reference(switch, g, mode, t, y)
                target, after, then = step(t, y, switch.p, switch.touch_tol)
                assert target == want_target, (name, system.guard_names[g], y)
                if target < 0:
                    continue
                assert list(after) == list(want_after)
                if then == -2:  # a tangency: the loop runs the full check
                    continue
                assert then == want_next, (name, system.guard_names[g], y)
                checked += 1
    assert checked > 100
