"""A stuck mass in closed form: when it is released, and the integrals while it waits.

While the mass is stuck (``V = 0``, ``|f_net| <= beta``) the state is frozen and only the
forcing moves. The release guards ``f_net -+ beta`` (see :mod:`impactosc.engine`) then
reduce to ``F cos(Omega t + phase) = spring(x) +- beta``, an arccos: no backend needs to
step through a stuck phase, however long (``F < beta`` keeps the mass stuck for ever and
costs one evaluation). This is model physics shared by every event-locating backend.
"""

from __future__ import annotations

import math

import numpy as np

from .engine import GUARD_DIRECTIONS, NO_GUARD, RELEASE_DOWN, RELEASE_UP, Mode, guard_gates
from .model import Oscillator

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
    F, Om, phase, beta = osc.F, osc.Omega, osc.phase, osc.beta
    if F == 0.0 or Om == 0.0:
        return t_end, NO_GUARD
    x = float(x)  # a NumPy scalar from an integrator would warn where a float gives inf
    spring = x + osc.K * (x - region) if region else x  # the restoring force in f_net
    th0 = (Om * t0 + phase) % _TWO_PI
    best_t, best_guard = math.inf, NO_GUARD
    for guard, offset in ((RELEASE_UP, beta), (RELEASE_DOWN, -beta)):
        if not gates[guard]:
            continue
        q = (spring + offset) / F
        if not -1.0 < q < 1.0:
            continue  # |q| >= 1: never reached, or only touched (a tangency is no crossing)
        alpha = math.acos(q)
        # Rising f_net (up) needs sin(theta) < 0, falling f_net (down) sin(theta) > 0;
        # GUARD_DIRECTIONS holds exactly these orientations.
        target = -alpha if GUARD_DIRECTIONS[guard] > 0 else alpha
        dtheta = (target - th0) % _TWO_PI
        t1 = _polish(osc, t0 + dtheta / Om, t0, spring + offset)
        if t1 < best_t:
            best_t, best_guard = t1, guard
    if best_t >= t_end:
        return t_end, NO_GUARD
    return best_t, best_guard


def _polish(osc: Oscillator, t: float, t0: float, level: float) -> float:
    """Newton steps on ``F cos(Omega t + phase) - level`` as the engine evaluates it.

    The arccos is exact in phase, but ``Omega t + phase`` is rounded when the engine and
    the integrating backends evaluate the forcing; two Newton steps put the release on
    the root of that rounded function. Steps larger than a phase error can explain (near
    a tangency, where the root is ill-conditioned anyway) are not taken.
    """
    F, Om, phase = osc.F, osc.Omega, osc.phase
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

    Returns ``(t1, x, 0.0, guard, impulse, impulse_sq, 0.0, 0)``: a mass stuck inside a
    flange keeps the spring compressed at a constant force, there is no forcing work
    (``V = 0``) and no integrator step.
    """
    r = mode.region
    t1, guard = release_time(osc, r, t0, x, t_end, guard_gates(mode))
    tau = t1 - t0
    q = q2 = 0.0
    if r:
        force = osc.K * (r * x - 1.0)
        q, q2 = force * tau, force * force * tau
    return t1, x, 0.0, guard, q, q2, 0.0, 0


def evaluate_stuck(osc: Oscillator, mode: Mode, t0: float, x: float, times):
    """``(X, V, impulse since t0)`` at ``times`` inside a stuck piece starting at ``(t0, x)``."""
    tau = np.asarray(times, dtype=float) - t0
    r = mode.region
    xs = np.full(tau.shape, x)
    vs = np.zeros(tau.shape)
    qs = osc.K * (r * x - 1.0) * tau if r else np.zeros(tau.shape)
    return xs, vs, qs
