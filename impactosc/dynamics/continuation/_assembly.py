"""Assembling a :class:`~._branch.Branch` from the followed nodes, and the checks shared by the entry points."""

from __future__ import annotations

import math
import numbers

from ._arclength import unscaled
from ._branch import LABELS, Branch, BranchPoint, SpecialPoint
from ._follow import LABEL_ORDER, Found, Node
from ._problem import MapProblem

__all__ = ["check_limits", "reindex", "assemble"]


def check_limits(name: str, limits, value: float) -> tuple[float, float]:
    try:
        lo, hi = limits
    except (TypeError, ValueError):
        raise TypeError(f"limits must be a pair (lo, hi) of the parameter {name!r}, got {limits!r}") from None
    for label, x in (("limits[0]", lo), ("limits[1]", hi)):
        if isinstance(x, bool) or not isinstance(x, numbers.Real):
            raise TypeError(f"{label} must be a real number, got {x!r}")
        if not math.isfinite(float(x)):
            raise ValueError(f"{label} must be finite, got {x!r}")
    lo, hi = float(lo), float(hi)
    if not lo < hi:
        raise ValueError(f"limits must satisfy lo < hi, got ({lo!r}, {hi!r})")
    if not lo <= value <= hi:
        raise ValueError(f"the start's {name} = {value!r} lies outside the limits ({lo!r}, {hi!r})")
    return lo, hi


def reindex(found: Found, index: int) -> Found:
    found.index = index
    return found


def assemble(problem: MapProblem, nodes, found, ends, start_index: int) -> Branch:
    points = [point_of(problem, node) for node in nodes]
    counters: dict = {}
    special = []
    for f in sorted(found, key=lambda f: (f.index, LABEL_ORDER.get(f.kind, 9))):
        counters[f.kind] = counters.get(f.kind, 0) + 1
        special.append(special_of(problem, f, counters[f.kind]))
    statuses = [s for s, _ in ends]
    status = next((s for s in statuses if s < 0), next((s for s in statuses if s != 0), 0))
    message = "; ".join(("backward: " if len(ends) == 2 and i == 0 else "forward: " if len(ends) == 2 else "") + m
                        for i, (_, m) in enumerate(ends))
    return Branch(problem.names, problem.n, points, special, status, message, tuple(ends), problem.base,
                  problem.backend)


def _xv(z) -> tuple[float, float]:
    """The first two components of the state (``X, V`` of the built-in family; NaN for a missing one)."""
    return float(z[0]), float(z[1]) if len(z) > 1 else math.nan


def point_of(problem: MapProblem, node: Node) -> BranchPoint:
    z, params = unscaled(problem, node.u)
    info = node.info
    return BranchPoint(dict(zip(problem.names, params, strict=True)), *_xv(z), problem.period(params),
                       info.multipliers, info.stability, info.signature, info.upper_margin, info.lower_margin,
                       info.stick_margin, node.arclength, info.tests, info.collapsed, state=z)


def special_of(problem: MapProblem, f: Found, number: int) -> SpecialPoint:
    z, params = unscaled(problem, f.node.u)
    if "value" in f.extra:  # an extrapolated end: the first parameter moved to where the grazing is
        params = (f.extra["value"],) + tuple(params[1:])
    return SpecialPoint(f.kind, f"{LABELS[f.kind]}{number}", dict(zip(problem.names, params, strict=True)),
                        *_xv(z), f.node.info.multipliers, f.before, f.after, f.index, f.accuracy,
                        f.message, context=(problem, f.node, f.extra), state=z)
