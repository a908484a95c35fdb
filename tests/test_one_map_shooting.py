"""Issue 27 item 3: one shooting (dynamics/_newton.shoot) for the built-in family and user systems.

Closed forms first (a forced linear oscillator's steady state and multipliers), then the
built-in family's map evaluated as a user system against the exact backend, then the
verdicts of the shared Newton (the contact case's period-1 stall, explained).
"""

import math

import heyoka as hy
import numpy as np
import pytest

import impactosc
from impactosc import HybridMode, HybridSystem, symbols
from impactosc.dynamics import HybridMap, HybridOrbit, PeriodicOrbit, monodromy, periodic_orbit, periodic_orbit_of
from impactosc.dynamics._newton import shoot
from impactosc.dynamics.oscillator_map import OscillatorMap

CONTACT = impactosc.Oscillator(0.5, 1.1, 0.01, 1e4)


def linear(zeta: float, w: float, F: float = 1.0) -> HybridSystem:
    """``x'' + 2 zeta x' + x = F cos(w t)``, one mode, no guard."""
    x, v, z_, w_, F_ = symbols("x v zeta w F")
    return HybridSystem("x v", {"zeta": zeta, "w": w, "F": F},
                        [HybridMode("only", {x: v, v: F_ * hy.cos(w_ * hy.time) - x - 2 * z_ * v})], [],
                        period=2 * math.pi / w_)


def test_a_linear_oscillator_has_its_closed_form_orbit_and_multipliers():
    zeta, w, F = 0.1, 0.8, 1.0
    orbit = periodic_orbit_of(HybridMap(linear(zeta, w, F)), [0.0, 0.0])
    assert isinstance(orbit, PeriodicOrbit) and HybridOrbit is PeriodicOrbit
    assert orbit.status == 0, orbit.message
    X = F / (1.0 - w * w + 2j * zeta * w)  # x = Re(X exp(i w t))
    np.testing.assert_allclose(orbit.z, [X.real, -w * X.imag], rtol=0, atol=1e-11)
    T = 2 * math.pi / w
    mu = np.exp((-zeta + 1j * math.sqrt(1 - zeta**2)) * T)
    np.testing.assert_allclose(sorted(orbit.multipliers, key=lambda m: m.imag), [mu.conjugate(), mu], atol=1e-11)
    assert orbit.stability == "stable" and orbit.state_names == ("x", "v")
    assert orbit.period == pytest.approx(T, rel=1e-15)
    assert "x = " in orbit.summary()


def test_shoot_reports_a_failed_first_run_and_a_grazing_by_status():
    class Broken:
        state_names, names, n = ("a",), (), 1

        def values(self):
            return ()

        def period(self, params=None):
            return 1.0

        def with_names(self, names):
            return self

        def evaluate(self, z, params=None):
            return OscillatorMapValueLike(np.asarray(z, float), None, "it broke", "")

    class Grazing(Broken):
        def evaluate(self, z, params=None):
            return OscillatorMapValueLike(np.asarray(z, float), np.asarray(z, float) + 1.0, "", "a grazing")

    shot = shoot(Broken(), [0.0])
    assert shot.status == -1 and "it broke" in shot.message
    shot = shoot(Grazing(), [0.0])
    assert shot.status == 2 and shot.message.startswith("a grazing") and "last iterate" in shot.message


class OscillatorMapValueLike:
    def __init__(self, z, image, failure, singular):
        self.z, self.params, self.image, self.failure, self.singular = z, (), image, failure, singular
        self.monodromy, self.dp, self.signature = np.full((1, 1), math.nan), np.zeros((1, 0)), ()

    ok = property(lambda self: self.image is not None)
    residual = property(lambda self: self.image - self.z)


@pytest.mark.parametrize("osc, n", [
    (CONTACT, 3),                                            # the contact case: period 3, stick phases
    (impactosc.Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.05), 3),
    (impactosc.Oscillator(1.5, 0.8, 0.05, 100.0, zeta=0.1), 1),
])
def test_heyoka_as_a_user_system_gives_the_exact_backends_orbit(osc, n):
    exact = periodic_orbit(osc, n, backend="exact")
    assert exact.status == 0, exact.message
    hybrid = periodic_orbit(osc, n, guess=(exact.x, exact.v), backend="heyoka", user_system=True)
    assert hybrid.status == 0, hybrid.message
    np.testing.assert_allclose(hybrid.z, exact.z, rtol=0, atol=1e-9)
    np.testing.assert_allclose(hybrid.multipliers, exact.multipliers, rtol=0, atol=1e-9)
    assert hybrid.collapsed == exact.collapsed
    m = monodromy(osc, exact.x, exact.v, n, backend="heyoka", user_system=True)
    np.testing.assert_allclose(m.jacobian, exact.monodromy, rtol=0, atol=1e-9)


def test_the_user_system_route_is_taken_only_where_it_expresses_the_member():
    assert OscillatorMap(CONTACT, backend="heyoka", user_system=True).route == "user system"
    assert OscillatorMap(CONTACT, backend="heyoka").route == "engine"
    rigid = impactosc.Oscillator(0.8, 0.7, 0.02, 1e4, flange="rigid", restitution=0.7)
    assert OscillatorMap(rigid, backend="heyoka", user_system=True).route == "engine"
    with pytest.raises(ValueError, match="backend must be 'heyoka'"):
        OscillatorMap(CONTACT, backend="exact", user_system=True)


@pytest.mark.parametrize("zeta", [0.0, 0.05])
def test_the_contact_cases_period_one_stall_names_the_period_three_orbit(zeta):
    # The contact case settles on a period-3 orbit: no period-1 fixed point lies near the
    # transient's end, and Newton stalls in a local minimum of |P(z) - z| (residual 0.87,
    # 0.13). The stall is the right verdict; the message now says where the orbit is.
    osc = impactosc.Oscillator(0.5, 1.1, 0.01, 1e4, zeta=zeta)
    stalled = periodic_orbit(osc, backend="exact")
    assert stalled.status == 1
    assert "repeats every 3 forcing periods" in stalled.message and "n=3" in stalled.message
    found = periodic_orbit(osc, 3, backend="exact")
    assert found.status == 0 and found.stable
