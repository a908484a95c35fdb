"""Guards that start a piece exactly on their zero: their later roots are found (regression tests).

heyoka took an event polynomial whose constant term is exactly 0 for a root at the step's
start and lost the later root in the same isolating interval; scipy's ``solve_ivp`` took a
guard still exactly 0 after its first step for a root at the start, and fired it again at
the instant of the transition. Both loops now move every event a hair (``START_NUDGE``)
to the side it fires from, and a guard crossed without a reset is not fired again at the
same instant.
"""

from __future__ import annotations

import math

import heyoka as hy
import numpy as np
import pytest
from scipy.optimize import brentq

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, stick_slip, symbols

TOL = {"heyoka": 1e-12, "scipy": 1e-9}


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_rising_root_after_a_start_on_zero_is_found(backend):
    """``y' = c - cos t`` from ``y(0) = 0``: ``y = c t - sin t`` dips below 0 and rises through it at
    the root of ``sin t = c t`` (0.78668 for c = 0.9); heyoka found nothing, scipy found it 65 times."""
    y, c = symbols("y c")
    system = HybridSystem("y", {"c": 0.9}, [HybridMode("a", {y: c - hy.cos(hy.time)})],
                          [Guard("up", y, 1, armed="a", to="a")])
    sol = impactosc.simulate(system, 2.0, [0.0], backend=backend)
    root = brentq(lambda t: 0.9 * t - math.sin(t), 0.5, 1.0, xtol=1e-15)
    assert sol.status == 0, sol.message
    assert [e.guard for e in sol.events] == ["up"]
    assert abs(sol.events[0].t - root) <= TOL[backend]


def _friction_referee(a: float, k: float, s: float, t_end: float) -> list[tuple[float, str]]:
    """The events of ``v' = a cos t - k sgn v`` (stuck while ``|a cos t| <= s``) from ``v(0) = 0``,
    from the closed form of each piece: slipping with sign ``q``, ``v = a (sin t - sin t0) - q k (t - t0)``."""
    t0, mode, out = 0.0, "+" if a > s else "0", []
    grid_step = 1e-3
    while t0 < t_end:
        if mode == "0":
            def g_up(t):
                return a * math.cos(t) - s

            def g_down(t):
                return a * math.cos(t) + s
            fns = [(g_up, "m release+", "+", 1), (g_down, "m release-", "-", -1)]
        else:
            q = 1.0 if mode == "+" else -1.0
            start = t0

            def vel(t, start=start, q=q):
                return a * (math.sin(t) - math.sin(start)) - q * k * (t - start)
            fns = [(vel, f"m{mode} stop", None, -int(q))]
        hit = None
        t = t0 + 1e-9
        while hit is None and t < t_end:
            for fn, name, to, d in fns:
                if d * fn(t) < 0.0 <= d * fn(t + grid_step) or (fn(t + grid_step) == 0.0):
                    hit = (brentq(fn, t, t + grid_step, xtol=1e-15, rtol=1e-15), name, to)
                    break
            t += grid_step
        if hit is None:
            break
        t0, name, to = hit
        if to is None:  # a stop: stuck if the force is within the static level, else reversed
            force = a * math.cos(t0)
            to = "0" if abs(force) <= s else ("+" if force > 0 else "-")
        out.append((t0, name))
        mode = to
    return out


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
@pytest.mark.parametrize("a, k, s", [(1.0, 0.9, 0.95), (2.0, 0.9, 0.95), (1.3, 0.8, 1.2)])
def test_a_stop_after_a_start_at_rest_or_a_reversal_is_not_lost(backend, a, k, s):
    """Coulomb friction under ``a cos t`` (one state, the velocity): each slip starts with ``v = 0``
    exactly (from rest, after a release, after a reversal), so the stop guard starts on its zero;
    heyoka lost the stops that came within the first Taylor step. Events against the closed form."""
    v, A, K, S = symbols("v A K S")
    modes, guards = stick_slip("m", v, A * hy.cos(hy.time), K, S)
    # the forcing period bounds scipy's steps: in the stuck mode the state is constant
    system = HybridSystem("v", {"A": a, "K": k, "S": s}, modes, guards, period=2.0 * math.pi)
    t_end = 12.0
    want = _friction_referee(a, k, s, t_end)
    assert len(want) >= 5
    sol = impactosc.simulate(system, t_end, [0.0], backend=backend, max_events=200)
    assert sol.status == 0, sol.message
    got = [(e.t, e.guard) for e in sol.events if e.kind == "crossing"]
    assert [g for _, g in got] == [g for _, g in want]
    assert np.max(np.abs(np.array([t for t, _ in got]) - [t for t, _ in want])) <= TOL[backend] * 10
