"""Closed-form slipping pieces of the exact backend for damped and harmonic-sum members.

The eq. 3 piece (one harmonic, no damping) lives in :mod:`impactosc.backends.exact`; this
module is its generalisation to the linear family: viscous damping ``2 zeta Y'`` and a sum
of harmonics. In region ``r`` with motion ``s`` (``Y = X - r``, see :mod:`.exact`)::

    Y'' + 2 zeta Y' + w^2 Y = cY + sum_i F_i cos(Omega_i t + phase_i),   w^2 = 1 + K r^2.

Solution
--------
``Y = Yc + sum_i Re(Q_i e^{i Omega_i tau}) + Yh(tau)`` with ``Yc = cY / w^2``, the steady
response ``Q_i = F_i e^{i theta0_i} / (w^2 - Omega_i^2 + 2 i zeta Omega_i)`` of each harmonic
(``theta0_i = Omega_i t0 + phase_i``, ``tau = t - t0``) and the homogeneous part::

    Yh = A EC + (B + zeta A) ES,   EC = e^{-zeta tau} C,   ES = e^{-zeta tau} S,

where ``(C, S)`` is ``(cos(wd tau), sin(wd tau) / wd)`` underdamped (``wd^2 = w^2 - zeta^2``),
``(1, tau)`` critically damped and ``(cosh(mu tau), sinh(mu tau) / mu)`` overdamped
(``mu^2 = zeta^2 - w^2``): one formula for the three cases, with no ``1 / wd`` blowing up at
the critical point. ``A, B`` match ``Y(0) = y0, Y'(0) = v0``. Overdamped, ``EC`` and ``ES``
are formed from ``e^{-(zeta -+ mu) tau}`` (``zeta - mu = w^2 / (zeta + mu)``) so nothing
overflows. The k-th derivative of ``Yh`` has the same form with ``(A_k, B_k)`` from
``(A_{k+1}, B_{k+1}) = (B_k, -w^2 A_k - 2 zeta B_k)``. ``Y`` itself is evaluated about the
start point, ``y0 + A (EC - 1) + (B + zeta A) ES + sum_i Re(Q_i (e^{i Omega_i tau} - 1))``,
with ``EC - 1`` and ``e^{i x} - 1`` formed without cancellation (``expm1`` and
``-2 sin^2(x / 2)``), so a huge ``cY`` (huge ``beta``) never cancels against ``A``.

The steady response has no resonance singularity when ``zeta > 0``. With ``zeta = 0`` (or a
tiny ``zeta``) it does, and near it ``Q_i`` and ``A`` cancel: the backend refuses members
with ``|w^2 - Omega_i^2 + 2 i zeta Omega_i| < 1e-6 w^2`` (see :func:`near_resonance`);
eq. 3 itself keeps the resonance-safe piece of :mod:`.exact`.

Derivative bounds
-----------------
On ``[a, b]``, with ``rho = zeta`` (overdamped ``zeta - mu``) and ``D = e^{-rho a}``:
``|EC| <= D`` and ``0 <= ES <= min(b D, D / wd, max_{[a, b]} tau e^{-rho tau})``
underdamped (``D / (2 mu)`` in place of ``D / wd`` overdamped, neither when critical),
so ``|Y^(k)| <= |A_k| D + |B_k + zeta A_k| max ES + sum_i |Q_i| Omega_i^k``: a bound of
the derivatives of the formula as evaluated, with the rounded ``A`` and ``B``. Taken per
window (``a > 0``), the decay lets the search prove the sign of an overdamped velocity that
creeps to zero.

Integrals
---------
``int Y`` in closed form from the integrated homogeneous equation,
``int ES = -(EC - 1 + zeta ES) / w^2`` and
``int (EC + zeta ES) - tau = (ES - tau) - 2 zeta (EC - 1 + zeta ES) / w^2``;
``int Y^2`` and ``int V^2`` by the Gauss-Legendre rule of :mod:`.exact` on sub-intervals
of half the period of the fastest rate ``max(w, Omega_i, zeta + mu)``.
"""

from __future__ import annotations

import math

import numpy as np

_EPS = 2.0**-52
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
#: Refusal threshold of :func:`near_resonance`: rounding of ``Y`` grows like ``eps / ratio``.
RESONANCE_RATIO = 1e-6

# z - sin z and sinh z - z = z^3/3! -+ z^5/5! + ...: nine terms reach z^19/19!, below an ulp for |z| < 1.
_SERIES = tuple(1.0 / math.factorial(2 * k + 3) for k in reversed(range(9)))


def _odd_tail(z, sign: float):
    """``z - sin z`` (``sign = 1``) or ``sinh z - z`` (``sign = -1``) without cancellation."""
    arr = isinstance(z, np.ndarray)
    if not arr and abs(z) >= 1.0:
        return z - math.sin(z) if sign > 0 else math.sinh(z) - z
    u = z * z
    series = 0.0
    for c in _SERIES:
        series = c - sign * u * series
    series = z * u * series
    if not arr:
        return series
    big = np.minimum(np.abs(z), 700.0) * np.sign(z)
    direct = big - np.sin(big) if sign > 0 else np.sinh(big) - big
    return np.where(np.abs(z) < 1.0, series, direct)


def mode_rates(osc, region: int) -> tuple[float, float]:
    """``(w^2, zeta)`` of a slipping mode in ``region``."""
    return (1.0 + osc.K if region and not osc.rigid else 1.0), osc.zeta


def near_resonance(osc) -> str | None:
    """A description of the first harmonic too close to an undamped resonance, or None."""
    regions = (0,) if osc.rigid else (0, 1)
    for region in regions:
        w2, zeta = mode_rates(osc, region)
        for F, Om, _ in osc.terms:
            if F > 0.0 and Om > 0.0 and abs(complex(w2 - Om * Om, 2.0 * zeta * Om)) < RESONANCE_RATIO * w2:
                where = "in contact" if region else "free"
                return (f"a forcing harmonic at resonance (Omega_i={Om!r}, natural frequency {math.sqrt(w2)!r} "
                        f"{where}, zeta={zeta!r}: steady amplitude over {1 / RESONANCE_RATIO:g} static)")
    return None


class FamilyConstants:
    """Per-mode constants of a damped / harmonic-sum slipping piece."""

    __slots__ = ("r", "s", "ref", "K", "beta", "zeta", "w2", "w", "cY", "Yc", "kind", "wd", "mu", "lo", "hi",
                 "terms", "fastest")

    def __init__(self, osc, r: int, s: int):
        self.r, self.s, self.ref = r, s, float(r)
        self.K, self.beta, self.zeta = osc.K, osc.beta, osc.zeta
        self.w2, _ = mode_rates(osc, r)
        self.w = math.sqrt(self.w2)
        self.cY = (-r - osc.beta * s) if r else -osc.beta * s  # as in exact._ModeConstants
        self.Yc = self.cY / self.w2
        z, w = self.zeta, self.w
        self.wd = self.mu = self.lo = self.hi = 0.0
        if z < w:
            self.kind, self.wd = 0, math.sqrt((w - z) * (w + z))
        elif z == w:
            self.kind = 1
        else:
            self.kind, self.mu = 2, math.sqrt((z - w) * (z + w))
            self.hi = z + self.mu
            self.lo = self.w2 / self.hi  # zeta - mu without cancellation
        # (F_i, Omega_i, phase_i, F_i H_i): the complex steady gain of each harmonic.
        self.terms = tuple((F, Om, ph, F / complex(self.w2 - Om * Om, 2.0 * z * Om))
                           for F, Om, ph in osc.terms if F > 0.0)
        self.fastest = max([w, self.hi] + [Om for _, Om, _, _ in self.terms])

    def decay_bounds(self, start: float, tmax: float) -> tuple[float, float]:
        """Upper bounds of ``|EC|`` and ``|ES|`` on ``[start, tmax]`` (see the module docstring).

        Both decay like ``e^{-rho tau}`` (``rho = zeta``, overdamped ``zeta - mu``); bounds taken
        at ``start`` rather than 0 let the guard search prove the sign of a velocity that
        creeps to zero without crossing it (overdamped), window after window.
        """
        rho = self.lo if self.kind == 2 else self.zeta
        decay = math.exp(-rho * start)
        es = tmax * decay  # |S| <= tau
        if self.kind == 0:
            es = min(es, decay / self.wd)
        elif self.kind == 2:
            es = min(es, 0.5 * decay / self.mu)
        if rho > 0.0:  # tau e^{-rho tau} peaks at 1 / rho
            peak = start * decay if rho * start >= 1.0 else 1.0 / (math.e * rho)
            es = min(es, peak)
        return decay, es

    def basis(self, tau, lib):
        """``(EC, ES, EC - 1)`` at ``tau`` (``lib`` is :mod:`math` or NumPy)."""
        z = self.zeta
        if self.kind == 2:
            ep, em = lib.exp(-self.lo * tau), lib.exp(-self.hi * tau)
            ec = 0.5 * (ep + em)
            es = ep * (-lib.expm1(-2.0 * self.mu * tau)) / (2.0 * self.mu)
            ecm1 = 0.5 * (lib.expm1(-self.lo * tau) + lib.expm1(-self.hi * tau))
            return ec, es, ecm1
        e, em1 = lib.exp(-z * tau), lib.expm1(-z * tau)
        if self.kind == 1:
            return e, e * tau, em1
        wd = self.wd
        c = lib.cos(wd * tau)
        h = lib.sin(0.5 * wd * tau)
        return e * c, e * lib.sin(wd * tau) / wd, em1 * c - 2.0 * h * h

    def es_minus_tau(self, tau, es, lib):
        """``ES - tau`` with the small-``tau`` cancellation removed."""
        if self.kind == 1:
            return tau * lib.expm1(-self.zeta * tau)
        if self.kind == 0:
            return -lib.exp(-self.zeta * tau) * _odd_tail(self.wd * tau, 1.0) / self.wd \
                + tau * lib.expm1(-self.zeta * tau)
        # Overdamped: the series where mu tau < 1 (sinh stays finite there), else directly.
        small = np.minimum(self.mu * tau, 1.0) if isinstance(tau, np.ndarray) else min(self.mu * tau, 1.0)
        series = lib.exp(-self.zeta * tau) * _odd_tail(small, -1.0) / self.mu + tau * lib.expm1(-self.zeta * tau)
        direct = es - tau
        if isinstance(tau, np.ndarray):
            return np.where(self.mu * tau < 1.0, series, direct)
        return series if self.mu * tau < 1.0 else direct


class FamilyPiece:
    """The closed-form motion of one damped / harmonic-sum slipping piece from ``(t0, x0, v0)``.

    Offers what :meth:`impactosc.backends.exact._Stepper._advance_slip` uses: ``va``, ``aj``,
    ``yv``, ``_yvp``, ``int_y``, ``int_squares``, ``bounds`` and ``y0``.
    """

    __slots__ = ("mc", "t0", "x0", "v0", "y0", "A", "B", "q", "qk", "_ab", "_at0")

    def __init__(self, mc: FamilyConstants, t0: float, x0: float, v0: float):
        self.mc = mc
        self.t0, self.x0, self.v0 = t0, x0, v0
        self.y0 = x0 - mc.ref
        # Q_i as (Re, Im, Omega_i): the steady response of each harmonic at the piece start,
        # and qk[k] the same for Y^(k): Q_i (i Omega_i)^k, k = 1..3.
        q: list = []
        qk: tuple[list, list, list] = ([], [], [])
        sum_re = sum_v = 0.0
        for _, Om, ph, gain in mc.terms:
            th = Om * t0 + ph  # the phase as the engine evaluates the forcing
            c, s = math.cos(th), math.sin(th)
            Q = gain * complex(c, s)
            q.append((Q.real, Q.imag, Om))
            for k in range(3):
                Qk = Q * (1j * Om) ** (k + 1)
                qk[k].append((Qk.real, Qk.imag, Om))
            sum_re += Q.real
            sum_v -= Om * Q.imag  # Re(i Omega Q)
        self.q = tuple(q)
        self.qk: tuple = ((), *(tuple(x) for x in qk))  # indexed by the derivative order k
        self.A = self.y0 - mc.Yc - sum_re
        self.B = v0 - sum_v
        # (A_k, B_k) for k = 0..5: Y^(k)_h has the form of Y_h with these amplitudes.
        z, w2 = mc.zeta, mc.w2
        ab = [(self.A, self.B)]
        for _ in range(5):
            a, b = ab[-1]
            ab.append((b, -w2 * a - 2.0 * z * b))
        self._ab = ab
        # The derivatives are evaluated about their start values: V(0) is v0 exactly (a tiny v0
        # next to a large steady velocity would otherwise be lost, and its sign with it);
        # Y''(0) and Y'''(0) are those of the formula, A_k + sum_i Re(Q_i (i Omega_i)^k), so
        # each evaluated derivative is exactly the derivative of the one below it and the
        # bounds below hold for the functions the guard search sees (no rounding offsets).
        self._at0 = (self.y0, v0, *(ab[k][0] + sum(c[0] for c in self.qk[k]) for k in (2, 3)))

    # -- values --------------------------------------------------------------------------
    def _deriv(self, tau: float, k: int, ecm1: float, es: float) -> float:
        """``Y^(k)`` at a scalar ``tau`` for ``1 <= k <= 3``, about its value at the start."""
        a, b = self._ab[k]
        out = a * ecm1 + (b + self.mc.zeta * a) * es
        for cr, ci, Om in self.qk[k]:
            h = math.sin(0.5 * Om * tau)
            out += -2.0 * cr * h * h - ci * math.sin(Om * tau)  # Re(Q_k (e^{i Omega tau} - 1))
        return self._at0[k] + out

    def va(self, tau: float):
        """``(V, Y'')`` at a scalar ``tau``."""
        _, es, ecm1 = self.mc.basis(tau, math)
        return self._deriv(tau, 1, ecm1, es), self._deriv(tau, 2, ecm1, es)

    def aj(self, tau: float):
        """``(Y'', Y''')`` at a scalar ``tau``."""
        _, es, ecm1 = self.mc.basis(tau, math)
        return self._deriv(tau, 2, ecm1, es), self._deriv(tau, 3, ecm1, es)

    def _yvp(self, tau):
        """``(Y, V, None, Y - y0)`` at a scalar or array ``tau`` (the layout of exact's ``_yvp``)."""
        lib = np if isinstance(tau, np.ndarray) else math
        mc, A, B, z = self.mc, self.A, self.B, self.mc.zeta
        _, es, ecm1 = mc.basis(tau, lib)
        dy = A * ecm1 + (B + z * A) * es
        b1 = self._ab[1][1]
        dv = B * ecm1 + (b1 + z * B) * es
        for (qr, qi, Om), (cr, ci, _) in zip(self.q, self.qk[1], strict=True):
            sn = lib.sin(Om * tau)
            h = lib.sin(0.5 * Om * tau)
            h2 = 2.0 * h * h
            dy = dy - (qr * h2 + qi * sn)  # Re(Q (e^{i Omega tau} - 1))
            dv = dv - (cr * h2 + ci * sn)
        return self.y0 + dy, self.v0 + dv, None, dy

    def yv(self, tau):
        """``(Y, V)`` at a scalar ``tau`` or an array of them."""
        return self._yvp(tau)[:2]

    # -- integrals -----------------------------------------------------------------------
    def int_y(self, tau, dp=None):
        """``int_0^tau Y`` in closed form (scalar or array; ``dp`` is unused)."""
        lib = np if isinstance(tau, np.ndarray) else math
        mc, A, B, z = self.mc, self.A, self.B, self.mc.zeta
        ec, es, ecm1 = mc.basis(tau, lib)
        g = (ecm1 + z * es) / mc.w2
        out = self.y0 * tau + A * (mc.es_minus_tau(tau, es, lib) - 2.0 * z * g) - B * g
        for qr, qi, Om in self.q:
            if Om == 0.0:
                continue  # a constant term: Y_i - Y_i(0) = 0
            h = lib.sin(0.5 * Om * tau)
            out = out - (qr * _odd_tail(Om * tau, 1.0) + 2.0 * qi * h * h) / Om
        return out

    def int_squares(self, tau: float) -> tuple[float, float]:
        """``(int_0^tau Y^2, int_0^tau V^2)`` by composite Gauss-Legendre."""
        if tau <= 0.0:
            return 0.0, 0.0
        n = max(1, math.ceil(tau * self.mc.fastest / math.pi))
        h = tau / n
        nodes = h * np.arange(n)[:, None] + 0.5 * h * (_GL_NODES[None, :] + 1.0)
        y, v = self.yv(nodes.ravel())
        weights = 0.5 * h * np.tile(_GL_WEIGHTS, n)
        return float(weights @ (y * y)), float(weights @ (v * v))

    def bounds(self, tmax: float, k: int, start: float = 0.0) -> tuple[float, float]:
        """Upper bounds of ``|Y^(k+2)|`` and ``|Y^(k+3)|`` over ``[start, tmax]`` (module docstring)."""
        mc = self.mc
        ecb, esb = mc.decay_bounds(start, tmax)
        out = []
        for j in (k + 2, k + 3):
            a, b = self._ab[j]
            o = abs(a) * ecb + abs(b + mc.zeta * a) * esb
            o += sum(math.hypot(qr, qi) * Om**j for qr, qi, Om in self.q)
            out.append(o * (1.0 + 1e-9) + 1e-300)
        return out[0], out[1]
