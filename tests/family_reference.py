"""Closed-form (or quadrature) references for the members of the model family (issue #10).

Each function solves one member analytically, independently of the engine: the tests hold
every backend against these numbers.
"""

from __future__ import annotations

import math

from scipy.integrate import quad
from scipy.optimize import brentq


def rigid_chatter_accumulation(F: float, beta: float, e: float, x0: float = 0.0) -> tuple[float, list[float]]:
    """Accumulation time of the impacts on the upper rigid wall under a constant push.

    ``X'' + X + beta sgn(X') = F`` (``Omega = 0``, ``F - 1 > beta``) from rest at ``x0``: every
    flight is a harmonic arc about the centre ``F - beta s``. Moving up the centre is
    ``ci = F - beta``; after an impact at speed ``u`` the mass leaves at ``e u`` about
    ``co = F + beta`` to an apex, then falls back about ``ci``. The arcs are evaluated without
    cancellation (``apex - 1 = -w^2 / ((co - 1) + hypot(co - 1, w))``) and summed until
    the flights vanish below double precision. Returns ``(t_inf, impact_times)``.
    """
    ci, co = F - beta, F + beta
    t = math.acos((1.0 - ci) / (x0 - ci))
    u = abs(x0 - ci) * math.sin(t)
    times = [t]
    for _ in range(5000):
        w = e * u
        t_up = math.atan2(w, co - 1.0)  # from the wall to the apex
        apex_m1 = -w * w / ((co - 1.0) + math.hypot(co - 1.0, w))
        u = math.sqrt(apex_m1 * (apex_m1 + 2.0 - 2.0 * ci))  # (apex - ci)^2 - (1 - ci)^2
        t_down = math.atan2(u, abs(1.0 - ci))
        if t_up + t_down < 1e-18 * t:
            break
        t += t_up + t_down
        times.append(t)
    return t, times


def coulomb_decay_turns(x0: float, beta: float, beta_static: float, zeta: float = 0.0):
    """Turning points of ``X'' + 2 zeta X' + X = -beta sgn X'`` from rest at ``x0``, and the stick.

    Each half cycle is a damped arc about the centre ``c = -beta s``: it ends after
    ``pi / w_d`` (``w_d = sqrt(1 - zeta^2)``) at ``c - (X - c) exp(-zeta pi / w_d)``. The mass
    sticks at the first turning point with ``|X| <= beta_static`` (the static level; with
    ``F = 0`` the net force at rest is ``-X``). Returns ``([(t_k, X_k), ...], t_stick)``.
    """
    wd = math.sqrt(1.0 - zeta * zeta)
    half = math.pi / wd
    decay = math.exp(-zeta * half)
    x, t, turns = x0, 0.0, []
    if abs(x) <= beta_static:
        return turns, 0.0
    for _ in range(10000):
        s = -1 if x > 0 else 1  # slides towards the origin
        c = -beta * s
        x = c - (x - c) * decay
        t += half
        turns.append((t, x))
        if abs(x) <= beta_static:
            return turns, t
    raise RuntimeError("no stick within 10000 half cycles")


def hertz_contact(v0: float, K: float, p: float):
    """A power-law flange contact of the free oscillator (``F = beta = zeta = 0``) from ``X = 0``.

    Energy ``E = v0^2 / 2`` is conserved: the peak penetration solves
    ``(1 + d)^2 / 2 + K d^(p+1) / (p+1) = E``; the contact starts at ``asin(1 / v0)`` with
    entry speed ``sqrt(v0^2 - 1)``, leaves with the same speed, and lasts
    ``2 int_0^dmax dd / sqrt(2 (E - (1+d)^2/2 - K d^(p+1)/(p+1)))`` (the square-root
    singularity at ``dmax`` removed by ``d = dmax (1 - s^2)``). Returns
    ``(t_entry, duration, d_max, v_entry)``.
    """
    energy = 0.5 * v0 * v0

    def potential(d):
        return 0.5 * (1.0 + d) ** 2 + K * d ** (p + 1.0) / (p + 1.0)

    dmax = brentq(lambda d: potential(d) - energy, 0.0, math.sqrt(2.0 * energy), xtol=1e-300, rtol=1e-15)

    def integrand(s):
        d = dmax * (1.0 - s * s)
        return 2.0 * dmax * s / math.sqrt(2.0 * (energy - potential(d)))

    half, _ = quad(integrand, 0.0, 1.0, epsabs=0.0, epsrel=1e-13, limit=200)
    return math.asin(1.0 / v0), 2.0 * half, dmax, math.sqrt(v0 * v0 - 1.0)


def rigid_release_time(F: float, Omega: float, beta_static: float) -> float:
    """Release of a mass resting on the upper rigid wall under ``F cos(Omega t)``.

    At ``X = 1`` the net force is ``F cos(Omega t) - 1``; the wall holds while it exceeds
    ``-beta_static`` and the mass leaves when ``F cos(Omega t) = 1 - beta_static`` (falling).
    """
    return math.acos((1.0 - beta_static) / F) / Omega


def rigid_chatter_state(F: float, beta: float, e: float, t: float, x0: float = 0.0) -> tuple[float, float]:
    """State ``(X, V)`` at ``t`` of the chatter of :func:`rigid_chatter_accumulation`.

    The same harmonic arcs, walked until the one that holds ``t``: from the wall at speed
    ``w`` down about ``co = F + beta`` (``X = co + (1 - co) cos s - w sin s``) to the apex ``A``,
    then back up about ``ci = F - beta`` (``X = ci + (A - ci) cos s``). After the accumulation
    time the mass rests on the wall.
    """
    t_inf, times = rigid_chatter_accumulation(F, beta, e, x0)
    if t >= t_inf:
        return 1.0, 0.0
    ci, co = F - beta, F + beta
    if t < times[0]:
        s = t
        return ci + (x0 - ci) * math.cos(s), -(x0 - ci) * math.sin(s)
    k = max(i for i, ti in enumerate(times) if ti <= t)
    # Speed of the k-th impact, as the reference recurrence computes it.
    u = abs(x0 - ci) * math.sin(times[0])
    for _ in range(k):
        w = e * u
        apex_m1 = -w * w / ((co - 1.0) + math.hypot(co - 1.0, w))
        u = math.sqrt(apex_m1 * (apex_m1 + 2.0 - 2.0 * ci))
    w = e * u
    s = t - times[k]
    t_up = math.atan2(w, co - 1.0)
    if s <= t_up:
        return co + (1.0 - co) * math.cos(s) - w * math.sin(s), -(1.0 - co) * math.sin(s) - w * math.cos(s)
    apex = 1.0 - w * w / ((co - 1.0) + math.hypot(co - 1.0, w))
    s -= t_up
    return ci + (apex - ci) * math.cos(s), -(apex - ci) * math.sin(s)
