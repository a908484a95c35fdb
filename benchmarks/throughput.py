"""Throughput and memory of the backends on long runs, and where heyoka's time goes.

Run: ``.venv/bin/python benchmarks/throughput.py [--quick] [--out DIR]``.

1. Events/s and steps/s per backend on long runs (10^4 to 10^6 events) in three regimes:
   the contact case, the quasi-static stick-slip contact regime (sticks once per contact
   period) and the paper's tape case (creep). Runs are cut at an exact number of events
   with ``max_events``; wall times are medians of repeats (one run for the longest ones).
2. Memory of heyoka with each recording option on runs of 10^4, 10^5 and 10^6 events,
   every configuration in a fresh subprocess: ``resource.getrusage(RUSAGE_SELF).ru_maxrss``
   after one untraced run (minus that of a subprocess that only warmed up), then the
   ``tracemalloc`` peak of a second, traced run.
3. A cProfile of heyoka on the stick-slip regime (top 15 by own time), and the split of
   the time per event into the one hybrid loop (one ``propagate_until`` whose event callbacks
   apply the transitions) and the replay into the built-in ``Solution``, with the fixed cost of
   a ``propagate_until`` call. (With the old piece loop, deleted, the split timed each
   ``propagate_until`` call through a proxy against the Python around them: the one loop's
   Python runs inside the call.)

Writes ``throughput.md``, ``throughput.json`` and ``throughput_profile.txt`` into ``--out``
(default ``benchmarks/results``; with ``--quick`` ``benchmarks/results/quick``).
"""

from __future__ import annotations

import argparse
import cProfile
import io as _io
import json
import math
import os
import platform
import pstats
import resource
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

import impactosc as io

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the shared _timing module beside this script
from _timing import Timeout, timed  # noqa: E402

HERE = Path(__file__).resolve().parent
HUGE_T = 1e12  # runs are cut by max_events

REGIMES = {
    "contact": ("contact case F=0.5, Omega=1.1, beta=0.01, K=1e4", io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)),
    "stickslip": ("quasi-static stick-slip contact F=2, Omega=0.01, beta=0.01, K=1e4",
                  io.Oscillator(F=2.0, Omega=0.01, beta=0.01, K=1e4)),
    "tape": ("paper's tape case (default TapeDrive, creep)", io.TapeDrive().oscillator()),
}




def load() -> float:
    return os.getloadavg()[0]


# -- 1. throughput ---------------------------------------------------------------------------
def event_rate(osc) -> float:
    """Events per unit of nondimensional time (from a heyoka run of ~2000 events)."""
    sol = io.simulate(osc, HUGE_T, record="stats", max_events=2000)
    return sum(sol.counts.values()) / sol.t_final


def throughput(args) -> list[dict]:
    q = args.quick
    plan = {  # backend -> event counts
        "heyoka": [500] if q else [10_000, 100_000, 1_000_000],
        "exact": [500] if q else [10_000, 100_000],
        "scipy": [50] if q else [2_000],
        "rk4": [500] if q else [10_000, 100_000],
    }
    io.simulate(REGIMES["contact"][1], 1.0, backend="rk4")  # numba warm-up
    io.simulate(REGIMES["contact"][1], 1.0)  # heyoka compile
    io.simulate(REGIMES["contact"][1], 0.1, backend="scipy")  # imports scipy.integrate
    from impactosc.backends.rk4 import default_dt
    rows = []
    for key, (_title, osc) in REGIMES.items():
        rate = event_rate(osc)
        for backend, sizes in plan.items():
            for n in sizes:
                if backend == "rk4":
                    # Fixed step: the run length of the exact answer with n events (rk4 sees other events).
                    t_end = n / rate
                    kw = {}
                    if t_end / default_dt(osc.K) > args.rk4_max_steps:
                        rows.append(dict(regime=key, backend=backend, target=n,
                                         error=f"skipped: {t_end / default_dt(osc.K):.2g} steps at the default dt"))
                        continue
                else:
                    t_end, kw = HUGE_T, {"max_events": n}
                reps = 1 if q or n >= 1_000_000 or backend == "scipy" else 3
                l0 = load()
                try:
                    wall, r, sol = timed(lambda b=backend, t=t_end, k=kw, o=osc: io.simulate(o, t, backend=b,
                                                                                      record="stats", **k),
                                         reps, args.budget, args.timeout)
                except Timeout:
                    rows.append(dict(regime=key, backend=backend, target=n,
                                     error=f"timeout: one run took more than {args.timeout:g} s"))
                    continue
                except Exception as exc:  # a backend failing on a long run is a finding, not a crash
                    rows.append(dict(regime=key, backend=backend, target=n, error=f"{type(exc).__name__}: {exc}"))
                    continue
                ev = sum(sol.counts.values())
                row = dict(regime=key, backend=backend, target=n, events=ev, t_final=sol.t_final, wall=wall,
                           repeats=r, events_per_s=ev / wall, steps=sol.n_steps, steps_per_s=sol.n_steps / wall,
                           us_per_event=1e6 * wall / max(ev, 1), sticks_per_t=sol.counts["stick"] / sol.t_final,
                           load=(l0, load()), status=sol.status)
                rows.append(row)
                print(f"  {key:<10} {backend:<7} {ev:>9} events {wall:9.3f} s {ev / wall:12,.0f} ev/s "
                      f"{sol.n_steps / wall:14,.0f} steps/s", flush=True)
    return rows


# -- 2. memory, one fresh subprocess per configuration --------------------------------------
def child(spec: dict) -> dict:
    osc = REGIMES[spec["regime"]][1]
    io.simulate(osc, 1.0)  # compile/load the integrator, as in the baseline child
    n, record = spec["events"], spec["record"]
    out = {}
    if n:
        t0 = time.perf_counter()
        sol = io.simulate(osc, HUGE_T, record=record, max_events=n)
        out["wall"] = time.perf_counter() - t0
        out["events"] = sum(sol.counts.values())
        out["status"] = sol.status
        del sol
    out["maxrss_kib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    if n and spec.get("trace", True):
        tracemalloc.start()
        sol = io.simulate(osc, HUGE_T, record=record, max_events=n)
        out["tracemalloc_peak"] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        del sol
    return out


def run_child(spec: dict) -> dict:
    res = subprocess.run([sys.executable, __file__, "--child", json.dumps(spec)], capture_output=True, text=True,
                         check=False)
    if res.returncode != 0:
        return {"error": res.stderr.strip().splitlines()[-1] if res.stderr.strip() else f"rc {res.returncode}"}
    return json.loads(res.stdout.strip().splitlines()[-1])


def memory(args) -> tuple[dict, list[dict]]:
    sizes = [10_000, 100_000, 1_000_000]
    if args.quick:  # few subprocesses: each one imports heyoka and loads the compiled integrator
        plan = {"full": [1_000], "events": [1_000], "stats": [300, 1_000]}
    else:
        plan = {"full": sizes, "events": sizes, "stats": sizes}
    base = run_child({"regime": args.mem_regime, "events": 0, "record": "stats"})
    rows = []
    for record, ns in plan.items():
        for n in ns:
            spec = {"regime": args.mem_regime, "events": n, "record": record}
            res = run_child(spec)
            res.update(spec)
            rows.append(res)
            if "error" in res:
                print(f"  memory {record:<7} {n:>9}: {res['error']}", flush=True)
                continue
            print(f"  memory {record:<7} {n:>9} events: RSS {res['maxrss_kib'] / 1024:8.1f} MiB "
                  f"(+{(res['maxrss_kib'] - base['maxrss_kib']) / 1024:.1f}), tracemalloc peak "
                  f"{res.get('tracemalloc_peak', 0) / 2**20:8.2f} MiB, {res['wall']:.2f} s", flush=True)
    return base, rows


# -- 3. profile and the split of the time per event -------------------------------------------
def split(osc, n_events: int) -> dict:
    """Time per event of ``simulate`` on the one hybrid heyoka loop: the loop alone, the replay, the raw integrator.

    The loop is one ``propagate_until`` whose event callbacks apply the transitions in Python, so
    the integration and the Python cannot be timed apart call by call (the old piece loop's
    proxy did that): the loop alone (``run_counted`` on ``oscillator_system(osc, energy=True)``) is
    set against ``simulate`` (loop and replay into the built-in ``Solution``), and the fixed cost
    of one ``propagate_until`` call is measured on the compiled integrator with its events off.
    """
    from impactosc.backends._hybrid_heyoka import DEFAULT_COOLDOWN, DEFAULT_TOL, checked_out, run_counted
    from impactosc.backends.heyoka._replay import _system
    from impactosc.engine import initial_mode

    system, modes, index, _, _ = _system(osc)
    start = initial_mode(osc, 0.0, 0.95, 0.0)
    mode = system.mode_names[index[(start.region, start.motion)]]
    quiet = f"{mode} stop" if start.motion != 0 else None
    t0 = time.perf_counter()
    sol = io.simulate(osc, HUGE_T, record="stats", max_events=n_events)
    total = time.perf_counter() - t0
    t1 = time.perf_counter()
    hybrid, steps = run_counted(system, HUGE_T, [0.95, 0.0], mode=mode, max_events=n_events,
                                quiet_at_start=quiet)
    loop = time.perf_counter() - t1
    n = int(sum(sol.counts.values()))
    # The fixed cost of one propagate_until call that takes a single tiny step, events off.
    with checked_out(system, DEFAULT_TOL, DEFAULT_COOLDOWN) as comp:  # an instance no run uses meanwhile
        comp.load(system.parameter_values, system.mode_index("free+"), 0.0)
        raw = comp.ta
        raw.state[:] = 0.0
        raw.state[1] = 1e-3
        n_calls = 2000
        raw.time = 0.0
        c0 = time.perf_counter()
        for k in range(1, n_calls + 1):
            raw.propagate_until(k * 1e-9)
        call_cost = (time.perf_counter() - c0) / n_calls
    return dict(events=n, hybrid_events=len(hybrid.events), steps=int(sol.n_steps), total=total, loop=loop,
                replay=total - loop, us_event=1e6 * total / n, us_loop_event=1e6 * loop / n,
                us_replay_event=1e6 * (total - loop) / n, us_tiny_call=1e6 * call_cost,
                steps_per_event=sol.n_steps / n)


def profile(osc, n_events: int) -> tuple[str, dict]:
    prof = cProfile.Profile()
    prof.enable()
    io.simulate(osc, HUGE_T, record="stats", max_events=n_events)
    prof.disable()
    s = _io.StringIO()
    st = pstats.Stats(prof, stream=s)
    st.sort_stats("tottime").print_stats(15)
    groups: dict[str, float] = {}
    total = 0.0
    for (file, _line, func), (_cc, _nc, tt, _ct, _callers) in st.stats.items():
        if "propagate_until" in func:
            g = "heyoka propagate_until (compiled steps, and the callbacks' Python below it)"
        elif file.endswith("_hybrid_heyoka.py"):
            g = "impactosc/backends/_hybrid_heyoka.py (the loop's event callbacks)"
        elif file.endswith(os.path.join("engine", "_hybrid.py")):
            g = "impactosc/engine/_hybrid.py (Switch: transitions, entry conditions)"
        elif file.endswith("_replay.py"):
            g = "impactosc/backends/heyoka/_replay.py (the replay into the Solution)"
        elif os.path.join("impactosc", "results") in file:
            g = "impactosc/results (recorder, Solution)"
        elif os.path.join("impactosc", "model") in file:
            g = "impactosc/model (the member, its hybrid system)"
        else:
            g = "other (builtins, numpy views, ...)"
        groups[g] = groups.get(g, 0.0) + tt
        total += tt
    text = s.getvalue()
    text = text[text.find("   ncalls"):] if "   ncalls" in text else text
    return text, {g: t / total for g, t in sorted(groups.items(), key=lambda kv: -kv[1])}


# -- report -------------------------------------------------------------------------------------
def report(args, rows, base, mem, sp, prof_text, groups, load0) -> str:
    L = ["# Throughput and memory", "",
         f"Generated by `benchmarks/throughput.py{' --quick' if args.quick else ''}` on "
         f"{time.strftime('%Y-%m-%d %H:%M')}, {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
         f"Python {platform.python_version()}, numpy {np.__version__}; load average {load0:.2f} at the start, "
         f"{load():.2f} at the end (others share the machine: medians of repeats).", "",
         "## Events and steps per second (record=\"stats\", compile excluded)", "",
         "Runs are cut at the requested number of events with `max_events` (rk4: the run length that has "
         "that many events in the exact answer, it sees other events). `steps` is the backend's own step count "
         "(heyoka Taylor steps, scipy solver steps, rk4 fixed steps, exact: pieces).", "",
         "| regime | backend | events | t_final | wall [s] | n | events/s | us/event | steps/s | sticks per unit time "
         "| load |", "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
    for r in rows:
        if "error" in r:
            L.append(f"| {r['regime']} | {r['backend']} | {r['target']} | - | - | - | - | - | - | - | {r['error']} |")
            continue
        L.append(f"| {r['regime']} | {r['backend']} | {r['events']} | {r['t_final']:.4g} | {r['wall']:.4g} | "
                 f"{r['repeats']} | {r['events_per_s']:,.0f} | {r['us_per_event']:.3g} | {r['steps_per_s']:,.0f} | "
                 f"{r['sticks_per_t']:.3g} | {r['load'][0]:.2f}/{r['load'][1]:.2f} |")
    L += ["", "Regimes: " + "; ".join(f"`{k}`: {t}" for k, (t, _) in REGIMES.items()) + ".", ""]

    L += [f"## Memory of heyoka per recording option ({REGIMES[args.mem_regime][0]})", "",
          "Each row is a fresh subprocess: it warms the integrator up, runs once untraced "
          "(`ru_maxrss` read after it; baseline: a subprocess that only warmed up, "
          f"{base.get('maxrss_kib', math.nan) / 1024:.1f} MiB), then once under `tracemalloc` (peak of Python "
          "allocations during that run).", "",
          "| record | events | wall [s] (untraced) | ru_maxrss [MiB] | above baseline [MiB] | tracemalloc peak [MiB] "
          "| bytes/event (tracemalloc) |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in mem:
        if "error" in r:
            L.append(f"| {r['record']} | {r['events']} | {r['error']} | | | | |")
            continue
        peak = r.get("tracemalloc_peak", math.nan)
        L.append(f"| {r['record']} | {r['events']} | {r['wall']:.3g} | {r['maxrss_kib'] / 1024:.1f} | "
                 f"{(r['maxrss_kib'] - base.get('maxrss_kib', 0)) / 1024:.1f} | {peak / 2**20:.3f} | "
                 f"{peak / r['events']:.1f} |")

    L += ["", "## Where heyoka's time goes (stick-slip regime, record=\"stats\")", "",
          f"Over {sp['events']} events ({sp['steps_per_event']:.3g} Taylor steps per event) on the one hybrid loop: "
          f"`simulate` took {sp['total']:.3g} s, the loop alone {sp['loop']:.3g} s (its callbacks' Python runs "
          "inside `propagate_until`, so the two cannot be timed apart call by call):", "",
          "| per event | us |", "| --- | ---: |",
          f"| total (`simulate`: the loop and the replay into the `Solution`) | {sp['us_event']:.2f} |",
          f"| the hybrid loop alone (integration, event location, transitions in callbacks) | "
          f"{sp['us_loop_event']:.2f} |",
          f"| the replay and `simulate`'s checks | {sp['us_replay_event']:.2f} |",
          f"| one `propagate_until` call of a single tiny step, events off (fixed cost) | {sp['us_tiny_call']:.2f} |",
          "",
          f"Target 1e5 events/s = 10 us/event: measured {1e6 / sp['us_event']:,.0f} events/s "
          f"({sp['us_event'] / 10:.3g}x the budget).", "",
          "cProfile own time by group (profiling inflates the Python share):", "",
          "| group | share of own time |", "| --- | ---: |"]
    L += [f"| {g} | {100 * f:.1f}% |" for g, f in groups.items()]
    L += ["", "Top 15 by own time (also in `throughput_profile.txt`):", "", "```", prof_text.rstrip(), "```", ""]
    return "\n".join(L)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small runs (smoke test)")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default benchmarks/results)")
    ap.add_argument("--budget", type=float, default=20.0, help="stop repeating a run after this many seconds")
    ap.add_argument("--timeout", type=float, default=120.0, help="give up on one run after this many s")
    ap.add_argument("--rk4-max-steps", type=float, default=2e8, help="skip rk4 runs needing more steps")
    ap.add_argument("--mem-regime", default="contact", choices=list(REGIMES), help="regime of the memory runs")
    ap.add_argument("--skip", default="", help="comma-separated parts to skip: throughput,memory,profile")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(json.loads(args.child))))
        return 0
    out = args.out or (HERE / "results" / ("quick" if args.quick else ""))
    out.mkdir(parents=True, exist_ok=True)
    skip = set(filter(None, args.skip.split(",")))
    load0 = load()

    print("throughput", flush=True)
    rows = [] if "throughput" in skip else throughput(args)
    print("memory", flush=True)
    base, mem = ({}, []) if "memory" in skip else memory(args)
    print("profile", flush=True)
    osc = REGIMES["stickslip"][1]
    n_prof = 500 if args.quick else 100_000
    io.simulate(osc, 1.0)
    sp = split(osc, n_prof)
    prof_text, groups = profile(osc, n_prof)

    text = report(args, rows, base, mem, sp, prof_text, groups, load0)
    (out / "throughput.md").write_text(text)
    (out / "throughput_profile.txt").write_text(prof_text)
    (out / "throughput.json").write_text(json.dumps({"throughput": rows, "memory_baseline": base, "memory": mem,
                                                     "split": sp, "profile_groups": groups}, indent=1, default=str))
    print("\n" + text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
