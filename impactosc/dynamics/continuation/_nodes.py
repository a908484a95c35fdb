"""The points a continuation accepts and the special points it locates, before they become a Branch."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._arclength import Corrected, jacobian_rows, tangent
from ._points import PointInfo, point_info
from ._problem import MapProblem

__all__ = ["Node", "Found", "make_node"]


@dataclass(eq=False)
class Node:
    """An accepted point: unknowns, tangent, evaluation and what it says."""

    u: np.ndarray
    t: np.ndarray
    corrected: Corrected
    info: PointInfo
    arclength: float


@dataclass(eq=False)
class Found:
    """A located special point before it becomes a :class:`~._branch.SpecialPoint`."""

    kind: str
    node: Node
    before: tuple
    after: tuple
    accuracy: float
    message: str
    index: int
    extra: dict = field(default_factory=dict)


def make_node(problem: MapProblem, corrected: Corrected, previous_t, arclength: float, extra=None) -> Node:
    rows = jacobian_rows(problem, corrected.ev)
    if extra is not None:
        rows = np.vstack([rows, extra(corrected.ev, corrected.u)[1]])
    t = tangent(rows, previous_t)
    return Node(corrected.u, t, corrected, point_info(problem, corrected.ev), arclength)
