"""One piece, and the pieces and impacts of one mode, in one compiled call each.

:func:`advance` sets a piece up (:mod:`._forms`), searches its guards (:mod:`._guards`) and
evaluates its end; :func:`run_mode` strings pieces of one mode together with the impacts that
keep it, so that the Python transition rule (:mod:`._run`) runs only where the mode changes.
"""

from __future__ import annotations

import numpy as np

from ..._util.jit import njit
from ._forms import integrals, rdot, rmv, setup_piece, state_at
from ._guards import search

__all__ = ["advance", "run_mode"]


@njit
def advance(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, vq, vv, vq0, vv0, csym,
            t0, q0, v0, t_end, energy):
    """One piece from ``(t0, q0, v0)`` to its first guard or ``t_end``, in one compiled call.

    Returns ``(tau, guard, status, q1, v1, work, dissipation)`` (:func:`setup_piece`,
    :func:`search`, :func:`state_at`, and with ``energy`` :func:`integrals`).
    """
    a, P, beta, res, W, D, RG, rk, rj, c0, omt, cscale, dscale, poly, Xi, X = setup_piece(
        lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, t0, q0, v0)
    armed = np.ones(W.shape[0], dtype=np.bool_)
    tau, g, status = search(lam, W, omt, D, rk, rj, RG, c0, cscale, dscale, poly, armed, t0, t_end - t0)
    if status != 0:
        return tau, g, status, q0, v0, 0.0, 0.0
    if g < 0:
        tau = t_end - t0
    q1, v1 = state_at(vq, vv, lam, a, P, beta, res, omt, vq0, vv0, Xi, X, q0, tau)
    work = diss = 0.0
    if energy:
        work, diss = integrals(vq, vv, lam, pair, a, P, beta, res, omt, vq0, vv0, Xi, X, tau, csym, om, fh, t0)
    return tau, g, status, q1, v1, work, diss


@njit
def run_mode(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om, fh, vq, vv, vq0, vv0, csym,
             guard_kind, guard_index, impact_kind, normals, mn, nmn, restitution, can_rest, gaps, mn_norm, any_resting,
             fr_coord, fr_motion, fr_kinetic, f0, M, bound_forces, k_norm, c_norm, chatter_height, push_margin,
             t, q, v, t_end, energy, ev_t, ev_index, ev_q, ev_v, pc_t, pc_q, pc_v):
    """Pieces of one mode, with the impacts that keep the mode resolved here, compiled.

    An impact on a rigid stop keeps the mode when no stop rests, the impulse reverses no
    friction coordinate and the rebound is too fast for rest (the cheap bound of the push of
    the Python rule): those are applied here (``v -> v - (1 + e) (n.v) M^-1 n / (n.M^-1 n)``)
    and recorded in ``ev_*``, every piece start in ``pc_*``. Any other event, ``t_end``, a
    full buffer or a failed search returns to the Python rule with the state at the event.

    Returns ``(n_events, n_pieces, tau, guard, status, t, q, v, work, dissipation, friction,
    impact_loss, energy_scale)``.
    """
    n_ev = 0
    n_pc = 0
    work = diss = fric = loss = 0.0
    escale = 0.0
    cap = ev_t.shape[0]
    while True:
        tau, g, st, q1, v1, w, d = advance(lam, pair, gin, gv, wk, N, gin0, gv0, wk0, ga, gu, gc, kmode, const, om,
                                           fh, vq, vv, vq0, vv0, csym, t, q, v, t_end, energy)
        pc_t[n_pc] = t
        pc_q[n_pc] = q
        pc_v[n_pc] = v
        n_pc += 1
        if st != 0:
            return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        t1 = t + tau if g >= 0 else t_end
        if energy:
            work += w + rdot(f0, q1 - q)
            diss += d
            for i in range(fr_coord.shape[0]):
                fric += fr_kinetic[i] * fr_motion[i] * (q1[fr_coord[i]] - q[fr_coord[i]])
            escale = max(escale, 0.5 * abs(rdot(v1, rmv(M, v1))) + 0.5 * abs(rdot(q1, rmv(kmode, q1))))
        t, q, v = t1, q1, v1
        if g < 0 or guard_kind[g] != impact_kind or tau == 0.0 or any_resting or n_ev >= cap or n_pc >= cap:
            return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        c = guard_index[g]
        u = rdot(normals[c], v)
        vn = v - (1.0 + restitution[c]) * u / nmn[c] * mn[c] if u > 0.0 else v.copy()
        for i in range(fr_coord.shape[0]):
            s = 1 if vn[fr_coord[i]] > 0.0 else (-1 if vn[fr_coord[i]] < 0.0 else 0)
            if s != fr_motion[i]:
                return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        if can_rest[c]:
            wn = -rdot(normals[c], vn)
            if wn <= 0.0:
                return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
            forces = bound_forces + k_norm * np.abs(q).sum() + c_norm * np.abs(vn).sum()
            if wn * wn <= 2.0 * push_margin * mn_norm[c] * forces * chatter_height * max(1.0, gaps[c]):
                return n_ev, n_pc, tau, g, st, t, q, v, work, diss, fric, loss, escale
        if energy:
            loss += 0.5 * rdot(v - vn, rmv(M, v + vn))
        v = vn
        ev_t[n_ev] = t
        ev_index[n_ev] = c
        ev_q[n_ev] = q
        ev_v[n_ev] = v
        n_ev += 1
