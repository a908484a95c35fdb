"""``impactosc path FILE`` (issue 28, item 3): a tape path from a path file, end to end."""

from __future__ import annotations

from importlib.resources import files

import numpy as np
import pytest

from impactosc import TapePath
from impactosc.__main__ import main
from impactosc.sweeps import critical_clearance, simulate_path

TWO = files("impactosc.cli") / "paths" / "two-guides.toml"
FOUR = files("impactosc.cli") / "paths" / "four-guides.toml"


def test_example_prints_a_file_that_runs(capsys, tmp_path):
    assert main(["path", "--example", "four-guides"]) == 0
    text = capsys.readouterr().out
    assert text == FOUR.read_text(encoding="utf-8")
    f = tmp_path / "four.toml"
    f.write_text(text)
    assert TapePath.from_file(f) == TapePath.from_file(FOUR)
    assert main(["path", str(f), "--duration", "0.0005"]) == 0  # every table of the example is read
    assert "4 guides at 20, 50, 80, 110 mm" in capsys.readouterr().out


def test_one_run_prints_the_guides_and_writes_motion_and_events(capsys, tmp_path):
    motion, events = tmp_path / "m.csv", tmp_path / "e.csv"
    assert main(["path", str(TWO), "--motion", str(motion), "--events", str(events), "--samples", "101"]) == 0
    out = capsys.readouterr().out
    path = TapePath.from_file(TWO)
    run = simulate_path(path, 0.002)  # the file's [run] duration
    assert "2 guides at 20, 50 mm" in out and "status 0" in out
    rows = [line.split() for line in out.splitlines() if line.strip()[:1].isdigit()][:2]
    for i, row in enumerate(rows):
        assert int(row[4]) == run.contact_starts(i).size
        assert float(row[7]) == pytest.approx(run.mean_flange_force(i), rel=1e-4)  # printed to 5 digits
    data = np.loadtxt(motion, delimiter=",", comments="#", skiprows=2)
    assert data.shape == (101, 4)
    t = np.linspace(0.0, run.duration, 101)
    np.testing.assert_allclose(data[:, 1], run.lateral_motion(t, 0.065), rtol=0, atol=1e-15)
    np.testing.assert_allclose(data[:, 3], run.lateral_motion(t, 0.05), rtol=0, atol=1e-15)
    lines = events.read_text().splitlines()
    assert lines[1] == "time_s,kind,guide,side" and len(lines) == 2 + len(run.solution.events)
    starts = [line.split(",") for line in lines[2:] if ",contact_start," in line]
    np.testing.assert_allclose([float(s[0]) for s in starts if s[2] == "1"], run.contact_starts(1), rtol=1e-15)
    assert {s[3] for s in starts} <= {"1", "-1"}


def test_options_override_the_file(capsys):
    assert main(["path", str(TWO), "--duration", "0.0005", "--head", "0.02"]) == 0
    out = capsys.readouterr().out
    assert "0.0005 s of tape motion" in out and "head at 20 mm" in out


def test_backend_runs_the_path_on_the_cross_check(capsys):
    assert main(["path", str(TWO), "--duration", "0.0005", "--backend", "heyoka"]) == 0
    heyoka = [line.split() for line in capsys.readouterr().out.splitlines() if line.strip()[:1].isdigit()][:2]
    assert main(["path", str(TWO), "--duration", "0.0005"]) == 0
    exact = [line.split() for line in capsys.readouterr().out.splitlines() if line.strip()[:1].isdigit()][:2]
    assert heyoka == exact and int(exact[1][4]) > 0  # the same table to the printed digits, with contacts


def test_grid_sweeps_and_writes_a_dataset(capsys, tmp_path):
    import xarray as xr

    nc, png = tmp_path / "s.nc", tmp_path / "s.png"
    assert main(["path", str(TWO), "--grid", "guide1_clearance=30e-6,1e-3", "--duration", "0.001", "--serial",
                 "--no-progress", "--out", str(nc), "--plot", str(png)]) == 0
    assert "2 points (guide1_clearance[2])" in capsys.readouterr().out
    assert png.stat().st_size > 10_000
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.mean_flange_force.dims == ("guide1_clearance", "guide")
        assert ds.mean_flange_force.attrs["units"] == "N"
        assert float(ds.contacts.sel(guide1_clearance=1e-3, guide=1)) == 0.0
        assert float(ds.contacts.sel(guide1_clearance=30e-6, guide=1)) > 0.0


def test_critical_clearance_of_a_guide(capsys):
    assert main(["path", str(TWO), "--critical-clearance", "1"]) == 0
    out = capsys.readouterr().out
    expected = critical_clearance(TapePath.from_file(TWO), 1)
    assert f"critical clearance {expected * 1e6:.6g} um" in out and "its clearance 40 um: contact" in out


def test_critical_clearance_chart_writes_its_dataset_and_figure(capsys, tmp_path):
    import xarray as xr

    nc, png = tmp_path / "c.nc", tmp_path / "c.png"
    assert main(["path", str(TWO), "--critical-clearance", "1", "--grid", "pack_diameter=0.05,0.09", "--serial",
                 "--no-progress", "--out", str(nc), "--plot", str(png)]) == 0
    assert "critical clearance of guide 1 [um] over pack_diameter[2]: 0 failed" in capsys.readouterr().out
    assert png.stat().st_size > 10_000
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.critical_clearance.attrs["units"] == "m"
        path = TapePath.from_file(TWO)
        for d in (0.05, 0.09):
            assert float(ds.critical_clearance.sel(pack_diameter=d)) == pytest.approx(
                critical_clearance(path.with_parameter("pack_diameter", d), 1), rel=1e-12)


@pytest.mark.parametrize("extra, text, message", [
    ([], "[run]\nduration = -1\n", r"\[run\] duration must be > 0, got -1"),
    ([], "[run]\nduraton = 1\n", r"\[run\] has an unknown key 'duraton'"),
    ([], "[output]\nsamples = 0\n", r"\[output\] samples must be an integer >= 1, got 0"),
    ([], "[output]\nmotion = 3\n", r"\[output\] motion must be a file name"),
    ([], "[[guides]]\nposition = 0.02\nclearance = -1e-6\n", r"guides\[0\]: clearance must be > 0"),
    (["--duration", "-1"], "", "--duration must be > 0"),
    (["--grid", "colour=1,2"], "", "'colour' is not a path parameter"),
    (["--grid", "speed=1,fast"], "", "'fast' is not a number"),
    (["--out", "x.nc"], "", "--out is for a --grid sweep"),
    (["--plot", "x.png"], "", "--plot is for a --grid sweep"),
    (["--grid", "speed=1,2", "--plot", "x.xyz"], "", "the figure's format is its extension"),
    (["--grid", "speed=1,2", "--motion", "m.csv"], "", "--motion and --events are for a single run"),
    (["--critical-clearance", "5"], "", "--critical-clearance must name guides 0 to 0"),
    (["--head", "1.0"], "", "head must lie on the path"),
    (["--grid", "speed=1,2", "--backend", "scipy"], "", "--backend scipy applies to a single run"),
])
def test_bad_files_and_options_are_one_line_errors(capsys, tmp_path, extra, text, message):
    import re

    f = tmp_path / "p.toml"
    base = "" if "[[guides]]" in text else "[[guides]]\nposition = 0.02\n"
    f.write_text(base + text + ("[run]\nduration = 1e-4\n" if "[run]" not in text else ""))
    assert main(["path", str(f), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactosc: error: ") and len(err.strip().splitlines()) == 1
    assert re.search(message, err), err


def test_no_file_is_an_error(capsys):
    assert main(["path"]) == 2
    assert "give a path file" in capsys.readouterr().err
