"""Speed of user hybrid systems and of the built-in heyoka path: the paper's eq. 3 on the one hybrid loop.

Run: ``.venv/bin/python benchmarks/system_speed.py [--quick]``. Prints a markdown table.
On the contact case (``F=0.5, Omega=1.1, beta=0.01, K=1e4``, ``t_end=400``, 328 events), side by
side in one run (every case once a round, rounds in shuffled orders, CPU-time medians):

- the user system on its heyoka loop (``impactosc.model.hybrid.oscillator_system``) and its
  compiled integrator with callbacks that only switch the mode (no resets, records or checks);
- the built-in heyoka path, ``simulate(osc, backend="heyoka")``: a spring-flange member runs as
  ``oscillator_system(osc, energy=True)`` (integrals ``Q, Q2, W``, scaled out of heyoka's error
  norm) on the same loop and is replayed into the built-in ``Solution``
  (``impactosc.backends.heyoka._replay``). Its parts: the hybrid loop alone, that system's
  integrator with the mode-switching callbacks only (the floor: the Taylor steps its states and
  events cost), and the replay of a stored run into the ``Solution``;
- the compiled RK4 at its default step, and the user system on the scipy loop (the cross-check,
  one run).

The row of the engine's old piece loop on the same member (3.96 ms at the end of the fourth
session, ``results/system_speed.md``) is gone with that loop: the built-in heyoka path has one
loop, and its floor is the row of its integrator with raw callbacks.

Targets: the user system within 1.5x of the built-in heyoka path per event; the built-in heyoka
path at least 10x faster than the RK4. The compile of the user system's integrator is timed once
(cold, in this process).
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import time

import impactosc as io
from impactosc.backends._hybrid_heyoka import compiled, run_counted
from impactosc.backends.heyoka import _replay as replay
from impactosc.backends.heyoka._replay import INTEGRAL_SCALE
from impactosc.engine._driver import initial_mode
from impactosc.model.hybrid import oscillator_system
from impactosc.model.hybrid._numeric import numeric
from impactosc.results._solution import Solution, _Recorder

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


def stored_replay(osc, t_end):
    """The built-in path's replay of a stored hybrid run into the ``Solution`` (what follows the loop)."""
    system, modes, _, guards, slots = replay._system(osc)
    start = initial_mode(osc, 0.0, 0.95, 0.0)
    hybrid, _ = run_counted(system, t_end, [0.95, 0.0], mode="free-", max_events=10**6, quiet_at_start="free- stop")

    def run():
        rec = _Recorder("full", "heyoka", replay._Evaluator(osc, 2.0**-52))
        replay._replay(osc, hybrid, rec, modes, guards, slots, start, 10**6, t_end)
        return Solution(rec, t_end)

    return run


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
        "built-in heyoka path (simulate, backend='heyoka')": lambda: io.simulate(CONTACT, T_END, backend="heyoka"),
        "  its hybrid loop alone (integrals Q, Q2, W)": lambda: io.simulate(energy, T_END, [0.95, 0.0]),
        "  its integrator, raw callbacks (integrals Q, Q2, W)": lambda: raw_run(energy, comp_energy),
        "  its replay of a stored run into the Solution": stored_replay(CONTACT, T_END),
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
        # out of the caches (the replay path after the old piece loop took ~0.4 ms more than after itself)
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
    builtin, rk4 = med["built-in heyoka path (simulate, backend='heyoka')"], med["built-in compiled RK4 (default dt)"]
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
    floor = med["  its integrator, raw callbacks (integrals Q, Q2, W)"]
    print(f"\nTarget, the built-in heyoka path at least 10x faster than the RK4: "
          f"{'met' if rk4 / builtin >= 10.0 else 'missed'} ({rk4 / builtin:.1f}x; 10x is {rk4 / 10.0 * 1e3:.2f} ms; "
          f"its integrator alone, no Python but the mode switch, is {rk4 / floor:.1f}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
