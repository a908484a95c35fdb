"""The stroboscopic map of a user hybrid system, its Jacobians from saltation products, periodic orbits.

For a :class:`~impactosc.HybridSystem` with a forcing period ``T``, the map
``P(z; p) = y(t0 + n T)`` of the run from ``y(t0) = z`` (for an autonomous system with a
``section`` guard instead: the state at its ``n``-th event, ``P = y(tau_n)``) is
differentiated exactly along the run: on each smooth piece the state-transition matrix and
the parameter sensitivities come from heyoka's variational equations (``heyoka.var_ode_sys``)
of the same compiled vector fields, and at each event the sensitivity ``J = [dy/dz | dy/dp]`` jumps by the saltation
rule::

    J+ = R_y J + [0 | R_p] + (f+ - R_y f- - R_t) (n^T J + [0 | h_p]) / (n . f- + h_t)

(the one saltation formula of every system, ``_jump.saltation_nd``) with ``n = dh/dy``,
``h_t``, ``h_p`` the guard's derivatives and ``R_y``, ``R_t``, ``R_p`` the reset's, all
symbolic derivatives of the definition, ``f-``/``f+`` the vector fields before and after.
Without parameters and time dependence this is ``S = R + (f+ - R f-) n^T / (n . f-)``.
Where ``n . f- + h_t`` vanishes (the orbit reaches the guard tangentially: a grazing) the map
is not differentiable: the evaluation says so (``singular``), with the guard and the time,
instead of returning a huge number. Everything is n-dimensional: the paper's eq. 3
(:func:`~impactosc.model.hybrid.oscillator_system`) is one case.

:class:`HybridMap` has the interface of the continuation's map problem (``evaluate(z, params)``
giving the image, ``dP/dz``, ``dP/dp`` and the event signature); :func:`periodic_orbit_of`
finds a fixed point of ``P`` by Newton's method with the Floquet multipliers.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from functools import cached_property, partial
from typing import Any

import numpy as np

from .._util.cache import BuiltOnce
from ..backends._hybrid import simulate_system
from ..backends._hybrid_heyoka import DEFAULT_TOL
from ..model.hybrid._definition import HybridSystem
from ..model.hybrid._numeric import gated_sum, numeric, rules
from ._guard_extrema import crossing_rate, guard_extrema
from ._jump import saltation_nd
from ._map import ImageAndResidual
from ._newton import PeriodicOrbit, orbit_of, shoot

__all__ = ["HybridMap", "HybridMapValue", "periodic_orbit_of"]

#: ``|n . f- + h_t|`` below this fraction of ``|n| |f-| + |h_t|`` is a grazing: the map's derivative does not
#: exist. Near a double root of the guard its time is only known to about ``sqrt(eps)`` (1.5e-8) relative,
#: and so is the crossing speed: an exact tangency is located with a speed of that order, not 0.
GRAZING_RATIO = 1e-7


@dataclass(frozen=True, eq=False)
class HybridMapValue(ImageAndResidual):
    """``P(z; p)`` with ``dP/dz``, ``dP/dp``, the event signature, or why not."""

    z: np.ndarray
    params: tuple
    image: np.ndarray | None  #: the states at ``t0 + n T`` (None when the run failed)
    monodromy: np.ndarray  #: ``dP/dz`` (NaN when singular)
    dp: np.ndarray  #: ``dP/dp_k`` for the map's parameter names, one column each (NaN when singular)
    signature: tuple  #: ``(guard, mode before, mode after)`` of every crossing, in order
    failure: str = ""  #: why the run failed ("" when it ran)
    singular: str = ""  #: why the map is not differentiable here ("" when it is)
    #: ``(guard, t, n . f- + h_t)`` of every crossing: the rate at which the guard's value passes zero.
    speeds: tuple = ()
    #: What :attr:`extrema` is computed from, on first use (None: no extrema, the map is singular).
    extrema_of: Any = field(default=None, repr=False)

    @cached_property
    def extrema(self) -> tuple:
        """``(guard, t, h)`` at every extremum of a guard's value ``h`` on the side it fires from (maxima
        of a rising guard, minima of a falling one) and at the ends of every piece, in the modes where a
        guard of the same expression is armed (the crossings of that expression left out, where ``h`` is 0).

        The largest ``d h`` among a guard's is how near the orbit comes to firing it (a grazing when
        it reaches 0). Empty when the map is singular. Computed on first use: shooting needs none.
        """
        return () if self.extrema_of is None else self.extrema_of()



class _Tangent:
    """The variational integrator of one system structure: states and parameter sensitivities per piece."""

    def __init__(self, system: HybridSystem, tol: float):
        import heyoka as hy

        num = numeric(system)
        P, M = num.n_params, len(system.modes)
        ind = [hy.par[P + m] for m in range(M)]
        n_all = len(num.states)
        rates = [gated_sum([num.rates[m][i] for m in range(M)], ind) for i in range(n_all)]
        args = list(num.states) + [hy.par[k] for k in range(P)]
        vsys = hy.var_ode_sys(list(zip(num.states, rates, strict=True)), args, order=1)
        # pars left out: heyoka sizes them to the highest index the expressions use
        self.ta = hy.taylor_adaptive(vsys, [0.0] * n_all, tol=tol, compact_mode=True)
        self.n_all, self.P, self.M = n_all, P, M
        self.width = n_all + P
        start = np.zeros((n_all, self.width))
        start[:, :n_all] = np.eye(n_all)
        self.start = start.ravel()  # dy/dy = I, dy/dp = 0 at the piece start
        self.lock = threading.Lock()

    def piece(self, params, mode: int, t0: float, y0, t1: float) -> np.ndarray:
        """``[dy(t1)/dy(t0) | dy(t1)/dp]`` of the piece in ``mode`` (n_all x (n_all + P))."""
        if t1 <= t0:
            out = np.zeros((self.n_all, self.width))
            out[:, :self.n_all] = np.eye(self.n_all)
            return out
        ta = self.ta
        pars = ta.pars
        size = len(pars)
        pars[:] = 0.0
        used = min(self.P, size)
        pars[:used] = params[:used]
        if self.P + mode < size:  # a mode whose field is zero has no indicator in the expressions
            pars[self.P + mode] = 1.0
        ta.time = t0
        ta.state[:self.n_all] = y0
        ta.state[self.n_all:] = self.start
        outcome = ta.propagate_until(t1)[0]
        import heyoka as hy

        if outcome != hy.taylor_outcome.time_limit:
            raise FloatingPointError(f"the variational equations failed ({outcome!r}) on the piece from t={t0!r}")
        return np.array(ta.state[self.n_all:]).reshape(self.n_all, self.width)


_tangents: BuiltOnce[_Tangent] = BuiltOnce()


def _tangent(system: HybridSystem, tol: float) -> _Tangent:
    return _tangents.get((system.structure, tol), lambda: _Tangent(system, tol))


class HybridMap:
    """The map over ``iterates`` forcing periods of a user system, differentiable by saltation.

    Parameters
    ----------
    system : HybridSystem
        With a forcing ``period`` (a number or an expression in its parameters), or, for an
        autonomous system without one, a ``section`` guard.
    iterates : int
        Forcing periods per map, or returns to the section (default 1).
    names : sequence of str, optional
        The parameters of ``dP/dp`` and of :meth:`evaluate` (default: all of the system's).
    mode : str, optional
        The mode at the section (default: the first whose entry conditions hold there).
    t0 : float
        The section time (default 0).
    tol : float
        heyoka's tolerance for the run and the variational equations.
    max_time : float
        Section maps: how long a run may take to return (default 1e3): longer is a failure.

    Examples
    --------
    >>> import numpy as np
    >>> import impactosc
    >>> from impactosc.dynamics import HybridMap
    >>> from impactosc.model.hybrid import oscillator_system
    >>> system = oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4))
    >>> value = HybridMap(system, names=["F"]).evaluate([0.95, 0.0])
    >>> value.monodromy.shape, value.dp.shape
    ((2, 2), (2, 1))
    """

    def __init__(self, system: HybridSystem, iterates: int = 1, *, names=None, mode: str | None = None,
                 t0: float = 0.0, tol: float = DEFAULT_TOL, max_time: float = 1e3):
        if not isinstance(system, HybridSystem):
            raise TypeError(f"system must be an impactosc.HybridSystem, got {system!r}")
        if system.period is None and system.section is None:
            raise ValueError(f"{system.name}: a map needs the system's forcing period (period=...) or, for an "
                             "autonomous system, a section guard (section=...)")
        #: The section guard of an autonomous system's map (None: the stroboscopic map of the period).
        self.section = system.section if system.period is None else None
        self.max_time = float(max_time)
        if isinstance(iterates, bool) or not isinstance(iterates, int) or iterates < 1:
            raise ValueError(f"iterates must be an integer >= 1, got {iterates!r}")
        self.system = system
        self.iterates = iterates
        self.names = tuple(system.parameter_names if names is None else names)
        for name in self.names:
            if name not in system.parameter_names:
                raise ValueError(f"{system.name}: {name!r} is not a parameter; the parameters are "
                                 f"{list(system.parameter_names)}")
        self.columns = [system.parameter_names.index(name) for name in self.names]
        self.mode = mode
        self.t0 = float(t0)
        self.tol = tol
        if self.section is None:
            self._period = numeric(system).period_function()

    @property
    def n(self) -> int:
        """Forcing periods (or section returns) per map, as the continuation's map problem names it."""
        return self.iterates

    @property
    def state_names(self) -> tuple[str, ...]:
        """The names of the components of ``z``: the system's states."""
        return tuple(self.system.states)

    def period(self, params=None) -> float:
        """The time one map takes at ``params`` (default :meth:`values`); NaN for a section map."""
        if self.section is not None:
            return math.nan
        params = self.values() if params is None else tuple(float(q) for q in params)
        p = self.system.with_parameters(**dict(zip(self.names, params, strict=True))).parameter_values
        return self.iterates * float(self._period(0.0, [0.0] * len(numeric(self.system).states), p)[0])

    def with_names(self, names) -> HybridMap:
        """The same map with other free parameters."""
        return HybridMap(self.system, self.iterates, names=names, mode=self.mode, t0=self.t0, tol=self.tol,
                         max_time=self.max_time)

    def values(self) -> tuple:
        """The map's parameters' values in the system."""
        current = dict(self.system.parameters)
        return tuple(current[name] for name in self.names)

    def evaluate(self, z, params=None) -> HybridMapValue:
        """``P(z; params)`` and its Jacobians (``params``: values of the map's ``names``, default the system's)."""
        system = self.system
        n = system.dimension
        z = np.asarray(z, dtype=float).ravel()
        params = self.values() if params is None else tuple(float(p) for p in params)
        k = len(self.names)
        nan_m, nan_p = np.full((n, n), math.nan), np.full((n, k), math.nan)
        if z.size != n or not np.all(np.isfinite(z)):
            return HybridMapValue(z, params, None, nan_m, nan_p, (), f"z must be {n} finite numbers, got {z}")
        sys_p = system.with_parameters(**dict(zip(self.names, params, strict=True)))
        p = sys_p.parameter_values
        try:
            if self.section is None:
                period_and_rates = self._period(0.0, [0.0] * len(numeric(system).states), p)
                span = self.iterates * period_and_rates[0]
                if not (math.isfinite(span) and span > 0.0):
                    return HybridMapValue(z, params, None, nan_m, nan_p, (), f"the period is {period_and_rates[0]!r}")
                sol = simulate_system(sys_p, self.t0 + span, z, backend="heyoka", mode=self.mode, t0=self.t0,
                                      tol=self.tol)
            else:
                sol = simulate_system(sys_p, self.t0 + self.max_time, z, backend="heyoka", mode=self.mode,
                                      t0=self.t0, tol=self.tol, until=(self.section, self.iterates))
        except ValueError as exc:  # a state no mode admits (beyond a rigid stop, say): no value, and why
            return HybridMapValue(z, params, None, nan_m, nan_p, (), str(exc))
        signature = tuple((e.guard, e.mode_before, e.mode_after) for e in sol.events if e.kind == "crossing")
        if sol.status != 0:
            return HybridMapValue(z, params, None, nan_m, nan_p, signature, sol.message)
        if self.section is not None and not (sol.events and sol.events[-1].guard == self.section
                                             and "as asked" in sol.message):
            return HybridMapValue(z, params, None, nan_m, nan_p, signature,
                                  f"no return {self.iterates} to the section {self.section!r} within "
                                  f"max_time={self.max_time!r}")
        image = sol.state_final[:n].copy()
        grazings = _grazings(sol)
        if grazings:
            e = grazings[0]
            return HybridMapValue(z, params, image, nan_m, nan_p, signature, "",
                                  f"guard {e.guard!r} grazes at t={e.t!r} (its value has an extremum on zero)")
        try:
            J, extrema_of, speeds = self._sensitivity(sys_p, sol, p)
        except ZeroDivisionError as exc:
            return HybridMapValue(z, params, image, nan_m, nan_p, signature, "", str(exc))
        n_all = J.shape[0]
        dp = J[:n, [n_all + c for c in self.columns]].copy()
        if self.section is not None:  # the map ends on the section: no end time to move
            return HybridMapValue(z, params, image, J[:n, :n].copy(), dp, signature, speeds=speeds,
                                  extrema_of=extrema_of)
        # the map ends at t0 + iterates T(p): a parameter that moves T moves the end
        f_end = np.array(rules(system).field[sys_p.mode_index(sol.mode_final)](self.t0 + span,
                                                                                sol.state_final.tolist(), p))
        for j, c in enumerate(self.columns):
            dT = self.iterates * period_and_rates[1 + c]
            if dT != 0.0:
                dp[:, j] += f_end[:n] * dT
        return HybridMapValue(z, params, image, J[:n, :n].copy(), dp, signature, speeds=speeds, extrema_of=extrema_of)

    def run(self, z, params=None):
        """``(system at params, the run of one map from z)``: the :class:`~impactosc.results.HybridSolution` behind
        :meth:`evaluate`, for what the map value does not carry (the state at an instant inside the period).

        Raises
        ------
        ValueError
            For a state no mode admits, as :func:`~impactosc.simulate` does; a failed run is returned
            with its status.
        """
        z = np.asarray(z, dtype=float).ravel()
        params = self.values() if params is None else tuple(float(q) for q in params)
        sys_p = self.system.with_parameters(**dict(zip(self.names, params, strict=True)))
        if self.section is not None:
            return sys_p, simulate_system(sys_p, self.t0 + self.max_time, z, backend="heyoka", mode=self.mode,
                                          t0=self.t0, tol=self.tol, until=(self.section, self.iterates))
        return sys_p, simulate_system(sys_p, self.t0 + self.period(params), z, backend="heyoka", mode=self.mode,
                                      t0=self.t0, tol=self.tol)

    def tangent_until(self, system: HybridSystem, sol, t: float) -> np.ndarray:
        """``[dy(t)/dz | dy(t)/dp]`` along the run ``sol`` of :meth:`run` from its start to ``t`` (before the
        events at ``t``): the sensitivity of the state at an instant inside the period, by the same pieces and
        saltation matrices as :meth:`evaluate` (rows: the states and integrals; columns: the initial states and
        integrals, then every parameter of the system).

        ``system`` is the system at the run's parameters (the first item :meth:`run` returns). A stroboscopic
        map's only (a section map's last event is its value, not a transition).
        """
        if self.section is not None:
            raise ValueError(f"{self.system.name}: tangent_until is defined for a stroboscopic map (the system has "
                             f"a period), not for the section map of {self.section!r}")
        events = [e for e in sol.events if e.t < t]
        until = _RunUntil(sol.pieces, events, float(t))
        return self._sensitivity(system, until, system.parameter_values)[0]

    def _sensitivity(self, system: HybridSystem, sol, p) -> tuple[np.ndarray, Any, tuple]:
        """``[dy/dz | dy/dp]`` at the end of ``sol``, pieces and saltations in turn; the guards' extrema (a
        function computing them) and speeds.

        The crossing speeds are those of :class:`HybridMapValue` (``speeds``); its ``extrema``
        come from the returned function, on first use (:mod:`._guard_extrema`).
        """
        tangent = _tangent(self.system, self.tol)
        rule = rules(self.system)
        n, n_all, P = system.dimension, tangent.n_all, tangent.P
        J = np.zeros((n_all, n_all + P))
        J[:, :n_all] = np.eye(n_all)
        t, mode_name, y = sol.pieces[0]
        mode = system.mode_index(mode_name)
        last = len(sol.events) - 1
        speeds = []
        with tangent.lock:
            for i, e in enumerate(sol.events):
                on_section = self.section is not None and i == last
                if e.kind != "crossing" and not on_section:
                    continue
                J = _compose(tangent.piece(p, mode, t, y, e.t), J, n_all)
                J, dtau, f_plus = self._saltation(rule, system, e, p, J, n, n_all, P, reset=e.kind == "crossing")
                if e.kind == "crossing":
                    speeds.append((e.guard, e.t, crossing_rate(rule, system, e, p)))
                if on_section:
                    # the map's value is the state on the section, at the perturbed return time
                    J = J - np.outer(f_plus, dtau)
                t, mode, y = e.t, system.mode_index(e.mode_after), e.state_after
            J = _compose(tangent.piece(p, mode, t, y, sol.t_final), J, n_all)
        return J, partial(guard_extrema, system, rule, (self.system, self.tol), sol, p), tuple(speeds)

    @staticmethod
    def _saltation(rule, system, e, p, J, n, n_all, P, reset: bool = True) -> tuple:
        """``(J+, dtau, f+)``: the sensitivity after the event, ``-d(event time)/d(z, p)`` and the field after.

        ``reset=False`` (a marker guard): no transition, ``J+ = J``.
        """
        g = system.guard_names.index(e.guard)
        guard_fn, reset_fn = rule.jacobians(g)
        before, after = list(e.state_before), list(e.state_after)
        f_minus = np.array(rule.field[system.mode_index(e.mode_before)](e.t, before, p))
        f_plus = np.array(rule.field[system.mode_index(e.mode_after)](e.t, after, p))
        dh = np.array(guard_fn(e.t, before, p))
        normal, h_t, h_p = dh[:n_all], dh[n_all], dh[n_all + 1:]
        R_y = np.eye(n_all)
        R_t = np.zeros(n_all)
        R_p = np.zeros((n_all, P))
        if reset_fn is not None and reset:
            rows = np.array(reset_fn(e.t, before, p)).reshape(n, n_all + 1 + P)
            R_y[:n] = rows[:, :n_all]
            R_t[:n] = rows[:, n_all]
            R_p[:n] = rows[:, n_all + 1:]
        if not reset:  # a marker guard: no transition, only its time moves
            R_t, R_p, f_plus = np.zeros(n_all), np.zeros((n_all, P)), f_minus
        jump = saltation_nd(R_y.tolist(), f_minus.tolist(), f_plus.tolist(), normal.tolist(), h_t=float(h_t),
                            reset_rate=R_t.tolist(), guard_params=h_p.tolist(), reset_params=R_p.tolist(),
                            tangential=GRAZING_RATIO * (np.linalg.norm(normal) * np.linalg.norm(f_minus) + abs(h_t)))
        if jump.singular:
            raise ZeroDivisionError(f"guard {e.guard!r} is reached tangentially at t={e.t!r} (n . f- + h_t = "
                                    f"{jump.speed!r}): a grazing, where the map has no derivative")
        dtau = -(np.array(jump.time_state) @ J)  # -d(event time)/d(z, p)
        dtau[n_all:] -= np.array(jump.time_params)
        if not reset:
            return J, dtau, f_minus
        S = np.array(jump.matrix)
        J_new = S @ J
        J_new[:, n_all:] += np.array(jump.params).reshape(n_all, P)
        return J_new, dtau, f_plus


@dataclass(frozen=True)
class _RunUntil:
    """A run cut at ``t_final``: what :meth:`HybridMap._sensitivity` reads of a run (its first piece, the
    events before the cut)."""

    pieces: list
    events: list
    t_final: float


def _grazings(sol) -> list:
    """The grazing events of a run that make the map singular.

    A guard whose value is zero with a zero rate at the very instant a crossing put the state
    on it (a slip mode entered at ``v = 0`` by a release, where the acceleration is zero too)
    is recorded as touching zero, but the orbit does not graze it: it starts there and moves
    away, and the saltation of the crossing is well defined.
    """
    out, last = [], None
    for e in sol.events:
        if e.kind == "crossing":
            last = e.t
        elif e.kind == "grazing" and not (last is not None and abs(e.t - last) <= 8.0 * 2.0**-52 * (1.0 + abs(e.t))):
            out.append(e)
    return out


def _compose(piece: np.ndarray, J: np.ndarray, n_all: int) -> np.ndarray:
    """``[Phi_y | Phi_p]`` after ``J = [dy/dz | dy/dp]``: ``[Phi_y J_z | Phi_y J_p + Phi_p]``."""
    out = piece[:, :n_all] @ J
    out[:, n_all:] += piece[:, n_all:]
    return out


def periodic_orbit_of(hmap: HybridMap, guess, *, tol: float = 1e-11, max_iter: int = 30) -> PeriodicOrbit:
    """A fixed point of ``hmap`` by Newton's method from ``guess``, with its Floquet multipliers.

    The one shooting (``_newton.shoot``, which the built-in family's
    :func:`~impactosc.dynamics.periodic_orbit` calls too): Newton's step solves
    ``(M - I) dz = -(P(z) - z)`` (least squares when ``M - I`` is singular), halving while
    the residual does not fall; convergence when ``|P(z) - z| <= tol max(1, |z|)``.

    Parameters
    ----------
    hmap : HybridMap
        The map whose fixed point is sought (its ``iterates`` give the orbit's period).
    guess : sequence of float
        The starting state on the section, one value per state of the system.
    tol : float
        Relative tolerance on the residual ``|P(z) - z|``.
    max_iter : int
        Newton steps before giving up (status 1).

    Returns
    -------
    PeriodicOrbit
        The fixed point ``z`` (named by ``state_names``), the monodromy matrix, the Floquet
        multipliers (largest modulus first), the verdict, the event signature of one period
        and a status: 0 converged, 1 not converged (stalled or out of iterations), 2 not
        differentiable (a grazing, see ``message``), -1 the run from ``guess`` failed.
        ``events`` and ``solution`` are None: simulate the system from ``z`` for the run.

    Examples
    --------
    A damped oscillator against a one-sided stop, ``x'' + 2 zeta x' + x = A cos(w t)`` with
    ``v -> -e v`` at ``x = d``: a stable period-1 orbit with two impacts.

    >>> import math
    >>> import heyoka as hy
    >>> import numpy as np
    >>> from impactosc import Guard, HybridMode, HybridSystem, symbols
    >>> from impactosc.dynamics import HybridMap, periodic_orbit_of
    >>> x, v, zeta, A, w, d, e = symbols("x v zeta A w d e")
    >>> stop = HybridSystem("x v", {"zeta": 0.05, "A": 1.2, "w": 0.8, "d": 0.6, "e": 0.7},
    ...                     [HybridMode("free", {x: v, v: A * hy.cos(w * hy.time) - x - 2 * zeta * v})],
    ...                     [Guard("impact", x - d, 1, armed="free", to="free", reset={v: -e * v})],
    ...                     period=2 * math.pi / w)
    >>> orbit = periodic_orbit_of(HybridMap(stop), [0.0, 0.0])
    >>> orbit.status, len(orbit.signature), np.round(orbit.z, 4)
    (0, 2, array([-0.4161, -0.5049]))
    >>> bool(np.all(np.abs(orbit.multipliers) < 1))
    True
    """
    shot = shoot(hmap, guess, tol=tol, max_iter=max_iter)
    return orbit_of(shot, hmap.system, hmap.iterates, hmap.period(), hmap.t0, state_names=hmap.state_names)


#: The result of :func:`periodic_orbit_of`: the one periodic-orbit type of every map.
HybridOrbit = PeriodicOrbit
