"""``impactosc simulate``: one oscillator or one tape drive, its events, impacts and a figure."""

from __future__ import annotations

from ._common import add_model_options, backend_options, check_plot_output, model_from_args, model_kind, nonnegative_int


def add_parser(sub) -> None:
    sim = sub.add_parser("simulate", help="run one oscillator or one tape drive and print its events",
                         description="Either oscillator parameters (nondimensional eq. 3) or tape-drive "
                                     "options in SI units (defaults: the paper's drive), and the family options "
                                     "of either (damping, flange law, restitution, spring exponent, harmonics).")
    add_model_options(sim)
    sim.add_argument("--t-end", type=float, help="end time of an oscillator run, in units of 1/omega_n (default 400)")
    sim.add_argument("--duration", type=float, help="simulated time of a tape drive [s] (default 0.01)")
    sim.add_argument("--x0", type=float, default=0.95, help="initial X = x/L (default 0.95, eq. 6)")
    sim.add_argument("--v0", type=float, default=0.0, help="initial velocity dX/dLambda (default 0, eq. 7)")
    sim.add_argument("--backend", default="heyoka", help="heyoka (default), scipy, exact, rk4 or auto (exact for a "
                                                        "linear flange law with numba, else heyoka)")
    sim.add_argument("--record", default="events", help="full, events (default) or stats")
    sim.add_argument("--tol", type=float, help="heyoka tolerance")
    sim.add_argument("--dt", type=float, help="rk4 step")
    sim.add_argument("--events", type=nonnegative_int, default=20,
                     help="rows of the event and impact tables (default 20)")
    sim.add_argument("--plot", metavar="PNG", help="write a figure of X(t), flange force and phase portrait")
    sim.set_defaults(handler=run)


def run(args) -> int:
    import impactosc as io

    kind = model_kind(args)
    if kind == "oscillator" and args.duration is not None:
        raise ValueError("--duration (seconds) is for a tape drive; an oscillator runs to --t-end "
                         "(nondimensional time)")
    if kind == "drive" and args.t_end is not None:
        raise ValueError("--t-end (nondimensional time) is for an oscillator; a tape drive runs for --duration "
                         "(seconds)")
    model = model_from_args(args)
    if kind == "oscillator":
        osc = model
        t_end = 400.0 if args.t_end is None else args.t_end
        scale, unit = 1.0, "nondimensional time $\\Lambda = \\omega_n t$"
        header = f"{osc}, t_end = {t_end:g}"
    else:
        osc = model.oscillator()
        duration = 0.01 if args.duration is None else args.duration
        t_end = model.seconds_to_lambda(duration)
        scale, unit = 1e3 / model.omega_n, "time t [ms]"
        header = model.describe() + f"\n  duration {duration:g} s = {t_end:.6g} time units"
    check_plot_output("--plot", args.plot)  # matplotlib and the path, before the run
    record = "full" if args.plot else args.record
    sol = io.simulate(osc, t_end, args.x0, args.v0, backend=args.backend, record=record, **backend_options(args))
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
        from ..results import plot_solution

        plot_solution(sol, args.plot, time_scale=scale, time_unit=unit)
        print(f"plot written to {args.plot}")
    return 0 if sol.status == 0 else 1
