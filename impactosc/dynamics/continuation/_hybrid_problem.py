"""The continuation problem of a user's hybrid system: ``G(z, p) = P^n(z; p) - z`` of a :class:`HybridMap`.

:class:`SystemProblem` answers what the follow loop asks of a problem (see
:class:`._problem.MapProblem`) from :meth:`HybridMap.evaluate`: the image, ``dP/dz`` and
``dP/dp`` (saltation products of the symbolic definition), the event signature and each
guard's extrema and crossing speeds along the orbit. From these it reads what the branch
locates:

* the **grazing** of each guard ``h`` (crossing direction ``d``): the margin ``-d h`` at the
  extremum of ``h`` nearest to firing (maxima of a rising guard, minima of a falling one)
  over the modes where a guard of the same expression is armed, so that it goes on through
  zero into the penetration of a contact entered (a spring flange's ``1 - max X``); where
  the guard fires and no extremum lies beyond zero (an impact with a reset), minus its
  slowest crossing speed. A zero of the margin is where a crossing appears or vanishes;
* the **stick onset**: a transition into a *stick mode* (a mode in which a state's rate is
  identically zero while another mode moves it: :func:`~impactosc.stick_slip`'s stuck mode)
  appearing or vanishing in the signature;
* any other change of the signature is a **border**.

The smooth special points (fold, branch point, period doubling, Neimark-Sacker) are the
same test functions of the ``n x n`` monodromy matrix as for the built-in family. A
grazing the branch reaches is crossed by the built-in family's code (:mod:`._grazing`), on
the map of the system with the grazed guard taken away and, for a guard with a reset, the
impact formulation of its impacting orbits (:mod:`._guard_crossing`); where that fails the
branch ends there with status 2, the grazing labelled with its guard.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from ...model.hybrid._definition import HybridSystem
from .._newton import PeriodicOrbit
from ..hybrid_map import HybridMap, HybridMapValue
from ._points import GUARD, PointInfo, smooth_tests, stability

__all__ = ["SystemProblem", "GUARD", "system_problem", "is_system_orbit"]


def is_system_orbit(start) -> bool:
    """Whether ``start`` is a periodic orbit of a user system (the built-in family's is one too, of an Oscillator)."""
    return isinstance(start, PeriodicOrbit) and isinstance(start.model, HybridSystem)


class SystemProblem:
    """``P^n`` of a user system's :class:`HybridMap` with one or more of its parameters free.

    Parameters
    ----------
    hmap : HybridMap
        The map; its ``names`` are the free parameters.
    scales : sequence of float, optional
        One per free parameter: the unknowns are ``p / scale`` (default ``max(|p|, 1e-3)``).
    """

    #: No rigid walls bound the corrector's iterates; grazings of guards are crossed (:mod:`._grazing`).
    rigid = False
    nonsmooth_steps = True
    stripped = 0
    walls = (math.inf, math.inf)
    backend = "heyoka"

    def __init__(self, hmap: HybridMap, scales=None):
        self.hmap = hmap
        self.base: HybridSystem = hmap.system
        self.names = tuple(hmap.names)
        self.n = hmap.n
        self.dimension = hmap.system.dimension
        self.state_names = tuple(hmap.system.states)
        self.section_phase = hmap.t0  #: the section's time (a forced system's stroboscopic map starts there)
        self.options: dict = {}
        self.scales = tuple(scales) if scales is not None else tuple(max(abs(v), 1e-3) for v in hmap.values())
        self.orbit_events = 0
        self.margin_tests = tuple((GUARD + g.name, "grazing") for g in self.base.guards if g.direction != 0)
        self._stick_modes = _stick_modes(self.base)

    # -- the map -----------------------------------------------------------------------------
    def evaluate(self, z, params) -> HybridMapValue:
        """``P^n(z; params)`` with ``dP/dz``, ``dP/dp`` (:meth:`HybridMap.evaluate`)."""
        return self.hmap.evaluate(z, params)

    def values(self) -> tuple:
        """The free parameters' values in the system."""
        return self.hmap.values()

    def model(self, params) -> HybridSystem:
        """The system with the free parameters set to ``params``."""
        return self.base.with_parameters(**dict(zip(self.names, (float(p) for p in params), strict=True)))

    def period(self, params) -> float:
        """The time one map takes at ``params`` (NaN for a section map, whose return time depends on the state)."""
        if self.hmap.section is not None:
            return math.nan
        return _period(self.model(params), self.n)

    @staticmethod
    def events_in(ev: HybridMapValue) -> int:
        return len(ev.signature)

    def limit_events(self, orbit_events: int) -> None:
        """Keep the events of the start's orbit (the user system's run has its own event limit)."""
        self.orbit_events = int(orbit_events)

    def doubled(self) -> SystemProblem:
        """The same problem over twice the periods (the branch born at a period doubling)."""
        h = self.hmap
        return SystemProblem(HybridMap(self.base, 2 * h.iterates, names=self.names, mode=h.mode, t0=h.t0, tol=h.tol,
                                       max_time=h.max_time), self.scales)

    # -- what a point says -------------------------------------------------------------------
    def point_info(self, ev: HybridMapValue) -> PointInfo:
        """Multipliers, stability, signature (counts of ``(guard, "mode before->mode after")``) and guard margins."""
        n = self.dimension
        if ev.singular:
            mus = np.full(n, math.nan, dtype=complex)
            tests = {"fold": math.nan, "period_doubling": math.nan, "neimark_sacker": math.nan}
        else:
            mus, tests = smooth_tests(ev.monodromy)
        margins = {name: self._margin(ev, name.removeprefix(GUARD)) for name, _ in self.margin_tests}
        times = [t for _, t, _ in ev.speeds] if len(ev.speeds) == len(ev.signature) else None
        return PointInfo(mus, stability(mus), False, signature(ev.signature, times), math.nan, math.nan, math.nan,
                         tests, ev.signature, ev.singular, margins=margins)

    def _margin(self, ev: HybridMapValue, guard: str) -> float:
        """The signed distance of the orbit from grazing ``guard`` (module docstring); NaN where none is defined."""
        d = self.base.guards[self.base.guard_names.index(guard)].direction
        reach = [d * h for g, _, h in ev.extrema if g == guard]
        speeds = [abs(s) for g, _, s in ev.speeds if g == guard]
        if speeds and not any(r > 0.0 for r in reach):
            return -min(speeds)
        return -max(reach) if reach else math.nan

    def signature_kind(self, before, after) -> str:
        """``"stick_onset"`` when transitions into a stick mode appear or vanish, ``"grazing"`` when a guard's
        crossings do, else ``"border"``."""
        if _into(before, self._stick_modes) != _into(after, self._stick_modes):
            return "stick_onset"
        if self.changed_guards(before, after):
            return "grazing"
        return "border"

    def stick_entries(self, sig) -> int:
        """How many transitions into a stick mode a signature has."""
        return _into(sig, self._stick_modes)

    @staticmethod
    def changed_guards(before, after) -> str:
        """The guards whose number of crossings differs between two signatures (comma-separated, "" if none)."""
        def crossings(sig):
            out: Counter = Counter()
            for (guard, _), count in sig:
                out[guard] += count
            return out

        a, b = crossings(before), crossings(after)
        return ", ".join(sorted(g for g in set(a) | set(b) if a[g] != b[g]))


def signature(crossings, times=None) -> tuple:
    """``((guard, "before->after"), count)`` pairs, sorted: how often each transition occurs in one map period.

    Several crossings at one instant (``times``, one per crossing) are one transition, from the
    mode before the first to the mode after the last, named by the first guard; such a group
    that returns to its mode is none. A mode occupied for no time is no part of the orbit: a
    slip that ends at the very instant of a release (the stick test decided within rounding)
    would otherwise add or drop a stick-release pair between neighbouring points of a branch.
    A single crossing always counts (an impact's reset keeps the mode).
    """
    merged: list[tuple] = []  # (guard, before, after, crossings in the group)
    for i, (guard, before, after) in enumerate(crossings):
        if merged and times is not None and times[i] == times[i - 1]:
            first, start, _, size = merged[-1]
            merged[-1] = (first, start, after, size + 1)
        else:
            merged.append((guard, before, after, 1))
    counts = Counter((guard, f"{before}->{after}") for guard, before, after, size in merged
                     if size == 1 or before != after)
    return tuple(sorted(counts.items()))


def _into(sig, modes) -> int:
    return sum(count for (_, transition), count in sig if transition.split("->")[1] in modes)


def _stick_modes(system: HybridSystem) -> frozenset:
    """Modes in which some state's rate is identically zero while another mode moves it (stuck modes)."""
    import heyoka as hy

    zero = hy.expression(0.0)
    out = set()
    for mode in system.modes:
        for i in range(system.dimension):
            if mode.field[i] == zero and any(other.field[i] != zero for other in system.modes):
                out.add(mode.name)
    return frozenset(out)


def _period(system: HybridSystem, n: int) -> float:
    from ...model.hybrid._numeric import numeric

    num = numeric(system)
    return n * float(num.period_function()(0.0, [0.0] * len(num.states), system.parameter_values)[0])


def system_problem(start, parameter: str, limits, base, options: dict):
    """``(SystemProblem, z0)`` of a user-system start (see :func:`.continuation`).

    ``base`` is a :class:`HybridMap` (its ``iterates``, section ``t0``, mode and tolerance are
    kept; the free parameter replaces its names) or a :class:`HybridSystem` (the map over one
    forcing period from ``t = 0``); ``start`` a converged :class:`HybridOrbit` of that map or a
    guess of the state on the section.
    """
    if options:
        raise TypeError(f"a user system's continuation takes no backend options, got {sorted(options)}: set the "
                        "map's tolerance with HybridMap(..., tol=...) and pass the map as base")
    if isinstance(base, HybridSystem):
        base = HybridMap(base)
    if not isinstance(base, HybridMap):
        raise TypeError(f"base must be a HybridMap or a HybridSystem for a user system's start, got {base!r}")
    system = base.system
    if not isinstance(parameter, str) or parameter not in system.parameter_names:
        raise ValueError(f"parameter must name a parameter of the system {system.name!r}; the parameters are "
                         f"{list(system.parameter_names)}, got {parameter!r}")
    hmap = base.with_names((parameter,))
    if is_system_orbit(start):
        if start.status != 0:
            raise ValueError(f"start must be a converged HybridOrbit (status 0), got status {start.status}: "
                             f"{start.message}")
        z0 = np.asarray(start.z, dtype=float)
    else:
        try:
            z0 = np.asarray(start, dtype=float).ravel()
        except (TypeError, ValueError):
            raise TypeError(f"start must be a HybridOrbit or the state on the section ({system.dimension} numbers), "
                            f"got {start!r}") from None
    if z0.size != system.dimension or not np.all(np.isfinite(z0)):
        raise ValueError(f"start must be {system.dimension} finite numbers, one per state {list(system.states)}, "
                         f"got {z0}")
    value = hmap.values()[0]
    lo, hi = limits
    scale = max(abs(value), float(hi) - float(lo))
    return SystemProblem(hmap, (scale,)), z0
