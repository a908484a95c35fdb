"""A run of a :class:`~impactosc.model.TapePath` in SI units: flange forces, impulses, impacts, the head.

:class:`TapePathRun` reads a :class:`~impactosc.results.MechanicalSolution` of
``path.mechanical_system()`` and turns it into per-guide observables in newtons, seconds and
metres. The flange impulses are exact integrals, not sums of samples: between two events
the chain is linear, so the momentum balance of each piece,
``K_mode int q dt = int f dt + const (b - a) - M Delta v - C Delta q`` (the coordinates held by
a stuck friction or a resting stop are constant), gives ``int q dt`` from the piece's end
states, and with it the integral of every engaged spring flange's force and of every
resting stop's reaction; an impact's impulse is the jump of momentum on its coordinate.
"""

from __future__ import annotations

import math

import numpy as np

from .._util import validation as _v
from ..model._tape_path import TapePath

__all__ = ["TapePathRun"]


def _forcing_integral(system, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``int_a^b sum_h f_h cos(omega_h t + phi_h) dt`` in closed form, per interval: shape ``(len(a), n)``."""
    out = np.zeros((a.size, system.n))
    for f, om, ph in system.harmonics:
        if om == 0.0:
            out += np.outer(np.cos(ph) * (b - a), f)
        else:
            out += np.outer((np.sin(om * b + ph) - np.sin(om * a + ph)) / om, f)
    return out


class TapePathRun:
    """Per-guide SI observables of one run of a tape path on the exact n-DOF backend.

    Parameters
    ----------
    path : TapePath
        The path whose :meth:`~impactosc.model.TapePath.mechanical_system` was run.
    solution : MechanicalSolution
        The run (``simulate_mechanical(path.mechanical_system(phase), ...)``), in the path's
        nondimensional units.
    phase : float
        The reel's phase the system was built with (:meth:`TapePath.mechanical_system`).

    Examples
    --------
    >>> import numpy as np
    >>> from impactosc import Guide, TapeDrive, TapePath, TapePathRun, simulate_mechanical
    >>> path = TapePath(TapeDrive(clearance=30e-6, friction=0.0), [Guide(0.01), Guide(0.03)])
    >>> sol = simulate_mechanical(path.mechanical_system(), path.seconds_to_time(2e-3), [0, 0], [0, 0])
    >>> run = TapePathRun(path, sol)
    >>> forces = run.mean_flange_force()          # N, one per guide
    >>> t = np.linspace(0.0, run.duration, 2001)
    >>> x_head = run.lateral_motion(t, 0.02)      # m, at the head 20 mm from the pack
    >>> from impactosc.signal import spectrum
    >>> freq, amp = spectrum(t, x_head, resolution=1e3)
    """

    def __init__(self, path: TapePath, solution, phase: float = 0.0):
        if not isinstance(path, TapePath):
            raise TypeError(f"path must be a TapePath, got {type(path).__name__}")
        self.path = path
        self.solution = solution
        self.phase = _v.real("phase", phase)
        system = path.mechanical_system(self.phase)
        if getattr(solution, "n", None) != system.n:
            raise ValueError(f"solution must be a run of path.mechanical_system() ({system.n} coordinates), "
                             f"got {solution!r}")
        self._system = system
        self._guides = path.contact_guides()
        self._impulse, self._impacts = self._integrate()

    # -- basic quantities ----------------------------------------------------------------
    @property
    def duration(self) -> float:
        """Seconds of tape motion the run covered."""
        return float(self.path.time_to_seconds(self.solution.t))

    @property
    def status(self) -> int:
        """The run's status (0: reached its end; see :class:`MechanicalSolution`)."""
        return int(self.solution.status)

    def _guide(self, guide: int) -> int:
        g = _v.integer("guide", guide, minimum=0)
        if g >= self.path.n:
            raise ValueError(f"guide must be < {self.path.n} (the path's guides), got {guide!r}")
        return g

    def _contacts_of(self, guide: int, side: int | None) -> list[int]:
        if side not in (None, 1, -1):
            raise ValueError(f"side must be +1 (upper flange), -1 (lower) or None (both), got {side!r}")
        g = self._guide(guide)
        return [c for c, (i, s) in enumerate(self._guides) if i == g and (side is None or s == side)]

    # -- the integrals -------------------------------------------------------------------
    def _integrate(self) -> tuple[np.ndarray, list[list[tuple[float, float]]]]:
        """Total impulse of every contact (nondimensional) and its impacts ``(t, impulse)``."""
        system, sol = self._system, self.solution
        nc = len(system.contacts)
        impulse = np.zeros(nc)
        impacts: list[list[tuple[float, float]]] = [[] for _ in range(nc)]
        coord = np.array([int(np.flatnonzero(c.normal)[0]) for c in system.contacts], dtype=int)
        side = np.array([float(c.normal[k]) for c, k in zip(system.contacts, coord, strict=True)])
        ev = sol.events
        cuts = np.unique(np.concatenate([[0.0], np.asarray(ev.t, dtype=float), [sol.t]]))
        cuts = cuts[(cuts >= 0.0) & (cuts <= sol.t)]
        if cuts.size < 2:
            return impulse, impacts
        a, b = cuts[:-1], cuts[1:]
        m = a.size
        qa, va, qb, vb, engaged, fixed, slip, resting = self._piece_states(cuts, coord)
        dt = b - a
        f_int = _forcing_integral(system, a, b)
        rhs_all = f_int - (vb - va) @ system.M.T - (qb - qa) @ system.C.T
        q_int = np.zeros((m, system.n))
        signature = np.concatenate([engaged, fixed, slip], axis=1)
        _, group = np.unique(signature, axis=0, return_inverse=True)
        group = group.reshape(-1)
        fric = np.zeros(system.n)
        for f in system.friction:
            fric[f.coordinate] = f.kinetic
        stiff = np.array([c.stiffness for c in system.contacts])
        gap0 = np.array([c.gap for c in system.contacts])
        for g in np.unique(group):
            sel = np.flatnonzero(group == g)
            p0 = sel[0]
            kmode = system.K.copy()
            const = -fric * slip[p0]
            for ce in map(int, np.flatnonzero(engaged[p0])):
                kmode[coord[ce], coord[ce]] += stiff[ce]
                const[coord[ce]] += stiff[ce] * gap0[ce] * side[ce]
            fx = fixed[p0]
            q_int[np.ix_(sel, fx)] = qa[np.ix_(sel, fx)] * dt[sel, None]
            free = ~fx
            if np.any(free):
                rhs = (rhs_all[sel] + const[None, :] * dt[sel, None])[:, free]
                rhs -= q_int[np.ix_(sel, fx)] @ kmode[np.ix_(free, fx)].T
                q_int[np.ix_(sel, free)] = np.linalg.solve(kmode[np.ix_(free, free)], rhs.T).T
        for c in range(nc):
            on = engaged[:, c]
            if np.any(on):
                impulse[c] += stiff[c] * float(np.sum(side[c] * q_int[on, coord[c]] - gap0[c] * dt[on]))
            if system.contacts[c].rigid:
                i = coord[c]  # resting on the stop: its reaction holds row i in balance
                rest = resting[:, c]
                if np.any(rest):
                    reaction = f_int[rest, i] - (qb[rest] - qa[rest]) @ system.C[i] - q_int[rest] @ system.K[i]
                    impulse[c] += side[c] * float(np.sum(reaction))
        self._add_impacts(impulse, impacts, coord, side, vb, cuts)
        return impulse, impacts

    def _piece_states(self, cuts: np.ndarray, coord: np.ndarray):
        """States at both ends of every piece between the cuts, and its mode, from the events table.

        The mode (engaged spring flanges, stuck coordinates, resting stops) follows the events
        from the first piece's, which is sampled; a slip that starts and ends at rest is sampled
        mid-way for its sign.
        """
        qa, va, qb, vb, mid_q, mid_v = self._end_states(cuts)
        engaged, fixed, resting = self._modes(cuts, coord, va[0], vb[0], mid_q, mid_v)
        system, sol = self._system, self.solution
        n = system.n
        fric_coord = np.array([f.coordinate for f in system.friction], dtype=int)
        slip = np.zeros((cuts.size - 1, n))
        for j in fric_coord:
            slip[:, j] = np.where(fixed[:, j], 0.0, np.sign(va[:, j] + vb[:, j]))
        # A slip that starts and ends at rest (a release, then a reversal or a stick): its sign mid-way.
        unsure = np.flatnonzero(np.any((slip == 0.0) & ~fixed & np.isin(np.arange(n), fric_coord)[None, :], axis=1))
        if unsure.size:
            _, v_mid = sol.sample(0.5 * (cuts[unsure] + cuts[unsure + 1]))
            for j in fric_coord:
                col = slip[unsure, j]
                slip[unsure, j] = np.where(col == 0.0, np.where(fixed[unsure, j], 0.0, np.sign(v_mid[:, j])), col)
        return qa, va, qb, vb, engaged, fixed, slip, resting

    def _end_states(self, cuts: np.ndarray):
        """``(q, v)`` after the start and before the end of every piece, and mid-way through the first.

        The state after an instant is its last event's; the state before it is its first event's
        (positions and, but for an impact, velocities are continuous there), an elastic impact's
        velocity before undone with Newton's law. Where the table cannot tell (the start of the
        run, a plastic impact, a rest reached without an impact row) the closed form is sampled.
        """
        system, sol = self._system, self.solution
        ev = sol.events
        times = np.asarray(ev.t, dtype=float)
        kinds = np.asarray(ev.kind)
        index = np.asarray(ev.index, dtype=int)
        m, n = cuts.size - 1, system.n
        first = np.searchsorted(times, cuts, side="left")
        last = np.searchsorted(times, cuts, side="right") - 1
        has = last >= first  # an event instant
        qa, va = np.empty((m, n)), np.empty((m, n))
        qb, vb = np.empty((m, n)), np.empty((m, n))
        qa[has[:-1]], va[has[:-1]] = ev.q[last[:-1][has[:-1]]], ev.v[last[:-1][has[:-1]]]
        qb[has[1:]], vb[has[1:]] = ev.q[first[1:][has[1:]]], ev.v[first[1:][has[1:]]]
        if not has[-1]:
            qb[-1], vb[-1] = sol.q, sol.v
        ask: list[tuple[str, int, float]] = []  # (which, piece, time) to sample
        if not has[0]:
            ask.append(("a", 0, 0.0))
        minv = system.minv
        for kb in map(int, np.flatnonzero(has[1:])):
            r = first[kb + 1]
            if kinds[r] == "impact":
                con = system.contacts[int(index[r])]
                if con.restitution > 0.0:
                    nv_before = -float(con.normal @ vb[kb]) / con.restitution
                    mn = minv @ con.normal
                    vb[kb] = vb[kb] + (1.0 + con.restitution) * nv_before * mn / float(con.normal @ mn)
                    continue
            if kinds[r] in ("impact", "rest"):
                ask.append(("b", kb, float(np.nextafter(cuts[kb + 1], -np.inf))))
        ask.append(("m", 0, 0.5 * (cuts[0] + cuts[1])))
        # Sampled states, in one call (each piece evaluated once).
        qs, vs = sol.sample(np.maximum([t for _, _, t in ask], cuts[0]))
        mid_q, mid_v = None, None
        for (which, k, _), q, v in zip(ask, qs, vs, strict=True):
            if which == "a":
                qa[k], va[k] = q, v
            elif which == "b":
                qb[k], vb[k] = q, v
            else:
                mid_q, mid_v = q, v
        return qa, va, qb, vb, mid_q, mid_v

    def _modes(self, cuts: np.ndarray, coord: np.ndarray, va0, vb0, mid_q, mid_v):
        """Engaged spring flanges, fixed coordinates and resting stops of every piece: shapes ``(pieces, .)``.

        The first piece's from its samples (``va0``, ``vb0`` at its ends, ``mid_q``, ``mid_v``
        mid-way), then each switching event sets its flag for the pieces after it.
        """
        system, ev = self._system, self.solution.events
        times = np.asarray(ev.t, dtype=float)
        kinds = np.asarray(ev.kind)
        index = np.asarray(ev.index, dtype=int)
        m, n, nc = cuts.size - 1, system.n, len(system.contacts)
        spring = np.array([not c.rigid for c in system.contacts], dtype=bool)
        eng = (system.gaps(mid_q) > 0.0) & spring
        fix = (va0 == 0.0) & (mid_v == 0.0) & (vb0 == 0.0)
        rest = np.array([c.rigid and fix[coord[i]] and abs(float(system.gaps(mid_q)[i])) <= 1e-9 * c.gap
                         for i, c in enumerate(system.contacts)], dtype=bool)
        fric_coord = np.array([f.coordinate for f in system.friction], dtype=int)
        engaged, fixed, resting = np.empty((m, nc), bool), np.empty((m, n), bool), np.empty((m, nc), bool)
        switches = np.flatnonzero(np.isin(kinds, ("contact_start", "contact_end", "stick", "release", "rest",
                                                  "lift")))
        piece = np.searchsorted(cuts, times[switches], side="right") - 1  # the piece each switch starts
        s = 0
        for k in range(m):
            while s < switches.size and piece[s] <= k:
                r = switches[s]
                kind, i = kinds[r], index[r]
                if kind in ("contact_start", "contact_end"):
                    eng[i] = kind == "contact_start"
                elif kind in ("stick", "release"):
                    fix[fric_coord[i]] = kind == "stick"
                else:
                    rest[i] = kind == "rest"
                    fix[coord[i]] = kind == "rest"
                s += 1
            engaged[k], fixed[k], resting[k] = eng, fix, rest
        return engaged, fixed, resting

    def _add_impacts(self, impulse, impacts, coord, side, v_before, cuts) -> None:
        """The momentum jump of every instant with an impact, on the coordinate of its stop.

        The velocity after the instant is that of its last event (an impact and the rest it
        ends in share a time); the one before, that of the piece that ends there.
        """
        system, ev = self._system, self.solution.events
        times = np.asarray(ev.t, dtype=float)
        seen: set[tuple[float, int]] = set()
        for r in np.flatnonzero(np.isin(ev.kind, ("impact", "rest"))):
            t, c = float(times[r]), int(ev.index[r])
            if (t, c) in seen:
                continue
            seen.add((t, c))
            k = int(np.searchsorted(cuts, t)) - 1  # the piece that ends at this instant
            if k < 0:
                continue
            last = int(np.searchsorted(times, t, side="right")) - 1
            i = coord[c]
            jump = -side[c] * system.M[i, i] * (ev.v[last][i] - v_before[k, i])
            impulse[c] += jump
            if ev.kind[r] == "impact":
                impacts[c].append((t, float(jump)))

    # -- SI outputs ----------------------------------------------------------------------
    def flange_impulse(self, guide: int | None = None, side: int | None = None):
        """Integral in N s of the flange force over the run: of guide ``guide`` (all guides when None).

        ``side`` +1 (upper flange), -1 (lower) or None (both). Spring flanges: ``k0 d`` over
        every contact; rigid flanges: the impacts' impulses and the reaction while resting.
        """
        if guide is None:
            return np.array([self.flange_impulse(g, side) for g in range(self.path.n)])
        return float(sum(self._impulse[c] for c in self._contacts_of(guide, side))) * self.path.impulse_scale

    def mean_flange_force(self, guide: int | None = None, side: int | None = None):
        """Time average in N of the flange force over the run (the quantity of the paper's Fig. 7-8)."""
        return self.flange_impulse(guide, side) / self.duration

    def impacts(self, guide: int, side: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(times in s, impulses in N s)`` of the impacts on guide ``guide``'s rigid flanges.

        For spring flanges use :meth:`contact_starts` (a spring contact has no impulse of its own).
        """
        rows = sorted(r for c in self._contacts_of(guide, side) for r in self._impacts[c])
        t = np.array([r[0] for r in rows])
        j = np.array([r[1] for r in rows])
        return self.path.time_to_seconds(t), j * self.path.impulse_scale

    def contact_starts(self, guide: int, side: int | None = None) -> np.ndarray:
        """Times in s at which guide ``guide``'s flanges are touched: spring contacts closing, rigid impacts."""
        contacts = self._contacts_of(guide, side)
        ev = self.solution.events
        sel = np.isin(ev.index, contacts) & np.isin(ev.kind, ("contact_start", "impact"))
        return np.asarray(self.path.time_to_seconds(np.asarray(ev.t[sel], dtype=float)))

    def impacts_per_second(self, guide: int | None = None, side: int | None = None):
        """Flange contacts (spring contacts closing, rigid impacts) per second on a guide (all when None)."""
        if guide is None:
            return np.array([self.impacts_per_second(g, side) for g in range(self.path.n)])
        return self.contact_starts(guide, side).size / self.duration

    def entry_speeds(self, guide: int, side: int | None = None) -> np.ndarray:
        """Speeds in m/s at which guide ``guide``'s flanges are entered (spring contacts closing, rigid impacts)."""
        contacts = self._contacts_of(guide, side)
        ev = self.solution.events
        sel = np.isin(ev.index, contacts) & np.isin(ev.kind, ("contact_start", "impact"))
        v = np.asarray(ev.v, dtype=float).reshape(len(ev), self.path.n)[sel, self._guide(guide)]
        return np.abs(v) * (self.path.length_scale / self.path.time_scale)

    def contact_observables(self, guide: int, side: int | None = None) -> dict[str, float]:
        """What a flange sensor at guide ``guide`` reads, in SI, as :func:`impactosc.results.contact_observables`.

        With ``m`` the guide's lumped mass (the diagonal of :attr:`TapePath.mass_matrix`), ``k0``
        its flange stiffness and ``v_i`` the entry speeds (:meth:`entry_speeds`), over the
        run's :attr:`duration` ``T``:

        * ``impact_rate`` (1/s), ``mean_force`` (N), ``mean_impulse`` (N s per contact; exact integrals);
        * ``ae_impact_sum = sum_i sqrt(k0 m) v_i / T`` (N/s), the elastic impact force of each
          entry summed per second (the AE proxy);
        * ``impact_energy_rate = sum_i m v_i^2 / 2 / T`` (W), the kinetic energy brought in;
        * ``dissipation_rate`` (W): ``(1 - e^2) m v_i^2 / 2`` per impact on a rigid flange; NaN on
          a spring flange (the n-DOF backend keeps no per-contact damping and friction integrals).

        Peak forces per contact and the rms force are not given: the n-DOF backend keeps no
        extremum or integral of the squared force per contact (sample :meth:`flange_force`).
        """
        g = self._guide(guide)
        contacts = self._contacts_of(g, side)
        speeds = self.entry_speeds(g, side)
        seconds = self.duration
        mass = float(self.path.mass_matrix[g, g])
        count = speeds.size
        laws = {self._system.contacts[c].law for c in contacts}
        dissipation = math.nan
        if laws == {"rigid"}:
            ev = self.solution.events
            e = {c: float(self._system.contacts[c].restitution) for c in contacts}
            sel = np.isin(ev.index, contacts) & (ev.kind == "impact")
            factor = np.array([1.0 - e[int(c)] ** 2 for c in np.asarray(ev.index)[sel]])
            dissipation = float(np.sum(factor * 0.5 * mass * speeds**2)) / seconds if count else 0.0
        impulse = self.flange_impulse(g, side)
        return {"impact_rate": count / seconds,
                "mean_force": impulse / seconds,
                "mean_impulse": impulse / count if count else math.nan,
                "ae_impact_sum": float(np.sum(np.sqrt(self.path.flange_stiffness(g) * mass) * speeds)) / seconds,
                "impact_energy_rate": float(np.sum(0.5 * mass * speeds**2)) / seconds,
                "dissipation_rate": dissipation}

    def lateral_motion(self, t_s, position: float) -> np.ndarray:
        """Lateral tape position in m at ``position`` (m along the path) at times ``t_s`` (s).

        Linear between the supports: the pack end (moving with the reel's run-out), each guide
        (its coordinate plus its roller's run-out), and the fixed end of ``end_span``.
        """
        path = self.path
        pos = _v.real("position", position)
        supports = [0.0] + [g.position for g in path.guides]
        if path.end_span is not None:
            supports.append(path.guides[-1].position + path.end_span)
        if not 0.0 <= pos <= supports[-1]:
            raise ValueError(f"position must lie on the path, in [0, {supports[-1]!r}] m, got {position!r}")
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        q, _ = self.solution.sample(path.seconds_to_time(t))
        x = [path.pack_runout(t, self.phase)]
        x += list((q * path.length_scale + path.roller_runout(t)).T)
        if path.end_span is not None:
            x.append(np.zeros_like(t))
        k = min(int(np.searchsorted(supports, pos, side="right")) - 1, len(supports) - 2)
        w = (pos - supports[k]) / (supports[k + 1] - supports[k])
        return (1.0 - w) * x[k] + w * x[k + 1]

    def flange_force(self, t_s, guide: int, side: int | None = None) -> np.ndarray:
        """Spring-flange force in N on guide ``guide`` at times ``t_s`` (s); rigid flanges: not a function of time."""
        contacts = self._contacts_of(guide, side)
        if any(self._system.contacts[c].rigid for c in contacts):
            raise ValueError(f"guide {guide} has rigid flanges: their force is impulses (use impacts()), "
                             "not a function of time")
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        q, _ = self.solution.sample(self.path.seconds_to_time(t))
        gaps = self._system.gaps(q)
        out = np.zeros(t.size)
        for c in contacts:
            out += self._system.contacts[c].stiffness * np.maximum(gaps[:, c], 0.0)
        return out * self.path.force_scale
