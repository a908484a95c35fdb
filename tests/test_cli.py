"""The command line: output, plots, and one-line errors."""

import os
import re

import pytest

from impactosc.__main__ import main


def test_demo(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "47 upper / 47 lower contacts" in out
    assert "0 upper / 0 lower contacts" in out  # the paper's drive never touches a flange


def test_simulate_oscillator_with_plot(capsys, tmp_path):
    png = tmp_path / "run.png"
    assert main(["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.01", "--K", "1e4",
                 "--events", "3", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "contact_start" in out and "47 upper" in out
    assert png.stat().st_size > 10_000


def test_simulate_tape_drive(capsys):
    assert main(["simulate", "--speed", "8", "--tension", "0.5", "--duration", "0.001", "--record", "stats"]) == 0
    out = capsys.readouterr().out
    assert "V = 8 m/s" in out and "0 upper / 0 lower contacts" in out


@pytest.mark.parametrize(
    "argv, message",
    [
        (["simulate", "--F", "0.5", "--Omega", "-1", "--beta", "0", "--K", "1"], "Omega must be >= 0"),
        (["simulate", "--speed", "4", "--F", "1"], "not both"),
        (["simulate", "--F", "0.5"], "missing: Omega, beta, K"),
        (["simulate", "--tension", "-1"], "tension"),
        (["simulate", "--backend", "euler"], "backend must be one of"),
        # each kind of model has its own end time: the other one is refused, not ignored
        (["simulate", "--speed", "4", "--t-end", "5"], "--t-end (nondimensional time) is for an oscillator"),
        (["simulate", "--t-end", "5"], "--t-end (nondimensional time) is for an oscillator"),
        (["simulate", "--F", "0.5", "--Omega", "1", "--beta", "0", "--K", "1", "--duration", "1"],
         "--duration (seconds) is for a tape drive"),
        (["simulate", "--F", "0.5", "--Omega", "1", "--beta", "0", "--K", "1", "--restitution", "2"], "restitution"),
        (["simulate", "--speed", "4", "--beta-static", "0.1"], "not both"),
        (["simulate", "--F", "0.5", "--Omega", "1", "--beta", "0", "--K", "1", "--static-friction", "0.3"],
         "not both"),
    ],
)
def test_errors_are_one_line(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactosc: error:") and message in err and "\n" not in err


# -- impactosc sweep ------------------------------------------------------------------------
@pytest.mark.slow  # a process pool
def test_sweep_writes_a_netcdf_dataset(capsys, tmp_path):
    import xarray as xr

    nc = tmp_path / "x.nc"
    assert main(["sweep", "--grid", "speed=4,8", "--duration", "0.001", "--out", str(nc), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "2 points (speed[2])" in out and "dataset written" in out
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.speed.values.tolist() == [4.0, 8.0]
        assert ds.mean_flange_force.attrs["units"] == "N"
        assert (ds.status.values == 0).all() and (ds.mean_flange_force.values == 0).all()
        assert ds.attrs["duration"] == 0.001


def test_sweep_toml_grid_and_plot(capsys, tmp_path):
    import xarray as xr

    toml = tmp_path / "grid.toml"
    toml.write_text('[grid]\npack_diameter = [0.05, 0.09]\nt_sin_half_theta = [0.1, 0.7]\n\n'
                    '[drive]\nspeed = 12.0\nclearance = 50e-6\n')
    nc, png = tmp_path / "t.nc", tmp_path / "t.png"
    assert main(["sweep", "--toml", str(toml), "--duration", "0.0005", "--serial", "--no-progress",
                 "--out", str(nc), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "4 points (pack_diameter[2] x t_sin_half_theta[2])" in out
    assert png.stat().st_size > 10_000
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.attrs["base_speed"] == 12.0 and ds.attrs["base_clearance"] == 50e-6
        assert ds.mean_flange_force.dims == ("pack_diameter", "t_sin_half_theta")
        assert (ds.impacts.values > 0).all()  # a 50 um clearance: the tape touches (see impactosc.paper)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["sweep", "--grid", "colour=1,2"], "unknown field 'colour'"),
        (["sweep", "--grid", "speed=4,fast"], "'fast' is not a number"),
        (["sweep", "--grid", "speed"], "expected field=v1,v2"),
        (["sweep", "--grid", "speed="], "no values"),
        (["sweep"], "give a grid"),
        (["sweep", "--grid", "speed=4,4", "--serial"], "duplicate"),
        (["sweep", "--grid", "speed=4", "--duration", "-1", "--serial"], "duration"),
        (["sweep", "--toml", "/nonexistent/grid.toml"], "cannot read"),
        (["sweep", "--grid", "speed=4", "--duration", "abc"], "invalid float value"),
        (["paper", "--bogus"], "unrecognized arguments"),
    ],
)
def test_sweep_errors_are_one_line(capsys, argv, message):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactosc: error:") and message in err and "\n" not in err


def test_bad_toml_is_one_line(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[grid\nspeed = [4")
    assert main(["sweep", "--toml", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert "not valid TOML" in err and "\n" not in err


def test_help_everywhere(capsys):
    for argv in (["--help"], ["sweep", "--help"], ["paper", "--help"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "--grid FIELD=V1,V2" in out and "--quick" in out and "--toml" in out


# -- output paths are checked before anything runs (issue #14 item 11) ----------------------
@pytest.fixture()
def no_sweep(monkeypatch):
    """Fails the test if a sweep or the paper reproduction starts."""
    import impactosc
    import impactosc.paper

    def boom(*args, **kwargs):
        raise AssertionError("the computation started although an output path was unusable")

    monkeypatch.setattr(impactosc, "sweep", boom)
    monkeypatch.setattr(impactosc.paper, "reproduce", boom)


def _unwritable_dir():
    # Creating files in /proc fails even for root (for whom permission bits do not apply).
    return "/proc" if os.path.isdir("/proc/self") else None


@pytest.mark.parametrize(
    "case, message",
    [
        ("out-missing-dir", "directory '/nonexistent' does not exist"),
        ("out-is-dir", "is a directory"),
        ("plot-missing-dir", "directory '/nonexistent' does not exist"),
        ("plot-is-dir", "is a directory"),
        ("store-is-file", "exists and is not a directory"),
        ("out-unwritable", "cannot write in '/proc'"),
        ("paper-out-unwritable", "cannot write in '/proc'"),
        ("paper-out-is-file", "exists and is not a directory"),
        ("simulate-plot-missing-dir", "directory '/nonexistent' does not exist"),
    ],
)
def test_unusable_output_paths_are_one_line_errors_before_running(capsys, tmp_path, no_sweep, case, message):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    sweep = ["sweep", "--grid", "speed=4", "--duration", "1e-5", "--no-progress"]
    if "unwritable" in case and _unwritable_dir() is None:
        pytest.skip("needs /proc for a directory nobody can write in")
    argv = {
        "out-missing-dir": sweep + ["--out", "/nonexistent/x.nc"],
        "out-is-dir": sweep + ["--out", str(tmp_path)],
        "plot-missing-dir": sweep + ["--plot", "/nonexistent/x.png"],
        "plot-is-dir": sweep + ["--plot", str(tmp_path)],
        "store-is-file": sweep + ["--store", str(a_file)],
        "out-unwritable": sweep + ["--out", "/proc/x.nc"],
        "paper-out-unwritable": ["paper", "--quick", "--out", "/proc/impactosc-reports"],
        "paper-out-is-file": ["paper", "--quick", "--out", str(a_file)],
        "simulate-plot-missing-dir": ["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.01", "--K", "1e4",
                                      "--plot", "/nonexistent/x.png"],
    }[case]
    assert main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("impactosc: error:") and message in err and "\n" not in err, err
    assert "Traceback" not in captured.out + captured.err


def test_a_failed_write_after_the_run_is_one_line(capsys, tmp_path, monkeypatch):
    import xarray as xr

    def fails(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied", str(tmp_path / "x.nc"))

    monkeypatch.setattr(xr.Dataset, "to_netcdf", fails)
    assert main(["sweep", "--grid", "speed=4", "--duration", "1e-5", "--serial", "--no-progress",
                 "--out", str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactosc: error:") and "Permission denied" in err and "x.nc" in err and "\n" not in err


@pytest.mark.parametrize("argv", [["simulate", "--events", "-1"], ["sweep", "--grid", "speed=4", "--rows", "-1"]])
def test_negative_row_counts_are_refused(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert "must be >= 0, got -1" in err and "\n" not in err


def test_events_zero_shows_no_rows_and_the_right_count(capsys):
    assert main(["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.01", "--K", "1e4", "--events", "0"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"Events \(first 0\):\n +t kind +x +v side\n\.\.\. [1-9]\d* more events", out), out


# -- simulate: the family options, --version, pipes, plots (issue 22 item 4, 6) ------------------
@pytest.fixture()
def simulated(monkeypatch):
    """The oscillators the CLI hands to impactosc.simulate (the runs still happen)."""
    import impactosc

    seen = []
    real = impactosc.simulate

    def spy(osc, *args, **kwargs):
        seen.append(osc)
        return real(osc, *args, **kwargs)

    monkeypatch.setattr(impactosc, "simulate", spy)
    return seen


def test_simulate_family_options_of_an_oscillator(capsys, simulated):
    from impactosc import Oscillator

    assert main(["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.01", "--K", "1e4", "--zeta", "0.02",
                 "--beta-static", "0.02", "--exponent", "1.5", "--harmonic", "0.1,2.2,0.3", "--harmonic", "0.05,3.3",
                 "--t-end", "50", "--events", "1"]) == 0
    assert simulated == [Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.02, beta_static=0.02, exponent=1.5,
                                    harmonics=((0.1, 2.2, 0.3), (0.05, 3.3, 0.0)))]
    assert main(["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.01", "--K", "1e4", "--flange", "rigid",
                 "--restitution", "0.8", "--t-end", "50", "--events", "1"]) == 0
    assert simulated[1] == Oscillator(0.5, 1.1, 0.01, 1e4, flange="rigid", restitution=0.8)
    assert "contact" in capsys.readouterr().out


def test_simulate_family_options_of_a_tape_drive(capsys, simulated):
    from impactosc import TapeDrive

    assert main(["simulate", "--speed", "8", "--zeta", "0.01", "--static-friction", "0.3", "--exponent", "1.5",
                 "--runout-harmonic", "2,0.1,0.5", "--duration", "1e-4", "--record", "stats"]) == 0
    want = TapeDrive(speed=8.0, damping_ratio=0.01, static_friction=0.3, flange_exponent=1.5,
                     runout_harmonics=((2, 0.1, 0.5),))
    assert simulated == [want.oscillator()]
    assert main(["simulate", "--flange", "rigid", "--restitution", "0.5", "--duration", "1e-4",
                 "--record", "stats"]) == 0
    assert simulated[1] == TapeDrive(flange="rigid", restitution=0.5).oscillator()
    capsys.readouterr()


def test_harmonic_needs_two_or_three_numbers(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--F", "0.5", "--Omega", "1", "--beta", "0", "--K", "1", "--harmonic", "0.1"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert "expected F,Omega[,phase]" in err and "\n" not in err


def test_version(capsys):
    from impactosc import __version__

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"impactosc {__version__}"


def test_plot_without_matplotlib_fails_before_the_run(capsys, monkeypatch, simulated):
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib... raises ImportError
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    assert main(["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.01", "--K", "1e4",
                 "--plot", "run.png"]) == 2
    err = capsys.readouterr().err.strip()
    assert "pip install 'impactosc[plot]'" in err and "\n" not in err
    assert simulated == []  # nothing was run


@pytest.mark.slow  # a subprocess
def test_a_closed_pipe_ends_quietly():
    """``impactosc simulate ... | head``: no "Broken pipe" error, no traceback (the reader left, that is all)."""
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-m", "impactosc", "simulate", "--F", "0.5", "--Omega", "1.1",
                             "--beta", "0.01", "--K", "1e4", "--t-end", "3000", "--events", "100000"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = proc.stdout.readline()
    proc.stdout.close()  # like head after its lines: far more than a pipe buffer is still to come
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert proc.wait(timeout=120) == 1
    assert first.startswith(b"Oscillator(")
    assert "Broken pipe" not in err and "Traceback" not in err and "BrokenPipeError" not in err, err
