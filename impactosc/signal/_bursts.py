"""Bursts of an rms envelope and how they line up with impacts (Fig. 3(b)-(c)).

Package-private: re-exported by :mod:`impactosc.signal`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._util import validation as _v
from ._checks import WINDOW_S, check_signal

__all__ = ["burst_times", "ImpactCorrelation", "correlate_with_impacts"]


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
    nearest = _nearest(imp, peak) if imp.size else np.full(len(bursts), np.nan)
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
        corr = _envelope_correlation(t, envelope, imp, tolerance)
    return ImpactCorrelation(out, impacts, tolerance,
                             float(matched.mean()) if len(bursts) else math.nan,
                             float(inside.mean()) if imp.size else math.nan, corr)


def _nearest(imp: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The element of ``imp`` (sorted, not empty) nearest to each of ``times``."""
    # The impacts either side of each time: the last at or before it and the one after.
    j = np.clip(np.searchsorted(imp, times), 1, imp.size) - 1
    k = np.minimum(j + 1, imp.size - 1)
    return np.where(np.abs(imp[k] - times) < np.abs(imp[j] - times), imp[k], imp[j])


def _envelope_correlation(t, envelope, imp: np.ndarray, tolerance: float) -> float | None:
    """Pearson correlation of ``envelope`` with "within ``tolerance`` of an impact" (point-biserial).

    None where it is undefined: the indicator or the envelope is constant.
    """
    tt, env, _ = check_signal(t, envelope)
    near = (np.abs(tt - _nearest(imp, tt)) <= tolerance).astype(float)
    if 0 < near.sum() < near.size and env.std() > 0:
        return float(np.corrcoef(env, near)[0, 1])
    return None
