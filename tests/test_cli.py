"""The command line: output, plots, and one-line errors."""

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
    ],
)
def test_errors_are_one_line(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactosc: error:") and message in err and "\n" not in err
