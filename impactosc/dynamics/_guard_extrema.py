"""How near a user system's orbit comes to each guard: the extrema of its value along a run, its crossing rates.

A grazing is a guard's value touching zero at an extremum. :func:`guard_extrema` finds the
extrema of every guard along a run of :class:`~impactosc.dynamics.HybridMap` by integrating
its pieces again with each guard expression's Lie derivative as a non-terminal heyoka event
(one integrator per system structure, built when first asked for), and adds the values at
the ends of the pieces, where another guard may switch the mode at the extremum (a velocity
reversal between two slip modes). :func:`crossing_rate` is ``n . f- + h_t`` at a crossing.
Continuation reads its grazing margins from both (:mod:`.continuation._hybrid_problem`).
"""

from __future__ import annotations

import re
import threading

import numpy as np

from .._util.cache import BuiltOnce
from ..model.hybrid._definition import HybridSystem
from ..model.hybrid._numeric import gated_sum, numeric

__all__ = ["guard_extrema", "crossing_rate"]


class _Extrema:
    """The extrema of every guard along a run: its pieces integrated again with the guards' Lie derivatives
    as non-terminal events (one integrator per system structure, used only when the extrema are asked for)."""

    def __init__(self, system: HybridSystem, tol: float):
        import heyoka as hy

        num = numeric(system)
        P, M = num.n_params, len(system.modes)
        ind = [hy.par[P + m] for m in range(M)]
        self.n_all, self.P = len(num.states), P
        rates = [gated_sum([num.rates[m][i] for m in range(M)], ind) for i in range(self.n_all)]
        self.ta = hy.taylor_adaptive(list(zip(num.states, rates, strict=True)), [0.0] * self.n_all, tol=tol,
                                     compact_mode=True, nt_events=self._extremum_events(system, num, ind))
        self.lock = threading.Lock()

    def _extremum_events(self, system: HybridSystem, num, ind) -> list:
        """One non-terminal event per guard expression: its Lie derivative where a guard of it is armed.

        The expression is ``sum_m [mode == m] h'_m + (1 - sum_m [mode == m])`` over those modes
        (the constant 1, without a root, elsewhere); each root is an extremum of ``h``, kept in
        :attr:`found` as ``(expression index, t, sign of h'' , state)``.
        """
        import heyoka as hy

        #: The distinct guard expressions, and for each guard the index of its own.
        self.expressions: list = []
        self.expression_of: list[int] = []
        for h in num.guards:
            if h not in self.expressions:
                self.expressions.append(h)
            self.expression_of.append(self.expressions.index(h))
        self.found: list = []
        events = []
        #: For each expression, the modes where a guard of it is armed.
        self.modes_of: list[set] = [set() for _ in self.expressions]
        for k in range(len(self.expressions)):
            lie = {}
            for g, modes in enumerate(num.armed):
                if self.expression_of[g] == k:
                    lie.update({m: num.lie[(m, g)] for m in modes})
                    self.modes_of[k].update(modes)
            terms = [(m, e) for m, e in sorted(lie.items())
                     if hy.get_variables(e) or "t" in re.findall(r"\w+", str(e))]
            if not terms:
                continue  # a constant rate everywhere it is armed: no extremum
            gate = hy.sum([ind[m] for m, _ in terms]) if len(terms) > 1 else ind[terms[0][0]]
            expr = hy.sum([ind[m] * e for m, e in terms] + [1.0 - gate])

            def record(ta, t, d_sgn, k=k):
                ta.update_d_output(t)
                self.found.append((k, t, int(d_sgn), ta.d_output[:self.n_all].copy()))

            events.append(hy.nt_event(expr, record))
        return events

    def run(self, params, pieces) -> list:
        """The extremum events ``(expression, t, sign of h'', state)`` of ``pieces`` ``(mode, t0, y0, t1)``."""
        ta = self.ta
        with self.lock:
            self.found = []
            for mode, t0, y0, t1 in pieces:
                if t1 <= t0:
                    continue
                pars = ta.pars
                pars[:] = 0.0
                used = min(self.P, len(pars))
                pars[:used] = params[:used]
                if self.P + mode < len(pars):
                    pars[self.P + mode] = 1.0
                ta.time = t0
                ta.state[:] = y0
                ta.propagate_until(t1)
            found, self.found = self.found, []
        return found


_extrema: BuiltOnce[_Extrema] = BuiltOnce()


def _extrema_integrator(system: HybridSystem, tol: float) -> _Extrema:
    return _extrema.get((system.structure, tol), lambda: _Extrema(system, tol))


def guard_extrema(system: HybridSystem, rule, structure: tuple, sol, p) -> tuple:
    """``HybridMapValue.extrema`` of a run: the extrema inside its pieces and the values at their ends.

    ``structure`` is ``(system, tol)`` of the map's integrator (built on first use).
    """
    tangent = _extrema_integrator(*structure)
    starts = sol.pieces
    pieces = [(system.mode_index(mode), t, y, starts[i + 1][0] if i + 1 < len(starts) else sol.t_final)
              for i, (t, mode, y) in enumerate(starts)]
    out = []
    for k, t, curvature, y in tangent.run(p, pieces):
        for g, guard in enumerate(system.guards):
            # a rising guard is touched from below at a maximum of h (h'' < 0), a falling one at a minimum
            if tangent.expression_of[g] == k and guard.direction != 0 and curvature == -guard.direction:
                out.append((guard.name, float(t), float(rule.guard[g](t, list(y), p)[0])))
    # the ends of the pieces: an extremum where another guard switches the mode (a velocity reversal
    # between two slip modes) lies there, not inside a piece
    t0, mode0, y0 = sol.pieces[0]
    ends = [(t0, system.mode_index(mode0), y0, -1)]
    ends += [(e.t, system.mode_index(m), state, system.guard_names.index(e.guard)) for e in sol.events
             if e.kind == "crossing" for m, state in ((e.mode_before, e.state_before), (e.mode_after, e.state_after))]
    ends.append((sol.t_final, system.mode_index(sol.mode_final), sol.state_final, -1))
    for t, mode, y, by in ends:
        for g, guard in enumerate(system.guards):
            k = tangent.expression_of[g]
            if guard.direction != 0 and mode in tangent.modes_of[k] and (by < 0 or tangent.expression_of[by] != k):
                out.append((guard.name, float(t), float(rule.guard[g](t, list(y), p)[0])))
    return tuple(out)


def crossing_rate(rule, system: HybridSystem, e, p) -> float:
    """``n . f- + h_t``: the rate at which the guard's value passes zero at the crossing ``e``."""
    g = system.guard_names.index(e.guard)
    before = list(e.state_before)
    f_minus = np.array(rule.field[system.mode_index(e.mode_before)](e.t, before, p))
    dh = np.array(rule.jacobians(g)[0](e.t, before, p))
    n_all = f_minus.size
    return float(dh[:n_all] @ f_minus + dh[n_all])
