"""Speed of user hybrid systems: the paper's eq. 3 written as a HybridSystem against the built-in paths.

Run: ``.venv/bin/python benchmarks/system_speed.py [--quick]``. Prints a markdown table.
On the contact case (``F=0.5, Omega=1.1, beta=0.01, K=1e4``, ``t_end=400``, 328 events), side by
side in one run (interleaved repeats, medians): the user system on its heyoka loop
(``impactosc.model.hybrid.oscillator_system``), the built-in heyoka path, the compiled RK4 at its
default step, and the user system on the scipy loop (the cross-check, a few repeats).
Targets: the user system within 1.5x of the built-in heyoka path per event; its ratio to the RK4.
The built-in heyoka path is the engine's piece loop; the row "hybrid loop + replay" runs the
member as a user system on the user systems' loop (``oscillator_system(osc, energy=True)``,
its integrals ``Q, Q2, W``) and replays it into the built-in ``Solution``
(``impactosc.backends.heyoka._replay``), the path the built-in is to move to.
A further row runs the user system's compiled integrator with callbacks that only switch the
mode (no resets, records or checks): the loop's Python cost per event is the difference.
The replay path is split in two more rows: the hybrid loop alone on the system with the
integrals the built-in ``Solution`` needs (``energy=True``), and that system's integrator
with the mode-switching callbacks only (the floor of the replay path: the Taylor steps its
states and events cost). Targets: the replay path at least 10x faster than the RK4.
The compile of the user system's integrator is timed once (cold, in this process).
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import time

import impactosc as io
from impactosc.backends._hybrid_heyoka import compiled
from impactosc.backends.heyoka._replay import INTEGRAL_SCALE, run_on_hybrid_loop
from impactosc.model.hybrid import oscillator_system
from impactosc.model.hybrid._numeric import numeric

CONTACT = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
T_END = 400.0


def raw_run(system, comp):
    """The user system's compiled integrator with the loop's Python stripped to the mode switch.

    The callbacks of the cached integrator are pointed at a stand-in run whose ``crossing``
    only moves the indicator to the guard's last candidate mode (no reset, records, chained
    guards, accumulation check) and whose ``extremum`` does nothing: the cost of the
    integration itself and of heyoka calling back into Python at each event.
    """
    num = numeric(system)
    P = comp.P
    last = [system.mode_index(g.to[-1]) if g.to else -1 for g in system.guards]

    class Stand:
        mode = 0
        events = 0

        def crossing(self, ta, g):
            target = last[g]
            if target >= 0:
                pars = comp.pars
                pars[P + self.mode] = 0.0
                pars[P + target] = 1.0
                self.mode = target
            self.events += 1
            return True

        def extremum(self, ta, guards):
            return True

    stand = Stand()
    mode0 = system.mode_index("free-")
    stand.mode = mode0
    comp.holder.run = stand
    comp.load(system.parameter_values, mode0, 1.0)
    comp.ta.time = 0.0
    comp.ta.state[:] = [0.95, 0.0] + [0.0] * (len(num.states) - 2)
    comp.ta.reset_cooldowns()
    comp.ta.propagate_until(T_END)
    comp.holder.run = None
    return stand.events


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="few repeats (smoke test)")
    args = ap.parse_args(argv)
    reps = 3 if args.quick else 25
    system = oscillator_system(CONTACT)
    t = time.perf_counter()
    compiled(system)
    compile_s = time.perf_counter() - t
    comp = compiled(system)
    # as the replay path builds it: its integrals scaled out of heyoka's error norm
    energy = oscillator_system(CONTACT, energy=True, integral_scale=INTEGRAL_SCALE)
    comp_energy = compiled(energy)
    cases = {
        "user system (heyoka loop)": lambda: io.simulate(system, T_END, [0.95, 0.0]),
        "user system's integrator, raw callbacks": lambda: raw_run(system, comp),
        "built-in heyoka path": lambda: io.simulate(CONTACT, T_END),
        "built-in on the hybrid loop + replay": lambda: run_on_hybrid_loop(CONTACT, T_END, 0.95, 0.0, record="full",
                                                                           max_events=10**6, tol=2.0**-52),
        "  its hybrid loop alone (integrals Q, Q2, W)": lambda: io.simulate(energy, T_END, [0.95, 0.0]),
        "  its integrator, raw callbacks (integrals Q, Q2, W)": lambda: raw_run(energy, comp_energy),
        "built-in compiled RK4 (default dt)": lambda: io.simulate(CONTACT, T_END, backend="rk4"),
    }
    events = {}
    for name, fn in cases.items():  # warm-up: compiles, caches
        out = fn()
        events[name] = out if isinstance(out, int) else len(out.events)
    times: dict[str, list[float]] = {name: [] for name in cases}
    cpu: dict[str, list[float]] = {name: [] for name in cases}
    order = list(cases)
    shuffle = random.Random(27).shuffle
    for _ in range(reps):  # interleaved, so that a busy machine slows every case alike
        # in a new order each round: a case that follows another integrator finds its code and data
        # out of the caches (the replay path after the piece loop took ~0.4 ms more than after itself)
        shuffle(order)
        for name in order:
            fn = cases[name]
            c = time.process_time()
            t = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t)
            cpu[name].append(time.process_time() - c)
    t = time.perf_counter()
    scipy_sol = io.simulate(system, T_END, [0.95, 0.0], backend="scipy")
    scipy_s = time.perf_counter() - t

    # The ratios are of CPU time (time.process_time): on a shared machine a run of a few ms is
    # descheduled for whole time slices, which wall-clock medians count and CPU time does not.
    med = {name: statistics.median(ts) for name, ts in cpu.items()}
    builtin, rk4 = med["built-in heyoka path"], med["built-in compiled RK4 (default dt)"]
    print(f"user system integrator compile (cold, tol=eps): {compile_s:.2f} s; repeats: {reps}; "
          f"load average {os.getloadavg()[0]:.2f}\n")
    print("| case | events | median CPU [ms] | median wall [ms] | best wall [ms] | CPU per event [us] "
          "| / built-in heyoka | RK4 / case |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name in cases:
        m, n = med[name], events[name]
        print(f"| {name} | {n} | {m * 1e3:.2f} | {statistics.median(times[name]) * 1e3:.2f} | "
              f"{min(times[name]) * 1e3:.2f} | {m / n * 1e6:.1f} | {m / builtin:.2f} | {rk4 / m:.1f} |")
    print(f"| user system (scipy loop, 1 run, wall) | {len(scipy_sol.events)} | | {scipy_s * 1e3:.1f} | | "
          f"{scipy_s / len(scipy_sol.events) * 1e6:.0f} | {scipy_s / builtin:.0f} | {rk4 / scipy_s:.2f} |")
    replay = med["built-in on the hybrid loop + replay"]
    floor = med["  its integrator, raw callbacks (integrals Q, Q2, W)"]
    print(f"\nTarget, the replay path at least 10x faster than the RK4: {'met' if rk4 / replay >= 10.0 else 'missed'} "
          f"({rk4 / replay:.1f}x; 10x is {rk4 / 10.0 * 1e3:.2f} ms; its integrator alone, no Python but the mode "
          f"switch, is {rk4 / floor:.1f}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
