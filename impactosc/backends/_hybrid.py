"""``simulate`` for a user's :class:`~impactosc.HybridSystem`: the backend by name."""

from __future__ import annotations

from .._util import validation as _v

__all__ = ["simulate_system", "SYSTEM_BACKENDS"]

#: The backends that run a user's system.
SYSTEM_BACKENDS = ("heyoka", "scipy")


def simulate_system(system, t_end: float, state0, v0: float = 0.0, *, backend: str = "heyoka", record: str = "full",
                    sample_at=None, **options):
    """Run a user's hybrid system from ``state0`` at ``t0`` (default 0) to ``t_end``.

    Parameters
    ----------
    system : HybridSystem
    t_end : float
    state0 : sequence of float
        One value per state, in the system's order (the integrals start at 0).
    v0, record, sample_at
        :func:`impactosc.simulate`'s arguments for the built-in oscillator: a user system
        refuses anything but their defaults (``0.0``, ``"full"``, ``None``) with a message.
    backend : {"heyoka", "scipy"}
        ``"heyoka"``: one compiled Taylor integrator per system, guards located on each
        step's Taylor polynomial, transitions in event callbacks. ``"scipy"``: one
        ``solve_ivp`` per smooth piece with the guards as events: the independent cross-check.
    **options
        ``mode`` (the initial mode's name; default the first whose entry conditions hold),
        ``t0``, ``max_events``, ``zeno_tol`` (an accumulation is declared when the time left
        to it is below ``zeno_tol (1 + |t|)``, default 1e-6), ``graze_tol`` (a guard's
        extremum within ``graze_tol (1 + max |y|)`` of zero is a grazing, default 1e-10),
        ``until=(guard, k)`` (end the run right after the ``k``-th event of ``guard``: a
        return to a Poincare section; status 0 and a message that says so),
        ``touch_tol`` (a state within ``touch_tol (1 + max |y|)`` of a guard it crosses
        fires it at once, default 1e-12), ``cooldown`` (how long a guard is ignored after it
        fired, default 1e-12 time units); heyoka: ``tol`` (in [1e-18, 1e-2], default machine
        epsilon), ``max_wall_time`` (seconds; the run stops there with status 1 and keeps what it
        computed, the clock read every 10,000 steps); scipy: ``method`` (default DOP853), ``rtol``,
        ``atol`` (default 1e-12), ``max_step`` (default a 32nd of the forcing period, unbounded
        without one: ``solve_ivp`` sees a guard only at its step ends, and in a mode where the
        state is constant its steps grow without bound, so a guard that moves with the time
        alone needs it).

    Returns
    -------
    HybridSolution

    Examples
    --------
    A mode in which every state's rate is zero (a mass stuck by friction) is *frozen*: with a
    forcing period, a whole period there without an event means none ever comes, and both loops
    jump to the last whole period before ``t_end`` (the integrals moved on by whole periods), so
    a mass stuck for ever costs about two periods of steps, whatever ``t_end``.

    The bouncing ball stops at its Zeno time ``sqrt(2 h / g) (1 + 2 e / (1 - e))``:

    >>> import impactosc
    >>> from impactosc import Guard, HybridMode, HybridSystem, symbols
    >>> x, v, g, e = symbols("x v g e")
    >>> ball = HybridSystem("x v", {"g": 9.81, "e": 0.8}, [HybridMode("flight", {x: v, v: -g})],
    ...                     [Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})])
    >>> sol = impactosc.simulate(ball, 10.0, [1.0, 0.0])
    >>> sol.status, round(sol.accumulation_time, 12)
    (2, 4.063712768872)

    A mass held by dry friction against a weak harmonic force never moves: its stick mode is
    frozen, and the run to ``t = 1e12`` jumps over whole forcing periods:

    >>> import heyoka as hy
    >>> from impactosc import stick_slip
    >>> A, w, mu = symbols("A w mu")
    >>> modes, guards = stick_slip("m", v, A * hy.cos(w * hy.time) - x, mu, rates={x: v})
    >>> stuck = HybridSystem("x v", {"A": 0.1, "w": 0.5, "mu": 0.5}, modes, guards, period=6.283185307179586 / w)
    >>> sol = impactosc.simulate(stuck, 1e12, [0.0, 0.0])
    >>> sol.status, sol.t_final, sol.mode_final, len(sol.events)
    (0, 1000000000000.0, 'm0', 0)
    """
    _v.choice("backend", backend, SYSTEM_BACKENDS)
    # simulate()'s arguments for the built-in oscillator that a user system does not take: refused, not ignored
    if v0 != 0.0:
        raise TypeError(f"v0={v0!r}: a user system takes its whole initial state in state0 (one value per state "
                        f"{list(system.states)}), not a separate velocity")
    if record != "full":
        raise ValueError(f"record={record!r}: a user system's run keeps every event (record='full' only)")
    if sample_at is not None:
        raise TypeError("sample_at is not available for a user system: use HybridSolution.sample(times) after the run")
    if backend == "heyoka":
        from . import _hybrid_heyoka as loop
    else:
        from . import _hybrid_scipy as loop  # type: ignore[no-redef]
    try:
        return loop.run_system(system, t_end, state0, **options)
    except TypeError as exc:
        if "unexpected keyword argument" in str(exc):
            raise TypeError(f"backend {backend!r} does not accept that option for a user system: {exc}") from None
        raise
