"""Speed of the heyoka backend: compile time, the contact case, a long creep run.

Run: ``.venv/bin/python benchmarks/heyoka_speed.py [--quick]``. Prints a markdown table.
Targets: contact case < 5 ms after the first compile; a run over t_end = 5.7e5
with ~1e4 friction events well under a second.

The compile is that of the integrator of the one heyoka loop a member runs on (the hybrid
loop of user systems, ``oscillator_system(osc)``), built cold with heyoka's code caches
bypassed; before the old piece loop was deleted it was that loop's integrator of eq. 3.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import tracemalloc

from _timing import cold_compile

import impactosc as io

CONTACT = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
# Paper-like scales (design.md): F ~ run-out/L, Omega ~ 2V/(D omega_n), beta ~ 3.9e-4 T.
CREEP = io.Oscillator(F=0.12, Omega=2e-4, beta=3.9e-4, K=1e4)


def timed(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), min(times), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="few repeats and a short creep run (smoke test)")
    args = ap.parse_args(argv)
    reps = 3 if args.quick else 21
    t_creep = 5.7e3 if args.quick else 5.7e5

    compile_s = cold_compile(CONTACT)

    rows = []
    for record in ("full", "events", "stats"):
        med, best, sol = timed(lambda r=record: io.simulate(CONTACT, 400.0, record=r), reps)
        n = sum(sol.counts.values())
        rows.append((f"contact case, t_end=400, record={record}", n, med, best, n / med))
    for record in ("full", "stats"):
        med, best, sol = timed(lambda r=record: io.simulate(CREEP, t_creep, record=r), max(1, reps // 7))
        n = sum(sol.counts.values())
        rows.append((f"creep F=0.12 Omega=2e-4 beta=3.9e-4, t_end={t_creep:g}, record={record}", n, med, best, n / med))

    print(f"heyoka integrator compile (the one loop's, of eq. 3; cold: code caches bypassed; tol=eps): "
          f"{compile_s:.3f} s\n")
    print("| case | events | median [ms] | best [ms] | events/s |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for name, n, med, best, rate in rows:
        print(f"| {name} | {n} | {med * 1e3:.2f} | {best * 1e3:.2f} | {rate:,.0f} |")

    print("\nPeak traced Python memory of the creep run per recording level:")
    for record in ("full", "events", "stats"):
        tracemalloc.start()
        io.simulate(CREEP, t_creep, record=record)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(f"  record={record:<7} {peak / 1024:9.1f} KiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
