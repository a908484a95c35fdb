"""``impactosc orbit``: a periodic orbit by Newton shooting, its Floquet multipliers; JSON and a figure."""

from __future__ import annotations

import json

from ._common import (
    add_model_options,
    check_output_file,
    check_plot_output,
    model_from_args,
    nonnegative_int,
    plot_title,
    positive_int,
)


def add_parser(sub) -> None:
    p = sub.add_parser("orbit", help="a periodic orbit by shooting and its Floquet multipliers; JSON and figure",
                       description="Newton shooting on the stroboscopic map from --guess X V (or from the end of a "
                                   "transient), the monodromy matrix from the saltation product, the multipliers "
                                   "and the verdict (impactosc.dynamics.periodic_orbit). Example: impactosc orbit "
                                   "--F 0.3 --Omega 0.8 --beta 0.05 --K 1e4 --guess 0.8 0 --json orbit.json "
                                   "--plot orbit.png")
    add_model_options(p)
    s = p.add_argument_group("shooting")
    s.add_argument("--periods", type=positive_int, default=1, help="forcing periods per orbit period (default 1)")
    s.add_argument("--guess", nargs=2, type=float, metavar=("X", "V"),
                   help="start of Newton on the section (default: the end of the transient)")
    s.add_argument("--x0", type=float, default=0.95, help="initial X of the transient (default 0.95)")
    s.add_argument("--v0", type=float, default=0.0, help="initial V of the transient (default 0)")
    s.add_argument("--transient-periods", type=nonnegative_int, default=100,
                   help="forcing periods of the transient, without --guess (default 100)")
    s.add_argument("--newton-tol", type=float, default=1e-11, help="Newton's tolerance on |P(z) - z| (default 1e-11)")
    s.add_argument("--max-iter", type=positive_int, default=50, help="Newton iterations at most (default 50)")
    s.add_argument("--backend", default="heyoka", help="heyoka (default), scipy or exact")
    o = p.add_argument_group("output")
    o.add_argument("--json", metavar="FILE", help="write the orbit (point, multipliers, verdict, events) as JSON")
    o.add_argument("--plot", metavar="PNG", help="the orbit in the phase plane, events marked")
    p.set_defaults(handler=run)


def orbit_record(orbit, base) -> dict:
    """The orbit as plain JSON types."""
    counts: dict[str, int] = {}
    if orbit.events is not None:
        for k in orbit.events.kind:
            counts[str(k)] = counts.get(str(k), 0) + 1
    return {"model": repr(base), "n": orbit.n, "period": orbit.period, "t0": orbit.t0, "x": orbit.x, "v": orbit.v,
            "multipliers": [[float(m.real), float(m.imag)] for m in orbit.multipliers],
            "spectral_radius": orbit.spectral_radius, "stability": orbit.stability, "collapsed": orbit.collapsed,
            "monodromy": [[float(a) for a in row] for row in orbit.monodromy], "status": orbit.status,
            "message": orbit.message, "iterations": orbit.iterations, "residual": orbit.residual,
            "events_per_period": counts}


def run(args) -> int:
    from ..dynamics import periodic_orbit

    base = model_from_args(args)
    if args.json:
        check_output_file("--json", args.json)
    check_plot_output("--plot", args.plot)
    orbit = periodic_orbit(base, args.periods, guess=None if args.guess is None else tuple(args.guess), x0=args.x0,
                           v0=args.v0, transient_periods=args.transient_periods, tol=args.newton_tol,
                           max_iter=args.max_iter, backend=args.backend)
    print(orbit.summary())
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(orbit_record(orbit, base), fh, indent=2)
            fh.write("\n")
        print(f"orbit written to {args.json}")
    if args.plot and orbit.solution is not None:
        _plot(orbit, base, args.plot)
        print(f"plot written to {args.plot}")
    return 0 if orbit.status == 0 else 1


def _plot(orbit, base, path: str) -> None:
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    fig, ax = plt.subplots(figsize=(6, 4.5), constrained_layout=True)
    orbit.plot(ax=ax)
    ax.set_title(plot_title(base), fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
