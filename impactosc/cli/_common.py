"""What the subcommands share: one-line argument errors, output checks, and the model options.

A model on the command line is either an oscillator (nondimensional eq. 3: ``--F --Omega
--beta --K``) or a tape drive (SI units, the paper's drive by default), with the family
options of either (:data:`FAMILY_OPTIONS`). :func:`add_model_options` adds them to a
subcommand and :func:`model_from_args` builds the :class:`~impactosc.Oscillator` or
:class:`~impactosc.TapeDrive` they describe.
"""

from __future__ import annotations

import argparse
import math
import numbers
import os
import tempfile
from pathlib import Path

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
    "guide-offset": ("guide_offset", float, "offset of the tape's rest position from the guide centre, towards "
                                            "the upper flange [m] (default 0)"),
    "flange-sides": ("flange_sides", str, "flanges of the guide: both (default), upper or lower"),
}
#: Choices of the string-valued drive options.
DRIVE_CHOICES = {"bending": ("in-plane", "out-of-plane"), "flange-sides": ("both", "upper", "lower")}
OSC_OPTIONS = ("F", "Omega", "beta", "K", "phase")
#: Oscillator options beyond the eq. 3 parameters (the flanges' distances from the rest position).
OSC_GAP_OPTIONS = ("gap_lower", "gap_upper")

#: Family options of both kinds of model: option -> (Oscillator field, TapeDrive field).
FAMILY_OPTIONS = {
    "zeta": ("zeta", "damping_ratio"),
    "flange": ("flange", "flange"),
    "restitution": ("restitution", "restitution"),
    "exponent": ("exponent", "flange_exponent"),
}


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``impactosc: error: ...`` and exit status 2 (no usage block)."""

    def error(self, message):
        self.exit(2, f"impactosc: error: {message} (see {self.prog} --help)\n")


def nonnegative_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid int value: {text!r}") from None
    if n < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {n}")
    return n


def positive_int(text: str) -> int:
    n = nonnegative_int(text)
    if n == 0:
        raise argparse.ArgumentTypeError("must be >= 1, got 0")
    return n


def _triple(names: str, integer_first: bool = False):
    """An argparse type: ``a,b[,c]`` -> a tuple of 3 numbers (the third defaults to 0; ``a`` an int if asked)."""

    def parse(text: str) -> tuple:
        parts = [p for p in text.split(",") if p.strip()]
        try:
            values = [float(p) for p in parts]
            if integer_first and values:
                values[0] = int(parts[0])
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {names} (numbers), got {text!r}") from None
        if len(values) not in (2, 3):
            raise argparse.ArgumentTypeError(f"expected {names}, got {text!r}")
        return tuple(values) if len(values) == 3 else (*values, 0.0)

    return parse


def gap(text: str) -> float:
    """An argparse type: a flange distance (a number), or ``none`` for an absent flange (``inf``, as stored)."""
    if text.strip().lower() in ("none", "inf"):
        return math.inf
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or 'none' (no such flange), got {text!r}") from None


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


def check_plot_output(option: str, path: str | None) -> None:
    """Before any computing: matplotlib is importable, ``path`` names a format it writes and is writable.

    The format is the file name's extension (``.png``, ``.pdf``, ``.svg`` ...), as
    ``Figure.savefig`` reads it; a name without one is refused (matplotlib would write
    ``path.png``, not ``path``).
    """
    if path:
        from .._util.optional import require_matplotlib

        require_matplotlib()
        from matplotlib.backend_bases import FigureCanvasBase

        check_output_file(option, path)
        formats = sorted(FigureCanvasBase.get_supported_filetypes())
        suffix = Path(path).suffix.lower().lstrip(".")
        if suffix not in formats:
            got = f"the extension .{suffix}" if suffix else "no extension"
            raise ValueError(f"{option} {path}: {got}; the figure's format is its extension, one of "
                             f"{', '.join('.' + f for f in formats)}")


#: Extensions of ``--out`` and the format written: netCDF (scipy engine) or CSV (one row per point).
DATASET_FORMATS = {".nc": "netcdf", ".nc4": "netcdf", ".cdf": "netcdf", ".netcdf": "netcdf", ".csv": "csv"}


def check_dataset_output(option: str, path: str | None) -> None:
    """Before any computing: ``path`` ends in ``.nc`` (netCDF) or ``.csv`` and can be written."""
    if path:
        check_output_file(option, path)
        suffix = Path(path).suffix.lower()
        if suffix not in DATASET_FORMATS:
            got = f"the extension {suffix}" if suffix else "no extension"
            raise ValueError(f"{option} {path}: {got}; write netCDF (.nc) or CSV (.csv)")


def write_dataset(ds, path: str) -> str:
    """Write the xarray Dataset ``ds`` in the format of ``path``'s extension; returns a word for it.

    netCDF with the scipy engine (every attribute kept), or CSV: one row per point of the
    Dataset's dimensions (``Dataset.to_dataframe``), preceded by ``#`` lines with the
    Dataset's attributes and each column's units (read it back with
    ``pandas.read_csv(path, comment="#")``).
    """
    if DATASET_FORMATS[Path(path).suffix.lower()] == "netcdf":
        ds.to_netcdf(path, engine="scipy")
        return "netCDF"
    frame = ds.to_dataframe().reset_index()
    with open(path, "w", encoding="utf-8", newline="") as fh:
        for key, value in ds.attrs.items():
            fh.write(f"# {key}: {value}\n")
        for name in frame.columns:
            attrs = ds[name].attrs if name in ds.variables else {}
            if attrs.get("units") or attrs.get("long_name"):
                units = f" [{attrs['units']}]" if attrs.get("units") else ""
                fh.write(f"# column {name}: {attrs.get('long_name', name)}{units}\n")
        frame.to_csv(fh, index=False)
    return "CSV"


def add_drive_options(group) -> None:
    """The TapeDrive fields of :data:`DRIVE_OPTIONS` as ``--speed --tension ...``."""
    for opt, (_, typ, text) in DRIVE_OPTIONS.items():
        group.add_argument(f"--{opt}", type=typ, choices=DRIVE_CHOICES.get(opt), help=text)


def drive_fields(args) -> dict:
    """The TapeDrive fields given on the command line (``--speed`` ... of :data:`DRIVE_OPTIONS`)."""
    return {field: getattr(args, opt.replace("-", "_")) for opt, (field, _, _) in DRIVE_OPTIONS.items()
            if getattr(args, opt.replace("-", "_")) is not None}


def add_model_options(parser) -> None:
    """Oscillator parameters, tape-drive options and the family options of both."""
    g = parser.add_argument_group("oscillator (nondimensional eq. 3)")
    for name in OSC_OPTIONS:
        g.add_argument(f"--{name}", type=float, help=f"{name} of eq. 3")
    g.add_argument("--beta-static", type=float, help="static friction level (>= beta; default: beta)")
    g.add_argument("--harmonic", action="append", type=_triple("F,Omega[,phase]"), metavar="F,OMEGA[,PHASE]",
                   help="a further forcing harmonic F cos(Omega t + phase); repeat for more")
    g.add_argument("--gap-lower", type=gap, metavar="GAP",
                   help="distance from X = 0 to the lower flange, at X = -GAP (default 1); none: no lower flange")
    g.add_argument("--gap-upper", type=gap, metavar="GAP",
                   help="distance from X = 0 to the upper flange, at X = +GAP (default 1); none: no upper flange")
    d = parser.add_argument_group("tape drive (SI units, defaults from the paper)")
    add_drive_options(d)
    d.add_argument("--static-friction", type=float, help="static friction coefficient mu_s (>= mu; default mu)")
    d.add_argument("--runout-harmonic", action="append", type=_triple("n,fraction[,phase]", integer_first=True),
                   metavar="N,FRACTION[,PHASE]",
                   help="a higher harmonic of the reel run-out: harmonic number, fraction of the run-out, phase; "
                        "repeat for more")
    f = parser.add_argument_group("family (either model)")
    f.add_argument("--zeta", type=float, help="viscous damping ratio (default 0)")
    f.add_argument("--flange", choices=("spring", "rigid"), help="flange law (default spring)")
    f.add_argument("--restitution", type=float, help="coefficient of restitution of a rigid flange (default 1)")
    f.add_argument("--exponent", type=float, help="exponent p of the flange spring law K d^p (default 1; Hertz 1.5)")


def model_kind(args) -> str:
    """``"oscillator"`` or ``"drive"`` from the options given (a drive, the paper's, when neither)."""
    osc_given = [k for k in (*OSC_OPTIONS, "beta_static", "harmonic") if getattr(args, k) is not None]
    gaps_given = [k for k in OSC_GAP_OPTIONS if getattr(args, k) is not None]
    drive_given = list(drive_fields(args)) + [k for k in ("static_friction", "runout_harmonic")
                                              if getattr(args, k) is not None]
    if (osc_given or gaps_given) and drive_given:
        raise ValueError("give either oscillator parameters (--F --Omega --beta --K --phase --beta-static "
                         "--harmonic --gap-lower --gap-upper) or tape-drive options (--speed --tension ... "
                         "--guide-offset --flange-sides --static-friction --runout-harmonic), not both")
    if gaps_given and not osc_given:
        raise ValueError(f"{', '.join('--' + k.replace('_', '-') for k in gaps_given)}: flange distances of an "
                         "oscillator (give --F --Omega --beta ...); a tape drive places its flanges with "
                         "--clearance, --guide-offset and --flange-sides")
    return "oscillator" if osc_given else "drive"


def model_from_args(args, *, free: tuple[tuple[str, float], ...] = ()):
    """The :class:`~impactosc.Oscillator` or :class:`~impactosc.TapeDrive` the options describe.

    ``free``: ``(name, value)`` of oscillator parameters that may be missing (a parameter a
    study varies anyway), filled with ``value``. A command that varies a parameter
    (``args.param``, as ``bifurcation``, ``onset``, ``chart`` and ``continue`` do) gets it
    checked here: it must be a real-valued parameter of the model
    (:func:`numeric_parameters`), not a structural field such as ``flange``.
    """
    import impactosc as io

    column = 0 if model_kind(args) == "oscillator" else 1
    family = {fields[column]: getattr(args, opt) for opt, fields in FAMILY_OPTIONS.items()
              if getattr(args, opt) is not None}
    if column == 0:
        given = {k: getattr(args, k) for k in OSC_OPTIONS if getattr(args, k) is not None}
        for name, value in free:
            given.setdefault(name, value)
        gaps = {k: getattr(args, k) for k in OSC_GAP_OPTIONS if getattr(args, k) is not None}
        # K is the stiffness of a spring flange: a rigid flange, or none at all, goes without it.
        no_flange = all(math.isinf(gaps.get(k, 1.0)) for k in OSC_GAP_OPTIONS)
        required = ("F", "Omega", "beta") + (() if family.get("flange") == "rigid" or no_flange else ("K",))
        missing = [k for k in required if k not in given]
        if missing:
            raise ValueError(f"oscillator mode needs {' '.join('--' + k for k in required)}"
                             f"{' (a spring flange needs its stiffness --K)' if 'K' in missing else ''}; "
                             f"missing: {', '.join(missing)}")
        if args.beta_static is not None:
            family["beta_static"] = args.beta_static
        if args.harmonic:
            family["harmonics"] = tuple(args.harmonic)
        model: io.Oscillator | io.TapeDrive = io.Oscillator(**given, **family, **gaps)
    else:
        fields = drive_fields(args)
        if args.static_friction is not None:
            fields["static_friction"] = args.static_friction
        if args.runout_harmonic:
            fields["runout_harmonics"] = tuple(args.runout_harmonic)
        model = io.TapeDrive(**fields, **family)
    if isinstance(getattr(args, "param", None), str):
        check_parameter_option("--param", model, args.param)
    return model


def numeric_parameters(model) -> tuple[str, ...]:
    """The parameters of ``model`` a command may vary: those of ``parameter_names`` with a real value.

    Structural fields (``flange``, ``flange_sides``, ``bending``, the harmonics) select a
    member of the family; they are options of their own, not a number to vary or grid.
    """
    from ..dynamics import parameter_names

    def real(name: str) -> bool:
        value = getattr(model, name)
        # None: a static friction level equal to the kinetic one (beta_static, static_friction).
        return value is None or isinstance(value, numbers.Real) and not isinstance(value, bool)

    return tuple(name for name in parameter_names(model) if real(name))


def check_parameter_option(option: str, model, name: str) -> str:
    """``name`` (given with ``option``) must be one of :func:`numeric_parameters` of ``model``."""
    names = numeric_parameters(model)
    if name not in names:
        structural = hasattr(model, name) and not isinstance(getattr(model, name), numbers.Real)
        flag = {"harmonics": "--harmonic", "runout_harmonics": "--runout-harmonic"}.get(
            name, "--" + name.replace("_", "-"))
        why = (f"{name!r} is not a number but chooses a member of the family: set it with {flag} and vary a "
               "number" if structural else f"got {name!r}")
        raise ValueError(f"{option} must be one of {', '.join(names)} for a {type(model).__name__}; {why}")
    return name


def add_backend_options(parser, *, dt: bool = True) -> None:
    choices = "heyoka (default), scipy, exact" + (" or rk4" if dt else "")
    parser.add_argument("--backend", default="heyoka", help=choices)
    parser.add_argument("--tol", type=float, help="heyoka tolerance")
    if dt:
        parser.add_argument("--dt", type=float, help="rk4 step")


def backend_options(args) -> dict:
    """``tol`` and ``dt`` when given (the backend's own defaults otherwise)."""
    return {k: getattr(args, k) for k in ("tol", "dt") if getattr(args, k, None) is not None}


def parse_grid_values(option: str, key: str, text: str) -> list:
    """``v1,v2,...`` of ``--grid key=...``: numbers (``bending`` takes names)."""
    parts = [v.strip() for v in text.split(",") if v.strip()]
    if not parts:
        raise ValueError(f"{option} {key}={text}: no values after '='")
    if key == "bending":
        return parts
    try:
        return [float(v) for v in parts]
    except ValueError:
        bad = next(v for v in parts if not _is_number(v))
        raise ValueError(f"{option} {key}: {bad!r} is not a number") from None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def plot_title(base) -> str:
    """A short title naming the model: its class and the fields that differ from their defaults."""
    import dataclasses

    try:
        reference = type(base)()  # a TapeDrive: the paper's drive
    except TypeError:  # an Oscillator: F, Omega, beta, K have no default
        reference = None
    parts = []
    for f in dataclasses.fields(base):
        if not f.init or f.name.startswith("_"):
            continue
        value = getattr(base, f.name)
        default = getattr(reference, f.name) if reference is not None else f.default
        if default is not dataclasses.MISSING and value == default:
            continue
        parts.append(f"{f.name}={value:g}" if isinstance(value, float) else f"{f.name}={value!r}")
    return f"{type(base).__name__}({', '.join(parts)})"


class pandas_display:
    """Wide tables with six significant digits while printing."""

    def __enter__(self):
        import pandas as pd

        self._ctx = pd.option_context("display.width", 200, "display.float_format", "{:.6g}".format)
        self._ctx.__enter__()

    def __exit__(self, *exc):
        return self._ctx.__exit__(*exc)
