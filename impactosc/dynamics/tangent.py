"""Tangent dynamics of the hybrid flow: the Jacobian of a run, piece by piece and event by event.

:class:`TangentRecorder` is a ``impactosc.solution._Recorder`` that the engine's driver
loop (:func:`impactosc.engine.drive`) feeds like any other: it multiplies the Jacobian of the
run so far by the state-transition matrix of every smooth piece (:mod:`.flow`) and by the
saltation matrix of every transition (:mod:`.saltation`), internal ones included. At the end
(or at every sample time) it holds ``d(X, V)(t) / d(X0, V0)``.

:func:`tangent_run` drives a backend's piece stepper with that recorder. The steppers are
built here the way each backend's ``run`` builds them (see :func:`piece_stepper`), after the
backend has validated the model and the options through :func:`impactosc.simulate`.
"""

from __future__ import annotations

import math

from ..backends._simulate import DEFAULT_MAX_EVENTS, simulate
from ..engine._driver import CHATTER, STICK, Mode, drive
from ..model._oscillator import Oscillator
from ..results._solution import Solution, _Recorder
from .flow import IDENTITY, matmul, transition_matrix
from .saltation import Saltation, saltation_matrix

__all__ = ["TangentRecorder", "tangent_run", "piece_stepper", "TANGENT_BACKENDS"]

#: Backends whose pieces and events the tangent dynamics can follow (rk4 has no events).
TANGENT_BACKENDS = ("heyoka", "scipy", "exact")

_COLLAPSE = (1.0, 0.0, 0.0, 0.0)
_ZERO = (0.0, 0.0, 0.0, 0.0)


class TangentRecorder(_Recorder):
    """A recorder that also accumulates the Jacobian of the flow (see the module docstring).

    Attributes
    ----------
    jacobian : tuple
        ``(a, b, c, d)``: the Jacobian from the start to the last state seen.
    collapsed : bool
        A stick, a stuck start, a chatter or a plastic impact annihilated a direction:
        the Jacobian is singular by the structure of the flow, not by rounding.
    singular : Saltation or None
        The first tangential crossing met (no saltation matrix exists there).
    saltations : list of Saltation
        Every saltation matrix, when ``keep_saltations``.
    slip_time : float
        Time spent slipping (the damping acts only then: Liouville's ``exp(-2 zeta t)``).
    """

    def __init__(self, record: str, backend: str, evaluator, *, keep_saltations: bool = False,
                 on_sample=None):
        super().__init__(record, backend, evaluator)
        self.jacobian = IDENTITY
        self.collapsed = False
        self.singular: Saltation | None = None
        self.keep_saltations = keep_saltations
        self.saltations: list[Saltation] = []
        self.slip_time = 0.0
        self.on_sample = on_sample
        self._state: tuple[float, float, float] | None = None  # (t, x, v) at the start of the next piece

    def begin(self, osc: Oscillator, t: float, x: float, v: float, mode: Mode) -> None:
        super().begin(osc, t, x, v, mode)
        self.jacobian = IDENTITY
        if mode.motion == 0:
            # A start at rest inside the stick band: a small initial velocity dies out at once
            # (the mass slips O(dV^2) and sticks), so the map does not depend on V0.
            self.jacobian = _COLLAPSE
            self.collapsed = True

    def segment(self, t: float, x: float, v: float, mode: Mode) -> None:
        super().segment(t, x, v, mode)
        self._state = (t, x, v)

    def piece(self, mode: Mode, t0: float, x0: float, t1: float, x1: float,
              q: float, q2: float, w: float, vv: float, steps: int) -> None:
        super().piece(mode, t0, x0, t1, x1, q, q2, w, vv, steps)
        if mode.motion != 0 and t1 > t0:
            self.slip_time += t1 - t0
            v0 = self._state[2] if self._state is not None else math.nan
            self.jacobian = matmul(transition_matrix(self.osc, mode, t0, x0, v0, t1), self.jacobian)

    def on_transition(self, t, mode_before, guard, mode_after, x_before, v_before, x_after, v_after, kind):
        if guard is None:  # a chatter jump: :meth:`chatter` zeroes the Jacobian
            self._state = (t, x_after, v_after)
            return
        sal = saltation_matrix(self.osc, t, mode_before, guard, mode_after, x_before, v_before,
                               x_after, v_after, kind)
        if self.keep_saltations:
            self.saltations.append(sal)
        if sal.singular and self.singular is None:
            self.singular = sal
        if sal.det == 0.0 or kind == STICK:
            self.collapsed = True
        self.jacobian = matmul(sal.matrix, self.jacobian)
        self._state = (t, x_after, v_after)

    def chatter(self, jump, t):
        # Infinitely many impacts end at rest on the wall at a time set by the impacts, after
        # which the release from the wall depends on the forcing alone: the map is locally
        # constant, its Jacobian zero.
        state = super().chatter(jump, t)
        self.jacobian = _ZERO
        self.collapsed = True
        if self.keep_saltations:
            self.saltations.append(Saltation(jump.t_inf, CHATTER, CHATTER, _ZERO, 0.0, False))
        return state

    def sample(self, t: float, x: float, v: float, mode: Mode) -> None:
        super().sample(t, x, v, mode)
        if self.on_sample is not None:
            self.jacobian = self.on_sample(self, t, x, v, self.jacobian)


def piece_stepper(backend: str, osc: Oscillator, options: dict):
    """``(stepper, evaluator)`` of ``backend`` for ``osc``, as that backend's ``run`` builds them.

    To be replaced by a public constructor in each backend (``backends.<name>.stepper``)
    once the engine offers one; until then this mirrors the three ``run`` functions.
    """
    if backend == "heyoka":
        from ..backends import heyoka as hb

        tol = hb.check_tol(options.get("tol", hb.DEFAULT_TOL))
        return hb._Stepper(hb.integrator(tol, hb.shape_of(osc)), osc), hb._Evaluator(osc, tol)
    if backend == "scipy":
        from ..backends import scipy as sb

        stepper = sb._Stepper(osc, options.get("method", sb.DEFAULT_METHOD), options.get("rtol", sb.DEFAULT_RTOL),
                              options.get("atol", sb.DEFAULT_ATOL))
        return stepper, stepper.evaluate
    if backend == "exact":
        from ..backends import exact as eb

        return eb._Stepper(osc), eb._Stepper(osc).evaluate
    raise ValueError(f"backend must be one of {', '.join(map(repr, TANGENT_BACKENDS))} for the tangent dynamics "
                     f"(the rk4 baseline locates no events), got {backend!r}")


def check_backend(osc: Oscillator, backend: str, options: dict) -> None:
    """Let ``backend`` refuse ``osc`` or ``options`` exactly as :func:`impactosc.simulate` would."""
    if backend not in TANGENT_BACKENDS:
        piece_stepper(backend, osc, options)  # raises the ValueError
    simulate(osc, 1e-9, 0.0, 0.0, backend=backend, record="stats", **options)


def tangent_run(osc: Oscillator, t_end: float, x0: float, v0: float, *, backend: str = "heyoka",
                options: dict | None = None, record: str = "stats", sample_at=(), on_sample=None,
                keep_saltations: bool = False, max_events: int = DEFAULT_MAX_EVENTS):
    """Run ``osc`` from ``(x0, v0)`` at time 0 to ``t_end`` and follow its Jacobian.

    ``options`` are the backend's (``tol``, ``rtol``, ...), already validated by
    ``check_backend``. ``on_sample(recorder, t, x, v, jacobian) -> jacobian`` is called
    at every ``sample_at`` time (sorted, in ``[0, t_end]``): the Lyapunov renormalisation.

    Returns
    -------
    (Solution, TangentRecorder)
    """
    stepper, evaluator = piece_stepper(backend, osc, options or {})
    rec = TangentRecorder(record, backend, evaluator, keep_saltations=keep_saltations, on_sample=on_sample)
    drive(stepper, osc, t_end, float(x0), float(v0), rec, max_events, tuple(sample_at))
    return Solution(rec, t_end), rec
