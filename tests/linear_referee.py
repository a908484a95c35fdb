"""A 50-digit referee for the linear members of the family (spring flange ``p = 1``).

Independent of the package: every slipping mode is the linear ODE

    Y'' + 2 zeta Y' + w^2 Y = cY + sum_i F_i cos(Omega_i t + phase_i),   Y = X - r,

(``w^2 = 1 + K r^2``, ``cY = -r - beta s`` in a flange, ``-beta s`` free), solved in closed
form with mpmath at ``DIGITS`` significant digits: the steady response of each harmonic
``Re(Q_i e^{i Omega_i t})`` with ``Q_i = F_i e^{i phase_i} / (w^2 - Omega_i^2 + 2 i zeta Omega_i)``
in absolute time, plus ``c1 e^{lambda_1 tau} + c2 e^{lambda_2 tau}`` with the complex roots
``lambda = -zeta +- sqrt(zeta^2 - w^2)``. Near a resonance this cancels like the double
precision form does, but 50 digits leave more than 40 after a 1e-8 resonance ratio.

Guards are scanned on a grid of 1/32 of the shortest period of the piece and each bracket
is bisected to ~1e-45: enter a flange (free, ``X`` crosses ``+-1`` outward), leave it
(``r X - 1`` falls to 0), slip end (``s V`` falls to 0), release (a stuck mass's
``|f_net|`` reaches ``beta_s``). At ``V = 0`` the Filippov rule decides: stick when
``|f_net| <= beta_s``, else slip towards ``f_net`` (``f_net`` includes the flange spring).
A grazing tangency closer than the grid resolves is not looked for: the referee is for
test cases whose events are transversal.

Refuses (``ValueError``) a rigid flange, a power-law flange, an exact resonance and critical
damping, for which the forms above do not hold.
"""

from __future__ import annotations

from dataclasses import dataclass

import mpmath as mp

DIGITS = 50
_BISECTIONS = 200


@dataclass(frozen=True)
class Event:
    t: mp.mpf
    kind: str
    x: mp.mpf
    v: mp.mpf
    side: int


class _Member:
    def __init__(self, osc):
        if osc.rigid or osc.exponent != 1.0:
            raise ValueError("linear_referee: spring flanges with exponent 1 only")
        self.K = mp.mpf(osc.K)
        self.beta = mp.mpf(osc.beta)
        self.beta_s = mp.mpf(osc.beta_s)
        self.zeta = mp.mpf(osc.zeta)
        self.terms = [(mp.mpf(F), mp.mpf(Om), mp.mpf(ph)) for F, Om, ph in osc.terms if F > 0.0]

    def forcing(self, t):
        return mp.fsum(F * mp.cos(Om * t + ph) for F, Om, ph in self.terms)

    def spring(self, x, r):
        return x + (r * self.K * (r * x - 1) if r else 0)

    def f_net(self, t, x, r):
        return self.forcing(t) - self.spring(x, r)


class _Piece:
    """The closed form of the slipping mode ``(r, s)`` from ``(t0, x0, v0)``."""

    def __init__(self, m: _Member, r: int, s: int, t0, x0, v0):
        self.r, self.s, self.t0 = r, s, t0
        w2 = 1 + (m.K if r else 0)
        z = m.zeta
        disc = z * z - w2
        if disc == 0:
            raise ValueError("linear_referee: critical damping is not supported")
        root = mp.sqrt(mp.mpc(disc))
        self.lam = (-z + root, -z - root)
        self.yc = ((-r - m.beta * s) if r else -m.beta * s) / w2
        self.q = []
        for F, Om, ph in m.terms:
            den = mp.mpc(w2 - Om * Om, 2 * z * Om)
            if den == 0:
                raise ValueError("linear_referee: an exact resonance is not supported")
            self.q.append((F * mp.expj(ph) / den, Om))
        y0 = x0 - r
        a = y0 - self.yc - mp.fsum(mp.re(Q * mp.expj(Om * t0)) for Q, Om in self.q)
        b = v0 - mp.fsum(mp.re(1j * Om * Q * mp.expj(Om * t0)) for Q, Om in self.q)
        l1, l2 = self.lam
        c1 = (b - l2 * a) / (l1 - l2)
        self.c = (c1, a - c1)
        self.fastest = max([abs(l1), abs(l2)] + [Om for _, Om in self.q])

    def deriv(self, t, k):
        """``d^k Y / dt^k`` at the absolute time ``t``."""
        tau = t - self.t0
        hom = mp.fsum(c * lam**k * mp.exp(lam * tau) for c, lam in zip(self.c, self.lam, strict=True))
        forced = mp.fsum((1j * Om) ** k * Q * mp.expj(Om * t) for Q, Om in self.q)
        out = mp.re(hom + forced)
        return out + self.yc if k == 0 else out

    def x(self, t):
        return self.r + self.deriv(t, 0)

    def v(self, t):
        return self.deriv(t, 1)


def _first_crossing(guards, t0, t_end, step):
    """The earliest ``(t, name)`` where a guard ``g`` passes from < 0 to >= 0 after ``t0``, or None."""
    prev = {name: g(t0) for name, g in guards.items()}
    a = t0
    while a < t_end:
        b = min(a + step, t_end)
        now = {name: g(b) for name, g in guards.items()}
        hits = []
        for name, g in guards.items():
            if prev[name] < 0 <= now[name]:
                lo, hi = a, b
                for _ in range(_BISECTIONS):
                    mid = (lo + hi) / 2
                    if g(mid) < 0:
                        lo = mid
                    else:
                        hi = mid
                    if hi - lo <= mp.mpf(10) ** (-DIGITS + 5) * max(1, abs(hi)):
                        break
                hits.append((hi, name))
        if hits:
            return min(hits, key=lambda h: h[0])
        prev, a = now, b
    return None


def simulate(osc, t_end: float, x0: float, v0: float, max_events: int = 100_000):
    """Events ``[Event, ...]`` and the final ``(t, x, v)`` of ``osc`` from ``(x0, v0)`` at 0, at 50 digits."""
    with mp.workdps(DIGITS):
        m = _Member(osc)
        t, x, v, t_end = mp.mpf(0), mp.mpf(x0), mp.mpf(v0), mp.mpf(t_end)
        r = 1 if x > 1 else (-1 if x < -1 else 0)
        s = _motion_at_rest(m, t, x, r) if v == 0 else (1 if v > 0 else -1)
        events: list[Event] = []
        while t < t_end and len(events) < max_events:
            if s == 0:
                f = lambda tt, x=x, r=r: abs(m.f_net(tt, x, r)) - m.beta_s  # noqa: E731
                period = min((2 * mp.pi / Om for _, Om, _ in m.terms if Om > 0), default=t_end)
                hit = _first_crossing({"release": f}, t, t_end, period / 64)
                if hit is None:
                    t = t_end
                    break
                t = hit[0]
                s = 1 if m.f_net(t, x, r) > 0 else -1
                events.append(Event(t, "release", x, mp.mpf(0), 0))
                continue
            piece = _Piece(m, r, s, t, x, v)
            guards = {"slip_end": lambda tt, p=piece, s=s: -s * p.v(tt)}
            if r == 0:
                guards["enter"] = (lambda tt, p=piece: p.x(tt) - 1) if s > 0 else (lambda tt, p=piece: -1 - p.x(tt))
            elif s == -r:
                guards["leave"] = lambda tt, p=piece, r=r: 1 - r * p.x(tt)
            step = 2 * mp.pi / piece.fastest / 32
            hit = _first_crossing(guards, t, t_end, step)
            if hit is None:
                x, v, t = piece.x(t_end), piece.v(t_end), t_end
                break
            t, name = hit
            x, v = piece.x(t), piece.v(t)
            if name == "enter":
                r = s
                x = mp.mpf(r)
                events.append(Event(t, "contact_start", x, v, r))
            elif name == "leave":
                events.append(Event(t, "contact_end", mp.mpf(r), v, r))
                x, r = mp.mpf(r), 0
            else:  # V = 0: the Filippov rule
                v = mp.mpf(0)
                s_new = _motion_at_rest(m, t, x, r)
                if s_new == 0:
                    events.append(Event(t, "stick", x, v, 0))
                elif s_new != s:
                    events.append(Event(t, "reversal", x, v, 0))
                s = s_new
        return events, (t, x, v)


def _motion_at_rest(m: _Member, t, x, r) -> int:
    f = m.f_net(t, x, r)
    if abs(f) <= m.beta_s:
        return 0
    return 1 if f > 0 else -1


def event_times(events) -> list[float]:
    return [float(e.t) for e in events]
