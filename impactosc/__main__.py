"""Command line: ``python -m impactosc demo``."""

from __future__ import annotations

import argparse
import sys
import time


def _demo(args) -> int:
    import impactosc as io
    from impactosc.backends.heyoka import integrator

    osc = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
    print("impactosc demo: the tape edge between two flanges (paper eq. 3, consistent two-sided flange)")
    print(f"  {osc}")
    print("  x0 = 0.95, v0 = 0 (paper eq. 6-7), t_end = 400 (nondimensional time omega_n t)\n")
    t = time.perf_counter()
    integrator()
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
    print(f"heyoka integrator compiled once in {compile_s:.2f} s; this run took {run_s * 1e3:.1f} ms "
          f"for {sum(sol.counts.values())} events.")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="impactosc", description="Event-driven tape-edge impact oscillator.")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("demo", help="run a short contacting case and print its event and impact tables")
    args = parser.parse_args(argv)
    try:
        return {"demo": _demo}[args.command](args)
    except (ValueError, TypeError) as exc:
        print(f"impactosc: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
