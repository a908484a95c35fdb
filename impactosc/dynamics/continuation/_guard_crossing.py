"""A user system's grazing crossed: the map with the grazed guard taken away, and the impacting orbits of a reset.

The changes of unknowns of :mod:`._grazing`, written for a :class:`~impactosc.HybridSystem`:

* the **virtual** map (:class:`GuardlessProblem`): the system with the grazed guard taken
  away (every other guard, mode and parameter kept: the same definition, one guard fewer),
  smooth through the grazing. Its grazing test is the guard's value ``h`` at its extremum
  nearest to firing along the orbit, ``-d h`` for a guard that fires in direction ``d``
  (positive while the orbit stays clear), with its exact gradient: the guard's derivatives
  times the sensitivity of the state at the extremum (:meth:`HybridMap.tangent_until`); the
  extremum's own shift drops out, since ``dh/dt = 0`` there;
* for a guard with a reset (a rigid stop's ``v -> -e v``) the **impact formulation**
  (:class:`GuardImpact`): unknowns the impact time ``t_i``, the state ``y_-`` just before it
  and the parameters; the orbit leaves with ``R(y_-)`` and must return to ``y_-`` after the
  map's span on the virtual map, with ``h(y_-, t_i) = 0``. Regular through zero impact speed,
  where it is the grazing orbit (Nordmark's square root is the real map's, not this one's).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...backends._hybrid import simulate_system
from ...model.hybrid._definition import HybridMode, HybridSystem
from ...model.hybrid._numeric import rules
from .._guard_extrema import _extrema_integrator
from ..hybrid_map import HybridMap
from ._hybrid_problem import SystemProblem

__all__ = ["without_guard", "GuardlessProblem", "GuardImpact", "guard_of"]


def guard_of(system: HybridSystem, name: str):
    """The guard ``name`` of ``system`` and its index."""
    g = system.guard_names.index(name)
    return system.guards[g], g


def without_guard(system: HybridSystem, name: str) -> HybridSystem:
    """``system`` with the guard ``name`` taken away (its modes, other guards and parameters kept as they are)."""
    if name not in system.guard_names:
        raise ValueError(f"{system.name}: no guard named {name!r}; the guards are {list(system.guard_names)}")
    if name == system.section:
        raise ValueError(f"{system.name}: the guard {name!r} is the section of the map, it cannot be taken away")
    n = system.dimension
    guard, g = guard_of(system, name)
    clear = _clear_side_conditions(system, g, guard.direction)
    modes = [HybridMode(m.name, tuple(m.field[:n]), entry=tuple(c for i, c in enumerate(m.entry) if i not in clear[k]),
                        integrands=dict(m.integrands)) for k, m in enumerate(system.modes)]
    guards = [g for g in system.guards if g.name != name]
    return HybridSystem(system.states, dict(system.parameters), modes, guards, integrals=system.integrals,
                        period=system.period, section=system.section, name=f"{system.name} without {name!r}")


def _clear_side_conditions(system: HybridSystem, g: int, direction: int) -> list[set]:
    """Per mode, the entry conditions that say the state lies on the clear side of guard ``g`` (``c = -d h``).

    A mode confined to one side of the guard (the free motion between two flanges, say) says so in
    its entry conditions; with the guard taken away the motion goes on past it, and the conditions
    go with the guard. They are recognised by value (``c + d h = 0`` at a few random states and
    times at the system's parameters), whatever the expressions' form.
    """
    rule = rules(system)
    p = system.parameter_values
    n_all = system.dimension + len(system.integrals)
    rng = np.random.default_rng(0)
    points = [(float(rng.uniform(0.0, 10.0)), list(rng.normal(0.0, 2.0, n_all))) for _ in range(4)]
    guard_values = [float(rule.guard[g](t, y, p)[0]) for t, y in points]
    out: list[set] = []
    for m, mode in enumerate(system.modes):
        found: set = set()
        entry = rule.entry[m]
        if mode.entry and entry is not None:
            values = [entry(t, y, p) for t, y in points]
            for i in range(len(mode.entry)):
                if all(abs(float(v[i]) + direction * h) <= 1e-12 * (1.0 + abs(h))
                       for v, h in zip(values, guard_values, strict=True)):
                    found.add(i)
        out.append(found)
    return out


class GuardlessProblem(SystemProblem):
    """The continuation problem of ``problem``'s system with the guard ``guard`` taken away (module docstring).

    ``stripped`` names the guard (a virtual problem crosses nothing itself); :meth:`grazing_test`
    is the grazing condition's value and gradient on its evaluations.
    """

    def __init__(self, problem: SystemProblem, guard: str):
        real = problem.base
        h = problem.hmap
        hmap = HybridMap(without_guard(real, guard), h.iterates, names=h.names, mode=h.mode, t0=h.t0, tol=h.tol,
                         max_time=h.max_time)
        super().__init__(hmap, problem.scales)
        #: The problem with the guard (the real system), which a boundary's points are rerun on.
        self.unstripped = problem
        self.real = real
        self.guard, self.guard_index = guard_of(real, guard)
        self.stripped = guard  # type: ignore[assignment]

    def peak(self, z, params):
        """``(psi, d psi / dz, d psi / dp, t, y, mode)`` at the guard's extremum nearest to firing, or why not.

        ``psi = -d h`` there (``d`` the guard's direction): positive while the orbit stays clear of it.
        """
        hmap, real = self.hmap, self.real
        if hmap.section is not None:
            return (f"the map returns to the section {hmap.section!r}: a grazing of an autonomous system's guard is "
                    "located, not crossed or followed (its extremum's sensitivity is written for a stroboscopic map)")
        try:
            sys_p, sol = hmap.run(z, params)
        except ValueError as exc:
            return str(exc)
        if sol.status != 0:
            return sol.message
        p = sys_p.parameter_values
        g, d = self.guard_index, self.guard.direction
        rule = rules(real)
        extrema = _extrema_integrator(real, hmap.tol)
        k = extrema.expression_of[g]
        starts = sol.pieces
        pieces = [(real.mode_index(mode), t, y, starts[i + 1][0] if i + 1 < len(starts) else sol.t_final)
                  for i, (t, mode, y) in enumerate(starts)]
        candidates = [(t, y, None) for kk, t, curvature, y in extrema.run(p, pieces) if kk == k and curvature == -d]
        # an extremum where another guard switches the mode (a velocity reversal between two slip modes)
        candidates += [(e.t, np.array(e.state_before), e.mode_before) for e in sol.events
                       if e.kind == "crossing" and real.mode_index(e.mode_before) in extrema.modes_of[k]]
        if not candidates:
            return f"the orbit without the guard {self.guard.name!r} never nears it (no extremum of its value)"
        values = [d * float(rule.guard[g](t, list(y), p)[0]) for t, y, _ in candidates]
        best = int(np.argmax(values))
        t, y, mode = candidates[best]
        if mode is None:
            mode = _mode_at(sol, t)
        J = hmap.tangent_until(sys_p, sol, t)
        dh = np.array(rule.jacobians(g)[0](t, list(y), p))
        n, n_all = self.dimension, J.shape[0]
        h_y = dh[:n_all]
        cols = [real.parameter_names.index(name) for name in self.names]
        grad_z = h_y @ J[:, :n]
        grad_p = np.array([h_y @ J[:, n_all + c] + dh[n_all + 1 + c] for c in cols])
        return -values[best], -d * grad_z, -d * grad_p, float(t), np.asarray(y, float), mode

    def grazing_test(self, ev, u):
        """``(psi, row)``: the grazing condition on the evaluation ``ev`` at ``u`` and its gradient in ``u``."""
        found = self.peak(ev.z, ev.params)
        if isinstance(found, str):
            return found
        psi, grad_z, grad_p = found[:3]
        return np.array([psi]), np.concatenate([grad_z, grad_p * np.asarray(self.scales)])[None, :]


def _mode_at(sol, t: float) -> str:
    """The mode of the run ``sol`` at the instant ``t``."""
    mode = sol.pieces[0][1]
    for start, name, _ in sol.pieces:
        if start > t:
            break
        mode = name
    return mode


class GuardImpact:
    """The impacting orbits of a guard with a reset, the impact's time and pre-impact state as unknowns.

    Unknowns ``w = (t_i, y_-, s_1 .. s_k)``; residual ``[Q(R(y_-)) - y_-, h(y_-, t_i)]`` with ``Q``
    the virtual map over the map's span from ``t_i`` (module docstring). ``arrive`` is the mode in
    which the guard fires (its field is the flow at ``y_-``), ``leave`` the mode after the reset.
    """

    def __init__(self, virtual: GuardlessProblem, arrive: str):
        self.virtual = virtual
        self.real = virtual.real
        self.guard, self.g = virtual.guard, virtual.guard_index
        self.arrive = arrive
        self.leave = self.guard.to[0] if self.guard.to else arrive
        self.n = virtual.dimension
        self.n_all = self.n + len(self.real.integrals)
        self.cols = [self.real.parameter_names.index(name) for name in virtual.names]

    def params(self, w) -> tuple:
        return tuple(float(s * c) for s, c in zip(w[1 + self.n:], self.virtual.scales, strict=True))

    def _full(self, y):
        return list(np.asarray(y, float)[:self.n]) + [0.0] * (self.n_all - self.n)

    def start(self, w):
        """``(p of the system, the state after the reset)`` of ``w``."""
        p = self.real.with_parameters(**dict(zip(self.virtual.names, self.params(w), strict=True))).parameter_values
        reset = rules(self.real).reset[self.g]
        y_minus = self._full(w[1:1 + self.n])
        y0 = np.asarray(reset(float(w[0]), y_minus, p), float)[:self.n] if reset is not None else np.array(y_minus)
        return p, y0

    def speed(self, w) -> float:
        """The guard's rate of approach at ``y_-`` (``d (n . f + h_t)``; 0 at the grazing, > 0 for an impact)."""
        p, _ = self.start(w)
        rule = rules(self.real)
        y = self._full(w[1:1 + self.n])
        f = np.asarray(rule.field[self.real.mode_index(self.arrive)](float(w[0]), y, p), float)
        dh = np.asarray(rule.jacobians(self.g)[0](float(w[0]), y, p), float)
        return self.guard.direction * float(dh[:self.n_all] @ f + dh[self.n_all])

    def residual(self, w):
        """``(R, dR/dw, value of the virtual map)``, or why not."""
        virtual, n, n_all = self.virtual, self.n, self.n_all
        t_i, params = float(w[0]), self.params(w)
        p, y0 = self.start(w)
        h = virtual.hmap
        hmap = HybridMap(h.system, h.iterates, names=h.names, mode=self.leave, t0=t_i, tol=h.tol)
        ev = hmap.evaluate(y0, params)
        if not ev.ok or ev.singular:
            return f"the impacting orbit could not be evaluated: {ev.failure or ev.singular}"
        rule = rules(self.real)
        y_minus = self._full(w[1:1 + n])
        M = ev.monodromy
        dh = np.asarray(rule.jacobians(self.g)[0](t_i, y_minus, p), float)
        reset_fn = rule.jacobians(self.g)[1]
        if reset_fn is not None:
            rows = np.asarray(reset_fn(t_i, y_minus, p), float).reshape(n, -1)
            R_y, R_t, R_p = rows[:, :n], rows[:, n_all], rows[:, [n_all + 1 + c for c in self.cols]]
        else:
            R_y, R_t, R_p = np.eye(n), np.zeros(n), np.zeros((n, len(self.cols)))
        span = hmap.period(params)
        f_start = np.asarray(rule.field[self.real.mode_index(self.leave)](t_i, self._full(y0), p), float)[:n]
        f_end = np.asarray(rule.field[self.real.mode_index(self.arrive)](t_i + span, self._full(ev.image), p),
                           float)[:n]
        scales = np.asarray(virtual.scales)
        d_t = f_end - M @ f_start + M @ R_t
        top = np.column_stack([d_t, M @ R_y - np.eye(n), (ev.dp + M @ R_p) * scales[None, :]])
        bottom = np.concatenate([[dh[n_all]], dh[:n], dh[[n_all + 1 + c for c in self.cols]] * scales])
        F = np.concatenate([ev.image - np.asarray(w[1:1 + n]), [float(rule.guard[self.g](t_i, y_minus, p)[0])]])
        return F, np.vstack([top, bottom[None, :]]), ev

    def section_state(self, w) -> np.ndarray | str:
        """The impacting orbit's state at the first section time after its impact (the branch's unknowns)."""
        h = self.virtual.hmap
        t_i, params = float(w[0]), self.params(w)
        _, y0 = self.start(w)
        T = h.period(params) / h.iterates
        t_s = h.t0 + math.ceil((t_i - h.t0) / T) * T
        if t_s <= t_i:
            t_s += T
        system = h.system.with_parameters(**dict(zip(h.names, params, strict=True)))
        try:
            sol = simulate_system(system, t_s, y0, backend="heyoka", mode=self.leave, t0=t_i, tol=h.tol)
        except ValueError as exc:
            return str(exc)
        if sol.status != 0:
            return sol.message
        return np.asarray(sol.state_final[:self.n], float)


def replace_info_singular(info, why: str):
    """``info`` of a grazing orbit of a guard with a reset: no multipliers (the map has no derivative there)."""
    return dataclasses.replace(info, multipliers=np.full(len(info.multipliers), math.nan, dtype=complex),
                               stability="undefined", singular=why)
