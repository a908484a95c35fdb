"""``impactosc demo``: a short contacting case, its event and impact tables, and the paper's drive."""

from __future__ import annotations

import time


def add_parser(sub) -> None:
    p = sub.add_parser("demo", help="a short contacting case, its event and impact tables, and the paper's drive")
    p.set_defaults(handler=run)


def run(args) -> int:
    import impactosc as io

    from ..backends.heyoka import compiled_integrator

    osc = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
    print("impactosc demo: the tape edge between two flanges (paper eq. 3, two-sided flange)")
    print(f"  {osc}")
    print("  x0 = 0.95, v0 = 0 (paper eq. 6-7), t_end = 400 (nondimensional time omega_n t)\n")
    t = time.perf_counter()
    compiled_integrator(osc)  # the compile apart from the timed run
    io.simulate(osc, 1.0, x0=0.95, v0=0.0)  # and numba's compiled rules and records, loaded from its cache
    compile_s = time.perf_counter() - t
    t = time.perf_counter()
    sol = io.simulate(osc, 400.0, x0=0.95, v0=0.0)
    run_s = time.perf_counter() - t
    print("Events (first 15):")
    print(sol.event_table(limit=15))
    print("\nImpacts (first 10):")
    print(sol.impact_table(limit=10))
    print()
    print(sol.summary())
    print(f"heyoka integrator compiled (and numba's code loaded) once in {compile_s:.2f} s; this run took "
          f"{run_s * 1e3:.1f} ms "
          f"for {sum(sol.counts.values())} events.")
    drive = io.TapeDrive()
    lam = drive.seconds_to_lambda(1.0)
    t = time.perf_counter()
    tape = io.simulate(drive.oscillator(), lam, record="stats")
    tape_s = time.perf_counter() - t
    print("\nThe paper's own drive (section 5 parameters, 4 m/s, 1 N, mid pack), 1 s of tape motion:")
    print(f"  F = {drive.F:.3g}, Omega = {drive.Omega:.3g}, beta = {drive.beta:.3g}, K = {drive.K:.3g}; "
          f"1 s = {lam:.4g} time units")
    print(f"  {tape.summary()}")
    print(f"  -> the exact answer: no flange contact at all; {tape.counts['stick']} stick/release pairs. "
          f"({tape_s:.2f} s)")
    return 0
