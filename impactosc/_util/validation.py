"""Argument checks shared by every public entry point.

Each check names the parameter, states the rule and shows the offending value, so that a
bad input fails loudly at the call site instead of producing a hang, a NaN or a plausible
wrong number deep inside an integrator.
"""

from __future__ import annotations

import math
import numbers


def real(name: str, value, *, rule: str | None = None) -> float:
    """Return ``value`` as a finite float, or raise a ``TypeError``/``ValueError``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r} of type {type(value).__name__}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return x


def positive(name: str, value) -> float:
    x = real(name, value)
    if not x > 0.0:
        raise ValueError(f"{name} must be > 0, got {x!r}")
    return x


def nonnegative(name: str, value) -> float:
    x = real(name, value)
    if not x >= 0.0:
        raise ValueError(f"{name} must be >= 0, got {x!r}")
    return x


def integer(name: str, value, *, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {value!r} of type {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)


def choice(name: str, value, options) -> str:
    if value not in options:
        opts = ", ".join(repr(o) for o in options)
        raise ValueError(f"{name} must be one of {opts}, got {value!r}")
    return value
