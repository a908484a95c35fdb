"""Signal analysis of lateral tape motion (LTM): the paper's Fig. 3 pipeline.

Section 4 of the paper ("Detection of Tape/Flange Contact") measures LTM with an edge
sensor and shows, in its Fig. 3, (a) the LTM signal, (b) the LTM high-pass filtered at
1 kHz, (c) the rms impact force and (d) a time-frequency analysis of the LTM. It reads
them as: high-frequency LTM *bursts* occur at the same time as tape/flange impacts, and
their content lies "predominantly in the 1-2 kHz range" -- above the ~1 kHz bandwidth
of the head's servo actuator, which is why 1 kHz is the cutoff.

This module does the same on any uniformly sampled ``(t, x)`` record in SI units
(seconds, metres), measured or simulated:

* :func:`highpass`: zero-phase Butterworth high-pass (``scipy.signal.sosfiltfilt``),
  default cutoff 1 kHz (Fig. 3(b));
* :func:`rms_envelope`: moving rms over a centred window (the rms of Fig. 3(c), here of
  the LTM itself: a simulation has no acoustic emission sensor);
* :func:`spectrogram` (Fig. 3(d)), :func:`spectrum` (Welch) and :func:`band_power`,
  default band 1-2 kHz;
* :func:`burst_times` and :func:`correlate_with_impacts`: bursts of the envelope and how
  they line up with impact times (Fig. 3(b)-(c), "the three vertical dashed lines");
* :func:`analyze` runs all of it in one call and returns an :class:`LTMAnalysis` whose
  :meth:`~LTMAnalysis.plot` draws the four panels of Fig. 3 in one figure;
  :func:`read_ltm_csv`/:func:`analyze_csv` for measured data, :func:`from_solution`/
  :func:`analyze_solution` for a simulated tape-drive run.
"""

from __future__ import annotations

import csv
import itertools
import math
import re
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import signal as _ss

from . import _validation as _v

__all__ = ["highpass", "rms_envelope", "spectrum", "spectrogram", "Spectrogram", "band_power", "burst_times",
           "correlate_with_impacts", "ImpactCorrelation", "analyze", "LTMAnalysis", "read_ltm_csv",
           "analyze_csv", "from_solution", "contact_times", "analyze_solution", "check_signal"]

#: Defaults from the paper's Fig. 3: high-pass at 1 kHz (the servo bandwidth), band 1-2 kHz.
CUTOFF_HZ = 1e3
BAND_HZ = (1e3, 2e3)
#: rms window: one period of the cutoff frequency, so every kept component completes a cycle.
WINDOW_S = 1e-3
#: Frequency resolution of the spectra: four bins across the default 1-2 kHz band.
RESOLUTION_HZ = 250.0
#: Relative deviation of a time step from the mean step above which sampling is "non-uniform".
UNIFORM_RTOL = 1e-3
MIN_SAMPLES = 16


# -- input checks ---------------------------------------------------------------------------
def check_signal(t, x) -> tuple[np.ndarray, np.ndarray, float]:
    """Validate a record and return ``(t, x, fs)`` as float arrays and the sampling rate in Hz.

    Raises
    ------
    ValueError
        Unless ``t`` and ``x`` are 1-D of the same length (at least ``MIN_SAMPLES``),
        finite, and ``t`` increases strictly with uniform steps (to ``UNIFORM_RTOL``); the
        message names the array, the index and the value.
    """
    arrays = []
    for name, a in (("t", t), ("x", x)):
        try:
            arr = np.asarray(a, dtype=float)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must be an array of real numbers: {exc}") from None
        if arr.ndim != 1:
            raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"{name} must be finite, got {float(arr[bad[0]])!r} at index {bad[0]} "
                             f"({bad.size} non-finite values in all)")
        arrays.append(arr)
    t, x = arrays
    if t.size != x.size:
        raise ValueError(f"t and x must have the same length, got {t.size} and {x.size}")
    if t.size < MIN_SAMPLES:
        raise ValueError(f"the signal is too short: {t.size} samples, need at least {MIN_SAMPLES}")
    steps = np.diff(t)
    back = np.flatnonzero(steps <= 0)
    if back.size:
        i = back[0]
        raise ValueError(f"t must increase strictly: t[{i + 1}] = {float(t[i + 1])!r} <= t[{i}] = {float(t[i])!r}")
    dt = float(t[-1] - t[0]) / (t.size - 1)
    dev = np.abs(steps - dt)
    worst = int(np.argmax(dev))
    if dev[worst] > UNIFORM_RTOL * dt:
        raise ValueError(f"t must be uniformly sampled: the step t[{worst + 1}] - t[{worst}] = {float(steps[worst])!r} "
                         f"differs from the mean step {dt!r} by more than {UNIFORM_RTOL:g} of it; "
                         f"interpolate onto a uniform grid first (e.g. numpy.interp)")
    return t, x, 1.0 / dt


def _check_frequency(name: str, value, fs: float) -> float:
    f = _v.positive(name, value)
    if not f < fs / 2:
        raise ValueError(f"{name} must be below the Nyquist frequency fs/2 = {fs / 2:g} Hz of the signal "
                         f"(sampling rate {fs:g} Hz), got {name}={f!r}")
    return f


def _check_band(band, fs: float) -> tuple[float, float]:
    try:
        lo, hi = band
    except (TypeError, ValueError):
        raise TypeError(f"band must be a pair (low, high) in Hz, got {band!r}") from None
    lo, hi = _v.nonnegative("band[0]", lo), _v.positive("band[1]", hi)
    if not lo < hi <= fs / 2:
        raise ValueError(f"band must satisfy 0 <= low < high <= fs/2 = {fs / 2:g} Hz, got band={band!r}")
    return lo, hi


def _nperseg(resolution, fs: float, n: int) -> int:
    res = _v.positive("resolution", resolution)
    return int(min(n, max(MIN_SAMPLES, round(fs / res))))


# -- filtering and envelopes ----------------------------------------------------------------
def highpass(t, x, cutoff: float = CUTOFF_HZ, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth high-pass filter of ``x`` (the paper's Fig. 3(b)).

    Parameters
    ----------
    t, x : array_like
        Uniformly sampled time (s) and signal.
    cutoff : float
        Cutoff frequency in Hz (default 1 kHz, the paper's: the servo actuator tracks LTM
        below about 1 kHz). Must be below the Nyquist frequency.
    order : int
        Order of the Butterworth design. The filter runs forward and backward
        (``scipy.signal.sosfiltfilt``): no phase shift, so bursts stay where they happen,
        twice the order in roll-off, and a gain of 1/2 (-6 dB) at the cutoff. The ends are
        padded by an odd reflection of three cutoff periods, which continues a ramp (the
        run-out near an end) without a step; what remains of the edge transient decays
        within a few cutoff periods.
    """
    t, x, fs = check_signal(t, x)
    cutoff = _check_frequency("cutoff", cutoff, fs)
    order = _v.integer("order", order)
    sos = _ss.butter(order, cutoff, btype="highpass", fs=fs, output="sos")
    # sosfiltfilt's default edge padding, a few samples; the record must be longer than that.
    minimum = 3 * (2 * len(sos) + 1 - min((sos[:, 2] == 0).sum(), (sos[:, 5] == 0).sum()))
    if x.size <= minimum:
        raise ValueError(f"the signal is too short for an order-{order} zero-phase filter: {x.size} samples, "
                         f"need more than {minimum}")
    # Pad by an odd reflection of three cutoff periods: with the default few samples the
    # filter's start-up transient at each end is as large as the bursts being looked for.
    padlen = min(x.size - 1, max(minimum, round(3 * fs / cutoff)))
    return _ss.sosfiltfilt(sos, x, padlen=padlen)


def rms_envelope(t, x, window: float = WINDOW_S) -> np.ndarray:
    """Moving root mean square of ``x`` over a centred window of ``window`` seconds.

    ``sqrt(mean(x^2))`` over the ``round(window fs)`` samples around each sample (fewer at
    the ends, where the window is cut by the record). The default 1 ms is one period of
    the 1 kHz cutoff. Apply it to the high-passed LTM for the envelope of its bursts.
    """
    t, x, fs = check_signal(t, x)
    window = _v.positive("window", window)
    n = round(window * fs)
    if not 1 <= n <= x.size:
        raise ValueError(f"window must hold between 1 sample and the whole record ({x.size / fs:g} s), "
                         f"got window={window!r} s = {window * fs:g} samples at {fs:g} Hz")
    csum = np.concatenate(([0.0], np.cumsum(x * x)))
    start = np.arange(x.size) - n // 2
    lo, hi = np.clip(start, 0, x.size), np.clip(start + n, 0, x.size)
    return np.sqrt(np.maximum(csum[hi] - csum[lo], 0.0) / (hi - lo))


# -- spectra --------------------------------------------------------------------------------
def spectrum(t, x, resolution: float = RESOLUTION_HZ) -> tuple[np.ndarray, np.ndarray]:
    """Power spectral density of ``x`` by Welch's method (Hann window, 3/4 overlap).

    Returns ``(frequencies in Hz, PSD in units of x^2/Hz)``. ``resolution`` (Hz) sets the
    segment length ``fs/resolution`` (at most the record), so the bin width is about
    ``resolution``; a sine shows as a peak within one bin of its frequency. With a hop of
    a quarter segment the squared Hann windows add up to a constant, so every sample
    away from the ends weighs the same in the average and the power of a short burst
    does not depend on where it falls between segments.
    """
    t, x, fs = check_signal(t, x)
    nper = _nperseg(resolution, fs, x.size)
    return _ss.welch(x, fs=fs, window="hann", nperseg=nper, noverlap=3 * nper // 4)


@dataclass(frozen=True)
class Spectrogram:
    """A time-frequency analysis (the paper's Fig. 3(d)).

    Attributes
    ----------
    t : ndarray
        Centres of the segments in s (on the time axis of the input).
    f : ndarray
        Frequencies in Hz.
    psd : ndarray
        Power spectral density, shape ``(f.size, t.size)``, in units of x^2/Hz.
    """

    t: np.ndarray
    f: np.ndarray
    psd: np.ndarray

    def band_power(self, band=BAND_HZ) -> np.ndarray:
        """Mean square of the signal in ``band`` (Hz) in each segment: the PSD summed over the band's bins."""
        lo, hi = band
        sel = (self.f >= lo) & (self.f <= hi)
        if not sel.any():
            raise ValueError(f"band {band!r} holds no frequency bin (bin width {self.f[1] - self.f[0]:g} Hz)")
        return self.psd[sel].sum(axis=0) * (self.f[1] - self.f[0])

    def peak_frequency(self) -> np.ndarray:
        """Frequency of the largest PSD bin in each segment (Hz)."""
        return self.f[np.argmax(self.psd, axis=0)]


def spectrogram(t, x, resolution: float = RESOLUTION_HZ, overlap: float = 0.75) -> Spectrogram:
    """Spectrogram of ``x``: Hann-windowed segments of ``fs/resolution`` samples (Fig. 3(d)).

    ``resolution`` (Hz, default 250: four bins across 1-2 kHz) trades frequency against
    time resolution (segments of ``1/resolution`` s); ``overlap`` is the fraction of a
    segment shared by neighbours, in [0, 1).
    """
    t, x, fs = check_signal(t, x)
    nper = _nperseg(resolution, fs, x.size)
    overlap = _v.nonnegative("overlap", overlap)
    if not overlap < 1:
        raise ValueError(f"overlap must be in [0, 1), got {overlap!r}")
    f, ts, psd = _ss.spectrogram(x, fs=fs, window="hann", nperseg=nper, noverlap=min(nper - 1, int(overlap * nper)))
    return Spectrogram(t[0] + ts, f, psd)


def band_power(t, x, band=BAND_HZ, resolution: float = RESOLUTION_HZ) -> float:
    """Mean square of ``x`` in a frequency band (default 1-2 kHz, the paper's Fig. 3(d)).

    The Welch PSD (:func:`spectrum`) summed over the bins in ``band`` times the bin width,
    in units of x^2 (m^2 for LTM in m); its square root is the rms of the band. For a sine
    of amplitude ``A`` inside the band and away from its edges it is ``A^2/2``. The band is
    as sharp as the resolution: a Hann bin collects power from two bins either side, so
    keep ``resolution`` well below the band's width, and high-pass a record with a strong
    low-frequency part first (as :func:`analyze` does) or it leaks into the band.
    """
    t, x, fs = check_signal(t, x)
    lo, hi = _check_band(band, fs)
    f, psd = spectrum(t, x, resolution)
    sel = (f >= lo) & (f <= hi)
    if not sel.any():
        raise ValueError(f"band={band!r} holds no frequency bin (bin width {f[1] - f[0]:g} Hz): "
                         f"widen it or lower resolution")
    return float(psd[sel].sum() * (f[1] - f[0]))


# -- bursts and impacts ---------------------------------------------------------------------
def burst_times(t, envelope, threshold: float | None = None, level: float = 0.3,
                min_gap: float = WINDOW_S) -> pd.DataFrame:
    """Intervals where an rms envelope exceeds a threshold: the LTM bursts of Fig. 3(b).

    Parameters
    ----------
    t, envelope : array_like
        Time (s) and envelope (e.g. :func:`rms_envelope` of the high-passed LTM).
    threshold : float, optional
        Absolute threshold. Default: ``median + level * (max - median)`` of the envelope,
        scale-free, with the median standing for the background between bursts.
    level : float
        Fraction in (0, 1) for the default threshold.
    min_gap : float
        Bursts separated by less than this (s) are merged; default one rms window.

    Returns
    -------
    pandas.DataFrame
        One row per burst: ``start [s]``, ``end [s]``, ``peak_time [s]``, ``peak_rms``
        (the envelope's maximum in the burst); ``attrs["threshold"]`` holds the threshold.
    """
    t, env, _ = check_signal(t, envelope)
    if threshold is None:
        level = _v.positive("level", level)
        if not level < 1:
            raise ValueError(f"level must be in (0, 1), got {level!r}")
        median = float(np.median(env))
        threshold = median + level * (float(env.max()) - median)
    else:
        threshold = _v.real("threshold", threshold)
    min_gap = _v.nonnegative("min_gap", min_gap)
    edges = np.diff(np.concatenate(([0], (env > threshold).astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    if starts.size > 1:
        keep = np.concatenate(([True], t[starts[1:]] - t[ends[:-1]] >= min_gap))
        starts, ends = starts[keep], ends[np.concatenate((keep[1:], [True]))]
    peaks = np.array([s + int(np.argmax(env[s:e + 1])) for s, e in zip(starts, ends, strict=True)], dtype=int)
    df = pd.DataFrame({"start [s]": t[starts], "end [s]": t[ends], "peak_time [s]": t[peaks],
                       "peak_rms": env[peaks]})
    df.attrs["threshold"] = threshold
    return df


@dataclass(frozen=True)
class ImpactCorrelation:
    """How LTM bursts line up with impacts (see :func:`correlate_with_impacts`).

    Attributes
    ----------
    bursts : pandas.DataFrame
        The bursts with ``nearest_impact [s]``, ``lag [s]`` (burst peak minus that impact
        time) and ``matched`` (an impact lies in the burst widened by ``tolerance``).
    impacts : pandas.DataFrame
        ``t [s]`` and ``burst`` (index of the burst it falls in, or -1).
    tolerance : float
        Widening of each burst, in s.
    bursts_at_impacts, impacts_with_burst : float
        Fraction of bursts that hold an impact, and of impacts that fall in a burst (NaN
        when there are no bursts, resp. no impacts).
    envelope_correlation : float or None
        Pearson correlation of the envelope with the indicator "within ``tolerance`` of an
        impact" (point-biserial); None if no envelope was given or it is undefined.
    """

    bursts: pd.DataFrame
    impacts: pd.DataFrame
    tolerance: float
    bursts_at_impacts: float
    impacts_with_burst: float
    envelope_correlation: float | None

    def summary(self) -> str:
        corr = "n/a" if self.envelope_correlation is None else f"{self.envelope_correlation:.3f}"
        return (f"{len(self.bursts)} bursts, {len(self.impacts)} impacts: {self.bursts_at_impacts:.0%} of bursts "
                f"at an impact, {self.impacts_with_burst:.0%} of impacts in a burst (tolerance "
                f"{self.tolerance * 1e3:.3g} ms); envelope/impact correlation {corr}")


def correlate_with_impacts(bursts: pd.DataFrame, impact_times, tolerance: float = WINDOW_S, *,
                           t=None, envelope=None) -> ImpactCorrelation:
    """Match LTM bursts with impact times (the dashed lines of the paper's Fig. 3).

    Parameters
    ----------
    bursts : pandas.DataFrame
        From :func:`burst_times` (columns ``start [s]``, ``end [s]``, ``peak_time [s]``).
    impact_times : array_like
        Times of impacts in s: measured (e.g. acoustic emission peaks) or simulated
        (:func:`contact_times`).
    tolerance : float
        A burst holds an impact if the impact lies within ``[start - tolerance,
        end + tolerance]`` (s). Default one rms window.
    t, envelope : array_like, optional
        The envelope the bursts came from, for ``envelope_correlation``.
    """
    tolerance = _v.nonnegative("tolerance", tolerance)
    imp = np.sort(np.asarray(impact_times, dtype=float).ravel())
    if not np.all(np.isfinite(imp)):
        raise ValueError("impact_times must be finite")
    lo = bursts["start [s]"].to_numpy() - tolerance
    hi = bursts["end [s]"].to_numpy() + tolerance
    peak = bursts["peak_time [s]"].to_numpy()
    # First impact at or after each widened start; the burst holds it if it is before the end.
    first = np.searchsorted(imp, lo, side="left")
    matched = (first < imp.size) & (imp[np.minimum(first, max(imp.size - 1, 0))] <= hi) if imp.size else \
        np.zeros(len(bursts), dtype=bool)
    nearest = np.full(len(bursts), np.nan)
    if imp.size:
        j = np.clip(np.searchsorted(imp, peak), 1, imp.size) - 1
        k = np.minimum(j + 1, imp.size - 1)
        nearest = np.where(np.abs(imp[k] - peak) < np.abs(imp[j] - peak), imp[k], imp[j])
    out = bursts.copy()
    out["nearest_impact [s]"] = nearest
    out["lag [s]"] = peak - nearest
    out["matched"] = matched
    # Bursts do not overlap and are sorted, so the last widened start at or before an impact decides.
    b = np.searchsorted(lo, imp, side="right") - 1
    inside = (b >= 0) & (imp <= hi[np.maximum(b, 0)]) if len(bursts) else np.zeros(imp.size, dtype=bool)
    impacts = pd.DataFrame({"t [s]": imp, "burst": np.where(inside, b, -1)})
    corr = None
    if t is not None and envelope is not None and imp.size:
        tt, env, _ = check_signal(t, envelope)
        j = np.clip(np.searchsorted(imp, tt), 1, imp.size) - 1
        dist = np.minimum(np.abs(tt - imp[j]), np.abs(tt - imp[np.minimum(j + 1, imp.size - 1)]))
        near = (dist <= tolerance).astype(float)
        if 0 < near.sum() < near.size and env.std() > 0:
            corr = float(np.corrcoef(env, near)[0, 1])
    return ImpactCorrelation(out, impacts, tolerance,
                             float(matched.mean()) if len(bursts) else math.nan,
                             float(inside.mean()) if imp.size else math.nan, corr)


# -- the pipeline ---------------------------------------------------------------------------
@dataclass(frozen=True)
class LTMAnalysis:
    """The paper's Fig. 3 pipeline applied to one LTM record (see :func:`analyze`).

    Attributes
    ----------
    t, x : ndarray
        The record: time (s) and LTM (m).
    fs : float
        Sampling rate (Hz).
    cutoff, window, band, detrend_cutoff
        The parameters used: high-pass cutoff (Hz), rms window (s), band (Hz), and the
        cutoff (Hz) of the high-pass applied before the spectra (0: none).
    highpassed : ndarray
        The LTM high-pass filtered at ``cutoff`` (Fig. 3(b)).
    envelope : ndarray
        Moving rms of ``highpassed`` over ``window`` (the envelope of its bursts).
    spectrogram : Spectrogram
        Time-frequency analysis of the LTM (Fig. 3(d)), after the ``detrend_cutoff`` high-pass.
    band_power : float
        Mean square of the LTM in ``band`` (m^2), from Welch's PSD (same detrending);
        ``band_rms`` is its root.
    bursts : pandas.DataFrame
        Bursts of the envelope (:func:`burst_times`); threshold in ``bursts.attrs``.
    impact_times : ndarray or None
        Impact times (s) given to :func:`analyze`.
    correlation : ImpactCorrelation or None
        Bursts against impacts, when impact times were given.
    """

    t: np.ndarray
    x: np.ndarray
    fs: float
    cutoff: float
    window: float
    band: tuple[float, float]
    detrend_cutoff: float
    highpassed: np.ndarray
    envelope: np.ndarray
    spectrogram: Spectrogram
    band_power: float
    bursts: pd.DataFrame
    impact_times: np.ndarray | None
    correlation: ImpactCorrelation | None

    @property
    def band_rms(self) -> float:
        """Root mean square of the LTM in ``band``, in m."""
        return math.sqrt(self.band_power)

    def summary(self) -> str:
        """A few lines: record, rms of the high-passed LTM, band rms, bursts, correlation."""
        lines = [f"LTM record: {self.t.size} samples at {self.fs:g} Hz over {(self.t[-1] - self.t[0]) * 1e3:.4g} ms",
                 f"high-pass {self.cutoff:g} Hz: rms {np.sqrt(np.mean(self.highpassed ** 2)) * 1e6:.4g} um; "
                 f"band {self.band[0]:g}-{self.band[1]:g} Hz: rms {self.band_rms * 1e6:.4g} um",
                 f"{len(self.bursts)} bursts above {self.bursts.attrs['threshold'] * 1e6:.4g} um rms "
                 f"(window {self.window * 1e3:g} ms)"]
        if self.correlation is not None:
            lines.append(self.correlation.summary())
        return "\n".join(lines)

    def plot(self, path=None, fmax: float | None = None):
        """One figure with the four panels of the paper's Fig. 3, impacts as dashed lines.

        (a) the LTM, (b) the high-passed LTM with the bursts shaded, (c) its rms envelope
        with the burst threshold, and the rms in ``band`` from the spectrogram, (d) the
        spectrogram up to ``fmax`` (default ``min(fs/2, 5 * band[1])``) with the band
        marked. Returns the :class:`matplotlib.figure.Figure`; saved to ``path`` if given.
        """
        from .plotting import require_matplotlib

        plt = require_matplotlib()
        fmax = min(self.fs / 2, 5 * self.band[1]) if fmax is None else _v.positive("fmax", fmax)
        fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True, constrained_layout=True)
        self._draw_signals(axes[:3])
        self._draw_spectrogram(fig, axes[3], fmax)
        if self.impact_times is not None and self.impact_times.size:
            for ax in axes:
                lo, hi = ax.get_ylim()
                ax.vlines(self.impact_times * 1e3, lo, hi, colors="tab:red", linestyles="--", lw=0.6, alpha=0.6)
                ax.set_ylim(lo, hi)
            axes[0].plot([], [], color="tab:red", ls="--", lw=0.6, label="impacts")
            axes[0].legend(loc="upper right", fontsize=8)
        fig.suptitle(self.summary() if self.correlation is None else self.correlation.summary(), fontsize=8)
        if path is not None:
            fig.savefig(path, dpi=120)
        return fig

    def _draw_signals(self, axes) -> None:
        """Panels (a)-(c): the LTM, the high-passed LTM with bursts, the rms envelopes (ms, um)."""
        ax_a, ax_b, ax_c = axes
        ms, um = 1e3, 1e6
        ax_a.plot(self.t * ms, self.x * um, lw=0.7, color="k")
        ax_a.set_ylabel("LTM [µm]")
        ax_a.set_title("(a) lateral tape motion", fontsize=9, loc="left")
        ax_b.plot(self.t * ms, self.highpassed * um, lw=0.6, color="k")
        for start, end in zip(self.bursts["start [s]"], self.bursts["end [s]"], strict=True):
            ax_b.axvspan(start * ms, end * ms, color="tab:orange", alpha=0.3, lw=0)
        ax_b.set_ylabel("high-passed [µm]")
        ax_b.set_title(f"(b) LTM high-pass filtered at {self.cutoff:g} Hz, bursts shaded", fontsize=9, loc="left")
        ax_c.plot(self.t * ms, self.envelope * um, lw=0.9, color="tab:blue",
                  label=f"rms, {self.window * ms:g} ms window")
        ax_c.axhline(self.bursts.attrs["threshold"] * um, color="tab:orange", ls=":", lw=1, label="burst threshold")
        sg = self.spectrogram
        ax_c.plot(sg.t * ms, np.sqrt(sg.band_power(self.band)) * um, color="tab:purple", lw=1, drawstyle="steps-mid",
                  label=f"rms in {self.band[0]:g}-{self.band[1]:g} Hz (spectrogram)")
        ax_c.set_ylabel("rms [µm]")
        ax_c.legend(loc="upper right", fontsize=8)
        ax_c.set_title("(c) rms of the high-passed LTM", fontsize=9, loc="left")

    def _draw_spectrogram(self, fig, ax, fmax: float) -> None:
        """Panel (d): the spectrogram in dB, 80 dB deep, with the band's edges."""
        sg = self.spectrogram
        sel = sg.f <= fmax
        level = 10 * np.log10(np.maximum(sg.psd[sel], np.finfo(float).tiny))
        floor = level.max() - 80.0  # an 80 dB range keeps bursts visible above numerical noise
        mesh = ax.pcolormesh(sg.t * 1e3, sg.f[sel] / 1e3, np.maximum(level, floor), shading="nearest", cmap="Greys")
        fig.colorbar(mesh, ax=ax, label="PSD [dB re 1 m²/Hz]")
        for edge in self.band:
            ax.axhline(edge / 1e3, color="tab:purple", lw=0.8, ls="--")
        ax.set_ylabel("frequency [kHz]")
        ax.set_xlabel("time [ms]")
        above = f" (above {self.detrend_cutoff:g} Hz)" if self.detrend_cutoff > 0 else ""
        ax.set_title(f"(d) time-frequency analysis of the LTM{above}", fontsize=9, loc="left")


def analyze(t, x, *, cutoff: float = CUTOFF_HZ, order: int = 4, window: float = WINDOW_S, band=BAND_HZ,
            resolution: float = RESOLUTION_HZ, detrend_cutoff: float | None = None, impact_times=None,
            tolerance: float | None = None, threshold: float | None = None, level: float = 0.3) -> LTMAnalysis:
    """The paper's Fig. 3 pipeline in one call: high-pass, rms envelope, spectrogram, band power, bursts.

    Parameters
    ----------
    t, x : array_like
        Uniformly sampled time (s) and lateral tape motion (m).
    cutoff, order
        High-pass filter (:func:`highpass`); default 1 kHz as in the paper.
    window : float
        rms window in s (:func:`rms_envelope`).
    band : (float, float)
        Frequency band in Hz for :func:`band_power` (default 1-2 kHz as in the paper).
    resolution : float
        Frequency resolution of the spectrogram and the band power (Hz).
    detrend_cutoff : float, optional
        The spectrogram and the band power are taken of the LTM high-passed at this
        frequency (Hz; default ``band[0] / 4``, 250 Hz). It removes the reel run-out (tens
        of um at tens of Hz), which a Hann window of a few ms would otherwise leak into the
        kHz bins, and leaves the band alone (power gain > 0.9999 at ``band[0]``). Pass 0
        for spectra of the raw LTM.
    impact_times : array_like, optional
        Impact times in s to correlate the bursts with (:func:`correlate_with_impacts`).
    tolerance : float, optional
        Matching tolerance in s (default ``window``).
    threshold, level
        Burst detection on the envelope (:func:`burst_times`).

    Returns
    -------
    LTMAnalysis
        Every intermediate result; ``.plot()`` draws one figure, ``.summary()`` prints.
    """
    t, x, fs = check_signal(t, x)
    band = _check_band(band, fs)
    hp = highpass(t, x, cutoff, order)
    env = rms_envelope(t, hp, window)
    bursts = burst_times(t, env, threshold=threshold, level=level, min_gap=window)
    detrend_cutoff = band[0] / 4 if detrend_cutoff is None else _v.nonnegative("detrend_cutoff", detrend_cutoff)
    detrended = highpass(t, x, detrend_cutoff, order) if detrend_cutoff > 0 else x
    imp = corr = None
    if impact_times is not None:
        imp = np.sort(np.asarray(impact_times, dtype=float).ravel())
        tol = window if tolerance is None else tolerance
        corr = correlate_with_impacts(bursts, imp, tol, t=t, envelope=env)
    return LTMAnalysis(t, x, fs, float(cutoff), float(window), band, detrend_cutoff, hp, env,
                       spectrogram(t, detrended, resolution), band_power(t, detrended, band, resolution),
                       bursts, imp, corr)


# -- measured records -------------------------------------------------------------------------
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9}


def _sniff(path, sep: str | None) -> tuple[str, bool]:
    """Delimiter (``sep`` if given) and whether a header line is present, from the first data lines.

    pandas' fast reader cannot guess either; a header is a first line with no number in it.
    """
    with open(path, newline="") as fh:
        lines = [line for line in itertools.islice(fh, 200) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise csv.Error("no data lines")
    if sep is None:
        sep = csv.Sniffer().sniff("".join(lines[:20]), delimiters=",;\t ").delimiter
        sep = r"\s+" if sep == " " else sep
    fields = re.split(sep, lines[0].strip()) if sep == r"\s+" else lines[0].strip().split(sep)
    numeric = pd.to_numeric(pd.Series(fields), errors="coerce").notna()
    return sep, not numeric.any()


def read_ltm_csv(path, *, time_column=0, x_column=1, time_unit: str = "s", x_unit: str = "m",
                 **read_csv_options) -> tuple[np.ndarray, np.ndarray]:
    """Read a measured LTM record ``(t, x)`` from a CSV file; returns SI arrays (s, m), checked.

    Parameters
    ----------
    path : str or path-like
        The file. The delimiter is detected from the first lines (comma, semicolon, tab,
        spaces); a header line is detected (a first row that is not numeric); lines
        starting with ``#`` are skipped.
    time_column, x_column : int or str
        Columns of time and displacement: positions, or names from the header.
    time_unit : {"s", "ms", "us"}
    x_unit : {"m", "mm", "um", "nm"}
        Units of the file's columns; the arrays returned are in s and m.
    **read_csv_options
        Passed to :func:`pandas.read_csv` (e.g. ``sep``, ``skiprows``).

    Raises
    ------
    ValueError
        If a column is missing, holds a non-numeric or empty entry (the message gives the
        row), or the record fails :func:`check_signal` (non-uniform or non-monotonic time,
        NaN, too short).
    """
    _v.choice("time_unit", time_unit, tuple(TIME_UNITS))
    _v.choice("x_unit", x_unit, tuple(LENGTH_UNITS))
    options = {"comment": "#", **read_csv_options}
    try:
        sep, has_header = _sniff(path, options.pop("sep", options.pop("delimiter", None)))
        options["sep"] = sep
        options.setdefault("header", 0 if has_header else None)
        raw = pd.read_csv(path, **options)
    except (csv.Error, pd.errors.EmptyDataError, pd.errors.ParserError) as exc:
        raise ValueError(f"{path}: cannot be read as a table of (time, displacement) columns: {exc}") from None
    raw.columns = [c.strip() if isinstance(c, str) else c for c in raw.columns]
    columns = []
    for name, col in (("time_column", time_column), ("x_column", x_column)):
        if isinstance(col, str):
            if col not in raw.columns:
                raise ValueError(f"{name}={col!r} is not a column of {path}; columns: {list(raw.columns)}")
            series = raw[col]
        else:
            col = _v.integer(name, col, minimum=0)
            if col >= raw.shape[1]:
                raise ValueError(f"{name}={col} but {path} has {raw.shape[1]} column(s)")
            series = raw.iloc[:, col]
        values = pd.to_numeric(series, errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(np.isnan(values))
        if bad.size:
            raise ValueError(f"{path}: {name} holds {bad.size} empty, NaN or non-numeric value(s), the first "
                             f"{series.iloc[bad[0]]!r} in data row {bad[0]}")
        columns.append(values)
    t, x, _ = check_signal(columns[0] * TIME_UNITS[time_unit], columns[1] * LENGTH_UNITS[x_unit])
    return t, x


def analyze_csv(path, *, time_column=0, x_column=1, time_unit: str = "s", x_unit: str = "m",
                **analyze_options) -> LTMAnalysis:
    """Read a measured LTM CSV (:func:`read_ltm_csv`) and run :func:`analyze` on it: one call, then ``.plot()``."""
    t, x = read_ltm_csv(path, time_column=time_column, x_column=x_column, time_unit=time_unit, x_unit=x_unit)
    return analyze(t, x, **analyze_options)


# -- simulated records ------------------------------------------------------------------------
def from_solution(sol, drive, dt: float, *, t0: float | None = None, t1: float | None = None,
                  max_samples: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A simulated tape-drive run as an LTM record ``(t [s], x [m])`` sampled every ``dt`` seconds.

    Exact samples of the run (:func:`impactosc.frames.resample`), so a run recorded with
    ``record="full"`` is needed and ``drive`` must be the run's :class:`~impactosc.tape.TapeDrive`.
    ``t0``/``t1`` (s) select a window. The samples are points, not averages: content above
    ``1/(2 dt)`` (e.g. the tape's natural frequency) aliases, as in a sensor without an
    anti-aliasing filter; choose ``dt`` below half the period of interest.
    """
    from .frames import sample_grid

    if drive is None:
        raise TypeError("from_solution needs the run's TapeDrive for SI units: from_solution(sol, drive, dt)")
    g = sample_grid(sol, dt, drive, t0=t0, t1=t1, max_samples=max_samples)
    return g["t"], g["x"]


def contact_times(sol, drive) -> np.ndarray:
    """Times (s) of every contact entry and exit of a run, sorted: the simulated impacts.

    Starts and ends of contacts cut by the start or end of the run are left out (they are
    not impacts). Needs ``record="events"`` or more.
    """
    from .frames import units_of

    u = units_of(sol, drive)
    im = sol.impacts
    starts = im["start"][im["start"] > sol.t0]
    ends = im["end"][im["complete"]]
    return np.sort(np.concatenate((starts, ends))) * u.time


def analyze_solution(sol, drive, dt: float, *, t0: float | None = None, t1: float | None = None,
                     **analyze_options) -> LTMAnalysis:
    """:func:`analyze` on a simulated run (:func:`from_solution`), with its contacts as the impacts.

    Contact entries and exits inside the window (:func:`contact_times`) are the impact
    times the bursts are matched with.
    """
    t, x = from_solution(sol, drive, dt, t0=t0, t1=t1)
    times = contact_times(sol, drive)
    times = times[(times >= t[0]) & (times <= t[-1])]
    return analyze(t, x, impact_times=times, **analyze_options)
