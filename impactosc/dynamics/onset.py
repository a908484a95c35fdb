"""Contact onset: the parameter value at which the steady state first touches a flange (the grazing boundary).

The **contact margin** of a steady state is a continuous function of the parameters whose
sign says whether the motion touches a flange:

* no contact: ``max |X| - 1 < 0`` over the recorded periods. It is exact, not sampled: every
  smooth piece is monotonic in ``X`` (each turning point is an event), so the maximum is at
  an event, at the start of the window or at its end;
* a spring flange in contact: the deepest penetration ``max |X| - 1 >= 0`` (the same formula);
* a rigid flange in contact: the largest impact speed ``max |V_impact| >= 0``, which tends to
  0 at grazing like the square root of the distance to the boundary.

:func:`contact_onset` brackets a sign change of the margin along one parameter and refines
it with Brent's method to the requested tolerance; :func:`onset_chart` does that at every
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

import math
from dataclasses import dataclass

import numpy as np

from .._util import validation as _v
from ..backends._simulate import DEFAULT_MAX_EVENTS, simulate
from ..engine._driver import CHATTER, CONTACT_START, IMPACT, drive
from ..results._solution import Solution, _Recorder
from ._common import advanced, check_base, check_parameter, forcing_period, oscillator_of, with_parameter
from .tangent import check_backend, check_start, piece_stepper

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
        stepper, evaluator = piece_stepper(backend, run, options)
        rec = _ContactWatch(backend, evaluator, t_start)
        try:
            drive(stepper, run, t_end, x0, v0, rec, DEFAULT_MAX_EVENTS, (t_start,))
        except _Touched:
            return 0.0, math.nan, math.nan, math.nan
        sol = Solution(rec, t_end)
    else:
        sol = simulate(run, t_end, x0, v0, backend=backend, record="events", sample_at=[t_start], **options)
    if sol.status != 0:
        raise RuntimeError(f"the run for the contact margin stopped (status {sol.status}): {sol.message}")
    ev = sol.events
    ev = ev[ev.t >= t_start]
    xs = [abs(float(sol.samples.x[0])), abs(sol.x_final)]
    if len(ev):
        xs.append(float(np.max(np.abs(ev.x))))
    margin = max(xs) - 1.0
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
    margin = max(abs(orb.x), abs(sol.x_final), float(np.max(np.abs(ev.x))) if len(ev) else 0.0) - 1.0
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
        Final bracket of the sign change (no contact at one end, contact at the other; its
        width is below the tolerance).
    direction : int
        +1: contact above ``value``; -1: contact below it; 0 none found.
    margins : (float, float)
        Contact margins at the ends of the final bracket.
    evaluations : int
        Steady states computed.
    status : int
        0 found; 1 no sign change in the bracket (the message says on which side it is);
        -1 a run failed (see ``message``).
    message : str
    """

    parameter: str
    value: float
    bracket: tuple
    direction: int
    margins: tuple
    evaluations: int
    status: int
    message: str


def contact_onset(base, parameter: str, bracket, *, tol: float | None = None, scan: int = 0,
                  follow: bool = True, orbit: int | None = None, transient_periods: float = 200,
                  record_periods: float = 20, x0: float = 0.95, v0: float = 0.0, stop_at_contact: bool = False,
                  backend: str = "heyoka", max_evaluations: int = 100, **options) -> ContactOnset:
    """Find the value of ``parameter`` at which the steady state of ``base`` first touches a flange.

    Near a grazing boundary a contact attractor often coexists with the contact-free one
    (hysteresis), so "the steady state" depends on where the motion comes from. With
    ``follow=True`` (default) the contact-free branch is followed, as in a slow sweep:
    the scan runs from ``lo`` to ``hi`` each value starting from the previous final state,
    and every refinement starts from the final state at the contact-free end of the
    current bracket. The onset is where that branch touches a flange (or ceases to exist).
    With ``follow=False`` every value starts from ``(x0, v0)``.

    The refinement is regula falsi with the Illinois modification and a bisection
    safeguard, on the contact margin (:func:`contact_margin`).

    Parameters
    ----------
    base : Oscillator or TapeDrive
    parameter : str
        E.g. ``"F"`` (forcing amplitude) of an oscillator; ``"clearance"``, ``"speed"``,
        ``"tension"``, ``"pack_diameter"``, ``"runout_full"`` ... of a drive (SI units).
    bracket : (float, float)
        Interval to search, ``lo < hi``.
    tol : float, optional
        Absolute tolerance on the critical value (default ``1e-6 * (hi - lo)``).
    scan : int
        Interior points evaluated first, from ``lo``; the first sign change is refined.
    follow : bool
        Follow the contact-free branch (see above).
    orbit : int, optional
        Take the steady state to be the period-``orbit`` orbit found by Newton shooting
        (:func:`~impactosc.dynamics.periodic_orbit`), from the previous orbit when following,
        instead of the end of a transient. Near a grazing boundary the basin of the
        contact-free orbit shrinks to nothing (any finite step of the parameter can throw
        a transient onto a coexisting contact attractor), so only shooting follows the
        branch all the way to its grazing point.
    transient_periods, record_periods : float
        Forcing periods discarded, then examined, for every steady state (see
        :func:`contact_margin`).
    x0, v0 : float
        Initial state (of the first value when following).
    stop_at_contact : bool
        Stop every run at its first contact in the window (see :func:`contact_margin`): the
        refinement is then a bisection.
    backend, **options
        Backend of the runs and its options.
    max_evaluations : int
        Steady states computed at most (status -1 beyond).

    Returns
    -------
    ContactOnset
    """
    check_base(base)
    check_parameter(base, parameter)
    try:
        lo, hi = bracket
    except (TypeError, ValueError):
        raise TypeError(f"bracket must be a pair (lo, hi), got {bracket!r}") from None
    lo, hi = _v.real("bracket[0]", lo), _v.real("bracket[1]", hi)
    if not lo < hi:
        raise ValueError(f"bracket must satisfy lo < hi, got ({lo!r}, {hi!r})")
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
        (a, ma, _), (b, mb, _) = _refine(found, tol, evaluate, follow, (x0, v0, 0.0))
    except (RuntimeError, ValueError, FloatingPointError) as exc:
        return ContactOnset(parameter, math.nan, (lo, hi), 0, (math.nan, math.nan), calls[0], -1,
                            f"{type(exc).__name__}: {exc}")
    root = 0.5 * (a + b)
    direction = 1 if mb >= 0.0 else -1
    return ContactOnset(parameter, float(root), (float(a), float(b)), direction, (ma, mb), calls[0], 0,
                        f"contact {'above' if direction > 0 else 'below'} {parameter} = {root:.10g} "
                        f"(bracket width {b - a:.2g}, {calls[0]} steady states)")


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
