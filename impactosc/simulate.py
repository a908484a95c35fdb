"""The public entry point :func:`simulate`."""

from __future__ import annotations

from . import _validation as _v
from .backends import get_backend
from .engine import check_run_arguments, check_sample_times
from .model import Oscillator
from .solution import RECORD_OPTIONS, Solution

__all__ = ["simulate", "DEFAULT_MAX_EVENTS"]

DEFAULT_MAX_EVENTS = 10_000_000


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
        Backend options: ``tol`` (heyoka); ``method``, ``rtol``, ``atol`` (scipy); ``dt``,
        ``flange`` (rk4).

    Returns
    -------
    Solution
    """
    run = get_backend(backend)
    osc, t_end, x0, v0, max_events = check_run_arguments(osc, t_end, x0, v0, max_events)
    _v.choice("record", record, RECORD_OPTIONS)
    stops = check_sample_times(sample_at, t_end)
    try:
        return run(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=stops, **options)
    except TypeError as exc:
        if "unexpected keyword argument" in str(exc):
            raise TypeError(f"backend {backend!r} does not accept that option: {exc}") from None
        raise
