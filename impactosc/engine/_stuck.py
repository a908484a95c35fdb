"""A stuck mass in closed form: when it is released, and the integrals while it waits.

While the mass is stuck (``V = 0``, ``|f_net| <= beta_s``) the state is frozen and only the
forcing moves. The release guards ``f_net -+ beta_s`` (see :mod:`impactosc.engine`) then
reduce to ``forcing(t) = spring(x) +- beta_s``. With one harmonic that is an arccos: no
backend needs to step through a stuck phase, however long (``F < beta_s`` keeps the mass
stuck for ever and costs one evaluation). With a sum of harmonics the first crossing is
bracketed by the rigorous derivative bounds of the exact backend's root finder, window by
window; when every frequency is an integer multiple of the lowest, one period without a
crossing proves there is none. This is model physics shared by every event-locating
backend (heyoka, scipy and exact call it for every stuck piece).
"""

from __future__ import annotations

import math

import numpy as np

from .._util.jit import njit
from .._util.roots import SEARCH_FAILED
from .._util.roots import first_rising_jit as first_rising
from .._util.roots import refine_jit as refine
from ..model._oscillator import Oscillator
from ..model._rule import GUARD_DIRECTIONS, NO_GUARD, P_TERMS, RELEASE_DOWN, RELEASE_UP
from ._driver import Mode, guard_gates

__all__ = ["release_time", "advance_stuck", "evaluate_stuck"]

_EPS = 2.0**-52
_TWO_PI = 2.0 * math.pi


def release_time(osc: Oscillator, region: int, t0: float, x: float, t_end: float,
                 gates) -> tuple[float, int]:
    """First release after ``t0`` of a mass stuck at ``x`` in ``region``, or ``t_end``.

    Solves ``F cos(Omega t + phase) - spring(x) = +-beta`` for the armed release guards
    (``gates``, in the order of :data:`impactosc.engine.GUARD_NAMES`), with the crossing
    direction of :data:`impactosc.engine.GUARD_DIRECTIONS`. A tangency (``|level| = F``)
    is no crossing; a constant force (``F = 0`` or ``Omega = 0``) never releases.

    Returns
    -------
    (t1, guard)
        The release time and guard, or ``(t_end, NO_GUARD)`` if the mass stays stuck.
    """
    if osc.constant_forcing:
        return t_end, NO_GUARD
    x = float(x)  # a NumPy scalar from an integrator would warn where a float gives inf
    # The restoring force in f_net: the spring of the mode's region (none for a rigid wall).
    spring = x + region * osc._region_force_scalar(x, region)
    if osc.harmonics:
        return _release_time_sum(osc, t0, t_end, spring, gates)
    return release_one_harmonic(osc.F, osc.Omega, osc.phase, osc.beta_s, spring,
                                bool(gates[RELEASE_UP]), bool(gates[RELEASE_DOWN]), t0, t_end)


@njit
def release_one_harmonic(F, Om, phase, beta, spring, up, down, t0, t_end):
    """:func:`release_time` for one harmonic ``F cos(Omega t + phase)``: an arccos, polished.

    ``up`` and ``down`` say which release guards are armed; ``spring`` is the restoring
    force in ``f_net`` at the stuck position. Compiled (:mod:`impactosc._jit`): the exact
    backend's event loop calls it too.
    """
    th0 = (Om * t0 + phase) % _TWO_PI
    best_t, best_guard = math.inf, NO_GUARD
    for guard in (RELEASE_UP, RELEASE_DOWN):
        if not (up if guard == RELEASE_UP else down):
            continue
        offset = beta if guard == RELEASE_UP else -beta
        q = (spring + offset) / F
        if not -1.0 < q < 1.0:
            continue  # |q| >= 1: never reached, or only touched (a tangency is no crossing)
        alpha = math.acos(q)
        # Rising f_net (up) needs sin(theta) < 0, falling f_net (down) sin(theta) > 0;
        # GUARD_DIRECTIONS holds exactly these orientations.
        target = -alpha if GUARD_DIRECTIONS[guard] > 0 else alpha
        dtheta = (target - th0) % _TWO_PI
        t1 = t0 + dtheta / Om
        if not t1 < t_end:  # beyond the run (or inf for a subnormal Omega): nothing to polish
            continue
        t1 = _polish(F, Om, phase, t1, t0, spring + offset)
        if t1 < best_t:
            best_t, best_guard = t1, guard
    if best_t >= t_end:
        return t_end, NO_GUARD
    return best_t, best_guard


def _release_time_sum(osc: Oscillator, t0: float, t_end: float, spring: float, gates) -> tuple[float, int]:
    """:func:`release_time` for a sum of harmonics (:func:`release_sum`, compiled)."""
    t1, guard, status = release_sum(osc._p, spring, osc.beta_s, bool(gates[RELEASE_UP]),
                                    bool(gates[RELEASE_DOWN]), t0, t_end)
    if status:
        raise FloatingPointError(f"the release search of the mass stuck from t={t0!r} did not converge")
    return t1, guard


@njit
def _h_release(st, tau):
    """``d (forcing(t0 + tau) - level)`` and its derivative; ``st`` holds
    ``[t0, d, const - level, n, (F_i, Omega_i, phase_i) of the n waves]``."""
    t = st[0] + tau
    f = st[2]
    df = 0.0
    for i in range(int(st[3])):
        j = 4 + 3 * i
        F, Om, ph = st[j], st[j + 1], st[j + 2]
        th = Om * t + ph
        f += F * math.cos(th)
        df -= F * Om * math.sin(th)
    d = st[1]
    return d * f, d * df


@njit
def release_sum(p, spring, beta_s, up, down, t0, t_end):
    """First release of a stuck mass forced by a sum of harmonics: ``(t1, guard, status)``.

    The crossings of ``forcing(t) = spring +- beta_s`` are bracketed by the exact backend's
    rigorous root finder (:mod:`impactosc.backends._exact_roots`), window by window (one
    period of the fastest wave); when every frequency is an integer multiple of the
    lowest, one period without a crossing proves there is none. ``status`` is
    ``SEARCH_FAILED`` when a search gave up. Compiled (:mod:`impactosc._jit`).
    """
    n_all = (p.shape[0] - P_TERMS) // 3
    st = np.zeros(4 + 3 * n_all)
    const = amplitude = m2 = m3 = 0.0
    slowest, fastest = math.inf, 0.0
    n = 0
    for i in range(n_all):
        F, Om, ph = p[P_TERMS + 3 * i], p[P_TERMS + 3 * i + 1], p[P_TERMS + 3 * i + 2]
        if not F > 0.0:
            continue
        if Om == 0.0:
            const += F * math.cos(ph)
            continue
        j = 4 + 3 * n
        st[j], st[j + 1], st[j + 2] = F, Om, ph
        n += 1
        amplitude += F
        m2 += F * Om**2
        m3 += F * Om**3
        slowest, fastest = min(slowest, Om), max(fastest, Om)
    periodic = True
    for i in range(n):
        ratio = st[4 + 3 * i + 1] / slowest
        if not (math.isfinite(ratio) and abs(ratio - round(ratio)) <= 1e-12 * ratio):
            periodic = False
    horizon = t_end - t0
    if periodic:  # no crossing within one period of the slowest harmonic: none ever
        horizon = min(horizon, 2.0 * math.pi / slowest * (1.0 + 1e-12) + 2.0 * math.pi / fastest)
    window = 2.0 * math.pi / fastest
    st[0], st[3] = t0, float(n)
    best_t, best_guard = math.inf, NO_GUARD
    for guard in (RELEASE_UP, RELEASE_DOWN):
        level = spring + beta_s if guard == RELEASE_UP else spring - beta_s
        if not (up if guard == RELEASE_UP else down) or abs(level - const) >= amplitude:
            continue  # never reached (a tangency at |level| = amplitude is no crossing)
        st[1], st[2] = float(GUARD_DIRECTIONS[guard]), const - level
        a = 0.0
        ha, da = _h_release(st, 0.0)
        while a < horizon and t0 + a < best_t:
            b = min(horizon, a + window)
            hmin = 4.0 * _EPS * (abs(t0) + b)
            found, lo, hi, hlo, hhi, hb, db, status = first_rising(_h_release, st, a, ha, da, b, m2, m3, hmin)
            if status == SEARCH_FAILED:
                return t0, NO_GUARD, status
            if found:
                t1 = t0 + refine(_h_release, st, lo, hi, hlo, hhi, t0)
                if t1 < best_t:
                    best_t, best_guard = t1, guard
                break
            a, ha, da = b, hb, db
    if best_t >= t_end:
        return t_end, NO_GUARD, 0
    return best_t, best_guard, 0


@njit
def _polish(F, Om, phase, t, t0, level):
    """Newton steps on ``F cos(Omega t + phase) - level`` as the engine evaluates it.

    The arccos is exact in phase, but ``Omega t + phase`` is rounded when the engine and
    the integrating backends evaluate the forcing; two Newton steps put the release on
    the root of that rounded function. Steps larger than a phase error can explain (near
    a tangency, where the root is ill-conditioned anyway) are not taken.
    """
    for _ in range(2):
        th = Om * t + phase
        g = F * math.cos(th) - level
        dg = -F * Om * math.sin(th)
        if g == 0.0 or dg == 0.0:
            break
        step = g / dg
        if abs(step) * Om > 64.0 * _EPS * (abs(th) + 1.0) or t - step <= t0:
            break
        t -= step
    return t


def advance_stuck(osc: Oscillator, mode: Mode, t0: float, x: float, t_end: float):
    """A stuck piece from ``t0`` to its release or ``t_end``, as :meth:`engine.PieceStepper.advance`.

    Returns ``(t1, x, 0.0, guard, impulse, impulse_sq, 0.0, 0.0, 0)``: a mass stuck inside
    a spring flange keeps it compressed at a constant force (against a rigid wall the
    recorder integrates the wall's push), there is no forcing work or damping loss
    (``V = 0``) and no integrator step.
    """
    r = mode.region
    t1, guard = release_time(osc, r, t0, x, t_end, guard_gates(mode, osc.rigid))
    tau = t1 - t0
    force = osc._region_force_scalar(x, r)
    return t1, x, 0.0, guard, force * tau, force * force * tau, 0.0, 0.0, 0


def evaluate_stuck(osc: Oscillator, mode: Mode, t0: float, x: float, times):
    """``(X, V, impulse since t0)`` at ``times`` inside a stuck piece starting at ``(t0, x)``."""
    tau = np.asarray(times, dtype=float) - t0
    r = mode.region
    xs = np.full(tau.shape, x)
    vs = np.zeros(tau.shape)
    qs = osc._region_force_scalar(x, r) * tau
    return xs, vs, qs


# -- a mass resting against a rigid flange: the force the wall takes ----------------------
