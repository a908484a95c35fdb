"""analyze and analyze_csv refuse what they cannot read or compute, naming the file, argument, rule (issue 20, 8)."""

from __future__ import annotations

import numpy as np
import pytest

import impactosc.signal as sg


def record(n: int = 2000, dt: float = 1e-5):
    t = np.arange(n) * dt
    return t, 1e-6 * np.sin(2 * np.pi * 1500 * t) + 2e-5 * np.sin(2 * np.pi * 30 * t)


def write_csv(path, t, x, sep=",", encoding="utf-8", header=""):
    text = header + "".join(f"{float(a)!r}{sep}{float(b)!r}\n" for a, b in zip(t, x, strict=True))
    path.write_bytes(text.encode(encoding))
    return path


def test_latin1_file_names_the_file_and_the_encoding_option(tmp_path):
    t, x = record()
    path = write_csv(tmp_path / "mesure.csv", t, x, header="# capteur à 20 °C\n", encoding="latin-1")
    with pytest.raises(ValueError, match=r"mesure\.csv: cannot be decoded as 'utf-8' text \(byte 0xe0.*encoding="):
        sg.analyze_csv(path)
    res = sg.analyze_csv(path, encoding="latin-1")  # and the option reads it
    ref = sg.analyze(t, x)
    assert res.band_rms == pytest.approx(ref.band_rms, rel=1e-12)


def test_binary_file_is_refused_with_its_name(tmp_path):
    path = tmp_path / "capture.bin"
    path.write_bytes(bytes(range(256)) * 8)
    with pytest.raises(ValueError, match=r"capture\.bin: cannot be decoded as 'utf-8'"):
        sg.analyze_csv(path)
    with pytest.raises(ValueError, match=r"capture\.bin: .*(binary|single column|cannot be read)"):
        sg.read_ltm_csv(path, encoding="latin-1")


def test_one_column_file_says_two_columns_are_needed(tmp_path):
    _, x = record()
    path = tmp_path / "x_only.csv"
    path.write_text("ltm_m\n" + "".join(f"{float(b)!r}\n" for b in x))
    with pytest.raises(ValueError, match=r"x_only\.csv: has a single column.*time and displacement"):
        sg.analyze_csv(path)


def test_tiny_time_step_names_the_cutoff_and_the_sampling_rate(tmp_path):
    t, x = record()
    with pytest.raises(ValueError, match=r"cutoff must be at least 1e-08 of the sampling rate fs = 1e\+300 Hz"):
        sg.analyze(t * 1e-295, x)
    path = write_csv(tmp_path / "ns.csv", t * 1e-295, x)
    with pytest.raises(ValueError, match=r"cutoff must be at least 1e-08"):
        sg.analyze_csv(path)
    with pytest.raises(ValueError, match=r"detrend_cutoff must be at least 1e-08"):
        sg.analyze(t, x, detrend_cutoff=1e-4)


def test_huge_finite_values_are_not_called_infinite(tmp_path):
    t, x = record()
    with pytest.raises(ValueError, match=r"x must stay within \+-1e\+100.*got 1e\+155 at index 3"):
        sg.analyze(t, np.where(np.arange(t.size) == 3, 1e155, x))
    path = write_csv(tmp_path / "big.csv", t, x * 1e161)
    with pytest.raises(ValueError, match=r"x must stay within \+-1e\+100") as err:
        sg.analyze_csv(path)
    assert "inf" not in str(err.value)
