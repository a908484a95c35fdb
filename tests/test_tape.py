"""TapeDrive: the paper's drive in SI units (eq. 1, 4, 5, Fig. 6) and its reduction to eq. 3.

Expected values are worked out by hand in the comments from the paper's parameters
(section 5): w = 12.7 mm, h = 9 um, l = 10 mm, E = 7 GPa, rho = 1370 kg/m^3, L = 1 mm,
theta = 60 deg, mu = 0.2, K = 1e4; plus the library's assumed reel (hub 44 mm, full pack
97 mm, run-out 60 -> 180 um).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import impactosc
from impactosc.model import Oscillator, TapeDrive

REL = 1e-9

# Hand arithmetic shared by several tests ------------------------------------------------
# in-plane I = h w^3 / 12 = 9e-6 * 0.0127^3 / 12
#   0.0127^3 = 2.048383e-6 ; * 9e-6 = 1.8435447e-11 ; / 12 = 1.536287250e-12 m^4
I_IN = 1.536287250e-12
# k = 48 E I / l^3 = 48 * 7e9 * 1.53628725e-12 / (0.01)^3
#   48 * 7e9 = 3.36e11 ; * 1.53628725e-12 = 0.516192516 ; / 1e-6 = 516192.516 N/m
K_IN = 516192.516
# out-of-plane I = w h^3 / 12 = 0.0127 * (9e-6)^3 / 12 = 0.0127 * 7.29e-16 / 12 = 7.715250e-19 m^4
I_OUT = 7.715250e-19
# k = 3.36e11 * 7.71525e-19 / 1e-6 = 2.592324e-7 / 1e-6 = 0.2592324 N/m
K_OUT = 0.2592324
# m = rho w h l = 1370 * 0.0127 * 9e-6 * 0.01 = 17.399 * 9e-8 = 1.56591e-6 kg
MASS = 1.56591e-6
# omega_n = sqrt(k/m) = sqrt(516192.516 / 1.56591e-6) = sqrt(3.2964378e11) = 574146.14 rad/s
OMEGA_N = 574146.14


# -- derived quantities --------------------------------------------------------------------
def test_stiffness_eq4_both_bendings():
    d = TapeDrive()
    assert d.second_moment == pytest.approx(I_IN, rel=REL, abs=0)
    assert d.stiffness == pytest.approx(K_IN, rel=REL, abs=0)
    o = d.replace(bending="out-of-plane")
    assert o.second_moment == pytest.approx(I_OUT, rel=REL, abs=0)
    assert o.stiffness == pytest.approx(K_OUT, rel=REL, abs=0)
    # The two readings differ by (w/h)^2 = (0.0127 / 9e-6)^2 = 1411.11^2 = 1.99124e6
    assert d.stiffness / o.stiffness == pytest.approx((12.7e-3 / 9e-6) ** 2, rel=REL)


def test_mass_and_natural_frequency():
    d = TapeDrive()
    assert d.mass == pytest.approx(MASS, rel=REL, abs=0)
    assert d.omega_n == pytest.approx(OMEGA_N, rel=1e-7, abs=0)
    # f_n = 574146.14 / (2 pi) = 574146.14 / 6.2831853 = 91378.5 Hz (the design's "91 kHz")
    assert d.natural_frequency_hz == pytest.approx(91378.5, rel=1e-5, abs=0)
    # out-of-plane: sqrt(0.2592324 / 1.56591e-6) = sqrt(165547.6) = 406.87 rad/s
    assert d.replace(bending="out-of-plane").omega_n == pytest.approx(406.87, rel=1e-4, abs=0)


def test_normal_force_eq5():
    # N = 2 T sin(theta/2) = 2 * 1 * sin(30 deg) = 2 * 0.5 = 1.0 N
    d = TapeDrive()
    assert d.normal_force == pytest.approx(1.0, rel=REL, abs=0)
    assert d.t_sin_half_theta == pytest.approx(0.5, rel=REL, abs=0)
    assert d.friction_force == pytest.approx(0.2, rel=REL, abs=0)  # mu N = 0.2 * 1.0
    # T = 2 N, theta = 90 deg: N = 2 * 2 * sin(45 deg) = 4 * 0.70710678 = 2.82842712 N
    assert d.replace(tension=2.0, wrap_angle=90.0).normal_force == pytest.approx(2.82842712, rel=1e-8, abs=0)
    # theta = 180 deg (half wrap): N = 2 T
    assert d.replace(tension=1.5, wrap_angle=180.0).normal_force == pytest.approx(3.0, rel=REL, abs=0)


def test_reel_frequency_eq1():
    # omega_r = 2 V / D ; mid pack D = (44 + 97)/2 = 70.5 mm
    d = TapeDrive()
    assert d.pack_diameter == pytest.approx(70.5e-3, rel=REL, abs=0)
    # 2 * 4 / 0.0705 = 113.47518 rad/s
    assert d.omega_r == pytest.approx(113.47518, rel=1e-7, abs=0)
    # 2 * 12 / 0.044 = 545.4545 rad/s (fastest reel: empty pack, 12 m/s)
    assert d.replace(speed=12.0, pack_diameter=0.044).omega_r == pytest.approx(545.454545, rel=1e-8, abs=0)


def test_runout_law_fig6():
    d = TapeDrive()
    # Hub: 60 um ; full pack: 180 um ; midpoint: (60 + 180)/2 = 120 um
    assert d.replace(pack_diameter=44e-3).runout == pytest.approx(60e-6, rel=REL, abs=0)
    assert d.replace(pack_diameter=97e-3).runout == pytest.approx(180e-6, rel=REL, abs=0)
    assert d.runout == pytest.approx(120e-6, rel=REL, abs=0)
    # Quarter way, D = 44 + 53/4 = 57.25 mm: 60 + 120/4 = 90 um
    assert d.runout_at(57.25e-3) == pytest.approx(90e-6, rel=REL, abs=0)
    # F_a = runout * k = 120e-6 * 516192.516 = 61.9431 N ; F = F_a / (k L) = runout / L
    assert d.forcing_amplitude == pytest.approx(61.9431019, rel=1e-8, abs=0)
    assert d.replace(pack_diameter=44e-3).F == pytest.approx(0.06, rel=REL, abs=0)
    assert d.F == pytest.approx(0.12, rel=REL, abs=0)
    assert d.replace(pack_diameter=97e-3).F == pytest.approx(0.18, rel=REL, abs=0)


def test_nondimensional_numbers_of_default_drive():
    d = TapeDrive()
    # F = 120e-6 / 1e-3 = 0.12
    assert d.F == pytest.approx(0.12, rel=REL, abs=0)
    # Omega = omega_r / omega_n = 113.47518 / 574146.14 = 1.976416e-4
    assert d.Omega == pytest.approx(1.976416e-4, rel=1e-6, abs=0)
    # beta = mu N / (k L) = 0.2 * 1.0 / (516192.516 * 1e-3) = 0.2 / 516.192516 = 3.874523e-4
    assert d.beta == pytest.approx(3.874523e-4, rel=1e-6, abs=0)
    # beta is linear in T: 3.87e-4 per newton (in-plane) ...
    assert d.replace(tension=2.0).beta == pytest.approx(2 * 3.874523e-4, rel=1e-6, abs=0)
    # ... and 0.2 / (0.2592324 * 1e-3) = 771.51 per newton out-of-plane (the design's "770 T")
    assert d.replace(bending="out-of-plane").beta == pytest.approx(771.508, rel=1e-5, abs=0)
    assert d.K == 1e4
    # Scales: k L = 516.192516 N ; L = 1 mm
    assert d.force_scale == pytest.approx(516.192516, rel=REL, abs=0)
    assert d.length_scale == 1e-3
    # Omega range of the paper's sweep: 4 m/s full pack 2*4/(0.097*574146.14) = 1.4365e-4,
    # 12 m/s at the hub 2*12/(0.044*574146.14) = 9.5003e-4
    assert d.replace(pack_diameter=97e-3).Omega == pytest.approx(1.43647e-4, rel=1e-5, abs=0)
    assert d.replace(speed=12.0, pack_diameter=44e-3).Omega == pytest.approx(9.50027e-4, rel=1e-5, abs=0)


def test_oscillator_fields():
    d = TapeDrive(speed=8.0, tension=2.0)
    osc = d.oscillator()
    assert isinstance(osc, Oscillator)
    assert osc.F == pytest.approx(0.12, rel=REL, abs=0)
    # 2 * 8 / 0.0705 / 574146.14 = 3.952833e-4
    assert osc.Omega == pytest.approx(3.952833e-4, rel=1e-6, abs=0)
    # 0.2 * 2 * 2 * 0.5 / 516.192516 = 0.4 / 516.192516 = 7.749045e-4
    assert osc.beta == pytest.approx(7.749045e-4, rel=1e-6, abs=0)
    assert osc.K == 1e4
    assert osc.phase == 0.0
    assert d.oscillator(phase=1.25).phase == 1.25


def test_time_conversion():
    d = TapeDrive()
    # 1 s = omega_n * 1 s = 574146.14 Lambda ; 20 ms = 11482.92
    assert d.seconds_to_lambda(1.0) == pytest.approx(OMEGA_N, rel=1e-7, abs=0)
    assert d.seconds_to_lambda(0.02) == pytest.approx(11482.92, rel=1e-6, abs=0)
    assert d.lambda_to_seconds(d.seconds_to_lambda(0.0123)) == pytest.approx(0.0123, rel=1e-14, abs=0)
    # One natural period 2 pi in Lambda is 1 / f_n = 10.9435 us
    assert d.lambda_to_seconds(2 * math.pi) == pytest.approx(1.0943e-5, rel=1e-4, abs=0)
    arr = d.seconds_to_lambda(np.array([0.0, 1e-3]))
    np.testing.assert_allclose(arr, [0.0, 574.14614], rtol=1e-7)
    with pytest.raises(ValueError, match="t_s"):
        d.seconds_to_lambda(math.nan)


def test_describe_lists_derived_numbers_with_units():
    text = TapeDrive().describe()
    assert len(text.splitlines()) >= 5
    for piece in ("k = 5.162e+05 N/m", "m = 1.566e-06 kg", "rad/s", "Hz", "beta = 0.0003875", "F = 0.12"):
        assert piece in text


# -- construction, replace, frozen -----------------------------------------------------------
def test_replace_revalidates():
    d = TapeDrive()
    d2 = d.replace(tension=2.0)
    assert d2.tension == 2.0 and d.tension == 1.0
    with pytest.raises(ValueError, match="tension"):
        d.replace(tension=-1.0)
    with pytest.raises(ValueError, match="pack_diameter"):
        d.replace(pack_diameter=0.2)
    # None means mid pack of the (possibly new) reel: (40 + 100) / 2 = 70 mm
    d3 = d.replace(hub_diameter=0.04, full_pack_diameter=0.1, pack_diameter=None)
    assert d3.pack_diameter == pytest.approx(0.07, rel=REL, abs=0)
    assert d3.runout == pytest.approx(120e-6, rel=REL, abs=0)


def test_from_t_sin_half_theta():
    # T sin(theta/2) = 0.1 N at the default 60 deg: T = 0.1 / sin(30 deg) = 0.2 N
    d = TapeDrive.from_t_sin_half_theta(0.1)
    assert d.wrap_angle == 60.0
    assert d.tension == pytest.approx(0.2, rel=REL, abs=0)
    assert d.t_sin_half_theta == pytest.approx(0.1, rel=REL, abs=0)
    # 0.7 N at 90 deg: T = 0.7 / sin(45 deg) = 0.7 / 0.70710678 = 0.98994949 N ; N = 2 * 0.7 = 1.4 N
    d = TapeDrive.from_t_sin_half_theta(0.7, wrap_angle=90.0, speed=12.0)
    assert d.tension == pytest.approx(0.98994949, rel=1e-8, abs=0)
    assert d.normal_force == pytest.approx(1.4, rel=REL, abs=0)
    assert d.speed == 12.0
    with pytest.raises(TypeError, match="tension"):
        TapeDrive.from_t_sin_half_theta(0.5, tension=1.0)
    with pytest.raises(ValueError, match="t_sin_half_theta"):
        TapeDrive.from_t_sin_half_theta(-0.5)


def test_frozen():
    d = TapeDrive()
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.tension = 2.0
    assert hash(d) == hash(TapeDrive())


@pytest.mark.parametrize(
    ("changes", "error", "words"),
    [
        ({"tension": -1.0}, ValueError, ("tension", "> 0", "-1.0")),
        ({"speed": math.nan}, ValueError, ("speed", "finite", "nan")),
        ({"speed": "4"}, TypeError, ("speed", "real number", "'4'")),
        ({"pack_diameter": 0.03}, ValueError, ("pack_diameter", "hub_diameter", "0.03")),
        ({"pack_diameter": 0.1}, ValueError, ("pack_diameter", "full_pack_diameter", "0.1")),
        ({"bending": "sideways"}, ValueError, ("bending", "in-plane", "sideways")),
        ({"bending": 1}, TypeError, ("bending",)),
        ({"wrap_angle": 360.0}, ValueError, ("wrap_angle", "(0, 360)", "360.0")),
        ({"wrap_angle": 0.0}, ValueError, ("wrap_angle", "(0, 360)")),
        ({"friction": -0.1}, ValueError, ("friction", ">= 0")),
        ({"width": 0.0}, ValueError, ("width", "> 0")),
        ({"clearance": math.inf}, ValueError, ("clearance", "finite")),
        ({"stiffness_ratio": True}, TypeError, ("stiffness_ratio",)),
        ({"hub_diameter": 0.1}, ValueError, ("full_pack_diameter", "hub_diameter")),
    ],
)
def test_bad_inputs(changes, error, words):
    with pytest.raises(error) as info:
        TapeDrive(**changes)
    for word in words:
        assert word in str(info.value)


def test_friction_zero_is_allowed():
    assert TapeDrive(friction=0.0).beta == 0.0


# -- physics finding -------------------------------------------------------------------------
# A physics finding, not a regression check of the numerics: named ``test_physics_finding_*`` so that
# ``pytest -k physics_finding`` selects it (a ``physics_finding`` marker would need registering in
# pyproject.toml, which this file does not own).
def test_physics_finding_default_drive_never_touches_a_flange_and_creeps():
    """Physics finding: with the paper's own parameters the tape never reaches a flange.

    Default drive (4 m/s, 1 N, 60 deg, mid pack): F = 0.12, Omega = 1.98e-4, beta = 3.87e-4.
    The forcing alone deflects the tape by F = run-out / L = 0.12 of the clearance, and
    Omega << 1 gives no dynamic amplification (1 / (1 - Omega^2) = 1 + 4e-8), so the only
    way to a flange is the initial condition X0 = 0.95 < 1 -- and Coulomb friction only
    removes energy. Hence no contact at all, for the whole run.

    The free oscillation about the slowly moving centre F cos(Omega Lambda) decays linearly
    (Coulomb): the amplitude A_n at the n-th turning point is (0.95 - 0.12) - 2 n beta
    = 0.83 - 7.749e-4 n, and the mass sticks at the first turning point with A_n <= beta:
    n = ceil((0.83 - beta) / (2 beta)) = ceil(1070.6) = 1071. So 1070 reversals, then the
    first stick at Lambda ~ 1071 pi = 3364.7, i.e. 3364.7 / 574146 = 5.86 ms (the design's
    "dies out in ~6 ms").

    After the release the mass creeps with the forcing. While the forcing's speed
    |F Omega sin(Omega Lambda)| keeps growing, the slip velocity never returns to zero, so
    there is no second stick until the forcing phase passes pi - (phase at release)
    = pi - 0.671 = 2.47, i.e. 2.47 / Omega = 12500 Lambda = 21.8 ms. The 20 ms run ends
    before that: exactly one stick and one release. The design's "thousands of stick/release
    pairs" are real but begin only then (checked with the 35 ms run below).
    """
    drive = TapeDrive()
    sol = impactosc.simulate(drive.oscillator(), t_end=drive.seconds_to_lambda(0.02), x0=0.95, v0=0.0,
                             record="stats")
    assert sol.status == 0
    assert sol.counts["contact_start"] == 0
    assert sol.counts["contact_end"] == 0
    assert sol.contact_entries() == 0
    assert sol.flange_impulse() == 0.0
    # 1070 predicted at constant forcing; the slow drift of the centre may shift it slightly.
    assert abs(sol.counts["reversal"] - 1070) <= 10
    assert sol.counts["stick"] == 1
    assert sol.counts["release"] == 1

    # Past 21.8 ms the stick-slip burst of the quasi-static creep starts, up to the forcing's
    # minimum at Omega Lambda = pi (27.7 ms): hundreds of stick/release pairs, still no contact.
    longer = impactosc.simulate(drive.oscillator(), t_end=drive.seconds_to_lambda(0.035), x0=0.95, v0=0.0,
                                record="events")
    ev = longer.events
    assert longer.counts["contact_start"] == 0
    assert longer.counts["stick"] > 100
    sticks = ev.t[ev.kind == "stick"]
    releases = ev.t[ev.kind == "release"]
    omega = drive.Omega
    # First stick after the Coulomb decay: Lambda ~ 1071 pi (within 0.5 %).
    assert sticks[0] == pytest.approx(1071 * math.pi, rel=5e-3, abs=0)
    # Second stick where the forcing speed falls back to its value at the first release.
    assert omega * sticks[1] == pytest.approx(math.pi - omega * releases[0], abs=1e-2)
    assert np.all(np.abs(ev.x) < 1.0)
