"""Command line: ``impactosc demo | simulate | sweep | paper`` (also ``python -m impactosc``).

Errors are reported as one line (``impactosc: error: ...``) with exit status 2.
"""

from __future__ import annotations

import argparse
import sys
import time

DRIVE_OPTIONS = {
    # option: (TapeDrive field, type, help)
    "speed": ("speed", float, "tape speed V [m/s]"),
    "tension": ("tension", float, "tape tension T [N]"),
    "pack-diameter": ("pack_diameter", float, "supply pack diameter D [m]"),
    "wrap-angle": ("wrap_angle", float, "wrap angle theta [deg]"),
    "thickness": ("thickness", float, "tape thickness h [m]"),
    "clearance": ("clearance", float, "flange clearance L [m]"),
    "friction": ("friction", float, "friction coefficient mu [-]"),
    "stiffness-ratio": ("stiffness_ratio", float, "flange/tape stiffness ratio K [-]"),
    "bending": ("bending", str, "bending reading of eq. 4: in-plane or out-of-plane"),
}
OSC_OPTIONS = ("F", "Omega", "beta", "K", "phase")


def _demo(args) -> int:
    import impactosc as io
    from impactosc.backends.heyoka import integrator

    osc = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
    print("impactosc demo: the tape edge between two flanges (paper eq. 3, two-sided flange)")
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


def _simulate(args) -> int:
    import impactosc as io

    osc_given = {k: getattr(args, k) for k in OSC_OPTIONS if getattr(args, k) is not None}
    drive_given = {field: getattr(args, opt.replace("-", "_")) for opt, (field, _, _) in DRIVE_OPTIONS.items()
                   if getattr(args, opt.replace("-", "_")) is not None}
    if osc_given and drive_given:
        raise ValueError("give either oscillator parameters (--F --Omega --beta --K --phase) "
                         "or tape-drive options (--speed --tension ...), not both")
    options = {}
    if args.tol is not None:
        options["tol"] = args.tol
    if args.dt is not None:
        options["dt"] = args.dt
    if osc_given:
        missing = [k for k in ("F", "Omega", "beta", "K") if k not in osc_given]
        if missing:
            raise ValueError(f"oscillator mode needs --F --Omega --beta --K; missing: {', '.join(missing)}")
        osc = io.Oscillator(**osc_given)
        t_end = 400.0 if args.t_end is None else args.t_end
        scale, unit = 1.0, "nondimensional time $\\Lambda = \\omega_n t$"
        header = f"{osc}, t_end = {t_end:g}"
    else:
        drive = io.TapeDrive(**drive_given)
        osc = drive.oscillator()
        duration = 0.01 if args.duration is None else args.duration
        t_end = drive.seconds_to_lambda(duration)
        scale, unit = 1e3 / drive.omega_n, "time t [ms]"
        header = drive.describe() + f"\n  duration {duration:g} s = {t_end:.6g} time units"
    record = "full" if args.plot else args.record
    sol = io.simulate(osc, t_end, args.x0, args.v0, backend=args.backend, record=record, **options)
    print(header)
    if record != "stats":
        print(f"\nEvents (first {args.events}):")
        print(sol.event_table(limit=args.events))
        print(f"\nImpacts (first {args.events}):")
        print(sol.impact_table(limit=args.events))
    print()
    print(sol.summary())
    if sol.status != 0:
        print(f"status {sol.status}: {sol.message}")
    if args.plot:
        from impactosc.plotting import plot_solution

        plot_solution(sol, args.plot, time_scale=scale, time_unit=unit)
        print(f"plot written to {args.plot}")
    return 0 if sol.status == 0 else 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="impactosc",
                                     description="Event-driven tape-edge / flange impact oscillator.")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("demo", help="a short contacting case, its event and impact tables, and the paper's drive")

    sim = sub.add_parser("simulate", help="run one oscillator or one tape drive and print its events",
                         description="Either oscillator parameters (nondimensional eq. 3) or tape-drive "
                                     "options in SI units (defaults: the paper's drive).")
    g = sim.add_argument_group("oscillator (nondimensional eq. 3)")
    for name in OSC_OPTIONS:
        g.add_argument(f"--{name}", type=float, help=f"{name} of eq. 3")
    g.add_argument("--t-end", type=float, help="end time in units of 1/omega_n (default 400)")
    d = sim.add_argument_group("tape drive (SI units, defaults from the paper)")
    for opt, (_, typ, text) in DRIVE_OPTIONS.items():
        d.add_argument(f"--{opt}", type=typ, help=text)
    d.add_argument("--duration", type=float, help="simulated time [s] (default 0.01)")
    sim.add_argument("--x0", type=float, default=0.95, help="initial X = x/L (default 0.95, eq. 6)")
    sim.add_argument("--v0", type=float, default=0.0, help="initial velocity dX/dLambda (default 0, eq. 7)")
    sim.add_argument("--backend", default="heyoka", help="heyoka (default), scipy, exact or rk4")
    sim.add_argument("--record", default="events", help="full, events (default) or stats")
    sim.add_argument("--tol", type=float, help="heyoka tolerance")
    sim.add_argument("--dt", type=float, help="rk4 step")
    sim.add_argument("--events", type=int, default=20, help="rows of the event and impact tables (default 20)")
    sim.add_argument("--plot", metavar="PNG", help="write a figure of X(t), flange force and phase portrait")
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    handlers = {"demo": _demo, "simulate": _simulate}
    try:
        return handlers[args.command](args)
    except (ValueError, TypeError, ImportError) as exc:
        print(f"impactosc: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
