"""Results that plug in: DataFrames, exact uniform resampling, SI units and the run plot.

A closed-form run first (free undamped oscillation, X = X0 cos Lambda), then a run with
contacts checked against its own record arrays, then a tape drive in SI units.
"""

from __future__ import annotations

import math
import sys

import matplotlib
import numpy as np
import pandas as pd
import pytest
import xarray as xr

import impactosc as io
from impactosc.results import _frames as frames
from impactosc.results._frames import SolutionFramesMixin

matplotlib.use("Agg")

CONTACT_CASE = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
#: Alternative B of impactosc.paper at 12 m/s, 0.5 N: ~100 flange impacts per second, cheap.
DRIVE = io.TapeDrive(speed=12.0, tension=0.5, bending="out-of-plane", friction=1e-5, clearance=100e-6)


class FramesSolution(io.Solution, SolutionFramesMixin):
    """A Solution with the mixin, as Solution will be once it inherits it."""


def with_mixin(sol):
    if not isinstance(sol, SolutionFramesMixin):
        sol.__class__ = FramesSolution
    return sol


@pytest.fixture(scope="module")
def contact_run():
    return with_mixin(io.simulate(CONTACT_CASE, 400.0))


@pytest.fixture(scope="module")
def drive_run():
    return with_mixin(io.simulate(DRIVE.oscillator(), DRIVE.seconds_to_lambda(0.1)))


# -- resampling --------------------------------------------------------------------------------
def test_resample_free_oscillation_matches_the_closed_form():
    sol = with_mixin(io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=1e4), 20.0, x0=0.5, v0=0.0))
    ds = sol.resample(0.1)
    assert sol.resample(0.1, t1=0.3)["t"].size == 4  # 0.3 / 0.1 = 2.9999999999999996: t1 is on the grid
    assert isinstance(ds, xr.Dataset)
    t = ds["t"].to_numpy()
    assert t.size == 201 and t[-1] == pytest.approx(20.0, rel=1e-14, abs=0)
    np.testing.assert_allclose(np.diff(t), 0.1, rtol=1e-9)
    np.testing.assert_allclose(ds["x"], 0.5 * np.cos(t), atol=1e-12)
    np.testing.assert_allclose(ds["v"], -0.5 * np.sin(t), atol=1e-12)
    assert float(ds["flange_force"].max()) == 0.0
    assert ds["x"].attrs["units"] == "L" and ds["t"].attrs["units"] == "1/omega_n"


def test_resample_is_the_dense_output_on_a_grid(contact_run):
    ds = contact_run.resample(0.05, t0=10.0, t1=60.0)
    t = ds["t"].to_numpy()
    assert t[0] == 10.0 and t.size == 1001
    x, v = contact_run.sample(t)
    np.testing.assert_array_equal(ds["x"], x)
    np.testing.assert_array_equal(ds["v"], v)
    np.testing.assert_array_equal(ds["flange_force"], CONTACT_CASE.flange_force(x))
    np.testing.assert_allclose(ds["forcing"], CONTACT_CASE.forcing(t), rtol=1e-15)
    assert float(ds["flange_force"].max()) > 0  # contacts are on the grid
    df = contact_run.resample(0.05, t0=10.0, t1=60.0, output="dataframe")
    assert isinstance(df, pd.DataFrame) and df.index.name == "t [1/omega_n]"
    assert list(df.columns) == ["x [L]", "v [L omega_n]", "flange_force [k L]", "forcing [k L]", "Lambda [-]"]
    np.testing.assert_array_equal(df["x [L]"], x)


def test_resample_in_si_units(drive_run):
    ds = drive_run.resample(1e-5, DRIVE)
    t = ds["t"].to_numpy()
    assert ds["t"].attrs["units"] == "s" and ds["x"].attrs["units"] == "m" and ds["flange_force"].attrs["units"] == "N"
    assert t.size == 10001 and t[-1] == pytest.approx(0.1, rel=1e-12, abs=0)
    np.testing.assert_allclose(ds["Lambda"], t * DRIVE.omega_n, rtol=1e-14)
    X, V = drive_run.sample(ds["Lambda"].to_numpy())
    np.testing.assert_allclose(ds["x"], X * DRIVE.clearance, rtol=1e-15)
    np.testing.assert_allclose(ds["v"], V * DRIVE.clearance * DRIVE.omega_n, rtol=1e-15)
    np.testing.assert_allclose(ds["flange_force"], DRIVE.oscillator().flange_force(X) * DRIVE.force_scale, rtol=1e-15)
    # The peak flange force on the grid cannot exceed the located peak of the impacts.
    assert 0 < float(ds["flange_force"].max()) <= drive_run.max_flange_force() * DRIVE.force_scale * (1 + 1e-12)
    assert ds.attrs["units"] == "SI" and "TapeDrive" in ds.attrs["drive"]


def test_resample_refuses_bad_grids(contact_run):
    with pytest.raises(ValueError, match=r"resample needs record='full'.*record='events'"):
        frames.resample(io.simulate(CONTACT_CASE, 40.0, record="events"), 0.1)
    with pytest.raises(ValueError, match="dt must be > 0, got -0.1"):
        contact_run.resample(-0.1)
    with pytest.raises(ValueError, match=r"window must satisfy.*t1=500"):
        contact_run.resample(0.1, t1=500.0)
    with pytest.raises(ValueError, match=r"dt=1e-12 over the window.*400,000,000,000,001 samples.*available memory"):
        contact_run.resample(1e-12)
    with pytest.raises(ValueError, match=r"4,001 samples.*max_samples allows \(1,000\)"):
        contact_run.resample(0.1, max_samples=1000)
    with pytest.raises(ValueError, match="output must be one of"):
        contact_run.resample(0.1, output="csv")


# -- tables ------------------------------------------------------------------------------------
def test_event_and_impact_frames_hold_the_record_arrays(contact_run):
    ev = contact_run.to_dataframe()
    rec = contact_run.events
    assert len(ev) == len(rec) and list(ev.columns) == ["t [1/omega_n]", "kind", "x [L]", "v [L omega_n]", "side"]
    np.testing.assert_array_equal(ev["t [1/omega_n]"], rec.t)
    assert list(ev["kind"].cat.categories) == list(io.EVENT_KINDS)
    assert (ev["kind"] == "contact_start").sum() == contact_run.counts["contact_start"]
    im = contact_run.to_dataframe("impacts")
    assert len(im) == len(contact_run.impacts) > 0
    np.testing.assert_array_equal(im["duration [1/omega_n]"], contact_run.impacts.end - contact_run.impacts.start)
    np.testing.assert_array_equal(im["peak_force [k L]"], contact_run.impacts.peak_force)
    assert im["complete"].dtype == bool and im["side"].dtype == np.int8
    with pytest.raises(ValueError, match="table must be one of"):
        contact_run.to_dataframe("segments")


def test_frames_in_si_units(drive_run):
    im = drive_run.to_dataframe("impacts", DRIVE)
    rec = drive_run.impacts
    np.testing.assert_allclose(im["start [s]"], rec.start / DRIVE.omega_n, rtol=1e-15)
    np.testing.assert_allclose(im["peak_penetration [m]"], rec.peak_penetration * DRIVE.clearance, rtol=1e-15)
    np.testing.assert_allclose(im["peak_force [N]"], rec.peak_force * DRIVE.stiffness * DRIVE.clearance, rtol=1e-15)
    np.testing.assert_allclose(im["entry_velocity [m/s]"], rec.entry_velocity * DRIVE.clearance * DRIVE.omega_n,
                               rtol=1e-15)
    np.testing.assert_allclose(im["impulse [N s]"], rec.impulse * DRIVE.force_scale / DRIVE.omega_n, rtol=1e-15)
    # A contact of the flange spring lasts half its period: pi / (omega_n sqrt(1 + K)) seconds.
    half_period = math.pi / (DRIVE.omega_n * math.sqrt(1 + DRIVE.K))
    np.testing.assert_allclose(im["duration [s]"], half_period, rtol=0.02)
    ev = drive_run.to_dataframe("events", DRIVE)
    assert ev.attrs["units"] == "SI" and "x [m]" in ev.columns


def test_to_si_converts_every_statistic(drive_run):
    si = drive_run.to_si(DRIVE)
    s = si.stats
    kL, L, w_n = DRIVE.force_scale, DRIVE.clearance, DRIVE.omega_n

    def close(value, rel=1e-15):
        return pytest.approx(value, rel=rel, abs=0)

    assert s["mean_flange_force_both [N]"] == close(drive_run.mean_flange_force() * kL)
    assert s["max_penetration_lower [m]"] == close(drive_run.max_penetration(-1) * L)
    assert s["contact_time_upper [s]"] == close(drive_run.contact_time(1) / w_n)
    assert s["t_final [s]"] == close(0.1, rel=1e-12)
    assert s["forcing_work [J]"] == close(drive_run.forcing_work * kL * L)
    assert s["contacts_both"] == drive_run.contact_entries() == len(si.impacts)
    # Mean force = impulse / duration, in SI as in eq. 3 units.
    assert s["flange_impulse_both [N s]"] / s["t_final [s]"] == close(s["mean_flange_force_both [N]"], rel=1e-12)
    stats_only = frames.to_si(io.simulate(DRIVE.oscillator(), DRIVE.seconds_to_lambda(0.1), record="stats"), DRIVE)
    assert stats_only.events is None and stats_only.impacts is None
    assert stats_only.stats["mean_flange_force_both [N]"] == close(s["mean_flange_force_both [N]"], rel=1e-9)


def test_a_drive_that_is_not_the_runs_is_refused(drive_run):
    with pytest.raises(ValueError, match=r"drive does not match the run: drive.beta"):
        drive_run.to_si(DRIVE.replace(tension=1.0))
    with pytest.raises(ValueError, match=r"drive.F"):
        drive_run.resample(1e-4, DRIVE.replace(clearance=50e-6))
    with pytest.raises(TypeError, match="drive must be a TapeDrive"):
        drive_run.to_dataframe("events", drive="SI")
    with pytest.raises(TypeError, match="needs the run's TapeDrive"):
        frames.to_si(drive_run, None)


# -- plot ----------------------------------------------------------------------------------------
def test_plot_marks_events_by_kind_and_the_flanges(contact_run):
    fig = contact_run.plot()
    ax_t, ax_p = fig.axes
    labels = [line.get_label() for line in ax_t.get_lines()]
    for kind in ("contact_start", "contact_end", "reversal"):
        n = contact_run.counts[kind]
        assert f"{kind} ({n})" in labels
        line = ax_t.get_lines()[labels.index(f"{kind} ({n})")]
        np.testing.assert_array_equal(line.get_xdata(), contact_run.events.t[contact_run.events.kind == kind])
    flanges_t = sorted(line.get_ydata()[0] for line in ax_t.get_lines() if line.get_linestyle() == "--")
    flanges_p = sorted(line.get_xdata()[0] for line in ax_p.get_lines() if line.get_linestyle() == "--")
    assert flanges_t == flanges_p == [-1, 1]
    traj = ax_p.get_lines()[0]
    assert np.max(np.abs(traj.get_xdata())) > 1  # the trajectory enters the flanges
    matplotlib.pyplot.close(fig)


def test_plot_in_si_units(drive_run, tmp_path):
    fig = drive_run.plot(DRIVE, kinds=("contact_start",), path=tmp_path / "run.png")
    ax_t, ax_p = fig.axes
    assert ax_t.get_xlabel() == "t [ms]" and ax_p.get_xlabel() == "x [µm]"
    flanges = sorted(line.get_xdata()[0] for line in ax_p.get_lines() if line.get_linestyle() == "--")
    assert flanges == pytest.approx([-100.0, 100.0])  # L = 100 um
    assert [line.get_label() for line in ax_t.get_lines()][-1] == f"contact_start ({drive_run.contact_entries()})"
    assert (tmp_path / "run.png").stat().st_size > 0
    matplotlib.pyplot.close(fig)


def test_plot_without_matplotlib_says_how_to_install(contact_run, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=r"pip install 'impactosc\[plot\]'"):
        contact_run.plot()
