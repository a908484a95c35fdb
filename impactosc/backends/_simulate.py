"""The public entry point :func:`simulate`."""

from __future__ import annotations

import math

from .._util import validation as _v
from ..engine._driver import check_run_arguments, check_sample_times
from ..model._mechanical import MechanicalSystem
from ..model._oscillator import Oscillator
from ..model.hybrid import HybridSystem
from ..results._solution import RECORD_OPTIONS, Solution
from ._registry import MAX_HEYOKA_TERMS, MAX_ZETA_OF, get_backend, resolve_backend

__all__ = ["simulate", "check_magnitudes", "check_cost", "check_gaps", "DEFAULT_MAX_EVENTS", "MAX_MAGNITUDE",
           "MAX_ZETA", "MAX_OVERDAMPED_SPAN_OF", "MAX_ZETA_OF", "MAX_HEYOKA_TERMS", "MIN_GAP"]

DEFAULT_MAX_EVENTS = 10_000_000

#: Largest value the run's worst-case integral of the squared flange force may reach
#: (see ``check_magnitudes`` of this module): double precision overflows at 1.8e308, and the
#: backends square and sum these quantities again internally.
MAX_MAGNITUDE = 1e300

#: Largest damping ratio any backend accepts: beyond it the overdamped rates
#: ``zeta +- sqrt(zeta^2 - w^2)`` and the powers of them the solvers form overflow double
#: precision (``zeta = 1e150`` failed with a FloatingPointError), and the
#: mass is locked anyway (its creep speed ``|f| / (2 zeta)`` is below 1e-100).
MAX_ZETA = 1e100
#: Largest ``zeta * t_end`` with ``zeta > 1`` for the backends whose work grows with the
#: fast decay rate ``~2 zeta`` of overdamped motion (see :func:`check_cost`), each about 3 s
#: of one core at its limit (measured: exact 2.7 s at 1e6, heyoka 3.5 s at 1e7, scipy's
#: DOP853 24 s at 9e5); ``"scipy"`` stands for its explicit methods.
MAX_OVERDAMPED_SPAN_OF = {"exact": 1e6, "heyoka": 1e7, "scipy": 1e5}
#: Smallest distance from the rest position to a flange (``gap_lower``, ``gap_upper``, in units of
#: the clearance ``L``) the backends resolve. From rest the mass reaches a flange at distance ``g``
#: after about ``sqrt(2 g / a)`` under a push ``a``; heyoka's root finder stops locating that first
#: contact when it comes within about 1e-12 of the start of a step (measured: status -1 from
#: ``g = 1e-25`` at ``a = 0.5``; its polynomial root isolation ran out of iterations at ``g = 1e-100``),
#: and scipy missed the impact on a rigid wall at ``g = 1e-100``. 1e-12 keeps a margin of 1e6 in
#: ``g / a`` over those; it is 1e-12 of the clearance (5e-17 m in a 50 micrometre guide).
MIN_GAP = 1e-12


def simulate(osc: Oscillator, t_end: float, x0: float = 0.95, v0: float = 0.0, *,
             backend: str = "heyoka", record: str = "full",
             max_events: int = DEFAULT_MAX_EVENTS, sample_at=None, **options) -> Solution:
    """Integrate the impact oscillator event by event from ``(x0, v0)`` at ``Lambda = 0``.

    ``simulate(system, t_end, q0, v0, backend="exact")`` runs a :class:`~impactosc.MechanicalSystem`
    and returns a :class:`~impactosc.results.MechanicalSolution`; ``"heyoka"`` and ``"scipy"`` run
    its form as a user system (:func:`~impactosc.model.hybrid.mechanical_system`) and return the
    same type (the events in the exact backend's kinds; a chatter that the exact backend sums
    into rest on a stop ends their run with status 2).
    ``simulate(system, t_end, state0, backend=..., **options)`` runs a user's
    :class:`~impactosc.HybridSystem` instead (see ``impactosc.backends._hybrid.simulate_system``
    for its options) and returns a :class:`~impactosc.results.HybridSolution`.

    Parameters
    ----------
    osc : Oscillator
        The model (nondimensional eq. 3).
    t_end : float
        End time in nondimensional units ``Lambda = omega_n t`` (> 0).
    x0, v0 : float
        Initial position ``X = x/L`` and velocity. The defaults are the paper's eq. 6-7.
        With ``v0 == 0`` the stick test decides whether the mass starts stuck.
    backend : {"heyoka", "scipy", "exact", "rk4", "auto"}
        ``"heyoka"`` (default): Taylor integration, events at machine precision; runs every
        member. ``"scipy"``: ``solve_ivp`` per smooth piece, the independent cross-check.
        ``"exact"``: closed-form pieces, the ground truth (linear members). ``"rk4"``: the
        paper's fixed-step RK4 with a naive ``sign()``, events reconstructed from sign
        changes (the baseline). ``"auto"``: the fastest that runs the member
        (:func:`impactosc.backends.resolve_backend`: ``"exact"`` for a linear member with
        numba installed, else ``"heyoka"``; with backend options, the backend they are
        for); ``Solution.backend`` says which one ran.
    record : {"full", "events", "stats"}
        What to keep (see :class:`~impactosc.Solution`). Use ``"stats"`` for long runs.
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
        precision (``check_magnitudes`` in ``impactosc.backends._simulate``), when a flange is closer
        to the rest position than the backends resolve (``gap_lower`` or ``gap_upper`` below
        ``MIN_GAP = 1e-12``), and when the run would
        cost minutes that another backend or option avoids: a heavily overdamped run on
        a backend that steps at its fast decay rate, or too many harmonics for heyoka's
        compiler (``check_cost`` in ``impactosc.backends._simulate``).
    KeyboardInterrupt
        Ctrl-C stops a run within milliseconds (measured on event-free and event-dense
        runs of every backend); the exception propagates, no partial result is returned,
        and the next run works normally. To bound a run and keep what it computed, use
        ``max_events`` or heyoka's ``max_wall_time``.

    Examples
    --------
    The contact case of the README: both flanges touched, every event located.

    >>> import impactosc as io
    >>> sol = io.simulate(io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), 400.0)
    >>> sol.status, sol.counts["contact_start"] > 0
    (0, True)

    The same member on the closed-form backend, chosen by ``"auto"``:

    >>> io.simulate(io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), 400.0, backend="auto").backend
    'exact'
    """
    if isinstance(osc, MechanicalSystem):  # n degrees of freedom: x0, v0 are the vectors q0, q0'
        return _simulate_mechanical(osc, t_end, x0, v0, backend=backend, record=record, max_events=max_events,
                                    sample_at=sample_at, **options)
    if isinstance(osc, HybridSystem):  # a user's system
        from ._hybrid import simulate_system

        return simulate_system(osc, t_end, x0, v0, backend=backend, record=record, max_events=max_events,
                               sample_at=sample_at, **options)
    get_backend(backend)  # an unknown name fails first
    osc, t_end, x0, v0, max_events = check_run_arguments(osc, t_end, x0, v0, max_events)
    _v.choice("record", record, RECORD_OPTIONS)
    stops = check_sample_times(sample_at, t_end)
    backend = resolve_backend(backend, osc, options)
    run = get_backend(backend)
    check_magnitudes(osc, t_end, x0, v0)
    check_cost(osc, t_end, backend, options)
    try:
        return run(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=stops, **options)
    except TypeError as exc:
        if "unexpected keyword argument" in str(exc):
            raise TypeError(f"backend {backend!r} does not accept that option: {exc}") from None
        raise


def _simulate_mechanical(system, t_end, q0, v0, *, backend, record, max_events, sample_at, **options):
    """A :class:`~impactosc.MechanicalSystem` on the exact n-DOF backend (``"exact"``, ``"auto"``), or on
    heyoka or scipy through its form as a user system (:func:`impactosc.model.hybrid.mechanical_system`);
    a :class:`~impactosc.results.MechanicalSolution` from each."""
    _v.choice("backend", backend, ("exact", "auto", "heyoka", "scipy"))
    if record != "full" or sample_at is not None:
        raise ValueError("a MechanicalSystem's run keeps every event and samples afterwards "
                         "(MechanicalSolution.sample): leave record and sample_at at their defaults")
    if backend in ("exact", "auto"):
        from ._exact_mdof import simulate_mechanical

        return simulate_mechanical(system, t_end, q0, v0, max_events=max_events, **options)
    from ._mechanical_hybrid import run_as_system

    return run_as_system(system, t_end, q0, v0, backend=backend, max_events=max_events, **options)


def check_magnitudes(osc: Oscillator, t_end: float, x0: float, v0: float) -> None:
    """Refuse a run whose magnitudes the backends cannot resolve or hold, naming the culprit.

    The small end first: a flange closer to the rest position than :data:`MIN_GAP`
    (:func:`check_gaps`). Then the large end, the statistics that could overflow: the
    mechanical energy ``E = V^2/2 + X^2/2 + K (|X|-1)+^2 / 2`` grows at most as
    ``d sqrt(2E)/dt <= F`` (friction only dissipates), so ``R = sqrt(2 E0) + F t_end``
    bounds ``|V|`` and ``sqrt(K) (|X|-1)+`` over the run, and ``K R^2 t_end`` bounds the
    integral of the squared flange force, the largest statistic. It must stay below
    :data:`MAX_MAGNITUDE`. Worked in logarithms so that the check itself cannot overflow.

    Raises
    ------
    ValueError
        Naming ``gap_lower`` or ``gap_upper`` below :data:`MIN_GAP`, or whichever of ``x0``,
        ``v0``, ``F``/``t_end`` or ``K`` dominates the bound.
    """
    check_gaps(osc)
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
                     "(K R^2 t_end with R = sqrt(2 E0) + F t_end, see impactosc.backends._simulate.check_magnitudes)")


def check_gaps(osc: Oscillator) -> None:
    """Refuse a flange closer to the rest position than the backends resolve (:data:`MIN_GAP`).

    Raises
    ------
    ValueError
        Naming ``gap_lower`` or ``gap_upper``, its value and the rule.
    """
    for name in ("gap_lower", "gap_upper"):
        gap = getattr(osc, name)
        if gap < MIN_GAP:
            raise ValueError(f"{name}={gap!r} is below {MIN_GAP:g}, the smallest flange distance (in units of the "
                             "clearance L) the backends resolve: the first contact from rest would come within "
                             f"rounding of the start of a step; use {name} >= {MIN_GAP:g}")


#: scipy's implicit methods: their steps follow the slow motion of a stiff (overdamped) run.
_STIFF_METHODS = ("Radau", "BDF", "LSODA")


def check_cost(osc: Oscillator, t_end: float, backend: str, options: dict) -> None:
    """Refuse a run that would take minutes (and ignore Ctrl-C for long) where another choice does not.

    Rules, each with the remedy in its message:

    * ``zeta <= MAX_ZETA`` (1e100) on every backend; ``backend="exact"``: ``zeta <= 1e3``,
      ``"heyoka"``: ``zeta <= 1e12`` (:data:`MAX_ZETA_OF`, where they stop following it).
    * With ``zeta > 1`` (overdamped free motion) ``zeta * t_end`` at most
      :data:`MAX_OVERDAMPED_SPAN_OF` (exact 1e6, heyoka 1e7, scipy's explicit methods
      1e5: about 3 s each) on the backends whose work grows with the fast decay rate
      ``zeta + sqrt(zeta^2 - 1) ~ 2 zeta``: ``"exact"`` (its guard search proves signs on
      windows of that time scale), ``"heyoka"`` (an explicit Taylor method, stability-bound
      steps) and ``"scipy"`` with an explicit method. A creeping piece can span the whole
      run, so this also bounds how long Ctrl-C waits (the exact backend's compiled loop
      checks it between pieces; 20 s at ``zeta = 1e5, t_end = 100`` before). scipy's
      implicit methods (``method="Radau"``, ``"BDF"``, ``"LSODA"``) step with the slow
      motion: 2 s at ``zeta = 1e8``.
    * ``backend="heyoka"``: at most ``MAX_HEYOKA_TERMS`` (40) forcing terms.

    Raises
    ------
    ValueError
        Naming the parameter, the rule, its value and what to use instead.
    """
    zeta = osc.zeta
    if zeta > MAX_ZETA:
        raise ValueError(f"zeta={zeta!r} is above the largest damping ratio the backends follow, {MAX_ZETA:g}: "
                         "beyond it the overdamped decay rates overflow double precision, and the mass is locked "
                         f"(its creep speed |f_net| / (2 zeta) is below {1 / MAX_ZETA:g}); use zeta <= {MAX_ZETA:g}")
    limit = MAX_ZETA_OF.get(backend)
    if limit is not None and zeta > limit:
        raise ValueError(f"zeta={zeta!r} is above {limit:g}, the largest damping ratio backend={backend!r} "
                         "follows (beyond it the run can fail with status -1: the fast transient of the "
                         "overdamped motion drowns the slow creep in rounding); use backend='scipy' with "
                         "method='Radau' (implicit: its steps follow the slow creep)")
    span = MAX_OVERDAMPED_SPAN_OF.get(backend)
    if backend == "scipy" and options.get("method", "DOP853") in _STIFF_METHODS:
        span = None
    if span is not None and zeta > 1.0 and zeta * t_end > span:
        which = (f"backend={backend!r}" if backend != "scipy"
                 else f"backend='scipy' with method={options.get('method', 'DOP853')!r}")
        raise ValueError(f"zeta * t_end = {zeta * t_end:.3g} (zeta={zeta!r}, t_end={t_end!r}) is above "
                         f"{span:.0e} for {which}: overdamped, its work grows with the fast decay "
                         "rate ~2 zeta (a creeping piece can span the run, minutes, without a Ctrl-C check); "
                         "use backend='scipy' with method='Radau' (implicit: its steps follow the slow creep), "
                         "or a shorter t_end")
    if backend == "heyoka" and len(osc.terms) > MAX_HEYOKA_TERMS:
        alternative = "backend='exact' (closed forms, no compile) or " if osc.linear else ""
        raise ValueError(f"the member has {len(osc.terms)} forcing terms (the fundamental and "
                         f"{len(osc.harmonics)} harmonics), more than the {MAX_HEYOKA_TERMS} backend='heyoka' "
                         "compiles an integrator for: its compile time grows faster than linearly (8 s for 30 "
                         f"terms, 35 s for 60, over 2 minutes for 200); use {alternative}backend='scipy'")
