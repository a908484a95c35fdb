"""The figure of a branch: AUTO/COCO style, stable solid, unstable dashed, special points labelled."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_branch"]

_YLABELS = {"x": "X on the section", "v": "V on the section", "max_x": "max X over the orbit"}


def plot_branch(branch, ax=None, y: str = "x", **style):
    """:meth:`Branch.plot` (see there)."""
    from ..._util.optional import require_matplotlib

    if y not in _YLABELS:
        raise ValueError(f"y must be 'x', 'v' or 'max_x', got {y!r}")
    plt = require_matplotlib()
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    p = branch.values() if len(branch) else np.array([])
    yy = _ordinate(branch, y)
    stable = branch.stable
    color = style.pop("color", "C0")
    for flag, ls in ((True, "-"), (False, "--")):
        # a point is drawn in the style of its own stability and of its neighbours', so each run
        # reaches the next one and the line has no gaps where the stability changes
        own = stable == flag
        near = own.copy()
        near[1:] |= own[:-1]
        near[:-1] |= own[1:]
        ax.plot(p, np.where(near, yy, np.nan), ls=ls, color=color, lw=1.4, **style)
    for i, s in enumerate(branch.special):
        if not len(p):
            break
        py = np.interp(s.parameter, p, yy) if s.index < 0 else _special_ordinate(branch, yy, s, y)
        ax.plot([s.parameter], [py], "o", ms=5, mfc="white", mec="k", zorder=5)
        ax.annotate(s.label, (s.parameter, py), xytext=(4, 6 + 8 * (i % 3)), textcoords="offset points", fontsize=8)
    ax.set_xlabel(branch.names[0])
    ax.set_ylabel(_YLABELS[y])
    return ax


def _ordinate(branch, y: str) -> np.ndarray:
    if y == "x":
        return branch.x
    if y == "v":
        return branch.v
    from .._common import oscillator_of
    from ._sensitivity import flange_gap

    out = []
    for i, p in enumerate(branch.points):
        osc = oscillator_of(branch.model(i))  # the gap itself may be the free parameter
        gap = flange_gap(osc, 1)
        # a spring flange's margin is minus the penetration, a rigid one's minus the impact speed
        out.append(gap if (osc.rigid and p.upper_margin < 0) else gap - p.upper_margin)
    return np.array(out, dtype=float)


def _special_ordinate(branch, yy: np.ndarray, s, y: str) -> float:
    if y == "x":
        return s.x
    if y == "v":
        return s.v
    i = min(max(s.index, 0), len(branch.points) - 1)
    return float(yy[i])
