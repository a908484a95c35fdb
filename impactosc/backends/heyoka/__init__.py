"""heyoka backend: Taylor integration with guards located on each step's Taylor polynomial.

One event loop
--------------
A member of the family runs on the one heyoka event loop, the loop of user systems
(``backends/_hybrid_heyoka.py``), as the hybrid system :func:`~impactosc.model.hybrid.oscillator_system`
writes for it, with the integrals the built-in :class:`~impactosc.Solution` reports
(``oscillator_system(osc, energy=True)``: the flange impulse ``Q = int K d``, ``Q2 = int (K d)^2``
for rms forces, the forcing work ``W = int V f`` and, when damped, ``VV = int V^2``, scaled by a
power of two out of heyoka's error norm). :func:`run` calls ``run_on_hybrid_loop``
(``backends/heyoka/_replay.py``), which runs that system and replays its events into the
built-in recorder as the engine's ``drive`` would feed it: the hybrid modes map onto the
engine's ``Mode(region, motion)`` and its guards onto the built-in event kinds
(``contact_start``, ``contact_end``, ``impact``, ``stick``, ``reversal``, ``release``), a flange
crossing is recorded on the flange's surface, and a rigid flange's impacts, chatter (the
engine's chatter rule as the impact guard's ``accumulation``), rest on the wall and release
are recorded as the engine records them. There is no other loop and no fallback: a run the
loop cannot finish ends with ``status = -1``, its message and what it computed.

The integrator
--------------
One ``taylor_adaptive`` per system structure and tolerance (:func:`compiled_integrator`),
compiled on first use and reused for every run, every member of that structure and every
sweep point: the member's numbers and the mode are runtime parameters, so only the
parameters, the time and the state change between runs. Every guard is a terminal event
gated by the modes that arm it and filtered by its direction, and each guard's Lie
derivative (its extrema) is a second one: heyoka finds their roots on the Taylor polynomial
of each step, so event times are located to machine precision and a grazing contact inside
a step is found even though the step's ends lie on the same side of the flange. Each
transition (the reset, the next mode, a guard the new state lies on) runs in the event's
callback (``engine/_hybrid.Switch``).

A stuck phase is a *frozen* mode (every state's rate zero). When the forcing is periodic
with ``2 pi / Omega`` (every harmonic a whole multiple of ``Omega``, or none depending on the
time) the loop jumps over whole periods, so a stuck phase of any length costs about three
periods of steps (``engine/_hybrid.period_jump``). Harmonics that are not whole multiples of
``Omega`` have no period to jump: the loop steps through the stuck phase, which is correct but
costs in proportion to its length (about 2.5 us per unit of time at ``Omega = 0.7``, measured:
23 ms to ``t = 1e4``).

``max_wall_time`` ends a run between two calls of at most ``WALL_TIME_STEPS`` integrator steps
(heyoka's steps do not depend on the previous one, so the run is the same step for step) with
``status = 1``, a message and the results up to ``t_final``. heyoka logs through spdlog on C's
``stdout``; the process's first heyoka integrator is built with that log pointed at ``stderr``
(``impactosc._util.heyoka_log``), so that its warnings cannot corrupt piped output.
"""

from __future__ import annotations

from ...model._oscillator import Oscillator
from ...results._solution import Solution
from .._hybrid_heyoka import DEFAULT_COOLDOWN, DEFAULT_TOL, MAX_TOL, MIN_TOL, check_tol, compiled
from ._replay import _system, run_on_hybrid_loop

__all__ = ["run", "compiled_integrator", "check_tol", "DEFAULT_TOL", "MIN_TOL", "MAX_TOL"]


def compiled_integrator(osc: Oscillator, tol: float = DEFAULT_TOL):
    """The compiled heyoka integrator that runs ``osc`` (compiled on the first call, then reused).

    ``osc`` runs as :func:`~impactosc.model.hybrid.oscillator_system` on the one heyoka loop,
    whose integrator is compiled once per system structure and tolerance
    (``backends/_hybrid_heyoka.py``, ``compiled``): members that differ only in their numbers
    (``F``, ``Omega``, ``beta``, ``K``, gaps...) share it, because every number is a runtime
    parameter. Call it to take the compile (0.1-1 s, logged once per structure) out of a first
    timed run. The process's first heyoka integrator is built with heyoka's log on ``stderr``,
    so its warnings never reach piped output.

    Parameters
    ----------
    osc : Oscillator
        The member (any member that ``simulate(osc, backend="heyoka")`` runs).
    tol : float, optional
        heyoka's tolerance, in ``[MIN_TOL, MAX_TOL]`` (default: machine epsilon).

    Returns
    -------
    object
        The loop's compiled system (its ``taylor_adaptive`` is ``.ta``): the same object for
        every member of one structure at one tolerance.

    Examples
    --------
    >>> import impactosc as io
    >>> from impactosc.backends.heyoka import compiled_integrator
    >>> a = compiled_integrator(io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4))
    >>> a is compiled_integrator(io.Oscillator(F=0.3, Omega=0.7, beta=0.02, K=1e3))
    True
    """
    system = _system(osc)[0]
    tol = check_tol(tol)
    return compiled(system, tol, DEFAULT_COOLDOWN)


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        sample_at=(), tol: float = DEFAULT_TOL, max_wall_time: float | None = None) -> Solution:
    """Run ``osc`` from ``(x0, v0)`` to ``t_end`` on the one heyoka event loop.

    Parameters
    ----------
    osc, t_end, x0, v0, record, max_events
        See :func:`impactosc.simulate`.
    tol : float, optional
        heyoka's relative and absolute tolerance, in ``[MIN_TOL, MAX_TOL] = [1e-18, 1e-2]``
        (default: machine epsilon).
    max_wall_time : float or None, optional
        Stop after this many seconds of wall time (checked every few thousand integrator
        steps), with ``status = 1``, a message and the results up to ``t_final`` kept.
        ``None`` (default): no limit.

    Returns
    -------
    Solution

    Examples
    --------
    >>> import impactosc as io
    >>> from impactosc.backends.heyoka import run
    >>> sol = run(io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), 50.0, 0.95, 0.0, record="events",
    ...           max_events=10**6)
    >>> sol.status, sol.counts["contact_start"] > 0
    (0, True)
    """
    return run_on_hybrid_loop(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=sample_at,
                              tol=check_tol(tol), max_wall_time=max_wall_time)
