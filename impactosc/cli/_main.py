"""Command line: ``impactosc demo | simulate | sweep | paper`` (also ``python -m impactosc``).

Errors are reported as one line (``impactosc: error: ...``) with exit status 2; output
paths are checked before anything is computed. Exit status 1: the run finished but failed
(a simulation's status, a sweep's failed points); 130: interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

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


def _nonnegative_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid int value: {text!r}") from None
    if n < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {n}")
    return n


def _probe_writable(option: str, path: str, directory: Path) -> None:
    try:
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as exc:
        raise ValueError(f"{option} {path}: cannot write in {str(directory)!r} ({exc.strerror or exc})") from None


def check_output_file(option: str, path: str) -> None:
    """Fail now, not after the computing, if ``path`` cannot be written as a file."""
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{option} {path}: is a directory; give a file name")
    parent = p.parent
    if not parent.is_dir():
        raise ValueError(f"{option} {path}: directory {str(parent)!r} does not exist")
    if p.exists() and not os.access(p, os.W_OK):
        raise ValueError(f"{option} {path}: the file is not writable")
    _probe_writable(option, path, parent)


def check_output_dir(option: str, path: str) -> None:
    """Fail now if ``path`` is not a directory that exists or can be created, and written in."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{option} {path}: exists and is not a directory")
    existing = p
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise ValueError(f"{option} {path}: {str(existing)!r} is not a directory")
    _probe_writable(option, path, existing)


def _demo(args) -> int:
    import impactosc as io

    from ..backends.heyoka import integrator

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
    if args.plot:
        check_output_file("--plot", args.plot)
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
        from ..results import plot_solution

        plot_solution(sol, args.plot, time_scale=scale, time_unit=unit)
        print(f"plot written to {args.plot}")
    return 0 if sol.status == 0 else 1


def _parse_grid_value(key: str, text: str):
    if key == "bending":
        return text.strip()
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--grid {key}: {text.strip()!r} is not a number") from None


def _parse_grid_option(item: str) -> tuple[str, list]:
    from ..sweeps import SWEEP_KEYS

    if "=" not in item:
        raise ValueError(f"--grid {item!r}: expected field=v1,v2,... (e.g. --grid speed=4,8,12)")
    key, _, values = item.partition("=")
    key = key.strip().replace("-", "_")
    if key not in SWEEP_KEYS:
        raise ValueError(f"--grid: unknown field {key!r}; valid fields: {', '.join(SWEEP_KEYS)}")
    parts = [v for v in values.split(",") if v.strip()]
    if not parts:
        raise ValueError(f"--grid {item!r}: no values after '='")
    return key, [_parse_grid_value(key, v) for v in parts]


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


def _sweep(args) -> int:
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
    base_fields.update({field: getattr(args, opt.replace("-", "_")) for opt, (field, _, _) in DRIVE_OPTIONS.items()
                        if getattr(args, opt.replace("-", "_")) is not None})
    base = io.TapeDrive(**base_fields)
    # Fail before the sweep runs, not after it.
    if args.out:
        check_output_file("--out", args.out)
    if args.plot:
        from .._util.optional import require_matplotlib

        require_matplotlib()
        check_output_file("--plot", args.plot)
    if args.store:
        check_output_dir("--store", args.store)
    options = {}
    if args.tol is not None:
        options["tol"] = args.tol
    if args.dt is not None:
        options["dt"] = args.dt
    t = time.perf_counter()
    ds = io.sweep(base, grid, duration=args.duration, backend=args.backend,
                  executor="serial" if args.serial else None, progress=not args.no_progress, store=args.store,
                  **options)
    wall = time.perf_counter() - t
    n = int(ds["status"].size)
    failed = int((ds["status"] != 0).sum())
    print(f"sweep: {n} points ({' x '.join(f'{k}[{ds.sizes[k]}]' for k in grid)}), {args.duration:g} s each, "
          f"backend {args.backend}: {wall:.2f} s wall, {failed} failed")
    table = ds[["mean_flange_force", "impacts", "sticks", "status"]].to_dataframe().reset_index()
    with _pandas_display():
        print(table.head(args.rows).to_string(index=False))
    if n > args.rows:
        print(f"... {n - args.rows} more rows (--rows, or --out FILE.nc for all of them)")
    if args.out:
        ds.to_netcdf(args.out, engine="scipy")
        print(f"dataset written to {args.out}")
    if args.plot:
        _plot_sweep(ds, list(grid), args.plot)
        print(f"plot written to {args.plot}")
    return 0 if failed == 0 else 1


class _pandas_display:
    def __enter__(self):
        import pandas as pd

        self._ctx = pd.option_context("display.width", 200, "display.float_format", "{:.6g}".format)
        self._ctx.__enter__()

    def __exit__(self, *exc):
        return self._ctx.__exit__(*exc)


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
    ax.set_title(f"sweep: {ds.attrs.get('duration', 0):g} s per point, backend {ds.attrs.get('backend', '')}",
                 fontsize=9)
    ax.grid(alpha=0.3)
    if len(combos) > 1 or combos[0]:
        ax.legend(fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _paper(args) -> int:
    from ..paper import reproduce

    check_output_dir("--out", args.out)

    s = reproduce(args.out, quick=args.quick, executor="serial" if args.serial else None,
                  progress=not args.no_progress)
    ed, cost = s["event_driven"], s["rk4_default_step"]
    rk = s["rk4_figure_step"]["consistent"]
    print(f"Fig. 6-8 recomputed ({'quick' if args.quick else 'full'}), written to {args.out}/paper_reproduction.md, "
          f"{args.out}/*.csv and {args.out}/figures/*.png")
    print(f"  paper's parameters: {ed['fig7']['impacts_total'] + ed['fig8']['impacts_total']} flange contacts, "
          f"max mean flange force {max(ed['fig7']['max_mean_force_N'], ed['fig8']['max_mean_force_N']):g} N "
          f"(event-driven); RK4 + sign(): {rk['fig7_max_force_N']:g} N")
    print(f"  event-driven Fig. 7 grid ({ed['fig7_points']} points): {ed['fig7_wall_s']:.1f} s; RK4 at the figure "
          f"step: {rk['fig7_wall_s']:.2f} s; RK4 at the default step (extrapolated): "
          f"{cost['fig7_full_extrapolated_s']:.0f} s")
    for name, info in s["alternatives"].items():
        t = info["trends"]
        print(f"  alternative {name}: {info['impacts_total']} contacts, max {t['max_force']:.3g} N, "
              f"up with speed: {t['up_with_speed']}, down with T sin: {t['down_with_t_sin']}, "
              f"0.1/0.7 ratio {t['ratio_01_07']:.3g}")
    return 0


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``impactosc: error: ...`` and exit status 2 (no usage block)."""

    def error(self, message):
        self.exit(2, f"impactosc: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="impactosc",
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
    sim.add_argument("--events", type=_nonnegative_int, default=20,
                     help="rows of the event and impact tables (default 20)")
    sim.add_argument("--plot", metavar="PNG", help="write a figure of X(t), flange force and phase portrait")
    sw = sub.add_parser("sweep", help="run a grid of tape drives in parallel; table, netCDF and figure",
                        description="The outer product of a grid of TapeDrive fields (SI units), run in parallel "
                                    "with impactosc.sweep. Example: impactosc sweep "
                                    "--grid pack_diameter=0.05,0.07,0.09 --grid speed=4,8,12 --duration 0.1 "
                                    "--out sweep.nc --plot sweep.png")
    sw.add_argument("--grid", action="append", metavar="FIELD=V1,V2,...",
                    help="a swept TapeDrive field (or t_sin_half_theta) and its values; repeat for more dimensions "
                         "(the first is the x axis of --plot, the second one line per value)")
    sw.add_argument("--toml", metavar="FILE", help="TOML file with a [grid] table (field = [values]) and an optional "
                                                   "[drive] table of base TapeDrive fields; --grid adds to it")
    d = sw.add_argument_group("base drive (SI units, defaults from the paper)")
    for opt, (_, typ, text) in DRIVE_OPTIONS.items():
        d.add_argument(f"--{opt}", type=typ, help=text)
    sw.add_argument("--duration", type=float, default=1.0, help="simulated time per point [s] (default 1, the paper)")
    sw.add_argument("--backend", default="heyoka", help="heyoka (default), scipy, exact or rk4")
    sw.add_argument("--tol", type=float, help="heyoka tolerance")
    sw.add_argument("--dt", type=float, help="rk4 step")
    sw.add_argument("--out", metavar="FILE.nc", help="write the xarray Dataset as netCDF (scipy engine)")
    sw.add_argument("--store", metavar="DIR", help="resumable per-point store (rerun to continue or extend)")
    sw.add_argument("--plot", metavar="PNG", help="mean flange force vs the first swept field, a line per value of "
                                                  "the others")
    sw.add_argument("--rows", type=_nonnegative_int, default=30, help="rows of the printed table (default 30)")
    sw.add_argument("--serial", action="store_true", help="run in this process instead of a process pool")
    sw.add_argument("--no-progress", action="store_true", help="no progress bar")

    pp = sub.add_parser("paper", help="recompute the paper's Fig. 6-8 and the report",
                        description="Fig. 6 (run-out law), Fig. 7 and 8 (average flange force vs pack diameter) with "
                                    "the event-driven solver and the paper's RK4 baseline, alternative parameter "
                                    "sets, timings; writes DIR/paper_reproduction.md, DIR/*.csv, DIR/figures/*.png.")
    pp.add_argument("--quick", action="store_true", help="coarse grid (5 diameters) and a 10 ms average: ~30 s")
    pp.add_argument("--out", default="reports", metavar="DIR", help="output directory (default reports)")
    pp.add_argument("--serial", action="store_true", help="run the sweeps in this process instead of a pool")
    pp.add_argument("--no-progress", action="store_true", help="no progress bars")
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    handlers = {"demo": _demo, "simulate": _simulate, "sweep": _sweep, "paper": _paper}
    try:
        return handlers[args.command](args)
    except (ValueError, TypeError, ImportError, OSError) as exc:
        print(f"impactosc: error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # a sweep that lost every point: the run itself failed
        print(f"impactosc: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        kept = " (the points finished so far are in --store)" if getattr(args, "store", None) else ""
        print(f"impactosc: interrupted{kept}", file=sys.stderr)
        return 130

