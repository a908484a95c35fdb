"""Contact onset: the parameter value at which the steady state first touches a flange (the grazing boundary).

The **contact margin** of a steady state is a continuous function of the parameters whose
sign says whether the motion touches a flange:

* no contact: ``max |X| - 1 < 0`` over the recorded periods. It is exact, not sampled: every
  smooth piece is monotonic in ``X`` (each turning point is an event), so the maximum is at
  an event, at the start of the window or at its end;
* a spring flange in contact: the deepest penetration ``max |X| - 1 >= 0`` (the same formula);
* a rigid flange in contact: the largest impact speed ``max |V_impact| >= 0``, which tends to
  0 at grazing like the square root of the distance to the boundary.

:func:`contact_onset` follows one branch of periodic orbits with
:func:`~impactosc.dynamics.continuation.continuation` (the orbit the user gives, or the one
a stated transient reaches) to the grazing at which it first touches a flange, and says
whether that orbit is stable there; ``method="transient"`` instead brackets a sign change of
the margin of the steady states that transients reach and refines it by regula falsi (the
search of earlier versions). :func:`onset_chart` does that at every
point of a 2-D grid of two other parameters, in parallel: for a :class:`~impactosc.TapeDrive`
the design chart of critical clearance (or run-out) against speed and tension, in SI units.

Closed forms to check against: the Den Hartog (1931) non-stop steady state of the forced
Coulomb oscillator has the amplitude
``A = sqrt((F/(1 - Omega^2))^2 - (beta tan(pi/(2 Omega)) / Omega)^2)``, so it reaches the
flange at ``F_c = |1 - Omega^2| sqrt(1 + (beta tan(pi/(2 Omega)) / Omega)^2)``
(:mod:`.closed_form`); in the quasi-static limit
``Omega -> 0`` the mass creeps at ``F cos - beta`` and touches when ``F - beta = 1``, i.e. the
tape touches the flange when the run-out exceeds the clearance plus the friction deflection
``mu N / k``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .._util import validation as _v
from ..backends._simulate import DEFAULT_MAX_EVENTS, simulate
from ..engine._driver import CHATTER, CONTACT_START, IMPACT
from ..model._oscillator import Oscillator
from ..results._solution import Solution, _Recorder
from ._common import (
    advanced,
    check_base,
    check_study_parameter,
    flange_clearance,
    forcing_period,
    oscillator_of,
    with_parameter,
)
from .tangent import check_backend, check_start, drive_recorder, evaluator_of

__all__ = ["ContactOnset", "contact_margin", "contact_onset"]


# -- the margin --------------------------------------------------------------------------
class _Touched(Exception):
    """Raised by :class:`_ContactWatch` at the first contact inside the window."""


class _ContactWatch(_Recorder):
    """Records events; stops the run at the first contact after ``t_start`` (``stop_at_contact``)."""

    def __init__(self, backend, evaluator, t_start: float):
        super().__init__("events", backend, evaluator)
        self.t_start = t_start

    def event(self, t, kind, x, v, side, count=1, direction=0):
        super().event(t, kind, x, v, side, count, direction)
        if t >= self.t_start and kind in (CONTACT_START, IMPACT, CHATTER):
            raise _Touched


def _margin(osc, x0, v0, cycle0, transient_periods, record_periods, backend, options,
            stop_at_contact: bool = False) -> tuple[float, float, float, float]:
    """``(margin, x_final, v_final, cycle_final)`` of the steady state reached from ``(x0, v0)``.

    ``cycle0`` is the start's position in the forcing cycle as a fraction of the period
    (continuation hands it on with the state: a parameter such as the tape speed changes
    the period, not the phase). The run lasts ``transient + record`` periods; the margin is over the last
    ``record_periods``. With ``stop_at_contact`` the run stops at the first contact in that
    window: the margin is then 0 (touching) and the final state NaN (not a steady state).
    """
    T = forcing_period(osc)
    t_start = transient_periods * T
    t_end = t_start + record_periods * T
    run = advanced(osc, cycle0 * T)
    if stop_at_contact:
        rec = _ContactWatch(backend, evaluator_of(backend, run, options), t_start)
        try:
            drive_recorder(backend, run, t_end, x0, v0, rec, DEFAULT_MAX_EVENTS, (t_start,), options)
        except _Touched:
            return 0.0, math.nan, math.nan, math.nan
        sol = Solution(rec, t_end)
    else:
        sol = simulate(run, t_end, x0, v0, backend=backend, record="events", sample_at=[t_start], **options)
    if sol.status != 0:
        raise RuntimeError(f"the run for the contact margin stopped (status {sol.status}): {sol.message}")
    ev = sol.events
    ev = ev[ev.t >= t_start]
    margin = -flange_clearance(osc, [float(sol.samples.x[0]), sol.x_final, *map(float, ev.x)])
    if osc.rigid:
        hits = ev[(ev.kind == IMPACT) | (ev.kind == CHATTER) | (ev.kind == CONTACT_START)]
        if len(hits):
            margin = float(np.max(np.abs(hits.v)))
    return margin, sol.x_final, sol.v_final, math.fmod(cycle0 + t_end / T, 1.0)


def _orbit_margin(osc, x0, v0, n, transient_periods, backend, options, guess: bool):
    """``(margin, x, v)`` of the period-``n`` orbit found by Newton shooting (from the guess or a transient)."""
    from .shooting import periodic_orbit

    kw = {"guess": (x0, v0)} if guess else {"x0": x0, "v0": v0, "transient_periods": transient_periods}
    orb = periodic_orbit(osc, n, backend=backend, **kw, **options)
    if orb.status != 0:
        raise RuntimeError(f"no period-{n} orbit at {osc!r}: {orb.message}")
    sol = orb.solution
    ev = sol.events
    margin = -flange_clearance(osc, [orb.x, sol.x_final, *map(float, ev.x)])
    if osc.rigid:
        hits = ev[(ev.kind == IMPACT) | (ev.kind == CHATTER) | (ev.kind == CONTACT_START)]
        if len(hits):
            margin = float(np.max(np.abs(hits.v)))
    return margin, orb.x, orb.v, 0.0


def contact_margin(base, *, transient_periods: float = 200, record_periods: float = 20, x0: float = 0.95,
                   v0: float = 0.0, backend: str = "heyoka", stop_at_contact: bool = False, **options) -> float:
    """Contact margin of the steady state of ``base`` reached from ``(x0, v0)`` (see the module docstring).

    Negative: the steady state stays off both flanges by that much (``1 - max|X|``).
    Non-negative: it touches (spring: deepest penetration; rigid: largest impact speed).
    The run lasts ``transient_periods + record_periods`` forcing periods (real numbers: a
    fraction of a period is enough when the free oscillation dies out fast, as on the
    tape drive); the margin is taken over the last ``record_periods``. With
    ``stop_at_contact`` the run stops at the first contact in that window and the margin
    is 0 (cheaper where contact is long, e.g. a tape creeping along a flange).

    Raises
    ------
    RuntimeError
        If the run does not reach its end (its status and message are in the error).
    """
    osc = oscillator_of(check_base(base))
    transient_periods, record_periods = _periods(transient_periods, record_periods)
    check_backend(osc, backend, options)
    x0, v0 = check_start(osc, (transient_periods + record_periods) * forcing_period(osc), x0, v0)
    return _margin(osc, x0, v0, 0.0, transient_periods, record_periods, backend, options, stop_at_contact)[0]


def _periods(transient_periods, record_periods) -> tuple[float, float]:
    return _v.nonnegative("transient_periods", transient_periods), _v.positive("record_periods", record_periods)


@dataclass(eq=False)
class ContactOnset:
    """The critical value of a parameter at which the steady state starts touching a flange.

    Attributes
    ----------
    parameter : str
    value : float
        The critical value (NaN when none was found).
    bracket : (float, float)
        ``method="transient"``: final bracket of the sign change of the margin (no contact
        at one end, contact at the other; its width is below the tolerance).
        ``method="continuation"``: the last point of the followed branch before the onset,
        and the onset.
    direction : int
        +1: contact above ``value``; -1: contact below it; 0 none found.
    margins : (float, float)
        Contact margins at the ends of ``bracket`` (continuation: ``min(upper_margin,
        lower_margin)`` of that branch point, and 0 at the onset).
    evaluations : int
        Steady states computed (continuation: points of the followed branch).
    status : int
        0 found; 1 no onset in the bracket (the message says on which side it is);
        2 no onset of the followed orbit: with continuation, the branch folds back before it
        touches a flange; with ``method="transient"``, the margin of the steady states
        changes sign where no orbit grazes (a jump between coexisting attractors, or
        transients that had not settled: ``value`` is the sign change, not an onset);
        -1 a run failed or no orbit was found (see ``message``).
    message : str
    method : str
        ``"continuation"`` or ``"transient"``.
    start : str
        The end of the bracket the search started from (``"lo"`` or ``"hi"``).
    followed : str
        Which orbit the continuation followed: the one through the user's ``guess``, or the
        one a stated transient reached (empty for ``method="transient"``).
    stable : bool or None
        Whether the followed orbit is stable just before the onset (None when unknown).
    branch : impactosc.dynamics.continuation.Branch or None
        The followed branch (:func:`~impactosc.dynamics.continuation.continuation`), up to the
        onset when it was followed with inert flanges (its points beyond it would not be the
        model's own orbits).
    """

    parameter: str
    value: float
    bracket: tuple
    direction: int
    margins: tuple
    evaluations: int
    status: int
    message: str
    method: str = "transient"
    start: str = "lo"
    followed: str = ""
    stable: bool | None = None
    branch: Any = None


METHODS = ("continuation", "transient")
#: Keywords of the transient search that mean nothing to continuation.
TRANSIENT_ONLY = ("scan", "follow", "record_periods", "stop_at_contact", "max_evaluations")
#: Settings of :func:`~impactosc.dynamics.continuation.continuation` that ``**options`` may carry.
CONTINUATION_SETTINGS = ("step", "min_step", "max_step", "max_points", "max_iter", "locate_tol")
#: Continuation's default ``locate_tol`` here: a coarse location, then the secant on the
#: contact-free orbits alone to ``tol`` (fewer runs than locating every point finely).
LOCATE_TOL = 1e-4
#: Parameters of the flange law (they act only in contact).
FLANGE_LAW = ("K", "exponent", "restitution", "stiffness_ratio", "flange_stiffness", "flange_exponent")
#: Flange stiffness of the model whose contact-free orbits are followed (see _shadow).
SHADOW_K = 1e-9


def contact_onset(base, parameter: str, bracket, *, method: str = "continuation", guess=None, start: str = "lo",
                  orbit: int | None = None, tol: float | None = None, transient_periods: float | None = None,
                  x0: float = 0.95, v0: float = 0.0, backend: str | None = None, scan: int | None = None,
                  follow: bool | None = None, record_periods: float | None = None, stop_at_contact: bool | None = None,
                  max_evaluations: int | None = None, **options) -> ContactOnset:
    """Find the value of ``parameter`` at which the followed steady state of ``base`` first touches a flange.

    Near a grazing boundary a contact attractor often coexists with the contact-free one
    (hysteresis), and an orbit may lose stability or fold back before it touches, so "the
    steady state" must be one definite branch of orbits.

    ``method="continuation"`` (default) takes the period-``orbit`` orbit at the ``start``
    end of the bracket, through ``guess`` or from the state a transient of
    ``transient_periods`` from ``(x0, v0)`` reaches (the result says which), and follows its
    branch with :func:`~impactosc.dynamics.continuation.continuation` towards the other end.
    The answer is the first contact onset along that branch: the grazing at which the first
    contact with a flange appears (or, from an orbit that touches, the last one vanishes).
    A contact-free branch is followed on the same model with the flanges made inert
    (a spring of stiffness ``1e-9``): its orbits are the model's own up to the grazing, and
    the margin ``1 - max|X|`` stays smooth through it, so the grazing is located as a plain
    zero (to about ``1e-12`` relative) without ever running the stiff contact. If the branch
    folds first, there is no onset on it (status 2); the result says whether the followed
    orbit was stable just before the onset.

    ``method="transient"`` is the search of earlier versions: brackets a sign change of the
    contact margin (:func:`contact_margin`) of the steady state that transients reach and
    refines it (regula falsi with the Illinois modification and a bisection safeguard). With
    ``follow=True`` (default) every refinement starts from the final state at the
    contact-free end of the current bracket; with ``orbit=n`` the steady state is the
    period-``n`` orbit found by Newton shooting.

    Parameters
    ----------
    base : Oscillator or TapeDrive
    parameter : str
        E.g. ``"F"`` (forcing amplitude) of an oscillator; ``"clearance"``, ``"speed"``,
        ``"tension"``, ``"pack_diameter"``, ``"runout_full"`` ... of a drive (SI units).
    bracket : (float, float)
        Interval to search, ``lo < hi``.
    method : {"continuation", "transient"}
    guess : (float, float), optional
        Continuation: ``(X, V)`` on the section near the orbit to follow at the ``start``
        end. Default: the state after a transient (``transient_periods`` from ``(x0, v0)``).
    start : {"lo", "hi"}
        Continuation: the end of the bracket the followed orbit is taken at.
    orbit : int, optional
        Continuation: the period ``n`` (in forcing periods) of the followed orbit (default 1).
        Transient: take the steady state to be the period-``orbit`` orbit found by Newton
        shooting instead of the end of a transient.
    tol : float, optional
        Absolute tolerance on the critical value. Transient default ``1e-6 * (hi - lo)``;
        continuation default ``1e-12 * max(|lo|, |hi|)`` (the located grazing is polished to
        it where continuation's bracket is wider).
    transient_periods : float, optional
        Forcing periods of the transient (default 100 for continuation, a whole number; 200
        for the transient search, where it may be fractional).
    x0, v0 : float
        Initial state of the transient.
    backend : str, optional
        Backend of the runs (continuation default: ``"exact"`` where it runs the model, else
        ``"heyoka"``; transient default ``"heyoka"``).
    scan, follow, record_periods, stop_at_contact, max_evaluations
        ``method="transient"`` only (refused otherwise): interior points scanned first
        (default 0), following the contact-free branch (default True), forcing periods
        examined per steady state (default 20), stopping each run at its first contact
        (default False), steady states computed at most (default 100).
    **options
        The backend's options; with ``method="continuation"`` also the continuation settings
        ``step``, ``min_step``, ``max_step``, ``max_points``, ``max_iter`` and ``locate_tol``
        (e.g. ``locate_tol=1e-4`` on a model whose runs are slow: the grazing is then located
        coarsely and polished to ``tol`` on the contact-free orbits alone).

    Returns
    -------
    ContactOnset

    Raises
    ------
    TypeError, ValueError
        For a bad argument (an unknown method or start, a guess that is not a pair of
        finite reals, a transient-only keyword with ``method="continuation"``, ...).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(map(repr, METHODS))}, got {method!r}")
    if method == "continuation":
        given = {"scan": scan, "follow": follow, "record_periods": record_periods,
                 "stop_at_contact": stop_at_contact, "max_evaluations": max_evaluations}
        for name in TRANSIENT_ONLY:
            if given[name] is not None:
                raise ValueError(f"{name}={given[name]!r} applies to method='transient' only (the search on "
                                 f"transients); use method='transient' with it, or leave it out")
        return _continuation_onset(base, parameter, bracket, guess, start, orbit, tol, transient_periods, x0, v0,
                                   backend, options)
    if guess is not None:
        raise ValueError(f"guess={guess!r} applies to method='continuation' only (the transient search starts "
                         "from (x0, v0))")
    if start != "lo":
        raise ValueError(f"start={start!r} applies to method='continuation' only (the transient search scans "
                         "from lo to hi)")
    return _transient_onset(base, parameter, bracket, tol=tol, scan=0 if scan is None else scan,
                            follow=True if follow is None else follow, orbit=orbit,
                            transient_periods=200 if transient_periods is None else transient_periods,
                            record_periods=20 if record_periods is None else record_periods, x0=x0, v0=v0,
                            stop_at_contact=bool(stop_at_contact), backend="heyoka" if backend is None else backend,
                            max_evaluations=100 if max_evaluations is None else max_evaluations, **options)


def _check_bracket(bracket) -> tuple[float, float]:
    try:
        lo, hi = bracket
    except (TypeError, ValueError):
        raise TypeError(f"bracket must be a pair (lo, hi), got {bracket!r}") from None
    lo, hi = _v.real("bracket[0]", lo), _v.real("bracket[1]", hi)
    if not lo < hi:
        raise ValueError(f"bracket must satisfy lo < hi, got ({lo!r}, {hi!r})")
    return lo, hi


def _check_study(base, parameter, bracket) -> tuple[float, float]:
    """The bracket of a contact onset, after the model (it has a flange) and the parameter are checked."""
    osc = oscillator_of(check_base(base))
    if math.isinf(osc.gap_lower) and math.isinf(osc.gap_upper):
        raise ValueError(f"this {type(base).__name__} has no flange (both gaps are absent): its motion never touches "
                         "one, so it has no contact onset")
    lo, hi = _check_bracket(bracket)
    check_study_parameter(base, parameter, (lo, hi))
    return lo, hi


def _default_backend(osc, backend, options) -> str:
    if backend is not None:
        if not isinstance(backend, str):
            raise TypeError(f"backend must be a string or None, got {backend!r}")
        check_backend(osc, backend, options)
        return backend
    try:
        check_backend(osc, "exact", options)
        return "exact"
    except ValueError:
        check_backend(osc, "heyoka", options)
        return "heyoka"


def _shadow(model):
    """``model`` with inert flanges: a linear spring of stiffness :data:`SHADOW_K` on both sides.

    Its contact-free orbits are exactly those of ``model`` (the flanges act only in
    contact), and its margin ``1 - max|X|`` passes smoothly through 0 where they graze.
    """
    if isinstance(model, Oscillator):
        return replace(model, K=SHADOW_K, flange="spring", exponent=1.0, restitution=1.0)
    return model.replace(stiffness_ratio=SHADOW_K, flange_stiffness=None, flange="spring", flange_exponent=1.0,
                         restitution=1.0)


def _touches(orb) -> bool:
    ev = orb.events
    if len(ev) and np.any(np.isin(ev.kind, (CONTACT_START, IMPACT, CHATTER))):
        return True
    return flange_clearance(orb.oscillator, [orb.x, *map(float, ev.x)]) <= 0.0


def _clear(point) -> float:
    """``min(upper_margin, lower_margin)`` of a branch point: > 0 while clear of both flanges."""
    return min(point.upper_margin, point.lower_margin)


def _continuation_onset(base, parameter, bracket, guess, start, orbit, tol, transient_periods, x0, v0, backend,
                        options) -> ContactOnset:
    from .continuation import continuation
    from .shooting import periodic_orbit

    settings = {k: options.pop(k) for k in CONTINUATION_SETTINGS if k in options}
    settings.setdefault("locate_tol", LOCATE_TOL)
    lo, hi = _check_study(base, parameter, bracket)
    n, tol, tp = _continuation_arguments(start, orbit, tol, transient_periods, lo, hi)
    p0 = lo if start == "lo" else hi
    model = with_parameter(base, parameter, p0)
    backend = _default_backend(oscillator_of(model), backend, options)
    orb, followed = _start_orbit(model, parameter, p0, n, guess, tp, x0, v0, backend, options)
    head = dict(parameter=parameter, method="continuation", start=start, followed=followed)

    def failed(status, message, branch=None, evaluations=0):
        return ContactOnset(value=math.nan, bracket=(lo, hi), direction=0, margins=(math.nan, math.nan),
                            evaluations=evaluations, status=status, message=message, branch=branch, **head)

    if orb.status != 0:
        return failed(-1, f"no period-{n} orbit to follow at {parameter} = {p0!r} (Newton from "
                          f"{'the guess' if guess is not None else 'the transient'}: {orb.message})")
    touching = _touches(orb)
    followed += f", {orb.stability}, {'touching a flange' if touching else 'clear of the flanges'}"
    head["followed"] = followed
    follow_base = model
    if not touching and parameter in FLANGE_LAW:
        raise ValueError(f"{parameter} does not move the contact onset of an orbit clear of the flanges: a flange law "
                         "acts only in contact, so every orbit of the followed branch is the same up to the onset")
    if not touching:
        follow_base = _shadow(model)
        orb = periodic_orbit(follow_base, n, guess=(orb.x, orb.v), backend=backend, **options)
        if orb.status != 0:
            return failed(-1, f"the orbit did not converge again on the model with inert flanges: {orb.message}")
    forward = start == "lo"
    try:
        # no bar of its own: an onset is one step of a chart (whose bar counts the points) or of a script
        br = continuation(orb, parameter, (lo, hi), base=follow_base, backend=backend,
                          direction="forward" if forward else "backward", progress=False, **settings, **options)
    except (RuntimeError, FloatingPointError) as exc:
        return failed(-1, f"the continuation failed: {type(exc).__name__}: {exc}")
    onset, fold = _first_onset(br, touching, forward)
    if fold is not None:
        return failed(2, f"the followed branch ({followed}) folds back at {parameter} = {fold.parameter!r} before "
                         f"it {'stops touching' if touching else 'touches'} a flange: it has no contact onset "
                         f"in the bracket", br, len(br.points))
    if onset is None:
        return failed(*_no_onset(br, followed, touching, lo if forward else hi, hi if forward else lo), br,
                      len(br.points))
    a, _ = _neighbours(br, onset, forward)
    n_points = len(br.points)
    value, polished = onset.parameter, ""
    if not touching or onset.accuracy > tol or (onset.context[2] or {}).get("test") == "end":
        try:
            br, onset, polished = _polished(br, onset, _shadow(model), n, tol, backend, options)
        except (RuntimeError, ValueError, FloatingPointError) as exc:
            return failed(-1, f"the grazing found near {parameter} = {onset.parameter!r} could not be located to "
                              f"tol = {tol:g}: {exc}", br, n_points)
        value = onset.parameter
    if not touching:
        br = _up_to(br, onset, forward, model)
    direction = (1 if forward else -1) * (-1 if touching else 1)
    stable = a.stable
    # the last branch point before the onset and the onset itself (margin 0 there)
    pa, pb = a.parameter, float(value)
    brk = (min(pa, pb), max(pa, pb))
    ms = (_clear(a), 0.0) if pa <= pb else (0.0, _clear(a))
    side = "above" if direction > 0 else "below"
    return ContactOnset(value=float(value), bracket=brk, direction=direction, margins=ms,
                        evaluations=n_points, status=0,
                        message=(f"contact {side} {parameter} = {value:.12g}: the followed branch ({followed}) "
                                 f"{'grazes' if not touching else 'leaves'} the flange there ({onset.label}: "
                                 f"{onset.message}), {'stable' if stable else a.stability} just before{polished}"),
                        stable=stable, branch=br.adopted(), **head)


def _continuation_arguments(start, orbit, tol, transient_periods, lo: float, hi: float) -> tuple[int, float, int]:
    """``(n, tol, transient_periods)`` of ``method="continuation"``, checked, with their defaults."""
    if start not in ("lo", "hi"):
        raise ValueError(f"start must be 'lo' or 'hi' (the end of the bracket the followed orbit is taken at), "
                         f"got {start!r}")
    n = 1 if orbit is None else _v.integer("orbit", orbit)
    tol = 1e-12 * max(abs(lo), abs(hi)) if tol is None else _v.positive("tol", tol)
    tp = 100 if transient_periods is None else transient_periods
    if (isinstance(tp, bool) or not isinstance(tp, numbers.Integral | float) or not math.isfinite(tp)
            or tp != int(tp) or tp < 0):
        raise ValueError(f"transient_periods must be a whole number >= 0 with method='continuation', got {tp!r}")
    return n, tol, int(tp)


def _start_orbit(model, parameter, p0, n: int, guess, tp: int, x0, v0, backend, options):
    """``(PeriodicOrbit, description)``: the orbit contact_onset follows, through ``guess`` or after a transient."""
    from .shooting import periodic_orbit

    osc = oscillator_of(model)
    if guess is not None:
        try:
            gx, gv = guess
        except (TypeError, ValueError):
            raise TypeError(f"guess must be a pair (X, V) on the section, got {guess!r}") from None
        gx, gv = check_start(osc, n * forcing_period(osc), gx, gv, names=("guess[0]", "guess[1]"))
        orb = periodic_orbit(model, n, guess=(gx, gv), backend=backend, **options)
        return orb, f"the period-{n} orbit through the guess (X, V) = ({gx!r}, {gv!r}) at {parameter} = {p0!r}"
    x0, v0 = check_start(osc, (tp + n) * forcing_period(osc), x0, v0)
    orb = periodic_orbit(model, n, x0=x0, v0=v0, transient_periods=tp, backend=backend, **options)
    return orb, (f"the period-{n} orbit reached at {parameter} = {p0!r} by a transient of {tp} forcing periods "
                 f"from (x0, v0) = ({x0!r}, {v0!r})")


def _first_onset(br, touching: bool, forward: bool):
    """``(onset, fold)``: the first contact onset along the followed direction, or the fold that comes first."""
    for s in (br.special if forward else list(reversed(br.special))):
        if s.kind == "fold":
            return None, s
        test = (s.context[2] or {}).get("test") if s.context else None
        if s.kind == "grazing" and test in ("upper_margin", "lower_margin", "end"):
            if not touching or _contact_free_beyond(br, s, forward):
                return s, None
    return None, None


def _no_onset(br, followed: str, touching: bool, near: float, far: float) -> tuple[int, str]:
    """``(status, message)`` of a followed branch without an onset: clear (or touching) all the way, or stopped short.

    "All the way" only when the branch reached the far end of the bracket; a branch that
    stopped before it rules nothing out beyond its last point.
    """
    parameter = br.names[0]
    end = br.ends[-1] if br.ends else (br.status, br.message)
    forward = far >= near
    reached = br.points[-1 if forward else 0].parameter if br.points else near
    if end[0] not in (0, 2):
        return -1, f"the continuation stopped before an onset: {end[1]}"
    if abs(reached - far) > 1e-9 * max(1.0, abs(far)):
        return -1, (f"the followed branch ({followed}) stopped at {parameter} = {reached!r}, short of the end of the "
                    f"bracket {far!r}, without touching a flange ({len(br.points)} points; {end[1]}): no onset "
                    "found, none ruled out beyond")
    where = "touches a flange" if touching else "stays clear of the flanges"
    lo, hi = min(near, far), max(near, far)
    return 1, (f"no contact onset in [{lo!r}, {hi!r}]: the followed branch ({followed}) {where} all the way "
               f"({len(br.points)} points; {end[1]})")


def _polished(br, onset, shadow, n: int, tol: float, backend, options):
    """``(branch, onset, note)`` with the onset moved to the zero of the clearance of the contact-free orbits.

    Always done from the contact-free side: continuation's corrector stops at a residual of
    its own tol, and where ``M - I`` is nearly singular that leaves the orbit (hence the
    grazing) farther off than ``tol``.
    """
    parameter = br.names[0]
    value, step, z, note = _polish(shadow, parameter, onset, n, tol, backend, options)
    new = dataclasses.replace(onset, parameters={**onset.parameters, parameter: value}, x=float(z[0]), v=float(z[1]),
                              accuracy=step)
    return dataclasses.replace(br, special=[new if s is onset else s for s in br.special]), new, f"; polished to {note}"


def _up_to(br, onset, forward: bool, model):
    """The part of a branch followed with inert flanges that is the model's own: up to the onset.

    Its points before the onset (along the followed direction) are contact-free, hence
    orbits of ``model`` too; beyond it they are not, and are left out.
    """
    if forward:
        points = br.points[:onset.index + 1]
        special = [s for s in br.special if s.index < onset.index or s is onset]
    else:
        cut = onset.index + 1
        points = br.points[cut:]
        special = [dataclasses.replace(s, index=s.index - cut) for s in br.special
                   if s.index > onset.index or s is onset]
    end = (0, f"stopped at the contact onset {onset.label} ({br.names[0]} = {onset.parameter!r}): the points beyond it "
              "were followed with inert flanges and are left out")
    return dataclasses.replace(br, points=points, special=special, status=0, message=end[1], ends=(end,),
                               base=model)


def _neighbours(br, s, forward: bool):
    """The branch points just before and just after ``s`` along the followed direction."""
    if (s.context[2] or {}).get("test") == "end":
        end = br.points[-1] if forward else br.points[0]
        return end, end
    i = min(max(s.index, 0), len(br.points) - 1)
    j = min(i + 1, len(br.points) - 1)
    return (br.points[i], br.points[j]) if forward else (br.points[j], br.points[i])


def _contact_free_beyond(br, s, forward: bool) -> bool:
    """From an orbit that touches: is the branch clear of both flanges just past the grazing ``s``?"""
    if (s.context[2] or {}).get("test") == "end":
        return True
    _, after = _neighbours(br, s, forward)
    return _clear(after) > 0.0


def _shadow_margin(shadow, parameter, p, z, n, backend, options):
    """``(1 - max|X|, (x, v))`` of the period-``n`` orbit of ``shadow`` at ``parameter = p`` near ``z``."""
    from .shooting import periodic_orbit

    orb = periodic_orbit(with_parameter(shadow, parameter, float(p)), n, guess=z, backend=backend, tol=1e-13,
                         **options)
    if orb.status != 0:
        if "guard is crossed tangentially" in orb.message and "enter_" in orb.message:
            return 0.0, z  # the orbit touches a flange tangentially to rounding: the grazing itself
        raise RuntimeError(f"no orbit at {parameter} = {p!r}: {orb.message}")
    return flange_clearance(orb.oscillator, [orb.x, *map(float, orb.events.x)]), (orb.x, orb.v)


def _polish(shadow, parameter, s, n, tol, backend, options):
    """The zero of ``1 - max|X|`` along the contact-free family next to the located grazing ``s`` (secant).

    Returns ``(value, last step, section state of the last orbit, note)``.
    """
    p1 = s.parameter
    m1, z = _shadow_margin(shadow, parameter, p1, (s.x, s.v), n, backend, options)
    h = max(1e3 * tol, 1e-7 * max(1.0, abs(p1)))
    p0 = p1 - h
    m0, _ = _shadow_margin(shadow, parameter, p0, z, n, backend, options)
    for _ in range(30):
        if m1 == m0:
            break
        p2 = p1 - m1 * (p1 - p0) / (m1 - m0)
        if abs(p2 - p1) <= tol:  # converged: the orbit at p2 itself grazes, where Newton may not run
            return (p2, abs(p2 - p1), z,
                    f"|1 - max|X|| = {abs(m1):.1g} at the last orbit computed (secant step {abs(p2 - p1):.1g})")
        p0, m0 = p1, m1
        p1 = p2
        m1, z = _shadow_margin(shadow, parameter, p1, z, n, backend, options)
    raise RuntimeError(f"the secant on 1 - max|X| did not converge (last step {abs(p1 - p0):.3g})")


def _transient_onset(base, parameter: str, bracket, *, tol, scan, follow, orbit, transient_periods, record_periods,
                     x0, v0, stop_at_contact, backend, max_evaluations, **options) -> ContactOnset:
    """The search of ``method="transient"`` (see :func:`contact_onset`)."""
    lo, hi = _check_study(base, parameter, bracket)
    tol = (1e-6 * (hi - lo)) if tol is None else _v.positive("tol", tol)
    scan = _v.integer("scan", scan, minimum=0)
    transient_periods, record_periods = _periods(transient_periods, record_periods)
    if orbit is not None and transient_periods != int(transient_periods):
        raise ValueError(f"transient_periods must be a whole number with orbit=, got {transient_periods!r}")
    first = oscillator_of(with_parameter(base, parameter, lo))
    check_backend(first, backend, options)
    max_evaluations = _v.integer("max_evaluations", max_evaluations, minimum=2)
    x0, v0 = check_start(first, (transient_periods + record_periods) * forcing_period(first), x0, v0)
    calls = [0]

    if orbit is not None:
        orbit = _v.integer("orbit", orbit)

    def evaluate(p, start):
        calls[0] += 1
        if calls[0] > max_evaluations:
            raise RuntimeError(f"max_evaluations={max_evaluations} steady states computed without reaching tol")
        osc = oscillator_of(with_parameter(base, parameter, float(p)))
        if orbit is not None:
            return _orbit_margin(osc, start[0], start[1], orbit, int(transient_periods), backend, options,
                                 guess=follow and calls[0] > 1)
        return _margin(osc, start[0], start[1], start[2], transient_periods, record_periods, backend, options,
                       stop_at_contact)

    try:
        grid = np.linspace(lo, hi, scan + 2)
        start = (x0, v0, 0.0)
        found = None
        seen = []
        for p in grid:
            m, xf, vf, tf = evaluate(p, start)
            if follow and math.isfinite(xf):
                start = (xf, vf, tf)
            seen.append((float(p), m, (xf, vf, tf)))
            if len(seen) > 1 and (seen[-2][1] >= 0.0) != (m >= 0.0):
                found = (seen[-2], seen[-1])
                break
        if found is None:
            m_lo = seen[0][1]
            where = "touches a flange" if m >= 0.0 else "stays off the flanges"
            return ContactOnset(parameter, math.nan, (lo, hi), 0, (m_lo, m), calls[0], 1,
                                f"no contact onset in [{lo!r}, {hi!r}]: the steady state {where} at all "
                                f"{grid.size} values tried (margins {m_lo:.3g} ... {m:.3g})")
        (a, ma, sa), (b, mb, sb) = _refine(found, tol, evaluate, follow, (x0, v0, 0.0))
    except (RuntimeError, ValueError, FloatingPointError) as exc:
        return ContactOnset(parameter, math.nan, (lo, hi), 0, (math.nan, math.nan), calls[0], -1,
                            f"{type(exc).__name__}: {exc}")
    root = 0.5 * (a + b)
    direction = 1 if mb >= 0.0 else -1
    where = f"{'above' if direction > 0 else 'below'} {parameter} = {root:.10g}"
    clear = (a, ma, sa) if ma < 0.0 else (b, mb, sb)
    doubt = _not_grazing(base, parameter, clear, (a, b), 1 if orbit is None else orbit, backend, options)
    if doubt:
        return ContactOnset(parameter, float(root), (float(a), float(b)), direction, (ma, mb), calls[0], 2,
                            f"the margin of the steady states reached by transients changes sign {where} (bracket "
                            f"width {b - a:.2g}), but that is no grazing of one followed orbit: {doubt}; "
                            "method='continuation' follows one orbit to its grazing")
    return ContactOnset(parameter, float(root), (float(a), float(b)), direction, (ma, mb), calls[0], 0,
                        f"contact {where} (bracket width {b - a:.2g}, {calls[0]} steady states; the periodic orbit "
                        "at the contact-free end, shot from the transient's state, grazes the flange)")


def _not_grazing(base, parameter, clear, bracket, n: int, backend, options) -> str:
    """Why the sign change found by the transient search is no grazing ("" when it is one).

    At the contact-free end ``p`` of the final bracket the state the transient reached is
    shot to its period-``n`` orbit (Newton), and that orbit again one bracket width farther
    from the contact; the secant through their clearances must vanish inside the bracket
    (give or take one width). A transient that had not settled (a multiplier near 1 decays
    slowly), or a sign change that is a jump between coexisting attractors, leaves the
    orbit at ``p`` touching or well clear of the flange, and fails.
    """
    from .shooting import periodic_orbit

    p, _, (x, v, cycle) = clear
    a, b = bracket
    width = b - a
    if not (math.isfinite(x) and math.isfinite(v)):
        return "the contact-free end has no final state to check"
    away = a - width if p == a else b + width

    def gap_of(value, guess):
        osc = oscillator_of(with_parameter(base, parameter, float(value)))
        section = advanced(osc, (cycle if math.isfinite(cycle) else 0.0) * forcing_period(osc))
        orb = periodic_orbit(section, n, guess=guess, backend=backend, tol=1e-12, **options)
        if orb.status != 0:
            raise RuntimeError(f"no period-{n} orbit at {parameter} = {value!r} ({orb.message})")
        return flange_clearance(orb.oscillator, [orb.x, *map(float, orb.events.x)]), (orb.x, orb.v), orb

    try:
        g0, z0, orb = gap_of(p, (x, v))
        if g0 <= 0.0 or _touches(orb):
            return (f"the period-{n} orbit through the state the transient reached at the contact-free end "
                    f"{parameter} = {p!r} touches a flange (the transient had not settled there)")
        g1, _, _ = gap_of(away, z0)
    except (RuntimeError, ValueError) as exc:
        return str(exc)
    if not g1 > g0:
        return (f"the orbit at the contact-free end {parameter} = {p!r} does not come nearer the flange towards the "
                f"bracket (clearance {g0:.3g} there, {g1:.3g} one width away)")
    zero = p + g0 * (p - away) / (g1 - g0)
    if not a - width <= zero <= b + width:
        return (f"the orbit at the contact-free end {parameter} = {p!r} stays {g0:.3g} from the flanges and would "
                f"graze near {parameter} = {zero:.10g}, outside the bracket: the steady state jumps there to "
                "another attractor, or the transients had not settled")
    return ""




def _refine(found, tol: float, evaluate, follow: bool, origin):
    """Shrink a bracket ``((a, m_a, state_a), (b, m_b, state_b))`` of a margin sign change below ``tol``.

    Regula falsi with the Illinois modification, bisecting whenever a step fails to halve
    the bracket (at grazing the margin has a kink: the penetration grows far more slowly
    than the clearance shrinks). Each evaluation starts from the state at the contact-free
    end when ``follow``, else from ``origin``.
    """
    (a, ma, sa), (b, mb, sb) = found
    fa, fb = ma, mb  # Illinois-weighted values used for the secant
    kept = 0  # +1: b kept last time, -1: a kept last time
    width = [b - a]
    while b - a > tol:
        free = sa if ma < 0.0 else sb
        c = (a * fb - b * fa) / (fb - fa)
        # Bisect when the secant leaves the bracket or the last step did not halve it (a kink
        # at grazing: the penetration grows far more slowly than the clearance shrinks).
        if not (a + 0.25 * tol < c < b - 0.25 * tol) or (len(width) > 1 and b - a > 0.5 * width[-2]):
            c = 0.5 * (a + b)
        mc, xf, vf, tf = evaluate(c, free if follow else origin)
        if (mc >= 0.0) == (ma >= 0.0):
            a, ma, sa, fa = c, mc, (xf, vf, tf), mc
            fb = 0.5 * fb if kept == 1 else fb
            kept = 1
        else:
            b, mb, sb, fb = c, mc, (xf, vf, tf), mc
            fa = 0.5 * fa if kept == -1 else fa
            kept = -1
        width.append(b - a)
    return (a, ma, sa), (b, mb, sb)
