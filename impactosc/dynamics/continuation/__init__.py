"""Continuation of periodic orbits through impacts and stick-slip, with their bifurcations located.

:func:`continuation` follows a family of periodic orbits of the stroboscopic map as one
parameter changes (a :class:`Branch`), locates its special points (:class:`SpecialPoint`:
folds, period doublings, Neimark-Sacker points, grazings, stick onsets, other changes of
the event signature), switches onto the period-doubled branch, and follows a located
point in two parameters (the boundary a design chart draws). The map and its Jacobian
are the exact event-driven ones of :mod:`impactosc.dynamics`: no collocation mesh, no
user-written segment signature. A user's own :class:`~impactosc.HybridSystem` is followed
by the same loop on its :class:`~impactosc.dynamics.HybridMap` (any number of states): the
same smooth special points, a grazing of each guard, stick onsets as entries into a stick
mode appearing; its grazings are crossed by the same code as the flanges' (on the map of the
system with the grazed guard taken away, and for a guard with a reset on its impacting
orbits with the impact's time and state as unknowns). A tape path's critical clearance at a
guide is such a boundary, followed in SI units by :func:`critical_clearance_boundary`.

What a COCO or AUTO user expects of a run: an AUTO-style table of the labelled points
(:meth:`Branch.table`, printed by :meth:`Branch.summary`, on the ``label`` dimension of
:meth:`Branch.to_xarray`); one file with the model (:meth:`Branch.save`,
:meth:`Branch.load`); the orbit at a label or an index (:meth:`Branch.orbit`, a
:class:`~impactosc.dynamics.PeriodicOrbit` with its time series); a restart from any point
(a :class:`BranchPoint` as the start of :func:`continuation`, :meth:`Branch.model`,
:meth:`impactosc.Oscillator.replace`). Every numeric field of the model is a parameter,
the flange gaps and a drive's guide offset included.
"""

from ._api import continuation
from ._branch import SPECIAL_KINDS, Branch, BranchPoint, SpecialPoint
from ._path_clearance import critical_clearance_boundary

__all__ = ["continuation", "Branch", "BranchPoint", "SpecialPoint", "SPECIAL_KINDS", "critical_clearance_boundary"]
