"""One piece, and the pieces and impacts of one mode, in one compiled call each.

:func:`advance` sets a piece up (:mod:`._forms`), searches its guards (:mod:`._guards`) and
evaluates its end; :func:`run_modes` strings pieces together with the events that only change
the mode (springs, lift-offs, releases) and the impacts that keep it, across the modes built so
far, so that the Python transition rule (:mod:`._run`) runs only where it must decide (stick
tests, rest) or build a mode.
"""

from __future__ import annotations

import cmath

import numpy as np

from ..._util.jit import HAVE_NUMBA, njit
from ._forms import integrals, rdot, rmv, state_at
from ._guards import search, workspace
from ._modes import ENTER, IMPACT, LEAVE, LIFT, RELEASE, SLIP_END, STICK
from ._setup import setup_piece

if HAVE_NUMBA:
    from numba.typed import List
else:  # pragma: no cover - plain Python: a list holds the rows
    List = list

__all__ = ["advance", "run_modes", "new_table", "push_mode", "holding_force"]


@njit
def advance(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gc, kmode, const, om, fh, constants, vq, vv, vq0, vv0,
            csym, t0, q0, v0, t_end, energy, work):
    """One piece from ``(t0, q0, v0)`` to its first guard or ``t_end``, in one compiled call.

    Returns ``(tau, guard, status, q1, v1, work, dissipation)`` (:func:`setup_piece`,
    :func:`search`, :func:`state_at`, and with ``energy`` :func:`integrals`); ``work``: the
    search's buffers (:func:`._guards.workspace`).
    """
    a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, dscale, poly, Xi, X = setup_piece(
        lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gc, kmode, const, om, fh, constants, t0, q0, v0)
    G, S, TT, terms, mag = work
    tau, g, status = search(lam, W, omt, D, rk, rj, RG, c0, cscale, dscale, poly, t0, t_end - t0, G, S, TT, terms,
                            mag)
    if status != 0:
        return tau, g, status, q0, v0, 0.0, 0.0
    if g < 0:
        tau = t_end - t0
    q1, v1 = state_at(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, q0, tau)
    work = diss = 0.0
    if energy:
        work, diss = integrals(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0)
    return tau, g, status, q1, v1, work, diss


@njit
def _holding_force(row, i, om, fh, C, t, q, v):
    """The force that holds friction entry ``i``'s coordinate at rest in the stuck mode ``row``:
    its row of the constraint-force weights times ``f(t) + const - K_mode q - C v``."""
    kmode, const, weights, friction_row = row[12], row[13], row[23], row[24]
    w = weights[friction_row[i]]
    push = 0.0
    for k in range(q.shape[0]):
        r = const[k]
        for j in range(om.shape[0]):
            r += (fh[j, k] * cmath.exp(1j * om[j] * t)).real
        for m in range(q.shape[0]):
            r -= kmode[k, m] * q[m] + C[k, m] * v[m]
        push += w[k] * r
    return push


@njit
def holding_force(table, row, i, om, fh, C, t, q, v):
    """:func:`_holding_force` of the mode ``table[row]``: the stick test of the Python rule, the same code."""
    return _holding_force(table[row], i, om, fh, C, t, q, v)


@njit
def new_table(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, vq, vv, vq0, vv0, guard_kind,
              guard_index, guard_sign, motion, info, weights, friction_row, constants):
    """A typed list of mode rows holding this first one (built here: typing the row in Python costs ms);
    a row is :meth:`._modes.Mode.entry` and the mode's :func:`._setup.mode_constants`."""
    table = List()
    table.append((lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, vq, vv, vq0, vv0, guard_kind,
                  guard_index, guard_sign, motion, info, weights, friction_row, constants))
    return table


@njit
def push_mode(table, lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, vq, vv, vq0, vv0,
              guard_kind, guard_index, guard_sign, motion, info, weights, friction_row, constants):
    """Append a mode row to ``table`` (:func:`new_table`)."""
    table.append((lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, vq, vv, vq0, vv0, guard_kind,
                  guard_index, guard_sign, motion, info, weights, friction_row, constants))


@njit
def run_modes(table, index_of, mi, code, spring_bit, rest_bit, fric_unit, om, fh, csym, normals, mn, nmn,
              restitution, can_rest, gaps, mn_norm, fr_coord, fr_kinetic, fr_static, f0, M, C, f_norm, c_norm,
              chatter_height,
              push_margin, t, q, v, t_end, energy, zero_time, max_zero, ev_t, ev_kind, ev_index, ev_q, ev_v, pc_t,
              pc_mode, pc_q, pc_v):
    """Pieces and the transitions that only change the mode, compiled: one call for a run of them.

    ``table[mi]`` is the mode (:meth:`._modes.Mode.entry`), ``index_of`` maps the code of a
    mode (``sum engaged 2^c + sum resting 2^(nc + c) + sum (motion + 1) 3^i 2^(2 nc)``, the bits
    and units given) to its row. Handled here: a spring contact engaging or opening, a stop
    lifting off, a stuck coordinate released, a slip ending (the stick test with the forces of
    the stuck mode's constraints, :func:`_holding_force`) (the next mode's code, found in the
    table, or back to Python to build it), and an impact on a rigid stop that keeps the mode (no stop
    rests, the impulse reverses no friction coordinate and the rebound is too fast for rest:
    ``v -> v - (1 + e) (n.v) M^-1 n / (n.M^-1 n)``). Every other event (an impact that may end
    in rest or that meets resting stops), ``t_end``, a full buffer, a failed
    search or more than ``max_zero`` transitions without time passing returns to the Python
    rule with the state at the event and the guard that fired. Events go to ``ev_*``
    (their kinds as guard kinds, a stick as ``STICK``), piece starts and their modes to ``pc_*``.

    Returns ``(n_events, n_pieces, tau, guard, status, mi, code, zero_time, t, q, v, work,
    dissipation, friction, impact_loss, energy_scale)``.
    """
    n_ev = 0
    n_pc = 0
    work = diss = fric = loss = 0.0
    escale = 0.0
    cap = ev_t.shape[0]
    ng = 0
    nt = 0
    for row in table:  # the search's buffers, for the largest mode built so far
        ng = max(ng, row[4].shape[0])
        nt = max(nt, row[0].shape[0] + om.shape[0])
    buffers = workspace(ng, nt)
    unpacked = -1
    (lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, _, gc, kmode, const, vq, vv, vq0, vv0, guard_kind,
     guard_index, guard_sign, motion, info, _, _, constants) = table[mi]
    while True:
        if mi != unpacked:  # a row of arrays unpacked costs a reference count each: only on a mode change
            (lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, _, gc, kmode, const, vq, vv, vq0, vv0, guard_kind,
             guard_index, guard_sign, motion, info, _, _, constants) = table[mi]
            unpacked = mi
        tau, g, st, q1, v1, w, d = advance(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gc, kmode, const, om,
                                           fh, constants, vq, vv, vq0, vv0, csym, t, q, v, t_end, energy, buffers)
        pc_t[n_pc] = t
        pc_mode[n_pc] = mi
        pc_q[n_pc] = q
        pc_v[n_pc] = v
        n_pc += 1
        if st != 0:
            return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
        t1 = t + tau if g >= 0 else t_end
        if energy:
            work += w + rdot(f0, q1 - q)
            diss += d
            for i in range(fr_coord.shape[0]):
                fric += fr_kinetic[i] * motion[i] * (q1[fr_coord[i]] - q[fr_coord[i]])
            escale = max(escale, 0.5 * abs(rdot(v1, rmv(M, v1))) + 0.5 * abs(rdot(q1, rmv(kmode, q1))))
        t, q, v = t1, q1, v1
        if g < 0 or n_ev >= cap or n_pc >= cap:
            return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
        kind = guard_kind[g]
        c = guard_index[g]
        if kind == IMPACT:
            if tau == 0.0 or info[0] != 0.0:
                return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
            u = rdot(normals[c], v)
            scale = (1.0 + restitution[c]) * u / nmn[c] if u > 0.0 else 0.0
            vn = np.empty(v.shape[0])
            q_abs = 0.0
            vn_abs = 0.0
            for i in range(v.shape[0]):  # loops: the vector expressions allocated a temporary each
                vn[i] = v[i] - scale * mn[c, i]
                q_abs += abs(q[i])
                vn_abs += abs(vn[i])
            for i in range(fr_coord.shape[0]):
                s = 1 if vn[fr_coord[i]] > 0.0 else (-1 if vn[fr_coord[i]] < 0.0 else 0)
                if s != motion[i]:
                    return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
            if can_rest[c]:
                wn = -rdot(normals[c], vn)
                forces = f_norm + info[1] + info[2] * q_abs + c_norm * vn_abs
                if wn <= 0.0 or wn * wn <= 2.0 * push_margin * mn_norm[c] * forces * chatter_height * max(1.0, gaps[c]):
                    return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
            if energy:
                loss += 0.5 * rdot(v - vn, rmv(M, v + vn))
            v = vn
            zero_time = 0
        else:
            if kind == ENTER:
                new = code + spring_bit[c]
            elif kind == LEAVE:
                new = code - spring_bit[c]
            elif kind == LIFT:
                new = code - rest_bit[c]
            elif kind == RELEASE:
                new = code + guard_sign[g] * fric_unit[c]
            elif kind == SLIP_END:
                # the stick test (Filippov) with the forces of every constraint of the stuck mode
                stuck = code - motion[c] * fric_unit[c]
                if stuck not in index_of:
                    return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
                v = v.copy()
                v[fr_coord[c]] = 0.0
                push = _holding_force(table[index_of[stuck]], c, om, fh, C, t, q, v)
                s_new = 0 if abs(push) <= fr_static[c] else (1 if push > 0.0 else -1)
                new = stuck + s_new * fric_unit[c]
                if s_new == 0:
                    kind = STICK
            else:
                return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
            nxt = index_of[new] if new in index_of else -1
            zt = zero_time + 1 if tau == 0.0 else 0
            if nxt < 0 or zt > max_zero:
                return n_ev, n_pc, tau, g, st, mi, code, zero_time, t, q, v, work, diss, fric, loss, escale
            zero_time = zt
            mi = nxt
            code = new
        ev_t[n_ev] = t
        ev_kind[n_ev] = kind
        ev_index[n_ev] = c
        ev_q[n_ev] = q
        ev_v[n_ev] = v
        n_ev += 1
