"""The figure of an :class:`~impactosc.signal.LTMAnalysis`: the four panels of the paper's Fig. 3.

Package-private: :meth:`impactosc.signal.LTMAnalysis.plot` calls :func:`plot_analysis`.
Drawing is kept apart from the analysis, which needs no matplotlib.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._util import validation as _v

if TYPE_CHECKING:  # the analysis module imports this one to draw
    from ._analysis import LTMAnalysis

__all__ = ["plot_analysis"]


def plot_analysis(analysis: LTMAnalysis, path=None, fmax: float | None = None):
    """Draw ``analysis`` as :meth:`~impactosc.signal.LTMAnalysis.plot` describes; returns the figure."""
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    fmax = min(analysis.fs / 2, 5 * analysis.band[1]) if fmax is None else _v.positive("fmax", fmax)
    fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True, constrained_layout=True)
    _draw_signals(analysis, axes[:3])
    _draw_spectrogram(analysis, fig, axes[3], fmax)
    if analysis.impact_times is not None and analysis.impact_times.size:
        for ax in axes:
            lo, hi = ax.get_ylim()
            ax.vlines(analysis.impact_times * 1e3, lo, hi, colors="tab:red", linestyles="--", lw=0.6, alpha=0.6)
            ax.set_ylim(lo, hi)
        axes[0].plot([], [], color="tab:red", ls="--", lw=0.6, label="impacts")
        axes[0].legend(loc="upper right", fontsize=8)
    fig.suptitle(analysis.summary() if analysis.correlation is None else analysis.correlation.summary(), fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


def _draw_signals(analysis: LTMAnalysis, axes) -> None:
    """Panels (a)-(c): the LTM, the high-passed LTM with bursts, the rms envelopes (ms, um)."""
    ax_a, ax_b, ax_c = axes
    ms, um = 1e3, 1e6
    ax_a.plot(analysis.t * ms, analysis.x * um, lw=0.7, color="k")
    ax_a.set_ylabel("LTM [µm]")
    ax_a.set_title("(a) lateral tape motion", fontsize=9, loc="left")
    ax_b.plot(analysis.t * ms, analysis.highpassed * um, lw=0.6, color="k")
    for start, end in zip(analysis.bursts["start [s]"], analysis.bursts["end [s]"], strict=True):
        ax_b.axvspan(start * ms, end * ms, color="tab:orange", alpha=0.3, lw=0)
    ax_b.set_ylabel("high-passed [µm]")
    ax_b.set_title(f"(b) LTM high-pass filtered at {analysis.cutoff:g} Hz, bursts shaded", fontsize=9, loc="left")
    ax_c.plot(analysis.t * ms, analysis.envelope * um, lw=0.9, color="tab:blue",
              label=f"rms, {analysis.window * ms:g} ms window")
    ax_c.axhline(analysis.bursts.attrs["threshold"] * um, color="tab:orange", ls=":", lw=1, label="burst threshold")
    sg = analysis.spectrogram
    ax_c.plot(sg.t * ms, np.sqrt(sg.band_power(analysis.band)) * um, color="tab:purple", lw=1, drawstyle="steps-mid",
              label=f"rms in {analysis.band[0]:g}-{analysis.band[1]:g} Hz (spectrogram)")
    ax_c.set_ylabel("rms [µm]")
    ax_c.legend(loc="upper right", fontsize=8)
    ax_c.set_title("(c) rms of the high-passed LTM", fontsize=9, loc="left")


def _draw_spectrogram(analysis: LTMAnalysis, fig, ax, fmax: float) -> None:
    """Panel (d): the spectrogram in dB, 80 dB deep, with the band's edges."""
    sg = analysis.spectrogram
    sel = sg.f <= fmax
    level = 10 * np.log10(np.maximum(sg.psd[sel], np.finfo(float).tiny))
    floor = level.max() - 80.0  # an 80 dB range keeps bursts visible above numerical noise
    mesh = ax.pcolormesh(sg.t * 1e3, sg.f[sel] / 1e3, np.maximum(level, floor), shading="nearest", cmap="Greys")
    fig.colorbar(mesh, ax=ax, label="PSD [dB re 1 m²/Hz]")
    for edge in analysis.band:
        ax.axhline(edge / 1e3, color="tab:purple", lw=0.8, ls="--")
    ax.set_ylabel("frequency [kHz]")
    ax.set_xlabel("time [ms]")
    above = f" (above {analysis.detrend_cutoff:g} Hz)" if analysis.detrend_cutoff > 0 else ""
    ax.set_title(f"(d) time-frequency analysis of the LTM{above}", fontsize=9, loc="left")
