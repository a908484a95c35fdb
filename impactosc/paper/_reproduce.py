"""The whole reproduction: every figure computed, drawn and tabulated, then the report written.

:func:`reproduce` runs its steps in order, each adding its part to the summary dict (the
numbers of the report, also written as ``paper_summary.json``): the run-out law, the
event-driven Fig. 7/8 grids, the paper's RK4 on them, the cost of the RK4 at its
contact-resolving step, the tables and figures, and the alternative parameter sets.
"""

from __future__ import annotations

import json
import os
import platform
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..model._tape import TapeDrive
from ._compute import fig6, figure_dt, quasi_static_mean_force, rk4_default_step_cost, rk4_grid, trends
from ._figures import plot_fig7, plot_fig8
from ._grids import (
    ALTERNATIVES,
    FULL_DURATION,
    FULL_N_DIAMETERS,
    PAPER_SPEEDS,
    PAPER_T_SIN_HALF_THETA,
    PAPER_TENSIONS,
    QUICK_DURATION,
    QUICK_N_DIAMETERS,
    fig7_grid,
    fig8_grid,
    grid_points,
    pack_diameters,
    resolve_drive,
)
from ._report import report_text


def _sweep(base, grid, duration, executor, progress, **kw):
    from ..sweeps._sweep import sweep

    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        ds = sweep(base, grid, duration=duration, backend="heyoka", executor=executor, progress=progress, **kw)
    return ds, time.perf_counter() - t


def _to_csv(ds: xr.Dataset, path, variables) -> None:
    df = ds[list(variables)].to_dataframe().reset_index()
    if "pack_diameter" in df:
        df.insert(0, "pack_diameter_mm", df.pop("pack_diameter") * 1e3)
    df.to_csv(path, index=False, float_format="%.6g")


def _max_abs_x_after_transient(drive: TapeDrive, window_s: float = 0.02) -> tuple[float, float]:
    """(max |X| over the first ``window_s`` s, max |X| after 10 ms) of one run, from dense output."""
    from ..backends._simulate import simulate

    sol = simulate(drive.oscillator(), drive.seconds_to_lambda(window_s), 0.95, 0.0, record="full")
    t = np.linspace(sol.t0, sol.t_final, 200_001)
    x, _ = sol.sample(t)
    late = t >= drive.seconds_to_lambda(0.01)
    return float(np.max(np.abs(x))), float(np.max(np.abs(x[late])))


def reproduce(out_dir="reports", quick: bool = False, executor=None, progress: bool = True) -> dict:
    """Recompute the paper's Fig. 6-8 and the alternatives; write PNGs, CSVs and the markdown report.

    Parameters
    ----------
    out_dir : str or path-like
        Where ``paper_reproduction.md`` and the ``*.csv`` tables go; figures go to
        ``out_dir/figures/*.png``.
    quick : bool
        A coarse grid (5 diameters), a 10 ms average and small alternative grids: for
        tests and notebooks (a minute or less). The full run (15 diameters, 1 s) takes a
        few minutes on two cores.
    executor
        Passed to :func:`impactosc.sweep` (None: a local process pool).
    progress : bool
        Progress bars of the sweeps.

    Returns
    -------
    dict
        The numbers of the report: timings, findings, trends (also written as
        ``out_dir/paper_summary.json``).
    """
    out = Path(out_dir)
    figs = out / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    base = TapeDrive()
    duration = QUICK_DURATION if quick else FULL_DURATION
    summary: dict = {"quick": quick, "duration_s": duration, "cpu_count": os.cpu_count(),
                     "machine": f"{platform.system()} {platform.machine()}, Python {platform.python_version()}"}
    if hasattr(os, "getloadavg"):
        summary["load_average_start"] = list(os.getloadavg())

    table6, fig = fig6(base, path=figs / "fig6_runout.png")
    import matplotlib.pyplot as plt

    plt.close(fig)
    table6.to_csv(out / "fig6_runout.csv", index=False, float_format="%.6g")

    grids = fig7_grid(base, quick), fig8_grid(base, quick)
    eds = _event_driven(base, grids, duration, executor, progress, summary)
    rks = _rk4_figure_step(base, grids, duration, summary)
    summary["rk4_default_step"] = _rk4_default_step(base, duration, quick)
    _paper_tables_and_figures(out, figs, eds, rks, duration)

    summary["alternatives"] = {}
    for name, alt in ALTERNATIVES.items():
        summary["alternatives"][name] = _alternative(name, alt, base, quick, duration, executor, progress, out, figs)

    summary["paper_trends"] = trends(eds[1])  # the paper's parameters: all zero
    if hasattr(os, "getloadavg"):
        summary["load_average_end"] = list(os.getloadavg())
    (out / "paper_summary.json").write_text(json.dumps(summary, indent=1, default=float))
    (out / "paper_reproduction.md").write_text(report_text(summary, quick))
    return summary


def _event_driven(base, grids, duration, executor, progress, summary: dict) -> tuple:
    """Fig. 7 and 8 with the event-driven solver, and the largest |X| of the worst point."""
    g7, g8 = grids
    ed7, t_ed7 = _sweep(base, g7, duration, executor, progress)
    ed8, t_ed8 = _sweep(base, g8, duration, executor, progress)
    summary["event_driven"] = {"fig7_points": int(ed7.mean_flange_force.size), "fig7_wall_s": t_ed7,
                               "fig8_points": int(ed8.mean_flange_force.size), "fig8_wall_s": t_ed8}
    for name, ds in (("fig7", ed7), ("fig8", ed8)):
        summary["event_driven"][name] = {
            "max_mean_force_N": float(ds.mean_flange_force.max()), "impacts_total": int(ds.impacts.sum()),
            "status_nonzero": int((ds.status != 0).sum()), "sticks_min": int(ds.sticks.min()),
            "sticks_max": int(ds.sticks.max()), "F_range": [float(ds.F.min()), float(ds.F.max())],
            "Omega_range": [float(ds.Omega.min()), float(ds.Omega.max())],
            "beta_range": [float(ds.beta.min()), float(ds.beta.max())]}
    worst = resolve_drive(base, {"pack_diameter": base.full_pack_diameter, "speed": 12.0, "t_sin_half_theta": 0.1})
    mx, mx_late = _max_abs_x_after_transient(worst)
    summary["max_abs_X"] = {"drive": "D = full pack, V = 12 m/s, T sin = 0.1 N", "first_20ms": mx,
                            "after_10ms": mx_late}
    return ed7, ed8


def _rk4_figure_step(base, grids, duration, summary: dict) -> tuple:
    """Fig. 7 and 8 with the paper's RK4 at the figure step, both flange laws."""
    g7, g8 = grids
    rk7, rk8 = {}, {}
    summary["rk4_figure_step"] = {"dt": figure_dt(), "steps_per_point": None}
    for flange in ("consistent", "paper"):
        rk7[flange] = rk4_grid(base, g7, duration=duration, dt="figure", flange=flange)
        rk8[flange] = rk4_grid(base, g8, duration=duration, dt="figure", flange=flange)
        summary["rk4_figure_step"][flange] = {
            "fig7_wall_s": rk7[flange].attrs["wall_time_s"], "fig8_wall_s": rk8[flange].attrs["wall_time_s"],
            "fig7_max_force_N": float(rk7[flange].mean_flange_force.max()),
            "fig8_max_force_N": float(rk8[flange].mean_flange_force.max()),
            "impacts_total": int(rk7[flange].impacts.sum() + rk8[flange].impacts.sum()),
            "status_nonzero": int((rk7[flange].status != 0).sum() + (rk8[flange].status != 0).sum())}
    n_pts7 = rk7["consistent"].mean_flange_force.size
    summary["rk4_figure_step"]["steps_per_point"] = rk7["consistent"].attrs["steps"] / n_pts7
    return rk7, rk8


def _rk4_default_step(base, duration, quick: bool) -> dict:
    """RK4 at the default (contact-resolving) step: measured on two points, extrapolated."""
    cost_duration = 0.002 if quick else duration
    pts = [{"pack_diameter": base.hub_diameter}, {"pack_diameter": base.full_pack_diameter}]
    cost = rk4_default_step_cost(base, pts, duration=cost_duration)
    steps_per_point_1s = base.seconds_to_lambda(FULL_DURATION) / cost["dt"]
    n7 = len(PAPER_SPEEDS) * len(PAPER_TENSIONS) * FULL_N_DIAMETERS
    n8 = len(PAPER_SPEEDS) * len(PAPER_T_SIN_HALF_THETA) * FULL_N_DIAMETERS
    cost.update(steps_per_point_1s=steps_per_point_1s,
                fig7_full_extrapolated_s=n7 * steps_per_point_1s / cost["steps_per_s"],
                fig8_full_extrapolated_s=n8 * steps_per_point_1s / cost["steps_per_s"],
                per_point_1s_extrapolated_s=steps_per_point_1s / cost["steps_per_s"] * min(2, os.cpu_count() or 1))
    return cost


def _paper_tables_and_figures(out: Path, figs: Path, eds, rks, duration) -> None:
    """The CSVs and figures of Fig. 7 and 8 with the paper's parameters."""
    (ed7, ed8), (rk7, rk8) = eds, rks
    for name, ed, rk in (("fig7", ed7, rk7), ("fig8", ed8, rk8)):
        merged = xr.Dataset({"event_driven_N": ed.mean_flange_force, "event_driven_impacts": ed.impacts,
                             "event_driven_sticks": ed.sticks,
                             "rk4_sign_N": rk["consistent"].mean_flange_force,
                             "rk4_sign_impacts": rk["consistent"].impacts,
                             "rk4_eq2_N": rk["paper"].mean_flange_force, "rk4_eq2_impacts": rk["paper"].impacts,
                             "F": ed.F, "Omega": ed.Omega, "beta": ed.beta})
        _to_csv(merged, out / f"{name}_paper_parameters.csv", merged.data_vars)
    dur_txt = f"{duration:g} s"
    plot_fig7(ed7, rk7, figs / "fig7_paper_parameters.png",
              f"Fig. 7 recomputed with the paper's parameters (L = 1 mm, in-plane k), average over {dur_txt}:\n"
              "lines event-driven (heyoka), markers the paper's RK4 with sign() (step 2π/100 of the free period)")
    plot_fig8(ed8, rk8, figs / "fig8_paper_parameters.png",
              f"Fig. 8 recomputed with the paper's parameters, θ = 60°, average over {dur_txt}")


def _alternative_grid(alt, alt_base, quick: bool, duration) -> tuple[dict, float]:
    """The event-driven grid of an alternative set, and its averaging time (s)."""
    if alt["event_grid"] == "fig8":
        return fig8_grid(alt_base, quick), duration
    # expensive quasi-static creep in contact: coarse grid and a shorter window
    n = 2 if quick else QUICK_N_DIAMETERS
    g = {"pack_diameter": pack_diameters(alt_base, n), "speed": [4.0, 12.0] if not quick else [4.0],
         "t_sin_half_theta": [0.1, 0.7] if not quick else [0.1]}
    return g, 0.002 if quick else 0.05


def _quasi_static_grid(alt_base, quick: bool) -> xr.DataArray:
    """The quasi-static reference on the full Fig. 8 grid (speed-independent by construction)."""
    gq = fig8_grid(alt_base, quick)
    qs = xr.DataArray(np.zeros(tuple(len(v) for v in gq.values())), coords={k: np.asarray(v, float)
                                                                          for k, v in gq.items()},
                      dims=list(gq), name="quasi_static_N")
    for idx, point in grid_points(gq):
        qs.values[idx] = quasi_static_mean_force(resolve_drive(alt_base, point))
    return qs


def _alternative(name, alt, base, quick, duration, executor, progress, out: Path, figs: Path) -> dict:
    """One alternative parameter set: run, compared with the quasi-static formula, drawn and tabulated."""
    alt_base = base.replace(**alt["fields"])
    info: dict[str, Any] = {"title": alt["title"], "fields": alt["fields"]}  # this set's part of the summary
    ref = resolve_drive(alt_base, {"t_sin_half_theta": 0.5})
    info["k_N_per_m"] = ref.stiffness
    info["f_n_Hz"] = ref.natural_frequency_hz
    g, alt_duration = _alternative_grid(alt, alt_base, quick, duration)
    ds, wall = _sweep(alt_base, g, alt_duration, executor, progress, max_events=20_000_000)
    info.update(duration_s=alt_duration, wall_s=wall, points=int(ds.mean_flange_force.size),
                impacts_total=int(np.nansum(ds.impacts.values)), status_nonzero=int((ds.status != 0).sum()),
                F_range=[float(ds.F.min()), float(ds.F.max())],
                Omega_range=[float(ds.Omega.min()), float(ds.Omega.max())],
                beta_range=[float(ds.beta.min()), float(ds.beta.max())])
    qs = _quasi_static_grid(alt_base, quick)
    info["trends"] = trends(ds)
    info["trends_quasi_static"] = trends(qs.to_dataset(name="mean_flange_force"))
    # Event-driven vs quasi-static at the computed points
    qs_at = np.array([quasi_static_mean_force(resolve_drive(alt_base, p), alt_duration) for _, p in grid_points(g)])
    ed_at = ds.mean_flange_force.values.ravel()
    ok = qs_at > 0
    ratio = ed_at[ok] / qs_at[ok]
    info["ed_over_quasi_static"] = [float(np.nanmin(ratio)), float(np.nanmax(ratio))] if ok.any() else None
    small = float(np.nanmax(ds.mean_flange_force.values)) < 1e-2
    factor, unit = (1e6, "uN") if small else (1.0, "N")
    plot_fig8(ds, {}, figs / f"alt_{name}.png",
              f"Alternative {alt['title']}\nevent-driven (heyoka), average over {alt_duration:g} s"
              + ("\ndotted: quasi-static formula over whole reel turns (speed-independent)"
                 if alt["event_grid"] != "fig8" else ""),
              qs=qs if alt["event_grid"] != "fig8" else None, unit=unit, factor=factor)
    info["unit"] = unit
    _to_csv(ds, out / f"alt_{name}.csv", ["mean_flange_force", "mean_flange_force_upper",
                                           "mean_flange_force_lower", "impacts", "sticks", "F", "Omega", "beta"])
    qs.to_dataframe().reset_index().to_csv(out / f"alt_{name}_quasi_static.csv", index=False, float_format="%.6g")
    return info
