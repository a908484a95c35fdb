"""``impactosc path FILE``: a tape path of several guides from a path file; per-guide SI results.

One run (the default), a sweep of path parameters (``--grid``) or where contact starts at a
guide (``--critical-clearance GUIDE``, over ``--grid`` a chart). A subcommand of its own
rather than ``simulate --path``: a path comes from a file with its own run and output
settings, and none of ``simulate``'s model options (an oscillator's or one drive's) applies
to it.

The path file (TOML or JSON; ``impactosc path --example four-guides`` prints one) holds the
tables of :meth:`TapePath.from_dict <impactosc.TapePath.from_dict>` (``drive``,
``guides``, ``end_span``) and two optional tables read here::

    [run]
    duration = 0.005       # s of tape motion (default 0.01)
    phase = 0.0            # rad: the reel's angle at t = 0
    head = 0.125           # m from the pack: where the lateral motion is reported (default: the last guide)
    max_events = 10000000

    [output]
    motion = "head.csv"    # time (s), lateral position at the head and at every guide (m)
    events = "events.csv"  # every event: time (s), kind, guide, side
    samples = 2001         # rows of motion

Command-line options override the file's. Output files are relative to the current directory.
"""

from __future__ import annotations

import math
from importlib.resources import files

from ._common import (
    check_dataset_output,
    check_output_dir,
    check_output_file,
    check_plot_output,
    nonnegative_int,
    positive_int,
)

#: The example path files shipped with the package (``impactosc/cli/paths/``).
EXAMPLES = ("two-guides", "four-guides")
#: Keys of the ``[run]`` and ``[output]`` tables: key -> (check, default).
RUN_KEYS = {"duration": ("positive", 0.01), "phase": ("real", 0.0), "head": ("positive", None),
            "max_events": ("count", 10_000_000)}
OUTPUT_KEYS = {"motion": ("text", None), "events": ("text", None), "samples": ("count", 2001)}


def add_parser(sub) -> None:
    p = sub.add_parser("path", help="run a tape path of several guides from a path file; per-guide SI results",
                       description="A tape path from a TOML or JSON path file (its layout: impactosc path --example "
                                   "four-guides). One run: per-guide flange impulse, mean force, contacts per second "
                                   "and contact starts, and the lateral motion at the head. --grid: a sweep of path "
                                   "parameters. --critical-clearance GUIDE: where contact starts at a guide. "
                                   "Example: impactosc path four-guides.toml --duration 0.01 --motion head.csv")
    p.add_argument("file", nargs="?", metavar="FILE", help="the path file (.toml or .json)")
    p.add_argument("--example", choices=EXAMPLES, help="print an example path file and exit")
    run_group = p.add_argument_group("run (override the file's [run] table)")
    run_group.add_argument("--duration", type=float, help="seconds of tape motion (default 0.01)")
    run_group.add_argument("--phase", type=float, help="the reel's angle at t = 0 [rad] (default 0)")
    run_group.add_argument("--head", type=float, help="position of the head along the path [m] (default: the last "
                                                      "guide)")
    run_group.add_argument("--max-events", type=positive_int, help="event limit of a run (default 1e7)")
    run_group.add_argument("--backend", choices=("exact", "heyoka", "scipy"), default="exact",
                           help="backend of a single run (default exact; heyoka and scipy are the cross-checks)")
    out = p.add_argument_group("output (override the file's [output] table)")
    out.add_argument("--motion", metavar="CSV", help="write the lateral motion at the head and the guides")
    out.add_argument("--events", metavar="CSV", help="write every event: time, kind, guide, side")
    out.add_argument("--samples", type=positive_int, help="rows of --motion (default 2001)")
    sw = p.add_argument_group("sweeps and where contact starts")
    sw.add_argument("--grid", action="append", metavar="PARAM=V1,V2,...",
                    help="a swept path parameter (speed, tension, pack_diameter, clearance, end_span, "
                         "guide<i>_<field> such as guide1_clearance) and its values; repeat for more dimensions")
    sw.add_argument("--critical-clearance", type=nonnegative_int, metavar="GUIDE",
                    help="the guide's critical clearance (steady state, its flanges taken away); over --grid a chart")
    sw.add_argument("--out", metavar="FILE.nc|FILE.csv", help="write the Dataset of --grid (netCDF or CSV)")
    sw.add_argument("--plot", metavar="PNG", help="a figure of --grid: per guide, the mean flange force (a sweep) or "
                                                  "the critical clearance (a chart) against the first parameter, a "
                                                  "line per value of the second")
    sw.add_argument("--store", metavar="DIR", help="resumable per-point store of a --grid sweep")
    sw.add_argument("--serial", action="store_true", help="run the points in this process")
    sw.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(handler=run)


def _check(name: str, kind: str, value):
    if kind == "text":
        if not isinstance(value, str) or not value:
            raise ValueError(f"{name} must be a file name, got {value!r}")
        return value
    if kind == "count":
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    if kind == "positive" and not value > 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return float(value)


def read_settings(data: dict, source: str, args) -> dict:
    """The ``[run]`` and ``[output]`` settings: the file's, checked by name, overridden by the options."""
    out = {}
    for table, keys in (("run", RUN_KEYS), ("output", OUTPUT_KEYS)):
        given = data.get(table, {})
        if not isinstance(given, dict):
            raise ValueError(f"{source}: [{table}] must be a table, got {given!r}")
        for key in given:
            if key not in keys:
                raise ValueError(f"{source}: [{table}] has an unknown key {key!r}; valid keys: {', '.join(keys)}")
        for key, (kind, default) in keys.items():
            value = given.get(key, default)
            out[key] = value if value is None else _check(f"{source}: [{table}] {key}", kind, value)
            option = getattr(args, key, None)
            if option is not None:
                out[key] = _check(f"--{key.replace('_', '-')}", kind, option)
    return out


def _parse_grid(items) -> dict:
    from ._common import parse_grid_values

    grid = {}
    for item in items or []:
        key, sep, values = item.partition("=")
        if not sep:
            raise ValueError(f"--grid {item!r}: expected parameter=v1,v2,... (e.g. --grid speed=2,4,8)")
        key = key.strip().replace("-", "_")
        grid[key] = parse_grid_values("--grid", key, values)
    return grid


def run(args) -> int:
    if args.example:
        print((files("impactosc.cli") / "paths" / f"{args.example}.toml").read_text(encoding="utf-8"), end="")
        return 0
    if not args.file:
        raise ValueError("give a path file (impactosc path FILE), or --example NAME to print one")
    from ..model import TapePath

    source = f"path file {args.file!r}"
    path, data = TapePath.read_file(args.file)
    settings = read_settings(data, source, args)
    grid = _parse_grid(args.grid)
    for option in ("out", "store", "plot"):
        if getattr(args, option) and not grid:
            raise ValueError(f"--{option} is for a --grid sweep or chart; a single run writes --motion and --events")
    if grid and (settings["motion"] or settings["events"]):
        raise ValueError("--motion and --events are for a single run, not a --grid sweep (use --out)")
    if args.out:
        check_dataset_output("--out", args.out)
    if len(grid) > 2 and args.plot:
        raise ValueError(f"--plot draws one or two --grid parameters, got {len(grid)}")
    check_plot_output("--plot", args.plot)
    if args.store:
        check_output_dir("--store", args.store)
    for key in ("motion", "events"):
        if settings[key]:
            check_output_file(f"--{key}", settings[key])
    if args.backend != "exact" and (grid or args.critical_clearance is not None):
        raise ValueError(f"--backend {args.backend} applies to a single run; --grid and --critical-clearance run "
                         "on the exact backend")
    if args.critical_clearance is not None:
        path.check_guide(args.critical_clearance, "--critical-clearance")
        return _contact(path, args, settings, grid)
    if grid:
        return _sweep(path, args, settings, grid)
    return _single(path, args, settings)


def _describe(path) -> str:
    d = path.drive
    end = f", end span {path.end_span * 1e3:g} mm" if path.end_span is not None else ""
    return (f"tape path: {path.n} guides at {', '.join(f'{g.position * 1e3:g}' for g in path.guides)} mm{end}; "
            f"speed {d.speed:g} m/s, tension {d.tension:g} N, pack {d.pack_diameter * 1e3:g} mm "
            f"(run-out {d.runout * 1e6:.4g} um at {d.omega_r / (2 * math.pi):.4g} Hz), damping ratio "
            f"{d.damping_ratio:g}")


def _single(path, args, settings) -> int:
    import numpy as np

    from ..sweeps import simulate_path

    supports_end = path.guides[-1].position + (path.end_span or 0.0)
    head = settings["head"] if settings["head"] is not None else path.guides[-1].position
    if head > supports_end:
        raise ValueError(f"head must lie on the path, in (0, {supports_end!r}] m, got {head!r}")
    run = simulate_path(path, settings["duration"], phase=settings["phase"], max_events=settings["max_events"],
                        backend=args.backend)
    print(_describe(path))
    print(f"run: {run.duration:g} s of tape motion, {len(run.solution.events)} events, status {run.status}"
          + (f" ({run.solution.message})" if run.status else ""))
    print(f"{'guide':>5} {'pos [mm]':>9} {'clear [um]':>10} {'flange':>7} {'contacts':>9} {'contacts/s':>11} "
          f"{'impulse [N s]':>14} {'mean force [N]':>15} {'upper [N]':>10} {'lower [N]':>10} {'first contact [s]':>18}")
    for i, g in enumerate(path.guides):
        gd = path.guide_drive(i)
        starts = run.contact_starts(i)
        first = f"{starts[0]:.6g}" if starts.size else "-"
        print(f"{i:>5} {g.position * 1e3:>9.4g} {gd.clearance * 1e6:>10.4g} {gd.flange:>7} {starts.size:>9d} "
              f"{run.impacts_per_second(i):>11.4g} {run.flange_impulse(i):>14.4e} {run.mean_flange_force(i):>15.4e} "
              f"{run.mean_flange_force(i, 1):>10.3e} {run.mean_flange_force(i, -1):>10.3e} {first:>18}")
    t = np.linspace(0.0, run.duration, settings["samples"])
    x = run.lateral_motion(t, head)
    print(f"head at {head * 1e3:g} mm: rms {np.sqrt(np.mean(x**2)) * 1e6:.4g} um, peak {np.abs(x).max() * 1e6:.4g} um "
          f"(lateral position, {t.size} samples)")
    if settings["motion"]:
        _write_motion(settings["motion"], run, t, x, head)
        print(f"motion written to {settings['motion']} ({t.size} rows)")
    if settings["events"]:
        n = _write_events(settings["events"], run)
        print(f"events written to {settings['events']} ({n} rows)")
    return 0 if run.status == 0 else 1


def _write_motion(file: str, run, t, x_head, head: float) -> None:
    import numpy as np

    path = run.path
    cols = [t, x_head] + [run.lateral_motion(t, g.position) for g in path.guides]
    names = ["time_s", "head_m"] + [f"guide{i}_m" for i in range(path.n)]
    with open(file, "w", encoding="utf-8", newline="") as fh:
        fh.write(f"# lateral tape position [m] at the head ({head!r} m from the pack) and at every guide\n")
        fh.write(",".join(names) + "\n")
        np.savetxt(fh, np.column_stack(cols), delimiter=",", fmt="%.17g")


def _write_events(file: str, run) -> int:
    path, sol = run.path, run.solution
    contacts = path.contact_guides()
    friction = [f.coordinate for f in path.mechanical_system(run.phase).friction]
    ev = sol.events
    times = path.time_to_seconds(ev.t) if len(ev) else []
    with open(file, "w", encoding="utf-8", newline="") as fh:
        fh.write("# side: +1 upper flange, -1 lower flange, 0 friction events\n")
        fh.write("time_s,kind,guide,side\n")
        for t, kind, index in zip(times, ev.kind, ev.index, strict=True):
            if kind in ("stick", "reversal", "release"):
                guide, side = friction[int(index)], 0
            else:
                guide, side = contacts[int(index)]
            fh.write(f"{float(t)!r},{kind},{guide},{side}\n")
    return len(ev)


def _write_out(ds, file: str) -> None:
    from ._common import write_dataset

    kind = write_dataset(ds, file)
    print(f"dataset written to {file} ({kind})")


def _sweep(path, args, settings, grid) -> int:
    from ..sweeps import sweep_path
    from ._common import pandas_display

    ds = sweep_path(path, grid, duration=settings["duration"], phase=settings["phase"],
                    max_events=settings["max_events"], executor="serial" if args.serial else None,
                    progress=not args.no_progress, store=args.store)
    print(_describe(path))
    failed = int((ds.status != 0).sum())
    print(f"sweep: {int(ds.status.size)} points ({' x '.join(f'{k}[{ds.sizes[k]}]' for k in grid)}), "
          f"{settings['duration']:g} s each: {failed} failed")
    table = ds[["mean_flange_force", "impact_rate"]].to_dataframe().reset_index()
    table = table.drop(columns=[c for c in ("guide_position",) if c in table])
    with pandas_display():
        print(table.to_string(index=False))
    if args.out:
        _write_out(ds, args.out)
    if args.plot:
        _plot(ds.mean_flange_force, list(grid), args.plot, "mean flange force [N]")
    return 0 if failed == 0 else 1


def _plot(var, dims: list, file: str, ylabel: str, title: str = "") -> None:
    """``var`` against the first grid dimension, a line per value of the second (and per guide)."""
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()
    ds = var.to_dataset()
    x_dim = dims[0]
    panels = list(var["guide"].values) if "guide" in var.dims else [None]
    fig, axes = plt.subplots(1, len(panels), figsize=(min(4.5 * len(panels), 9.0), 3.8), squeeze=False,
                             constrained_layout=True)
    for ax, guide in zip(axes[0], panels, strict=True):
        v = var if guide is None else var.sel(guide=guide)
        for k, value in enumerate(ds[dims[1]].values if len(dims) > 1 else [None]):
            y = v if value is None else v.sel({dims[1]: value})
            label = None if value is None else f"{dims[1]} = {value:g} {ds[dims[1]].attrs.get('units', '')}"
            ax.plot(ds[x_dim].values, y.values, "o-", ms=3, color=f"C{k % 10}", label=label)
        ax.set_xlabel(f"{x_dim} [{ds[x_dim].attrs.get('units', '')}]")
        ax.set_title(f"guide {guide}" if guide is not None else title, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(ylabel)
    if len(dims) > 1:
        axes[0][-1].legend(fontsize=7)
    fig.savefig(file, dpi=100)
    plt.close(fig)
    print(f"plot written to {file}")


def _contact(path, args, settings, grid) -> int:
    from ..sweeps import critical_clearance_chart, steady_deflection

    g = args.critical_clearance
    print(_describe(path))
    if not grid:
        res = steady_deflection(path, g, phase=settings["phase"], max_events=settings["max_events"])
        if res["status"] != 0:
            print(f"guide {g}: the run ended with status {res['status']}: {res['message']}")
            return 1
        clearance = path.guide_drive(g).clearance
        print(f"guide {g}: steady-state deflection with its flanges taken away {res['min'] * 1e6:.6g} to "
              f"{res['max'] * 1e6:.6g} um (after {res['settle_time']:.4g} s)")
        print(f"critical clearance {res['critical_clearance'] * 1e6:.6g} um (upper flange "
              f"{res['critical_clearance_upper'] * 1e6:.6g}, lower {res['critical_clearance_lower'] * 1e6:.6g}); "
              f"its clearance {clearance * 1e6:.6g} um: "
              + ("contact" if clearance < res["critical_clearance"] else "no contact"))
        return 0
    ds = critical_clearance_chart(path, g, grid, phase=settings["phase"], max_events=settings["max_events"],
                                  executor="serial" if args.serial else None, progress=not args.no_progress)
    failed = int((ds.status != 0).sum())
    print(f"critical clearance of guide {g} [um] over {' x '.join(f'{k}[{ds.sizes[k]}]' for k in grid)}: "
          f"{failed} failed")
    table = (ds[["critical_clearance"]] * 1e6).to_dataframe().reset_index()
    print(table.to_string(index=False))
    if args.out:
        _write_out(ds, args.out)
    if args.plot:
        um = ds.critical_clearance * 1e6
        um.attrs = {**ds.critical_clearance.attrs, "units": "um"}
        _plot(um, list(grid), args.plot, f"guide {g} critical clearance [um]",
              f"contact at guide {g} starts below these clearances")
    return 0 if failed == 0 else 1

