"""The figures of Fig. 7 and 8 as the reproduction draws them (matplotlib, imported when drawn)."""

from __future__ import annotations

import numpy as np
import xarray as xr

_SPEED_COLORS = {4.0: "tab:blue", 8.0: "tab:orange", 12.0: "tab:green"}


def _speed_color(v: float, i: int) -> str:
    return _SPEED_COLORS.get(float(v), f"C{i}")


def plot_fig7(ed: xr.Dataset, rk: dict, path, title: str) -> None:
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    fig, ax = plt.subplots(figsize=(7.5, 4.8), constrained_layout=True)
    d = ed.pack_diameter.values * 1e3
    for i, v in enumerate(ed.speed.values):
        for tens, ls in zip(ed.tension.values, ("-", "--"), strict=False):
            y = ed.mean_flange_force.sel(speed=v, tension=tens).values
            ax.plot(d, y, ls=ls, color=_speed_color(v, i), lw=1.5,
                    label=f"event-driven, V = {v:g} m/s, T = {tens:g} N")
    markers = {"consistent": ("x", "RK4 + sign(), two-sided flange"), "paper": ("o", "RK4 + sign(), eq. 2 as printed")}
    for name, ds in rk.items():
        m, lab = markers[name]
        y = ds.mean_flange_force.values.ravel()
        dd = np.broadcast_to(ds.pack_diameter.values[:, None, None] * 1e3, ds.mean_flange_force.shape).ravel()
        ax.plot(dd, y, m, ms=5, mfc="none", color="k", alpha=0.6, label=f"{lab} (all V, T)")
    _zero_axis(ax, ed.mean_flange_force.values)
    ax.set_xlabel("supply pack diameter D [mm]")
    ax.set_ylabel("average flange force over the run [N]")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="upper left")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _zero_axis(ax, values) -> None:
    vals = np.asarray(values, dtype=float)
    if np.all(np.nan_to_num(vals) == 0):
        ax.set_ylim(-0.05, 1.0)
        ax.text(0.5, 0.45, "identically 0 N at every point:\nthe tape never touches a flange",
                transform=ax.transAxes, ha="center", va="center", fontsize=11, color="tab:red")


def plot_fig8(ed: xr.Dataset, rk: dict, path, title: str, qs: xr.DataArray | None = None,
               unit: str = "N", factor: float = 1.0) -> None:
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    speeds = ed.speed.values
    fig, axes = plt.subplots(1, len(speeds), figsize=(max(9.0, 4.2 * len(speeds)), 4.4), constrained_layout=True,
                             sharey=True, squeeze=False)
    cmap = plt.get_cmap("viridis")
    tss = ed.t_sin_half_theta.values
    for k, (ax, v) in enumerate(zip(axes[0], speeds, strict=True)):
        d = ed.pack_diameter.values * 1e3
        for j, ts in enumerate(tss):
            c = cmap(j / max(1, len(tss) - 1))
            y = ed.mean_flange_force.sel(speed=v, t_sin_half_theta=ts).values * factor
            ax.plot(d, y, "-", color=c, lw=1.5, label=f"T sin(θ/2) = {ts:g} N")
            if qs is not None:
                yq = qs.sel(speed=v, t_sin_half_theta=ts).values * factor
                ax.plot(qs.pack_diameter.values * 1e3, yq, ":", color=c, lw=1,
                        label="quasi-static formula" if j == 0 else None)
        for name, (m, lab) in {"consistent": ("x", "RK4 + sign(), two-sided"),
                               "paper": ("o", "RK4 + sign(), eq. 2")}.items():
            if name in rk:
                y = rk[name].mean_flange_force.sel(speed=v).values.ravel() * factor
                dd = np.broadcast_to(rk[name].pack_diameter.values[:, None] * 1e3,
                                     rk[name].mean_flange_force.sel(speed=v).shape).ravel()
                ax.plot(dd, y, m, ms=5, mfc="none", color="k", alpha=0.6, label=f"{lab} (all T sin)")
        _zero_axis(ax, ed.mean_flange_force.values)
        ax.set_title(f"({'abc'[k] if k < 3 else k}) V = {v:g} m/s", fontsize=10)
        ax.set_xlabel("supply pack diameter D [mm]")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"average flange force [{unit}]")
    axes[0][-1].legend(fontsize=7, loc="upper left")
    fig.suptitle(title, fontsize=9)
    fig.savefig(path, dpi=120)
    plt.close(fig)
