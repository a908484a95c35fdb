"""A guard whose events accumulate leads into a rest mode (``Guard.rest``): the bouncing ball lands.

Closed forms: a ball dropped from rest at height ``h`` with restitution ``e`` lands for good at
``sqrt(2 h / g) (1 + 2 e / (1 - e))``; kicked up from the floor at ``T`` with speed ``V``, it
lands again ``2 V / (g (1 - e))`` later (the flights ``2 V e^k / g``).
"""

from __future__ import annotations

import math

import heyoka as hy
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols

G, E, H, T_KICK, V_KICK = 9.81, 0.8, 1.0, 6.0, 3.0
TOL = {"heyoka": 1e-9, "scipy": 1e-7}


def landing_ball() -> HybridSystem:
    x, v, g, e, T, V = symbols("x v g e T V")
    modes = [HybridMode("flight", {x: v, v: -g}), HybridMode("floor", {x: 0.0, v: 0.0})]
    guards = [Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v}, rest="floor",
                    rest_reset={x: 0.0, v: 0.0}),
              Guard("kick", hy.time - T, 1, armed="floor", to="flight", reset={v: V})]
    return HybridSystem("x v", {"g": G, "e": E, "T": T_KICK, "V": V_KICK}, modes, guards)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_the_ball_rests_on_the_floor_at_its_zeno_time_and_flies_again_when_kicked(backend):
    sol = impactosc.simulate(landing_ball(), 12.0, [H, 0.0], backend=backend)
    assert sol.status == 0, sol.message
    rests = [e for e in sol.events if e.kind == "rest"]
    first = math.sqrt(2.0 * H / G) * (1.0 + 2.0 * E / (1.0 - E))
    second = T_KICK + 2.0 * V_KICK / (G * (1.0 - E))
    assert [e.mode_after for e in rests] == ["floor", "floor"]
    assert abs(rests[0].t - first) <= TOL[backend]
    assert abs(rests[1].t - second) <= TOL[backend]
    kicks = sol.event_times("kick")
    assert len(kicks) == 1 and abs(kicks[0] - T_KICK) <= 1e-12
    assert sol.mode_final == "floor"
    assert list(sol.state_final) == [0.0, 0.0]
    # between the rests every event is an impact, and none after the kick comes before it
    impacts = sol.event_times("impact")
    assert all(t < first or T_KICK < t < second for t in impacts)


def test_without_a_rest_mode_the_accumulation_still_ends_the_run():
    x, v, g, e = symbols("x v g e")
    ball = HybridSystem("x v", {"g": G, "e": E}, [HybridMode("flight", {x: v, v: -g})],
                        [Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})])
    sol = impactosc.simulate(ball, 12.0, [H, 0.0])
    assert sol.status == 2
    assert abs(sol.accumulation_time - math.sqrt(2.0 * H / G) * (1.0 + 2.0 * E / (1.0 - E))) <= 1e-9


def test_a_rest_mode_is_checked_at_construction():
    x, v, g = symbols("x v g")
    flight = HybridMode("flight", {x: v, v: -g})
    with pytest.raises(ValueError, match="rest names the mode 'table'"):
        HybridSystem("x v", {"g": G}, [flight], [Guard("impact", x, -1, armed="flight", rest="table")])
    with pytest.raises(ValueError, match="rest_reset"):
        Guard("impact", x, -1, armed="flight", rest_reset={v: 0.0})
    with pytest.raises(ValueError, match="rest_reset of 'w'"):
        HybridSystem("x v", {"g": G}, [flight, HybridMode("floor", {x: 0.0, v: 0.0})],
                     [Guard("impact", x, -1, armed="flight", rest="floor", rest_reset={"w": 0.0})])
