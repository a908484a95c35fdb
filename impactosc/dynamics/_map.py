"""The map interface every analysis of a periodic or section map takes.

A *map* is ``z -> P(z; p)``: the state ``z`` on a section (a forcing phase for a forced
system, a guard for an autonomous one), run for ``n`` forcing periods or ``n`` returns, with
the free parameters ``p``. Shooting, Floquet multipliers, Lyapunov exponents and
continuation need from it, at a point, only:

* the image ``P(z; p)``, or why the run failed (``failure``; ``image`` is then None);
* ``dP/dz`` (``monodromy``, the product of the smooth pieces' state-transition matrices and
  the saltation matrices of the events) and ``dP/dp`` (``dp``, one column per free
  parameter), or why they do not exist (``singular``: a grazing, a start held by static
  friction alone, ...; both are NaN then, never a huge number);
* the events crossed, in order (``signature``), so that a branch knows when its orbit
  changed.

Two kinds of map provide it: a user's :class:`~impactosc.HybridSystem` through
:class:`~impactosc.dynamics.HybridMap` (n-dimensional, Jacobians from the symbolic
derivatives of the definition), and the built-in oscillator family (eq. 3 of the paper,
``z = (X, V)``) through :class:`~impactosc.dynamics.OscillatorMap` (the exact, scipy or heyoka
engine, Jacobians from the model's rule). Everything written against :class:`PoincareMap`
runs on both: there is one shooting (:func:`~impactosc.dynamics.shoot`), one saltation
formula (:func:`~impactosc.dynamics.saltation_nd`) and one continuation.

The protocols are structural (:class:`typing.Protocol`): an object with these members is a
map, whatever its class; ``isinstance(obj, PoincareMap)`` checks the members' presence.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["MapValue", "PoincareMap", "ImageAndResidual"]


class ImageAndResidual:
    """``ok`` and ``residual`` of a map value from its ``image`` and ``z``, written once for every kind of map."""

    image: np.ndarray | None
    z: np.ndarray

    @property
    def ok(self) -> bool:
        """The run finished (the map has a value)."""
        return self.image is not None

    @property
    def residual(self) -> np.ndarray:
        """``P(z) - z``."""
        assert self.image is not None, "a failed run has no residual"
        return self.image - self.z


@runtime_checkable
class MapValue(Protocol):
    """The map at one ``(z, p)``: what :meth:`PoincareMap.evaluate` returns.

    Every member is read-only; a value may carry more (the run, guard margins, ...).
    """

    @property
    def z(self) -> np.ndarray:
        """The state the map was evaluated at (length ``d``, the map's dimension)."""

    @property
    def params(self) -> tuple:
        """The free parameters' values (one per name of the map's ``names``)."""

    @property
    def image(self) -> np.ndarray | None:
        """``P(z; p)`` (length ``d``), or None when the run failed (``failure`` says why)."""

    @property
    def monodromy(self) -> np.ndarray:
        """``dP/dz`` (``d x d``); NaN when the map is not differentiable here (``singular``)."""

    @property
    def dp(self) -> np.ndarray:
        """``dP/dp`` (``d x k``, one column per free parameter, the end time's move included); NaN when singular."""

    @property
    def signature(self) -> tuple:
        """The events crossed by the run, in order (hashable items; equal signatures: the same event sequence)."""

    @property
    def failure(self) -> str:
        """Why the run failed ("" when it ran and ``image`` holds its end)."""

    @property
    def singular(self) -> str:
        """Why the map has no derivative here, in words ("" when it has one)."""

    @property
    def ok(self) -> bool:
        """The run finished: ``image`` is the map's value."""

    @property
    def residual(self) -> np.ndarray:
        """``P(z; p) - z`` (defined when ``ok``)."""


@runtime_checkable
class PoincareMap(Protocol):
    """A map ``z -> P(z; p)`` with its Jacobians (see the module docstring).

    Attributes
    ----------
    state_names : tuple of str
        The names of the components of ``z`` (``("X", "V")`` for the built-in family).
    names : tuple of str
        The free parameters: the columns of ``dp`` and the entries of ``params``.
    n : int
        Forcing periods (or returns to the section) per map.
    """

    @property
    def state_names(self) -> tuple[str, ...]:
        """The names of the components of ``z``."""

    @property
    def names(self) -> tuple[str, ...]:
        """The free parameters, in the order of ``params`` and of the columns of ``dp``."""

    @property
    def n(self) -> int:
        """Forcing periods (or returns to the section) per map."""

    def values(self) -> tuple:
        """The free parameters' values in the map's model (the default ``params``)."""

    def period(self, params=None) -> float:
        """The time one map takes at ``params`` (default :meth:`values`): ``n`` forcing periods.

        NaN for a section map of an autonomous system, whose return time depends on ``z``.
        """

    def evaluate(self, z: Sequence[float] | np.ndarray, params=None) -> MapValue:
        """``P(z; params)`` with ``dP/dz``, ``dP/dp`` and the signature (``params`` default :meth:`values`).

        Never raises for a state or a parameter value the model cannot run: the value's
        ``failure`` says why and its ``image`` is None.
        """

    def with_names(self, names) -> PoincareMap:
        """The same map with other free parameters."""
