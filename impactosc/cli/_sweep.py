"""``impactosc sweep``: a grid of tape drives run in parallel; a table, a netCDF file and a figure."""

from __future__ import annotations

import time
from typing import Any

from ._common import (
    add_drive_options,
    backend_options,
    check_dataset_output,
    check_output_dir,
    check_plot_output,
    drive_fields,
    nonnegative_int,
    pandas_display,
    parse_grid_values,
    write_dataset,
)


def add_parser(sub) -> None:
    sw = sub.add_parser("sweep", help="run a grid of tape drives in parallel; table, netCDF and figure",
                        description="The outer product of a grid of TapeDrive fields (SI units), run in parallel "
                                    "with impactosc.sweep. Example: impactosc sweep "
                                    "--grid clearance=100e-6,110e-6,120e-6 --grid speed=2,4,8 --duration 0.05 "
                                    "--out sweep.nc --plot sweep.png")
    sw.add_argument("--grid", action="append", metavar="FIELD=V1,V2,...",
                    help="a swept TapeDrive field (or t_sin_half_theta) and its values; repeat for more dimensions "
                         "(the first is the x axis of --plot, the second one line per value)")
    sw.add_argument("--toml", metavar="FILE", help="TOML file with a [grid] table (field = [values]) and an optional "
                                                   "[drive] table of base TapeDrive fields; --grid adds to it")
    add_drive_options(sw.add_argument_group("base drive (SI units, defaults from the paper)"))
    sw.add_argument("--duration", type=float, default=1.0, help="simulated time per point [s] (default 1, the paper)")
    sw.add_argument("--backend", default="auto", help="auto (default: exact for a linear flange law with numba, "
                                                      "else heyoka), heyoka, scipy, exact or rk4")
    sw.add_argument("--tol", type=float, help="heyoka tolerance")
    sw.add_argument("--dt", type=float, help="rk4 step")
    sw.add_argument("--out", metavar="FILE.nc|FILE.csv",
                   help="write the xarray Dataset: netCDF (.nc, scipy engine) or CSV (.csv, one row per point)")
    sw.add_argument("--store", metavar="DIR", help="resumable per-point store (rerun to continue or extend)")
    sw.add_argument("--plot", metavar="PNG", help="mean flange force vs the first swept field, a line per value of "
                                                  "the others")
    sw.add_argument("--rows", type=nonnegative_int, default=30, help="rows of the printed table (default 30)")
    sw.add_argument("--serial", action="store_true", help="run in this process instead of a process pool")
    sw.add_argument("--no-progress", action="store_true", help="no progress bar")
    sw.set_defaults(handler=run)


def _parse_grid_option(item: str) -> tuple[str, list]:
    from ..sweeps import SWEEP_KEYS

    if "=" not in item:
        raise ValueError(f"--grid {item!r}: expected field=v1,v2,... (e.g. --grid speed=4,8,12)")
    key, _, values = item.partition("=")
    key = key.strip().replace("-", "_")
    if key not in SWEEP_KEYS:
        raise ValueError(f"--grid: unknown field {key!r}; valid fields: {', '.join(SWEEP_KEYS)}")
    if not values.strip(" ,"):
        raise ValueError(f"--grid {item!r}: no values after '='")
    return key, parse_grid_values("--grid", key, values)


def _read_toml(path: str) -> tuple[dict[str, list[Any]], dict[str, Any]]:
    import tomllib

    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except OSError as exc:
        raise ValueError(f"--toml {path}: cannot read it ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"--toml {path}: not valid TOML ({exc})") from None
    unknown = sorted(set(doc) - {"grid", "drive"})
    if unknown:
        raise ValueError(f"--toml {path}: unknown table(s) {unknown}; expected [grid] and optional [drive]")
    grid, drive = doc.get("grid", {}), doc.get("drive", {})
    if not isinstance(grid, dict) or not isinstance(drive, dict):
        raise ValueError(f"--toml {path}: [grid] and [drive] must be tables")
    grid = {k: (v if isinstance(v, list) else [v]) for k, v in grid.items()}
    return grid, drive


def run(args) -> int:
    import impactosc as io

    grid: dict[str, list[Any]] = {}  # sweep field -> its values
    base_fields: dict[str, Any] = {}  # TapeDrive keyword arguments of the base drive
    if args.toml:
        grid, base_fields = _read_toml(args.toml)
    for item in args.grid or []:
        key, values = _parse_grid_option(item)
        grid[key] = values
    if not grid:
        raise ValueError("give a grid: --grid field=v1,v2,... (repeatable) or --toml FILE with a [grid] table")
    base_fields.update(drive_fields(args))
    base = io.TapeDrive(**base_fields)
    # Fail before the sweep runs, not after it.
    if args.out:
        check_dataset_output("--out", args.out)
    check_plot_output("--plot", args.plot)
    if args.store:
        check_output_dir("--store", args.store)
    t = time.perf_counter()
    ds = io.sweep(base, grid, duration=args.duration, backend=args.backend,
                  executor="serial" if args.serial else None, progress=not args.no_progress, store=args.store,
                  **backend_options(args))
    wall = time.perf_counter() - t
    n = int(ds["status"].size)
    failed = int((ds["status"] != 0).sum())
    print(f"sweep: {n} points ({' x '.join(f'{k}[{ds.sizes[k]}]' for k in grid)}), {args.duration:g} s each, "
          f"backend {ds.attrs['backend_used'] or args.backend}: {wall:.2f} s wall, {failed} failed")
    # the mean force of Fig. 7-8, then what a flange sensor reads (impact rate, the AE proxy of impact forces)
    columns = ["mean_flange_force", "impacts", "impact_rate", "ae_impact_sum", "sticks", "status"]
    table = ds[columns].to_dataframe().reset_index()
    with pandas_display():
        print(table.head(args.rows).to_string(index=False))
    if n > args.rows:
        print(f"... {n - args.rows} more rows (--rows, or --out FILE.nc for all of them)")
    if args.out:
        kind = write_dataset(ds, args.out)
        print(f"dataset written to {args.out} ({kind})")
    if args.plot:
        _plot_sweep(ds, list(grid), args.plot)
        print(f"plot written to {args.plot}")
    return 0 if failed == 0 else 1


def _plot_sweep(ds, dims: list, path: str) -> None:
    import itertools

    import numpy as np

    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    x_dim, rest = dims[0], dims[1:]
    var = ds["mean_flange_force"].transpose(*dims)
    x = ds[x_dim].values
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    combos = list(itertools.product(*(range(ds.sizes[d]) for d in rest))) if rest else [()]
    for i, combo in enumerate(combos):
        sel = dict(zip(rest, combo, strict=True))
        y = var.isel(sel).values
        label = ", ".join(f"{d} = {ds[d].values[j]:g} {ds[d].attrs.get('units', '')}".strip()
                          if np.issubdtype(ds[d].dtype, np.number) else f"{d} = {ds[d].values[j]}"
                          for d, j in sel.items()) or None
        ax.plot(x, y, "o-", ms=3, color=f"C{i % 10}", label=label)
    unit = ds[x_dim].attrs.get("units", "")
    ax.set_xlabel(f"{ds[x_dim].attrs.get('long_name', x_dim)} [{unit}]" if unit else x_dim)
    ax.set_ylabel("mean flange force, both flanges [N]")
    ax.set_title(f"sweep: {ds.attrs.get('duration', 0):g} s per point, backend "
                 f"{ds.attrs.get('backend_used') or ds.attrs.get('backend', '')}",
                 fontsize=9)
    ax.grid(alpha=0.3)
    if len(combos) > 1 or combos[0]:
        ax.legend(fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)



