"""Contact observables (results/_observables.py) against closed forms.

* a quasi-static tape pushed into a spring flange once per reel turn: contact duration, peak
  force, impulse and the rms force over a turn in closed form;
* a rigid flange: the energy lost per impact is ``(1 - e^2) m v^2 / 2``, in SI through a drive;
* a spring flange with friction and damping and no forcing: the energy dissipated in a
  contact is the kinetic energy it took (the energy identity over the contact);
* the elastic impact force ``sqrt(K) V`` against the simulated peak of a free impact.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import impactosc
from impactosc.results import OBSERVABLES, contact_observables, contact_table, moving_rms_force

F, OMEGA, K, ZETA = 2.0, 1e-4, 100.0, 0.05
PHI_C = math.acos(1.0 / F)  # the forcing phase at which the quasi-static tape reaches the flange


@pytest.fixture(scope="module")
def quasi_static():
    """Two reel turns of a tape that follows the reel, damped so that contact ringing dies out."""
    osc = impactosc.Oscillator(F, OMEGA, 0.0, K, math.pi / 2, zeta=ZETA)
    period = 2.0 * math.pi / OMEGA
    # the harmonic steady state at phase pi/2: X = -F sin / (1 - Omega^2), no free oscillation
    return impactosc.simulate(osc, 2.0 * period, 0.0, -F * OMEGA / (1.0 - OMEGA**2), backend="exact"), period


def test_quasi_static_push_closed_forms(quasi_static):
    """Per turn and flange: force K (F cos phi - 1)/(1 + K) while cos phi > 1/F (zeta shifts it by O(zeta Omega))."""
    sol, period = quasi_static
    tab = contact_table(sol)
    for side in (1, -1):
        rows = tab[tab.side == side]
        main = rows[np.argmax(rows.duration)]
        # the push itself: duration 2 phi_c / Omega, peak K (F - 1)/(1 + K)
        assert main.duration == pytest.approx(2.0 * PHI_C / OMEGA, rel=2e-3)
        assert main.peak_force == pytest.approx(K * (F - 1.0) / (1.0 + K), rel=1e-6)
        # the impulse per turn, bounces on arrival included: 2K/((1+K) Omega) (sqrt(F^2-1) - phi_c)
        impulse = 2.0 * K / ((1.0 + K) * OMEGA) * (math.sqrt(F * F - 1.0) - PHI_C)
        assert np.sum(rows.impulse) / 2.0 == pytest.approx(impulse, rel=1e-4)
    obs = contact_observables(sol)
    # mean force over two whole turns: the impulse of both flanges over a period
    assert obs["both"]["mean_force"] == pytest.approx(2.0 * impulse / period, rel=1e-4)
    # one push per turn and flange, each arriving with a few elastic bounces (slow entry into a spring)
    assert obs["upper"]["impacts"] >= 2
    assert obs["upper"]["impact_rate"] == pytest.approx(obs["upper"]["impacts"] / (2 * period))


def test_moving_rms_over_a_turn_closed_form(quasi_static):
    """rms over one turn: sqrt(Omega/(2 pi) * 2 (K/(1+K))^2 int_{-phi_c}^{phi_c} (F cos - 1)^2 dphi / Omega)."""
    sol, period = quasi_static
    t, rms = moving_rms_force(sol, period, step=0.25)
    integral = F * F * (PHI_C + math.sin(PHI_C) * math.cos(PHI_C)) - 4.0 * F * math.sin(PHI_C) + 2.0 * PHI_C
    expected = K / (1.0 + K) * math.sqrt(2.0 * integral / (2.0 * math.pi))
    assert rms[-1] == pytest.approx(expected, rel=1e-3)
    assert t[0] == pytest.approx(period, abs=0.25) and t[-1] == pytest.approx(2 * period, abs=0.25)
    # the streamed exact rms over the whole run agrees with the sampled meter over whole turns
    assert contact_observables(sol)["both"]["rms_force"] == pytest.approx(expected, rel=1e-4)


def test_rigid_flange_energy_loss_si():
    """A rigid flange with restitution e: (1 - e^2) m v^2 / 2 per impact, v decaying as e^n (SI units)."""
    e = 0.5
    drive = impactosc.TapeDrive(flange="rigid", restitution=e, friction=0.0, runout_hub=1e-9, runout_full=1e-9,
                                clearance=100e-6)
    osc = impactosc.Oscillator(0.0, drive.Omega, 0.0, drive.K, flange="rigid", restitution=e)
    sol = impactosc.simulate(osc, 8.0, 0.0, 2.0, backend="exact")
    tab = contact_table(sol, drive)
    v_si = drive.clearance * drive.omega_n  # speed scale L omega_n
    speeds = math.sqrt(3.0) * e ** np.arange(len(tab))  # energy V^2/2 + X^2/2 between impacts
    assert len(tab) >= 3
    np.testing.assert_allclose(tab.entry_speed, speeds * v_si, rtol=1e-9)
    np.testing.assert_allclose(tab.dissipated, 0.5 * (1 - e * e) * drive.mass * (speeds * v_si) ** 2, rtol=1e-9)
    np.testing.assert_allclose(tab.impulse, (1 + e) * drive.mass * speeds * v_si, rtol=1e-9)
    assert np.all(np.isinf(tab.peak_force)) and np.all(tab.duration == 0.0)
    obs = contact_observables(sol, drive)
    duration = 8.0 / drive.omega_n
    assert obs["both"]["dissipation_rate"] == pytest.approx(np.sum(tab.dissipated) / duration, rel=1e-12)
    assert obs["both"]["impact_rate"] == pytest.approx(len(tab) / duration)


@pytest.mark.parametrize(("beta", "zeta"), [(0.05, 0.0), (0.0, 0.1), (0.05, 0.1)])
def test_spring_contact_dissipation_is_kinetic_energy_taken(beta, zeta):
    """No forcing, entry and exit at the same X: friction + damping work in the contact = KE_in - KE_out."""
    osc = impactosc.Oscillator(0.0, 1.0, beta, 1e3, zeta=zeta)
    sol = impactosc.simulate(osc, 2.0, 0.0, 3.0, backend="exact")
    tab = contact_table(sol)
    first = tab[0]
    assert first.complete
    taken = 0.5 * (first.entry_speed**2 - first.exit_speed**2)
    assert first.dissipated == pytest.approx(taken, rel=1e-7)
    assert first.dissipated > 0


def test_impact_force_is_the_elastic_peak():
    """A free mass on a stiff linear spring: peak force -> sqrt(K) V_in as K grows (tape spring O(1/sqrt K))."""
    osc = impactosc.Oscillator(0.0, 1.0, 0.0, 1e6)
    sol = impactosc.simulate(osc, 2.0, 0.0, 2.0, backend="exact")
    row = contact_table(sol)[0]
    assert row.entry_speed == pytest.approx(math.sqrt(3.0), rel=1e-12)
    assert row.impact_force == pytest.approx(1e3 * math.sqrt(3.0), rel=1e-12)
    assert row.peak_force == pytest.approx(row.impact_force, rel=2e-3)


def test_observables_table_and_units():
    osc = impactosc.Oscillator(0.0, 1.0, 0.0, 1e4)
    sol = impactosc.simulate(osc, 3.0, 0.0, 2.0, backend="exact")
    obs = sol.contact_observables()
    assert set(obs) == {"upper", "lower", "both"}
    assert set(obs["both"]) == set(OBSERVABLES)
    assert obs["both"]["impacts"] == obs["upper"]["impacts"] + obs["lower"]["impacts"]
    assert obs["both"]["ae_peak_sum"] == pytest.approx(obs["upper"]["ae_peak_sum"] + obs["lower"]["ae_peak_sum"])


def test_bad_input_is_named():
    osc = impactosc.Oscillator(0.0, 1.0, 0.0, 1e4)
    sol = impactosc.simulate(osc, 3.0, 0.0, 2.0, backend="exact")
    with pytest.raises(ValueError, match="window"):
        moving_rms_force(sol, 10.0)
    with pytest.raises(ValueError, match="window"):
        moving_rms_force(sol, -1.0)
    with pytest.raises(ValueError, match="max_samples"):
        moving_rms_force(sol, 1.0, step=1e-6, max_samples=1000)
    with pytest.raises(TypeError, match="force_scale"):
        contact_table(sol, drive=object())
    stats = impactosc.simulate(osc, 3.0, 0.0, 2.0, backend="exact", record="stats")
    with pytest.raises(ValueError, match="record"):
        contact_table(stats)
    # the slip path is streamed: "events" (no pieces kept) gives the dissipation of "full"
    member = impactosc.Oscillator(0.0, 1.0, 0.05, 1e4)
    damped = impactosc.simulate(member, 3.0, 0.0, 2.0, backend="exact", record="events")
    full = impactosc.simulate(member, 3.0, 0.0, 2.0, backend="exact", record="full")
    np.testing.assert_allclose(contact_table(damped).dissipated, contact_table(full).dissipated, rtol=1e-12)
    assert np.all(contact_table(damped).dissipated > 0)
