"""The Fig. 4 study (paper/_study.py): its criteria as code, the lead derived, the study's points.

Closed forms first: the quasi-static impact speed ``omega_r sqrt(A^2 - c^2)`` against a
simulated entry speed, the peak of the lead's proxy over the pack against its formula.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import impactosc
from impactosc.paper import lead_ae_proxy, lead_peak_runout, quasi_static_impact_speed, trend_checks
from impactosc.paper._study import STUDY_OBSERVABLES, evaluate_models, lead_ratio_bound
from impactosc.results import contact_table

D = np.linspace(44e-3, 97e-3, 7)
SPEEDS = (4.0, 8.0, 12.0)
T_SIN = (0.1, 0.4, 0.7)


def _grid(shape_d, speed_gain=(1.0, 1.5, 2.0), tension_gain=(2.0, 1.5, 1.0)):
    return np.einsum("i,j,k->ijk", shape_d, np.asarray(speed_gain), np.asarray(tension_gain))


def test_criteria_hold_on_an_ideal_figure():
    peaked = np.array([0.2, 0.6, 0.9, 1.0, 0.9, 0.7, 0.5])
    assert trend_checks(_grid(peaked), D, SPEEDS, T_SIN) == {"mid_pack": True, "speed": True, "tension": True,
                                                           "double": True}


@pytest.mark.parametrize(("shape", "speed", "tension", "failing"), [
    (np.linspace(0.2, 1.0, 7), (1.0, 1.5, 2.0), (2.0, 1.5, 1.0), "mid_pack"),          # monotonic in D
    (np.array([0.5, 1.0, 0.9, 0.8, 0.6, 0.5, 0.4]), (1, 1.5, 2), (2, 1.5, 1), "mid_pack"),  # peak in first third
    (np.array([0.2, 0.6, 0.9, 1.0, 0.9, 0.7, 0.95]), (1, 1.5, 2), (2, 1.5, 1), "mid_pack"),  # end within 10 %
    (np.array([0.2, 0.6, 0.9, 1.0, 0.9, 0.7, 0.5]), (1.0, 1.05, 1.5), (2, 1.5, 1), "speed"),  # step < 10 %
    (np.array([0.2, 0.6, 0.9, 1.0, 0.9, 0.7, 0.5]), (1, 1.5, 2), (1.05, 1.02, 1.0), "tension"),
    (np.array([0.2, 0.6, 0.9, 1.0, 0.9, 0.7, 0.5]), (1, 1.5, 2), (1.3, 1.2, 1.0), "double"),  # ratio 1.3
    (np.array([0.2, 0.6, 0.9, 1.0, 0.9, 0.7, 0.5]), (1, 1.5, 2), (3.0, 2.0, 1.0), "double"),  # ratio 3
])
def test_each_criterion_can_fail(shape, speed, tension, failing):
    checks = trend_checks(_grid(shape, speed, tension), D, SPEEDS, T_SIN)
    assert checks[failing] is False
    assert sum(checks.values()) == (2 if failing == "tension" else 3)  # double implies tension


def test_zero_or_failed_holds_nothing():
    assert not any(trend_checks(np.zeros((7, 3, 3)), D, SPEEDS, T_SIN).values())
    y = _grid(np.array([0.2, 0.6, 0.9, 1.0, 0.9, 0.7, 0.5]))
    y[3, 1, 1] = np.nan
    assert not any(trend_checks(y, D, SPEEDS, T_SIN).values())


def test_quasi_static_impact_speed_against_simulation():
    """First entry of a damped, frictionless, quasi-static tape: omega_r sqrt(A^2 - L^2) to O(Omega, zeta Omega)."""
    drive = impactosc.TapeDrive(clearance=60e-6, friction=0.0, damping_ratio=0.05)
    osc = drive.oscillator(phase=math.pi / 2)  # X = -F sin / (1 - Omega^2): no free oscillation
    om = osc.Omega
    sol = impactosc.simulate(osc, 0.5 * 2 * math.pi / om, 0.0, -osc.F * om / (1 - om**2), backend="exact")
    first = contact_table(sol, drive)[0]
    assert first.entry_speed == pytest.approx(quasi_static_impact_speed(drive), rel=1e-3)


def test_quasi_static_impact_speed_friction_delays_contact():
    drive = impactosc.TapeDrive(clearance=60e-6, free_length=40e-3)
    c = drive.clearance + drive.friction_force / drive.stiffness
    assert quasi_static_impact_speed(drive) == pytest.approx(drive.omega_r * math.sqrt(drive.runout**2 - c * c))
    assert quasi_static_impact_speed(drive.replace(clearance=200e-6)) == 0.0


def test_lead_proxy_grows_as_speed_squared():
    drive = impactosc.TapeDrive(clearance=60e-6, free_length=40e-3)
    assert lead_ae_proxy(drive.replace(speed=8.0)) == pytest.approx(4.0 * lead_ae_proxy(drive.replace(speed=4.0)))


@pytest.mark.parametrize("proportional", [True, False])
def test_lead_peak_runout_is_the_maximum_over_the_pack(proportional):
    """The lead peaks at A = sqrt(2) c for A = a D; on Fig. 6's affine law at the root of A^2 + A0 A - 2 c^2."""
    fields = {"runout_hub": 60e-6 * 44 / 97, "runout_full": 60e-6} if proportional else {}
    drive = impactosc.TapeDrive(clearance=40e-6, friction=0.0, **fields)
    slope = (drive.runout_full - drive.runout_hub) / (drive.full_pack_diameter - drive.hub_diameter)
    a0 = drive.runout_hub - slope * drive.hub_diameter
    d = np.linspace(drive.hub_diameter, drive.full_pack_diameter, 20001)
    y = [lead_ae_proxy(drive.replace(pack_diameter=float(x))) for x in d]
    numeric = drive.runout_at(float(d[int(np.argmax(y))]))
    expected = lead_peak_runout(40e-6, 0.0 if proportional else a0)
    if proportional:
        assert abs(a0) < 1e-18 and expected == pytest.approx(math.sqrt(2) * 40e-6)
    assert numeric == pytest.approx(expected, abs=slope * (d[1] - d[0]))


def test_lead_band_ends_put_the_peak_at_the_thirds():
    """The c band of lead_ratio_bound: the peak runout at its ends is the run-out at D = hub + 1/3, 2/3 of the pack."""
    drive = impactosc.TapeDrive()
    band = lead_ratio_bound()
    slope = (drive.runout_full - drive.runout_hub) / (drive.full_pack_diameter - drive.hub_diameter)
    a0 = drive.runout_hub - slope * drive.hub_diameter
    span = drive.full_pack_diameter - drive.hub_diameter
    third = drive.runout_at(drive.hub_diameter + span / 3)
    two_thirds = drive.runout_at(drive.hub_diameter + 2 * span / 3)
    assert lead_peak_runout(band["c_lo"], a0) == pytest.approx(third, rel=2e-3)
    assert lead_peak_runout(band["c_hi"], a0) == pytest.approx(two_thirds, rel=2e-3)
    assert 1.0 < band["ratio"] < 2.5


def test_paper_parameters_touch_nothing():
    """The paper's own parameters: no contact, every observable zero, no trend (the reproduction's finding)."""
    res = evaluate_models({"paper": {}}, quick=True, executor="serial")["paper"]
    assert res["errors"] == []
    for obs in STUDY_OBSERVABLES:
        assert np.all(res["values"][obs] == 0.0)
        assert not any(res["trends"][obs].values())
