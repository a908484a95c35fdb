"""Figures of a single run (matplotlib is the optional ``plot`` extra)."""

from __future__ import annotations

import numpy as np

from .._util.optional import require_matplotlib
from ._solution import Solution

__all__ = ["plot_solution"]


def plot_solution(sol: Solution, path=None, *, n_samples: int = 4000, time_scale: float = 1.0,
                  time_unit: str = "nondimensional time $\\Lambda = \\omega_n t$"):
    """Position, flange force and phase portrait of a run, with contacts and sticks marked.

    Parameters
    ----------
    sol : Solution
        A run recorded with ``record="full"``.
    path : str or path-like, optional
        Where to save the figure (PNG); the figure is returned either way.
    n_samples : int
        Dense-output samples between the events (event states are always included).
    time_scale : float
        Multiplies the time axis (e.g. ``1e3 / omega_n`` for milliseconds).
    time_unit : str
        Label of the time axis.
    """
    plt = require_matplotlib()
    ev = sol.events
    t = np.union1d(np.linspace(sol.t0, sol.t_final, n_samples), ev.t)
    x, v = sol.sample(t)
    fig, (ax_x, ax_f, ax_p) = plt.subplots(3, 1, figsize=(9, 9), constrained_layout=True)
    ts = t * time_scale
    ax_x.plot(ts, x, lw=0.8, color="k", label="X = x/L")
    for lim in (-1, 1):
        ax_x.axhline(lim, color="tab:red", lw=0.8, ls="--")
    for im in sol.impacts:
        ax_x.axvspan(im.start * time_scale, im.end * time_scale, color="tab:red", alpha=0.2, lw=0)
    sticks = ev[ev.kind == "stick"]
    ax_x.plot(sticks.t * time_scale, sticks.x, "o", ms=3, color="tab:blue", label="stick")
    rel = ev[ev.kind == "release"]
    ax_x.plot(rel.t * time_scale, rel.x, "^", ms=3, color="tab:green", label="release")
    ax_x.set_ylabel("lateral position X = x/L [-]")
    ax_x.set_xlabel(time_unit)
    ax_x.legend(loc="upper right", fontsize=8)
    ax_x.set_title(sol.summary().replace(": ", ":\n", 1), fontsize=8)
    ax_f.plot(ts, sol.flange_force(t), lw=0.8, color="tab:red")  # the member's law (a rigid wall's push too)
    law = ("rigid wall's push" if sol.oscillator.rigid
           else "K d" if sol.oscillator.exponent == 1.0 else f"K d^{sol.oscillator.exponent:g}")
    ax_f.set_ylabel(f"flange force {law} [units of kL]")
    ax_f.set_xlabel(time_unit)
    ax_p.plot(x, v, lw=0.6, color="k")
    ax_p.axvline(-1, color="tab:red", lw=0.8, ls="--")
    ax_p.axvline(1, color="tab:red", lw=0.8, ls="--")
    ax_p.set_xlabel("X = x/L [-]")
    ax_p.set_ylabel("V = dX/dΛ [-]")
    ax_p.set_title("phase portrait", fontsize=9)
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig
