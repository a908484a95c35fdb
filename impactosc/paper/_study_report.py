"""The markdown report of the Fig. 4 study, written from its summary dict alone."""

from __future__ import annotations

import math

from ._study import CANDIDATES, CRITERIA, MEASURED_TURNS, STUDY_OBSERVABLES, TRANSIENT_TURNS
from ._study_path import PATH_CANDIDATES


def _mark(ok: bool) -> str:
    return "yes" if ok else "no"


def _trend_row(name: str, obs: str, res: dict) -> str:
    trends = res["trends"][obs]
    cells = " | ".join(_mark(trends[k]) for k in CRITERIA)
    return (f"| {name} | {STUDY_OBSERVABLES[obs][0]} | {cells} | {sum(trends.values())} | "
            f"{res['mid_pack_curves'][obs]:.0%} |")


def _header() -> list[str]:
    return ["| model | observable | " + " | ".join(CRITERIA) + " | held | curves peaking mid pack |",
            "| --- | --- | " + " | ".join("---" for _ in CRITERIA) + " | --- | --- |"]


def _criteria_section() -> list[str]:
    lines = ["## 1. The criteria, fixed before the search", "",
             "Each trend of the paper's Fig. 4 (measured) and Fig. 8 (its model) is judged on an observable "
             "computed on the grid pack diameter x speed (4, 8, 12 m/s) x T sin(theta/2) (theta = 60 deg) "
             "and holds only as follows (`impactosc.paper._study.CRITERIA`, `trend_checks`):", ""]
    for key, (what, rule) in CRITERIA.items():
        lines.append(f"* **{key}** -- {what}: {rule}.")
    lines += ["", "A model whose observable is zero everywhere holds none; a failed point (NaN) holds none either. "
              "The 10 % margins are this study's reading of 'reaches a maximum', 'increases' and 'decreases' for "
              "curves read off a figure; 'almost double' is read as a ratio in [1.5, 2.5].", ""]
    return lines


def _observables_section() -> list[str]:
    return [
        "## 2. The observables (`impactosc.results.contact_observables`)", "",
        f"Every point is a steady state of the exact backend: {TRANSIENT_TURNS} reel turns of transient from "
        f"the paper's X = 0.95, X' = 0 (eq. 6-7), then {MEASURED_TURNS} measured turns (the paper's 1-s average of "
        "a periodic state is the average over whole turns). Both flanges, SI units:", "",
        "* **time-averaged contact force** `(1/T) int f dt`, f the flange spring force of eq. 2 -- the quantity "
        "of the paper's Fig. 7-8;",
        "* **AE proxy** `(1/T) sum_i sqrt(k0 m) v_i`: the elastic impact force of each contact's entry speed v_i "
        "(a mass m on the flange spring k0 stops where m v^2/2 = k0 d^2/2), summed per second -- the ball-drop "
        "calibration (section 3) reads impact peaks, and the sensor, blind to the 15-90 Hz reel frequency, sees "
        "the impact, not the slow push of the run-out that follows it;",
        "* **AE proxy, energy rate** `(1/T) sum_i m v_i^2 / 2` (W): the kinetic energy brought into contacts per "
        "second; an AE sensor's rms voltage squared measures an energy rate (section 4, ref. [11]);",
        "* **impact rate**: contacts per second (a slow entry into a stiff spring flange bounces: several "
        "contacts per push are counted);",
        "* **rms contact force** `sqrt((1/T) int f^2 dt)` (Fig. 3(c) shows it over a moving window: "
        "`impactosc.results.moving_rms_force`).", ""]


def _lead_section(s: dict) -> list[str]:
    le, lb, sc = s["lead"], s["lead_bound"], s["lead_scan"]
    return [
        "## 3. The lead, derived and tested", "",
        "A quasi-static tape (Omega = omega_r/omega_n << 1) follows the reel, x = A cos(omega_r t), shifted by the "
        "friction dead band mu N/k. It reaches the flange where x = c = L + mu N/k, cos(phi_c) = c/A, with speed "
        "A omega_r sin(phi_c) = **omega_r sqrt(A^2 - c^2)** (the issue's formula with c for L: friction delays "
        "the contact). One impact per turn and flange at elastic peak sqrt(k0 m) v gives the per-second sum "
        "2 (omega_r/2pi) sqrt(k0 m) omega_r sqrt(A^2 - c^2), proportional to V^2 sqrt(A^2 - c^2)/D^2 "
        "(`lead_ae_proxy`). With A = a D its maximum over D is at a^2 D^2 = 2 c^2, **A = sqrt(2) c** (the issue's "
        "claim, correct for a run-out proportional to D). Fig. 6's law is affine, A = A0 + s D with "
        f"A0 = {le['runout_at_zero_m'] * 1e6:.1f} um: then A^2 + A0 A - 2 c^2 = 0 (`lead_peak_runout`). Checked "
        f"on a drive with c = {le['c_m'] * 1e6:.2f} um: formula A* = {le['peak_runout_formula_m'] * 1e6:.3f} um, "
        f"numerical maximum over 20001 diameters {le['peak_runout_numeric_m'] * 1e6:.3f} um (the proportional "
        f"law would say {le['peak_runout_proportional_law_m'] * 1e6:.3f} um).", "",
        "**What the lead allows.** In it the tension enters only through c. Every curve peaks in the middle third "
        f"of the pack only if c lies in [{lb['c_lo'] * 1e6:.1f}, {lb['c_hi'] * 1e6:.1f}] um for every tension, so "
        "the pack-averaged ratio between T sin(theta/2) = 0.1 and 0.7 N is at most its value with c at the two "
        f"ends of that band: **{lb['ratio']:.3f}** -- barely above the 1.5 of 'almost double', and only if mu N/k "
        "spans exactly the band (a span stiffness k = 2 mu (0.7 - 0.1) N / (c_hi - c_lo)). At the ends of the band "
        "the peak sits at the edge of the middle third, where the 10 % margin over the full-pack value fails.", "",
        f"Closed-form scan of the lead (`lead_scan`, {sc['points']} points: span 10-100 mm x clearance 5-150 um"
        f"{' x mu 0.1, 0.2, 0.3' if not s['quick'] else ', mu = 0.2, 5 x 5 in quick mode'}, 15 diameters, "
        "the Fig. 8 grid): mid pack "
        f"{sc['mid_pack']}, speed {sc['speed']}, tension {sc['tension']}, double {sc['double']}; mid pack and "
        f"double together **{sc['mid_pack_and_double']}**; three or more trends {sc['three']}; **all four "
        f"{sc['all_four']}**.", ""]


def _candidates_section(s: dict) -> list[str]:
    lines = ["## 4. Candidate models: which trends each observable gives", ""]
    for name, c in s["candidates"].items():
        meta = CANDIDATES.get(name) or PATH_CANDIDATES[name]
        lines.append(f"* **{name}** -- {meta['title']}. Fields changed: `{c['fields']}`. Ranges: {meta['source']}. "
                     f"Failed points: {c['n_errors']}.")
    if s["quick"]:
        lines.append("* *short_clearance* is left out of quick mode (its creep at 91 kHz costs minutes).")
    lines += ["", "Common ranges: speed 4-12 m/s and T sin(theta/2) 0.1-0.7 N at theta = 60 deg (Fig. 7-8, "
              "section 5), run-out 60-180 um linear in the pack diameter between an assumed 44 mm hub and 97 mm "
              "full pack (Fig. 6; the diameters are not in the paper), mu = 0.2 (section 5, refs. [19, 20]) unless "
              "stated.", ""]
    lines += _header()
    for name, c in s["candidates"].items():
        for obs in STUDY_OBSERVABLES:
            lines.append(_trend_row(name, obs, c))
    lines += ["", "'curves peaking mid pack': the share of the (speed, T sin) curves that meet the mid-pack rule "
              "(the criterion wants all of them).", ""]
    lines += _path_section(s)
    return lines


def _path_section(s: dict) -> list[str]:
    """The tape-path candidates: why their trends hold or not, from :func:`._study_run._path_summary`."""
    paths = s.get("tape_path", {})
    if not paths:
        return []
    lines = ["**The tape path** (`impactosc.TapePath`: a chain of guides, eq. 4 per span, eq. 5 per guide, the "
             "pack's run-out of Fig. 6 at its end; the sensor is the flanged guide nearest the pack, "
             "`impactosc.paper._study_path`). Its AE proxy uses that guide's flange stiffness and lumped mass, "
             "sqrt(k0 m_0) v; its rms force is not computed (no streamed integral of the squared force on the "
             "n-DOF backend), so that row holds nothing by construction.", ""]
    for name, p in paths.items():
        failed = p["failed_by_t_sin"]
        n_failed = sum(failed.values())
        rising = p["rising_over_pack"]
        effect = p["tension_effect"]
        lines.append(
            f"* `{name}`: {n_failed} of {p['points']} points failed "
            f"({', '.join(f'{n} at T sin = {ts} N' for ts, n in failed.items())}). "
            "Largest change between tensions at one pack diameter and speed (where two or more ran), relative "
            "to the largest value: "
            + ", ".join(f"{STUDY_OBSERVABLES[o][0]} {v:.2g}" for o, v in effect.items()) + ". Curves rising at "
            "every step over the pack: "
            + ", ".join(f"{STUDY_OBSERVABLES[o][0]} {r['rising']}/{r['curves']}" for o, r in rising.items()) + ".")
    lines += ["", "Without friction the tension enters a tape path nowhere (eq. 5's normal force acts only through "
              "friction; the spans of eq. 4 do not depend on T), so its observables are the same at every tension "
              "(the change above is zero) and the tension and doubling trends cannot hold. With friction on a "
              "guide the tension acts through that guide's friction (eq. 5). A point counted as failed is a run "
              "that did not reach its end (its message is in the JSON): the trends it would decide are not "
              "decided by this study.", ""]
    return lines


def _search_section(s: dict) -> list[str]:
    g = s["search_grid"]
    best = s["best"]
    lines = ["## 5. The search", "",
             f"The in-plane reading of eq. 4 (the tape bends in its own plane, k = 48 E h w^3 / (12 l^3)) with the "
             f"paper's mu = 0.2, over span l = {', '.join(f'{x * 1e3:g}' for x in g['free_length_m'])} mm "
             "(assumption: the free span between reel and roller of a cartridge drive, 10-100 mm; 10 mm is the "
             "paper's own candidate above, and spans under 30 mm creep at >= 60 kHz, which costs minutes per cell) "
             "x clearance "
             f"L = {', '.join(f'{x * 1e6:g}' for x in g['clearance_m'])} um (assumption: tens of um, a guide holds "
             f"the tape to a fraction of a track): {g['cells']} cells, each on the quick grid (5 diameters x 3 "
             f"speeds x T sin = 0.1, 0.7 N), all points by the exact backend through the runner "
             f"({s['search_wall_s']:.0f} s wall). {_lead_region(s)} Map: `figures/fig4_study_search.png`.", ""]
    lines += _header()
    for name, c in s["search"].items():
        for obs in STUDY_OBSERVABLES:
            if sum(c["trends"][obs].values()) >= 3 or c["mid_pack_curves"][obs] >= 0.5:
                lines.append(_trend_row(name, obs, c))
    n_all = sum(all(c["trends"][o].values()) for c in s["search"].values() for o in STUDY_OBSERVABLES)
    most_mid = max(((c["mid_pack_curves"][o], n, o) for n, c in s["search"].items() for o in STUDY_OBSERVABLES))
    bs = s["best_search"]
    lines += ["", f"(rows with three or more trends, or with at least half the curves peaking mid pack). Cells x "
              f"observables with all four: **{n_all}** of {len(s['search']) * len(STUDY_OBSERVABLES)}. Largest share "
              f"of mid-pack curves in a cell: {most_mid[0]:.0%} (`{most_mid[1]}`, "
              f"{STUDY_OBSERVABLES[most_mid[2]][0]}).", "",
              f"**Best search cell**: `{bs['model']}` with the {STUDY_OBSERVABLES[bs['observable']][0]}: "
              f"{', '.join(k for k, v in bs['trends'].items() if v) or 'none'} hold.", "",
              f"**Best overall** (most trends, ties to the AE proxy, then to the first listed): `{best['model']}` with "
              "the "
              f"{STUDY_OBSERVABLES[best['observable']][0]}, fields `{best['fields']}`: "
              f"{', '.join(k for k, v in best['trends'].items() if v) or 'none'} hold.", ""]
    if s["sensitivity_neighbours"]:
        lines.append(f"Sensitivity: trends held by the search cells around `{bs['model']}`, same observable: " +
                     ", ".join(f"{k}: {v}" for k, v in s["sensitivity_neighbours"].items()) + ".")
    if s["sensitivity_friction"]:
        lines.append("Friction (an assumed number) halved and doubled, trends held: " + ", ".join(
            f"{k}: {', '.join(kk for kk, vv in v.items() if vv) or 'none'}" for k, v in
            s["sensitivity_friction"].items()) + ".")
    lines.append("")
    if s["refine"]:
        lines += [f"**Second stage, aimed by the lead**: a 3 x 3 grid over the lead's cells with a mid-pack maximum "
                  f"and a tension effect ({s['refine_wall_s']:.0f} s wall):", ""]
        lines += _header()
        for name, c in s["refine"].items():
            for obs in ("ae_impact_sum", "impact_energy_rate", "impact_rate"):
                lines.append(_trend_row(name, obs, c))
        lines.append("")
    return lines


def _lead_region(s: dict) -> str:
    region = s["lead_scan"].get("mid_pack_and_tension_region")
    if not region:
        return "The closed-form lead (section 3) has no cell with both a mid-pack maximum and a tension effect."
    (l0, l1), (c0, c1), (m0, m1) = region["free_length"], region["clearance"], region["friction"]
    return (f"The closed-form lead (section 3) aims it: its cells with both a mid-pack maximum and a tension effect "
            f"lie at l = {l0 * 1e3:.3g}-{l1 * 1e3:.3g} mm, L = {c0 * 1e6:.3g}-{c1 * 1e6:.3g} um "
            f"(mu {m0:g}-{m1:g}).")


def _onset_section(s: dict) -> list[str]:
    on = s["onset"]
    if on["model"] is None:
        return ["## 6. Contact onset in SI parameters", "", "No search cell starts contact inside the pack.", ""]
    lines = ["## 6. Contact onset in SI parameters", "",
             f"Search cell `{on['model']}` (the best whose contact starts inside the pack) at V = 8 m/s: the pack "
             "diameter above which the tape touches a "
             "flange, found "
             "by `impactosc.dynamics.contact_onset(drive, 'pack_diameter', ..., backend='exact')` on the drive's SI "
             "parameter -- by continuation (the period-1 orbit followed from the hub to its grazing) and by the "
             "transient search (steady states bracketed and refined) -- against the quasi-static closed form "
             "runout(D) = L + mu N/k. Each steady state starts from a transient of 3 reel turns (a quasi-static "
             "tape settles within one; with the default 200 turns of creep one transient search did not finish "
             "in 5 minutes on this loaded machine).", "",
             "| T sin(theta/2) [N] | c = L + mu N/k [um] | closed form D [mm] | continuation D [mm] | transient D [mm] "
             "| wall [s] |",
             "| --- | --- | --- | --- | --- | --- |"]

    def cell(r, method):
        res = r.get(method)
        if not res:
            return "-"
        v = res["onset_m"]
        return f"{v * 1e3:.4f}" if v is not None and math.isfinite(v) else f"status {res['status']}"

    for r in on["rows"]:
        walls = " / ".join(f"{r[m]['wall_s']:.0f}" for m in ("continuation", "transient") if m in r)
        lines.append(f"| {r['t_sin_half_theta']:g} | {r['c_m'] * 1e6:.2f} | {r['closed_form_m'] * 1e3:.4f} | "
                     f"{cell(r, 'continuation')} | {cell(r, 'transient')} | {walls or '-'} |")
    lines += ["", "The onset moves up the pack with tension (c grows by mu N/k): below it every observable is zero, "
              "which is how tension acts in the in-plane models here.", ""]
    return lines


def study_report_text(s: dict) -> str:
    """The report's markdown, from :func:`impactosc.paper.study`'s summary."""
    best = s["best"]
    lines = ["# What the sensor saw: the four trends of Fig. 4", "",
             f"Generated by `impactosc paper --study{' --quick' if s['quick'] else ''}` "
             f"(`impactosc.paper.study`), {s['wall_s']:.0f} s wall. Machine: {s['machine']}.", "",
             "The paper's figures are not available here as data (the text in `/work/shared/paper` has their "
             "captions only), so the paper's side is its stated trends: Fig. 4 (measured) 'reaches a maximum when "
             "the tape reel diameter is halfway', 'increases with increasing tape speed and decreasing tape tension'; "
             "Fig. 8 (its model) 'the impact for T sin(theta/2) = 0.1 is almost double the value for 0.7'. "
             "Nothing below is tuned to a figure: every parameter is from the paper, from a stated assumption, or a "
             "cell of the search.", ""]
    lines += _criteria_section()
    lines += _observables_section()
    lines += _lead_section(s)
    lines += _candidates_section(s)
    lines += _search_section(s)
    lines += _onset_section(s)
    lines += ["## 7. Side by side", "",
              f"`figures/fig4_study_best.png`: the best model (`{best['model']}`, "
              f"{STUDY_OBSERVABLES[best['observable']][0]}) in the layout of Fig. 4/7 (left: colour = speed, "
              "solid = T sin 0.1 N, dashed = 0.7 N) and of Fig. 8 (a panel per speed). Paper, for comparison "
              "(stated trends): Fig. 4 mid-pack maximum, up with speed, down with tension; Fig. 7-8 the same and "
              "0.1 N ~ 2 x 0.7 N. Best model: " +
              ", ".join(f"{k} {_mark(v)}" for k, v in best["trends"].items()) + ".", ""]
    lines += _conclusion(s)
    lines += ["## Files", "", "* `fig4_study.json`: every number of this report; `fig4_study.csv`: every simulated "
              "point (model, observable, pack diameter, speed, T sin(theta/2), value).",
              "* `figures/fig4_study_best.png`, `figures/fig4_study_search.png`.", ""]
    return "\n".join(lines)


def _max_mid(s: dict) -> float:
    return max(c["mid_pack_curves"][o] for part in ("candidates", "search", "refine") for c in s[part].values()
               for o in STUDY_OBSERVABLES)


def _conclusion(s: dict) -> list[str]:
    n_all = sum(all(c["trends"][o].values()) for part in ("candidates", "search", "refine")
                for c in s[part].values() for o in STUDY_OBSERVABLES)
    best = s["best"]
    held = [k for k, v in best["trends"].items() if v]
    lines = ["## 8. Conclusion and its uncertainty", ""]
    if n_all:
        lines.append(f"**{n_all} model/observable combination(s) hold all four trends** (tables above); the region "
                     "is as large as the cells listed, at the grid's resolution.")
    else:
        lines.append("**No model and observable of this study holds all four trends.** The best, "
                     f"`{best['model']}` with the {STUDY_OBSERVABLES[best['observable']][0]}, holds "
                     f"{len(held)} ({', '.join(held) or 'none'}).")
    lines += [
        "",
        "Why, in one line each: the time-averaged force of a quasi-static tape grows monotonically with the "
        "run-out and does not see the speed; impact-based observables grow with speed (entry speed and rate both "
        "scale with omega_r) and can peak inside the pack, but their peak sits where the run-out is about "
        "sqrt(2) (L + mu N/k), so a tension large enough to halve them also moves the peak out of the middle "
        "third (section 3's bound on the ratio); the plate-bending reading has the dynamics but not the "
        "mid-pack maximum (as the reproduction found); a frictionless tape path does not see the tension at all, "
        "and one with friction could not be run at the low tension on the n-DOF exact backend (section 4).",
        "",
        "Uncertainty: the criteria's margins (10 %, [1.5, 2.5]) and the middle-third window are readings of a "
        "figure's words; the assumed hub and full-pack diameters set where 'mid pack' is; the run-out law is a "
        "straight line through two numbers read from Fig. 6; mu is the paper's 'typical' value (halved and "
        "doubled above); the grids are coarse (5-7 diameters). Impact-based observables of a creeping tape depend "
        "on the phase of its stick-slip cycle when it reaches the flange (a creeping tape slips in bursts at its "
        "natural frequency, at up to twice its drift speed), which the steady state fixes differently at each "
        f"grid point: their curves over the pack are ragged (at most {_max_mid(s):.0%} of a model's curves peak "
        "mid pack), and "
        f"{MEASURED_TURNS} turns of a locked steady state do not average it out; a real drive's noise would. "
        "The AE proxies are proxies: the sensor's transfer function is unknown.",
        ""]
    return lines
