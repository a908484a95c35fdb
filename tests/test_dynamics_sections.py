"""Poincare sections: exact stroboscopic samples, event sections, xarray output, period detection."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import Oscillator, simulate
from impactosc.dynamics import detect_period, event_section, forcing_period, stroboscopic_section

CONTACT = Oscillator(0.5, 1.1, 0.01, 1e4)


def test_stroboscopic_samples_are_states_of_the_run():
    T = forcing_period(CONTACT)
    sec = stroboscopic_section(CONTACT, 5, transient_periods=3, phase=1.0)
    assert len(sec) == 5 and sec.status == 0
    t_s = (1.0 - CONTACT.phase) / CONTACT.Omega
    np.testing.assert_allclose(sec.t, t_s + T * np.arange(3, 8), rtol=0, atol=1e-12)
    np.testing.assert_allclose(sec.phase, 1.0, atol=1e-12)
    # A sample is a time event of the run: a run that ends there has the same state.
    for k in (0, 4):
        sol = simulate(CONTACT, float(sec.t[k]))
        assert abs(sol.x_final - sec.x[k]) < 1e-12 and abs(sol.v_final - sec.v[k]) < 1e-12


def test_section_dataset_and_period_detection():
    sec = stroboscopic_section(CONTACT, 12, transient_periods=200)
    ds = sec.to_xarray()
    assert ds.sizes["period"] == 12 and list(ds["period"].values) == list(range(200, 212))
    assert set(ds.data_vars) == {"t", "x", "v", "phase"}
    # the contact case settles (slowly: |mu| = 0.94 per orbit) on a period-3 orbit
    assert detect_period(sec.x, sec.v, tol=1e-2) == 3
    assert detect_period([0.1, 0.2, 0.3], [0.0, 0.0, 0.0]) is None


def test_event_sections():
    osc = Oscillator(0.5, 0.5, 0.05, 1e4, beta_static=0.08)  # sticks once per period
    sticks = event_section(osc, 10, "stick", transient_periods=20, backend="exact")
    assert len(sticks) == 10 and np.all(sticks.v == 0.0)
    contacts = event_section(CONTACT, 10, "contact_start", side=1, transient_periods=50)
    assert len(contacts) > 0 and np.all(contacts.x == 1.0) and np.all(contacts.side == 1)
    assert np.all(contacts.t >= 50 * forcing_period(CONTACT))
    ds = contacts.to_xarray()
    assert "side" in ds and ds.sizes["event"] == len(contacts)


def test_section_bad_input():
    with pytest.raises(ValueError, match="kind must be one of"):
        event_section(CONTACT, 3, "bounce")
    with pytest.raises(ValueError, match="side must be"):
        event_section(CONTACT, 3, side=2)
    with pytest.raises(ValueError, match="periods must be >= 1"):
        stroboscopic_section(CONTACT, 0)
    with pytest.raises(ValueError, match="constant"):
        stroboscopic_section(Oscillator(0.0, 1.0, 0.01, 1e4), 3)
    with pytest.raises(ValueError, match="phase must be finite"):
        stroboscopic_section(CONTACT, 3, phase=math.nan)


def test_section_plot():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    ax = stroboscopic_section(CONTACT, 5).plot()
    assert ax.get_xlabel().startswith("X")
