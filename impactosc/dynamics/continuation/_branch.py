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

from ...model.hybrid._definition import HybridSystem
from ._table import signature_text, touched_flanges

__all__ = ["BranchPoint", "SpecialPoint", "Branch", "SPECIAL_KINDS"]

#: The kinds of special point a branch labels (AUTO's abbreviations LP, BP, PD, NS; GR grazing, ST stick onset, SC
#: another change of the event signature; RG resonant grazing, where a fold or period-doubling curve of impacting
#: orbits meets the grazing and ends; CP a cusp of a fold curve; FG, PDG where a fold or a period-doubling curve meets a
#: grazing curve; GS where a stick onset meets a grazing curve).
SPECIAL_KINDS = ("fold", "branch_point", "period_doubling", "neimark_sacker", "grazing", "stick_onset", "border",
                 "resonant_grazing", "cusp", "fold_grazing", "period_doubling_grazing", "grazing_stick")
LABELS = {"fold": "LP", "branch_point": "BP", "period_doubling": "PD", "neimark_sacker": "NS", "grazing": "GR",
          "stick_onset": "ST", "border": "SC", "resonant_grazing": "RG", "cusp": "CP",
          "fold_grazing": "FG", "period_doubling_grazing": "PDG", "grazing_stick": "GS"}


class _OnTheSection:
    """What a point of a branch and a special point derive alike from their fields."""

    parameters: dict
    state: Any
    x: float
    v: float

    @property
    def parameter(self) -> float:
        """The value of the first free parameter."""
        return next(iter(self.parameters.values()))

    @property
    def z(self) -> np.ndarray:
        """The orbit's state on the section: ``state``, or ``(x, v)`` of a point loaded from a file."""
        return np.array(self.state if self.state is not None else (self.x, self.v), dtype=float)

    @property
    def norm(self) -> float:
        """``|z|`` of the orbit's point on the section (the norm column of :meth:`Branch.table`)."""
        return float(np.linalg.norm(self.z))


@dataclass(frozen=True, eq=False)
class BranchPoint(_OnTheSection):
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
    #: The branch the point belongs to (set by :func:`continuation` and :meth:`Branch.load`): what
    #: makes the point a start of its own (``continuation(point, ...)``, :meth:`Branch.orbit`).
    branch: Any = field(default=None, repr=False, compare=False)
    #: The whole state on the section (a user system's, any length; ``(X, V)`` of the built-in family).
    state: Any = field(default=None, repr=False, compare=False)

    @property
    def stable(self) -> bool:
        return self.stability == "stable"

    def signature_text(self) -> str:
        return signature_text(self.signature)


@dataclass(frozen=True, eq=False)
class SpecialPoint(_OnTheSection):
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
    context: Any = field(default=None, repr=False)  #: (problem, node, extra): what continues it
    #: The flange a grazing touches, as saved in a file (a loaded point has no ``context``).
    saved_flange: str = field(default="", repr=False)
    #: The branch the point was located on (set by :func:`continuation` and :meth:`Branch.load`).
    branch: Any = field(default=None, repr=False, compare=False)
    #: The whole state on the section (see :attr:`BranchPoint.state`).
    state: Any = field(default=None, repr=False, compare=False)

    @property
    def guard(self) -> str:
        """The guard of a user system that a grazing touches (or whose crossings change); ``""`` otherwise."""
        extra = self.context[2] if isinstance(self.context, tuple) and len(self.context) > 2 else None
        return str((extra or {}).get("guard", ""))

    @property
    def located(self) -> bool:
        """False for a point known only to lie in a bracket (see its message and accuracy)."""
        return not self.message.startswith("not located")

    @property
    def flange(self) -> str:
        """The flange a grazing touches (``"upper"``, ``"lower"``); ``""`` for other kinds or when unknown."""
        if self.kind != "grazing" or self.saved_flange:
            return self.saved_flange if self.kind == "grazing" else ""
        extra = self.context[2] if isinstance(self.context, tuple) and len(self.context) > 2 else None
        margin = (extra or {}).get("margin") or (extra or {}).get("test")
        if margin in ("upper_margin", "lower_margin"):
            return margin.split("_")[0]
        return touched_flanges(tuple(set(self.before) ^ set(self.after)))


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
    backend : str
        The backend of every run of the branch.
    section_phase : float
        The forcing phase ``Omega t + phase`` (mod 2 pi) of the section the points lie on.
    options : dict
        The backend's options.

    Examples
    --------
    The Den Hartog orbit of a Coulomb oscillator between spring flanges, followed in the
    forcing amplitude through its grazing; the table, an orbit at a labelled point, a
    file and a restart:

    >>> import impactosc as io, impactosc.dynamics as dy
    >>> osc = io.Oscillator(0.9, 1.5, 0.1, 24.0)
    >>> orb = dy.periodic_orbit(osc, guess=(-0.79, 0.16), backend="exact")
    >>> br = dy.continuation(orb, "F", (0.6, 1.3))
    >>> print(br.summary())                                  # doctest: +SKIP
    >>> gr = br.find("grazing")[0]                           # the first touch of a flange
    >>> br.orbit(gr.label).solution.plot()                   # doctest: +SKIP
    >>> br.save("branch.nc")                                 # doctest: +SKIP
    >>> again = dy.Branch.load("branch.nc")                  # doctest: +SKIP
    >>> more = dy.continuation(br.points[-1], "Omega", (1.2, 1.8))   # restart at a point  # doctest: +SKIP
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
    section_phase: float = 0.0
    options: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.points)

    # -- the points as models, orbits and starts -----------------------------------------
    def point(self, key):
        """The point labelled ``key`` (a :class:`SpecialPoint`, e.g. ``"LP1"``) or at index ``key`` (a BranchPoint).

        Raises
        ------
        KeyError
            If no special point has that label.
        IndexError, TypeError
            For an index out of range, or a key that is neither a label nor an integer.
        """
        if isinstance(key, BranchPoint | SpecialPoint):
            return key
        if isinstance(key, str):
            for s in self.special:
                if s.label == key:
                    return s
            raise KeyError(f"no special point is labelled {key!r}; the labels are "
                           f"{', '.join(s.label for s in self.special) or 'none'}")
        if isinstance(key, bool) or not isinstance(key, int | np.integer):
            raise TypeError(f"key must be a label (str) or an index (int), got {key!r}")
        return self.points[int(key)]

    @property
    def is_system(self) -> bool:
        """A branch of a user's :class:`~impactosc.HybridSystem` (not of the built-in family)."""
        return isinstance(self.base, HybridSystem)

    def model(self, key):
        """The model (Oscillator, TapeDrive or HybridSystem, like ``base``) at the point ``key`` (see :meth:`point`)."""
        from .._common import with_parameter

        if self.is_system:
            return self.base.with_parameters(**self.point(key).parameters)
        m = self.base
        for name, value in self.point(key).parameters.items():
            m = with_parameter(m, name, float(value))
        return m

    def orbit_phase(self, key) -> float:
        """The forcing phase of the section at the point ``key`` (``section_phase`` unless the phase is free)."""
        if "phase" not in self.names:
            return self.section_phase
        from .._common import oscillator_of

        base = oscillator_of(self.base)
        here = oscillator_of(self.model(key))
        t_section = ((self.section_phase - base.phase) % (2.0 * math.pi)) / base.Omega if base.F and base.Omega \
            else 0.0
        return math.fmod(here.phase + here.Omega * t_section, 2.0 * math.pi)

    def orbit(self, key, **options):
        """The periodic orbit at the point ``key`` (a label such as ``"PD1"`` or an index), Newton-corrected.

        A :class:`~impactosc.dynamics.PeriodicOrbit`: its ``solution`` has the time series of
        one period (``solution.sample``, ``solution.plot()``), its multipliers and events.
        At a located nonsmooth point (a grazing) the orbit exists but the map has no
        Jacobian there: Newton may say so in ``status``/``message``.

        Parameters
        ----------
        key : str or int
            A special point's label or a point's index (:meth:`point`).
        **options
            Passed to :func:`~impactosc.dynamics.periodic_orbit` (``tol``, ``max_iter``, ...).
        """
        from ..shooting import periodic_orbit

        p = self.point(key)
        if self.is_system:  # a HybridOrbit of the user system's map, on the branch's section
            from ..hybrid_map import HybridMap, periodic_orbit_of

            return periodic_orbit_of(HybridMap(self.model(p), self.n, t0=self.section_phase), p.z, **options)
        kw = {**self.options, **options}
        return periodic_orbit(self.model(p), self.n, guess=(p.x, p.v), phase=self.orbit_phase(p),
                              backend=self.backend, **kw)

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

    def table(self) -> list[dict]:
        """The AUTO-style table of the labelled points: the ends (``EP``) and the special points.

        One dict per row, in arclength order: ``label`` (``EP1``, ``LP1``, ...), ``type``
        (AUTO's ``EP``, ``LP``, ``BP``, ``PD``, ``NS``, ``GR``, ``ST``, ``SC``), ``point`` (the
        index of the branch point at or just before it), one entry per free parameter,
        ``norm`` (``|(X, V)|`` on the section), ``stability`` and ``flange`` (which flanges the
        orbit touches there, or the flange a grazing touches).
        """
        from ._points import _stability

        rows: list[tuple[float, int, dict]] = []
        ends = [0, len(self.points) - 1] if len(self.points) > 1 else [0] if self.points else []
        for k, i in enumerate(ends, start=1):
            p = self.points[i]
            rows.append((i, 0 if k == 1 else 2, {"label": f"EP{k}", "type": "EP", "point": i, **p.parameters,
                                                  "norm": p.norm, "stability": p.stability,
                                                  "flange": touched_flanges(p.signature) or "none"}))
        for s in self.special:
            mus = np.asarray(s.multipliers)
            stability = _stability(mus) if np.all(np.isfinite(mus)) else "undefined"
            rows.append((s.index + 0.5, 1, {"label": s.label, "type": s.label.rstrip("0123456789"),
                                            "point": max(s.index, 0), **s.parameters, "norm": s.norm,
                                            "stability": stability,
                                            "flange": s.flange or s.guard or touched_flanges(s.after) or "none"}))
        return [row for *_, row in sorted(rows, key=lambda r: (r[0], r[1]))]

    def to_xarray(self):
        """One row per point: parameters, state, multipliers, stability, signature, margins.

        The labelled points (:meth:`table`) are on a second dimension ``label``: ``type``,
        ``label_point``, ``label_<parameter>``, ``label_norm``, ``label_stability`` and
        ``label_flange``. The special points are also in the attribute ``special`` (one line
        each). A branch without points gives a Dataset of length 0.
        """
        from ._table import dataset

        return dataset(self)

    def summary(self) -> str:
        """The run's outcome, its special points in words, and the AUTO-style table (:meth:`table`)."""
        lines = [f"branch of period-{self.n} orbits in {', '.join(self.names)}: {len(self.points)} points, "
                 f"status {self.status}: {self.message}"]
        for s in self.special:
            where = ", ".join(f"{k} = {val:.12g}" for k, val in s.parameters.items())
            lines.append(f"  {s.label:5s} {s.kind:16s} {where}  ({s.message})")
        rows = self.table()
        if rows:
            lines.append("")
            head = f"  {'LAB':5s} {'TY':3s} {'PT':>5s} " + " ".join(f"{n:>16s}" for n in self.names)
            lines.append(head + f" {'norm':>14s}  {'stability':10s} flange")
            for r in rows:
                lines.append(f"  {r['label']:5s} {r['type']:3s} {r['point']:5d} "
                             + " ".join(f"{r[n]:16.10g}" for n in self.names)
                             + f" {r['norm']:14.8g}  {r['stability']:10s} {r['flange']}")
        return "\n".join(lines)

    # -- one file -----------------------------------------------------------------------
    def save(self, path) -> None:
        """Write the branch and its model to one netCDF file (:meth:`load` reads it back).

        The file is :meth:`to_xarray` plus what a restart needs: the model's class and
        fields, the backend and its options, the section phase, each point's event
        signature and test functions, and the special points (kind, label, where, state,
        multipliers, signatures, accuracy, message) on a dimension ``special``. The special
        points come back without their ``context``: follow one as a boundary or switch
        branches from a fresh run, or restart from :meth:`orbit`.
        """
        from ._file import to_dataset

        if self.is_system:
            raise TypeError(f"a branch of the user system {self.base.name!r} cannot be saved: its model is written in "
                            "heyoka expressions, which a netCDF file cannot hold; keep the table "
                            "(branch.to_xarray().to_netcdf(path)) and rebuild the system in code")
        to_dataset(self).to_netcdf(path, engine="scipy")

    @classmethod
    def load(cls, path) -> Branch:
        """The branch :meth:`save` wrote to ``path``.

        Raises
        ------
        ValueError
            If the file is not a saved branch (or from another format version).
        """
        import xarray as xr

        from ._file import from_dataset

        with xr.open_dataset(path, engine="scipy") as ds:
            ds.load()
            return from_dataset(ds, (cls, BranchPoint, SpecialPoint)).adopted()

    def adopted(self) -> Branch:
        """The branch with every point knowing it (:attr:`BranchPoint.branch`): each point a start of its own."""
        for p in (*self.points, *self.special):
            object.__setattr__(p, "branch", self)
        return self

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
        from ._plot import plot_branch

        return plot_branch(self, ax, y, **style)

    def overlay(self, diagram, ax=None, **style):
        """Draw the branch over a :func:`~impactosc.dynamics.bifurcation_diagram` Dataset (its ``x`` points)."""
        from ..bifurcation import plot_bifurcation

        ax = plot_bifurcation(diagram, ax=ax) if ax is None else ax
        return self.plot(ax=ax, y="x", **style)


def nan_multipliers() -> np.ndarray:
    return np.full(2, math.nan, dtype=complex)
