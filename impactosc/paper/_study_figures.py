"""The study's figures: the best model in the layouts of the paper's Fig. 4/7 and Fig. 8, and the search map."""

from __future__ import annotations

import numpy as np

from ._study import CRITERIA, STUDY_OBSERVABLES

_SPEED_COLORS = ("tab:blue", "tab:orange", "tab:green")
_TS_STYLES = ("-", "-.", "--")


def plot_best(res: dict, obs: str, name: str, path) -> None:
    """Left: Fig. 4/7's layout (colour = speed, line = T sin(theta/2)); right: Fig. 8's (a panel per speed)."""
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    label, units = STUDY_OBSERVABLES[obs]
    d = res["diameters"] * 1e3
    y = res["values"][obs]
    fig, axes = plt.subplots(1, 1 + len(res["speeds"]), figsize=(15, 3.8), constrained_layout=True)
    ax = axes[0]
    for j, v in enumerate(res["speeds"]):
        for k, ts in enumerate(res["t_sin"]):
            if k not in (0, len(res["t_sin"]) - 1):
                continue
            ax.plot(d, y[:, j, k], _TS_STYLES[0 if k == 0 else 2], color=_SPEED_COLORS[j % 3], marker="o", ms=3,
                    label=f"V = {v:g} m/s, T sin = {ts:g} N")
    ax.set_title(f"Fig. 4/7 layout: {name}", fontsize=9)
    ax.legend(fontsize=6)
    for j, v in enumerate(res["speeds"]):
        a = axes[1 + j]
        for k, ts in enumerate(res["t_sin"]):
            a.plot(d, y[:, j, k], _TS_STYLES[k % 3], color=f"C{k}", marker="o", ms=3, label=f"T sin = {ts:g} N")
        a.set_title(f"Fig. 8 layout ({'abc'[j % 3]}): V = {v:g} m/s", fontsize=9)
        a.legend(fontsize=6)
    for a in axes:
        a.set_xlabel("supply pack diameter D [mm]")
        a.set_ylabel(f"{label} [{units}]", fontsize=8)
        a.grid(alpha=0.3)
    held = [k for k, v in res["trends"][obs].items() if v]
    fig.suptitle(f"{name}, {label}: trends held {', '.join(held) if held else 'none'}", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_search(search: dict, spans, clearances, path) -> None:
    """Number of the four trends held, per observable, over span length x clearance."""
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    names = list(search)
    obs_list = list(STUDY_OBSERVABLES)
    fig, axes = plt.subplots(1, len(obs_list), figsize=(3.2 * len(obs_list), 3.4), constrained_layout=True,
                             squeeze=False)
    for a, obs in zip(axes[0], obs_list, strict=True):
        grid = np.zeros((len(spans), len(clearances)))
        for n, name in enumerate(names):
            grid[n // len(clearances), n % len(clearances)] = sum(search[name]["trends"][obs].values())
        im = a.imshow(grid.T, origin="lower", vmin=0, vmax=len(CRITERIA), cmap="viridis", aspect="auto")
        a.set_xticks(range(len(spans)), [f"{s * 1e3:g}" for s in spans], fontsize=7)
        a.set_yticks(range(len(clearances)), [f"{c * 1e6:g}" for c in clearances], fontsize=7)
        a.set_xlabel("span l [mm]")
        a.set_ylabel("clearance L [um]")
        a.set_title(STUDY_OBSERVABLES[obs][0], fontsize=8)
        for i in range(grid.shape[0]):
            for j in range(grid.shape[1]):
                a.text(i, j, f"{grid[i, j]:.0f}", ha="center", va="center", color="w", fontsize=8)
    fig.colorbar(im, ax=axes[0].tolist(), shrink=0.8, label="trends held (of 4)")
    fig.savefig(path, dpi=110)
    plt.close(fig)
