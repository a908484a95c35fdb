"""The paper's Fig. 3 pipeline in one call: :func:`analyze` and its result :class:`LTMAnalysis`.

Package-private: re-exported by :mod:`impactosc.signal`. The figure is drawn by
:mod:`impactosc._signal_plot`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._util import validation as _v
from ._bursts import ImpactCorrelation, burst_times, correlate_with_impacts
from ._checks import BAND_HZ, CUTOFF_HZ, RESOLUTION_HZ, WINDOW_S, _check_band, _check_filter_cutoff, check_signal
from ._filters import highpass, rms_envelope
from ._plot import plot_analysis
from ._spectra import Spectrogram, band_power, spectrogram

__all__ = ["LTMAnalysis", "analyze"]


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
        return plot_analysis(self, path, fmax)


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
    detrend_cutoff = band[0] / 4 if detrend_cutoff is None else _v.nonnegative("detrend_cutoff", detrend_cutoff)
    if detrend_cutoff > 0:  # checked here so that the message names it (highpass calls it cutoff)
        _check_filter_cutoff("detrend_cutoff", detrend_cutoff, fs)
    env = rms_envelope(t, hp, window)
    bursts = burst_times(t, env, threshold=threshold, level=level, min_gap=window)
    detrended = highpass(t, x, detrend_cutoff, order) if detrend_cutoff > 0 else x
    imp = corr = None
    if impact_times is not None:
        imp = np.sort(np.asarray(impact_times, dtype=float).ravel())
        tol = window if tolerance is None else tolerance
        corr = correlate_with_impacts(bursts, imp, tol, t=t, envelope=env)
    return LTMAnalysis(t, x, fs, float(cutoff), float(window), band, detrend_cutoff, hp, env,
                       spectrogram(t, detrended, resolution), band_power(t, detrended, band, resolution),
                       bursts, imp, corr)
