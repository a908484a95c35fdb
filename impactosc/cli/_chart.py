"""``impactosc chart``: the contact-onset value over a grid of two parameters (a design chart)."""

from __future__ import annotations

import time

from ._common import (
    add_model_options,
    check_dataset_output,
    check_parameter_option,
    check_plot_output,
    parse_grid_values,
    plot_title,
    write_dataset,
)
from ._onset import add_onset_options, base_for, onset_kwargs


def add_parser(sub) -> None:
    p = sub.add_parser("chart", help="the contact-onset value over a grid of two parameters; netCDF and figure",
                       description="impactosc onset at every point of a grid of two other parameters "
                                   "(impactosc.dynamics.onset_chart), in parallel. Example: impactosc chart "
                                   "--param clearance --bracket 100e-6 140e-6 --grid speed=2,4,8 "
                                   "--grid tension=0.5,1,2 --start hi --transient-periods 1 --out chart.nc "
                                   "--plot chart.png (each point follows the orbit at the wide end to its "
                                   "grazing; --method transient --transient-periods 0.25 --record-periods 1 "
                                   "--stop-at-contact: the search on transients). Defaults for a chart: --start "
                                   "is the end of the bracket whose orbit touches no flange after the transient "
                                   "(checked once, on the base model), and a tape drive's transient is one forcing "
                                   "period (its free oscillation dies within a few milliseconds). Lengths are "
                                   "printed in micrometres.")
    add_model_options(p)
    add_onset_options(p)
    p.add_argument("--grid", action="append", required=True, metavar="FIELD=V1,V2,...",
                   help="a grid parameter and its values; give exactly two (the first is the y axis)")
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="FILE.nc|FILE.csv",
                   help="write the xarray Dataset: netCDF (.nc, scipy engine) or CSV (.csv, one row per point)")
    o.add_argument("--plot", metavar="PNG", help="filled contours of the critical value over the grid")
    o.add_argument("--serial", action="store_true", help="run in this process instead of a process pool")
    o.add_argument("--no-progress", action="store_true", help="no progress bar")
    # chart's own defaults (parser-level defaults override those of add_onset_options): see _defaults.
    p.set_defaults(handler=run, start=None)


def _grid(items) -> dict:
    grid = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"--grid {item!r}: expected field=v1,v2,... (e.g. --grid speed=2,4,8)")
        key, _, values = item.partition("=")
        key = key.strip().replace("-", "_")
        grid[key] = parse_grid_values("--grid", key, values)
    if len(grid) != 2:
        raise ValueError(f"--grid: give exactly two parameters, got {len(grid)} ({', '.join(grid) or 'none'})")
    return grid


#: Forcing periods of a tape drive's transient in a chart: the free oscillation of the paper's
#: drive dies out in about 6 ms, a forcing period lasts 11 ms (12 m/s on a 44 mm pack) or more.
DRIVE_TRANSIENT_PERIODS = 1


def _defaults(args, base) -> None:
    """Fill the chart's defaults: ``--start`` (the contact-free end) and a drive's ``--transient-periods``.

    The contact onset follows the orbit at the ``start`` end of the bracket to its first
    contact: from the end where the orbit already touches a flange the continuation follows
    impacting orbits, minutes per point (a tape drive's clearance chart from ``lo``: over
    5 minutes for one point, against 7-20 s from ``hi``).
    """
    from ..model import TapeDrive

    if args.method != "continuation":
        args.start = "lo" if args.start is None else args.start
        return
    if args.transient_periods is None and isinstance(base, TapeDrive):
        args.transient_periods = DRIVE_TRANSIENT_PERIODS
    if args.start is None:
        args.start = _contact_free_end(base, args)


def _contact_free_end(base, args) -> str:
    """``"hi"`` if only the high end of the bracket runs clear of the flanges after the transient, else ``"lo"``."""
    import dataclasses

    import impactosc as io

    from ..dynamics import forcing_period

    periods = 100 if args.transient_periods is None else args.transient_periods
    touches = []
    for value in args.bracket:
        if isinstance(base, io.TapeDrive):
            osc = base.replace(**{args.param: value}).oscillator()
        else:
            osc = dataclasses.replace(base, **{args.param: value})
        sol = io.simulate(osc, periods * forcing_period(osc), args.x0, args.v0, backend="auto", record="stats")
        touches.append(sol.contact_entries() > 0)
    return "hi" if touches == [True, False] else "lo"


def run(args) -> int:
    import numpy as np

    from ..dynamics import onset_chart

    base = base_for(args)
    grid = _grid(args.grid)
    for key in grid:
        check_parameter_option("--grid", base, key)
    if args.out:
        check_dataset_output("--out", args.out)
    check_plot_output("--plot", args.plot)
    _defaults(args, base)
    t = time.perf_counter()
    ds = onset_chart(base, args.param, tuple(args.bracket), grid, executor="serial" if args.serial else None,
                     progress=not args.no_progress, **onset_kwargs(args))
    wall = time.perf_counter() - t
    status = ds["status"].values
    failed = int(np.count_nonzero(status != 0))
    (k1, a1), (k2, a2) = ((k, ds[k].values) for k in ds["critical"].dims)
    print(f"onset chart of {args.param} for {plot_title(base)}")
    print(f"  {k1}[{a1.size}] x {k2}[{a2.size}] points: {wall:.2f} s wall, {failed} without an onset in the bracket "
          "or failed")
    print(f"  followed from the {args.start} end of the bracket"
          + (f", after {args.transient_periods:g} forcing periods" if args.transient_periods is not None else ""))

    def column(name: str, attrs) -> tuple[str, float]:
        """A length in metres is printed in micrometres (a tape engineer's unit), with its unit."""
        units = attrs.get("units", "")
        if units == "m":
            return f"{name} [um]", 1e6
        return (f"{name} [{units}]" if units not in ("", "1") else name), 1.0

    (h1, s1), (h2, s2) = column(k1, ds[k1].attrs), column(k2, ds[k2].attrs)
    hc, sc = column(args.param, ds["critical"].attrs)
    print(f"  {h1:>14} {h2:>14} {'critical ' + hc:>26} {'status':>6}")
    crit = ds["critical"].values
    for i in range(a1.size):
        for j in range(a2.size):
            print(f"  {a1[i] * s1:14.6g} {a2[j] * s2:14.6g} {crit[i, j] * sc:26.9g} {int(status[i, j]):6d}")
    if args.out:
        kind = write_dataset(ds, args.out)
        print(f"dataset written to {args.out} ({kind})")
    if args.plot:
        _plot(ds, base, args.plot)
        print(f"plot written to {args.plot}")
    return 0 if failed == 0 else 1


def _plot(ds, base, path: str) -> None:
    from .._util.optional import require_matplotlib
    from ..dynamics import plot_onset_chart

    plt = require_matplotlib()
    fig, ax = plt.subplots(figsize=(6.5, 4.5), constrained_layout=True)
    plot_onset_chart(ds, ax=ax)
    ax.set_title(plot_title(base), fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
