"""Work-precision study: heyoka, scipy and the paper's RK4 against the exact backend.

Run: ``.venv/bin/python benchmarks/work_precision.py [--quick] [--out DIR]``.

For each case every method is swept over its accuracy knob (heyoka ``tol``, scipy ``rtol``
with ``atol = rtol``, RK4 ``dt``) and measured against ``backend="exact"`` on:

* the largest error in contact entry times, contacts matched one-to-one by order and side
  (when the contact sequences differ the row says "wrong sequence" and the count mismatch);
* the largest relative error in the peak flange force of an impact (same matching);
* the relative error in the mean flange force over the run (for the tape case, whose exact
  answer has no contact at all, the absolute mean flange force, 0 for exact);
* whether the event sequence (kinds and sides) is the exact one (tape case: event counts);

against the wall time, the median of repeats: each row runs once (its errors come from
that run), then the repeats run round by round over all rows, so that the load of a shared
machine weighs on every row alike. heyoka's compile time (the one loop's integrator of the
case's member built afresh, ``_timing.cold_compile``, with heyoka's in-memory and on-disk caches
of compiled code bypassed) and
numba's (a warm-up call) are measured apart and not in the wall times.

Writes ``work_precision.md`` (one table per case, then the targets), one
``work_precision_<case>.png`` per case and ``work_precision.json`` into ``--out``
(default ``benchmarks/results``; with ``--quick`` ``benchmarks/results/quick``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import impactosc as io

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the shared _timing module beside this script
from _timing import Timeout, cold_compile, timed  # noqa: E402

HERE = Path(__file__).resolve().parent
EPS = 2.0**-52  # heyoka's default tol
FLOOR = 1e-17  # zero errors are drawn at this level on the log plots


@dataclass
class Case:
    key: str
    title: str
    osc: io.Oscillator
    t_end: float
    x0: float = 0.95
    v0: float = 0.0
    tape: bool = False  # exact answer without contact: compare |mean force| and counts
    period: float = 0.0  # RK4 step unit (contact period, or the free period for the tape case)
    period_name: str = ""


def make_cases(quick: bool) -> list[Case]:
    contact = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
    stick = io.Oscillator(F=2.0, Omega=0.05, beta=0.05, K=1e4)
    stiff = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e6)
    drive = io.TapeDrive()
    t = 20.0 if quick else 400.0
    t_tape = drive.seconds_to_lambda(0.002 if quick else 1.0)

    def tc(osc):
        return 2 * math.pi / math.sqrt(1 + osc.K)

    return [
        Case("a", f"(a) contact case F=0.5, Omega=1.1, beta=0.01, K=1e4, x0=0.95, t_end={t:g}", contact, t,
             period=tc(contact), period_name="T_c"),
        Case("b", f"(b) forced stick-slip with contacts F=2, Omega=0.05, beta=0.05, K=1e4, x0=0.95, t_end={t:g}",
             stick, t, period=tc(stick), period_name="T_c"),
        Case("c", f"(c) stiff flange F=0.5, Omega=1.1, beta=0.01, K=1e6, x0=0.95, t_end={t:g}", stiff, t,
             period=tc(stiff), period_name="T_c"),
        Case("d", f"(d) paper's tape case, default TapeDrive ({'2 ms' if quick else '1 s'}), "
                  f"F={drive.F:.4g}, Omega={drive.Omega:.4g}, beta={drive.beta:.4g}, K={drive.K:g}, "
                  f"t_end={t_tape:.6g}, record='stats'",
             drive.oscillator(), t_tape, tape=True, period=2 * math.pi, period_name="T_free"),
    ]


# -- settings of the sweep -------------------------------------------------------------
def sweeps(quick: bool, tape: bool):
    """(method label, backend, list of (setting label, options)) for one case."""
    if quick:
        tols = [1e-8, EPS]
        rtols = {"DOP853": [1e-10], "RK45": [1e-8]}  # looser ones hit slow paths of the scipy backend
        steps = [10, 100]
    else:
        tols = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14, EPS]
        rtols = {"DOP853": [1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-13],
                 "RK45": [1e-4, 1e-6, 1e-8, 1e-10]}
        steps = [10, 20, 30, 50, 100, 200, 300, 1000, 3000]
        if tape:
            rtols = {"DOP853": [1e-4, 1e-6, 1e-8, 1e-10], "RK45": [1e-4, 1e-6]}
            steps = [10, 30, 100, 300, 1000, 3000]
    out = [("heyoka", "heyoka", [(f"tol={'eps' if t == EPS else f'{t:.0e}'}", {"tol": t}) for t in tols])]
    for m, rs in rtols.items():
        out.append((f"scipy {m}", "scipy", [(f"rtol={r:.0e}", {"method": m, "rtol": r, "atol": r}) for r in rs]))
    rk = [(f"dt=T/{n}", {"n": n}) for n in steps]
    if tape and not quick:
        rk.append(("dt=default (T_c/100)", {"n": None}))  # the backend's default step, 1e4 per free period
    out.append(("rk4", "rk4", rk))
    return out


# -- timing ------------------------------------------------------------------------------


# -- comparison with the exact answer ---------------------------------------------------
@dataclass
class Row:
    method: str
    setting: str
    wall: float = math.nan  # s, median
    best: float = math.nan  # s, fastest repeat
    repeats: int = 0
    mean_force: float = math.nan  # relative error (tape case: absolute mean force)
    contact_t: float = math.nan  # max abs error in contact entry times
    peak_force: float = math.nan  # max rel error in peak flange force
    contacts_ok: bool = False
    seq_ok: bool = False
    n_events: int = 0
    counts: dict = field(default_factory=dict)
    note: str = ""


def compare(case: Case, sol, ref, row: Row) -> None:
    row.counts = dict(sol.counts)
    row.n_events = sum(sol.counts.values())
    if sol.status != 0:
        row.note = (row.note + f" status {sol.status}: {sol.message.split(';')[0]}").strip()
    m, m_ex = sol.mean_flange_force(), ref.mean_flange_force()
    if case.tape:
        row.mean_force = abs(m - m_ex) if m_ex == 0.0 else abs(m - m_ex) / abs(m_ex)
        row.seq_ok = sol.counts == ref.counts
        row.contacts_ok = (sol.counts["contact_start"] == ref.counts["contact_start"])
        return
    row.mean_force = abs(m - m_ex) / abs(m_ex)
    ev, ex = sol.events, ref.events
    row.seq_ok = bool(len(ev) == len(ex) and np.array_equal(ev.kind, ex.kind) and np.array_equal(ev.side, ex.side))
    cs, cx = ev[ev.kind == "contact_start"], ex[ex.kind == "contact_start"]
    row.contacts_ok = bool(len(cs) == len(cx) and np.array_equal(cs.side, cx.side))
    if row.contacts_ok and len(cx):
        row.contact_t = float(np.max(np.abs(cs.t - cx.t)))
    elif not row.contacts_ok:
        row.note = (row.note + f" wrong contact sequence: {len(cs)} contacts vs {len(cx)} exact").strip()
    ip, ix = sol.impacts, ref.impacts
    if len(ip) == len(ix) and np.array_equal(ip.side, ix.side) and len(ix):
        row.peak_force = float(np.max(np.abs(ip.peak_force - ix.peak_force) / np.abs(ix.peak_force)))


def ms(x: float) -> str:
    return "-" if math.isnan(x) else f"{x * 1e3:.4g}"


def fmt(x: float, digits: int = 1) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if x == 0:
        return "0"
    return f"{x:.{digits}e}"


# -- one case ------------------------------------------------------------------------------
def run_case(case: Case, args) -> tuple[list[Row], dict]:
    """Every method and setting of ``case``: one run each for the errors, then interleaved repeats.

    The repeats run round by round over all rows (a row drops out once its runs took more
    than ``--budget`` seconds), so that the load of a shared machine weighs on every row alike.
    """
    from impactosc.backends import rk4 as rb

    record = "stats" if case.tape else "events"
    load0 = os.getloadavg()
    reps, budget = (1, 0.0) if args.quick else (args.repeats, args.budget)

    def sim(backend, t_end=case.t_end, **opt):
        return io.simulate(case.osc, t_end, case.x0, case.v0, backend=backend, record=record, **opt)

    def exact_run():
        return sim("exact")

    ref_t, _, ref = timed(exact_run, 1, math.inf, 0)
    info = {"exact_counts": dict(ref.counts), "exact_mean_force": ref.mean_flange_force(), "compile": {}}
    rows: list[Row] = [Row("exact", "-", mean_force=0.0, contact_t=math.nan if case.tape else 0.0,
                           peak_force=math.nan if case.tape else 0.0, contacts_ok=True, seq_ok=True,
                           n_events=sum(ref.counts.values()), counts=dict(ref.counts))]
    # row -> (the timed call, its time scale (extrapolated rk4 prefixes), its samples, scipy's alarm)
    timing = {id(rows[0]): (exact_run, 1.0, [ref_t], 0)}
    refs = {case.t_end: ref}
    for label, backend, points in sweeps(args.quick, case.tape):
        skip = False
        for setting, opt in points:
            row = Row(label, setting)
            rows.append(row)
            if skip:
                row.note = "skipped: a looser setting timed out"
                continue
            t_end = case.t_end
            if backend == "heyoka":
                tol = opt["tol"]
                if tol not in info["compile"]:
                    # A cold compile: heyoka's in-memory and on-disk caches of compiled code are bypassed.
                    info["compile"][tol] = cold_compile(case.osc, tol)
                sim("heyoka", t_end=1e-3, tol=tol)  # builds the cached integrator (not timed)
            elif backend == "rk4":
                dt = case.period / opt["n"] if opt["n"] else rb.default_dt(case.osc.K)
                opt = {"dt": dt}
                if "numba" not in info["compile"]:
                    t0 = time.perf_counter()
                    sim("rk4", t_end=min(case.t_end, 10 * dt), dt=dt)
                    info["compile"]["numba"] = time.perf_counter() - t0
                n_steps = case.t_end / dt
                if n_steps > args.rk4_max_steps:
                    # Too slow for the full run: time a prefix and extrapolate linearly.
                    frac = args.rk4_max_steps / n_steps
                    t_end = case.t_end * frac
                    row.note = (f"extrapolated: ran {frac:.2g} of t_end ({t_end:.4g}), time scaled by 1/{frac:.2g}, "
                                f"errors over that prefix")
            elif "scipy_warm" not in info:
                sim("scipy", t_end=1e-2, method="DOP853")  # imports scipy (not timed)
                info["scipy_warm"] = True

            def run(b=backend, o=opt, te=t_end):
                return sim(b, t_end=te, **o)

            alarm = args.timeout if backend == "scipy" else 0
            try:
                wall, _, sol = timed(run, 1, math.inf, alarm)
            except Timeout:
                row.note = f"timeout: one run took more than {args.timeout:g} s"
                row.wall = args.timeout
                skip = True
                continue
            if t_end != case.t_end and t_end not in refs:
                refs[t_end] = sim("exact", t_end=t_end)
            timing[id(row)] = (run, case.t_end / t_end, [wall], alarm)
            compare(case, sol, refs[t_end], row)
            print(f"  {case.key} {label:<13} {setting:<12} {wall * case.t_end / t_end * 1e3:10.2f} ms (first run)  "
                  f"mean {fmt(row.mean_force)}  t_c {fmt(row.contact_t)}  seq {row.seq_ok}  {row.note}", flush=True)
    # The repeats, round by round over every row that ran.
    for _ in range(reps - 1):
        for row in rows:
            if id(row) not in timing:
                continue
            run, _, samples, alarm = timing[id(row)]
            if sum(samples) <= budget:
                try:
                    samples.append(timed(run, 1, math.inf, alarm)[0])
                except Timeout:  # the machine got slower than the first run: keep the samples so far
                    pass
    for row in rows:
        if id(row) in timing:
            _, scale, samples, _ = timing[id(row)]
            row.wall, row.best, row.repeats = scale * float(np.median(samples)), scale * min(samples), len(samples)
    info["exact_wall"], info["exact_repeats"] = rows[0].wall, rows[0].repeats
    info["load"] = (load0, os.getloadavg())
    return rows, info


# -- output --------------------------------------------------------------------------------
def table(case: Case, rows: list[Row], info: dict) -> str:
    comp = ", ".join(f"tol={'eps' if k == EPS else f'{k:.0e}'}: {v:.2f} s" for k, v in info["compile"].items()
                     if k != "numba")
    l0, l1 = info["load"]
    lines = [f"## {case.title}", "",
             f"Exact: {info['exact_counts']}, mean flange force {info['exact_mean_force']:.16g}; "
             f"load average {l0[0]:.2f} at the start, {l1[0]:.2f} at the end.",
             f"Compile times (not in the wall times): heyoka {comp}; numba warm-up "
             f"{info['compile'].get('numba', math.nan):.2f} s. RK4 steps are in units of "
             f"{case.period_name} = {case.period:.6g}.", ""]
    if case.tape:
        lines += ["| method | setting | wall [ms] | best [ms] | n | abs mean flange force | reversals | sticks "
                  "| releases | contacts | counts right | note |",
                  "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |"]
        for r in rows:
            c = r.counts
            lines.append(f"| {r.method} | {r.setting} | {ms(r.wall)} | {ms(r.best)} | {r.repeats} | "
                         f"{fmt(r.mean_force)} | {c.get('reversal', '-')} | {c.get('stick', '-')} | "
                         f"{c.get('release', '-')} | {c.get('contact_start', '-')} | "
                         f"{('yes' if r.seq_ok else 'no') if c else '-'} | {r.note} |")
    else:
        lines += ["| method | setting | wall [ms] | best [ms] | n | mean force rel err | contact entry max err "
                  "| peak force max rel err | event sequence | events | note |",
                  "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: | --- |"]
        for r in rows:
            seq = "right" if r.seq_ok else ("wrong (contacts right)" if r.contacts_ok else "wrong sequence")
            if not r.counts:
                seq = "-"
            lines.append(f"| {r.method} | {r.setting} | {ms(r.wall)} | {ms(r.best)} | {r.repeats} | "
                         f"{fmt(r.mean_force)} | {fmt(r.contact_t)} | {fmt(r.peak_force)} | {seq} | "
                         f"{r.n_events if r.counts else '-'} | {r.note} |")
    return "\n".join(lines) + "\n"


def plot(case: Case, rows: list[Row], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    styles = {"heyoka": "o-", "scipy DOP853": "s-", "scipy RK45": "^-", "rk4": "d-"}
    for method, style in styles.items():
        rs = [r for r in rows if r.method == method and r.counts]
        if not rs:
            continue
        w = np.array([r.wall for r in rs])
        e1 = np.array([max(r.mean_force, FLOOR) for r in rs])
        axes[0].loglog(w, e1, style, label=method)
        if case.tape:
            e2 = np.array([sum(abs(r.counts[k] - rows[0].counts[k]) for k in ("stick", "release", "reversal"))
                           for r in rs], dtype=float)
            axes[1].plot(w, np.maximum(e2, 0.5), style, label=method)
        else:
            ok = np.array([r.contacts_ok for r in rs])
            e2 = np.array([max(r.contact_t, FLOOR) if r.contacts_ok else np.nan for r in rs])
            axes[1].loglog(w, e2, style, label=method)
            if (~ok).any():
                axes[1].loglog(w[~ok], np.full((~ok).sum(), 1.0), "x", color="red", ms=9,
                               label=f"{method}: wrong contact sequence" if method == "rk4" else None)
    ex = rows[0]
    for ax in axes:
        ax.axvline(ex.wall, color="gray", ls=":", label=f"exact backend ({ex.wall * 1e3:.3g} ms)")
        ax.set_xscale("log")
        ax.set_xlabel("wall time [s] (median of repeats, compile excluded)")
        ax.grid(True, which="both", alpha=0.3)
    if case.tape:
        axes[0].set_ylabel(f"|mean flange force| (exact: 0; 0 drawn at {FLOOR:g})")
        axes[1].set_yscale("log")
        axes[1].set_ylabel("|stick|+|release|+|reversal| count error (0 drawn at 0.5)")
    else:
        axes[0].set_ylabel(f"relative error of the mean flange force (0 drawn at {FLOOR:g})")
        axes[1].set_ylabel("max error of contact entry times (x: wrong sequence)")
    axes[0].legend(fontsize=8)
    axes[1].legend(fontsize=8)
    fig.suptitle(case.title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def targets(case: Case, rows: list[Row]) -> list[str]:
    """The targets for one case, measured (speed-ups from medians; best-of-repeats in brackets)."""
    def pick(method, setting):
        return next((r for r in rows if r.method == method and r.setting == setting), None)

    def speedup(slow: Row, fast: Row) -> str:
        return f"{slow.wall / fast.wall:.3g}x ({slow.best / fast.best:.3g}x best-of-repeats)"

    def met(ok: bool) -> str:
        return "met" if ok else "MISSED"

    hy = pick("heyoka", "tol=eps")
    rk = pick("rk4", "dt=default (T_c/100)" if case.tape else "dt=T/100")
    sp = pick("scipy DOP853", "rtol=1e-10")
    out = [f"**Case {case.key}**"]
    if hy is None or not hy.counts:
        return out + ["- heyoka at default tol did not run"]
    if case.tape:
        out.append(f"- heyoka tol=eps: |mean flange force| {fmt(hy.mean_force)} (exact 0), counts "
                   f"{'identical' if hy.seq_ok else 'DIFFERENT'} to exact; wall {ms(hy.wall)} ms")
    else:
        out.append(f"- heyoka tol=eps: mean flange force rel err {fmt(hy.mean_force)} (target 1e-10: "
                   f"{met(hy.mean_force <= 1e-10)}), contact entry times {fmt(hy.contact_t)} "
                   f"(target 1e-12: {met(hy.contact_t <= 1e-12)}), sequence "
                   f"{'right' if hy.seq_ok else 'WRONG'}; wall {ms(hy.wall)} ms (best {ms(hy.best)} ms)")
    if rk is not None and rk.counts:
        out.append(f"- vs RK4 at its default step (T_c/100, {ms(rk.wall)} ms, error {fmt(rk.mean_force)}, sequence "
                   f"{'right' if rk.seq_ok else 'wrong'}): {speedup(rk, hy)} faster "
                   f"(target 10x: {met(rk.wall / hy.wall >= 10)})")
    if sp is not None and sp.counts:
        out.append(f"- vs scipy DOP853 rtol=1e-10 ({ms(sp.wall)} ms, error {fmt(sp.mean_force)}): {speedup(sp, hy)} "
                   f"faster (target 10x: {met(sp.wall / hy.wall >= 10)})")
    elif sp is not None:
        to = next((r for r in rows if r.method == "scipy DOP853" and r.note.startswith("timeout")), None)
        if to is not None:
            out.append(f"- vs scipy DOP853 rtol=1e-10: not run, DOP853 already took more than {to.wall:g} s at "
                       f"{to.setting}: heyoka more than {to.wall / hy.wall:.3g}x faster (target 10x: met)")
        else:
            out.append(f"- vs scipy DOP853 rtol=1e-10: not measured ({sp.note})")
    if not case.tape:
        rks = [r for r in rows if r.method == "rk4" and r.counts]
        ok = [r for i, r in enumerate(rks) if all(q.mean_force <= 1e-6 for q in rks[i:])]
        if ok:
            r = ok[0]
            hys = [h for h in rows if h.method == "heyoka" and h.counts and h.mean_force <= 1e-6 and h.seq_ok]
            fastest = min(hys, key=lambda h: h.wall) if hys else hy
            out.append(f"- equal accuracy: RK4 reaches 1e-6 in the mean flange force from {r.setting} on "
                       f"({fmt(r.mean_force)}, {ms(r.wall)} ms): heyoka at tol=eps {speedup(r, hy)} faster "
                       f"(target 100x: {met(r.wall / hy.wall >= 100)}); the fastest heyoka setting within 1e-6 "
                       f"({fastest.setting}, {fmt(fastest.mean_force)}) {speedup(r, fastest)} faster")
        else:
            out.append("- equal accuracy: RK4 does not reach 1e-6 in the mean flange force at any tested step "
                       f"(finest: {fmt(rks[-1].mean_force) if rks else '-'}); target 100x not applicable")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="short runs, two points per method (smoke test)")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default benchmarks/results)")
    ap.add_argument("--cases", default="abcd", help="which cases to run (letters), default abcd")
    ap.add_argument("--repeats", type=int, default=5, help="repeats per point (median), default 5")
    ap.add_argument("--budget", type=float, default=4.0,
                    help="stop repeating a point after this many seconds (at least one run), default 4")
    ap.add_argument("--timeout", type=float, default=60.0, help="give up on one scipy run after this many s")
    ap.add_argument("--rk4-max-steps", type=float, default=4e8,
                    help="RK4 runs needing more steps are timed on a prefix and extrapolated")
    args = ap.parse_args(argv)
    if args.quick:
        args.timeout = min(args.timeout, 20.0)
    out = args.out or (HERE / "results" / ("quick" if args.quick else ""))
    out.mkdir(parents=True, exist_ok=True)

    header = [
        "# Work-precision study", "",
        f"Generated by `benchmarks/work_precision.py{' --quick' if args.quick else ''}` on "
        f"{time.strftime('%Y-%m-%d %H:%M')}, {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}, numpy {np.__version__}; "
        f"load average at start {os.getloadavg()[0]:.2f}.",
        "Errors against `backend=\"exact\"`. Wall times: median of `n` repeats, run round by round over all "
        f"rows of a case (a row stops repeating once its runs took more than {args.budget:g} s), compile times "
        "excluded and reported per case. "
        "Contact entry times and peak forces are matched one-to-one by order and side.", ""]
    body, summary, raw = [], ["## Targets", ""], {}
    for case in make_cases(args.quick):
        if case.key not in args.cases:
            continue
        print(f"case {case.title}", flush=True)
        rows, info = run_case(case, args)
        body.append(table(case, rows, info))
        body.append(f"![work-precision {case.key}](work_precision_{case.key}.png)\n")
        plot(case, rows, out / f"work_precision_{case.key}.png")
        summary += targets(case, rows) + [""]
        raw[case.key] = {"title": case.title, "info": {k: (v if k != "compile" else {str(a): b for a, b in v.items()})
                                                        for k, v in info.items()},
                         "rows": [r.__dict__ for r in rows]}
    text = "\n".join(header + body + summary)
    (out / "work_precision.md").write_text(text)
    (out / "work_precision.json").write_text(json.dumps(raw, indent=1, default=str))
    print("\n" + text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
