"""heyoka and the compiled closed form against the compiled RK4, side by side, and the Fig. 7 grid.

Run: ``.venv/bin/python benchmarks/speed.py [--quick] [--baseline REF ...] [--out DIR]``.

1. The contact case (``F=0.5, Omega=1.1, beta=0.01, K=1e4``, ``x0=0.95``, ``t_end=400``,
   328 events): heyoka and the paper's RK4 at its default step (numba, compile excluded by a
   warm-up), both with ``record="events"`` and with ``simulate``'s default ``"full"`` (the
   RK4's dense recording costs it twice its "events" time), the exact backend's compiled event
   loop in every recording mode and its Python driver (``compiled=False``), scipy (DOP853,
   every fifth round) and every ``--baseline``, interleaved round by round; medians of the
   wall time and of the CPU time of the thread (``time.thread_time``, which other people's
   processes on a shared machine inflate less).
2. The stick-slip regime (``F=2, Omega=0.01, beta=0.01, K=1e4``, ``record="stats"``, cut at
   ``max_events``): events/s of heyoka, exact and the baselines, and the RK4's steps/s on a
   run of the same length, interleaved likewise. The yardstick of the target is
   heyoka's events/s divided by the RK4's steps/s of the same round.
2b. The compiled closed form on a long run of the contact case (``t_end=1e5``, ~8e4 events):
   events/s, and its mean flange force against the Python driver and heyoka.
3. The paper's Fig. 7 grid (``impactosc.paper.fig7_grid``: 90 points, 1 s of tape each) with
   heyoka and with the exact backend (its compiled loop): ``impactosc.sweep`` on the default
   process pool twice each (the first sweep starts the pool and loads the integrators in
   its workers), then the 90 points one after the other in this process (CPU time, events
   and Taylor steps; also for each baseline, and for the compiled loop).

Section 4 (heyoka's batch mode) is gone with the old piece loop: it timed that loop's
integrator of free slipping as ``taylor_adaptive`` and ``taylor_adaptive_batch`` on the longest
piece of a Fig. 7 point (the last numbers are in the ``speed.md`` of earlier runs). The one
heyoka loop applies its transitions in event callbacks, one run per integrator, which batch
mode's lanes do not share.

``--baseline REF`` (repeatable) exports ``impactosc/`` at the git revision ``REF`` of this
repository (``git archive``) into a temporary folder as the package ``impactosc_<REF>`` and
times its heyoka in the same rounds: before/after numbers that the machine's load cannot
tilt. The load average is recorded at the start and the end of every section.

Writes ``speed.md`` and ``speed.json`` into ``--out`` (default ``benchmarks/results``; with
``--quick``, ``benchmarks/results/quick``).
"""

from __future__ import annotations

import argparse
import importlib
import io as _io
import json
import math
import os
import platform
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

import impactosc as io

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
HUGE_T = 1e12  # the stick-slip runs are cut by max_events

CONTACT = dict(F=0.5, Omega=1.1, beta=0.01, K=1e4)
STICKSLIP = dict(F=2.0, Omega=0.01, beta=0.01, K=1e4)


def load() -> float:
    return os.getloadavg()[0]


def load_baseline(ref: str):
    """``impactosc/`` at git revision ``ref``, imported as the package ``impactosc_<ref>``."""
    name = "impactosc_" + re.sub(r"\W", "_", ref)
    root = Path(tempfile.mkdtemp(prefix="impactosc-baseline-"))
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref, "impactosc"], capture_output=True,
                             check=True).stdout
    with tarfile.open(fileobj=_io.BytesIO(archive)) as tar:
        tar.extractall(root, filter="data")
    (root / "impactosc").rename(root / name)
    registry = root / name / "backends" / "__init__.py"  # the backends are looked up by dotted name
    registry.write_text(registry.read_text().replace('"impactosc.', f'"{name}.'))
    sys.path.insert(0, str(root))
    return importlib.import_module(name)


def clock(fn):
    """``(wall, cpu, result)`` of one call; cpu is this thread's CPU time."""
    c0, w0 = time.thread_time(), time.perf_counter()
    out = fn()
    return time.perf_counter() - w0, time.thread_time() - c0, out


def med(values) -> float:
    return statistics.median(values) if values else math.nan


# -- 1. contact case -------------------------------------------------------------------------------
def contact(pkgs: dict, rounds: int) -> dict:
    runs = {}
    osc = io.Oscillator(**CONTACT)
    for record in ("events", "full"):
        for label, pkg in pkgs.items():
            o = pkg.Oscillator(**CONTACT)
            runs[(label, record)] = (lambda p=pkg, o=o, r=record: p.simulate(o, 400.0, 0.95, 0.0, record=r), 1)
        runs[("rk4 (default dt)", record)] = (lambda r=record: io.simulate(osc, 400.0, 0.95, 0.0, backend="rk4",
                                                                          record=r), 1)
    for record in ("stats", "events", "full"):
        runs[("exact (compiled loop)", record)] = (
            lambda r=record: io.simulate(osc, 400.0, 0.95, 0.0, backend="exact", record=r, compiled=True), 1)
    runs[("exact (Python driver)", "events")] = (
        lambda: io.simulate(osc, 400.0, 0.95, 0.0, backend="exact", record="events", compiled=False), 1)
    runs[("rk4 (default dt)", "stats")] = (lambda: io.simulate(osc, 400.0, 0.95, 0.0, backend="rk4", record="stats"), 1)
    runs[("scipy DOP853 (rtol 1e-10)", "events")] = (
        lambda: io.simulate(osc, 400.0, 0.95, 0.0, backend="scipy", method="DOP853", rtol=1e-10, atol=1e-10,
                            record="events"), 5)
    times = {k: ([], []) for k in runs}
    sols = {}
    for k, (fn, _) in runs.items():  # warm-up: compiles heyoka and numba, imports scipy
        sols[k] = fn()
    l0 = load()
    for i in range(rounds):
        for k, (fn, every) in runs.items():
            if i % every == 0:
                wall, cpu, _ = clock(fn)
                times[k][0].append(wall)
                times[k][1].append(cpu)
    l1 = load()
    rows = []
    for (backend, record), (walls, cpus) in times.items():
        sol = sols[(backend, record)]
        rows.append(dict(backend=backend, record=record, events=int(sum(sol.counts.values())), steps=int(sol.n_steps),
                         n=len(walls), wall=med(walls), cpu=med(cpus), best=min(walls)))
    return dict(rows=rows, load=(l0, l1), rounds=rounds)


# -- 2. stick-slip regime ------------------------------------------------------------------------
def stickslip(pkgs: dict, rounds: int, n_events: int, n_exact: int) -> dict:
    osc = io.Oscillator(**STICKSLIP)
    runs = {}
    for label, pkg in pkgs.items():
        o = pkg.Oscillator(**STICKSLIP)
        runs[label] = lambda p=pkg, o=o: p.simulate(o, HUGE_T, 0.95, 0.0, record="stats", max_events=n_events)
    runs["exact (compiled loop)"] = lambda: io.simulate(osc, HUGE_T, 0.95, 0.0, backend="exact", record="stats",
                                                        max_events=n_events, compiled=True)
    runs["exact (Python driver)"] = lambda: io.simulate(osc, HUGE_T, 0.95, 0.0, backend="exact", record="stats",
                                                        max_events=n_exact, compiled=False)
    first = runs["heyoka"]()
    t_rk4 = first.t_final  # the RK4 runs as long as heyoka's run of n_events
    runs["rk4 (default dt)"] = lambda: io.simulate(osc, t_rk4, 0.95, 0.0, backend="rk4", record="stats")
    for fn in runs.values():
        fn()
    per = {k: [] for k in runs}  # (wall, cpu, events, steps)
    l0 = load()
    for _ in range(rounds):
        for k, fn in runs.items():
            wall, cpu, sol = clock(fn)
            per[k].append((wall, cpu, int(sum(sol.counts.values())), int(sol.n_steps), sol.t_final))
    l1 = load()
    rows = []
    for k, samples in per.items():
        wall, cpu = med([s[0] for s in samples]), med([s[1] for s in samples])
        ev, steps, t_final = samples[0][2], samples[0][3], samples[0][4]
        rows.append(dict(backend=k, events=ev, steps=steps, t_final=t_final, n=len(samples), wall=wall, cpu=cpu,
                         events_per_s=ev / wall, events_per_cpu_s=ev / cpu, steps_per_s=steps / wall,
                         steps_per_cpu_s=steps / cpu))
    # Ratios per round, against the RK4 of the same round.
    rk = per["rk4 (default dt)"]
    ratios = {}
    for k in pkgs:
        ratios[k] = med([(s[2] / s[1]) / (r[3] / r[1]) for s, r in zip(per[k], rk, strict=True)])
    return dict(rows=rows, ratios=ratios, load=(l0, l1), rounds=rounds)


# -- 2b. the compiled closed form in the contact regime ---------------------------------------------
def compiled_rate(rounds: int, t_end: float) -> dict:
    """Events/s of the exact backend's compiled loop on a long contact-regime run, and its accuracy.

    The mean flange force is compared with the Python driver of the same closed forms and
    with heyoka at its default tolerance, on the same run.
    """
    osc = io.Oscillator(**CONTACT)
    fast = lambda: io.simulate(osc, t_end, 0.95, 0.0, backend="exact", record="stats", compiled=True)  # noqa: E731
    first = fast()
    l0 = load()
    samples = [clock(fast)[:2] for _ in range(rounds)]
    l1 = load()
    slow = io.simulate(osc, t_end, 0.95, 0.0, backend="exact", record="stats", compiled=False)
    hey = io.simulate(osc, t_end, 0.95, 0.0, record="stats")
    events = int(sum(first.counts.values()))
    wall, cpu = med([w for w, _ in samples]), med([c for _, c in samples])
    # The contact case itself (t_end = 400), against the same two references.
    short = [io.simulate(osc, 400.0, 0.95, 0.0, backend=b, record="stats", **kw).mean_flange_force(1)
             for b, kw in (("exact", {"compiled": True}), ("exact", {"compiled": False}), ("heyoka", {}))]
    return dict(t_end=t_end, events=events, n=rounds, wall=wall, cpu=cpu, events_per_s=events / wall,
                events_per_cpu_s=events / cpu, mean_force=first.mean_flange_force(1),
                python_driver=slow.mean_flange_force(1), heyoka=hey.mean_flange_force(1), contact_case=short,
                load=(l0, l1))


# -- 3. the Fig. 7 grid ----------------------------------------------------------------------------
def fig7(pkgs: dict, quick: bool, serial: bool) -> dict:
    from impactosc.paper import fig7_grid

    base = io.TapeDrive()
    grid = fig7_grid(base, quick=quick)
    duration = 0.05 if quick else 1.0
    out = {"points": int(np.prod([len(v) for v in grid.values()])), "duration": duration, "sweeps": [], "serial": []}
    for backend, label in (("heyoka", "first sweep (starts the pool)"), ("heyoka", "second sweep (warm pool)"),
                           ("exact", "first sweep"), ("exact", "second sweep (warm pool)")):
        l0 = load()
        wall, _, ds = clock(lambda b=backend: io.sweep(base, grid, duration=duration, backend=b, progress=False))
        events = float((2 * ds.impacts + ds.sticks + ds.releases + ds.reversals).sum())
        out["sweeps"].append(dict(run=label, backend=backend, wall=wall, ok=int((ds.status == 0).sum()),
                                  events=events, load=(l0, load())))
        print(f"  fig7 {backend} {label}: {wall:.1f} s", flush=True)
    if not serial:
        return out
    for label, pkg in pkgs.items():
        paper = importlib.import_module(pkg.__name__ + ".paper")  # each version builds its own drives
        tape = pkg.TapeDrive()
        drives = [paper.resolve_drive(tape, pt) for _, pt in paper._points(paper.fig7_grid(tape, quick=quick))]
        pkg.simulate(tape.oscillator(), 1.0)  # loads the integrators
        l0 = load()
        cpu = wall = 0.0
        events = steps = 0
        for d in drives:
            w, c, sol = clock(lambda p=pkg, d=d: p.simulate(d.oscillator(), d.seconds_to_lambda(duration), 0.95, 0.0,
                                                          record="stats"))
            wall, cpu = wall + w, cpu + c
            events += int(sum(sol.counts.values()))
            steps += int(sol.n_steps)
        out["serial"].append(dict(backend=label, wall=wall, cpu=cpu, events=events, steps=steps, load=(l0, load())))
        print(f"  fig7 serial {label}: {cpu:.1f} s CPU", flush=True)
    paper = importlib.import_module("impactosc.paper")
    drives = [paper.resolve_drive(base, pt) for _, pt in paper._points(grid)]
    l0 = load()
    cpu = wall = 0.0
    events = 0
    for d in drives:
        w, c, sol = clock(lambda d=d: io.simulate(d.oscillator(), d.seconds_to_lambda(duration), 0.95, 0.0,
                                                  backend="exact", record="stats"))
        wall, cpu, events = wall + w, cpu + c, events + int(sum(sol.counts.values()))
    out["serial"].append(dict(backend="exact (compiled loop)", wall=wall, cpu=cpu, events=events, steps=len(drives),
                              load=(l0, load())))
    print(f"  fig7 serial exact: {cpu:.1f} s CPU", flush=True)
    return out


# -- report ------------------------------------------------------------------------------------------
def report(args, c, s, cr, f, load0, info) -> str:
    L = ["# heyoka and the compiled closed form against the compiled RK4", "",
         f"Generated by `benchmarks/speed.py{' --quick' if args.quick else ''}"
         f"{''.join(f' --baseline {b}' for b in args.baseline)}` on {time.strftime('%Y-%m-%d %H:%M')}, "
         f"{info}; load average {load0:.2f} at the start, {load():.2f} at the end (2 cores shared with other "
         "people's runs: every number is a median of interleaved rounds, and the ratios compare runs of the "
         "same rounds). Compile times excluded (warm-up runs first).", ""]
    rk = {r["record"]: r for r in c["rows"] if r["backend"].startswith("rk4")}
    L += ["## Contact case (`F=0.5, Omega=1.1, beta=0.01, K=1e4`, x0=0.95, t_end=400)", "",
          f"{c['rounds']} interleaved rounds (scipy every fifth), load {c['load'][0]:.2f} -> {c['load'][1]:.2f}. "
          "Each backend records what `record` asks for; the RK4 it is compared with records the same.", "",
          "| backend | record | events | steps | n | wall [ms] (median) | CPU [ms] (median) | best wall [ms] "
          "| RK4 / backend (wall) | RK4 / backend (CPU) |",
          "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in c["rows"]:
        ref = rk[r["record"]]
        L.append(f"| {r['backend']} | {r['record']} | {r['events']} | {r['steps']} | {r['n']} | "
                 f"{r['wall'] * 1e3:.2f} | {r['cpu'] * 1e3:.2f} | {r['best'] * 1e3:.2f} | "
                 f"{ref['wall'] / r['wall']:.2f} | {ref['cpu'] / r['cpu']:.2f} |")
    L += ["", "## Stick-slip regime (`F=2, Omega=0.01, beta=0.01, K=1e4`, record=\"stats\")", "",
          f"{s['rounds']} interleaved rounds, load {s['load'][0]:.2f} -> {s['load'][1]:.2f}. The RK4 runs as long "
          "as heyoka's run (it has no stick logic, so its events are not comparable; its steps are the yardstick).",
          "", "| backend | events | steps | t_final | n | wall [s] | events/s | events/CPU s | steps/s "
          "| steps/CPU s |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in s["rows"]:
        L.append(f"| {r['backend']} | {r['events']} | {r['steps']} | {r['t_final']:.4g} | {r['n']} | {r['wall']:.3g} "
                 f"| {r['events_per_s']:,.0f} | {r['events_per_cpu_s']:,.0f} | {r['steps_per_s']:,.0f} "
                 f"| {r['steps_per_cpu_s']:,.0f} |")
    L += ["", "heyoka's events per CPU second divided by the RK4's steps per CPU second of the same round "
          "(median over rounds):", "", "| version | events/s per RK4 step/s | relative to the first baseline |",
          "| --- | ---: | ---: |"]
    base_key = next((k for k in s["ratios"] if k != "heyoka"), None)
    for k, v in s["ratios"].items():
        rel = v / s["ratios"][base_key] if base_key else math.nan
        L.append(f"| {k} | {v:.3e} | {rel:.2f} |")
    L += ["", f"## The paper's Fig. 7 grid with heyoka ({f['points']} points x {f['duration']:g} s of tape)", "",
          "| run | wall [s] | points ok | events | load |", "| --- | ---: | ---: | ---: | --- |"]
    for r in f["sweeps"]:
        L.append(f"| `impactosc.sweep(backend={r['backend']!r})`, default pool ({os.cpu_count()} workers), "
                 f"{r['run']} | {r['wall']:.1f} | {r['ok']} | {r['events']:,.0f} | "
                 f"{r['load'][0]:.2f} -> {r['load'][1]:.2f} |")
    for r in f["serial"]:
        steps = ("" if r["backend"].startswith("exact")
                 else f"{r['steps'] / max(r['events'], 1):.1f} Taylor steps/event, ")
        L.append(f"| {r['backend']}, the points one after the other in this process: CPU {r['cpu']:.1f} s, "
                 f"{steps}{r['events'] / r['cpu']:,.0f} events/CPU s "
                 f"| {r['wall']:.1f} | | {r['events']:,} | {r['load'][0]:.2f} -> {r['load'][1]:.2f} |")
    L += ["", f"## The compiled closed form in the contact regime (contact case to t_end={cr['t_end']:g}, "
          "record=\"stats\")", "",
          f"{cr['n']} runs, load {cr['load'][0]:.2f} -> {cr['load'][1]:.2f}: {cr['events']:,} events in "
          f"{cr['wall'] * 1e3:.1f} ms wall ({cr['cpu'] * 1e3:.1f} ms CPU), **{cr['events_per_s']:,.0f} events/s** "
          f"({cr['events_per_cpu_s']:,.0f} per CPU s). Mean upper flange force {cr['mean_force']!r}; "
          f"the Python driver of the same closed forms {cr['python_driver']!r}; heyoka (default tolerance) "
          f"{cr['heyoka']!r}."]
    hey = {r["record"]: r for r in c["rows"] if r["backend"] == "heyoka"}
    ratio = {rec: (rk[rec]["wall"] / hey[rec]["wall"], rk[rec]["cpu"] / hey[rec]["cpu"]) for rec in hey}
    L += ["", "## Targets", "", "| target | measured | verdict |", "| --- | --- | --- |",
          "| contact case: heyoka >= 10x faster than the RK4 at its default step, same run | "
          + "; ".join(f"record={rec}: {w:.2f}x (wall), {cpu:.2f}x (CPU)" for rec, (w, cpu) in ratio.items())
          + f" | {'met' if min(min(v) for v in ratio.values()) >= 10 else 'missed'} |"]
    if base_key:
        rel = s["ratios"]["heyoka"] / s["ratios"][base_key]
        L.append(f"| stick-slip: >= 3x the events/s of `{base_key}` relative to the RK4's steps/s, same run | "
                 f"{rel:.2f}x | {'met' if rel >= 3 else 'missed'} |")
    hs = next(r for r in s["rows"] if r["backend"] == "heyoka")
    L.append(f"| stick-slip: about 2.5e5 events/s on an idle machine | {hs['events_per_cpu_s']:,.0f} events per CPU s "
             f"| {'met' if hs['events_per_cpu_s'] >= 2.5e5 else 'missed'} |")
    ex = {r["record"]: r for r in c["rows"] if r["backend"] == "exact (compiled loop)"}
    ex_ratio = {rec: (rk[rec]["wall"] / r["wall"], rk[rec]["cpu"] / r["cpu"]) for rec, r in ex.items() if rec in rk}
    L.append(f"| compiled closed form: >= 1e6 events/s in the contact regime | {cr['events_per_s']:,.0f} events/s "
             f"({cr['events_per_cpu_s']:,.0f} per CPU s) | {'met' if cr['events_per_s'] >= 1e6 else 'missed'} |")
    L.append("| compiled closed form: contact case >= 100x faster than the RK4 at its default step | "
             + "; ".join(f"record={rec}: {w:.1f}x (wall), {cpu:.1f}x (CPU)" for rec, (w, cpu) in ex_ratio.items())
             + f" | {'met' if ex_ratio and min(min(v) for v in ex_ratio.values()) >= 100 else 'missed'} |")
    fast, ref, hey = cr["contact_case"]
    gap = max(abs(cr["mean_force"] - cr["python_driver"]), abs(fast - ref))
    L.append(f"| compiled closed form: mean flange force within 1e-12 of the reference (the exact backend's "
             f"Python driver, the ground truth of the tests) | contact case (t_end=400): {abs(fast - ref):.1e} "
             f"({fast!r}); t_end={cr['t_end']:g}: {abs(cr['mean_force'] - cr['python_driver']):.1e}. "
             f"Cross-check with heyoka: {abs(fast - hey):.1e} and {abs(cr['mean_force'] - cr['heyoka']):.1e} "
             f"| {'met' if gap <= 1e-12 else 'missed'} |")
    sweeps = {(r["backend"], r["run"]): r["wall"] for r in f["sweeps"]}
    if f["sweeps"]:
        hw = [w for (b, _), w in sweeps.items() if b == "heyoka"]
        ew = [w for (b, _), w in sweeps.items() if b == "exact"]
        L.append(f"| Fig. 7 grid under 5 s on {os.cpu_count()} cores with the fastest exact path | "
                 f"{ew[-1]:.1f} s (warm pool), {ew[0]:.1f} s (first sweep) | {'met' if ew[-1] < 5 else 'missed'} |")
        L.append(f"| Fig. 7 grid with heyoka: how long | {hw[-1]:.1f} s (warm pool), {hw[0]:.1f} s (first sweep) "
                 "| reported |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="few rounds, small runs (smoke test)")
    ap.add_argument("--baseline", action="append", default=[], metavar="REF",
                    help="a git revision whose heyoka is timed in the same rounds (repeatable)")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds of the contact case (default 31)")
    ap.add_argument("--events", type=int, default=None, help="events per stick-slip run (default 20000)")
    ap.add_argument("--skip", default="", help="comma-separated parts to skip: fig7,serial")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default benchmarks/results)")
    args = ap.parse_args(argv)
    out = args.out or (HERE / "results" / ("quick" if args.quick else ""))
    out.mkdir(parents=True, exist_ok=True)
    skip = set(filter(None, args.skip.split(",")))
    rounds = args.rounds or (3 if args.quick else 31)
    n_events = args.events or (1000 if args.quick else 20_000)

    import heyoka

    info = (f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
            f"heyoka.py {heyoka.__version__}, numpy {np.__version__}")
    load0 = load()
    pkgs = {"heyoka": io}
    for ref in args.baseline:
        pkgs[f"heyoka @ {ref}"] = load_baseline(ref)
    print("contact case", flush=True)
    c = contact(pkgs, rounds)
    print("stick-slip regime", flush=True)
    s = stickslip(pkgs, max(2, rounds // 4), n_events, max(500, n_events // 4))
    print("compiled closed form", flush=True)
    cr = compiled_rate(3 if args.quick else 9, 2e3 if args.quick else 1e5)
    print("Fig. 7 grid", flush=True)
    f = (fig7(pkgs, args.quick, "serial" not in skip) if "fig7" not in skip
         else {"points": 0, "duration": math.nan, "sweeps": [], "serial": []})
    text = report(args, c, s, cr, f, load0, info)
    (out / "speed.md").write_text(text)
    raw = {"contact": c, "stickslip": s, "compiled": cr, "fig7": f, "info": info}
    (out / "speed.json").write_text(json.dumps(raw, indent=1))
    print("\n" + text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
