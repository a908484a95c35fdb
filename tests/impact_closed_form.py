"""Closed forms of single-impact period-1 orbits of a linear oscillator against a rigid stop.

``X'' + 2 zeta X' + X = F cos(W t) + c`` with Newton's impact ``V -> -e V`` at ``X = 1``
(the constant push ``c`` keeps the motion off the lower wall at ``X = -1``, so the member
behaves as a one-sided stop). Between impacts the motion is linear: ``X = X_p + Y`` with the
particular solution ``X_p = c + A cos(W t - delta)`` and ``Y`` the free damped motion, whose
transition matrix over one period ``T = 2 pi / W`` is ``Phi``. An orbit that leaves the wall
at phase ``theta = W t_i - delta`` with speed ``-e v`` and returns after ``T`` with speed ``v``
satisfies two linear equations in ``(1 - X_p, v)``; eliminating ``v`` leaves
``A (P cos theta + W Q sin theta) = P (1 - c)`` with ``P = (1 - a)(1 + d e) + b e c'``,
``Q = b (1 + e)`` for ``Phi = [[a, b], [c', d]]``: two orbits for ``F`` above the fold
``F_fold = (1 - c) |P| sqrt((1 - W^2)^2 + (2 zeta W)^2) / sqrt(P^2 + W^2 Q^2)``, none below
(Shaw & Holmes 1983 derive the undamped case). The multipliers are the eigenvalues of
``Phi S`` with the impact's saltation matrix ``S = [[-e, 0], [(a+ + e a-)/v, -e]]``.
Written from the equations here, independently of the library.
"""

from __future__ import annotations

import math

import numpy as np


def transition(zeta: float, tau: float) -> np.ndarray:
    """``exp(A tau)`` of ``Y'' + 2 zeta Y' + Y = 0`` (underdamped)."""
    wd = math.sqrt(1.0 - zeta * zeta)
    e = math.exp(-zeta * tau)
    C, S = e * math.cos(wd * tau), e * math.sin(wd * tau) / wd
    return np.array([[C + zeta * S, S], [-S, C - zeta * S]])


def particular(F: float, W: float, zeta: float):
    """``(A, delta)`` of the forced response ``A cos(W t - delta)``."""
    return F / math.hypot(1.0 - W * W, 2.0 * zeta * W), math.atan2(2.0 * zeta * W, 1.0 - W * W)


def _pq(W: float, zeta: float, e: float):
    (a, b), (c1, d) = transition(zeta, 2.0 * math.pi / W)
    return (1.0 - a) * (1.0 + d * e) + b * e * c1, b * (1.0 + e)


def fold(W: float, zeta: float, e: float, c: float) -> float:
    """The forcing amplitude at which the two single-impact orbits are born."""
    P, Q = _pq(W, zeta, e)
    return (1.0 - c) * abs(P) * math.hypot(1.0 - W * W, 2.0 * zeta * W) / math.hypot(P, W * Q)


def orbits(F: float, W: float, zeta: float, e: float, c: float):
    """The single-impact orbits at ``F``: a list of dicts (impact time in [0, T), speed, multipliers)."""
    A, delta = particular(F, W, zeta)
    P, Q = _pq(W, zeta, e)
    R, phi = math.hypot(P, W * Q), math.atan2(W * Q, P)
    ratio = P * (1.0 - c) / (A * R)
    if abs(ratio) > 1.0:
        return []
    out = []
    Phi = transition(zeta, 2.0 * math.pi / W)
    T = 2.0 * math.pi / W
    for sign in (1.0, -1.0):
        theta = phi + sign * math.acos(ratio)
        u, w = 1.0 - c - A * math.cos(theta), -A * W * math.sin(theta)
        (_, _), (c1, d) = Phi
        v = (c1 * u + (1.0 - d) * w) / (1.0 + d * e)
        t_i = ((theta + delta) / W) % T
        force = F * math.cos(W * t_i) + c - 1.0
        a_minus, a_plus = force - 2.0 * zeta * v, force + 2.0 * zeta * e * v
        S = np.array([[-e, 0.0], [(a_plus + e * a_minus) / v, -e]])
        mus = np.linalg.eigvals(Phi @ S)
        out.append({"t_impact": t_i, "v": v, "multipliers": mus[np.argsort(-np.abs(mus))], "theta": theta})
    return out


def period_doubling(W: float, zeta: float, e: float, c: float, lo: float, hi: float, which: int = 0) -> float:
    """``F`` in ``(lo, hi)`` where orbit ``which`` has a multiplier -1 (bisection on ``det(M + I)``)."""

    def g(F):
        o = orbits(F, W, zeta, e, c)[which]
        return float(np.real(np.prod(o["multipliers"] + 1.0)))

    return _bisect(g, lo, hi)


def period_doubling_near(W: float, zeta: float, e: float, c: float, near: float, width: float = 2e-3):
    """The period doubling of either single-impact orbit within ``width`` of ``F = near``, or None."""
    for which in (0, 1):
        try:
            return period_doubling(W, zeta, e, c, near - width, near + width, which=which)
        except (ValueError, IndexError):
            continue
    return None


def grazing(W: float, zeta: float, e: float, c: float, lo: float, hi: float, which: int = 1) -> float:
    """``F`` in ``(lo, hi)`` where orbit ``which`` hits the stop at zero speed (bisection on its ``v``)."""

    def v(F):
        found = orbits(F, W, zeta, e, c)
        return found[which]["v"] if found else -math.inf

    if not (math.isfinite(v(lo)) and math.isfinite(v(hi))):
        raise ValueError("no single-impact orbit at an end of the interval")
    return _bisect(v, lo, hi)


def _bisect(g, lo: float, hi: float) -> float:
    """A sign change of ``g`` in ``(lo, hi)`` by bisection to the last bits."""
    glo, ghi = g(lo), g(hi)
    if glo * ghi > 0:
        raise ValueError("no sign change in the interval")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        gm = g(mid)
        if gm * glo > 0:
            lo, glo = mid, gm
        else:
            hi = mid
        if hi - lo <= 1e-15 * max(1.0, abs(hi)):
            break
    return 0.5 * (lo + hi)


def section_state(F: float, W: float, zeta: float, e: float, c: float, orbit: dict, t_section: float = 0.0):
    """``(X, V)`` at ``t_section`` (mod ``T``) of a single-impact orbit of :func:`orbits`.

    After the impact at ``t_i`` the state is ``(1, -e v)``; the free part ``Y = X - X_p``
    then evolves by the transition matrix until the section.
    """
    A, delta = particular(F, W, zeta)
    T = 2.0 * math.pi / W
    t_i = orbit["t_impact"]

    def xp(t):
        return np.array([c + A * math.cos(W * t - delta), -A * W * math.sin(W * t - delta)])

    y0 = np.array([1.0, -e * orbit["v"]]) - xp(t_i)
    tau = (t_section - t_i) % T
    return xp(t_section) + transition(zeta, tau) @ y0


def free_state(F: float, W: float, zeta: float, c: float, t_section: float = 0.0):
    """``(X, V)`` at ``t_section`` of the contact-free periodic orbit ``c + A cos(W t - delta)``."""
    A, delta = particular(F, W, zeta)
    return np.array([c + A * math.cos(W * t_section - delta), -A * W * math.sin(W * t_section - delta)])


def grazing_amplitude(W: float, zeta: float, c: float = 0.0) -> float:
    """The amplitude at which the contact-free orbit touches the stop ``X = 1``: ``(1 - c)|1 - W^2 + 2 i zeta W|``."""
    return (1.0 - c) * abs(complex(1.0 - W * W, 2.0 * zeta * W))
