"""``impactosc continue``: a branch of periodic orbits followed in one parameter, and a boundary in two."""

from __future__ import annotations

import time
from pathlib import Path

from ._common import (
    add_model_options,
    check_output_file,
    check_plot_output,
    model_from_args,
    nonnegative_int,
    plot_title,
    positive_int,
)

#: The kinds of special point ``--special`` may name (those a boundary in two parameters follows).
BOUNDARY_KINDS = ("grazing", "stick_onset", "fold", "period_doubling")


def add_parser(sub) -> None:
    p = sub.add_parser("continue", help="follow a branch of periodic orbits in a parameter (continuation); its "
                                        "special points, a boundary in two parameters; netCDF and figure",
                       description="Pseudo-arclength continuation of the period-N orbit through --guess X V (or "
                                   "the one a transient reaches) as --param runs over --limits, with its stability, "
                                   "event signature and special points (folds, period doublings, grazings, stick "
                                   "onsets) located (impactosc.dynamics.continuation). With --boundary NAME LO HI "
                                   "and --special KIND, the first special point of that kind is then followed in "
                                   "the two parameters. Example: impactosc continue --F 0.3 --Omega 0.8 --beta 0.05 "
                                   "--K 1e4 --param F --limits 0.3 0.5 --guess 0.8 0 --boundary Omega 0.7 0.9 "
                                   "--special grazing --out branch.nc --plot branch.png (the boundary goes to "
                                   "branch_boundary.nc, or --boundary-out)")
    add_model_options(p)
    c = p.add_argument_group("continuation")
    c.add_argument("--param", required=True, help="the free parameter (an oscillator's F, Omega ...; a drive's "
                                                  "field in SI units, e.g. clearance)")
    c.add_argument("--limits", nargs=2, type=float, required=True, metavar=("LO", "HI"),
                   help="the parameter range; the model's own value (LO when an oscillator leaves it out) must lie "
                        "in it")
    c.add_argument("--guess", nargs=2, type=float, metavar=("X", "V"),
                   help="start of Newton on the section (default: the end of a transient from --x0 --v0)")
    c.add_argument("--x0", type=float, default=0.95, help="initial X of the transient (default 0.95)")
    c.add_argument("--v0", type=float, default=0.0, help="initial V of the transient (default 0)")
    c.add_argument("--transient-periods", type=nonnegative_int, default=100,
                   help="forcing periods of the transient, without --guess (default 100)")
    c.add_argument("--periods", type=positive_int, default=1, help="forcing periods per orbit period (default 1)")
    c.add_argument("--direction", choices=("both", "forward", "backward"), default="both",
                   help="forward: increasing parameter at the start (default both)")
    c.add_argument("--step", type=float, default=0.02, help="first arclength step, scaled (default 0.02)")
    c.add_argument("--max-step", type=float, default=0.1, help="largest arclength step (default 0.1)")
    c.add_argument("--min-step", type=float, default=1e-7, help="smallest arclength step (default 1e-7)")
    c.add_argument("--max-points", type=positive_int, default=500, help="points per direction (default 500)")
    c.add_argument("--backend", help="exact (default where it runs the model), heyoka or scipy")
    b = p.add_argument_group("boundary in two parameters")
    b.add_argument("--boundary", nargs=3, metavar=("NAME", "LO", "HI"),
                   help="a second parameter and its range: follow the --special point in (--param, NAME)")
    b.add_argument("--special", choices=BOUNDARY_KINDS,
                   help="the kind of special point whose first occurrence on the branch is followed")
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="FILE.nc", help="write the branch as netCDF with its model, one row per point "
                                                    "(Branch.save; impactosc.dynamics.Branch.load reads it back)")
    o.add_argument("--boundary-out", metavar="FILE.nc",
                   help="with --boundary: write the boundary there (default: FILE_boundary.nc beside --out)")
    o.add_argument("--plot", metavar="PNG", help="the branch, stable solid and unstable dashed, special points "
                                                 "labelled (and the boundary beside it)")
    p.set_defaults(handler=run)


def _boundary(args):
    """``(name, (lo, hi))`` of ``--boundary``, or None; checked before anything runs."""
    if args.boundary is None:
        if args.special is not None:
            raise ValueError("--special needs --boundary NAME LO HI (the second parameter to follow it in)")
        return None
    if args.special is None:
        raise ValueError("--boundary needs --special KIND (the special point to follow)")
    name, lo, hi = args.boundary
    try:
        lo, hi = float(lo), float(hi)
    except ValueError:
        raise ValueError(f"--boundary {name} {lo} {hi}: LO and HI must be numbers") from None
    if not lo < hi:
        raise ValueError(f"--boundary must satisfy LO < HI, got {lo:g} {hi:g}")
    name = name.replace("-", "_")
    if name == args.param:
        raise ValueError(f"--boundary names the second parameter; it must differ from --param {args.param}")
    return name, (lo, hi)


def run(args) -> int:
    from ..dynamics import parameter_names, periodic_orbit
    from ..dynamics.continuation import continuation

    args.param = args.param.replace("-", "_")
    lo, hi = args.limits
    if not lo < hi:
        raise ValueError(f"--limits must satisfy LO < HI, got {lo:g} {hi:g}")
    boundary = _boundary(args)
    base = model_from_args(args, free=((args.param, lo),) if args.param in ("F", "Omega", "beta", "K") else ())
    names = parameter_names(base)
    for option, name in (("--param", args.param), ("--boundary", None if boundary is None else boundary[0])):
        if name is not None and name not in names:
            raise ValueError(f"{option} must be one of {', '.join(names)}, got {name!r}")
    outputs = _outputs(args, boundary)
    for option, path in outputs.items():
        check_output_file(option, path)
    check_plot_output("--plot", args.plot)
    backend = args.backend or ("exact" if _exact(base) else "heyoka")
    t = time.perf_counter()
    if args.guess is not None:
        start = tuple(args.guess)
        orbit = periodic_orbit(base, args.periods, guess=start, backend=backend)
        origin = f"through the guess ({start[0]:g}, {start[1]:g})"
    else:
        orbit = periodic_orbit(base, args.periods, x0=args.x0, v0=args.v0, transient_periods=args.transient_periods,
                               backend=backend)
        origin = f"reached by a transient of {args.transient_periods} periods from ({args.x0:g}, {args.v0:g})"
    if orbit.status != 0:
        print(f"no period-{args.periods} orbit {origin}: {orbit.message}")
        return 1
    # no backend given: continuation picks one that runs every member of the range (heyoka past exponent 1)
    branch = continuation(orbit, args.param, (lo, hi), base=base, backend=args.backend, direction=args.direction,
                          step=args.step, min_step=args.min_step, max_step=args.max_step, max_points=args.max_points)
    wall = time.perf_counter() - t
    print(f"continuation of {plot_title(base)}")
    print(f"  start: the period-{args.periods} orbit {origin}, {orbit.stability}; {wall:.2f} s wall")
    print(branch.summary())
    result, curve = branch, None
    if boundary is not None:
        found = branch.find(args.special)
        if not found:
            print(f"no {args.special} point on the branch: no boundary to follow")
            return 1
        t = time.perf_counter()
        curve = continuation(found[0], (args.param, boundary[0]), {boundary[0]: boundary[1]},
                             max_points=args.max_points)
        print(f"boundary of {found[0].label} ({args.special}) in ({args.param}, {boundary[0]}): "
              f"{time.perf_counter() - t:.2f} s wall")
        print(curve.summary())
        result = curve
    if "--out" in outputs:
        branch.save(outputs["--out"])
        print(f"branch written to {outputs['--out']}")
    if curve is not None and "--boundary-out" in outputs:
        curve.save(outputs["--boundary-out"])
        print(f"boundary written to {outputs['--boundary-out']}")
    if args.plot:
        _plot(branch, curve, base, args.plot)
        print(f"plot written to {args.plot}")
    return 0 if result.status in (0, 2) else 1


def _outputs(args, boundary) -> dict:
    """``{option: path}`` of the netCDF files to write: the branch, and the boundary beside it."""
    out = {}
    if args.out:
        out["--out"] = args.out
    if args.boundary_out and boundary is None:
        raise ValueError("--boundary-out needs --boundary NAME LO HI (there is no boundary to write)")
    if boundary is not None and (args.boundary_out or args.out):
        out["--boundary-out"] = args.boundary_out or str(Path(args.out).with_name(Path(args.out).stem
                                                                                   + "_boundary.nc"))
    for option, path in out.items():
        if Path(path).suffix.lower() not in (".nc", ".nc4", ".netcdf"):
            raise ValueError(f"{option} {path}: the file is netCDF, so its name must end in .nc")
    return out


def _exact(base) -> bool:
    """Whether the exact backend runs ``base`` (the default of continuation, used for the start too)."""
    from .. import simulate

    osc = base.oscillator() if hasattr(base, "oscillator") else base
    try:
        simulate(osc, 1e-9, 0.0, 0.0, backend="exact", record="stats")
    except ValueError:
        return False
    return True


def _plot(branch, curve, base, path: str) -> None:
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    ncols = 1 if curve is None else 2
    fig, axes = plt.subplots(1, ncols, figsize=(6.5 * ncols, 4.5), constrained_layout=True, squeeze=False)
    branch.plot(ax=axes[0, 0])
    axes[0, 0].set_title(f"{plot_title(base)}\nbranch of period-{branch.n} orbits (solid stable, dashed unstable)",
                         fontsize=8)
    if curve is not None:
        p1, p2 = curve.names
        ax = axes[0, 1]
        ax.plot(curve.values(p1), curve.values(p2), "-", color="C1", lw=1.4)
        ax.set_xlabel(p1)
        ax.set_ylabel(p2)
        ax.set_title("the special point followed in two parameters", fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
