"""Regressions of the exact n-DOF backend found on tape paths (issue 28): no loop at one instant, rest on
elastic stops. The three regression tests failed on the main of the session start (status -1 or status 1);
the elastic stop that keeps bouncing guards against resting too early."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import Guide, MechanicalSystem, TapeDrive, TapePath, simulate_mechanical
from impactosc.model import Contact


def _pressed_elastic_stop(harmonics):
    """A damped mass on a spring, pushed into a rigid stop with restitution 1 at q = 1."""
    return MechanicalSystem(M=[[1.0]], C=[[0.2]], K=[[1.0]], harmonics=harmonics,
                            contacts=[Contact([1.0], 1.0, law="rigid", restitution=1.0)])


def test_elastic_stop_pressed_statically_rests_and_lifts_at_the_closed_form_time():
    """Touching the stop at 1e-8 under the push ``2 cos(0.1 t) - q``: the rebound would rise 5e-17,
    below the rounding of the gap, so the mass rests (old main: impacts every ~2e-7 without end, status 1
    at max_events); it lifts off where the push vanishes, ``2 cos(0.1 t) = 1``."""
    system = _pressed_elastic_stop([([2.0], 0.1, 0.0)])
    sol = simulate_mechanical(system, 20.0, [1.0 - 1e-14], [1e-8], max_events=10_000)
    assert sol.status == 0, sol.message
    assert list(sol.events.kind[:3]) == ["impact", "rest", "lift"]
    assert sol.events.t[2] == pytest.approx(math.acos(0.5) / 0.1, abs=1e-9)
    np.testing.assert_array_equal(sol.events.v[1], [0.0])
    assert sol.energy_balance()["relative"] < 1e-9


def test_elastic_stop_keeps_bouncing_while_its_rebounds_are_measurable():
    """Dropped onto the same stop from 1e-3 below it: e = 1 keeps every rebound above the rounding
    (damping shrinks them only slowly), so no rest in 5 time units, and energy is kept to 1e-9."""
    system = _pressed_elastic_stop([([2.0], 0.0, 0.0)])
    sol = simulate_mechanical(system, 5.0, [1.0 - 1e-3], [0.0], max_events=100_000)
    assert sol.status == 0, sol.message
    assert set(sol.events.kind) == {"impact"} and len(sol.events) > 20
    assert sol.energy_balance()["relative"] < 1e-9


def test_two_guide_friction_path_release_at_the_kinetic_level_does_not_loop():
    """Guide 0 with friction (mu_s = mu_k) released while pressing its spring flange, guide 1 moving
    fast: the closed form rebuilt the resting coordinate's velocity from the neighbour's modes with a
    rounding of 5e-19 and fired the reversal again at once (old main: status -1, "no consistent mode")."""
    path = TapePath(TapeDrive(clearance=30e-6, friction=0.2), [Guide(0.01), Guide(0.03, friction=0.0)])
    sol = simulate_mechanical(path.mechanical_system(), path.seconds_to_time(2e-3), [0.0, 0.0], [0.0, 0.0])
    assert sol.status == 0, sol.message
    assert sol.energy_balance()["relative"] < 1e-9
    same_instant = np.diff(sol.events.t) == 0.0
    assert not np.any(same_instant[:-1] & same_instant[1:] & (sol.events.kind[2:] == "reversal"))


def test_rigid_four_guide_path_at_4_m_s_reaches_its_end():
    """The benchmark's rigid-flanged four-guide path at 4 m/s: guide 2 sits on its lower flange in a
    quasi-static balance, an impact leaves it at 9e-18 and the closed form saw it approach again at
    1.2e-17 (rounding of the neighbours' modes); old main: status -1 at 0.43 s of tape, a loop of
    identical impacts."""
    guides = tuple(Guide(x, clearance=c, wrap_angle=w, flange="rigid", restitution=0.8)
                   for x, c, w in ((0.02, 300e-6, None), (0.05, 200e-6, 90.0), (0.08, 20e-6, None),
                                   (0.11, 300e-6, None)))
    path = TapePath(TapeDrive(speed=4.0, friction=0.0, damping_ratio=0.02), guides, end_span=0.03)
    sol = simulate_mechanical(path.mechanical_system(), path.seconds_to_time(0.5), np.zeros(4), np.zeros(4))
    assert sol.status == 0, sol.message
    assert sol.t == pytest.approx(path.seconds_to_time(0.5), rel=1e-15)
    assert sol.energy_balance()["relative"] < 1e-9
