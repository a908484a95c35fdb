"""Issue 27 item 3: Lyapunov exponents of user systems from the map's tangent products."""

import math

import heyoka as hy
import numpy as np
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols
from impactosc.dynamics import HybridMap, lyapunov_exponent, periodic_orbit_of
from impactosc.model.hybrid import oscillator_system


def linear(zeta: float, w: float) -> HybridSystem:
    x, v, z_, w_ = symbols("x v zeta w")
    return HybridSystem("x v", {"zeta": zeta, "w": w},
                        [HybridMode("only", {x: v, v: hy.cos(w_ * hy.time) - x - 2 * z_ * v})], [],
                        period=2 * math.pi / w_)


def test_a_linear_oscillator_forced_at_its_damped_frequency_has_exponent_minus_zeta():
    # w = sqrt(1 - zeta^2): one forcing period turns the free motion by exactly 2 pi, so the
    # monodromy matrix is exp(-zeta T) I and every renormalisation logs -zeta T.
    zeta = 0.1
    result = lyapunov_exponent(linear(zeta, math.sqrt(1 - zeta**2)), 30, transient_periods=5, state0=[0.3, 0.0])
    assert result.status == 0, result.message
    assert result.exponent == pytest.approx(-zeta, abs=1e-9)
    np.testing.assert_allclose(result.history, -zeta, atol=1e-9)


def test_a_linear_oscillator_at_another_frequency_converges_to_minus_zeta():
    # |M^k u| = exp(-zeta k T) |S R^k S^-1 u| with S the eigenvectors (cond <= (1 + zeta)/(1 - zeta)):
    # the estimate after a time t is within log cond / t of -zeta.
    zeta, w, periods = 0.05, 0.8, 100
    result = lyapunov_exponent(linear(zeta, w), periods, transient_periods=0, state0=[0.0, 0.0])
    t = periods * 2 * math.pi / w
    assert abs(result.exponent + zeta) <= math.log((1 + zeta) / (1 - zeta)) / t + 1e-9
    assert result.t[-1] == pytest.approx(t, rel=1e-14)


def test_the_built_in_and_the_user_system_exponents_agree_on_the_contact_case():
    osc = impactosc.Oscillator(0.5, 1.1, 0.01, 1e4)
    built_in = lyapunov_exponent(osc, 60, transient_periods=100, backend="exact")
    user = lyapunov_exponent(oscillator_system(osc), 60, transient_periods=100, state0=[0.95, 0.0])
    assert built_in.status == user.status == 0
    assert user.exponent == pytest.approx(built_in.exponent, abs=1e-6)
    np.testing.assert_allclose(user.growth, built_in.growth, rtol=0, atol=1e-6)


def test_a_map_of_several_periods_and_the_stable_orbits_multiplier():
    # On a stable period-1 orbit with two impacts the exponent is log|mu_max| / T.
    x, v, zeta, A, w, d, e = symbols("x v zeta A w d e")
    stop = HybridSystem("x v", {"zeta": 0.05, "A": 1.2, "w": 0.8, "d": 0.6, "e": 0.7},
                        [HybridMode("free", {x: v, v: A * hy.cos(w * hy.time) - x - 2 * zeta * v})],
                        [Guard("impact", x - d, 1, armed="free", to="free", reset={v: -e * v})],
                        period=2 * math.pi / w)
    orbit = periodic_orbit_of(HybridMap(stop), [0.0, 0.0])
    assert orbit.status == 0
    result = lyapunov_exponent(HybridMap(stop, 2, names=()), 40, transient_periods=0, state0=orbit.z)
    expected = math.log(abs(orbit.multipliers[0])) / orbit.period
    assert result.status == 0 and result.t[-1] == pytest.approx(80 * orbit.period)
    # the bounded transient factor of a complex pair: within log(cond)/t, cond of the eigenvectors
    _, vecs = np.linalg.eig(orbit.monodromy)
    assert abs(result.exponent - expected) <= math.log(np.linalg.cond(vecs)) / result.t[-1] + 1e-9


def test_bad_arguments_name_themselves():
    system = linear(0.1, 0.8)
    with pytest.raises(TypeError, match="state0"):
        lyapunov_exponent(system, 10, x0=0.3)
    with pytest.raises(ValueError, match="state0 must be 2 finite numbers"):
        lyapunov_exponent(system, 10, state0=[0.0])
    with pytest.raises(TypeError, match="state0 is a user system's start"):
        lyapunov_exponent(impactosc.Oscillator(0.5, 1.1, 0.01, 1e4), 10, state0=[0.0, 0.0])
    with pytest.raises(TypeError, match="lyapunov_exponent needs"):
        lyapunov_exponent(object(), 10)
