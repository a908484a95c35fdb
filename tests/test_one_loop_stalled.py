"""A run whose integrator steps fall to the rounding of the time ends with a status, never a hang."""

import math

import heyoka as hy
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols

x = symbols("x")


@pytest.mark.parametrize("backend_options", [{}, {"max_wall_time": 60.0}])
def test_a_pole_ahead_ends_the_run_with_status_minus_one(backend_options):
    """x' = 1 / (1 - t): heyoka's steps shrink towards the pole at t = 1 until the time no longer moves.
    The loop went on calling the integrator for ever (with max_wall_time, until the clock ran out);
    it now stops at the first chunk of steps that did not move the time, with what it computed."""
    pole = HybridSystem("x", {}, [HybridMode("m", {x: 1.0 / (1.0 - hy.time)})],
                        [Guard("far", x - 100.0, 1, armed="m", to="m")], name="pole")
    sol = impactosc.simulate(pole, 2.0, [0.0], **backend_options)
    assert sol.status == -1
    assert "rounding of the time" in sol.message and "singular" in sol.message
    assert 1.0 - 1e-12 < sol.t_final < 1.0
    # x = -log(1 - t), finite where the run stopped; 1 - t ~ 2e-15 is known to ~eps there, so x to ~1e-2 of 34
    assert sol.state_final[0] == pytest.approx(-math.log1p(-sol.t_final), rel=1e-2)
