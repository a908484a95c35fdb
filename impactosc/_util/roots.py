"""The exact backend's root finder: rigorous brackets, then safeguarded Newton to an ulp.

Written once in compilable Python (:mod:`impactosc._jit`): the closed-form pieces
(:mod:`._exact_piece`, :mod:`._exact_family`) and the stuck releases
(:mod:`impactosc._stuck`) call ``first_rising_jit`` and ``refine_jit``, compiled copies
inlined into each caller with its own guard function ``fun(state, tau) -> (h, h')``. Without
numba they are :func:`first_rising` and :func:`refine` themselves, run as Python.

Bracketing
----------
On ``[a, b]`` a function with ``|h''| <= M2`` stays within ``M2 (b - a)^2 / 8`` of its
chord, which excludes intervals of one sign, and ``|h'''| <= M3`` applied to ``h'`` proves
monotonicity, so a bracket holds a single crossing. Near a double root (a tangency) the
bisection goes on until the extremum separates the two crossings; only below ``hmin`` (a
few ulps of ``t``), or where ``h`` cannot leave its rounding level (:func:`decide`), do the
end values decide.
"""

from __future__ import annotations

import math

from .jit import njit_inline

__all__ = ["decide", "first_rising", "refine", "refine_from", "decide_jit", "first_rising_jit", "refine_jit",
           "refine_from_jit", "MAX_BRACKET_STEPS", "SEARCH_FAILED", "BISECT", "NO_CROSSING", "CROSSING"]

_EPS = 2.0**-52
#: Intervals one guard search may examine in one window: a few hundred are typical (a
#: tangency bisected down to ulps takes ~100 per level); far more means useless bounds.
MAX_BRACKET_STEPS = 100_000
#: ``status`` of :func:`first_rising` when the search gave up (non-finite values or bounds,
#: or :data:`MAX_BRACKET_STEPS` intervals): never a hang, the run ends with status -1.
SEARCH_FAILED = 1


#: Outcomes of :func:`decide` on one interval: bisect it, it holds no crossing, it brackets one.
BISECT, NO_CROSSING, CROSSING = 0, 1, 2


def decide(ha, hb, da, db, slack2, slack3, width, hmin, noise=0.0):
    """What an interval ``[a, b]`` of the bracketing holds: :data:`BISECT`, :data:`NO_CROSSING` or :data:`CROSSING`.

    ``ha, hb`` and ``da, db``: ``h`` and ``h'`` at its ends; ``slack2`` and ``slack3``: how far
    ``h`` and ``h'`` can stray from their chords on it (``M2 w^2 / 8`` and ``M3 w^2 / 8`` with
    bounds ``M2``, ``M3`` of the second and third derivative, or any tighter bound); ``width = b - a``;
    ``noise``: a bound of the rounding of the computed ``h`` on it (0 when not known).
    ``h`` of one sign beyond the slack holds no crossing; ``h'`` of one sign beyond its slack
    makes ``h`` monotonic, with a crossing from negative to non-negative exactly when
    ``ha < 0 <= hb``. Below the resolution of the computed ``h`` its end values decide, by
    that same rule: on an interval at most ``hmin`` wide (the resolution in ``t``), and on one
    where ``|h| <= max(|ha|, |hb|) + slack2 <= noise`` (the resolution in ``h``: the guard
    stays within its rounding of zero all over it, so no sign the computed values could show
    there means anything; e.g. a start at rest where the force turns at second order with a
    curvature far below rounding, whose bisection down to ``hmin`` would take some ``2^50``
    steps). The one decision of every bracketing (the 1-DOF pieces, the stuck releases, the
    n-DOF guards).
    """
    if ha >= 0.0 and hb >= 0.0 and min(ha, hb) > slack2:
        return NO_CROSSING  # h > 0 on [a, b]
    if ha < 0.0 and hb < 0.0 and max(ha, hb) < -slack2:
        return NO_CROSSING  # h < 0 on [a, b]
    if min(da, db) > slack3:  # h increasing: one crossing at most
        return CROSSING if ha < 0.0 <= hb else NO_CROSSING
    if max(da, db) < -slack3:  # h decreasing: it cannot rise through 0
        return NO_CROSSING
    if width <= hmin or max(abs(ha), abs(hb)) + slack2 <= noise:
        return CROSSING if ha < 0.0 <= hb else NO_CROSSING
    return BISECT


#: The compiled copy of :func:`decide`, inlined into its compiled callers.
decide_jit = njit_inline(decide)


def first_rising(fun, state, a, ha, da, b, M2, M3, hmin, noise_at0=0.0, noise_rate=0.0, noise_cap=0.0):
    """First crossing of ``h`` from negative to non-negative in ``(a, b]``.

    ``fun(state, tau) -> (h, h')``; ``ha, da`` are its values at ``a``; ``M2 >= |h''|`` and
    ``M3 >= |h'''|`` on ``[a, b]``. The rounding of the computed ``h`` at offsets up to ``tau``
    is at most ``min(noise_cap, noise_at0 + noise_rate tau)`` (the ``noise`` of :func:`decide`;
    all 0 when not known): a local bound, so that a guard that starts on zero is resolved as
    finely near its start as its values allow there. Returns ``(found, lo, hi, h(lo), h(hi), h(b), h'(b), status)``:
    when ``found``, ``[lo, hi]`` brackets the crossing with ``h`` monotonic on it; the values
    at ``b`` start the next window. The right ends of the still unexplored intervals sit on
    a stack, so intervals are examined strictly left to right and the first crossing is the
    one returned.
    """
    hb, db = fun(state, b)
    end_h, end_d = hb, db
    stack = [(b, hb, db)]
    evaluations = 0
    while len(stack) > 0:
        b, hb, db = stack[-1]
        width = b - a
        evaluations += 1
        if evaluations > MAX_BRACKET_STEPS or not math.isfinite(ha + hb + da + db + M2 + M3):
            # Never a hang: non-finite values or bounds would send the bisection down to
            # ulp-wide intervals over the whole window.
            return False, a, b, ha, hb, end_h, end_d, SEARCH_FAILED
        # max distances of h and h' from their chords
        noise = min(noise_cap, noise_at0 + noise_rate * b)
        outcome = decide_jit(ha, hb, da, db, 0.125 * M2 * width * width, 0.125 * M3 * width * width, width, hmin,
                             noise)
        if outcome == CROSSING:
            return True, a, b, ha, hb, end_h, end_d, 0
        if outcome == NO_CROSSING:
            stack.pop()
            a, ha, da = b, hb, db
        else:
            mid = a + 0.5 * width
            hm, dm = fun(state, mid)
            stack.append((mid, hm, dm))
    return False, a, a, ha, ha, end_h, end_d, 0


def refine_from(fun, state, lo, hi, x, t0):
    """Root of ``h = fun(state, tau)[0]`` in a bracket where it rises through 0, from the start ``x``.

    Safeguarded Newton: a Newton step is taken when it stays inside the shrinking bracket
    and converges fast enough, a bisection otherwise, so the iteration is as robust as
    bisection and converges quadratically near the root. It stops when the step is below
    one ulp of ``t0 + tau``. A start outside ``(lo, hi)`` is replaced by the midpoint.
    """
    tol = _EPS * (abs(t0) + hi)
    if not lo < x < hi:
        x = 0.5 * (lo + hi)
    dx_old = hi - lo
    for _ in range(200):  # bisection alone needs < 1100 halvings from any float bracket; Newton far fewer
        h, dh = fun(state, x)
        if h == 0.0:
            return x
        if h < 0.0:
            lo = x
        else:
            hi = x
        if dh > 0.0:
            step = h / dh
            if abs(step) <= tol:  # converged: the last Newton correction is below one ulp
                return min(max(x - step, lo), hi)
            xn = x - step
        else:
            xn = math.nan
        if lo < xn < hi and abs(2.0 * h) <= abs(dx_old * dh):
            dx = x - xn
        else:
            xn = 0.5 * (lo + hi)
            dx = hi - lo
        dx_old = dx
        if abs(dx) <= tol:
            return xn
        x = xn
    return x


#: The compiled copy of :func:`refine_from`, inlined into its compiled callers.
refine_from_jit = njit_inline(refine_from)


def refine(fun, state, lo, hi, hlo, hhi, t0):
    """Root of ``h = fun(state, tau)[0]`` in a bracket where it rises through 0 (``hlo < 0 <= hhi``):
    :func:`refine_from` from the regula falsi point."""
    if hhi == 0.0:
        return hi
    x = lo - hlo * (hi - lo) / (hhi - hlo)  # regula falsi start
    return refine_from_jit(fun, state, lo, hi, x, t0)


#: The compiled copies, inlined into compiled callers (see :func:`impactosc._jit.njit_inline`).
first_rising_jit = njit_inline(first_rising)
refine_jit = njit_inline(refine)
