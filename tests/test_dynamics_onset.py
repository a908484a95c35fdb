"""Contact onset: the Den Hartog grazing boundary, the quasi-static tape drive, the design chart."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import Oscillator, TapeDrive
from impactosc.dynamics import (
    contact_margin,
    contact_onset,
    den_hartog_onset,
    onset_chart,
    plot_onset_chart,
    quasi_static_critical_clearance,
)


def test_den_hartog_grazing_boundary():
    Fc = den_hartog_onset(0.8, 0.05)
    res = contact_onset(Oscillator(0.3, 0.8, 0.05, 1e4), "F", (0.8 * Fc, 1.1 * Fc), tol=1e-10, scan=4,
                        orbit=1, x0=0.0, transient_periods=300)
    print(f"Den Hartog onset: closed form {Fc:.12f}, found {res.value:.12f}, error {abs(res.value - Fc):.1e}, "
          f"{res.evaluations} orbits")
    assert res.status == 0 and res.direction == 1
    assert abs(res.value - Fc) < 1e-9


def test_margin_signs():
    below = contact_margin(Oscillator(0.3, 0.8, 0.05, 1e4), transient_periods=100, record_periods=2)
    assert below == pytest.approx(0.819559119886055 - 1.0, abs=1e-9)  # 1 - Den Hartog amplitude
    assert contact_margin(Oscillator(0.5, 1.1, 0.01, 1e4), transient_periods=50, record_periods=2) > 0.0
    rigid = Oscillator(0.8, 0.7, 0.02, 1e4, flange="rigid", restitution=0.7)
    assert contact_margin(rigid, transient_periods=30, record_periods=2, backend="exact") > 0.1  # impact speed
    assert contact_margin(Oscillator(0.5, 1.1, 0.01, 1e4), transient_periods=50, record_periods=2,
                          stop_at_contact=True) == 0.0


def test_tape_drive_critical_clearance_is_quasi_static():
    drive = TapeDrive()  # the paper's drive: 1 mm clearance, no contact
    res = contact_onset(drive, "clearance", (100e-6, 140e-6), tol=1e-9, transient_periods=0.25,
                        record_periods=1, stop_at_contact=True)
    Lc = quasi_static_critical_clearance(drive)
    print(f"critical clearance {res.value * 1e6:.6f} um, quasi-static run-out - mu N/k = {Lc * 1e6:.6f} um")
    assert res.status == 0 and res.direction == -1  # contact for clearances below it
    assert abs(res.value - Lc) < 2e-9
    assert drive.clearance > res.value  # the paper's 1 mm clearance is far from contact


def test_no_onset_in_the_bracket_is_a_status():
    res = contact_onset(Oscillator(0.1, 0.8, 0.05, 1e4), "F", (0.05, 0.2), transient_periods=50)
    assert res.status == 1 and math.isnan(res.value) and "stays off the flanges" in res.message


def test_chart_over_two_parameters():
    drive = TapeDrive()
    ds = onset_chart(drive, "clearance", (115e-6, 125e-6), {"speed": [2.0, 8.0], "tension": [0.5, 2.0]},
                     executor="serial", progress=False, tol=5e-8, transient_periods=0.25, record_periods=1,
                     stop_at_contact=True)
    assert ds["critical"].dims == ("speed", "tension") and ds["critical"].attrs["units"] == "m"
    assert np.all(ds["status"].values == 0)
    for s in (2.0, 8.0):
        for t in (0.5, 2.0):
            Lc = quasi_static_critical_clearance(drive.replace(speed=s, tension=t))
            assert abs(float(ds["critical"].sel(speed=s, tension=t)) - Lc) < 1e-7
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    ax = plot_onset_chart(ds, scale=1e6, units="um")
    assert "speed" in ax.get_ylabel() and "tension" in ax.get_xlabel()


def test_bad_input():
    osc = Oscillator(0.3, 0.8, 0.05, 1e4)
    with pytest.raises(ValueError, match="parameter must be one of"):
        contact_onset(osc, "clearance", (0.1, 0.2))
    with pytest.raises(ValueError, match="lo < hi"):
        contact_onset(osc, "F", (0.4, 0.2))
    with pytest.raises(ValueError, match="NaN"):
        onset_chart(TapeDrive(), "clearance", (1e-4, 2e-4), {"speed": [2.0, math.nan], "tension": [1.0]})
    with pytest.raises(ValueError, match="exactly two"):
        onset_chart(TapeDrive(), "clearance", (1e-4, 2e-4), {"speed": [2.0]})
    with pytest.raises(ValueError, match="charted parameter"):
        onset_chart(TapeDrive(), "clearance", (1e-4, 2e-4), {"clearance": [1e-4], "speed": [2.0]})
