"""The whole Fig. 4 study: the lead checked, the candidates judged, the search, the onset, figures and report.

:func:`study` runs the steps of :mod:`._study` in order and writes ``fig4_study.md``
(:mod:`._study_report`), ``fig4_study.json`` (every number of the report),
``fig4_study.csv`` (every simulated point) and ``figures/fig4_study_*.png``.
"""

from __future__ import annotations

import json
import math
import os
import platform
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..model._tape import TapeDrive
from ._grids import resolve_drive
from ._study import (
    CANDIDATES,
    CRITERIA,
    STUDY_OBSERVABLES,
    evaluate_models,
    lead_ae_proxy,
    lead_peak_runout,
    lead_ratio_bound,
    lead_scan,
    mid_pack_fraction,
    quasi_static_impact_speed,
    search_models,
)
from ._study_path import PATH_CANDIDATES
from ._study_report import study_report_text

#: Reel turns (transient, measured) of the candidates whose points are expensive.
_CHEAP_TURNS = {"short_clearance": (1, 2)}


def _n_trends(trends: dict) -> int:
    return sum(bool(v) for v in trends.values())


def _best(results: dict) -> tuple[str, str]:
    """The (model, observable) holding the most trends; ties go to the AE proxy, then to the first model listed."""
    best, score = ("", ""), (-1, False)
    for name, res in results.items():
        for obs in STUDY_OBSERVABLES:
            key = (_n_trends(res["trends"][obs]), obs == "ae_impact_sum")
            if key > score:
                best, score = (name, obs), key
    return best


def _onset_in_pack(fields: dict, t_sin) -> bool:
    """Whether the quasi-static onset ``runout(D) = L + mu N/k`` lies inside the pack at every ``t_sin``."""
    base = TapeDrive(**fields)
    for ts in t_sin:
        d = resolve_drive(base, {"t_sin_half_theta": ts})
        c = d.clearance + d.friction_force / d.stiffness
        if not d.runout_hub < c < d.runout_full:
            return False
    return True


def _lead_check() -> dict:
    """The lead's formulas against a finite-difference maximum on the drive's own run-out law."""
    base = TapeDrive(free_length=40e-3, clearance=50e-6)
    slope = (base.runout_full - base.runout_hub) / (base.full_pack_diameter - base.hub_diameter)
    a0 = base.runout_hub - slope * base.hub_diameter
    c = base.clearance + base.friction_force / base.stiffness
    d = np.linspace(base.hub_diameter, base.full_pack_diameter, 20001)
    y = np.array([lead_ae_proxy(base.replace(pack_diameter=float(x))) for x in d])
    numeric = base.runout_at(float(d[int(np.argmax(y))]))
    return {"runout_at_zero_m": a0, "c_m": c, "peak_runout_formula_m": lead_peak_runout(c, a0),
            "peak_runout_numeric_m": numeric, "peak_runout_proportional_law_m": lead_peak_runout(c),
            "impact_speed_mid_pack_m_s": quasi_static_impact_speed(base)}


def _onset(fields: dict, t_sin: tuple, quick: bool) -> list[dict]:
    """Contact-onset pack diameter by :func:`contact_onset` (continuation and transient) and in closed form."""
    from ..dynamics.onset import contact_onset

    rows = []
    base = TapeDrive(**fields)
    for ts in t_sin:
        drive = resolve_drive(base, {"speed": 8.0, "t_sin_half_theta": ts})
        c = drive.clearance + drive.friction_force / drive.stiffness
        frac = (c - drive.runout_hub) / (drive.runout_full - drive.runout_hub)
        closed = drive.hub_diameter + frac * (drive.full_pack_diameter - drive.hub_diameter)
        row: dict[str, Any] = {"t_sin_half_theta": ts, "closed_form_m": closed, "c_m": c}
        if not drive.hub_diameter < closed < drive.full_pack_diameter:
            row["message"] = "closed-form onset outside the pack: not searched"
            rows.append(row)
            continue
        bracket = (drive.hub_diameter + 1e-4, drive.full_pack_diameter - 1e-4)
        settings: tuple[tuple[str, dict[str, Any]], ...] = (("continuation", {}),
                                                            ("transient", {"record_periods": 2, "tol": 1e-5}))
        for method, kw in settings:
            t = time.perf_counter()
            try:
                res = contact_onset(drive, "pack_diameter", bracket, method=method, transient_periods=3,
                                    backend="exact", **kw)
                row[method] = {"onset_m": res.value, "status": res.status, "message": res.message}
            except Exception as exc:  # noqa: BLE001 - reported, the study goes on
                row[method] = {"onset_m": math.nan, "status": -2, "message": f"{type(exc).__name__}: {exc}"}
            row[method]["wall_s"] = time.perf_counter() - t
        rows.append(row)
        if quick:
            break
    return rows


def _neighbourhood(search: dict, spans, clearances, best: str, obs: str) -> dict:
    """Sensitivity of the search's best cell: trends held by the cells around it."""
    names = list(search)
    shape = (len(spans), len(clearances))
    if best not in search:
        return {}
    i, j = np.unravel_index(names.index(best), shape)
    around = {}
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            a, b = i + di, j + dj
            if (di or dj) and 0 <= a < shape[0] and 0 <= b < shape[1]:
                name = names[a * shape[1] + b]
                around[name] = _n_trends(search[name]["trends"][obs])
    return around


def _path_summary(res: dict) -> dict:
    """What decides a tape path's trends: failed points per T sin, the tension's effect, curves rising over the pack."""
    values = {obs: v for obs, v in res["values"].items() if np.any(np.isfinite(v))}  # rms: not computed for a path
    failed = np.isnan(res["values"]["mean_force"])
    by_t_sin = {f"{ts:g}": int(failed[:, :, k].sum()) for k, ts in enumerate(res["t_sin"])}
    out: dict[str, Any] = {"failed_by_t_sin": by_t_sin, "points": int(failed.size), "tension_effect": {},
                           "rising_over_pack": {}}
    for obs, v in values.items():
        scale = np.nanmax(np.abs(v))
        compared = np.sum(np.isfinite(v), axis=2) >= 2  # (diameter, speed) points run at two tensions or more
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices are left out by ``compared``
            change = (np.nanmax(v, axis=2) - np.nanmin(v, axis=2))[compared]
        # the largest change between tensions at one (diameter, speed), relative to the largest value
        out["tension_effect"][obs] = float(change.max() / scale) if change.size and scale > 0 else math.nan
        steps = np.diff(v, axis=0)
        curves = [bool(np.all(steps[:, j, k] > 0)) for j in range(v.shape[1]) for k in range(v.shape[2])
                  if np.all(np.isfinite(v[:, j, k]))]
        out["rising_over_pack"][obs] = {"rising": sum(curves), "curves": len(curves)}
    return out


def _csv(path: Path, results: dict) -> None:
    lines = ["model,observable,pack_diameter_mm,speed_m_s,t_sin_half_theta_N,value"]
    for name, res in results.items():
        for obs in STUDY_OBSERVABLES:
            v = res["values"][obs]
            for idx in np.ndindex(*v.shape):
                lines.append(f"{name},{obs},{res['diameters'][idx[0]] * 1e3:.6g},{res['speeds'][idx[1]]:g},"
                             f"{res['t_sin'][idx[2]]:g},{v[idx]:.6g}")
    path.write_text("\n".join(lines) + "\n")


def _jsonable(res: dict) -> dict:
    return {"fields": res["fields"], "trends": res["trends"], "errors": res["errors"][:5],
            "n_errors": len(res["errors"]), "mid_pack_curves": {
                obs: mid_pack_fraction(res["values"][obs], res["diameters"]) for obs in STUDY_OBSERVABLES},
            "pack_mean": {obs: _pack_mean(res["values"][obs]) for obs in STUDY_OBSERVABLES}}


def _pack_mean(values: np.ndarray) -> list:
    """Mean over the pack diameters of the points that ran (NaN where none did: a tape path's rms)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices are NaN, as meant
        return np.nanmean(values, axis=0).tolist()


def study(out_dir="reports", quick: bool = False, executor=None, progress: bool = True) -> dict:
    """Run the Fig. 4 study and write ``fig4_study.md``, ``.json``, ``.csv`` and its figures.

    Parameters
    ----------
    out_dir : str or path-like
        Where the report and tables go; figures go to ``out_dir/figures``.
    quick : bool
        The coarse grids: 5 pack diameters, T sin(theta/2) = 0.1 and 0.7 N, one search cell,
        no short-clearance candidate (its creep at 91 kHz is the expensive part), no friction
        sensitivity, one onset, a 5 x 5 closed-form scan (~20 s on an idle 2-core machine).
    executor, progress
        As :func:`impactosc.runner.run_points`.

    Returns
    -------
    dict
        The summary written to ``fig4_study.json``.

    Examples
    --------
    >>> from impactosc.paper import study
    >>> summary = study("reports", quick=True)        # doctest: +SKIP
    >>> summary["best"]                               # doctest: +SKIP
    """
    from ._study_figures import plot_best, plot_search

    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    s: dict[str, Any] = {"quick": quick, "criteria": CRITERIA,
                         "machine": f"{platform.system()} {platform.machine()}, {os.cpu_count()} CPUs, Python "
                                    f"{platform.python_version()}, load average {load:.1f} at the start"}

    s["lead"] = _lead_check()
    s["lead_bound"] = lead_ratio_bound()
    n = 5 if quick else 31
    scan = lead_scan(np.linspace(10e-3, 100e-3, n), np.linspace(5e-6, 150e-6, n), frictions=(0.2,) if quick
                     else (0.1, 0.2, 0.3))
    both = [r for r in scan if r["mid_pack"] and r["tension"]]
    s["lead_scan"] = {"points": len(scan), **{k: sum(r[k] for r in scan) for k in CRITERIA},
                      "mid_pack_and_tension_region": None if not both else {
                          key: [min(r[key] for r in both), max(r[key] for r in both)]
                          for key in ("free_length", "clearance", "friction")},
                      "all_four": sum(all(r[k] for k in CRITERIA) for r in scan),
                      "mid_pack_and_double": sum(r["mid_pack"] and r["double"] for r in scan),
                      "three": sum(sum(r[k] for k in CRITERIA) >= 3 for r in scan)}

    models = {k: c["fields"] for k, c in CANDIDATES.items() if not (quick and k == "short_clearance")}
    models.update({k: c["fields"] for k, c in PATH_CANDIDATES.items()})
    t = time.perf_counter()
    cand = evaluate_models(models, quick=quick, executor=executor, progress=progress, turns=_CHEAP_TURNS)
    s["candidates_wall_s"] = time.perf_counter() - t
    s["tape_path"] = {k: _path_summary(cand[k]) for k in PATH_CANDIDATES}
    t = time.perf_counter()
    smodels = search_models(quick)
    search = evaluate_models(smodels, quick=True, executor=executor, progress=progress)
    s["search_wall_s"] = time.perf_counter() - t
    spans = sorted({f["free_length"] for f in smodels.values()})
    clearances = sorted({f["clearance"] for f in smodels.values()})
    s["search_grid"] = {"free_length_m": spans, "clearance_m": clearances, "cells": len(smodels)}
    # second stage, aimed by the lead: a 3 x 3 grid over its cells with a mid-pack maximum and a tension effect
    region = s["lead_scan"]["mid_pack_and_tension_region"]
    refine: dict[str, dict] = {}
    if region is not None and not quick:
        (l0, l1), (c0, c1) = region["free_length"], region["clearance"]
        for span in np.linspace(l0, l1, 3):
            for c in np.linspace(c0, c1, 3):
                refine[f"lead_l{span * 1e3:.3g}mm_L{c * 1e6:.3g}um"] = {"free_length": float(span),
                                                                       "clearance": float(c)}
    t = time.perf_counter()
    refined = evaluate_models(refine, quick=True, executor=executor, progress=progress) if refine else {}
    s["refine_wall_s"] = time.perf_counter() - t
    s["refine"] = {k: _jsonable(v) for k, v in refined.items()}

    best_model, best_obs = _best({**cand, **search, **refined})
    best = {**cand, **search, **refined}[best_model]
    s["best"] = {"model": best_model, "observable": best_obs, "fields": best["fields"],
                 "trends": best["trends"][best_obs]}
    bs_model, bs_obs = _best(search)
    bs = search[bs_model]
    s["best_search"] = {"model": bs_model, "observable": bs_obs, "fields": bs["fields"],
                        "trends": bs["trends"][bs_obs]}
    # friction is an assumed number (section 5 takes a 'typical' mu = 0.2 from [19, 20]): halve and double it
    sens: dict[str, dict] = {}
    if not quick:
        for name, res in ((best_model, best), (bs_model, bs)):
            mu = res["fields"].get("friction", TapeDrive().friction)
            for factor in (0.5, 2.0):
                sens[f"{name}_mu{mu * factor:g}"] = {**res["fields"], "friction": mu * factor}
    sres = evaluate_models(sens, quick=True, executor=executor, progress=progress) if sens else {}
    s["sensitivity_friction"] = {k: v["trends"][best_obs if k.startswith(best_model + "_mu") else bs_obs]
                                 for k, v in sres.items()}
    s["sensitivity_neighbours"] = _neighbourhood(search, spans, clearances, bs_model, bs_obs)

    t_sin_onset = (0.1, 0.7) if not quick else (0.4,)
    # the onset of the best search cell whose contact starts inside the pack (else there is nothing to find)
    ranked = sorted(search, key=lambda k: -max(_n_trends(t) for t in search[k]["trends"].values()))
    onset_model = next((k for k in ranked if _onset_in_pack(search[k]["fields"], t_sin_onset)), None)
    s["onset"] = {"model": onset_model, "fields": None if onset_model is None else search[onset_model]["fields"],
                  "rows": [] if onset_model is None else _onset(search[onset_model]["fields"], t_sin_onset, quick)}

    s["candidates"] = {k: _jsonable(v) for k, v in cand.items()}
    s["search"] = {k: _jsonable(v) for k, v in search.items()}
    s["sensitivity"] = {k: _jsonable(v) for k, v in sres.items()}
    plot_best(best, best_obs, best_model, out / "figures" / "fig4_study_best.png")
    plot_search(search, spans, clearances, out / "figures" / "fig4_study_search.png")
    _csv(out / "fig4_study.csv", {**cand, **search, **refined, **sres})
    s["wall_s"] = time.perf_counter() - t_start
    (out / "fig4_study.json").write_text(json.dumps(s, indent=1, default=float))
    (out / "fig4_study.md").write_text(study_report_text(s))
    return s
