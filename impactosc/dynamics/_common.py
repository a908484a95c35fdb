"""What every dynamics tool shares: the parameter being varied, the forcing period, time shifts.

The tools accept either an :class:`~impactosc.model.Oscillator` (nondimensional eq. 3) or a
:class:`~impactosc.tape.TapeDrive` (SI units) as the *base* of a study; a *parameter* is one
field of that base (or ``t_sin_half_theta`` of a drive, the abscissa of the paper's Fig. 8).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import sys
from fractions import Fraction

import numpy as np

from .._util import validation as _v
from ..model._oscillator import PARAMETERS, Oscillator
from ..model._tape import FIELD_UNITS, NUMERIC_FIELDS, TapeDrive

#: Fields of an Oscillator that a study may vary: its numeric fields (``flange`` and
#: ``harmonics`` are structure, not numbers).
OSCILLATOR_PARAMETERS = PARAMETERS
#: Fields of a TapeDrive that a study may vary (its numeric fields), plus ``t_sin_half_theta`` (eq. 5, Fig. 8).
TAPE_PARAMETERS = NUMERIC_FIELDS + ("t_sin_half_theta",)

#: (units, long name) of the TapeDrive parameters, for xarray attributes and plot labels.
TAPE_UNITS = FIELD_UNITS
_OSC_NAMES = {"F": "forcing amplitude F", "Omega": "forcing frequency Omega", "beta": "friction level beta",
              "K": "flange stiffness ratio K", "phase": "forcing phase", "zeta": "damping ratio zeta",
              "beta_static": "static friction level", "exponent": "flange law exponent p",
              "restitution": "coefficient of restitution e", "gap_lower": "distance to the lower flange",
              "gap_upper": "distance to the upper flange"}


def on_a_terminal() -> bool:
    """Whether standard error is a terminal: where a progress bar is shown by default.

    No bar in a notebook, a pipe, a log file, or without a standard error at all.
    """
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty()) if callable(isatty) else False


def check_base(base) -> Oscillator | TapeDrive:
    """``base`` must be an Oscillator or a TapeDrive."""
    if not isinstance(base, Oscillator | TapeDrive):
        raise TypeError(f"base must be an impactosc.Oscillator or an impactosc.TapeDrive, got {type(base).__name__}")
    return base


def parameter_names(base) -> tuple[str, ...]:
    """The parameters a study of ``base`` may vary."""
    return OSCILLATOR_PARAMETERS if isinstance(check_base(base), Oscillator) else TAPE_PARAMETERS


def check_parameter(base, name) -> str:
    """``name`` must be a parameter of ``base`` (see :func:`parameter_names`).

    Only numeric fields are parameters: a string or tuple field (the flange law, the
    flanges of a guide, the run-out harmonics) is structure, refused by name.
    """
    names = parameter_names(base)
    if not isinstance(name, str) or name not in names:
        fields = {f.name for f in dataclasses.fields(base)}
        if isinstance(name, str) and name in fields:
            raise ValueError(f"{name} of a {type(base).__name__} is not a parameter: it is not a number "
                             f"(got {getattr(base, name)!r}) but the member's structure; the parameters are its "
                             f"numeric fields: {', '.join(names)}")
        raise ValueError(f"parameter must be one of {', '.join(names)} for a {type(base).__name__}, got {name!r}")
    return name


def with_parameter(base, name: str, value):
    """A copy of ``base`` with parameter ``name`` set to ``value`` (validated by the class)."""
    check_parameter(base, name)
    if isinstance(base, Oscillator):
        return dataclasses.replace(base, **{name: value})
    if name == "t_sin_half_theta":
        fields = {f.name: getattr(base, f.name) for f in dataclasses.fields(TapeDrive)}
        del fields["tension"]
        return TapeDrive.from_t_sin_half_theta(value, **fields)
    return base.replace(**{name: value})


def parameter_value(base, name: str) -> float:
    """The current value of parameter ``name`` of ``base``.

    An optional field left at ``None`` has the value it stands for: ``beta_static`` (a
    drive's ``static_friction``) the kinetic level, a drive's ``flange_stiffness`` the
    ``k0 = stiffness_ratio k L^(1 - p)`` of its spring law.
    """
    check_parameter(base, name)
    value = getattr(base, name)
    if value is None and name == "beta_static":  # None means "equal to beta"
        return float(base.beta_s)
    if value is None and name == "static_friction":
        return float(base.friction)
    if value is None and name == "flange_stiffness":
        return float(base.stiffness_ratio * base.stiffness * base.clearance ** (1.0 - base.flange_exponent))
    return float(value)


def inert_reason(base, name: str) -> str:
    """Why parameter ``name`` does nothing in ``base`` ("" when it acts on the motion).

    A flange stiffness or exponent of a rigid flange (or of a guide without flanges), a
    drive's ``stiffness_ratio`` once its ``flange_stiffness`` is given, and the distance to
    an absent flange leave every orbit as it is: a study in them would compute the same
    orbit again and again.
    """
    osc = oscillator_of(base)
    no_flange = math.isinf(osc.gap_lower) and math.isinf(osc.gap_upper)
    law = "the guide has no flange" if no_flange else "the flange is rigid (flange='rigid')" if osc.rigid else ""
    if name in ("K", "stiffness_ratio", "flange_stiffness", "exponent", "flange_exponent") and law:
        return f"{law}: it has no spring law, so {name} does not enter the motion"
    if name == "restitution" and not osc.rigid:
        return "restitution applies to a rigid flange only, and this member's flange is a spring (or absent)"
    if name == "stiffness_ratio" and isinstance(base, TapeDrive) and base.flange_stiffness is not None:
        return f"flange_stiffness={base.flange_stiffness!r} is given, which sets K in its place"
    for side, gap in (("lower", "gap_lower"), ("upper", "gap_upper")):
        if name == gap and math.isinf(getattr(osc, gap)):
            return f"there is no {side} flange ({gap} = inf): its distance does not enter the motion"
    return ""


def check_study_parameter(base, name, limits=None) -> str:
    """``name`` must be a parameter that acts on ``base``, and ``limits`` inside its domain.

    Refuses up front, naming the parameter: a name that is not a numeric field, a parameter
    that does nothing in this member (:func:`inert_reason`), and limits at which the model
    itself refuses the value (``beta < 0``, ``exponent < 1``, ``K <= 0``, a gap <= 0, ...:
    the class's own validation, run at both ends).
    """
    check_parameter(base, name)
    why = inert_reason(base, name)
    if why:
        raise ValueError(f"{name} is not a parameter of this {type(base).__name__}: {why}")
    if limits is not None:
        for end, value in zip(("lower", "upper"), limits, strict=True):
            try:
                with_parameter(base, name, value)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"the {end} limit {name} = {value!r} lies outside the domain of {name}: the model "
                                 f"refuses it ({exc})") from None
    return name


def parameter_attrs(base, name: str) -> dict:
    """xarray attributes (units, long_name) of parameter ``name``."""
    if isinstance(base, TapeDrive):
        units, long = TAPE_UNITS[name]
        return {"units": units, "long_name": long}
    return {"units": "1", "long_name": _OSC_NAMES.get(name, name) + " (nondimensional, eq. 3)"}


def oscillator_of(base) -> Oscillator:
    """The nondimensional model of ``base`` (itself, or the drive's :meth:`TapeDrive.oscillator`)."""
    return base if isinstance(check_base(base), Oscillator) else base.oscillator()


def flange_clearance(osc: Oscillator, xs) -> float:
    """Smallest distance of the positions ``xs`` from the flanges: ``min_side (gap(side) - max side X)``.

    Negative by the deepest penetration when some ``X`` lies beyond a flange; ``inf`` when
    there is no flange (each flange at its own distance, :meth:`Oscillator.gap`).
    """
    xs = np.asarray(xs, dtype=float)
    if xs.size == 0:
        return math.inf
    return min(osc.gap(1) - float(np.max(xs)), osc.gap(-1) + float(np.min(xs)))


def check_values(name: str, values) -> np.ndarray:
    """A 1-D array of finite, distinct parameter values (NaN, inf and duplicates refused)."""
    if isinstance(values, str | bytes) or np.ndim(values) != 1:
        raise ValueError(f"{name} must be a 1-D sequence of numbers, got {values!r}")
    out = []
    for i, x in enumerate(values):
        if isinstance(x, bool) or not isinstance(x, numbers.Real):
            raise TypeError(f"{name}[{i}] must be a real number, got {x!r}")
        if not math.isfinite(float(x)):
            raise ValueError(f"{name}[{i}] must be finite, got {float(x)!r}: a grid may not hold NaN or inf")
        out.append(float(x))
    if not out:
        raise ValueError(f"{name} is empty: give at least one value")
    arr = np.array(out)
    if np.unique(arr).size != arr.size:
        raise ValueError(f"{name} has duplicate values: each value must appear once")
    return arr


# -- the forcing period ------------------------------------------------------------------
_MAX_DENOMINATOR = 64


def forcing_period(osc: Oscillator) -> float:
    """The common period of every forcing harmonic, ``2 pi / Omega`` for one harmonic.

    Harmonics whose frequency ratios are rational (denominators up to 64, to 1e-12) have a
    common period; incommensurate ones (quasi-periodic forcing) have none.

    Raises
    ------
    ValueError
        If the forcing is constant (no period) or its harmonics are incommensurate.
    """
    freqs = [Om for F, Om, _ in osc.terms if F > 0.0 and Om > 0.0]
    if not freqs:
        raise ValueError("the forcing is constant (F = 0 or Omega = 0): there is no forcing period, so no "
                         "stroboscopic map; give the oscillator a periodic forcing")
    base = freqs[0]
    ratios = []
    for Om in freqs:
        q = Om / base
        fr = Fraction(q).limit_denominator(_MAX_DENOMINATOR)
        if abs(float(fr) - q) > 1e-12 * max(1.0, q):
            raise ValueError(f"the forcing frequencies {freqs} are incommensurate (ratio {q!r} is not a fraction "
                             f"with denominator <= {_MAX_DENOMINATOR}): the forcing has no period")
        ratios.append(fr)
    den = math.lcm(*(fr.denominator for fr in ratios))
    num = math.gcd(*(fr.numerator * (den // fr.denominator) for fr in ratios))
    return 2.0 * math.pi * den / (base * num)


def periods_in(osc: Oscillator, period, n) -> tuple[int, float]:
    """``(n, n T)``: the number of forcing periods ``T`` in a map, given as ``n`` or as a ``period``.

    Raises
    ------
    ValueError
        If ``period`` is not a whole multiple of the forcing period (to 1e-9 relative).
    """
    T = forcing_period(osc)
    if period is None:
        n = _v.integer("n", n)
        return n, n * T
    period = _v.positive("period", period)
    ratio = period / T
    k = round(ratio)
    if k < 1 or abs(ratio - k) > 1e-9 * max(1.0, ratio):
        raise ValueError(f"period must be a whole multiple of the forcing period 2 pi/Omega = {T!r}, got "
                         f"{period!r} = {ratio:.6g} forcing periods")
    return int(k), k * T


def advanced(osc: Oscillator, t: float) -> Oscillator:
    """The oscillator seen from time ``t``: every forcing phase advanced by ``Omega_i t``.

    A run of ``advanced(osc, t)`` from time 0 is the run of ``osc`` from time ``t`` (the
    model is autonomous except for its forcing), so a map over ``[t, t + n T]`` is a run
    that starts at 0. Phases are reduced modulo ``2 pi``.
    """
    if t == 0.0:
        return osc
    two_pi = 2.0 * math.pi
    return dataclasses.replace(osc, phase=math.fmod(osc.phase + osc.Omega * t, two_pi),
                               harmonics=tuple((F, Om, math.fmod(ph + Om * t, two_pi)) for F, Om, ph in osc.harmonics))


def section_offset(osc: Oscillator, phase) -> float:
    """First time ``t_s >= 0`` at which the forcing phase ``Omega t + osc.phase`` equals ``phase`` (mod 2 pi).

    ``phase=None`` means the phase at ``t = 0`` (``t_s = 0``).
    """
    if phase is None:
        return 0.0
    phase = _v.real("phase", phase)
    forcing_period(osc)  # a constant forcing has no phase
    if osc.F == 0.0 or osc.Omega == 0.0:
        raise ValueError("phase refers to the fundamental forcing term F cos(Omega t + phase), which is zero here")
    d = (phase - osc.phase) % (2.0 * math.pi)
    return d / osc.Omega


def forcing_phase(osc: Oscillator, t):
    """The forcing phase ``(Omega t + phase) mod 2 pi`` of the fundamental term at ``t``."""
    return np.mod(osc.Omega * np.asarray(t, dtype=float) + osc.phase, 2.0 * math.pi)
