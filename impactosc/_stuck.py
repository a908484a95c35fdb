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

from ._jit import njit
from ._rule import GUARD_DIRECTIONS, NO_GUARD, P_TERMS, RELEASE_DOWN, RELEASE_UP, forcing, forcing_derivatives
from .backends._exact_roots import SEARCH_FAILED
from .backends._exact_roots import first_rising_jit as first_rising
from .backends._exact_roots import refine_jit as refine
from .engine import Mode, guard_gates
from .model import Oscillator

__all__ = ["release_time", "advance_stuck", "evaluate_stuck", "wall_force_integrals"]

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
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)


@njit
def _h_push(st, tau):
    """``sign (side f_net(t0 + tau, side))`` and its rate; ``st = [t0, side, sign, p...]``."""
    t, side, sign = st[0] + tau, st[1], st[2]
    d1, _, _ = forcing_derivatives(st[3:], t)
    return sign * (side * forcing(st[3:], t) - 1.0), sign * side * d1


@njit
def _h_fall(st, tau):
    """``-side f_net'`` (rising through 0 at a maximum of the push) and its rate."""
    t, side = st[0] + tau, st[1]
    d1, d2, _ = forcing_derivatives(st[3:], t)
    return -side * d1, -side * d2


@njit
def _push(st, t):
    return st[1] * forcing(st[3:], t) - 1.0  # side * f_net at X = side (rigid: no spring)


@njit
def wall_force_integrals(p, side, t0, t1):
    """Force of a rigid flange on a mass resting against it over ``[t0, t1]`` (see the model).

    The wall takes the push ``P(t) = max(side * f_net(t, side), 0)``. Returns
    ``(int P dt, int P^2 dt, max P)``. The roots of the push are bracketed on a grid finer
    than a quarter period of the fastest harmonic and refined to an ulp
    (:func:`impactosc.backends._exact_roots.refine`), so each integral is over a smooth
    stretch (composite 16-node Gauss-Legendre); the maximum is taken at the ends and at the
    maxima of the push inside (roots of the forcing rate, refined the same way).
    """
    if not t1 > t0:
        return 0.0, 0.0, 0.0
    fastest = 0.0
    for i in range(P_TERMS, p.shape[0], 3):
        if p[i] > 0.0:
            fastest = max(fastest, p[i + 1])
    n = max(1, math.ceil((t1 - t0) * fastest / (0.25 * math.pi)))
    st = np.empty(3 + p.shape[0])
    st[0], st[1], st[2] = t0, float(side), 1.0
    st[3:] = p
    grid = np.linspace(t0, t1, n + 1)
    g = np.empty(n + 1)
    rate = np.empty(n + 1)
    for i in range(n + 1):
        g[i] = _push(st, grid[i])
        rate[i] = side * forcing_derivatives(p, grid[i])[0]
    cuts = np.empty(2 * n + 2)
    nc = 0
    cuts[nc] = t0
    nc += 1
    peak = max(0.0, g.max())
    for i in range(n):
        lo, hi = grid[i] - t0, grid[i + 1] - t0
        if g[i] * g[i + 1] < 0.0:
            st[2] = 1.0 if g[i] < 0.0 else -1.0  # refine wants h rising through 0
            cuts[nc] = t0 + refine(_h_push, st, lo, hi, st[2] * g[i], st[2] * g[i + 1], t0)
            nc += 1
        if 0 < i and g[i] == 0.0:  # a root on the grid itself
            cuts[nc] = grid[i]
            nc += 1
        if rate[i] > 0.0 and rate[i + 1] < 0.0:  # a maximum of the push inside
            top = t0 + refine(_h_fall, st, lo, hi, -rate[i], -rate[i + 1], t0)
            peak = max(peak, _push(st, top))
    cuts[nc] = t1
    nc += 1
    cuts = np.sort(cuts[:nc])
    total = total_sq = 0.0
    for c in range(nc - 1):
        a, b = cuts[c], cuts[c + 1]
        if not b > a:
            continue
        m = max(1, math.ceil((b - a) * fastest / math.pi))
        h = (b - a) / m
        for i in range(m):
            for j in range(_GL_NODES.shape[0]):
                val = max(_push(st, a + h * (i + 0.5 * (_GL_NODES[j] + 1.0))), 0.0)
                wj = 0.5 * h * _GL_WEIGHTS[j]
                total += wj * val
                total_sq += wj * (val * val)
    return total, total_sq, peak
