"""Defaults of the paper's Fig. 3 pipeline and the input checks every part of it shares.

Package-private: the public names are re-exported by :mod:`impactosc.signal`. The other
``_signal_*`` modules import from here, so the defaults are defined once.
"""

from __future__ import annotations

import numpy as np

from .._util import validation as _v

__all__ = ["CUTOFF_HZ", "BAND_HZ", "WINDOW_S", "RESOLUTION_HZ", "UNIFORM_RTOL", "MIN_SAMPLES", "MAX_SIGNAL",
           "MIN_CUTOFF_RATIO", "check_signal"]

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
#: Largest ``|x|`` accepted. The pipeline squares and sums the signal (rms, Welch's
#: ``|FFT|^2``, ``~ (n max|x|)^2``): below 1e100 that stays under 1e216 for 1e8 samples,
#: far from the double-precision overflow at 1.8e308 (an LTM in metres is ~1e-6).
MAX_SIGNAL = 1e100
#: Smallest ``cutoff / fs`` of a filter: scipy's zero-phase Butterworth (order 4, second-order
#: sections) works at 1e-8 and its initial conditions are a singular system at 1e-10.
MIN_CUTOFF_RATIO = 1e-8


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
    big = np.flatnonzero(np.abs(x) > MAX_SIGNAL)
    if big.size:
        raise ValueError(f"x must stay within +-{MAX_SIGNAL:g} (its squares, the rms and the power, must fit in double "
                         f"precision), got {float(x[big[0]])!r} at index {big[0]}: is it in metres?")
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


def _check_filter_cutoff(name: str, value, fs: float) -> float:
    """A filter cutoff: below Nyquist, and at least :data:`MIN_CUTOFF_RATIO` of the sampling rate."""
    f = _check_frequency(name, value, fs)
    if not f >= MIN_CUTOFF_RATIO * fs:
        raise ValueError(f"{name} must be at least {MIN_CUTOFF_RATIO:g} of the sampling rate fs = {fs:g} Hz (time "
                         f"step {1.0 / fs:g} s): a Butterworth filter at {name}/fs = {f / fs:.3g} is numerically "
                         f"singular; got {name}={f!r} Hz. Is t in seconds?")
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
