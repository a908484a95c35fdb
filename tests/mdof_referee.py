"""An independent referee for linear mechanical systems with contacts and friction: scipy's solve_ivp.

Written from the model's definition only (the module docstring of
``impactosc.model._mechanical``), sharing no code with the exact backend: the forces from
``M, C, K``, the harmonics and the engaged springs; the constraint forces of stuck
coordinates and resting stops from the KKT system ``[[M, G^T], [G, 0]] [a; -lambda] = [r; 0]``
(no assumption that the constraints decouple); events by solve_ivp's root finding on the
dense output of DOP853 at tight tolerances; the same transition rule (stick test, impact
law, chatter summed into rest below a flight height of 1e-13).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

RTOL, ATOL = 1e-12, 1e-13
CHATTER_HEIGHT = 1e-13


class Referee:
    def __init__(self, system):
        self.s = system
        self.n = system.n

    # --- forces and constraints ---------------------------------------------------------
    def _forces(self, t, q, v, engaged, motion):
        s = self.s
        r = s.forcing(t) - s.C @ v - s.K @ q
        for c, contact in enumerate(s.contacts):
            if engaged[c]:
                r = r - contact.stiffness * (contact.normal @ q - contact.gap) * contact.normal
        for i, fr in enumerate(s.friction):
            if motion[i] != 0:
                r[fr.coordinate] -= fr.kinetic * motion[i]
        return r

    def _constraints(self, resting, motion):
        rows = [c.normal for c, on in zip(self.s.contacts, resting, strict=True) if on]
        for i, fr in enumerate(self.s.friction):
            if motion[i] == 0:
                e = np.zeros(self.n)
                e[fr.coordinate] = 1.0
                rows.append(e)
        return np.array(rows).reshape(len(rows), self.n)

    def accel(self, t, q, v, mode):
        """Acceleration and the constraint forces (stops: lambda >= 0 pushes back; friction: the holding force)."""
        engaged, resting, motion = mode
        r = self._forces(t, q, v, engaged, motion)
        G = self._constraints(resting, motion)
        k = G.shape[0]
        if k == 0:
            return np.linalg.solve(self.s.M, r), np.zeros(0)
        kkt = np.zeros((self.n + k, self.n + k))
        kkt[:self.n, :self.n] = self.s.M
        kkt[:self.n, self.n:] = G.T
        kkt[self.n:, :self.n] = G
        sol = np.linalg.solve(kkt, np.concatenate([r, np.zeros(k)]))
        # M a + G^T mu = r: mu are the forces the constraints take; a stop pushes with -mu n.
        return sol[:self.n], sol[self.n:]

    # --- guards: (function, kind, index, sign) rising through zero ----------------------------
    def _guards(self, mode):
        engaged, resting, motion = mode
        out = []
        nres = sum(resting)
        k = 0
        for c, contact in enumerate(self.s.contacts):
            if contact.rigid and resting[c]:
                j = k
                out.append((lambda t, y, j=j: -self.accel(t, y[:self.n], y[self.n:], mode)[1][j], "lift", c, 0))
                k += 1
            elif contact.rigid or not engaged[c]:
                out.append((lambda t, y, c=c: self.s.contacts[c].normal @ y[:self.n] - self.s.contacts[c].gap,
                            "impact" if contact.rigid else "enter", c, 0))
            else:
                out.append((lambda t, y, c=c: -(self.s.contacts[c].normal @ y[:self.n] - self.s.contacts[c].gap),
                            "leave", c, 0))
        k = nres
        for i, fr in enumerate(self.s.friction):
            if motion[i] != 0:
                out.append((lambda t, y, i=i, j=fr.coordinate: -motion[i] * y[self.n + j], "slip_end", i, 0))
            else:
                j = k
                # the holding force is -mu_j: it slips towards sign when sign * mu_j rises to mu_s
                for sign in (1, -1):
                    out.append((lambda t, y, j=j, sign=sign, ms=fr.static:
                                sign * self.accel(t, y[:self.n], y[self.n:], mode)[1][j] - ms,
                                "release", i, sign))
                k += 1
        return out

    def _stick_test(self, t, q, v, mode, i):
        engaged, resting, motion = mode
        motion = list(motion)
        motion[i] = 0
        _, mu = self.accel(t, q, v, (engaged, resting, tuple(motion)))
        j = sum(resting) + sum(1 for m in motion[:i] if m == 0)
        hold = -mu[j]
        if abs(hold) <= self.s.friction[i].static:
            return 0
        return 1 if hold < 0 else -1  # it slips against the force that would have had to hold it

    # --- the run --------------------------------------------------------------------------
    def run(self, t_end, q0, v0, max_events=10_000):
        n, s = self.n, self.s
        q, v = np.array(q0, float), np.array(v0, float)
        engaged = tuple((not c.rigid) and (c.normal @ q - c.gap) > 0 for c in s.contacts)
        resting = tuple(False for _ in s.contacts)
        motion = [int(np.sign(v[f.coordinate])) for f in s.friction]
        mode = (engaged, resting, tuple(motion))
        for i in range(len(motion)):
            if motion[i] == 0:
                motion[i] = self._stick_test(0.0, q, v, mode, i)
                mode = (engaged, resting, tuple(motion))
        t = 0.0
        events = []
        while t < t_end and len(events) < max_events:
            guards = self._guards(mode)
            fns = []
            for fn, *_ in guards:
                fn.terminal = True
                fn.direction = 1
                fns.append(fn)

            def rhs(t, y, mode=mode):
                a, _ = self.accel(t, y[:n], y[n:], mode)
                return np.concatenate([y[n:], a])

            sol = solve_ivp(rhs, (t, t_end), np.concatenate([q, v]), method="DOP853", rtol=RTOL, atol=ATOL,
                            events=fns)
            if sol.status != 1:
                break
            hits = [(sol.t_events[g][0], g) for g in range(len(guards)) if len(sol.t_events[g])]
            te, g = min(hits)
            y = sol.y_events[g][0]
            t, q, v = te, y[:n].copy(), y[n:].copy()
            _, kind, idx, sign = guards[g]
            engaged, resting, motion = (list(x) for x in mode)
            if kind == "enter":
                engaged[idx] = True
                events.append((t, "contact_start", idx))
            elif kind == "leave":
                engaged[idx] = False
                events.append((t, "contact_end", idx))
            elif kind == "lift":
                resting[idx] = False
                events.append((t, "lift", idx))
            elif kind == "release":
                motion[idx] = sign
                events.append((t, "release", idx))
            elif kind == "slip_end":
                v[s.friction[idx].coordinate] = 0.0
                new = self._stick_test(t, q, v, (tuple(engaged), tuple(resting), tuple(motion)), idx)
                motion[idx] = new
                events.append((t, "stick" if new == 0 else "reversal", idx))
            else:  # impact
                c = s.contacts[idx]
                mn = np.linalg.solve(s.M, c.normal)
                u = c.normal @ v
                if u > 0:
                    v = v - (1 + c.restitution) * u / (c.normal @ mn) * mn
                events.append((t, "impact", idx))
                a, _ = self.accel(t, q, v, (tuple(engaged), tuple(resting), tuple(motion)))
                push = c.normal @ a
                w = max(-(c.normal @ v), 0.0)
                if c.restitution < 1 and push > 0 and w * w / (2 * push) <= CHATTER_HEIGHT * max(1.0, c.gap):
                    v = v - (c.normal @ v) / (c.normal @ mn) * mn
                    resting[idx] = True
                    events.append((t, "rest", idx))
                for i, fr in enumerate(s.friction):
                    sg = int(np.sign(v[fr.coordinate]))
                    if sg != 0 and sg != motion[i]:
                        motion[i] = sg
            mode = (tuple(engaged), tuple(resting), tuple(motion))
        return events
