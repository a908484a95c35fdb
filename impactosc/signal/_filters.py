"""Filtering and envelopes of an LTM record: the high-pass of Fig. 3(b) and the rms of Fig. 3(c).

Package-private: re-exported by :mod:`impactosc.signal`.
"""

from __future__ import annotations

import numpy as np
from scipy import signal as _ss

from .._util import validation as _v
from ._checks import CUTOFF_HZ, WINDOW_S, _check_filter_cutoff, check_signal

__all__ = ["highpass", "rms_envelope"]


def highpass(t, x, cutoff: float = CUTOFF_HZ, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth high-pass filter of ``x`` (the paper's Fig. 3(b)).

    Parameters
    ----------
    t, x : array_like
        Uniformly sampled time (s) and signal.
    cutoff : float
        Cutoff frequency in Hz (default 1 kHz, the paper's: the servo actuator tracks LTM
        below about 1 kHz). Must be below the Nyquist frequency and at least 1e-8 of the
        sampling rate (below that the filter design is numerically singular).
    order : int
        Order of the Butterworth design. The filter runs forward and backward
        (``scipy.signal.sosfiltfilt``): no phase shift, so bursts stay where they happen,
        twice the order in roll-off, and a gain of 1/2 (-6 dB) at the cutoff. The ends are
        padded by an odd reflection of three cutoff periods, which continues a ramp (the
        run-out near an end) without a step; what remains of the edge transient decays
        within a few cutoff periods.
    """
    t, x, fs = check_signal(t, x)
    cutoff = _check_filter_cutoff("cutoff", cutoff, fs)
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
    try:
        return _ss.sosfiltfilt(sos, x, padlen=padlen)
    except np.linalg.LinAlgError:  # the filter's initial conditions: a singular system
        raise ValueError(f"an order-{order} Butterworth high-pass at cutoff={cutoff!r} Hz is numerically singular at "
                         f"the sampling rate fs = {fs:g} Hz (cutoff/fs = {cutoff / fs:.3g}): lower the order or raise "
                         "the cutoff") from None


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
