"""The public entry point :func:`simulate`."""

from __future__ import annotations

import math

from .._util import validation as _v
from ..engine._driver import check_run_arguments, check_sample_times
from ..model._oscillator import Oscillator
from ..results._solution import RECORD_OPTIONS, Solution
from ._registry import get_backend

__all__ = ["simulate", "check_magnitudes", "DEFAULT_MAX_EVENTS", "MAX_MAGNITUDE"]

DEFAULT_MAX_EVENTS = 10_000_000

#: Largest value the run's worst-case integral of the squared flange force may reach
#: (see :func:`impactosc.simulate.check_magnitudes`): double precision overflows at 1.8e308, and the
#: backends square and sum these quantities again internally.
MAX_MAGNITUDE = 1e300


def simulate(osc: Oscillator, t_end: float, x0: float = 0.95, v0: float = 0.0, *,
             backend: str = "heyoka", record: str = "full",
             max_events: int = DEFAULT_MAX_EVENTS, sample_at=None, **options) -> Solution:
    """Integrate the impact oscillator event by event from ``(x0, v0)`` at ``Lambda = 0``.

    Parameters
    ----------
    osc : Oscillator
        The model (nondimensional eq. 3).
    t_end : float
        End time in nondimensional units ``Lambda = omega_n t`` (> 0).
    x0, v0 : float
        Initial position ``X = x/L`` and velocity. The defaults are the paper's eq. 6-7.
        With ``v0 == 0`` the stick test decides whether the mass starts stuck.
    backend : {"heyoka", "scipy", "exact", "rk4"}
        ``"heyoka"`` (default): Taylor integration, events at machine precision.
        ``"scipy"``: ``solve_ivp`` per smooth piece, the independent cross-check.
        ``"exact"``: closed-form pieces, the ground truth. ``"rk4"``: the paper's fixed-step
        RK4 with a naive ``sign()``, events reconstructed from sign changes (the baseline).
    record : {"full", "events", "stats"}
        What to keep (see :mod:`impactosc.solution`). Use ``"stats"`` for long runs.
    max_events : int
        Stop with ``status = 1`` after this many recorded events (results are kept).
    sample_at : sequence of float, optional
        Times in ``[0, t_end]`` at which the exact state is recorded in
        :attr:`Solution.samples` (``t, x, v, region, motion``). They are time events of the
        run, not interpolations: a stroboscopic Poincare section is ``sample_at`` at every
        forcing period. Not available with ``backend="rk4"``.
    **options
        Backend options: ``tol`` in ``[1e-18, 1e-2]`` and ``max_wall_time`` (seconds; the
        run stops with ``status = 1`` and keeps its results) (heyoka); ``method``,
        ``rtol`` in ``[100 eps, 1e-3]``, ``atol`` in ``[1e-18, 1e-3]`` (scipy); ``dt``,
        ``flange``, ``every`` (rk4).

    Returns
    -------
    Solution
        It pickles in every recording mode (for process pools, dask or a cache), and
        :meth:`Solution.sample` works on the unpickled copy.

    Raises
    ------
    TypeError, ValueError
        For a bad argument or option; the message names it. Also when ``x0``, ``v0``,
        ``F * t_end`` or ``K`` are so large that the run's integrals could overflow double
        precision (see :func:`impactosc.simulate.check_magnitudes`).
    KeyboardInterrupt
        Ctrl-C stops a run within milliseconds (measured on event-free and event-dense
        runs of every backend); the exception propagates, no partial result is returned,
        and the next run works normally. To bound a run and keep what it computed, use
        ``max_events`` or heyoka's ``max_wall_time``.
    """
    run = get_backend(backend)
    osc, t_end, x0, v0, max_events = check_run_arguments(osc, t_end, x0, v0, max_events)
    _v.choice("record", record, RECORD_OPTIONS)
    stops = check_sample_times(sample_at, t_end)
    check_magnitudes(osc, t_end, x0, v0)
    try:
        return run(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=stops, **options)
    except TypeError as exc:
        if "unexpected keyword argument" in str(exc):
            raise TypeError(f"backend {backend!r} does not accept that option: {exc}") from None
        raise


def check_magnitudes(osc: Oscillator, t_end: float, x0: float, v0: float) -> None:
    """Refuse a run whose statistics could overflow double precision, naming the culprit.

    The mechanical energy ``E = V^2/2 + X^2/2 + K (|X|-1)+^2 / 2`` grows at most as
    ``d sqrt(2E)/dt <= F`` (friction only dissipates), so ``R = sqrt(2 E0) + F t_end``
    bounds ``|V|`` and ``sqrt(K) (|X|-1)+`` over the run, and ``K R^2 t_end`` bounds the
    integral of the squared flange force, the largest statistic. It must stay below
    :data:`MAX_MAGNITUDE`. Worked in logarithms so that the check itself cannot overflow.

    Raises
    ------
    ValueError
        Naming whichever of ``x0``, ``v0``, ``F``/``t_end`` or ``K`` dominates the bound.
    """
    def log10(a: float) -> float:
        return math.log10(a) if a > 0.0 else -math.inf

    pen = abs(x0) - 1.0
    terms = {  # log10 of the contributions to R (their sum bounds R within a factor 4)
        "x0": max(log10(abs(x0)), 0.5 * log10(osc.K) + log10(pen) if pen > 0.0 else -math.inf),
        "v0": log10(abs(v0)),
        "F": log10(sum(F for F, _, _ in osc.terms)) + log10(t_end),
    }
    log_r = max(max(terms.values()), 0.0) + math.log10(len(terms) + 1)
    log_q2 = log10(osc.K) + 2.0 * log_r + max(log10(t_end), 0.0)
    limit = math.log10(MAX_MAGNITUDE)
    if log_q2 <= limit:
        return
    name = max(terms, key=lambda k: terms[k])
    if log10(osc.K) > 2.0 * log_r:
        name = "K"
    culprit = {"x0": f"x0={x0!r}", "v0": f"v0={v0!r}", "K": f"K={osc.K!r}",
               "F": f"F * t_end (F={osc.F!r}, t_end={t_end!r})"}[name]
    raise ValueError(f"{culprit} is too large for double precision: with "
                     f"x0={x0!r}, v0={v0!r}, F={osc.F!r}, K={osc.K!r} and t_end={t_end!r} the integral of "
                     f"the squared flange force could reach 1e{log_q2:.0f}, beyond {MAX_MAGNITUDE:g} "
                     "(K R^2 t_end with R = sqrt(2 E0) + F t_end, see impactosc.simulate.check_magnitudes)")
