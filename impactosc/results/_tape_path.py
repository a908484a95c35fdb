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

import numpy as np

from .._util import validation as _v
from ..model._tape_path import TapePath

__all__ = ["TapePathRun"]


def _forcing_integral(system, a: float, b: float) -> np.ndarray:
    """``int_a^b sum_h f_h cos(omega_h t + phi_h) dt`` in closed form."""
    out = np.zeros(system.n)
    for f, om, ph in system.harmonics:
        if om == 0.0:
            out += f * np.cos(ph) * (b - a)
        else:
            out += f * (np.sin(om * b + ph) - np.sin(om * a + ph)) / om
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
        qa, va = sol.sample(a)
        qb, vb = sol.sample(np.maximum(np.nextafter(b, -np.inf), a))
        qm, vm = sol.sample(0.5 * (a + b))
        M, C, K = system.M, system.C, system.K
        fric = {f.coordinate: f.kinetic for f in system.friction}
        for p in range(a.size):
            dt = b[p] - a[p]
            gaps = system.gaps(qm[p])
            engaged = [c for c in range(nc) if not system.contacts[c].rigid and gaps[c] > 0.0]
            fixed = np.array([va[p, j] == 0.0 and vm[p, j] == 0.0 and vb[p, j] == 0.0 for j in range(system.n)])
            kmode = K.copy()
            const = np.zeros(system.n)
            for c in engaged:
                k = system.contacts[c].stiffness
                kmode[coord[c], coord[c]] += k
                const[coord[c]] += k * system.contacts[c].gap * side[c]
            for j, mu in fric.items():
                if not fixed[j]:
                    const[j] -= mu * np.sign(vm[p, j])
            f_int = _forcing_integral(system, a[p], b[p])
            q_int = qm[p] * 0.0
            q_int[fixed] = qa[p, fixed] * dt
            free = ~fixed
            if np.any(free):
                rhs = (f_int + const * dt - M @ (vb[p] - va[p]) - C @ (qb[p] - qa[p]))[free]
                rhs -= kmode[np.ix_(free, fixed)] @ q_int[fixed]
                q_int[free] = np.linalg.solve(kmode[np.ix_(free, free)], rhs)
            for c in engaged:
                impulse[c] += system.contacts[c].stiffness * (side[c] * q_int[coord[c]] - system.contacts[c].gap * dt)
            for c in range(nc):
                if system.contacts[c].rigid and fixed[coord[c]] and abs(gaps[c]) <= 1e-9 * system.contacts[c].gap:
                    i = coord[c]  # resting on the stop: its reaction holds row i in balance
                    impulse[c] += side[c] * (f_int[i] - (C @ (qb[p] - qa[p]))[i] - (K @ q_int)[i])
        self._add_impacts(impulse, impacts, coord, side, vb, cuts)
        return impulse, impacts

    def _add_impacts(self, impulse, impacts, coord, side, v_before, cuts) -> None:
        """The momentum jump of every instant with an impact, on the coordinate of its stop."""
        system, ev = self._system, self.solution.events
        done: set[tuple[float, int]] = set()
        for row in ev:
            if row.kind not in ("impact", "rest"):
                continue
            c = int(row.index)
            if (row.t, c) in done:
                continue
            done.add((row.t, c))
            k = int(np.searchsorted(cuts, row.t)) - 1  # the piece that ends at this instant
            after = ev[(ev.t == row.t)]
            v_after = after.v[-1]
            i = coord[c]
            jump = -side[c] * system.M[i, i] * (v_after[i] - v_before[k, i]) if k >= 0 else 0.0
            impulse[c] += jump
            if row.kind == "impact":
                impacts[c].append((float(row.t), float(jump)))

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
