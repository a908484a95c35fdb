"""Signal analysis of lateral tape motion (the paper's Fig. 3 pipeline) on signals with known answers.

Synthetic records first (sums of sines, a decaying burst: spectra and rms known in closed
form), then input checks, CSV input, and a simulated tape-drive run whose impacts are known.
"""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pytest

import impactosc as io
from impactosc import signal as sg

matplotlib.use("Agg")


def grid(fs: float, duration: float) -> np.ndarray:
    return np.arange(round(fs * duration)) / fs


# -- spectra: a known peak within one bin --------------------------------------------------
@pytest.mark.parametrize("f0", [1234.5, 1500.0, 1777.7])
def test_spectrum_peak_of_a_sum_of_sines_within_one_bin(f0):
    fs = 50e3
    t = grid(fs, 1.0)
    rng = np.random.default_rng(1)
    # A strong low-frequency run-out, the line at f0 and a weaker one above, and noise.
    x = (40e-6 * np.sin(2 * np.pi * 30 * t) + 1e-6 * np.sin(2 * np.pi * f0 * t)
         + 0.3e-6 * np.sin(2 * np.pi * 4321.0 * t) + 0.05e-6 * rng.standard_normal(t.size))
    hp = sg.highpass(t, x)
    f, psd = sg.spectrum(t, hp)
    df = f[1] - f[0]
    assert df == pytest.approx(sg.RESOLUTION_HZ, rel=0.01, abs=0)
    assert abs(f[np.argmax(psd)] - f0) <= df
    # The second line is found once the first is masked out.
    masked = np.where(np.abs(f - f0) > 3 * df, psd, 0.0)
    assert abs(f[np.argmax(masked)] - 4321.0) <= df
    # The spectrogram sees the same peak in every segment.
    spec = sg.spectrogram(t, hp)
    assert np.all(np.abs(spec.peak_frequency() - f0) <= spec.f[1] - spec.f[0])
    assert spec.t[0] > t[0] and spec.t[-1] < t[-1]


def test_spectrogram_localises_a_tone_in_time():
    fs = 40e3
    t = grid(fs, 0.4)
    x = np.where((t >= 0.1) & (t < 0.2), np.sin(2 * np.pi * 1500 * t), np.sin(2 * np.pi * 6000 * t))
    spec = sg.spectrogram(t, x, resolution=100.0)
    inside = (spec.t > 0.12) & (spec.t < 0.18)
    outside = (spec.t < 0.08) | (spec.t > 0.22)
    df = spec.f[1] - spec.f[0]
    assert np.all(np.abs(spec.peak_frequency()[inside] - 1500) <= df)
    assert np.all(np.abs(spec.peak_frequency()[outside] - 6000) <= df)


# -- rms: known values to 1e-6 -------------------------------------------------------------
def test_rms_envelope_of_a_sine_over_whole_periods():
    fs, f0, amp = 100e3, 2e3, 3e-6
    t = grid(fs, 0.05)
    env = sg.rms_envelope(t, amp * np.sin(2 * np.pi * f0 * t + 0.3), window=1e-3)  # 2 periods
    interior = env[100:-100]
    np.testing.assert_allclose(interior, amp / math.sqrt(2), rtol=1e-6)
    # At the ends the window is cut by the record: still a mean of squares, never above the peak.
    assert np.all(env <= amp)


def test_highpass_keeps_the_high_line_and_removes_the_run_out():
    fs = 100e3
    t = grid(fs, 0.5)
    amp = 1e-6
    x = 40e-6 * np.sin(2 * np.pi * 50 * t) + amp * np.sin(2 * np.pi * 10e3 * t)
    hp = sg.highpass(t, x, cutoff=1e3)
    # Butterworth order 4 forward and back: power gain 1/(1 + (fc/f)^8)^2 -> 1 - 2e-8 at 10 kHz,
    # and (50/1000)^16 ~ 2e-21 on the run-out.
    env = sg.rms_envelope(t, hp, window=1e-3)
    np.testing.assert_allclose(env[5000:-5000], amp / math.sqrt(2), rtol=1e-6)
    np.testing.assert_allclose(hp[5000:-5000], amp * np.sin(2 * np.pi * 10e3 * t[5000:-5000]), atol=1e-6 * amp)


def test_highpass_has_no_edge_transient_on_a_ramp():
    # The run-out near the ends of a record is a ramp (here 0.04 m/s: 120 um at 54 Hz, the
    # tight guide of alternative A at 12 m/s). A 4th-order high-pass removes a ramp exactly
    # in steady state, but scipy's default padding of a few samples starts it in a transient
    # of ~ slope/(2 pi fc) ~ 0.6 um at the ends, the size of a burst. The long odd-reflection
    # padding continues the ramp and leaves nothing.
    fs = 100e3
    t = grid(fs, 0.02)
    hp = sg.highpass(t, 0.04 * t)
    assert np.max(np.abs(hp)) < 0.005e-6  # scipy default padding: 0.64e-6


def test_highpass_gain_at_the_cutoff_is_one_half():
    # sosfiltfilt applies the filter twice: |H(fc)|^2 = 1/2 for Butterworth, so the gain is 1/2.
    fs, fc = 50e3, 1e3
    t = grid(fs, 1.0)
    hp = sg.highpass(t, np.sin(2 * np.pi * fc * t), cutoff=fc)
    mid = slice(t.size // 4, 3 * t.size // 4)
    assert np.sqrt(2 * np.mean(hp[mid] ** 2)) == pytest.approx(0.5, rel=1e-3, abs=0)


def test_band_power_of_a_bin_centred_sine():
    fs, amp = 64e3, 2e-6
    t = grid(fs, 1.0)
    # 100 Hz resolution: 640-sample segments, bins at multiples of 100 Hz; the line at 1.5 kHz
    # with the Hann window's three bins well inside 1-2 kHz.
    x = amp * np.sin(2 * np.pi * 1500 * t) + 5e-6 * np.sin(2 * np.pi * 5000 * t)
    p = sg.band_power(t, x, band=(1e3, 2e3), resolution=100.0)
    assert math.sqrt(p) == pytest.approx(amp / math.sqrt(2), rel=1e-6, abs=0)
    # Everything in a band holding both lines.
    p_all = sg.band_power(t, x, band=(1e3, 6e3), resolution=100.0)
    assert p_all == pytest.approx(amp**2 / 2 + 25e-12 / 2, rel=1e-6, abs=0)


# -- a decaying burst: the pipeline finds it, where and at which frequency ------------------
@pytest.fixture(scope="module")
def burst_record():
    fs, t_b, f_b, tau, amp = 50e3, 0.3, 1500.0, 5e-3, 2e-6
    t = grid(fs, 0.6)
    s = np.clip(t - t_b, 0.0, None)
    burst = np.where(t >= t_b, amp * np.exp(-s / tau) * np.sin(2 * np.pi * f_b * s), 0.0)
    rng = np.random.default_rng(7)
    x = 30e-6 * np.sin(2 * np.pi * 25 * t) + burst + 1e-9 * rng.standard_normal(t.size)
    return t, x, dict(t_b=t_b, f_b=f_b, tau=tau, amp=amp)


def test_decaying_burst_is_found_at_its_time_and_frequency(burst_record):
    t, x, p = burst_record
    res = sg.analyze(t, x, impact_times=[p["t_b"]])
    assert len(res.bursts) == 1
    b = res.bursts.iloc[0]
    assert b["start [s]"] <= p["t_b"] + 1e-3 and b["end [s]"] >= p["t_b"] + p["tau"]
    assert abs(b["peak_time [s]"] - p["t_b"]) < res.window
    assert res.correlation.bursts_at_impacts == 1.0 and res.correlation.impacts_with_burst == 1.0
    # The envelope follows the impact indicator (+-1 ms): clearly positive, though the burst
    # rings for several tau, longer than the indicator; impacts at the wrong time: none.
    assert res.correlation.envelope_correlation > 0.3
    wrong = sg.correlate_with_impacts(res.bursts, [0.1], t=t, envelope=res.envelope)
    assert wrong.envelope_correlation < 0 and wrong.bursts_at_impacts == 0.0
    # Energy of the burst: int (A e^{-s/tau} sin)^2 ds = A^2 tau / 4 (to (2 pi f tau)^-2 ~ 5e-4),
    # spread over a Lorentzian line of half width 1/(2 pi tau) = 32 Hz, of which the fraction
    # (2/pi) arctan(2 pi tau 500 Hz) = 0.96 lies within the band's +-500 Hz. The band's edges
    # are as sharp as its 250 Hz bins, hence 2 %.
    energy = p["amp"] ** 2 * p["tau"] / 4 / (t[-1] - t[0] + 1 / res.fs)
    in_band = 2 / np.pi * np.arctan(2 * np.pi * p["tau"] * 500.0)
    assert res.band_power == pytest.approx(energy * in_band, rel=0.02, abs=0)
    assert res.band_power < energy
    seg = np.argmin(np.abs(res.spectrogram.t - (p["t_b"] + 2e-3)))
    assert abs(res.spectrogram.peak_frequency()[seg] - p["f_b"]) <= res.spectrogram.f[1] - res.spectrogram.f[0]


def test_analysis_figure_has_the_four_panels_of_fig_3(burst_record):
    t, x, p = burst_record
    res = sg.analyze(t, x, impact_times=[p["t_b"]])
    fig = res.plot()
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    assert [s[:3] for s in titles if s] == ["(a)", "(b)", "(c)", "(d)"]
    assert len(fig.axes) == 5  # four panels and the spectrogram's colour bar
    ax_b = fig.axes[1]
    assert len(ax_b.patches) == 1  # the one burst, shaded
    assert all(len(ax.collections) >= 1 for ax in fig.axes[:4])  # impact lines (and the spectrogram mesh)
    matplotlib.pyplot.close(fig)
    assert "1 bursts" in res.summary() and "100% of impacts" in res.summary()


# -- bursts and impacts -------------------------------------------------------------------------
def test_burst_times_and_merging():
    t = np.arange(1000) * 1e-4
    env = np.zeros_like(t)
    env[100:120] = 1.0
    env[125:130] = 0.8  # 0.5 ms after the first: merged with min_gap = 1 ms
    env[500:510] = 0.5
    b = sg.burst_times(t, env, threshold=0.2)
    assert list(b["start [s]"]) == pytest.approx([0.01, 0.05])
    assert list(b["end [s]"]) == pytest.approx([0.0129, 0.0509])
    assert list(b["peak_rms"]) == [1.0, 0.5]
    assert len(sg.burst_times(t, env, threshold=0.2, min_gap=0.0)) == 3
    # Default threshold: median (0) + 0.3 of the range: the 0.5 burst is above, not below 0.6.
    assert len(sg.burst_times(t, env)) == 2 and len(sg.burst_times(t, env, level=0.6)) == 1


def test_correlate_with_impacts_counts_and_lags():
    import pandas as pd

    bursts = pd.DataFrame({"start [s]": [0.10, 0.30, 0.50], "end [s]": [0.11, 0.31, 0.51],
                           "peak_time [s]": [0.105, 0.305, 0.505], "peak_rms": [1.0, 1.0, 1.0]})
    c = sg.correlate_with_impacts(bursts, [0.1045, 0.3118, 0.9], tolerance=0.002)
    assert list(c.bursts["matched"]) == [True, True, False]
    assert c.bursts["lag [s]"].to_numpy() == pytest.approx([0.0005, -0.0068, 0.1932])
    assert list(c.impacts["burst"]) == [0, 1, -1]
    assert c.bursts_at_impacts == pytest.approx(2 / 3) and c.impacts_with_burst == pytest.approx(2 / 3)
    none = sg.correlate_with_impacts(bursts, [], tolerance=0.002)
    assert not none.bursts["matched"].any() and math.isnan(none.impacts_with_burst)


# -- input checks ---------------------------------------------------------------------------------
def test_bad_records_are_refused_with_the_reason():
    t = grid(10e3, 0.1)
    x = np.sin(2 * np.pi * 1500 * t)
    with pytest.raises(ValueError, match=r"x must be finite, got nan at index 7"):
        sg.highpass(t, np.where(np.arange(t.size) == 7, np.nan, x))
    back = t.copy()
    back[50] = back[48]
    with pytest.raises(ValueError, match=r"t must increase strictly: t\[50\] = 0.0048 <= t\[49\] = 0.0049"):
        sg.analyze(back, x)
    jitter = t.copy()
    jitter[30] += 0.3e-4
    with pytest.raises(ValueError, match=r"uniformly sampled: the step t\[30\] - t\[29\] = 0\.00013\d* differs"):
        sg.rms_envelope(jitter, x)
    with pytest.raises(ValueError, match="too short: 5 samples"):
        sg.spectrum(t[:5], x[:5])
    with pytest.raises(ValueError, match=r"cutoff must be below the Nyquist frequency fs/2 = 5000 Hz.*cutoff=6000"):
        sg.highpass(t, x, cutoff=6e3)
    with pytest.raises(ValueError, match=r"band must satisfy.*band=\(3000.0, 6000.0\)"):
        sg.band_power(t, x, band=(3e3, 6e3))
    with pytest.raises(ValueError, match="window must hold"):
        sg.rms_envelope(t, x, window=1.0)
    with pytest.raises(ValueError, match="same length"):
        sg.analyze(t, x[:-1])
    with pytest.raises(ValueError, match="too short for an order-8 zero-phase filter: 20 samples, need more than 27"):
        sg.highpass(t[:20], x[:20], cutoff=1e3, order=8)
    with pytest.raises(TypeError, match="band must be a pair"):
        sg.band_power(t, x, band=1e3)


# -- measured records from CSV --------------------------------------------------------------------
def test_csv_record_in_one_call_and_one_figure(tmp_path, burst_record):
    t, x, p = burst_record
    t, x = t[::2], x[::2]  # 25 kHz is enough here, and half the rows to write and read
    path = tmp_path / "ltm.csv"
    with path.open("w") as fh:
        fh.write("# LTM edge sensor, tape at 4 m/s\ntime_ms;ltm_um\n")
        for ti, xi in zip(t * 1e3, x * 1e6, strict=True):
            fh.write(f"{ti:.9f};{xi:.12g}\n")
    t_read, x_read = sg.read_ltm_csv(path, time_unit="ms", x_unit="um")
    np.testing.assert_allclose(t_read, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(x_read, x, rtol=1e-11, atol=1e-20)
    res = sg.analyze_csv(path, time_column="time_ms", x_column="ltm_um", time_unit="ms", x_unit="um")
    fig = res.plot(path=tmp_path / "fig3.png")
    assert (tmp_path / "fig3.png").stat().st_size > 0 and len(fig.axes) == 5
    matplotlib.pyplot.close(fig)
    assert len(res.bursts) == 1 and res.correlation is None


def test_csv_errors_name_the_problem(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("0.0,1\n0.001,2\n0.002,oops\n")
    with pytest.raises(ValueError, match=r"x_column holds 1 empty, NaN or non-numeric value\(s\), the first 'oops'"):
        sg.read_ltm_csv(bad)
    with pytest.raises(ValueError, match="x_column=3 but"):
        sg.read_ltm_csv(bad, x_column=3)
    with pytest.raises(ValueError, match="'depth' is not a column"):
        sg.read_ltm_csv(bad, x_column="depth")
    with pytest.raises(ValueError, match="x_unit must be one of"):
        sg.read_ltm_csv(bad, x_unit="inch")
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(ValueError, match="empty.csv: cannot be read as a table"):
        sg.read_ltm_csv(empty)
    spaces = tmp_path / "spaces.txt"
    spaces.write_text("".join(f"{k * 1e-4:.4f} {math.sin(k):.6f}\n" for k in range(100)))
    t, x = sg.read_ltm_csv(spaces, x_unit="um")
    assert t.size == 100 and x[3] == pytest.approx(math.sin(3) * 1e-6, rel=1e-5, abs=0)
    backwards = tmp_path / "backwards.csv"
    backwards.write_text("\n".join(f"{ti},{0.0}" for ti in [0.0, 0.1, 0.05] + [0.1 + 0.05 * k for k in range(20)]))
    with pytest.raises(ValueError, match="t must increase strictly"):
        sg.read_ltm_csv(backwards)


# -- a simulated tape-drive run: bursts at the simulated impacts ----------------------------------
#: Alternative B of impactosc.paper (plate bending, air-lubricated roller, L = 100 um) at
#: 12 m/s and T = 0.5 N: f_n = 65 Hz, ~100 flange impacts per second, cheap to simulate.
DRIVE_B = io.TapeDrive(speed=12.0, tension=0.5, bending="out-of-plane", friction=1e-5, clearance=100e-6)


@pytest.fixture(scope="module")
def drive_run():
    return io.simulate(DRIVE_B.oscillator(), DRIVE_B.seconds_to_lambda(0.1), record="full")


def test_from_solution_is_the_run_in_si_units(drive_run):
    t, x = sg.from_solution(drive_run, DRIVE_B, 1e-5)
    assert t.size == 10001 and t[-1] == pytest.approx(0.1, rel=1e-12, abs=0)
    X, _ = drive_run.sample(DRIVE_B.seconds_to_lambda(t[[0, 1234, -1]]))
    np.testing.assert_allclose(x[[0, 1234, -1]], X * 100e-6, rtol=1e-12)
    times = sg.contact_times(drive_run, DRIVE_B)
    im = drive_run.impacts
    assert times.size == 2 * len(im)
    np.testing.assert_allclose(times[::2], im.start / DRIVE_B.omega_n, rtol=1e-12)


def test_simulated_impacts_come_with_ltm_bursts(drive_run):
    res = sg.analyze_solution(drive_run, DRIVE_B, 1e-5)
    n_impacts = len(drive_run.impacts)
    assert n_impacts >= 8
    assert len(res.bursts) == n_impacts
    assert res.correlation.bursts_at_impacts == 1.0 and res.correlation.impacts_with_burst == 1.0
    assert np.all(np.abs(res.correlation.bursts["lag [s]"]) < 1e-4)
    assert res.band_rms > 0.1e-6  # impacts put sub-micrometre LTM into 1-2 kHz
    quiet = sg.analyze(*sg.from_solution(drive_run, DRIVE_B, 1e-5, t1=0.008))  # before the first impact
    assert quiet.band_rms < 1e-2 * res.band_rms


def test_from_solution_needs_the_drive(drive_run):
    with pytest.raises(TypeError, match="TapeDrive"):
        sg.from_solution(drive_run, None, 1e-5)
    with pytest.raises(ValueError, match="drive does not match the run"):
        sg.from_solution(drive_run, DRIVE_B.replace(tension=1.0), 1e-5)
