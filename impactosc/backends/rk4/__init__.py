"""rk4 backend: the paper's method, a fixed-step classic Runge-Kutta scheme on eq. 3.

This is the baseline the event-driven backends are measured against, reproduced as the
paper describes it (section 5: "using the fourth order Runge Kutta method, we solved
Eq. (3)"), errors included:

* one fixed step ``dt`` for the whole run (default: 100 steps per contact period
  ``2 pi / sqrt(1 + K)``); only the last step is shortened so that the run ends exactly
  at ``t_end``;
* the friction term is the naive ``beta * sign(V)`` (``np.sign``: 0 at ``V == 0``).
  There is **no stick logic**, so ``stick`` and ``release`` events never occur with this
  backend. Where the exact solution sticks, the mass does not stop. At fine steps (the
  default) the RK4 stages straddle ``V = 0`` inside every step while the step ends keep
  one sign of ``V``, with ``|V| ~ beta dt``: the "stuck" mass creeps at that spurious
  speed and no reversal is seen. At coarse steps ``V`` changes sign at step ends and the
  chatter shows up as spurious reversals;
* the flange springs are switched by ``|X| > 1`` inside the right-hand side, with **no
  event location**: a step that crosses a flange integrates across the kink of the force.

The model family: the scheme integrates every member that its smooth
right-hand side can express, viscous damping ``2 zeta X'``, any sum of forcing harmonics
and the power-law flange ``K d^p`` (``d = |X| - 1``), with the same fixed step and the same
naive ``sign(V)``. It refuses, with a ``ValueError``, what needs the event location it does
not have: a rigid flange (an impact is an instantaneous reset at ``|X| = 1``), a static
friction level ``beta_static > beta`` (only the stick logic could tell the static from the
kinetic level) and ``sample_at`` (time events).

``flange="consistent"`` (default) uses the two-sided spring ``-K (X - sgn X) [|X| > 1]``
(``sgn X K d^p`` for a power law) of :class:`impactosc.Oscillator`. ``flange="paper"``
integrates eq. 2/3 as printed, ``-K H(X^2 - 1)(X - 1)`` at both flanges (a linear law
only: the misprint has no power-law form). At the upper flange the two agree. At the lower
flange the printed term is ``-K (X - 1) = K (1 + |X|) >= 2K`` for ``X < -1``: the force
jumps from 0 to ``2K`` at ``X = -1`` and points up, out of the lower flange. The lower
flange becomes a discontinuous wall of strength about ``2K`` that stops the mass within a fraction
of one step, so the fixed-step scheme gives the mass a spurious kick each time it
reaches ``X = -1`` (see the tests for what that does to the contact statistics).

Events are not located, they are *reconstructed* from sign changes between consecutive
steps: ``contact_start``/``contact_end`` from sign changes of ``|X| - 1`` (side by the
sign of ``X``), ``reversal`` from sign changes of ``V`` (a sample with ``V == 0`` exactly
counts once: the reversal is placed at that sample). Times, ``X`` and ``V`` at an event
come from linear interpolation between the two samples; contact events are reported at
``X = +-1``, which is what that interpolation gives.

Statistics are streamed in the compiled loop, so ``record="stats"`` needs O(1) memory
however long the run: per flange, the impulse ``int f dLambda`` and ``int f^2 dLambda``
of the *sampled* flange force ``f`` (the trapezoid rule with its endpoint correction,
i.e. the integral of the cubic Hermite interpolant built from ``f`` and ``f' = +-K p d^(p-1) V``
at the samples; a step that crosses a flange contributes only its in-contact part, cut at
the interpolated crossing), the contact time, the deepest sampled penetration, the
forcing work ``int V f(Lambda)`` (trapezoid rule), the path length of the sampled ``X``
(for the friction work) and, beyond eq. 3, ``int V^2`` (for the damping loss
``2 zeta int V^2``: RK4's own quadrature of ``q' = V^2`` carried along the stages, fourth
order). Eq. 3 runs use a kernel compiled without the family terms (see ``_family_args``),
which keeps their arithmetic and their speed exactly as they were. With
``flange="paper"`` the statistics use the force the integrated equation actually applies
(``K (|X| + 1)`` at the lower flange).
Peak penetrations are the deepest *sample* of each contact (low by up to
``(omega dt)^2 / 8`` relative, 5e-4 at the default step).

numba is an optional dependency (``pip install impactosc[fast]``). Without it the same
loop runs as plain Python, some hundred times slower, and a warning says so once.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..._util import validation as _v
from ..._util.jit import INSTALL_HINT
from ...engine._driver import check_run_arguments, initial_mode
from ...model._oscillator import Oscillator
from ...results._solution import Solution, _Recorder
from . import _args as _rk4_args
from ._args import FLANGE_OPTIONS, _check_dt, _family_args, _flange_jump, _refuse_unsupported, default_dt
from ._batch import BatchResult, _batch_family, _batch_flange_jump, _batch_harmonics, _batch_sets, _batch_steps
from ._kernels import _BUFFER_FULL, _EVENT_BUFFER, _HAVE_NUMBA, _I_STATUS, _batch_kernel, _init_state, _kernel
from ._solution import _attach_trajectory, _drain_buffers, _finish_record, _trajectory_buffers

# The implementation lives in private modules, one per responsibility: rk4._kernels (the
# compiled loop), _args (the step, flange law and family terms), _solution (kernel
# buffers -> Solution, dense output) and _batch (the batch's sets and result). This
# module keeps the public entry points and the switches below, which tests patch here.

__all__ = ["run", "rk4_batch", "BatchResult", "default_dt", "FLANGE_OPTIONS", "MAX_STEPS"]

# Documented here, where they are public (the API pages read these comments).
#: Steps per contact period ``2 pi / sqrt(1 + K)`` used when ``dt`` is not given.
STEPS_PER_CONTACT_PERIOD = _rk4_args.STEPS_PER_CONTACT_PERIOD
#: A run needing more steps than this is refused: at ~6e7 steps/s (measured) it would
#: take more than half a minute per run, and a stored trajectory would need >80 GB.
MAX_STEPS = _rk4_args.MAX_STEPS

_warned_slow = False


def _warn_if_slow() -> None:
    global _warned_slow
    if not _HAVE_NUMBA and not _warned_slow:
        _warned_slow = True
        warnings.warn("numba is not installed: the rk4 backend runs its fixed-step loop in plain Python, "
                      f"some hundred times slower; {INSTALL_HINT} compiles it", RuntimeWarning, stacklevel=3)


#: Kernels used by run() and rk4_batch(); module attributes so that the plain-Python
#: fallback can be exercised in tests where numba is installed.
_KERNEL = _kernel
_INIT_STATE = _init_state
_BATCH_KERNEL = _batch_kernel


# -- public entry points -------------------------------------------------------------------
# -- public entry points -------------------------------------------------------------------
def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int, sample_at=(),
        dt: float | None = None, flange: str = "consistent", every: int = 1) -> Solution:
    """Integrate ``osc`` with the paper's fixed-step RK4 scheme (see the module docstring).

    Parameters
    ----------
    osc : Oscillator
        The model.
    t_end : float
        End time (> 0).
    x0, v0 : float
        Initial state.
    record : {"full", "events", "stats"}
        What to keep. ``"full"`` keeps every ``every``-th step for :meth:`Solution.sample`
        (cubic Hermite interpolation from the stored ``X``, ``V`` and the acceleration);
        ``"stats"`` streams the statistics in O(1) memory.
    max_events : int
        Stop with status 1 at the ``max_events``-th reconstructed event; the statistics
        then run to that event's time.
    dt : float, optional
        Fixed step (finite, > 0, <= ``t_end``). Default: ``2 pi / (100 sqrt(1 + K))``,
        100 steps per contact period. The last step is shortened to land on ``t_end``.
    flange : {"consistent", "paper"}
        ``"consistent"``: the two-sided spring ``-K (X - sgn X) [|X| > 1]`` (``K d^p`` for a
        power law); ``"paper"``: eq. 2/3 as printed, ``-K H(X^2 - 1)(X - 1)`` at both
        flanges (linear law only).
    every : int, optional
        With ``record="full"``, keep every ``every``-th step (default 1: all of them).

    Returns
    -------
    Solution
        With events ``contact_start``, ``contact_end`` and ``reversal`` only: the naive
        ``sign(V)`` has no stick logic, so ``stick``/``release`` never occur.

    Raises
    ------
    ValueError
        For a bad ``dt`` (not finite, <= 0, > ``t_end``, or more than ``MAX_STEPS`` steps),
        an unknown ``flange`` (or ``"paper"`` with a power law) or a bad ``every``, and for
        what needs event location: ``sample_at`` (time events), a rigid flange, and static
        friction ``beta_static > beta`` (stick logic).
    """
    osc, t_end, x0, v0, max_events = check_run_arguments(osc, t_end, x0, v0, max_events)
    # The kernel counts in int64; a larger limit can never be reached anyway.
    kernel_max_events = min(max_events, np.iinfo(np.int64).max)
    _v.choice("record", record, ("full", "events", "stats"))
    _refuse_unsupported(osc, sample_at)
    jlo = _flange_jump(flange, osc.K, osc.exponent)
    if jlo and not osc.symmetric:
        raise ValueError("flange='paper' (eq. 2/3 as printed, -K H(X^2 - 1)(X - 1)) has its flanges at |X| = 1, got "
                         f"gap_lower={osc.gap_lower!r}, gap_upper={osc.gap_upper!r}; use flange='consistent'")
    dt, n_steps = _check_dt(dt, t_end, osc.K)
    every = _v.integer("every", every, minimum=1)
    _warn_if_slow()

    mode0 = initial_mode(osc, 0.0, x0, v0)
    S, I = _INIT_STATE(x0, v0, mode0.region, osc.gap_upper, osc.gap_lower)
    # The paper's flanges at |X| = 1 compile without the positions (None), as before.
    gaps = None if osc.symmetric else (osc.gap_upper, osc.gap_lower)
    keep_events = record != "stats"
    tr = _trajectory_buffers(record == "full", n_steps, every, x0, v0, I)
    cap = _EVENT_BUFFER if keep_events else 0
    ev = np.empty((cap, 6))
    imp = np.empty((cap, 9))

    rec = _Recorder(record, "rk4", None)
    rec.begin(osc, 0.0, x0, v0, mode0)
    impacts: list[tuple] = []
    harm, damp, p = _family_args(np.array(osc.harmonics, dtype=float).reshape(-1, 3).T, osc.zeta, osc.exponent)
    # The kernel returns when its event buffers are nearly full; drain them and resume.
    while True:
        _KERNEL(osc.F, osc.Omega, osc.phase, harm, osc.beta, damp, osc.K, p, jlo, dt, t_end, n_steps, S, I,
                ev, imp, keep_events, tr[0], tr[1], tr[2], tr[3], tr[4], every, kernel_max_events, gaps)
        _drain_buffers(rec, impacts, ev, imp, I)
        if I[_I_STATUS] != _BUFFER_FULL:
            break
    _finish_record(rec, osc, jlo, S, I, impacts, keep_events, max_events, dt)
    if record == "full":
        _attach_trajectory(rec, osc, jlo, tr, I)
    return Solution(rec, t_end)


def rk4_batch(F, Omega, beta, K, phase=0.0, t_end=400.0, x0=0.95, v0=0.0, dt=None,
              flange: str = "consistent", *, zeta=0.0, exponent=1.0, harmonics=()) -> BatchResult:
    """Run the RK4 baseline for many parameter sets at once, statistics only.

    Every argument except ``flange`` may be an array; they are broadcast together and the
    sets run in parallel (numba ``prange``) through the same compiled loop as :func:`run`,
    so each set gives bit for bit what ``simulate(..., backend="rk4", record="stats")``
    gives for it.

    Parameters
    ----------
    F, Omega, beta, K, phase : float or array_like
        Model parameters (see :class:`impactosc.Oscillator`).
    t_end, x0, v0 : float or array_like
        End time (> 0) and initial state.
    dt : float, array_like or None
        Fixed step; None (or NaN entries in an array) selects the default per set.
    flange : {"consistent", "paper"}
        Flange force law (see :func:`run`; ``"paper"`` needs ``exponent == 1`` in every set).
    zeta, exponent : float or array_like, keyword-only
        Viscous damping ratio (>= 0) and flange exponent ``p >= 1`` (see :class:`impactosc.Oscillator`).
    harmonics : sequence of tuple, keyword-only
        Further forcing harmonics ``(F_i, Omega_i, phase_i)``, the same number in every set; each entry of a triple
        may be an array broadcast with the other arguments.

    Returns
    -------
    BatchResult
        Mean flange force per flange over the run (units of ``k L``), contact counts per
        flange, deepest sampled penetration per flange and the status (0: reached ``t_end``,
        -1: non-finite state), each of the broadcast shape.

    Raises
    ------
    ValueError
        For a parameter out of its range in any set (the message names it), and for
        ``flange="paper"`` with a power law. Rigid flanges and static friction are not
        parameters here: the fixed-step scheme cannot express them (see :func:`run`).
    """
    _v.choice("flange", flange, FLANGE_OPTIONS)
    terms = _batch_harmonics(harmonics)
    sets = _batch_sets(F, Omega, beta, K, phase, t_end, x0, v0, dt, zeta, exponent, terms)
    jlo = _batch_flange_jump(flange, sets)
    dt, n_steps, region = _batch_steps(sets)
    _warn_if_slow()
    n = sets.F.shape[0]
    out_f = [np.empty(n) for _ in range(2)]
    out_n = [np.empty(n, dtype=np.int64) for _ in range(2)]
    out_p = [np.empty(n) for _ in range(2)]
    status = np.empty(n, dtype=np.int64)
    harm, damp, p = _batch_family(sets, len(terms))
    _BATCH_KERNEL(sets.F, sets.Om, sets.phase, harm, sets.beta, damp, sets.K, p, jlo, dt, sets.t_end, n_steps,
                  sets.x0, sets.v0, region, out_f[0], out_f[1], out_n[0], out_n[1], out_p[0], out_p[1], status)
    return BatchResult(*(a.reshape(sets.shape) for a in (*out_f, *out_n, *out_p, status)))
