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


# -- a one-sided linear spring flange: X'' + 2 zeta X' + X + K (X - 1)^+ = F cos(W t) -------------------------------
#
# A period-1 orbit with one contact a period enters the flange at (1, v1), leaves it after the contact time tau at
# (1, v2) and returns to (1, v1) after the period T. With the time origin at the entry and the forcing written
# a cos(W s) - b sin(W s) (a = F cos phi, b = F sin phi), both pieces are linear oscillators with harmonic forcing,
# so the four conditions are linear in (a, b, v1, v2): F(tau, W) = |(a, b)| in closed form (a 4 x 4 solve). A fold of
# the family in F at fixed W is dF/dtau = 0; a cusp, where two folds meet, also has d^2F/dtau^2 = 0. Evaluated in
# mpmath at 30 digits, so that the derivatives by numerical differentiation are exact to far below 1e-10.


def _mp_transition(mp, t, w2, zeta):
    wd = mp.sqrt(w2 - zeta**2)
    e, c, s = mp.exp(-zeta * t), mp.cos(wd * t), mp.sin(wd * t)
    return mp.matrix([[e * (c + zeta / wd * s), e * s / wd], [-e * w2 / wd * s, e * (c - zeta / wd * s)]])


def _mp_forced(mp, s, W, w2, zeta):
    """d(X_p, V_p)/d(a, b) at time ``s`` of the forced response ``Re((a + i b) e^{iWs} / (w2 - W^2 + 2 i zeta W))``."""
    HE = mp.exp(1j * W * s) / (w2 - W**2 + 2j * zeta * W)
    return mp.matrix([[mp.re(HE), -mp.im(HE)], [mp.re(1j * W * HE), -mp.im(1j * W * HE)]])


def spring_orbit(tau, W, zeta, K):
    """``(a, b, v1, v2)`` of the one-contact orbit of contact time ``tau`` (mpmath numbers)."""
    import mpmath as mp

    T = 2 * mp.pi / W
    rest = mp.matrix([K / (1 + K), 0])  # the contact piece's equilibrium
    Phc, Phf = _mp_transition(mp, tau, 1 + K, zeta), _mp_transition(mp, T - tau, 1, zeta)
    Mc = _mp_forced(mp, tau, W, 1 + K, zeta) - Phc * _mp_forced(mp, 0, W, 1 + K, zeta)
    Mf = _mp_forced(mp, T, W, 1, zeta) - Phf * _mp_forced(mp, tau, W, 1, zeta)
    A, rhs = mp.zeros(4, 4), mp.zeros(4, 1)
    after_contact = rest + Phc * (mp.matrix([1, 0]) - rest)  # the contact piece from (1, 0), unforced
    for i in range(2):
        A[i, 0], A[i, 1], A[i, 2], A[i, 3] = Mc[i, 0], Mc[i, 1], Phc[i, 1], -1 if i == 1 else 0
        rhs[i] = (1 if i == 0 else 0) - after_contact[i]
        A[2 + i, 0], A[2 + i, 1], A[2 + i, 2], A[2 + i, 3] = Mf[i, 0], Mf[i, 1], -1 if i == 1 else 0, Phf[i, 1]
        rhs[2 + i] = (1 if i == 0 else 0) - Phf[i, 0]
    return mp.lu_solve(A, rhs)


def spring_amplitude(tau, W, zeta, K):
    """The forcing amplitude ``F`` of the one-contact orbit of contact time ``tau``."""
    import mpmath as mp

    y = spring_orbit(tau, W, zeta, K)
    return mp.sqrt(y[0] ** 2 + y[1] ** 2)


def spring_cusp(zeta: float, K: float, tau0: float, W0: float):
    """``(W, F)`` of the cusp of the fold curve near ``(tau0, W0)``: dF/dtau = d^2F/dtau^2 = 0."""
    import mpmath as mp

    with mp.workdps(30):
        z, k = mp.mpf(zeta), mp.mpf(K)

        def equations(tau, W):
            def f(t):
                return spring_amplitude(t, W, z, k)

            return [mp.diff(f, tau, 1), mp.diff(f, tau, 2)]

        tau, W = mp.findroot(equations, (mp.mpf(tau0), mp.mpf(W0)))
        return float(W), float(spring_amplitude(tau, W, z, k))


def spring_folds(W: float, zeta: float, K: float, lo: float, hi: float, n: int = 40) -> list:
    """The fold amplitudes at ``W``: the local extrema of ``F(tau)`` for contact times in ``(lo, hi)``."""
    import mpmath as mp

    with mp.workdps(30):
        w, z, k = mp.mpf(W), mp.mpf(zeta), mp.mpf(K)

        def slope(t):
            return mp.diff(lambda s: spring_amplitude(s, w, z, k), t)

        taus = [mp.mpf(lo) + (mp.mpf(hi) - mp.mpf(lo)) * i / n for i in range(n + 1)]
        slopes = [slope(t) for t in taus]
        out = []
        for i in range(n):
            if slopes[i] * slopes[i + 1] < 0:
                tau = mp.findroot(slope, (taus[i], taus[i + 1]), solver="anderson")
                out.append(float(spring_amplitude(tau, w, z, k)))
        return out


# -- a period-1 orbit with two impacts a period on the rigid stop, at the grazing of one of them ---------------------
def _flight(F: float, W: float, zeta: float, c: float, t_a: float, z_a, t_b: float) -> np.ndarray:
    """``(X, V)`` at ``t_b`` of the contact-free motion from ``z_a`` at ``t_a``."""
    A, delta = particular(F, W, zeta)

    def xp(t):
        return np.array([c + A * math.cos(W * t - delta), -A * W * math.sin(W * t - delta)])

    return xp(t_b) + transition(zeta, t_b - t_a) @ (np.asarray(z_a, float) - xp(t_a))


def two_impact_grazing(W: float, zeta: float, e: float, c: float, guess):
    """``(F, t1, t2, v1)``: the two-impact orbit whose impact at ``t2`` has zero speed.

    The orbit leaves the wall at ``t1`` at ``-e v1``, reaches it at ``t2`` with zero speed
    (so leaves it unchanged) and hits it again at ``t1 + T`` at ``v1``: four equations in
    ``(F, t1, t2, v1)``, solved by Newton (scipy's ``hybr``) from ``guess``.
    """
    from scipy.optimize import root

    T = 2.0 * math.pi / W

    def equations(y):
        F, t1, t2, v1 = y
        first = _flight(F, W, zeta, c, t1, (1.0, -e * v1), t2)
        second = _flight(F, W, zeta, c, t2, (1.0, 0.0), t1 + T)
        return [first[0] - 1.0, first[1], second[0] - 1.0, second[1] - v1]

    sol = root(equations, np.asarray(guess, float), method="hybr", options={"xtol": 1e-14})
    if np.max(np.abs(equations(sol.x))) > 1e-13:
        raise ValueError(f"the two-impact grazing orbit was not found: {sol.message}")
    return tuple(float(v) for v in sol.x)
