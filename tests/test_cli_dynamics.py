"""The dynamics subcommands end to end: each writes its file and figure, checked against closed forms."""

from __future__ import annotations

import json

import numpy as np
import pytest

from impactosc import Oscillator, TapeDrive
from impactosc.cli import main
from impactosc.dynamics import (
    den_hartog_amplitude,
    den_hartog_multipliers,
    den_hartog_onset,
    periodic_orbit,
    quasi_static_critical_clearance,
)

# Den Hartog's oscillator (no flange contact below F ~ 0.364): every answer has a closed form.
DEN_HARTOG = ["--F", "0.3", "--Omega", "0.8", "--beta", "0.05", "--K", "1e4"]


@pytest.fixture(autouse=True)
def _agg():
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")


def test_bifurcation_writes_the_section_points_of_the_period_1_orbit(capsys, tmp_path):
    import xarray as xr

    nc, png = tmp_path / "bif.nc", tmp_path / "bif.png"
    assert main(["bifurcation", *DEN_HARTOG, "--param", "F", "--range", "0.2", "0.3", "--n", "3",
                 "--transient-periods", "200", "--record-periods", "3", "--serial", "--no-progress",
                 "--out", str(nc), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "3 values" in out and "0 failed" in out and "dataset written" in out
    assert png.stat().st_size > 10_000
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.x.dims == ("direction", "F", "period")
        np.testing.assert_allclose(ds.F.values, [0.2, 0.25, 0.3])
        assert (ds.status.values == 0).all()
        for i, F in enumerate((0.2, 0.25, 0.3)):
            orbit = periodic_orbit(Oscillator(F, 0.8, 0.05, 1e4), guess=(0.5, 0.0))
            np.testing.assert_allclose(ds.x.values[0, i], orbit.x, atol=1e-8)
            np.testing.assert_allclose(ds.v.values[0, i], orbit.v, atol=1e-8)


def test_orbit_prints_and_writes_the_den_hartog_multipliers(capsys, tmp_path):
    path, png = tmp_path / "orbit.json", tmp_path / "orbit.png"
    assert main(["orbit", *DEN_HARTOG, "--guess", "0.8", "0", "--json", str(path), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "period-1 orbit" in out and "Floquet multipliers" in out and "stable" in out
    rec = json.loads(path.read_text())
    assert rec["status"] == 0 and rec["n"] == 1 and rec["stability"] == "stable"
    def order(m):  # a complex pair: the real parts agree to rounding
        return round(m.real, 6), m.imag

    got = sorted((complex(re, im) for re, im in rec["multipliers"]), key=order)
    want = sorted((complex(m) for m in den_hartog_multipliers(0.3, 0.8, 0.05)), key=order)
    np.testing.assert_allclose(got, want, atol=1e-8)
    assert abs(rec["x"]) <= den_hartog_amplitude(0.3, 0.8, 0.05)  # the orbit's stops are at +-A
    assert rec["events_per_period"] == {"reversal": 2}
    assert png.stat().st_size > 10_000


def test_onset_follows_the_branch_to_the_den_hartog_grazing_value(capsys, tmp_path):
    path, png = tmp_path / "onset.json", tmp_path / "onset.png"
    assert main(["onset", *DEN_HARTOG, "--param", "F", "--bracket", "0.33", "0.45", "--guess", "0.8", "0",
                 "--json", str(path), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "contact above it" in out and "(continuation)" in out and "through the guess" in out
    rec = json.loads(path.read_text())
    assert rec["status"] == 0 and rec["method"] == "continuation" and rec["start"] == "lo"
    assert rec["stable"] is True and rec["direction"] == 1 and "GR1" in rec["branch"]
    assert abs(rec["value"] - den_hartog_onset(0.8, 0.05)) < 1e-9
    assert png.stat().st_size > 10_000


def test_onset_refuses_the_options_of_the_other_method(capsys):
    assert main(["onset", *DEN_HARTOG, "--param", "F", "--bracket", "0.33", "0.45", "--scan", "4"]) == 2
    err = capsys.readouterr().err
    assert "--scan: an option of --method transient" in err
    assert main(["onset", *DEN_HARTOG, "--param", "F", "--bracket", "0.33", "0.45", "--method", "transient",
                 "--guess", "0.8", "0"]) == 2
    assert "--guess: an option of --method continuation" in capsys.readouterr().err


def test_onset_transient_finds_the_den_hartog_grazing_value(capsys, tmp_path):
    path, png = tmp_path / "onset.json", tmp_path / "onset.png"
    assert main(["onset", *DEN_HARTOG, "--param", "F", "--bracket", "0.33", "0.45", "--method", "transient",
                 "--scan", "4", "--orbit", "1",
                 "--x0", "0", "--transient-periods", "300", "--value-tol", "1e-10", "--plot-values", "8",
                 "--json", str(path), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "contact above it" in out and "result written" in out
    rec = json.loads(path.read_text())
    assert rec["status"] == 0 and rec["parameter"] == "F" and rec["direction"] == 1
    assert abs(rec["value"] - den_hartog_onset(0.8, 0.05)) < 1e-9
    assert png.stat().st_size > 10_000


def test_continue_writes_the_branch_and_its_den_hartog_grazing(capsys, tmp_path):
    import xarray as xr

    nc, png = tmp_path / "branch.nc", tmp_path / "branch.png"
    assert main(["continue", *DEN_HARTOG, "--param", "F", "--limits", "0.2", "0.36", "--guess", "0.8", "0",
                 "--out", str(nc), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "branch of period-1 orbits in F" in out and "through the guess" in out and "branch written" in out
    assert png.stat().st_size > 10_000
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.attrs["parameters"] == "F" and ds.attrs["status"] == 0 and ds.attrs["special"] == ""
        F = ds.F.values
        assert F.min() == pytest.approx(0.2, abs=1e-12) and F.max() == pytest.approx(0.36, abs=1e-12)
        assert bool(ds.stable.values.all())  # the Den Hartog orbits are stable below the grazing
        # 1 - max X is the distance of the non-stop orbit's amplitude from the flange
        for i in (0, F.size // 2, F.size - 1):
            assert 1.0 - ds.upper_margin.values[i] == pytest.approx(den_hartog_amplitude(F[i], 0.8, 0.05), abs=1e-9)


def test_continue_follows_the_grazing_in_two_parameters(capsys, tmp_path):
    import xarray as xr

    nc, png = tmp_path / "boundary.nc", tmp_path / "boundary.png"
    assert main(["continue", *DEN_HARTOG, "--param", "F", "--limits", "0.3", "0.4", "--guess", "0.8", "0",
                 "--direction", "forward", "--boundary", "Omega", "0.7", "0.9", "--special", "grazing",
                 "--out", str(nc), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "GR1" in out and "boundary of GR1 (grazing) in (F, Omega)" in out and "boundary written" in out
    assert png.stat().st_size > 10_000
    with xr.open_dataset(nc, engine="scipy") as ds:  # --out keeps the branch, the boundary goes beside it
        assert ds.attrs["parameters"] == "F" and "GR1 grazing" in ds.attrs["special"]
    with xr.open_dataset(tmp_path / "boundary_boundary.nc", engine="scipy") as ds:
        assert ds.attrs["parameters"] == "F, Omega" and ds.F.size > 10
        assert ds.Omega.values.min() == pytest.approx(0.7) and ds.Omega.values.max() == pytest.approx(0.9)
        for F, W in zip(ds.F.values, ds.Omega.values, strict=True):  # every point on Den Hartog's grazing curve
            assert abs(F - den_hartog_onset(W, 0.05)) < 1e-9


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--special", "grazing"], "--special needs --boundary"),
        (["--boundary", "Omega", "0.7", "0.9"], "--boundary needs --special"),
        (["--boundary", "F", "0.7", "0.9", "--special", "fold"], "must differ from --param"),
        (["--boundary", "speed", "0.7", "0.9", "--special", "fold"], "--boundary must be one of"),
    ],
)
def test_continue_refuses_a_bad_boundary(capsys, extra, message):
    assert main(["continue", *DEN_HARTOG, "--param", "F", "--limits", "0.3", "0.4", *extra]) == 2
    assert message in capsys.readouterr().err


def test_onset_without_a_sign_change_is_status_1_and_null_in_json(capsys, tmp_path):
    path = tmp_path / "none.json"
    assert main(["onset", "--F", "0.1", "--Omega", "0.8", "--beta", "0.05", "--K", "1e4", "--param", "F",
                 "--bracket", "0.05", "0.2", "--transient-periods", "50", "--json", str(path)]) == 1
    rec = json.loads(path.read_text())  # strict JSON: NaN is written as null
    assert rec["status"] == 1 and rec["value"] is None and "stays clear of the flanges" in rec["message"]


def test_chart_writes_the_quasi_static_critical_clearance(capsys, tmp_path):
    import xarray as xr

    nc, png = tmp_path / "chart.nc", tmp_path / "chart.png"
    assert main(["chart", "--param", "clearance", "--bracket", "115e-6", "125e-6", "--grid", "speed=2,8",
                 "--grid", "tension=0.5,2", "--method", "transient", "--transient-periods", "0.25",
                 "--record-periods", "1", "--stop-at-contact", "--value-tol", "5e-8", "--serial", "--no-progress",
                 "--out", str(nc), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "speed[2] x tension[2] points" in out and "dataset written" in out
    assert png.stat().st_size > 10_000
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.critical.dims == ("speed", "tension") and (ds.status.values == 0).all()
        for s in (2.0, 8.0):
            for t in (0.5, 2.0):
                Lc = quasi_static_critical_clearance(TapeDrive(speed=s, tension=t))
                assert abs(float(ds.critical.sel(speed=s, tension=t)) - Lc) < 1e-7


@pytest.mark.parametrize(
    "argv, message",
    [
        (["bifurcation", *DEN_HARTOG, "--param", "speed", "--range", "1", "2"], "--param must be one of"),
        (["bifurcation", *DEN_HARTOG, "--param", "F", "--range", "0.3", "0.2"], "LO < HI"),
        (["bifurcation", "--speed", "4", "--param", "F", "--range", "0.1", "0.2"], "--param must be one of"),
        (["orbit", "--F", "0.3"], "missing: Omega, beta, K"),
        (["onset", *DEN_HARTOG, "--param", "F", "--bracket", "0.5", "0.4"], "LO < HI"),
        (["continue", *DEN_HARTOG, "--param", "F", "--limits", "0.5", "0.4"], "LO < HI"),
        (["continue", *DEN_HARTOG, "--param", "speed", "--limits", "0.3", "0.4"], "--param must be one of"),
        (["chart", "--param", "clearance", "--bracket", "1e-4", "2e-4", "--grid", "speed=2,4"], "exactly two"),
        (["chart", "--param", "clearance", "--bracket", "1e-4", "2e-4", "--grid", "speed=2,x", "--grid",
          "tension=1"], "'x' is not a number"),
        (["orbit", *DEN_HARTOG, "--json", "/nonexistent/o.json"], "directory '/nonexistent' does not exist"),
        (["bifurcation", *DEN_HARTOG, "--param", "F", "--range", "0.1", "0.2", "--n", "0"], "must be >= 1"),
    ],
)
def test_dynamics_errors_are_one_line(capsys, argv, message):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactosc: error:") and message in err and "\n" not in err, err
