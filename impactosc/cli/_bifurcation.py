"""``impactosc bifurcation``: a stroboscopic bifurcation diagram to netCDF and a figure."""

from __future__ import annotations

import time

import numpy as np

from ._common import (
    add_backend_options,
    add_model_options,
    backend_options,
    check_dataset_output,
    check_output_dir,
    check_plot_output,
    model_from_args,
    nonnegative_int,
    plot_title,
    positive_int,
    write_dataset,
)


def add_parser(sub) -> None:
    p = sub.add_parser("bifurcation", help="a stroboscopic bifurcation diagram over one parameter; netCDF and figure",
                       description="The stroboscopic section (once per forcing period) after a transient, at --n "
                                   "values of --param evenly spaced over --range (impactosc.dynamics."
                                   "bifurcation_diagram). Example: impactosc bifurcation --F 0.3 --Omega 0.8 "
                                   "--beta 0.05 --K 1e4 --param F --range 0.2 0.6 --n 50 --out bif.nc --plot bif.png")
    add_model_options(p)
    s = p.add_argument_group("diagram")
    s.add_argument("--param", required=True, help="the parameter to vary (an oscillator's F, Omega, beta ...; "
                                                  "a drive's field in SI units, e.g. speed)")
    s.add_argument("--range", nargs=2, type=float, required=True, metavar=("LO", "HI"), help="its first and last value")
    s.add_argument("--n", type=positive_int, default=50, help="values over the range (default 50)")
    s.add_argument("--transient-periods", type=nonnegative_int, default=200,
                   help="forcing periods discarded at every value (default 200)")
    s.add_argument("--record-periods", type=positive_int, default=50,
                   help="forcing periods recorded at every value (default 50)")
    s.add_argument("--continuation", choices=("none", "forward", "backward", "both"), default="none",
                   help="none: every value from (x0, v0); forward/backward/both: each value from the previous "
                        "final state (hysteresis)")
    s.add_argument("--x0", type=float, default=0.95, help="initial X (default 0.95)")
    s.add_argument("--v0", type=float, default=0.0, help="initial V (default 0)")
    add_backend_options(p, dt=False)
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="FILE.nc|FILE.csv",
                   help="write the xarray Dataset: netCDF (.nc, scipy engine) or CSV (.csv, one row per point)")
    o.add_argument("--plot", metavar="PNG", help="the diagram: section points X against the parameter")
    o.add_argument("--store", metavar="DIR", help="resumable per-value store (rerun to continue)")
    o.add_argument("--serial", action="store_true", help="run in this process instead of a process pool")
    o.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(handler=run)


def distinct_points(x: np.ndarray, rtol: float = 1e-6) -> int:
    """Distinct values among the recorded section points (1: a period-1 orbit; many: no period)."""
    x = np.sort(x[np.isfinite(x)])
    if x.size == 0:
        return 0
    return int(1 + np.count_nonzero(np.diff(x) > rtol * max(1.0, float(np.max(np.abs(x))))))


def run(args) -> int:
    from ..dynamics import bifurcation_diagram, parameter_names

    lo, hi = args.range
    base = model_from_args(args, free=((args.param, lo),) if args.param in ("F", "Omega", "beta", "K") else ())
    if args.param not in parameter_names(base):
        raise ValueError(f"--param must be one of {', '.join(parameter_names(base))} for a {type(base).__name__}, "
                         f"got {args.param!r}")
    if not lo < hi:
        raise ValueError(f"--range must satisfy LO < HI, got {lo:g} {hi:g}")
    if args.out:
        check_dataset_output("--out", args.out)
    check_plot_output("--plot", args.plot)
    if args.store:
        check_output_dir("--store", args.store)
    values = np.linspace(lo, hi, args.n)
    t = time.perf_counter()
    ds = bifurcation_diagram(base, args.param, values, transient_periods=args.transient_periods,
                             record_periods=args.record_periods, continuation=args.continuation, x0=args.x0,
                             v0=args.v0, backend=args.backend, executor="serial" if args.serial else None,
                             store=args.store, progress=not args.no_progress, **backend_options(args))
    wall = time.perf_counter() - t
    status = ds["status"].values
    failed = int(np.count_nonzero(status != 0))
    print(f"bifurcation diagram of {plot_title(base)}")
    print(f"  {args.param} over [{lo:g}, {hi:g}], {args.n} values, {args.transient_periods} transient + "
          f"{args.record_periods} recorded periods, continuation {args.continuation}, backend {args.backend}: "
          f"{wall:.2f} s wall, {failed} failed")
    print(f"  {'direction':>11} {args.param:>12} {'status':>6} {'points':>6} {'min X':>10} {'max X':>10}")
    x = ds["x"].values
    for d, label in enumerate(ds["direction"].values.tolist()):
        for i, value in enumerate(values):
            row = x[d, i]
            ok = np.isfinite(row)
            lo_x = f"{np.min(row[ok]):10.6f}" if ok.any() else f"{'nan':>10}"
            hi_x = f"{np.max(row[ok]):10.6f}" if ok.any() else f"{'nan':>10}"
            print(f"  {label:>11} {value:12.6g} {int(status[d, i]):6d} {distinct_points(row):6d} {lo_x} {hi_x}")
    print("  (points: distinct section points among the recorded periods; 1 is a period-1 orbit)")
    if args.out:
        kind = write_dataset(ds, args.out)
        print(f"dataset written to {args.out} ({kind})")
    if args.plot:
        _plot(ds, base, args.plot)
        print(f"plot written to {args.plot}")
    return 0 if failed == 0 else 1


def _plot(ds, base, path: str) -> None:
    from .._util.optional import require_matplotlib
    from ..dynamics import plot_bifurcation

    plt = require_matplotlib()
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    plot_bifurcation(ds, ax=ax, markersize=2.0)
    ax.set_title(plot_title(base), fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
