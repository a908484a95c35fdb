"""Contact onset: the Den Hartog grazing boundary, the quasi-static tape drive, the design chart.

Both methods: continuation (the default: the followed branch grazes at the answer) and the
transient search of earlier versions.
"""

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
    periodic_orbit,
    plot_onset_chart,
    quasi_static_critical_clearance,
)
from impactosc.dynamics.continuation import Branch


# -- method="continuation" (issue 19) --------------------------------------------------------
def test_continuation_follows_the_given_den_hartog_orbit_to_its_grazing():
    # issue 19: the transient search from this orbit answered 0.98 Fc (Newton jumped to an unstable
    # contacting orbit); the followed orbit is contact-free and stable up to Fc itself
    Fc = den_hartog_onset(1.5, 0.1)
    res = contact_onset(Oscillator(Fc, 1.5, 0.1, 24.0), "F", (0.8 * Fc, 1.1 * Fc),
                        guess=(-0.7891869048001374, 0.16283153617831878))
    print(f"Den Hartog (Omega 1.5, beta 0.1): value/Fc - 1 = {res.value / Fc - 1:.2e}; {res.message}")
    assert res.status == 0 and res.method == "continuation" and res.start == "lo"
    assert abs(res.value / Fc - 1.0) < 1e-9
    assert res.stable is True and res.direction == 1
    assert "through the guess" in res.followed and "stable" in res.followed
    assert isinstance(res.branch, Branch) and res.bracket[0] <= res.value <= res.bracket[1]
    assert res.margins[0] > 0.0 == res.margins[1] and res.bracket[1] == res.value  # clear below, grazing at it
    # the branch returned is the model's own: contact-free up to the onset, which it ends on
    assert all(min(p.upper_margin, p.lower_margin) > 0.0 for p in res.branch.points)
    assert res.branch.special[-1].kind == "grazing" and res.branch.special[-1].parameter == res.value
    p = res.branch.points[-1]
    again = periodic_orbit(Oscillator(p.parameter, 1.5, 0.1, 24.0), guess=(p.x, p.v), backend="exact")
    assert again.status == 0 and abs(again.x - p.x) < 1e-9 and abs(again.v - p.v) < 1e-9


# A stable contact orbit of the Den Hartog oscillator just above Fc (on the branch through the
# guess above): its contact branch folds at 1.000217 Fc going up, and loses its contacts at Fc going down.
CONTACT = (1.2583732909684309, (-0.9937457694004849, 0.165050446979377))


def test_continuation_a_fold_before_the_onset_is_status_2():
    Fc = den_hartog_onset(1.5, 0.1)
    F0, guess = CONTACT
    res = contact_onset(Oscillator(Fc, 1.5, 0.1, 24.0), "F", (F0, 1.1 * Fc), guess=guess)
    assert res.status == 2 and math.isnan(res.value) and "folds back" in res.message
    assert "touching a flange" in res.followed


def test_continuation_from_an_orbit_in_contact_finds_where_it_leaves_the_flange():
    Fc = den_hartog_onset(1.5, 0.1)
    F0, guess = CONTACT
    res = contact_onset(Oscillator(Fc, 1.5, 0.1, 24.0), "F", (0.9 * Fc, F0), start="hi", guess=guess)
    assert res.status == 0 and res.direction == 1 and res.stable is True
    assert abs(res.value / Fc - 1.0) < 1e-9 and "leaves the flange" in res.message


@pytest.mark.parametrize("backend", ["exact", "heyoka"])
def test_continuation_finds_the_linear_textbook_onset(backend):
    # issue 19: default settings answered 0.36757 (exact) / 0.36877 (heyoka) with status 0
    zeta, W = 0.05, 0.8
    exact = abs(1 - W**2 + 2j * zeta * W)  # the damped linear amplitude reaches 1
    res = contact_onset(Oscillator(0.3, W, 0.0, 1e4, zeta=zeta), "F", (0.2, 0.6), backend=backend)
    print(f"linear onset on {backend}: {res.value:.15f} against {exact:.15f}")
    assert res.status == 0 and abs(res.value - exact) < 1e-9
    assert "transient of 100 forcing periods" in res.followed and res.stable is True


def test_continuation_tape_drive_clearance_from_the_wide_end():
    drive = TapeDrive()
    res = contact_onset(drive, "clearance", (100e-6, 140e-6), start="hi", transient_periods=1)
    Lc = quasi_static_critical_clearance(drive)
    print(f"critical clearance {res.value * 1e6:.9f} um, quasi-static {Lc * 1e6:.9f} um: {res.message}")
    assert res.status == 0 and res.direction == -1 and res.start == "hi" and res.stable is True
    assert abs(res.value - Lc) < 1e-10  # the quasi-static closed form is itself ~3e-11 m off


def test_continuation_tape_drive_point_whose_polish_meets_the_grazing_itself():
    # a chart point that failed (status -1): Newton met the grazing orbit itself during the polish
    drive = TapeDrive(speed=8.0, tension=0.5)
    res = contact_onset(drive, "clearance", (100e-6, 140e-6), start="hi", transient_periods=1)
    assert res.status == 0 and abs(res.value - quasi_static_critical_clearance(drive)) < 1e-10


def test_continuation_without_an_onset_is_a_status():
    res = contact_onset(Oscillator(0.1, 0.8, 0.05, 1e4), "F", (0.05, 0.2))
    assert res.status == 1 and math.isnan(res.value) and "stays clear of the flanges" in res.message
    assert isinstance(res.branch, Branch) and len(res.branch.points) > 1


def test_continuation_bad_input():
    osc = Oscillator(0.3, 0.8, 0.05, 1e4)
    for kw in ({"scan": 4}, {"follow": False}, {"record_periods": 5}, {"stop_at_contact": True},
               {"max_evaluations": 10}):
        name = next(iter(kw))
        with pytest.raises(ValueError, match=rf"{name}=.*method='transient'"):
            contact_onset(osc, "F", (0.2, 0.4), **kw)
    with pytest.raises(ValueError, match="method must be one of"):
        contact_onset(osc, "F", (0.2, 0.4), method="shooting")
    with pytest.raises(ValueError, match="start must be 'lo' or 'hi'"):
        contact_onset(osc, "F", (0.2, 0.4), start="middle")
    with pytest.raises(TypeError, match="guess must be a pair"):
        contact_onset(osc, "F", (0.2, 0.4), guess=0.5)
    with pytest.raises(ValueError, match=r"guess\[0\]"):
        contact_onset(osc, "F", (0.2, 0.4), guess=(math.nan, 0.0))
    with pytest.raises(ValueError, match="transient_periods must be a whole number"):
        contact_onset(osc, "F", (0.2, 0.4), transient_periods=0.5)
    with pytest.raises(ValueError, match="guess=.*method='continuation' only"):
        contact_onset(osc, "F", (0.2, 0.4), method="transient", guess=(0.1, 0.0))
    with pytest.raises(ValueError, match="start=.*method='continuation' only"):
        contact_onset(osc, "F", (0.2, 0.4), method="transient", start="hi")
    with pytest.raises(ValueError, match="lo < hi"):
        contact_onset(osc, "F", (0.4, 0.2))
    with pytest.raises(ValueError, match="scan=.*method='transient'"):
        onset_chart(TapeDrive(), "clearance", (1e-4, 2e-4), {"speed": [2.0], "tension": [1.0]}, scan=3)


def test_continuation_no_orbit_at_the_start_is_a_status():
    res = contact_onset(Oscillator(0.3, 0.8, 0.05, 1e4), "F", (0.2, 0.4), guess=(0.9, 50.0))
    assert res.status == -1 and "no period-1 orbit" in res.message and math.isnan(res.value)


# -- method="transient" --------------------------------------------------------------------
def test_den_hartog_grazing_boundary():
    Fc = den_hartog_onset(0.8, 0.05)
    res = contact_onset(Oscillator(0.3, 0.8, 0.05, 1e4), "F", (0.8 * Fc, 1.1 * Fc), method="transient", tol=1e-10,
                        scan=4, orbit=1, x0=0.0, transient_periods=300)
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
    res = contact_onset(drive, "clearance", (100e-6, 140e-6), method="transient", tol=1e-9, transient_periods=0.25,
                        record_periods=1, stop_at_contact=True)
    Lc = quasi_static_critical_clearance(drive)
    print(f"critical clearance {res.value * 1e6:.6f} um, quasi-static run-out - mu N/k = {Lc * 1e6:.6f} um")
    assert res.status == 0 and res.direction == -1  # contact for clearances below it
    assert abs(res.value - Lc) < 2e-9
    assert drive.clearance > res.value  # the paper's 1 mm clearance is far from contact


def test_no_onset_in_the_bracket_is_a_status():
    res = contact_onset(Oscillator(0.1, 0.8, 0.05, 1e4), "F", (0.05, 0.2), method="transient", transient_periods=50)
    assert res.status == 1 and math.isnan(res.value) and "stays off the flanges" in res.message


def test_chart_over_two_parameters():
    drive = TapeDrive()
    ds = onset_chart(drive, "clearance", (115e-6, 125e-6), {"speed": [2.0, 8.0], "tension": [0.5, 2.0]},
                     executor="serial", progress=False, method="transient", tol=5e-8, transient_periods=0.25,
                     record_periods=1, stop_at_contact=True)
    assert ds.attrs["method"] == "transient"
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
