"""Points where the stroboscopic map has no Jacobian must say so (issue 20, item 5).

(a) a start at rest held by static friction alone (``beta < |f_net| <= beta_static``): the
map jumps in ``V``; (b) a grazing impact on a rigid flange: the saltation matrix blows up
like ``1/V``. Both are status 2 ("not differentiable"), never a converged orbit with a
Jacobian, and the orbits next to them keep their (finite-difference checked) Jacobians.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest

from impactosc import Oscillator, simulate
from impactosc.dynamics import lyapunov_exponent, monodromy, periodic_orbit, saltation_matrix
from impactosc.engine import ENTER_UPPER, Mode

# -- (a) static friction alone -------------------------------------------------------------
#: At X = -0.2 at rest f_net = 0.1 cos t + 0.2 lies in [0.1, 0.3]: above beta = 0.1 (except
#: at t = pi), below beta_static = 0.5: the mass stays put, but only static friction holds it.
HELD = Oscillator(0.1, 1.0, 0.1, 1e4, beta_static=0.5)


def test_start_held_by_static_friction_alone_is_not_differentiable():
    # The map is discontinuous there: a velocity of 1e-12 slides the mass by ~0.255 in a period.
    T = 2.0 * math.pi
    still = simulate(HELD, T, -0.2, 0.0, backend="exact")
    nudged = simulate(HELD, T, -0.2, 1e-12, backend="exact")
    assert still.x_final == -0.2
    assert nudged.x_final - still.x_final > 0.2
    orbit = periodic_orbit(HELD, guess=(-0.2, 0.0), backend="exact")
    assert orbit.status == 2, orbit.message
    assert "static friction" in orbit.message and "not differentiable" in orbit.message
    assert orbit.stability == "undefined"
    assert np.all(np.isnan(orbit.monodromy))
    m = monodromy(HELD, -0.2, 0.0, backend="heyoka")
    assert not m.differentiable and "beta_static" in m.reason
    assert np.all(np.isnan(m.jacobian))


def test_start_held_within_the_kinetic_band_keeps_its_jacobian():
    # |f_net| <= beta: any small velocity dies at once, the map is flat in V: M = [[1, 0], [0, 0]].
    robust = Oscillator(0.1, 1.0, 0.35, 1e4, beta_static=0.5)
    orbit = periodic_orbit(robust, guess=(-0.2, 0.0), backend="exact")
    assert orbit.status == 0, orbit.message
    assert orbit.collapsed
    np.testing.assert_array_equal(orbit.monodromy, [[1.0, 0.0], [0.0, 0.0]])
    for dv in (1e-6, -1e-6):  # the nudged mass slips O(dv^2) and sticks again
        moved = monodromy(robust, -0.2, dv, backend="exact")
        assert abs(moved.x + 0.2) < 1e-9 and moved.v == 0.0


def test_stick_in_the_static_band_during_the_period_is_differentiable():
    # Arriving at V = 0 with beta < |f_net| <= beta_static the mass sticks, and so does every
    # neighbour (V reaches 0 at a nearby point): the stick's saltation matrix exists.
    h = 1e-7
    z = np.array([-0.2, -1e-2])
    m = monodromy(HELD, *z, backend="exact")
    assert m.differentiable and m.collapsed, m.reason
    assert "stick" in m.events.kind
    fd = np.empty((2, 2))
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        fd[:, k] = (np.array(monodromy(HELD, *(z + e), backend="exact")[:2])
                    - np.array(monodromy(HELD, *(z - e), backend="exact")[:2])) / (2 * h)
    np.testing.assert_allclose(m.jacobian, fd, atol=1e-7)


def test_rest_on_a_rigid_wall_held_by_static_friction_alone():
    # At the upper wall the pull away from it is 1 - 0.1 cos t in [0.9, 1.1]: above beta = 0.5,
    # below beta_static = 1.2. A velocity away from the wall slides the mass off.
    wall = Oscillator(0.1, 1.0, 0.5, 1.0, flange="rigid", beta_static=1.2)
    assert simulate(wall, 2 * math.pi, 1.0, -1e-12, backend="exact").x_final < 0.9
    m = monodromy(wall, 1.0, 0.0, backend="exact")
    assert not m.differentiable and "static friction" in m.reason


def test_lyapunov_exponent_is_not_refused_for_a_held_start():
    # The exponent is a rate along the trajectory: one instant at rest at the start does not
    # change it (the tangent dynamics of the periods after it exist).
    res = lyapunov_exponent(HELD, 5, transient_periods=0, x0=-0.2, v0=0.0, backend="exact")
    assert res.status == 0, res.message
    assert res.exponent == pytest.approx(math.log(math.sqrt(0.5)) / (5 * 2 * math.pi), abs=1e-12)


# -- (b) grazing impact on a rigid flange ----------------------------------------------------
ZETA, W, E = 0.05, 0.8, 0.8
#: With F = |1 - W^2 + 2i zeta W| the free linear response X = cos(W t - phi) has amplitude 1:
#: it touches both walls with V = 0 (the restitution never acts).
GRAZING_F = abs(complex(1.0 - W * W, 2.0 * ZETA * W))
PHI = cmath.phase(complex(1.0 - W * W, 2.0 * ZETA * W))
GRAZER = Oscillator(GRAZING_F, W, 0.0, 1.0, flange="rigid", zeta=ZETA, restitution=E)


@pytest.mark.parametrize("backend", ["heyoka", "exact", "scipy"])
def test_grazing_impact_orbit_is_reported_not_differentiable(backend):
    guess = (math.cos(PHI), W * math.sin(PHI))  # X(0), V(0) of the closed form
    orbit = periodic_orbit(GRAZER, guess=guess, backend=backend)
    assert orbit.status == 2, (orbit.status, orbit.message, orbit.multipliers)
    assert "grazing" in orbit.message and "not differentiable" in orbit.message
    assert orbit.stability == "undefined"
    assert orbit.x == pytest.approx(guess[0], abs=1e-9) and orbit.v == pytest.approx(guess[1], abs=1e-9)


def test_slow_impact_below_the_grazing_bound_has_no_saltation_matrix():
    from impactosc.dynamics.saltation import GRAZING

    osc = Oscillator(0.3, 1.0, 0.1, 1e4, flange="rigid", restitution=0.6)
    a = abs(osc._accel_scalar(1.0, 1.0, 0.0, 0, 1))
    bound = GRAZING * math.sqrt(2.0 * 2.0**-52 * a)
    for v in (1.2e-16, 0.5 * bound):
        s = saltation_matrix(osc, 1.0, Mode(0, 1), ENTER_UPPER, Mode(0, -1), 1.0, v, 1.0, -0.6 * v, "impact")
        assert s.singular and "grazing" in s.reason, v
    v = 100.0 * bound  # a slow but resolved impact keeps the formula [[-e, 0], [(a+ + e a-)/V, -e]]
    s = saltation_matrix(osc, 1.0, Mode(0, 1), ENTER_UPPER, Mode(0, -1), 1.0, v, 1.0, -0.6 * v, "impact")
    a_minus = osc._accel_scalar(1.0, 1.0, v, 0, 1)
    a_plus = osc._accel_scalar(1.0, 1.0, -0.6 * v, 0, -1)
    assert not s.singular
    np.testing.assert_allclose(s.matrix, (-0.6, 0.0, (a_plus + 0.6 * a_minus) / v, -0.6), rtol=1e-12)


def test_slow_impacts_inside_a_chatter_are_not_grazing():
    # The impacts of a chatter slow down geometrically below the grazing bound before the jump
    # to rest resolves them; the jump makes the map locally constant (Jacobian 0), so they are
    # no singularity. Neither is the apex of a rebound a rounding away from the wall.
    from impactosc.dynamics.saltation import GRAZING
    from impactosc.dynamics.tangent import tangent_run

    osc = Oscillator(2.0, 0.3, 0.05, 1.0, flange="rigid", restitution=0.8)
    sol, rec = tangent_run(osc, 200.0, 0.0, 0.0, backend="exact", record="events")
    impacts = sol.events[sol.events.kind == "impact"]
    assert np.min(np.abs(impacts.v)) < GRAZING * math.sqrt(2.0 * 2.0**-52)  # the premise: below the bound
    assert sol.counts["chatter"] >= 1
    assert rec.singular is None, rec.singular.reason
    assert rec.collapsed
