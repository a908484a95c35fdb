"""Speed of the exact n-DOF backend: chains of masses between two stops, events per second, against heyoka.

Run: ``.venv/bin/python benchmarks/mdof_speed.py [--quick]``. Prints three markdown tables, single
process, one core, every run warmed up first (numba cache or compile, heyoka compile):

1. per system the events, the closed-form pieces and the wall time (median and best of the
   repeats) with and without the energy terms (forcing work and viscous dissipation in closed
   form on every piece), and the events per second of the best run;
2. the paper's contact case (eq. 3) on the 1-DOF exact backend and as the ``n = 1`` mechanical
   system, side by side;
3. the ``n = 4`` chain between two rigid stops on ``simulate_mechanical`` against heyoka on the
   same system written as a user hybrid system (:func:`~impactosc.model.hybrid.mechanical_system`),
   energy integrals off in both, repeats interleaved so that both see the same load.

Targets: at least 2e5 events per second for ``n = 4`` with two rigid stops, and at least 10x the
heyoka path per event. Every table gives the wall time and the process's CPU time (the best of the
repeats of each): on a machine shared with other work the CPU time is the one core's share that
the run itself used, the wall time includes the waits for that core. The chains are chaotic (a
start moved by 1e-14 changes the event count after ~100 events), so the counts move with the
rounding of the machine and of the code.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from _timing import load_average  # noqa: E402

import impactosc  # noqa: E402
from impactosc import MechanicalSystem, Oscillator, simulate_mechanical  # noqa: E402
from impactosc.model import Contact, Friction  # noqa: E402

#: The targets of the n = 4 chain between two rigid stops.
TARGET_RATE = 2e5
TARGET_HEYOKA = 10.0


def chain(n: int = 4, *, friction: bool = False, springs: bool = False) -> MechanicalSystem:
    """``n`` unit masses in a chain of unit springs, lightly damped, the first one forced; the last
    one between two stops (rigid, ``e = 0.9``, or springs of stiffness 100) at +-0.5."""
    K = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    K[-1, -1] = 1.0
    C = 0.02 * K + 0.01 * np.eye(n)
    f = np.zeros(n)
    f[0] = 1.0
    e_last = np.eye(n)[-1]
    law = {"law": "spring", "stiffness": 100.0} if springs else {"law": "rigid", "restitution": 0.9}
    contacts = [Contact(e_last, 0.5, **law), Contact(-e_last, 0.5, **law)]
    fr = [Friction(0, 0.05, 0.07)] if friction else []
    return MechanicalSystem(M=np.eye(n), C=C, K=K, harmonics=[(f, 0.8, 0.0)], contacts=contacts, friction=fr)


CASES = [
    ("n=4, two rigid stops", lambda: chain(4)),
    ("n=4, two rigid stops, friction on q0", lambda: chain(4, friction=True)),
    ("n=4, two spring stops", lambda: chain(4, springs=True)),
    ("n=8, two rigid stops", lambda: chain(8)),
]


def _times(fns, repeats: int) -> tuple[list[list[float]], list[list[float]]]:
    """Wall and CPU times of ``repeats`` rounds of every function of ``fns``, interleaved round by round."""
    wall: list[list[float]] = [[] for _ in fns]
    cpu: list[list[float]] = [[] for _ in fns]
    for _ in range(repeats):
        for w, c, fn in zip(wall, cpu, fns, strict=True):
            t0, c0 = time.perf_counter(), time.process_time()
            fn()
            c.append(time.process_time() - c0)
            w.append(time.perf_counter() - t0)
    return wall, cpu


def systems_table(t_end: float, repeats: int) -> float:
    """Table 1; returns the best events/s (wall, CPU) of the n = 4 rigid chain without energy terms."""
    print("| system | events | pieces | energy | median (ms) | best (ms) | events/s (best) | CPU best (ms) | "
          "events/s (CPU best) |")
    print("| --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: |")
    rate = (0.0, 0.0)
    for name, make in CASES:
        system = make()
        zeros = np.zeros(system.n)
        simulate_mechanical(system, 1.0, zeros, zeros)  # warm-up: numba cache or compile
        for energy in (False, True):
            def run(s=system, z=zeros, e=energy):
                return simulate_mechanical(s, t_end, z, z, energy=e)

            sol = run()
            (times,), (cpu,) = _times([run], repeats)
            best, cpu_best = min(times), min(cpu)
            if name == CASES[0][0] and not energy:
                rate = (len(sol.events) / best, len(sol.events) / cpu_best)
            print(f"| {name} | {len(sol.events)} | {sol.n_pieces} | {'yes' if energy else 'no'} | "
                  f"{1e3 * statistics.median(times):.2f} | {1e3 * best:.2f} | {len(sol.events) / best:,.0f} | "
                  f"{1e3 * cpu_best:.2f} | {len(sol.events) / cpu_best:,.0f} |")
    return rate


def one_dof_table(repeats: int) -> None:
    """Table 2: the paper's contact case on the 1-DOF exact backend and as the n = 1 system."""
    osc = Oscillator(0.5, 1.1, 0.01, 1e4)
    one = MechanicalSystem.from_oscillator(osc)
    fns = [lambda: impactosc.simulate(osc, 400.0, 0.95, 0.0, backend="exact"),
           lambda: simulate_mechanical(one, 400.0, [0.95], [0.0], energy=False)]
    sols = [fn() for fn in fns]
    times, cpu = _times(fns, 5 * repeats)
    print("| eq. 3 contact case to t = 400 | events | median (ms) | best (ms) | events/s (best) | CPU best (ms) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for name, sol, ts, cs in zip(("1-DOF exact backend", "n-DOF exact backend, n = 1"), sols, times, cpu,
                                 strict=True):
        print(f"| {name} | {len(sol.events)} | {1e3 * statistics.median(ts):.3f} | {1e3 * min(ts):.3f} | "
              f"{len(sol.events) / min(ts):,.0f} | {1e3 * min(cs):.3f} |")


def heyoka_table(t_end: float, repeats: int) -> float:
    """Table 3: exact against heyoka on the n = 4 rigid chain; returns the speed-up per event (best runs:
    wall, CPU)."""
    from impactosc.model.hybrid import mechanical_system

    system = chain(4)
    hybrid = mechanical_system(system, energy=False)
    zeros = np.zeros(system.n)
    fns = [lambda: simulate_mechanical(system, t_end, zeros, zeros, energy=False),
           lambda: impactosc.simulate(hybrid, t_end, [0.0] * 8)]
    exact, sol = (fn() for fn in fns)  # warm-up, and the events compared
    times, cpu = _times(fns, repeats)
    heyoka_times = sol.event_times()
    counts = (len(exact.events), len(heyoka_times))
    # a chaotic chain: the runs part after ~100 events; count the leading events that agree to 1e-9
    k = min(counts)
    same = int(np.argmin(np.append(np.abs(heyoka_times[:k] - exact.events["t"][:k]) <= 1e-9, False)))
    per_event = [min(ts) / c for ts, c in zip(times, counts, strict=True)]
    per_event_cpu = [min(cs) / c for cs, c in zip(cpu, counts, strict=True)]
    print(f"n=4, two rigid stops, t_end={t_end:g}: exact n-DOF loop against heyoka on mechanical_system(...), "
          "energy integrals off, repeats interleaved")
    print("| backend | events | median (ms) | best (ms) | events/s (best) | per event (us) | CPU per event (us) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name, c, ts, pe, pc in zip(("exact", "heyoka (user system)"), counts, times, per_event, per_event_cpu,
                                   strict=True):
        print(f"| {name} | {c} | {1e3 * statistics.median(ts):.2f} | {1e3 * min(ts):.2f} | {c / min(ts):,.0f} | "
              f"{1e6 * pe:.2f} | {1e6 * pc:.2f} |")
    speedup = (per_event[1] / per_event[0], per_event_cpu[1] / per_event_cpu[0])
    print(f"leading events that agree to 1e-9: {same}; exact speed-up per event: {speedup[0]:.1f}x wall, "
          f"{speedup[1]:.1f}x CPU")
    return speedup


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs, fewer repeats")
    args = parser.parse_args(argv)
    t_end = 200.0 if args.quick else 1000.0
    repeats = 2 if args.quick else 15
    print(f"load average before: {load_average()}")
    rate = systems_table(t_end, repeats)
    print()
    one_dof_table(repeats)
    print()
    speedup = heyoka_table(t_end, repeats)
    print()
    for how, r, x in (("wall", rate[0], speedup[0]), ("CPU", rate[1], speedup[1])):
        print(f"targets ({how} time): {r:,.0f} events/s for n = 4 with two rigid stops (target {TARGET_RATE:,.0f}: "
              f"{'met' if r >= TARGET_RATE else 'missed'}); {x:.1f}x heyoka per event (target "
              f"{TARGET_HEYOKA:g}x: {'met' if x >= TARGET_HEYOKA else 'missed'})")
    print(f"load average after: {load_average()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
