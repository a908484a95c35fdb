"""Spectra of an LTM record: Welch PSD, the spectrogram of Fig. 3(d) and band power.

Package-private: re-exported by :mod:`impactosc.signal`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal as _ss

from .._util import validation as _v
from ._checks import BAND_HZ, RESOLUTION_HZ, _check_band, _nperseg, check_signal

__all__ = ["spectrum", "Spectrogram", "spectrogram", "band_power"]


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
