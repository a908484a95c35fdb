"""Continuation of periodic orbits through impacts and stick-slip, with their bifurcations located.

:func:`continuation` follows a family of periodic orbits of the stroboscopic map as one
parameter changes (a :class:`Branch`), locates its special points (:class:`SpecialPoint`:
folds, period doublings, Neimark-Sacker points, grazings, stick onsets, other changes of
the event signature), switches onto the period-doubled branch, and follows a located
point in two parameters (the boundary a design chart draws). The map and its Jacobian
are the exact event-driven ones of :mod:`impactosc.dynamics`: no collocation mesh, no
user-written segment signature.
"""

from ._api import continuation
from ._branch import SPECIAL_KINDS, Branch, BranchPoint, SpecialPoint

__all__ = ["continuation", "Branch", "BranchPoint", "SpecialPoint", "SPECIAL_KINDS"]
