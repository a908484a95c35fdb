"""The result of a continuation run: a :class:`Branch` of :class:`BranchPoint` with :class:`SpecialPoint` labels.

Laid out the way AUTO and COCO report a run: one row per point (parameter, state, period,
multipliers, stability, event signature, margins), the located special points with their
kind and label, and a status and message per end of the branch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["BranchPoint", "SpecialPoint", "Branch", "SPECIAL_KINDS"]

#: The kinds of special point a branch labels (AUTO's abbreviations LP, BP, PD, NS; GR grazing, ST stick onset, SC
#: another change of the event signature; RG resonant grazing, where a fold or period-doubling curve of impacting
#: orbits meets the grazing and ends).
SPECIAL_KINDS = ("fold", "branch_point", "period_doubling", "neimark_sacker", "grazing", "stick_onset", "border",
                 "resonant_grazing")
LABELS = {"fold": "LP", "branch_point": "BP", "period_doubling": "PD", "neimark_sacker": "NS", "grazing": "GR",
          "stick_onset": "ST", "border": "SC", "resonant_grazing": "RG"}


@dataclass(frozen=True, eq=False)
class BranchPoint:
    """One periodic orbit on a branch.

    Attributes
    ----------
    parameters : dict
        The free parameters' values, by name.
    x, v : float
        The orbit's point on the section (nondimensional, eq. 3).
    period : float
        The map's time span ``n * 2 pi / Omega`` (nondimensional).
    multipliers : ndarray of complex
        Floquet multipliers, largest modulus first (NaN at a point where no Jacobian exists).
    stability : str
        ``"stable"``, ``"unstable"``, ``"marginal"`` or ``"undefined"``.
    signature : tuple
        ``((kind, side), count)`` of the events of one map period (side +1 upper, -1 lower, 0 none).
    upper_margin, lower_margin : float
        Signed distance from each flange: ``1 - max X`` while clear of it, the penetration
        (negative) of a spring flange, minus the slowest impact speed on a rigid one.
    stick_margin : float
        ``max (beta_s - |f_net|)`` over the reversals (negative: each slides on) or, once the orbit
        sticks, its shortest stick (positive); NaN without friction.
    arclength : float
        Signed pseudo-arclength from the start (scaled units).
    """

    parameters: dict
    x: float
    v: float
    period: float
    multipliers: np.ndarray
    stability: str
    signature: tuple
    upper_margin: float
    lower_margin: float
    stick_margin: float
    arclength: float
    tests: dict = field(default_factory=dict, repr=False)
    collapsed: bool = False

    @property
    def parameter(self) -> float:
        """The value of the first free parameter."""
        return next(iter(self.parameters.values()))

    @property
    def stable(self) -> bool:
        return self.stability == "stable"

    def signature_text(self) -> str:
        side = {1: "upper ", -1: "lower ", 0: ""}
        return ", ".join(f"{count} {side[s]}{kind}" for (kind, s), count in self.signature) or "no events"


@dataclass(frozen=True, eq=False)
class SpecialPoint:
    """A located special point of a branch.

    Attributes
    ----------
    kind : str
        One of :data:`SPECIAL_KINDS`.
    label : str
        AUTO's abbreviation and a number (``"PD1"``, ``"GR2"``, ...).
    parameters : dict
        Where it is.
    x, v : float
        The orbit's section point there.
    multipliers : ndarray of complex
        Multipliers on the branch side before the point (NaN where no Jacobian exists).
    before, after : tuple
        Event signatures on the two sides.
    index : int
        The branch point after which it lies.
    accuracy : float
        Width of the final bracket in the first parameter.
    message : str
        What happens there, in words.
    """

    kind: str
    label: str
    parameters: dict
    x: float
    v: float
    multipliers: np.ndarray
    before: tuple
    after: tuple
    index: int
    accuracy: float
    message: str
    context: Any = field(default=None, repr=False)  #: (problem, u, tangent): what continues it

    @property
    def parameter(self) -> float:
        return next(iter(self.parameters.values()))


@dataclass(frozen=True, eq=False)
class Branch:
    """A branch of periodic orbits (one or two free parameters).

    Attributes
    ----------
    names : tuple of str
        The free parameters.
    n : int
        Forcing periods per orbit period.
    points : list of BranchPoint
        In arclength order.
    special : list of SpecialPoint
        Located special points, in arclength order.
    status : int
        0: each end reached a parameter limit; 1: ``max_points`` reached; 2: an end is a
        nonsmooth point where the family ends (a grazing with no orbit beyond); -1: the step
        fell below ``min_step`` (the corrector failed: the message says why). The points
        computed so far are kept whatever the status.
    message : str
        Each end's outcome, in words.
    ends : tuple
        ``(status, message)`` of the backward and the forward end.
    base : Oscillator or TapeDrive
        The model at the start.
    """

    names: tuple
    n: int
    points: list
    special: list
    status: int
    message: str
    ends: tuple
    base: Any
    backend: str

    def __len__(self) -> int:
        return len(self.points)

    def values(self, name: str | None = None) -> np.ndarray:
        """The values of a free parameter (default the first) along the branch."""
        name = self.names[0] if name is None else name
        return np.array([p.parameters[name] for p in self.points])

    @property
    def x(self) -> np.ndarray:
        return np.array([p.x for p in self.points])

    @property
    def v(self) -> np.ndarray:
        return np.array([p.v for p in self.points])

    @property
    def stable(self) -> np.ndarray:
        return np.array([p.stable for p in self.points], dtype=bool)

    def find(self, kind: str) -> list:
        """The special points of one kind."""
        if kind not in SPECIAL_KINDS:
            raise ValueError(f"kind must be one of {', '.join(SPECIAL_KINDS)}, got {kind!r}")
        return [s for s in self.special if s.kind == kind]

    def to_xarray(self):
        """One row per point: parameters, state, multipliers, stability, signature, margins.

        The special points are in the attributes ``special`` (one line each).
        """
        import xarray as xr

        idx = np.arange(len(self.points))
        mus = np.array([p.multipliers for p in self.points], dtype=complex).reshape(len(idx), -1)
        data = {name: ("point", self.values(name)) for name in self.names}
        data.update({
            "x": ("point", self.x), "v": ("point", self.v),
            "period": ("point", np.array([p.period for p in self.points])),
            "multiplier_real": (("point", "k"), mus.real), "multiplier_imag": (("point", "k"), mus.imag),
            "multiplier_abs": (("point", "k"), np.abs(mus)),
            "stability": ("point", np.array([p.stability for p in self.points], dtype=str)),
            "stable": ("point", self.stable),
            "signature": ("point", np.array([p.signature_text() for p in self.points], dtype=str)),
            "upper_margin": ("point", np.array([p.upper_margin for p in self.points])),
            "lower_margin": ("point", np.array([p.lower_margin for p in self.points])),
            "stick_margin": ("point", np.array([p.stick_margin for p in self.points])),
            "arclength": ("point", np.array([p.arclength for p in self.points])),
        })
        ds = xr.Dataset(data, coords={"point": idx})
        ds.attrs.update({"parameters": ", ".join(self.names), "n": self.n, "status": self.status,
                         "message": self.message, "backend": self.backend,
                         "special": "; ".join(f"{s.label} {s.kind} at "
                                              + ", ".join(f"{k}={val:.12g}" for k, val in s.parameters.items())
                                              for s in self.special),
                         "model": repr(self.base)})
        return ds

    def summary(self) -> str:
        """A few lines: the run's outcome and its special points."""
        lines = [f"branch of period-{self.n} orbits in {', '.join(self.names)}: {len(self.points)} points, "
                 f"status {self.status}: {self.message}"]
        for s in self.special:
            where = ", ".join(f"{k} = {val:.12g}" for k, val in s.parameters.items())
            lines.append(f"  {s.label:5s} {s.kind:16s} {where}  ({s.message})")
        return "\n".join(lines)

    def plot(self, ax=None, y: str = "x", **style):
        """The branch in the AUTO/COCO style: stable solid, unstable dashed, special points labelled.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
        y : {"x", "v", "max_x"}
            What to draw against the first parameter: the section state, or ``max X`` over
            the orbit (the upper flange's gap minus ``upper_margin``: beyond the gap where the
            orbit penetrates a spring flange, at the gap where it hits a rigid one).
        **style
            Passed to ``Axes.plot`` (e.g. ``color``).
        """
        from ..._util.optional import require_matplotlib

        plt = require_matplotlib()
        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        p = self.values()
        yy = self._ordinate(y)
        stable = self.stable
        color = style.pop("color", "C0")
        for flag, ls in ((True, "-"), (False, "--")):
            # a point is drawn in the style of its own stability and of its neighbours', so each run
            # reaches the next one and the line has no gaps where the stability changes
            own = stable == flag
            near = own.copy()
            near[1:] |= own[:-1]
            near[:-1] |= own[1:]
            ax.plot(p, np.where(near, yy, np.nan), ls=ls, color=color, lw=1.4, **style)
        for i, s in enumerate(self.special):
            py = np.interp(s.parameter, p, yy) if s.index < 0 else self._special_ordinate(s, y)
            ax.plot([s.parameter], [py], "o", ms=5, mfc="white", mec="k", zorder=5)
            ax.annotate(s.label, (s.parameter, py), xytext=(4, 6 + 8 * (i % 3)), textcoords="offset points",
                        fontsize=8)
        ax.set_xlabel(self.names[0])
        ax.set_ylabel({"x": "X on the section", "v": "V on the section", "max_x": "max X over the orbit"}[y])
        return ax

    def _ordinate(self, y: str) -> np.ndarray:
        if y == "x":
            return self.x
        if y == "v":
            return self.v
        if y == "max_x":
            from .._common import oscillator_of
            from ._sensitivity import flange_gap

            osc = oscillator_of(self.base)
            gap = flange_gap(osc, 1)
            # a spring flange's margin is minus the penetration, a rigid one's minus the impact speed
            return np.array([gap if (osc.rigid and p.upper_margin < 0) else gap - p.upper_margin
                             for p in self.points])
        raise ValueError(f"y must be 'x', 'v' or 'max_x', got {y!r}")

    def _special_ordinate(self, s: SpecialPoint, y: str) -> float:
        if y == "x":
            return s.x
        if y == "v":
            return s.v
        i = min(max(s.index, 0), len(self.points) - 1)
        return float(self._ordinate(y)[i])

    def overlay(self, diagram, ax=None, **style):
        """Draw the branch over a :func:`~impactosc.dynamics.bifurcation_diagram` Dataset (its ``x`` points)."""
        from ..bifurcation import plot_bifurcation

        ax = plot_bifurcation(diagram, ax=ax) if ax is None else ax
        return self.plot(ax=ax, y="x", **style)


def nan_multipliers() -> np.ndarray:
    return np.full(2, math.nan, dtype=complex)
