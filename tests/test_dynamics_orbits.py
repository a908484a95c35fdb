"""Periodic orbits by Newton shooting: closed forms, stability verdicts, Lyapunov exponents, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import Oscillator, TapeDrive
from impactosc.dynamics import (
    den_hartog_amplitude,
    den_hartog_multipliers,
    forcing_period,
    lyapunov_exponent,
    periodic_orbit,
)

# The forced Coulomb oscillator of Den Hartog (1931): a non-stop steady state with two
# stops per period, amplitude 0.82, clear of the flanges.
DEN_HARTOG = Oscillator(0.3, 0.8, 0.05, 1e4)


@pytest.fixture(scope="module")
def den_hartog_orbit():
    return periodic_orbit(DEN_HARTOG, 1, transient_periods=200)


def test_den_hartog_amplitude_and_multipliers(den_hartog_orbit):
    orbit = den_hartog_orbit
    assert orbit.status == 0, orbit.message
    assert [str(k) for k in orbit.events.kind] == ["reversal", "reversal"]
    A = den_hartog_amplitude(0.3, 0.8, 0.05)
    stops = np.abs(orbit.events.x)
    print(f"amplitude: closed form {A:.15f}, orbit {stops.max():.15f}, error {abs(stops.max() - A):.2e}")
    np.testing.assert_allclose(stops, A, rtol=1e-12)
    mu = den_hartog_multipliers(0.3, 0.8, 0.05)
    # Sorted by the imaginary part: a conjugate pair's real parts may differ by an ulp.
    def by_imag(z):
        return np.asarray(sorted(z, key=lambda w: (w.imag, w.real)))

    err = np.abs(by_imag(orbit.multipliers) - by_imag(mu)).max()
    print(f"multipliers: closed form {mu}, shooting {orbit.multipliers}, error {err:.2e}")
    assert err < 1e-9
    assert orbit.stability == "stable" and orbit.stable and not orbit.collapsed


def test_lyapunov_of_a_stable_orbit_is_log_multiplier_over_period(den_hartog_orbit):
    orbit = den_hartog_orbit
    expected = math.log(orbit.spectral_radius) / orbit.period
    res = lyapunov_exponent(DEN_HARTOG, 600, transient_periods=0, x0=orbit.x, v0=orbit.v)
    print(f"Lyapunov: {res.exponent:.10f}, log|mu|/T = {expected:.10f}, error {abs(res.exponent - expected):.2e}")
    assert res.status == 0, res.message
    assert abs(res.exponent - expected) < 1e-4
    assert res.history.size == 600 and res.history[-1] == res.exponent
    ds = res.to_xarray()
    assert ds.sizes["renormalisation"] == 600


def test_lyapunov_of_an_orbit_that_sticks():
    osc = Oscillator(0.5, 0.5, 0.05, 1e4, beta_static=0.08)
    orbit = periodic_orbit(osc, 1, transient_periods=60, backend="exact")
    assert orbit.collapsed and orbit.status == 0
    expected = math.log(abs(orbit.multipliers[0])) / orbit.period
    res = lyapunov_exponent(osc, 300, transient_periods=0, x0=orbit.x, v0=orbit.v, backend="exact")
    print(f"stick orbit: Lyapunov {res.exponent:.10f}, log|trace M|/T {expected:.10f}")
    assert abs(res.exponent - expected) < 1e-4


def test_chatter_annihilates_the_tangent_vector():
    # A plastic-ish rigid flange pushed into hard: impacts accumulate (a chatter) and the
    # mass rests on the wall; every perturbation dies: the exponent is -inf, said so.
    osc = Oscillator(2.0, 0.3, 0.05, 1.0, flange="rigid", restitution=0.5)
    res = lyapunov_exponent(osc, 5, transient_periods=0, x0=0.0, v0=0.0, backend="exact")
    assert res.status == 3 and res.exponent == -math.inf
    assert "annihilated" in res.message


def test_contact_case_period_three_and_unstable_orbits():
    osc = Oscillator(0.5, 1.1, 0.01, 1e4)  # the paper's eq. 3, the contact case
    orbit = periodic_orbit(osc, 3, transient_periods=200)
    assert orbit.status == 0 and orbit.stable
    assert np.sum(orbit.events.kind == "contact_start") == 4
    # A short period-1 search from the same transient lands on an orbit and classifies it.
    one = periodic_orbit(osc, 1, guess=(orbit.x, orbit.v), max_iter=50)
    assert one.status in (0, 1)
    if one.status == 0:
        assert one.stability in ("stable", "unstable", "marginal")


def test_marginal_without_dissipation():
    # No friction, no damping, no contact: a linear oscillator, |mu| = 1 exactly.
    osc = Oscillator(0.1, 1.3, 0.0, 1e4)
    orbit = periodic_orbit(osc, 1, guess=(0.0, 0.0))
    assert orbit.status == 0
    np.testing.assert_allclose(np.abs(orbit.multipliers), 1.0, atol=1e-12)
    assert orbit.stability == "marginal"


def test_period_must_be_a_multiple_of_the_forcing_period():
    T = forcing_period(DEN_HARTOG)
    with pytest.raises(ValueError, match="whole multiple of the forcing period"):
        periodic_orbit(DEN_HARTOG, period=1.5 * T)
    orbit = periodic_orbit(DEN_HARTOG, period=2 * T, transient_periods=100)
    assert orbit.n == 2 and orbit.period == pytest.approx(2 * T)


def test_non_converging_newton_keeps_the_last_iterate():
    osc = Oscillator(0.5, 1.1, 0.01, 1e4)
    orbit = periodic_orbit(osc, 1, guess=(0.0, 0.0), max_iter=1)
    assert orbit.status == 1 and not orbit.converged
    assert "did not converge in 1 iterations" in orbit.message and "last iterate" in orbit.message
    assert len(orbit.history) == 2 and orbit.residual == orbit.history[-1] > 1e-11
    assert (orbit.x, orbit.v) != (0.0, 0.0) and math.isfinite(orbit.x) and math.isfinite(orbit.v)
    assert np.all(np.isfinite(orbit.monodromy))


def test_bad_input():
    with pytest.raises(ValueError, match="constant"):
        periodic_orbit(Oscillator(0.5, 0.0, 0.01, 1e4))
    with pytest.raises(ValueError, match="backend must be one of"):
        periodic_orbit(DEN_HARTOG, backend="rk4")
    with pytest.raises(ValueError, match="does not support"):
        periodic_orbit(Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5), backend="exact")
    with pytest.raises(TypeError, match="guess must be a pair"):
        periodic_orbit(DEN_HARTOG, guess=0.5)
    with pytest.raises(ValueError, match="n must be >= 1"):
        periodic_orbit(DEN_HARTOG, 0)
    with pytest.raises(ValueError, match="incommensurate"):
        periodic_orbit(Oscillator(0.3, 1.0, 0.01, 1e4, harmonics=[(0.1, math.sqrt(2), 0.0)]))


def test_tape_drive_is_accepted():
    # 200 um clearance: no contact, quasi-static creep with stick/release every period
    drive = TapeDrive(clearance=200e-6)
    orbit = periodic_orbit(drive, 1, transient_periods=1)
    assert orbit.oscillator == drive.oscillator()
    assert orbit.status == 0, orbit.message
    assert orbit.collapsed and orbit.multipliers[1] == 0.0
