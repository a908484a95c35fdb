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

#: Options of the transient search (``--method transient``), refused with continuation.
TRANSIENT_OPTIONS = (("scan", "--scan"), ("no_follow", "--no-follow"), ("record_periods", "--record-periods"),
                     ("stop_at_contact", "--stop-at-contact"), ("max_evaluations", "--max-evaluations"))


def add_onset_options(p) -> None:
    """The search options of ``onset`` and ``chart`` (those of :func:`impactosc.dynamics.contact_onset`)."""
    s = p.add_argument_group("onset search")
    s.add_argument("--param", required=True, help="the parameter whose critical value is sought (an oscillator's F, "
                                                  "Omega ...; a drive's field in SI units, e.g. clearance)")
    s.add_argument("--bracket", nargs=2, type=float, required=True, metavar=("LO", "HI"), help="the interval searched")
    s.add_argument("--method", choices=("continuation", "transient"), default="continuation",
                   help="continuation (default): follow the branch of the orbit at the --start end (through "
                        "--guess, or reached by a transient) to its first contact onset; transient: the search on "
                        "transients of earlier versions, status 0 only where the orbit at the contact-free end of "
                        "its final bracket grazes (2: a jump between attractors or an unsettled transient)")
    s.add_argument("--guess", nargs=2, type=float, metavar=("X", "V"),
                   help="continuation: (X, V) on the section near the orbit to follow (default: a transient "
                        "from --x0 --v0)")
    s.add_argument("--start", choices=("lo", "hi"), default="lo",
                   help="continuation: the end of the bracket the followed orbit is taken at (default lo)")
    s.add_argument("--value-tol", type=float, help="absolute tolerance on the critical value (default 1e-12 of the "
                                                   "bracket's magnitude; transient: 1e-6 of its width)")
    s.add_argument("--orbit", type=positive_int, metavar="N",
                   help="continuation: the period N of the followed orbit (default 1); transient: take the steady "
                        "state to be the period-N orbit found by shooting")
    s.add_argument("--transient-periods", type=float,
                   help="forcing periods of the transient (continuation: a whole number, default 100; transient: "
                        "a fraction is fine for a tape drive, default 200)")
    s.add_argument("--x0", type=float, default=0.95, help="initial X of the transient (default 0.95)")
    s.add_argument("--v0", type=float, default=0.0, help="initial V of the transient (default 0)")
    s.add_argument("--backend", help="exact, heyoka or scipy (default: exact where it runs the model, else heyoka; "
                                     "transient: heyoka)")
    t = p.add_argument_group("transient search (--method transient only)")
    t.add_argument("--scan", type=nonnegative_int, help="interior values evaluated first (default 0)")
    t.add_argument("--no-follow", action="store_true", default=None,
                   help="start every value from (x0, v0) instead of following the contact-free branch")
    t.add_argument("--record-periods", type=float, help="forcing periods examined (default 20)")
    t.add_argument("--stop-at-contact", action="store_true", default=None,
                   help="stop every run at its first contact (a bisection)")
    t.add_argument("--max-evaluations", type=positive_int, help="steady states computed at most (default 100)")


def onset_kwargs(args) -> dict:
    """The keyword arguments of :func:`~impactosc.dynamics.contact_onset` the options give.

    Raises ``ValueError`` for an option of the other method (before anything runs).
    """
    kw = {"method": args.method, "tol": args.value_tol, "orbit": args.orbit, "x0": args.x0, "v0": args.v0,
          "backend": args.backend}
    if args.transient_periods is not None:
        kw["transient_periods"] = args.transient_periods
    given = [(dest, flag) for dest, flag in TRANSIENT_OPTIONS if getattr(args, dest) is not None]
    if args.method == "continuation":
        if given:
            raise ValueError(f"{', '.join(flag for _, flag in given)}: an option of --method transient (the search "
                             "on transients); add --method transient to use it")
        if args.guess is not None:
            kw["guess"] = tuple(args.guess)
        kw["start"] = args.start
        if args.transient_periods is not None and args.transient_periods != int(args.transient_periods):
            raise ValueError(f"--transient-periods must be a whole number with --method continuation, got "
                             f"{args.transient_periods:g}")
        if "transient_periods" in kw:
            kw["transient_periods"] = int(kw["transient_periods"])
        return kw
    for flag, bad in (("--guess", args.guess is not None), ("--start", args.start != "lo")):
        if bad:
            raise ValueError(f"{flag}: an option of --method continuation")
    kw.update({"scan": args.scan, "follow": None if args.no_follow is None else not args.no_follow,
               "record_periods": args.record_periods, "stop_at_contact": args.stop_at_contact,
               "max_evaluations": args.max_evaluations})
    return {k: v for k, v in kw.items() if v is not None or k in ("tol", "orbit")}


def base_for(args):
    """The model; an oscillator may leave out the charted parameter (the bracket's low end stands in)."""
    lo, hi = args.bracket
    if not lo < hi:
        raise ValueError(f"--bracket must satisfy LO < HI, got {lo:g} {hi:g}")
    return model_from_args(args, free=((args.param, lo),) if args.param in ("F", "Omega", "beta", "K") else ())


def add_parser(sub) -> None:
    p = sub.add_parser("onset", help="the critical value of a parameter at which contact starts; JSON and figure",
                       description="Follows the branch of the orbit at one end of the bracket to the value of "
                                   "--param where it first touches a flange (impactosc.dynamics.contact_onset). "
                                   "Example: impactosc onset --F 0.3 --Omega 0.8 --beta 0.05 --K 1e4 --param F "
                                   "--bracket 0.3 0.5 --guess 0.8 0 --json onset.json --plot onset.png")
    add_model_options(p)
    add_onset_options(p)
    o = p.add_argument_group("output")
    o.add_argument("--json", metavar="FILE", help="write the result (value, bracket, margins, status, the followed "
                                                  "orbit and its stability) as JSON")
    o.add_argument("--plot", metavar="PNG", help="a bifurcation diagram over the bracket with the onset marked")
    o.add_argument("--plot-values", type=positive_int, default=40,
                   help="values of the parameter in the diagram of --method transient (default 40)")
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
    what = "branch points" if res.method == "continuation" else "steady states"
    print(f"  {args.param} = {res.value:.12g}" + (f" (contact {side} it)" if side else "")
          + f"; bracket [{res.bracket[0]:.12g}, {res.bracket[1]:.12g}], margins "
          f"({res.margins[0]:.3g}, {res.margins[1]:.3g}), {res.evaluations} {what} ({res.method})")
    if res.method == "continuation":
        stable = {True: "stable", False: "not stable", None: "unknown"}[res.stable]
        print(f"  followed: {res.followed}; just before the onset: {stable}")
    print(f"  status {res.status}: {res.message}")
    if args.json:
        record = {f.name: getattr(res, f.name) for f in dataclasses.fields(res) if f.name != "branch"}
        if res.branch is not None:
            record["branch"] = res.branch.summary()
        with open(args.json, "w") as fh:
            json.dump({"model": repr(base), **_plain(record)}, fh, indent=2)
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
    """The followed branch (continuation) or a bifurcation diagram over the bracket (transient), the onset marked."""

    import numpy as np

    from .._util.optional import require_matplotlib
    from ..dynamics import bifurcation_diagram, plot_bifurcation

    plt = require_matplotlib()
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    if res.branch is not None and len(res.branch.points):
        res.branch.plot(ax=ax, y="x")
        if not math.isnan(res.value):
            ax.axvline(res.value, color="C3", lw=0.8, ls=":")
        ax.set_title(f"{plot_title(base)}\nthe followed branch (solid stable, dashed unstable), the contact onset "
                     "dotted", fontsize=8)
    else:
        lo, hi = args.bracket
        values = np.linspace(lo, hi, args.plot_values)
        tp = 200.0 if args.transient_periods is None else args.transient_periods
        rp = 20.0 if args.record_periods is None else args.record_periods
        ds = bifurcation_diagram(base, args.param, values, transient_periods=math.ceil(tp),
                                 record_periods=max(1, math.ceil(rp)),
                                 continuation="none" if args.no_follow else "forward", x0=args.x0, v0=args.v0,
                                 backend=args.backend or "heyoka", executor="serial", progress=False)
        plot_bifurcation(ds, ax=ax, onset=None if math.isnan(res.value) else res.value, markersize=2.0)
        ax.set_title(f"{plot_title(base)}\nstroboscopic points over the bracket, the contact onset found marked",
                     fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
