"""``impactosc onset``: the critical value of a parameter where the steady state first touches a flange."""

from __future__ import annotations

import dataclasses
import json
import math

from ._common import (
    add_model_options,
    check_output_file,
    check_plot_output,
    model_from_args,
    nonnegative_int,
    plot_title,
    positive_int,
)


def add_onset_options(p) -> None:
    """The search options of ``onset`` and ``chart`` (those of :func:`impactosc.dynamics.contact_onset`)."""
    s = p.add_argument_group("onset search")
    s.add_argument("--param", required=True, help="the parameter whose critical value is sought (an oscillator's F, "
                                                  "Omega ...; a drive's field in SI units, e.g. clearance)")
    s.add_argument("--bracket", nargs=2, type=float, required=True, metavar=("LO", "HI"), help="the interval searched")
    s.add_argument("--value-tol", type=float, help="absolute tolerance on the critical value (default 1e-6 of the "
                                                   "bracket)")
    s.add_argument("--scan", type=nonnegative_int, default=0, help="interior values evaluated first (default 0)")
    s.add_argument("--orbit", type=positive_int, metavar="N",
                   help="take the steady state to be the period-N orbit found by shooting (follows the branch "
                        "up to grazing)")
    s.add_argument("--no-follow", action="store_true", help="start every value from (x0, v0) instead of following "
                                                            "the contact-free branch")
    s.add_argument("--transient-periods", type=float, default=200.0,
                   help="forcing periods discarded (a fraction is fine for a tape drive; default 200)")
    s.add_argument("--record-periods", type=float, default=20.0, help="forcing periods examined (default 20)")
    s.add_argument("--stop-at-contact", action="store_true", help="stop every run at its first contact (a bisection)")
    s.add_argument("--max-evaluations", type=positive_int, default=100, help="steady states computed at most")
    s.add_argument("--x0", type=float, default=0.95, help="initial X (default 0.95)")
    s.add_argument("--v0", type=float, default=0.0, help="initial V (default 0)")
    s.add_argument("--backend", default="heyoka", help="heyoka (default), scipy or exact")


def onset_kwargs(args) -> dict:
    """The keyword arguments of :func:`~impactosc.dynamics.contact_onset` the options give."""
    return {"tol": args.value_tol, "scan": args.scan, "follow": not args.no_follow, "orbit": args.orbit,
            "transient_periods": args.transient_periods, "record_periods": args.record_periods,
            "x0": args.x0, "v0": args.v0, "stop_at_contact": args.stop_at_contact, "backend": args.backend,
            "max_evaluations": args.max_evaluations}


def base_for(args):
    """The model; an oscillator may leave out the charted parameter (the bracket's low end stands in)."""
    lo, hi = args.bracket
    if not lo < hi:
        raise ValueError(f"--bracket must satisfy LO < HI, got {lo:g} {hi:g}")
    return model_from_args(args, free=((args.param, lo),) if args.param in ("F", "Omega", "beta", "K") else ())


def add_parser(sub) -> None:
    p = sub.add_parser("onset", help="the critical value of a parameter at which contact starts; JSON and figure",
                       description="Brackets and refines the value of --param where the steady state first "
                                   "touches a flange (impactosc.dynamics.contact_onset). Example: impactosc onset "
                                   "--F 0.3 --Omega 0.8 --beta 0.05 --K 1e4 --param F --bracket 0.3 0.5 --orbit 1 "
                                   "--x0 0 --json onset.json --plot onset.png")
    add_model_options(p)
    add_onset_options(p)
    o = p.add_argument_group("output")
    o.add_argument("--json", metavar="FILE", help="write the result (value, final bracket, margins, status) as JSON")
    o.add_argument("--plot", metavar="PNG", help="a bifurcation diagram over the bracket with the onset marked")
    o.add_argument("--plot-values", type=positive_int, default=40,
                   help="values of the parameter in that diagram (default 40)")
    p.set_defaults(handler=run)


def run(args) -> int:
    from ..dynamics import contact_onset

    base = base_for(args)
    if args.json:
        check_output_file("--json", args.json)
    check_plot_output("--plot", args.plot)
    res = contact_onset(base, args.param, tuple(args.bracket), **onset_kwargs(args))
    side = {1: "above", -1: "below"}.get(res.direction)
    print(f"contact onset of {plot_title(base)}")
    print(f"  {args.param} = {res.value:.12g}" + (f" (contact {side} it)" if side else "")
          + f"; final bracket [{res.bracket[0]:.12g}, {res.bracket[1]:.12g}], margins "
          f"({res.margins[0]:.3g}, {res.margins[1]:.3g}), {res.evaluations} steady states")
    print(f"  status {res.status}: {res.message}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"model": repr(base), **_plain(dataclasses.asdict(res))}, fh, indent=2)
            fh.write("\n")
        print(f"result written to {args.json}")
    if args.plot:
        _plot(res, base, args, args.plot)
        print(f"plot written to {args.plot}")
    return 0 if res.status == 0 else 1


def _plain(value):
    """JSON types: tuples to lists, NumPy scalars to Python numbers, NaN to null (strict JSON)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    value = value.item() if hasattr(value, "item") else value
    return None if isinstance(value, float) and math.isnan(value) else value


def _plot(res, base, args, path: str) -> None:
    """A bifurcation diagram over the bracket (continued forward, as the search follows), the onset marked."""

    import numpy as np

    from .._util.optional import require_matplotlib
    from ..dynamics import bifurcation_diagram, plot_bifurcation

    plt = require_matplotlib()
    lo, hi = args.bracket
    values = np.linspace(lo, hi, args.plot_values)
    ds = bifurcation_diagram(base, args.param, values, transient_periods=math.ceil(args.transient_periods),
                             record_periods=max(1, math.ceil(args.record_periods)),
                             continuation="none" if args.no_follow else "forward", x0=args.x0, v0=args.v0,
                             backend=args.backend, executor="serial", progress=False)
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    plot_bifurcation(ds, ax=ax, onset=None if math.isnan(res.value) else res.value, markersize=2.0)
    ax.set_title(f"{plot_title(base)}\nstroboscopic points over the bracket, the contact onset found marked",
                 fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
