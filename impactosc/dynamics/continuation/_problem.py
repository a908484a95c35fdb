"""The problem continuation solves: ``G(z, p) = P^n(z; p) - z = 0`` on a fixed section.

:class:`MapProblem` evaluates the stroboscopic map of the model at a parameter value with
the full Jacobian ``[dP/dz, dP/dp]`` (:mod:`._sensitivity`). The section is a fixed forcing
phase: when a parameter changes ``Omega`` (the frequency itself, or a drive's speed) the
section time moves with it, so that the map stays the map of one forcing cycle; when the
parameter is ``phase`` the section stays at its time.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...backends._simulate import DEFAULT_MAX_EVENTS
from ...model._oscillator import Oscillator
from .._common import advanced, check_parameter, oscillator_of, parameter_value, periods_in, with_parameter
from .._map import ImageAndResidual
from ..saltation import vector_field
from ..tangent import check_backend, drive_recorder, evaluator_of
from ._sensitivity import SensitivityRecorder, Stencil, flange_gap

__all__ = ["MapProblem", "MapEvaluation", "without_flange", "UNSUPPORTED", "BOTH", "MARGIN_TESTS"]

#: ``MapProblem.virtual(BOTH)``: both flanges taken away.
BOTH = 2
#: The built-in family's margins whose zeros are nonsmooth bifurcations: (name of the margin, kind of the point).
MARGIN_TESTS = (("upper_margin", "grazing"), ("lower_margin", "grazing"), ("stick_margin", "stick_onset"))
#: The start of a failure message of a member the problem's backend does not run (the branch stops there).
UNSUPPORTED = "a member the backend does not run"


@dataclass(frozen=True, eq=False)
class MapEvaluation(ImageAndResidual):
    """The map at one ``(z, p)``: ``P^n(z)``, ``dP/dz``, ``dP/dp`` and what the run saw."""

    z: np.ndarray
    params: tuple
    image: np.ndarray | None
    monodromy: np.ndarray
    dp: np.ndarray  #: (2, k): dP/dp_j
    recorder: Any
    failure: str = ""  #: why the run failed ("" when it ran)

    @property
    def singular(self) -> str:
        """Why the map is not differentiable here ("" when it is)."""
        rec = self.recorder
        if rec is None or rec.singular is None:
            return ""
        return rec.singular.reason



class MapProblem:
    """``P^n`` of ``base`` with the named parameters free (:mod:`.continuation`).

    What the follow loop asks of a problem, and a user system's problem
    (:class:`._hybrid_problem.SystemProblem`) answers too: ``names``, ``n``, ``scales``,
    ``dimension`` (the state's length), ``evaluate(z, params)``, ``values()``, ``model(params)``,
    ``period(params)``, ``margin_tests`` (the margins whose zeros are nonsmooth points),
    ``events_in(ev)``, ``limit_events(count)``, ``doubled()``; ``nonsmooth_steps`` says whether it
    crosses grazings and impacts on the section (:mod:`._nonsmooth`; a user system's problem crosses
    the grazings of its guards, :mod:`._guard_crossing`).

    Parameters
    ----------
    base : Oscillator or TapeDrive
        The model; parameters are its fields (:func:`impactosc.dynamics.parameter_names`).
    names : tuple of str
        The free parameters.
    n : int
        Forcing periods per map.
    section_phase : float
        Forcing phase ``Omega t + phase`` of the section (mod 2 pi).
    backend : str
        ``"exact"``, ``"heyoka"`` or ``"scipy"``; ``options`` are its options.
    """

    #: The length of the state ``z = (X, V)`` on the section.
    dimension = 2
    state_names = ("X", "V")
    #: The margins whose zeros are located as grazings and stick onsets.
    margin_tests = MARGIN_TESTS
    #: The branch crosses grazings and impacts on the section (:mod:`._nonsmooth`).
    nonsmooth_steps = True

    def __init__(self, base, names, n: int, section_phase: float, backend: str, options: dict, scales=None,
                 stripped: int = 0):
        self.base = base
        #: The side (+1 upper, -1 lower) whose flange is taken away (0: none): the *virtual* map of the
        #: contact-free orbits near a grazing of that flange, smooth through the grazing (:mod:`._grazing`).
        self.stripped = int(stripped)
        self.names = tuple(check_parameter(base, name) for name in names)
        self.n = int(n)
        self.section_phase = float(section_phase)
        self.backend = backend
        self.options = dict(options)
        self.scales = tuple(scales) if scales is not None else tuple(
            max(abs(parameter_value(base, name)), 1e-3) for name in self.names)
        #: Events a map evaluation may take before it counts as failed (see :meth:`limit_events`).
        self.max_events = DEFAULT_MAX_EVENTS
        self.orbit_events = 0
        base_osc = oscillator_of(base)
        #: Rigid flanges: no state beyond them (the corrector keeps its iterates on the walls).
        self.rigid = base_osc.rigid
        #: Distances of the lower and the upper flange from X = 0 (inf: absent).
        self.flange_gaps = (flange_gap(base_osc, -1), flange_gap(base_osc, 1))
        #: The walls the corrector keeps its iterates within (a stripped flange is no wall).
        self.walls = tuple(math.inf if self.stripped in (side, BOTH) else gap
                           for side, gap in zip((-1, 1), self.flange_gaps, strict=True))
        # The section time of the base, kept when the parameter is the phase itself.
        self._t_section = self._section_time(base_osc)
        check_backend(self.section(self.values(base)), backend, self.options)

    # -- the model at a parameter value ------------------------------------------------
    def values(self, base=None) -> tuple:
        """The free parameters' values in ``base`` (default: the problem's base)."""
        base = self.base if base is None else base
        return tuple(parameter_value(base, name) for name in self.names)

    def model(self, params):
        """The base with the free parameters set to ``params`` (Oscillator or TapeDrive)."""
        m = self.base
        for name, value in zip(self.names, params, strict=True):
            m = with_parameter(m, name, float(value))
        return m

    def _section_time(self, osc: Oscillator) -> float:
        if osc.F == 0.0 or osc.Omega == 0.0:
            return 0.0
        return ((self.section_phase - osc.phase) % (2.0 * math.pi)) / osc.Omega

    def section(self, params) -> Oscillator:
        """The model at ``params`` seen from its section (a run from time 0 is one map)."""
        if isinstance(self.base, Oscillator) and "phase" not in self.names:
            return self._oscillator_section(params)
        osc = oscillator_of(self.model(params))
        if self.stripped:
            osc = without_flange(osc, self.stripped)
        if "phase" in self.names:
            return advanced(osc, self._t_section)
        return advanced(osc, self._section_time(osc))

    def _oscillator_section(self, params) -> Oscillator:
        """:meth:`section` of an Oscillator base in one construction (the same member, validated once).

        The parameters, the flange taken away and the forcing phases advanced to the section
        are one ``dataclasses.replace``: an evaluation builds a dozen members (the parameter
        stencils), and each construction validates every field.
        """
        base = self.base
        changes: dict[str, Any] = {name: float(value) for name, value in zip(self.names, params, strict=True)}
        if self.stripped:
            changes.update(stripped_fields(base, self.stripped))
        F, Omega = changes.get("F", base.F), changes.get("Omega", base.Omega)
        if F != 0.0 and Omega != 0.0:
            t = ((self.section_phase - base.phase) % (2.0 * math.pi)) / Omega
            if t != 0.0:
                two_pi = 2.0 * math.pi
                changes["phase"] = math.fmod(base.phase + Omega * t, two_pi)
                changes["harmonics"] = tuple((Fi, Om, math.fmod(ph + Om * t, two_pi)) for Fi, Om, ph in base.harmonics)
        return dataclasses.replace(base, **changes)

    def span(self, osc: Oscillator) -> float:
        return periods_in(osc, None, self.n)[1]

    def period(self, params) -> float:
        """The time one map takes at ``params`` (``n`` forcing periods)."""
        return self.span(self.section(params))

    @staticmethod
    def events_in(ev: MapEvaluation) -> int:
        """The events of one map evaluation's run."""
        return int(ev.recorder.n_events)

    def doubled(self) -> MapProblem:
        """The same problem over twice the periods (the branch born at a period doubling)."""
        double = MapProblem(self.base, self.names, 2 * self.n, self.section_phase, self.backend, self.options,
                            self.scales)
        if self.orbit_events:
            double.limit_events(2 * self.orbit_events)
        return double

    # -- the map -------------------------------------------------------------------------
    def evaluate(self, z, params, record: str = "events") -> MapEvaluation:
        """``P^n(z; params)`` with its Jacobians; a failed run gives ``image = None`` and ``failure``."""
        z = np.asarray(z, dtype=float)
        params = tuple(float(p) for p in params)
        k = len(self.names)
        nan2 = np.full((2, 2), math.nan)
        try:
            sec = self.section(params)
        except ValueError as exc:
            return MapEvaluation(z, params, None, nan2, np.full((2, k), math.nan), None, str(exc))
        unsupported = self.unsupported(sec)
        if unsupported:
            return MapEvaluation(z, params, None, nan2, np.full((2, k), math.nan), None, unsupported)
        if not (math.isfinite(z[0]) and math.isfinite(z[1])):
            return MapEvaluation(z, params, None, nan2, np.full((2, k), math.nan), None, f"state {z} is not finite")
        if sec.rigid and not -flange_gap(sec, -1) <= z[0] <= flange_gap(sec, 1):
            return MapEvaluation(z, params, None, nan2, np.full((2, k), math.nan), None,
                                 f"X = {z[0]!r} lies beyond a rigid flange")
        stencils = [self._stencil(params, j) for j in range(k)]
        span = self.span(sec)

        try:
            rec = SensitivityRecorder(record, self.backend, evaluator_of(self.backend, sec, self.options), stencils)
            drive_recorder(self.backend, sec, span, float(z[0]), float(z[1]), rec, self.max_events, (), self.options)
        except (ValueError, FloatingPointError) as exc:
            return MapEvaluation(z, params, None, nan2, np.full((2, k), math.nan), None, str(exc))
        if rec.status != 0:
            message = rec.message
            if rec.n_events >= self.max_events:
                message = (f"the map took more than {self.max_events} events (an orbit of the branch takes "
                           f"{self.orbit_events}): this state is far from the branch's orbits")
            return MapEvaluation(z, params, None, nan2, np.full((2, k), math.nan), rec, message)
        image = np.array([rec.x_final, rec.v_final])
        if rec.singular is not None:
            return MapEvaluation(z, params, image, nan2, np.full((2, k), math.nan), rec)
        M = np.array(rec.jacobian, dtype=float).reshape(2, 2)
        dp = rec.sigma.copy()
        fx, fv = vector_field(sec, span, rec.x_final, rec.v_final, rec.final_mode)
        for j, stencil in enumerate(stencils):
            dT = stencil.derivative(self.span)
            if dT != 0.0:
                dp[:, j] += np.array([fx, fv]) * dT
        return MapEvaluation(z, params, image, M, dp, rec)

    def unsupported(self, sec: Oscillator) -> str:
        """Why the problem's backend cannot run the member ``sec`` ("" when it can).

        The backend is checked against the base once, at the start; a parameter such as the
        flange's ``exponent`` can carry the branch to members it does not run (the exact
        backend runs linear members only), and every evaluation must then stop, not run the
        member as if it were another.
        """
        if self.backend == "exact" and not sec.linear:
            return (f"{UNSUPPORTED}: the exact backend runs linear members only, and this one has a power-law "
                    f"flange (exponent = {sec.exponent!r}); continue with backend='heyoka' or backend='scipy'")
        return ""

    def limit_events(self, orbit_events: int) -> None:
        """Let a map evaluation take at most ``max(5000, 20 * orbit_events)`` events.

        A Newton iterate far from the branch can start a motion with orders of magnitude more
        events than the orbits followed (a tape drive that creeps in stick-slip along a flange
        has ~1e5 per period where the contact-free orbit has a few hundred): such an iterate
        fails fast instead, and the step is shortened.
        """
        self.orbit_events = int(orbit_events)
        self.max_events = max(5000, 20 * self.orbit_events)

    def _stencil(self, params, j: int) -> Stencil:
        def family(value):
            q = list(params)
            q[j] = value
            return self.section(q)

        return Stencil(family, params[j], self.scales[j])

    def with_names(self, names, scales=None) -> MapProblem:
        """The same problem with other free parameters."""
        return MapProblem(self.base, names, self.n, self.section_phase, self.backend, self.options, scales,
                          self.stripped)

    def virtual(self, side: int) -> MapProblem:
        """The same problem with the flange on ``side`` taken away (contact-free orbits past its grazing).

        ``side = 0`` gives the problem with every flange back (the real model), ``side = BOTH``
        the one without flanges (an orbit that grazes both at once, the symmetric guide's).
        """
        out = copy.copy(self)
        out.stripped = int(side)
        out.walls = tuple(math.inf if side in (s, BOTH) else w for s, w in zip((-1, 1), self.flange_gaps, strict=True))
        return out

    def at_phase(self, section_phase: float) -> MapProblem:
        """The same problem on the section at another forcing phase (the phase of an impact, say)."""
        out = copy.copy(self)
        out.section_phase = float(section_phase)
        out._t_section = out._section_time(oscillator_of(self.base))
        return out


def without_flange(osc: Oscillator, side: int) -> Oscillator:
    """``osc`` with the flange on ``side`` taken away (its other flange, if any, kept as it is)."""
    return dataclasses.replace(osc, **stripped_fields(osc, side))


def stripped_fields(osc: Oscillator, side: int) -> dict[str, Any]:
    """The fields that take the flange on ``side`` away from ``osc`` (:func:`without_flange`)."""
    if side == BOTH:
        return {"gap_upper": math.inf, "gap_lower": math.inf, "flange": "spring", "restitution": 1.0, "exponent": 1.0,
                "K": None}
    fields: dict[str, Any] = {"gap_upper" if side > 0 else "gap_lower": math.inf}
    if math.isinf(osc.gap(-side)):  # no flange left: the flange law's fields go back to their defaults
        fields.update(flange="spring", restitution=1.0, exponent=1.0, K=None)
    return fields
