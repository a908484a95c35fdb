"""Tangent dynamics of the hybrid flow: the Jacobian of a run, piece by piece and event by event.

:class:`TangentRecorder` is a ``impactosc.solution._Recorder`` that the engine's driver
loop (:func:`impactosc.engine.drive`), or the replay of a heyoka run, feeds like any other: it
multiplies the Jacobian of the
run so far by the state-transition matrix of every smooth piece (:mod:`.flow`) and by the
saltation matrix of every transition (:mod:`.saltation`), internal ones included. At the end
(or at every sample time) it holds ``d(X, V)(t) / d(X0, V0)``.

:func:`tangent_run` runs a member with that recorder through the one dispatch of the toolkit's
recorders, :func:`drive_recorder`: the engine's driver loop steps the piece stepper of ``scipy``
and ``exact`` (built here the way each backend's ``run`` builds it, :func:`piece_stepper`);
``heyoka`` runs its one event loop and replays the run into the recorder with the calls the
driver loop would make. The backend has validated the model and the options through
:func:`impactosc.simulate` before (``check_backend``).
"""

from __future__ import annotations

import math

from .._util import validation as _v
from ..backends._simulate import DEFAULT_MAX_EVENTS, check_cost, check_magnitudes, simulate
from ..engine._driver import CHATTER, IMPACT, REVERSAL, STICK, Mode, check_run_arguments, check_sample_times, drive
from ..model import _rule
from ..model._oscillator import Oscillator
from ..results._solution import Solution, _Recorder
from .flow import IDENTITY, matmul, transition_matrix
from .saltation import Saltation, saltation_matrix

__all__ = ["TangentRecorder", "tangent_run", "piece_stepper", "evaluator_of", "drive_recorder",
           "held_by_static_friction", "check_start", "TANGENT_BACKENDS"]

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
        The first point met where no Jacobian exists: a tangential crossing (no saltation
        matrix) or a start at rest held by static friction alone (``held_start``); its
        ``reason`` says which, in words.
    held_start : Saltation or None
        The start at rest held by static friction alone (:func:`held_by_static_friction`).
    tangential : Saltation or None
        The first guard crossed tangentially (a grazing impact, ...).
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
        #: The singular "transition" of a start at rest held by static friction alone, or None.
        self.held_start: Saltation | None = None
        #: The first guard crossed tangentially, or None.
        self.tangential: Saltation | None = None
        self._impact_side = 0  # wall of the last impact while a sequence of impacts goes on, else 0
        self._pending: Saltation | None = None  # a slow impact inside such a sequence

    def begin(self, osc: Oscillator, t: float, x: float, v: float, mode: Mode) -> None:
        super().begin(osc, t, x, v, mode)
        self.jacobian = IDENTITY
        self.held_start = None
        if mode.motion == 0:
            # A start at rest inside the kinetic stick band |f_net| <= beta: a small initial
            # velocity dies out at once (the mass slips O(dV^2) and sticks), so the map does not
            # depend on V0.
            self.jacobian = _COLLAPSE
            self.collapsed = True
            if osc.rigid and mode.region != 0:
                # At rest on a rigid wall that the net force pushes it into: a perturbation off the wall
                # (the only one there is) falls back and comes to rest on it again after impacts that
                # accumulate in a time ~ sqrt(perturbation), before anything else happens: the map is
                # locally constant, its Jacobian zero (as after a chatter), not the identity in X.
                self.jacobian = _ZERO
            self.held_start = held_by_static_friction(osc, t, x)
            if self.held_start is not None:
                self.singular = self.held_start

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
        side = 1 if x_after > 0.0 else -1
        if kind == IMPACT and sal.singular and self._impact_side == side:
            # A slow impact after an impact on the same wall: a member of a chatter sequence,
            # whose jump (:meth:`chatter`) will make the map locally constant. Singular only if
            # the sequence ends otherwise.
            self._pending = self._pending or sal
        elif sal.singular:
            self._tangential(sal)
        if kind == IMPACT:
            self._impact_side = side
        elif kind is not None and kind != REVERSAL:
            self._impact_side = 0
            self._commit_pending()
        if sal.det == 0.0 or kind == STICK:
            self.collapsed = True
        self.jacobian = matmul(sal.matrix, self.jacobian)
        self._state = (t, x_after, v_after)

    def chatter(self, jump, t):
        # Infinitely many impacts end at rest on the wall at a time set by the impacts, after
        # which the release from the wall depends on the forcing alone: the map is locally
        # constant, its Jacobian zero.
        state = super().chatter(jump, t)
        self._pending = None  # the slow impacts of the sequence end in the jump: no singularity
        self._impact_side = 0
        self.jacobian = _ZERO
        self.collapsed = True
        if self.keep_saltations:
            self.saltations.append(Saltation(jump.t_inf, CHATTER, CHATTER, _ZERO, 0.0, False))
        return state

    def finish(self, t: float, x: float, v: float, mode: Mode, status: int, message: str) -> None:
        self._commit_pending()
        super().finish(t, x, v, mode, status, message)

    def _tangential(self, sal: Saltation) -> None:
        if self.tangential is None:
            self.tangential = sal
            if self.singular is None:
                self.singular = sal

    def _commit_pending(self) -> None:
        if self._pending is not None:
            self._tangential(self._pending)
            self._pending = None

    def sample(self, t: float, x: float, v: float, mode: Mode) -> None:
        super().sample(t, x, v, mode)
        if self.on_sample is not None:
            self.jacobian = self.on_sample(self, t, x, v, self.jacobian)


def held_by_static_friction(osc: Oscillator, t: float, x: float) -> Saltation | None:
    """Why the map from a state at rest at ``(t, x)`` has no Jacobian, or None if it has one.

    A mass at rest with ``beta < |f_net| <= beta_static`` is held by static friction alone:
    with ``V0 = 0`` exactly it stays, but any velocity along ``f_net``, however small, makes
    it slide against the kinetic level ``beta < |f_net|`` and accelerate away (a
    velocity of 1e-12 moved the mass by 0.255 in one period). The map is discontinuous in
    ``V0`` there. Against a rigid wall only the pull away from it counts (a push into the
    wall brings the mass back). A *stick* event in that band is different: every
    neighbouring trajectory reaches ``V = 0`` at a nearby point and sticks too, so the
    saltation matrix of the stick exists; only a start at rest is singular.
    """
    f = osc._net_force_scalar(t, x)
    tie = _rule.tie_tolerance(osc._p, float(t), float(x), f)
    pull = abs(f)
    side = 1 if x > 0.0 else -1
    if osc.rigid and side * x >= osc.gap(side):
        pull = -side * f  # the force away from the wall the mass rests on
    if not pull > osc.beta + tie:
        return None
    nan = float("nan")
    reason = (f"the start at rest (X = {x!r}, V = 0, t = {t!r}) is held by static friction alone: "
              f"beta = {osc.beta!r} < |f_net| = {pull!r} <= beta_static = {osc.beta_s!r}, so any velocity along "
              "f_net makes the mass slide away and the map is not differentiable (it jumps) in V there")
    return Saltation(t, "static_friction", None, (nan, nan, nan, nan), nan, True, reason)


def piece_stepper(backend: str, osc: Oscillator, options: dict):
    """``(stepper, evaluator)`` of the engine's ``drive`` on ``backend`` for ``osc``, as its ``run`` builds them.

    The backends whose runs the engine's driver loop steps piece by piece: ``"scipy"`` and
    ``"exact"``. ``"heyoka"`` runs on its own event loop (:func:`drive_recorder` replays it);
    ``"rk4"`` locates no events. To be replaced by a public constructor in each backend
    (``backends.<name>.stepper``) once the engine offers one; until then this mirrors their
    ``run`` functions.
    """
    if backend == "scipy":
        from ..backends import scipy as sb

        stepper = sb._Stepper(osc, options.get("method", sb.DEFAULT_METHOD), options.get("rtol", sb.DEFAULT_RTOL),
                              options.get("atol", sb.DEFAULT_ATOL))
        return stepper, stepper.evaluate
    if backend == "exact":
        from ..backends import exact as eb

        return eb._Stepper(osc), eb._Stepper(osc).evaluate
    if backend == "heyoka":
        raise ValueError("backend='heyoka' has no piece stepper: its runs are one event loop, replayed into a recorder "
                         "by drive_recorder")
    raise ValueError(f"backend must be one of {', '.join(map(repr, TANGENT_BACKENDS))} for the tangent dynamics "
                     f"(the rk4 baseline locates no events), got {backend!r}")


def evaluator_of(backend: str, osc: Oscillator, options: dict):
    """The dense output ``(mode, t0, x, v, times) -> (X, V, impulse)`` of a recorder of ``backend``'s runs of ``osc``.

    What a recorder hands to its :class:`~impactosc.Solution` (``sample``, ``evaluate``) and
    the continuation's quadratures read: the heyoka run's integrator at its tolerance
    (``options["tol"]``, checked as :func:`impactosc.simulate` checks it), the piece stepper's
    of the other backends (:func:`piece_stepper`).
    """
    if backend == "heyoka":
        from ..backends.heyoka import DEFAULT_TOL, check_tol
        from ..backends.heyoka._replay import _Evaluator

        return _Evaluator(osc, check_tol(options.get("tol", DEFAULT_TOL)))
    return piece_stepper(backend, osc, options)[1]


def drive_recorder(backend: str, osc: Oscillator, t_end: float, x0: float, v0: float, rec, max_events: int,
                   stops=(), options: dict | None = None) -> None:
    """Run ``osc`` from ``(x0, v0)`` at time 0 to ``t_end`` on ``backend`` and feed the engine recorder ``rec``.

    The one dispatch of the dynamics toolkit's runs with a recorder of its own (the tangent
    dynamics, the continuation's sensitivities, the contact onset's watch). ``"scipy"`` and
    ``"exact"``: the engine's driver loop (:func:`impactosc.engine.drive`) steps their piece
    stepper. ``"heyoka"``: its one event loop runs the member and its run is replayed into
    ``rec`` with the same calls in the same order
    (:func:`impactosc.backends.heyoka._replay.drive_on_hybrid_loop`), ``options["tol"]`` its
    tolerance. ``stops`` are the sample times (sorted, :func:`impactosc.engine.check_sample_times`).
    """
    options = options or {}
    if backend == "heyoka":
        from ..backends.heyoka import DEFAULT_TOL, check_tol
        from ..backends.heyoka._replay import drive_on_hybrid_loop

        drive_on_hybrid_loop(osc, t_end, x0, v0, rec, max_events=max_events, sample_at=stops,
                             tol=check_tol(options.get("tol", DEFAULT_TOL)))
        return
    stepper, _ = piece_stepper(backend, osc, options)
    drive(stepper, osc, t_end, x0, v0, rec, max_events, stops)


def check_backend(osc: Oscillator, backend: str, options: dict) -> None:
    """Let ``backend`` refuse ``osc`` or ``options`` exactly as :func:`impactosc.simulate` would."""
    if backend not in TANGENT_BACKENDS:
        piece_stepper(backend, osc, options)  # raises the ValueError
    simulate(osc, 1e-9, 0.0, 0.0, backend=backend, record="stats", **options)


def check_start(osc: Oscillator, t_end: float, x0, v0, *, names: tuple[str, str] = ("x0", "v0")):
    """``(x0, v0)`` as floats, refused exactly as :func:`impactosc.simulate` refuses them.

    The same checks in the same order (:func:`impactosc.engine.check_run_arguments`, then
    :func:`impactosc.backends._simulate.check_magnitudes` over ``t_end``), so a dynamics
    tool fails where ``simulate`` would, with the same message: a finite real start, inside
    the walls of a rigid flange, whose run cannot overflow. ``names`` are the caller's
    names of the two values (e.g. ``guess[0]``), put in the message where they differ.
    """
    x0, v0 = _v.real(names[0], x0), _v.real(names[1], v0)
    try:
        check_run_arguments(osc, t_end, x0, v0, 1)
        check_magnitudes(osc, t_end, x0, v0)
    except ValueError as exc:
        if names == ("x0", "v0"):
            raise
        raise ValueError(f"{names[0]}, {names[1]} = {x0!r}, {v0!r} (the start, checked as simulate's x0, v0): "
                         f"{exc}") from None
    return x0, v0


def tangent_run(osc: Oscillator, t_end: float, x0: float, v0: float, *, backend: str = "heyoka",
                options: dict | None = None, record: str = "stats", sample_at=(), on_sample=None,
                keep_saltations: bool = False, max_events: int = DEFAULT_MAX_EVENTS):
    """Run ``osc`` from ``(x0, v0)`` at time 0 to ``t_end`` and follow its Jacobian.

    ``options`` are the backend's (``tol``, ``rtol``, ...), already validated by
    ``check_backend``; ``t_end``, ``x0``, ``v0`` and ``sample_at`` are checked here as
    :func:`impactosc.simulate` checks them (:func:`check_start`: a ``ValueError`` or
    ``TypeError`` naming the argument). ``on_sample(recorder, t, x, v, jacobian) -> jacobian`` is called
    at every ``sample_at`` time (sorted, in ``[0, t_end]``): the Lyapunov renormalisation.

    Returns
    -------
    (Solution, TangentRecorder)

    Examples
    --------
    The Jacobian ``d(X, V)(30) / d(X0, V0)`` of a run with soft flanges (contacts and reversals
    inside them), on heyoka's one event loop and on the closed-form backend:

    >>> from impactosc import Oscillator
    >>> from impactosc.dynamics.tangent import tangent_run
    >>> osc = Oscillator(0.8, 1.3, 0.05, 10.0)
    >>> for backend in ("heyoka", "exact"):
    ...     sol, rec = tangent_run(osc, 30.0, 0.5, 0.0, backend=backend)
    ...     print(backend, [round(j, 6) for j in rec.jacobian], sol.counts["contact_start"])
    heyoka [0.649155, -0.152402, -0.546495, 0.975503] 11
    exact [0.649155, -0.152402, -0.546495, 0.975503] 11
    """
    x0, v0 = check_start(osc, t_end, x0, v0)
    check_cost(osc, t_end, backend, options or {})  # simulate's refusal of runs that would take minutes
    stops = check_sample_times(sample_at, t_end)
    options = options or {}
    rec = TangentRecorder(record, backend, evaluator_of(backend, osc, options), keep_saltations=keep_saltations,
                          on_sample=on_sample)
    drive_recorder(backend, osc, t_end, x0, v0, rec, max_events, stops, options)
    return Solution(rec, t_end), rec
