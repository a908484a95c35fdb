"""The built-in family's stroboscopic map as a :class:`~._map.PoincareMap`.

:class:`OscillatorMap` is ``z = (X, V) -> P^n(z)`` of a member of the paper's family (eq. 3:
an :class:`~impactosc.Oscillator`, or a :class:`~impactosc.TapeDrive` through its
oscillator) over ``n`` forcing periods from a section phase, with ``dP/dz`` from the
saltation product. It is what :func:`~impactosc.dynamics.periodic_orbit`,
:func:`~impactosc.dynamics.monodromy` and the shooting (``_newton.shoot``) evaluate:

* ``backend="exact"`` (the compiled closed form of linear members: the fast path) and
  ``"scipy"`` (the cross-check) run the built-in engine with the tangent recorder
  (:mod:`.tangent`: state-transition matrices and the model's saltation matrices);
* ``backend="heyoka"`` runs the member on heyoka's one event loop and replays the run into the
  same recorder, with the engine's transitions (:func:`.tangent.drive_recorder`); with
  ``user_system=True`` it writes the member as a user system
  (:func:`~impactosc.model.hybrid.oscillator_system`) and evaluates its
  :class:`~impactosc.dynamics.HybridMap` instead (heyoka's variational equations and the
  shared saltation formula), where that system expresses the member: a power-law flange
  (``d^p`` is not analytic where a contact starts) or a rigid one (a mass that comes to rest
  on the wall after a chatter is an accumulation the user system stops at) stay on the
  engine. Not the default yet: the user-system event loop can spin in its missed-root search
  on a slow quasi-static creep (the tape drive of ``TapeDrive(clearance=200e-6)``, whose
  period is 3.2e4 time units), where the engine takes 0.1 s.

Its free parameters are none (``names = ()``, ``dp`` has no columns): the continuation's
map problem is the built-in map with parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..engine._driver import initial_mode
from ._common import advanced, check_base, oscillator_of, periods_in, section_offset
from ._map import ImageAndResidual
from .hybrid_map import HybridMap
from .tangent import check_backend, held_by_static_friction, tangent_run

__all__ = ["OscillatorMap", "OscillatorMapValue"]


@dataclass(frozen=True, eq=False)
class OscillatorMapValue(ImageAndResidual):
    """``P^n(z)`` of a built-in member with ``dP/dz``, or why not (a :class:`~._map.MapValue`)."""

    z: np.ndarray
    params: tuple
    image: np.ndarray | None  #: ``P^n(z)`` (None when the run failed)
    monodromy: np.ndarray  #: ``dP^n/dz`` (2x2, NaN when singular)
    dp: np.ndarray  #: no columns: the map has no free parameters
    signature: tuple  #: ``(guard, kind)`` (engine) or ``(guard, mode before, mode after)`` (user system)
    failure: str = ""
    singular: str = ""
    collapsed: bool = False  #: a stick or chatter annihilated a direction: one multiplier is exactly 0
    recorder: Any = None  #: the engine's :class:`~.tangent.TangentRecorder` (None on the user-system route)
    hybrid: Any = None  #: the :class:`~impactosc.dynamics.HybridMapValue` of the user-system route



class OscillatorMap:
    """The stroboscopic map of a built-in member over ``n`` forcing periods (module docstring).

    Parameters
    ----------
    base : Oscillator or TapeDrive
    n : int
        Forcing periods per map (``period``: the same given as a time).
    period : float, optional
        A whole multiple of the forcing period, instead of ``n``.
    phase : float, optional
        Forcing phase ``Omega t + phase`` of the section (default: the phase at ``t = 0``).
    t0 : float, optional
        The section as a time instead of a phase (default 0; not with ``phase``).
    backend : {"heyoka", "scipy", "exact"}
        ``**options`` are its options (``tol`` for heyoka).
    user_system : bool
        With ``backend="heyoka"``: evaluate the member written as a user system through
        :class:`~impactosc.dynamics.HybridMap` where that expresses it (module docstring).

    Examples
    --------
    >>> import impactosc
    >>> from impactosc.dynamics import OscillatorMap
    >>> pmap = OscillatorMap(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), 3, backend="exact")
    >>> value = pmap.evaluate([0.95, 0.0])
    >>> value.ok, value.monodromy.shape, pmap.state_names
    (True, (2, 2), ('X', 'V'))
    """

    state_names = ("X", "V")
    names: tuple[str, ...] = ()

    def __init__(self, base, n: int = 1, *, period: float | None = None, phase: float | None = None,
                 t0: float | None = None, backend: str = "heyoka", user_system: bool = False, **options):
        check_base(base)
        osc = oscillator_of(base)
        self.model = osc
        self.n, self.span = periods_in(osc, period, n)
        if phase is not None and t0 is not None:
            raise ValueError(f"give the section as phase or as t0, not both (got phase={phase!r}, t0={t0!r})")
        self.t0 = float(t0) if t0 is not None else section_offset(osc, phase)
        #: The member seen from the section: its run from time 0 is one map.
        self.section_model = advanced(osc, self.t0)
        check_backend(self.section_model, backend, options)
        self.backend, self.options = backend, dict(options)
        if user_system and backend != "heyoka":
            raise ValueError(f"user_system=True runs the member on heyoka as a user system; backend must be 'heyoka', "
                             f"got {backend!r}")
        self.hybrid = self._hybrid_map() if user_system else None

    def _hybrid_map(self) -> HybridMap | None:
        """The member's user-system map where it expresses the member (module docstring), else None."""
        from ..model.hybrid import oscillator_system

        sec = self.section_model
        if sec.rigid or not sec.linear or sec.Omega <= 0.0:
            return None
        iterates = self.span / (2.0 * math.pi / sec.Omega)
        if abs(iterates - round(iterates)) > 1e-9 * iterates:
            return None
        kwargs = {"tol": self.options["tol"]} if "tol" in self.options else {}
        return HybridMap(oscillator_system(sec), int(round(iterates)), names=(), **kwargs)

    @property
    def route(self) -> str:
        """What evaluates the map: ``"user system"`` (heyoka through :class:`HybridMap`) or ``"engine"``."""
        return "user system" if self.hybrid is not None else "engine"

    def values(self) -> tuple:
        """No free parameters: ``()``."""
        return ()

    def period(self, params=None) -> float:
        """The time of one map: ``n`` forcing periods."""
        return self.span

    def with_names(self, names) -> OscillatorMap:
        """This map (it has no free parameters; the continuation's map problem has them)."""
        if tuple(names):
            raise ValueError(f"names must be empty: the built-in stroboscopic map has no free parameters (got "
                             f"{tuple(names)!r}); the continuation (impactosc.dynamics.continuation) differentiates "
                             "in the model's parameters")
        return self

    def project(self, z) -> np.ndarray:
        """``z`` with ``X`` moved onto a rigid wall it lies beyond (no state lies there)."""
        sec = self.section_model
        z = np.array(z, dtype=float)
        if sec.rigid:
            z[0] = min(max(z[0], -sec.gap(-1)), sec.gap(1))
        return z

    def evaluate(self, z, params=None, *, record: str = "stats") -> OscillatorMapValue:
        """``P^n(z)`` with ``dP^n/dz`` (``params``: none); a failed run gives ``image = None`` and ``failure``.

        ``record``: what the engine's recorder keeps (``"events"`` for its events).
        """
        z = np.asarray(z, dtype=float).ravel()
        nan2, none = np.full((2, 2), math.nan), np.zeros((2, 0))
        sec = self.section_model
        if z.size != 2 or not np.all(np.isfinite(z)):
            return OscillatorMapValue(z, (), None, nan2, none, (), f"z must be two finite numbers (X, V), got {z}")
        if sec.rigid and not -sec.gap(-1) <= z[0] <= sec.gap(1):
            return OscillatorMapValue(z, (), None, nan2, none, (), f"X = {z[0]!r} lies beyond a rigid flange (at "
                                      f"{-sec.gap(-1)!r} and {sec.gap(1)!r})")
        if self.hybrid is not None:
            return self._through_hybrid(self.hybrid, z)
        try:
            sol, rec = tangent_run(sec, self.span, float(z[0]), float(z[1]), backend=self.backend,
                                   options=self.options, record=record, keep_saltations=True)
        except ValueError as exc:  # a Newton trial that simulate would refuse (e.g. a speed that overflows)
            return OscillatorMapValue(z, (), None, nan2, none, (), str(exc))
        signature = tuple((s.guard, s.kind) for s in rec.saltations if s.kind is not None)
        if sol.status != 0:
            return OscillatorMapValue(z, (), None, nan2, none, signature, sol.message, recorder=rec)
        image = np.array([sol.x_final, sol.v_final])
        if rec.singular is not None:
            return OscillatorMapValue(z, (), image, nan2, none, signature, "", rec.singular.reason,
                                      bool(rec.collapsed), rec)
        M = np.array(rec.jacobian, dtype=float).reshape(2, 2)
        return OscillatorMapValue(z, (), image, M, none, signature, "", "", bool(rec.collapsed), rec)

    def _through_hybrid(self, hmap: HybridMap, z: np.ndarray) -> OscillatorMapValue:
        """The heyoka route: the member's user-system map, with the built-in rule's held start."""
        sec = self.section_model
        value = hmap.evaluate(z)
        none = np.zeros((2, 0))
        # a stick (into a stuck mode of stick_slip, named "<region>0") zeroes the V row, as in the engine
        collapsed = any(after.endswith("0") and not before.endswith("0") for _, before, after in value.signature)
        if initial_mode(sec, 0.0, float(z[0]), float(z[1])).motion == 0:
            # a start at rest in the stick band: the V direction is annihilated at once (the engine's rule)
            collapsed = True
            held = held_by_static_friction(sec, 0.0, float(z[0]))
            if held is not None:
                return OscillatorMapValue(z, (), value.image, np.full((2, 2), math.nan), none, value.signature,
                                          value.failure, held.reason, True, hybrid=value)
        return OscillatorMapValue(z, (), value.image, value.monodromy, none, value.signature, value.failure,
                                  value.singular, bool(collapsed), hybrid=value)
