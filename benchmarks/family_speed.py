"""Speed on every kind of family member : heyoka beside scipy and exact, one run.

Run: ``.venv/bin/python benchmarks/family_speed.py [--quick] [--baseline OLD_HEYOKA_PY]``.
Prints markdown tables: per member the events, the wall time (median of repeats after a
warm-up that compiles heyoka's integrator of that structure) and events per second of wall
time for each backend that supports the member, and how closely heyoka and scipy agree next
to how far heyoka moves from a start nudged by 1e-14 (the member's own conditioning: a
chaotic member amplifies any difference, rounding included).
heyoka's compile is timed per system structure of the one heyoka loop (before the old piece
loop was deleted: per shape of that loop's integrators).
For the rigid flange with chatter the impacts resolved per second are given too (impacts
followed one by one plus the chatter jumps that resolve the rest of each sequence).

``--baseline FILE`` times the eq. 3 contact case with another version of
``impactosc/backends/heyoka.py`` (e.g. ``git show main:impactosc/backends/heyoka.py > old.py``)
interleaved with the current one in the same process, so both see the same machine load.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from _timing import Timeout, cold_compile, timed  # noqa: E402

import impactosc as io  # noqa: E402
from impactosc.backends import heyoka as hb  # noqa: E402
from impactosc.backends.heyoka._replay import _system  # noqa: E402

O = io.Oscillator
#: (name, member, t_end, x0, v0)
MEMBERS = [
    ("eq. 3 contact case", O(0.5, 1.1, 0.01, 1e4), 400.0, 0.95, 0.0),
    ("damped, zeta=0.02", O(0.5, 1.1, 0.01, 1e4, zeta=0.02), 400.0, 0.95, 0.0),
    ("static/kinetic, beta=0.2, beta_s=0.35", O(0.5, 0.3, 0.2, 1e4, beta_static=0.35), 400.0, 0.0, 0.0),
    ("Hertz flange, p=1.5", O(0.5, 1.1, 0.01, 1e4, exponent=1.5), 400.0, 0.95, 0.0),
    ("rigid flange, e=0.8, chatter", O(2.0, 0.1, 0.1, 1.0, flange="rigid", restitution=0.8), 400.0, 0.0, 0.0),
    ("harmonic sum, 3 terms", O.from_harmonics([(0.5, 1.1, 0.0), (0.1, 2.2, 0.3), (0.05, 3.3, 1.0)], 0.01, 1e4),
     400.0, 0.95, 0.0),
]
BACKENDS = ("heyoka", "scipy", "exact")


def measure(osc, t_end, x0, v0, backend, repeats, budget, timeout):
    """(median seconds, repeats, Solution) or a string saying why there is no number."""
    def run():
        return io.simulate(osc, t_end, x0, v0, backend=backend, record="events")

    try:
        io.simulate(osc, 1e-3, x0, v0, backend=backend)  # compiles heyoka's shape (not timed)
    except ValueError as exc:
        return "n/a" if "does not support" in str(exc) else f"error: {exc}"
    try:
        med, n, sol = timed(run, repeats, budget, timeout)
    except Timeout:
        return f"> {timeout:g} s"
    return med, n, sol


def agreement(a, b) -> str:
    ea, eb = a.events, b.events
    if list(ea.kind) != list(eb.kind) or list(ea.side) != list(eb.side):
        first = next((i for i in range(min(len(ea), len(eb))) if ea.kind[i] != eb.kind[i]), min(len(ea), len(eb)))
        return f"sequences differ at event {first} ({len(ea)} vs {len(eb)})"
    return f"same {len(ea)} events, max dt {np.max(np.abs(ea.t - eb.t)) if len(ea) else 0.0:.1e}"


def load_module(path: str):
    spec = importlib.util.spec_from_file_location("impactosc.backends._heyoka_baseline", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def baseline(path: str, rounds: int) -> str:
    """Contact case, this heyoka.py against ``path``, interleaved in one process."""
    old = load_module(path)
    osc, t_end, x0, v0 = MEMBERS[0][1:]
    runs = {"baseline": lambda: old.run(osc, t_end, x0, v0, record="events", max_events=10**9),
            "current": lambda: hb.run(osc, t_end, x0, v0, record="events", max_events=10**9)}
    times = {k: [] for k in runs}
    sols = {k: f() for k, f in runs.items()}  # compiles both
    for _ in range(rounds):
        for k, f in runs.items():
            t0 = time.perf_counter()
            f()
            times[k].append(time.perf_counter() - t0)
    same = np.array_equal(sols["baseline"].events.t, sols["current"].events.t)
    lines = [f"\n## eq. 3 contact case: current heyoka.py against {path} ({rounds} interleaved rounds)\n",
             "| version | median [ms] | best [ms] | events/s (median) |", "| --- | ---: | ---: | ---: |"]
    n = len(sols["current"].events)
    for k, ts in times.items():
        med = statistics.median(ts)
        lines.append(f"| {k} | {med * 1e3:.2f} | {min(ts) * 1e3:.2f} | {n / med:,.0f} |")
    ratio = statistics.median(times["current"]) / statistics.median(times["baseline"])
    best = min(times["current"]) / min(times["baseline"])
    lines.append(f"\ncurrent / baseline: {ratio:.3f} (medians), {best:.3f} (best); "
                 f"event times identical bit for bit: {same}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="t_end / 20 and few repeats (smoke test)")
    ap.add_argument("--baseline", metavar="FILE", help="an older heyoka.py to time the contact case against")
    ap.add_argument("--rounds", type=int, default=41, help="interleaved rounds of --baseline")
    ap.add_argument("--budget", type=float, default=20.0, help="seconds of repeats per member and backend")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per single run")
    args = ap.parse_args(argv)
    scale = 20.0 if args.quick else 1.0
    repeats = {"heyoka": 3 if args.quick else 15, "scipy": 1 if args.quick else 3, "exact": 3 if args.quick else 7}
    load0 = os.getloadavg()

    structures: dict = {}  # one integrator per system structure: members that differ in numbers only share it
    for name, osc, *_ in MEMBERS:
        try:
            structures.setdefault(_system(osc)[0].structure, (name, osc))
        except ValueError as exc:  # a member the one loop's system cannot write
            structures.setdefault(name, (name, exc))
    compile_s = {name: cold_compile(osc) if isinstance(osc, io.Oscillator) else f"not compiled: {osc}"
                 for name, osc in structures.values()}

    rows, notes = [], []
    for name, osc, t_end, x0, v0 in MEMBERS:
        t_end /= scale
        res = {b: measure(osc, t_end, x0, v0, b, repeats[b], args.budget, args.timeout) for b in BACKENDS}
        cells, events = [], None
        for b in BACKENDS:
            r = res[b]
            if isinstance(r, str):
                cells += [r, ""]
                continue
            med, _, sol = r
            n = len(sol.events)
            events = n if events is None else events
            cells += [f"{med * 1e3:.1f}", f"{n / med:,.0f}"]
            if osc.rigid:
                resolved = sol.counts["impact"] + sol.counts["chatter"]
                notes.append(f"- {name}, {b}: {sol.counts['impact']} impacts followed and {sol.counts['chatter']} "
                             f"chatter jumps in {med * 1e3:.1f} ms: {resolved / med:,.0f} impacts resolved per second")
        h, s = res["heyoka"], res["scipy"]
        agree = agreement(h[2], s[2]) if not isinstance(h, str) and not isinstance(s, str) else ""
        # The conditioning of the member: heyoka against itself from x0 + 1e-14.
        nudged = "" if isinstance(h, str) else agreement(h[2], io.simulate(osc, t_end, x0 + 1e-14, v0, record="events"))
        rows.append((name, t_end, events, cells, agree, nudged))

    print(f"# Family members: events per second of wall time (load average {load0[0]:.2f} at the start, "
          f"{os.getloadavg()[0]:.2f} at the end, {os.cpu_count()} cores)\n")
    print("| member | t_end | events | heyoka [ms] | heyoka events/s | scipy [ms] | scipy events/s | exact [ms] | "
          "exact events/s | heyoka vs scipy | heyoka vs itself from x0 + 1e-14 |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |")
    for name, t_end, events, cells, agree, nudged in rows:
        print(f"| {name} | {t_end:g} | {events} | " + " | ".join(cells) + f" | {agree} | {nudged} |")
    print()
    print("\n".join(notes))
    print("\nheyoka compile per system structure (cold: code caches bypassed; once per structure and tolerance, "
          "shared by threads), named by its first member:")
    for name, sec in compile_s.items():
        print(f"- {name}: {sec:.2f} s" if isinstance(sec, float) else f"- {name}: {sec}")
    if args.baseline:
        print(baseline(args.baseline, max(3, args.rounds // (10 if args.quick else 1))))
    return 0 if all(isinstance(v, float) and math.isfinite(v) for v in compile_s.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
