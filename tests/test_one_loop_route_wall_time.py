"""Issue 27 item 4: ``max_wall_time`` on the hybrid heyoka loop (user systems and the built-in members on it).

The loop looks at the clock every ``WALL_TIME_STEPS`` integrator steps; heyoka's steps do not
depend on the previous one, so a run with a limit that it does not reach is the same run,
step for step. A run that reaches it ends with status 1 and keeps what it computed.
"""

from __future__ import annotations

import heyoka as hy
import numpy as np
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols
from impactosc.backends._hybrid_heyoka import WALL_TIME_STEPS, run_counted


def fast_forcing(omega: float) -> HybridSystem:
    """``x'' = cos(omega t) - x`` with a wall at ``x = 1`` and ``I = int x^2 dt``: no event for a long time."""
    x, v, w = symbols("x v w")
    return HybridSystem("x v", {"w": omega},
                        [HybridMode("free", {x: v, v: hy.cos(w * hy.time) - x}, integrands={"I": x * x})],
                        [Guard("wall", x - 1.0, 1, armed="free", to="free", reset={v: -v})],
                        integrals=["I"], period=2.0 * np.pi / w, name="fast forcing")


def test_a_run_that_reaches_the_limit_ends_with_status_1_and_keeps_its_results():
    # ~3e8 steps per time unit at omega = 1e8: to t = 10 this would take ~25 minutes
    sol, steps = run_counted(fast_forcing(1e8), 10.0, [0.5, 0.0], max_wall_time=0.2)
    assert sol.status == 1
    assert "max_wall_time=0.2" in sol.message and "kept" in sol.message
    assert 0.0 < sol.t_final < 10.0 and steps >= WALL_TIME_STEPS
    # what it computed: the motion under the tiny fast force is x = 0.5 cos t (to ~1e-16), I its square's integral
    t = sol.t_final
    assert sol.state_final[0] == pytest.approx(0.5 * np.cos(t), abs=1e-9)
    assert sol.integrals["I"] == pytest.approx(0.25 * (t / 2 + np.sin(2 * t) / 4), rel=1e-9)


def test_a_limit_that_is_not_reached_changes_nothing():
    system = fast_forcing(1e3)
    free, steps = run_counted(system, 60.0, [1.2, 0.0])
    limited, limited_steps = run_counted(system, 60.0, [1.2, 0.0], max_wall_time=1e6)
    assert steps > 2 * WALL_TIME_STEPS and limited_steps == steps  # several looks at the clock
    assert free.status == limited.status == 0 and len(free.events) > 3
    np.testing.assert_array_equal(limited.event_times(), free.event_times())
    np.testing.assert_array_equal(limited.state_final, free.state_final)


def test_the_limit_is_checked_naming_it():
    with pytest.raises(ValueError, match="max_wall_time"):
        impactosc.simulate(fast_forcing(1.0), 1.0, [0.0, 0.0], max_wall_time=0.0)
    with pytest.raises(TypeError, match="max_wall_time"):
        impactosc.simulate(fast_forcing(1.0), 1.0, [0.0, 0.0], max_wall_time="1")


def test_a_builtin_member_on_the_hybrid_loop_stops_at_the_limit():
    from impactosc.backends.heyoka._replay import run_on_hybrid_loop

    osc = impactosc.Oscillator(F=1.0, Omega=1e8, beta=0.1, K=10.0)
    sol = run_on_hybrid_loop(osc, 10.0, 0.0, 0.0, record="full", max_events=10**6, tol=2.0**-52, max_wall_time=0.2)
    assert sol.status == 1 and "max_wall_time=0.2" in sol.message
    assert 0.0 < sol.t_final < 10.0 and sol.n_steps >= WALL_TIME_STEPS
