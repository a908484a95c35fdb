"""Figures of a single run (matplotlib is the optional ``plot`` extra)."""

from __future__ import annotations

import numpy as np

from .._util.optional import require_matplotlib
from ._frames import draw_flanges
from ._solution import Solution

__all__ = ["plot_solution"]


def plot_solution(sol: Solution, path=None, *, n_samples: int = 4000, time_scale: float = 1.0,
                  time_unit: str = "nondimensional time $\\Lambda = \\omega_n t$"):
    """Position, flange force and phase portrait of a run, with contacts and sticks marked.

    The flanges are drawn where the member has them (:func:`draw_flanges`). The middle
    panel shows the member's flange law over time: a spring's ``K d^p``, or for a rigid
    wall its push on a mass resting against it (a line) and the impulse ``(1 + e)|V|`` of
    every impact (stems, on their own axis: an impact has no finite force).

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
    draw_flanges(ax_x, sol.oscillator)
    for im in sol.impacts:
        if im.end > im.start:
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
    law = ("rigid wall's push at rest" if sol.oscillator.rigid
           else "K d" if sol.oscillator.exponent == 1.0 else f"K d^{sol.oscillator.exponent:g}")
    ax_f.set_ylabel(f"flange force {law} [units of kL]")
    ax_f.set_xlabel(time_unit)
    if sol.oscillator.rigid:
        _draw_impulses(ax_f, sol, time_scale)
    ax_p.plot(x, v, lw=0.6, color="k")
    draw_flanges(ax_p, sol.oscillator, axis="x", label=False)
    ax_p.set_xlabel("X = x/L [-]")
    ax_p.set_ylabel("V = dX/dΛ [-]")
    ax_p.set_title("phase portrait", fontsize=9)
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


def _draw_impulses(ax, sol: Solution, time_scale: float) -> None:
    """The impacts of a rigid wall as stems of their impulse ``(1 + e)|V|`` on a second y axis.

    A chatter's infinitely many remaining impacts are one stem at its accumulation time, of
    their summed impulse (the tail's share of :meth:`Solution.flange_impulse`).
    """
    im = sol.impacts
    hits = im[im.end == im.start]  # an impact: a contact of zero duration
    twin = ax.twinx()
    color = "tab:purple"  # impulses, not forces: not the flange colour
    if len(hits):
        twin.vlines(hits.start * time_scale, 0.0, hits.impulse, color=color, lw=0.8)
        twin.plot(hits.start * time_scale, hits.impulse, "v", ms=3, color=color, ls="none",
                  label=f"impacts ({len(hits)})")
    tails = [jump for jump in sol._tails if jump.t_inf <= sol.t_final]  # chatters resolved by a jump
    if tails:
        twin.plot([j.t_inf * time_scale for j in tails], [j.impulse for j in tails], "*", ms=7, color="indigo",
                  ls="none", label=f"rest of a chatter, summed ({len(tails)})")
    twin.set_ylim(bottom=0.0)
    twin.set_ylabel("impact impulse (1 + e)|V| [units of kL/ω_n]")
    if len(hits) or tails:
        twin.legend(loc="upper right", fontsize=8)
