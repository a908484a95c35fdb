"""The compiled fixed-step loop of the rk4 backend: right-hand side, RK4 step, event
reconstruction and streamed statistics (see :mod:`impactosc.backends.rk4` for the scheme).

Every function numba compiles for the rk4 backend lives in this one file, and the file is
longer than the others for that reason: numba keys a function's on-disk cache on its own
source file only, so a compiled caller would keep the old machine code of a callee edited
in another file (``cache=True``). Kept together, an edit here invalidates all of them.
Without numba the same functions run as plain Python.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...engine._driver import EVENT_KINDS

_prange: Any  # numba.prange, or range without numba
try:
    import numba

    _HAVE_NUMBA = True
    _njit = numba.njit(cache=True)
    _njit_parallel = numba.njit(cache=True, parallel=True)
    _njit_inline = numba.njit(cache=True, inline="always")
    _prange = numba.prange
except ImportError:  # pragma: no cover - exercised only where numba is absent
    _HAVE_NUMBA = False

    def _njit(f):
        return f

    _njit_parallel = _njit
    _njit_inline = _njit
    _prange = range

# Event kind codes used inside the compiled loop (indices into engine.EVENT_KINDS).
_CONTACT_START, _CONTACT_END, _REVERSAL = 0, 1, 2
assert EVENT_KINDS[:3] == ("contact_start", "contact_end", "reversal")

# Kernel status codes.
_DONE, _EVENT_LIMIT, _NONFINITE, _BUFFER_FULL = 0, 1, -1, 2

# Layout of the float state vector S carried between kernel calls.
(_S_X, _S_V, _S_QU, _S_QL, _S_SQU, _S_SQL, _S_CTU, _S_CTL, _S_MPU, _S_MPL, _S_WORK, _S_SLIP,
 _S_TZ, _S_XZ, _S_OSTART, _S_OVIN, _S_OPEN_PEN, _S_OIMP, _S_T, _S_VSQ) = range(20)
_NS = 20
# Layout of the integer state vector I.
(_I_K, _I_UP, _I_LO, _I_SV, _I_OSIDE, _I_OCOMPLETE, _I_NEV, _I_NIMP, _I_NTRAJ,
 _I_START_UP, _I_START_LO, _I_END_UP, _I_END_LO, _I_REV, _I_NEVENTS, _I_STATUS) = range(16)
_NI = 16

#: Forcing phase is re-anchored with an exact cos/sin every this many steps; in between
#: it is advanced by an exact rotation, whose rounding drift stays ~1e-14 over 64 steps.
_ANCHOR = 64
#: Rows of the event and impact buffers handed back by one kernel call.
_EVENT_BUFFER = 4096
#: Event limit of the batch runs: never reached (they keep no events).
_NO_EVENT_LIMIT = 2**62


# -- the compiled loop --------------------------------------------------------------------
@_njit
def _accel(x, v, fc, beta, damp, K, p, jlo, gaps):
    """Right-hand side ``V'`` of eq. 3 and its family with naive ``sign(V)``.

    ``fc`` is the forcing, ``damp = 2 zeta``, ``p`` the flange exponent and ``jlo`` 0 or 2K
    (paper flange, ``p = 1`` only). ``damp = p = None`` compiles eq. 3 alone (see
    :func:`_family_args`). ``gaps`` is ``None`` for the paper's flanges at ``|X| = 1``, else
    ``(gap_upper, gap_lower)`` (``inf`` for an absent flange).
    """
    gu, gl = _gaps(gaps)
    a = fc - x
    if v > 0.0:
        a -= beta
    elif v < 0.0:
        a += beta
    if damp is not None:
        a -= damp * v
    if x > gu:
        if p is None or p == 1.0:
            a -= K * (x - gu)
        else:
            a -= K * (x - gu) ** p
    elif x < -gl:
        if p is None or p == 1.0:
            # consistent: -K (X + 1); as printed in the paper: -K (X - 1) = -K (X + 1) + 2K
            a -= K * (x + gl) - jlo
        else:
            a += K * (-x - gl) ** p
    return a


@_njit_inline
def _gaps(gaps):
    """``(gap_upper, gap_lower)``: ``(1.0, 1.0)`` when ``gaps`` is None (compiled away)."""
    if gaps is None:
        return 1.0, 1.0
    return gaps[0], gaps[1]


@_njit_inline
def _rk4_step(x, v, h, f0, fm, f1, beta, damp, K, p, jlo, gaps):
    """One classic RK4 step of length ``h`` on ``(X, V)``, the forcing given at its start,
    midpoint and end (``f0, fm, f1``; the other arguments as for :func:`_accel`).

    Returns ``(x1, v1, v2, v3, v4)``: the state at the end and the stage velocities, which
    the kernel's quadrature of ``int V^2`` reuses. Inlined: as a compiled call it cost the
    eq. 3 loop some 4% of its step rate (measured).
    """
    hh = 0.5 * h
    k1v = _accel(x, v, f0, beta, damp, K, p, jlo, gaps)
    x2 = x + hh * v
    v2 = v + hh * k1v
    k2v = _accel(x2, v2, fm, beta, damp, K, p, jlo, gaps)
    x3 = x + hh * v2
    v3 = v + hh * k2v
    k3v = _accel(x3, v3, fm, beta, damp, K, p, jlo, gaps)
    x4 = x + h * v3
    v4 = v + h * k3v
    k4v = _accel(x4, v4, f1, beta, damp, K, p, jlo, gaps)
    x1 = x + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
    v1 = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
    return x1, v1, v2, v3, v4


@_njit
def _forcing_at(F, Om, phase, harm, t):
    """The forcing ``F cos(Omega t + phase) + sum_i F_i cos(Omega_i t + phase_i)``, evaluated exactly.

    ``harm`` is None (eq. 3) or the further harmonics as rows ``F_i, Omega_i, phase_i``.
    """
    f = F * math.cos(Om * t + phase)
    if harm is not None:
        for i in range(harm.shape[1]):
            f += harm[0, i] * math.cos(harm[1, i] * t + harm[2, i])
    return f


@_njit_inline
def _fundamental_phases(Om, phase, t0, t1, anchor, exact, c0, s0, rc, rs):
    """``cos, sin`` of the fundamental's phase ``Omega t + phase`` over one step.

    Returns ``(c0, s0, cm, c1, s1)``: cos and sin at ``t0``, cos at ``(t0 + t1) / 2``,
    cos and sin at ``t1``. ``c0, s0`` are those the previous step left at ``t0``,
    re-anchored with an exact cos/sin when ``anchor``; the later points follow by the
    half-step rotation ``rc + 1j rs`` (see ``_ANCHOR``), or exactly when ``exact`` (the
    shortened last step, whose rotation differs). Inlined, as the kernel's other per-step
    helpers: a compiled call on this serial chain costs some percent of the step rate.
    """
    if anchor:
        c0 = math.cos(Om * t0 + phase)
        s0 = math.sin(Om * t0 + phase)
    if exact:
        h = t1 - t0
        cm = math.cos(Om * (t0 + 0.5 * h) + phase)
        c1 = math.cos(Om * t1 + phase)
        s1 = math.sin(Om * t1 + phase)
    else:
        cm = c0 * rc - s0 * rs
        sm = s0 * rc + c0 * rs
        c1 = cm * rc - sm * rs
        s1 = sm * rc + cm * rs
    return c0, s0, cm, c1, s1


@_njit_inline
def _harmonics_step(harm, t0, t1, anchor, exact, rot, f0, fm, f1):
    """Add the further harmonics at ``t0``, ``(t0 + t1) / 2`` and ``t1`` to ``f0, fm, f1``.

    ``rot[0, i], rot[1, i]`` hold ``cos, sin(Omega_i t0 + phase_i)``: re-anchored with an
    exact cos/sin when ``anchor``, then rotated by ``rot[2, i] + 1j rot[3, i]`` (half a step,
    see ``_ANCHOR``) and left at ``t1``; ``exact`` evaluates the later two points exactly
    instead (the shortened last step), as the kernel does for the fundamental. Inlined: a
    call passing arrays would cost reference counting in every step.
    """
    h = t1 - t0
    for i in range(harm.shape[1]):
        Fi, Omi, phi = harm[0, i], harm[1, i], harm[2, i]
        if anchor:
            rot[0, i] = math.cos(Omi * t0 + phi)
            rot[1, i] = math.sin(Omi * t0 + phi)
        c0 = rot[0, i]
        s0 = rot[1, i]
        if exact:
            cm = math.cos(Omi * (t0 + 0.5 * h) + phi)
            c1 = math.cos(Omi * t1 + phi)
            s1 = math.sin(Omi * t1 + phi)
        else:
            rc = rot[2, i]
            rs = rot[3, i]
            cm = c0 * rc - s0 * rs
            sm = s0 * rc + c0 * rs
            c1 = cm * rc - sm * rs
            s1 = sm * rc + cm * rs
        rot[0, i] = c1
        rot[1, i] = s1
        f0 += Fi * c0
        fm += Fi * cm
        f1 += Fi * c1
    return f0, fm, f1


@_njit
def _harmonics_rotation(harm, dt):
    """Scratch for :func:`_harmonics_step`: rows cos, sin (filled at the first anchor) and the
    half-step rotation ``cos, sin(Omega_i dt / 2)`` of every further harmonic."""
    rot = np.zeros((4, harm.shape[1]))
    for i in range(harm.shape[1]):
        rot[2, i] = math.cos(0.5 * harm[1, i] * dt)
        rot[3, i] = math.sin(0.5 * harm[1, i] * dt)
    return rot


@_njit
def _side_quad(pa, pb, da, db, h, K, p, j):
    """Flange integrals over one step from the sampled penetration ``d`` (> 0 in contact).

    ``pa, pb`` are the penetrations at the two ends of the step and ``da, db`` their rates
    (``+-V``). The force is ``f = K d^p + j`` while ``d > 0`` (``j`` is its jump at the
    boundary: 0 for the consistent spring, ``2K`` at the lower flange as printed in the
    paper, where ``p = 1``; ``p = None`` is the linear law). A step that crosses the
    boundary contributes only its in-contact part, cut at the linearly interpolated
    crossing (the same one the contact events use).

    Returns ``(int f, int f^2, time with p > 0)``. The integrals are the trapezoid rule
    with its endpoint correction ``L^2/12 (g'(a) - g'(b))``, i.e. the integral of the
    cubic Hermite interpolant, using ``f' = K p'`` which the integrator provides at every
    sample (``f' = K p d^(p-1) d'`` for a power law). Why not the plain trapezoid rule: its
    error does not cancel at the kinks of the force at the contact boundaries and comes to
    ``(omega dt)^2 / 12`` of each
    contact's impulse (3.3e-4 at the default step), some 30 times the error of the RK4
    solution it is meant to measure; the correction makes the quadrature O(dt^4).
    """
    if pa > 0.0:
        if pb > 0.0:
            L = h
        else:
            th = pa / (pa - pb)
            L = h * th
            pb = 0.0
            db = da + th * (db - da)
    elif pb > 0.0:
        th = pa / (pa - pb)
        L = h * (1.0 - th)
        pa = 0.0
        da = da + th * (db - da)
    else:
        return 0.0, 0.0, 0.0
    if p is None or p == 1.0:
        fa = K * pa + j
        fb = K * pb + j
        ga = K * da
        gb = K * db
    else:
        fa = K * pa**p + j
        fb = K * pb**p + j
        ga = K * p * pa ** (p - 1.0) * da
        gb = K * p * pb ** (p - 1.0) * db
    c = L * L / 12.0
    q = 0.5 * L * (fa + fb) + c * (ga - gb)
    q2 = 0.5 * L * (fa * fa + fb * fb) + 2.0 * c * (fa * ga - fb * gb)
    return q, q2, L


@_njit_inline
def _flange_quads(x, x1, v, v1, h, K, p, jlo, gu, gl):
    """:func:`_side_quad` at both flanges for the step ``(x, v) -> (x1, v1)`` of length ``h``.

    Returns ``(int f, int f^2, contact time)`` at the upper flange, then at the lower one
    (force jump ``jlo``), each clipped at the interpolated boundary crossings. Inlined: as a
    compiled call it cost the eq. 3 loop some 6% of its step rate (measured).
    """
    dqu, dsqu, dctu = _side_quad(x - gu, x1 - gu, v, v1, h, K, p, 0.0)
    dql, dsql, dctl = _side_quad(-x - gl, -x1 - gl, -v, -v1, h, K, p, jlo)
    return dqu, dsqu, dctu, dql, dsql, dctl


@_njit_inline
def _impact_row(imp, i, t_start, t_end, side, v_in, v_out, pen, impulse, complete, K, p, jlo):
    """Fill row ``i`` of the kernel's impact buffer ``imp`` for a contact that closed at ``t_end``.

    Columns: start and end time, side, entry and exit velocities, deepest sampled
    penetration, the force there, impulse, complete (0 for the contact a run starts in).
    Inlined, like :func:`_harmonics_step`: a compiled call passing an array costs reference counting.
    """
    imp[i, 0] = t_start
    imp[i, 1] = t_end
    imp[i, 2] = side
    imp[i, 3] = v_in
    imp[i, 4] = v_out
    imp[i, 5] = pen
    if p is None or p == 1.0:
        imp[i, 6] = K * pen + (jlo if side == -1 else 0.0)
    else:
        imp[i, 6] = K * pen**p
    imp[i, 7] = impulse
    imp[i, 8] = complete


@_njit
def _kernel(F, Om, phase, harm, beta, damp, K, p, jlo, dt, t_end, n_steps, S, I,
            ev, imp, keep_events, tr_t, tr_x, tr_v, tr_qu, tr_ql, every, max_events, gaps=None):
    """Advance the fixed-step RK4 loop from step ``I[_I_K]`` until the end, the event limit,
    a non-finite state, or (with ``keep_events``) nearly full event/impact buffers.

    ``harm`` holds the further forcing harmonics (rows ``F_i, Omega_i, phase_i``),
    ``damp = 2 zeta`` and ``p`` is the flange exponent; all three are ``None`` for eq. 3
    (see :func:`_family_args`); ``gaps`` as for :func:`_accel`. All state lives in ``S``
    (floats) and ``I`` (integers), so a call can resume where the previous one returned; the status is left in
    ``I[_I_STATUS]``.
    """
    gu, gl = _gaps(gaps)
    x = S[_S_X]
    v = S[_S_V]
    qu, ql, squ, sql = S[_S_QU], S[_S_QL], S[_S_SQU], S[_S_SQL]
    ctu, ctl, mpu, mpl = S[_S_CTU], S[_S_CTL], S[_S_MPU], S[_S_MPL]
    work, slip, tz, xz, vsq = S[_S_WORK], S[_S_SLIP], S[_S_TZ], S[_S_XZ], S[_S_VSQ]
    o_start, o_vin, o_pen, o_imp = S[_S_OSTART], S[_S_OVIN], S[_S_OPEN_PEN], S[_S_OIMP]
    k = I[_I_K]
    in_up = I[_I_UP]
    in_lo = I[_I_LO]
    sv = I[_I_SV]
    o_side = I[_I_OSIDE]
    o_complete = I[_I_OCOMPLETE]
    nev = I[_I_NEV]
    nimp = I[_I_NIMP]
    ntr = I[_I_NTRAJ]
    n_start_up, n_start_lo = I[_I_START_UP], I[_I_START_LO]
    n_end_up, n_end_lo, n_rev, n_events = I[_I_END_UP], I[_I_END_LO], I[_I_REV], I[_I_NEVENTS]
    keep_traj = tr_t.shape[0] > 0
    ev_cap = ev.shape[0]
    imp_cap = imp.shape[0]
    status = _DONE
    t_now = k * dt if k < n_steps else t_end

    # Exact rotation by half a step for the forcing phase (see _ANCHOR).
    rc = math.cos(0.5 * Om * dt)
    rs = math.sin(0.5 * Om * dt)
    c0 = 0.0
    s0 = 0.0
    if harm is not None:
        rot = _harmonics_rotation(harm, dt)
    first = True  # a resumed call must re-anchor the forcing phase at its first step
    # Local scratch for the (at most three) events of one step.
    e_t = np.empty(3)
    e_x = np.empty(3)
    e_v = np.empty(3)
    e_kind = np.empty(3, dtype=np.int64)
    e_side = np.empty(3, dtype=np.int64)
    e_dir = np.empty(3, dtype=np.int64)

    while k < n_steps:
        if keep_events and (nev + 3 > ev_cap or nimp + 2 > imp_cap):
            status = _BUFFER_FULL
            break
        t0 = k * dt
        last = k == n_steps - 1
        t1 = t_end if last else (k + 1) * dt
        h = t1 - t0
        # Forcing at t0, t0 + h/2, t1.
        anchor = first or last or k % _ANCHOR == 0
        first = False
        c0, s0, cm, c1, s1 = _fundamental_phases(Om, phase, t0, t1, anchor, last, c0, s0, rc, rs)
        f0 = F * c0
        fm = F * cm
        f1 = F * c1
        if harm is not None:
            f0, fm, f1 = _harmonics_step(harm, t0, t1, anchor, last, rot, f0, fm, f1)

        x1, v1, v2, v3, v4 = _rk4_step(x, v, h, f0, fm, f1, beta, damp, K, p, jlo, gaps)
        if not (math.isfinite(x1) and math.isfinite(v1)):
            status = _NONFINITE
            break

        # -- reconstruct the events of this step from sign changes --------------------
        ne = 0
        ga = x - gu
        gb = x1 - gu
        if (in_up != 0) != (gb > 0.0):
            th = ga / (ga - gb) if ga != gb else 0.0
            e_t[ne] = t0 + th * h
            e_x[ne] = gu
            e_v[ne] = v + th * (v1 - v)
            e_kind[ne] = _CONTACT_START if gb > 0.0 else _CONTACT_END
            e_side[ne] = 1
            e_dir[ne] = 1 if e_v[ne] > 0.0 else (-1 if e_v[ne] < 0.0 else 0)
            ne += 1
        ga = -x - gl
        gb = -x1 - gl
        if (in_lo != 0) != (gb > 0.0):
            th = ga / (ga - gb) if ga != gb else 0.0
            e_t[ne] = t0 + th * h
            e_x[ne] = -gl
            e_v[ne] = v + th * (v1 - v)
            e_kind[ne] = _CONTACT_START if gb > 0.0 else _CONTACT_END
            e_side[ne] = -1
            e_dir[ne] = 1 if e_v[ne] > 0.0 else (-1 if e_v[ne] < 0.0 else 0)
            ne += 1
        if v1 != 0.0:
            s_new = 1 if v1 > 0.0 else -1
            if sv != 0 and s_new != sv:
                if v == 0.0:
                    # V landed exactly on 0 at an earlier sample: that sample is the reversal.
                    e_t[ne] = tz
                    e_x[ne] = xz
                else:
                    th = v / (v - v1)
                    e_t[ne] = t0 + th * h
                    e_x[ne] = x + th * (x1 - x)
                e_v[ne] = 0.0
                e_kind[ne] = _REVERSAL
                e_side[ne] = 0
                e_dir[ne] = s_new
                ne += 1
            sv = s_new
        elif v != 0.0:
            tz = t1
            xz = x1

        # int V^2 over the step: RK4 on q' = V^2 alongside (X, V), i.e. its own stage weights.
        # Only the damping loss needs it (eq. 3 runs skip it: 6% of their step rate).
        dvsq = 0.0
        if damp is not None:
            dvsq = h / 6.0 * (v * v + 2.0 * v2 * v2 + 2.0 * v3 * v3 + v4 * v4)
        # Flange integrals of this step, per side (clipped at the interpolated boundaries).
        dqu, dsqu, dctu, dql, dsql, dctl = _flange_quads(x, x1, v, v1, h, K, p, jlo, gu, gl)

        stop = False
        t_stop = t1
        # Emit the step's events in time order (selection sort over at most three).
        for _ in range(ne):
            j = 0
            for i in range(1, ne):
                if e_t[i] < e_t[j]:
                    j = i
            te = e_t[j]
            e_t[j] = np.inf
            kind = e_kind[j]
            side = e_side[j]
            if kind == _CONTACT_START:
                if side == 1:
                    in_up = 1
                    n_start_up += 1
                else:
                    in_lo = 1
                    n_start_lo += 1
                o_start = te
                o_side = side
                o_vin = e_v[j]
                o_pen = 0.0
                o_imp = 0.0
                o_complete = 1
            elif kind == _CONTACT_END:
                # The in-contact part of this step ends here: it belongs to the closing contact.
                if side == 1:
                    in_up = 0
                    n_end_up += 1
                    o_imp += dqu
                else:
                    in_lo = 0
                    n_end_lo += 1
                    o_imp += dql
                if o_side == side:
                    if keep_events:
                        _impact_row(imp, nimp, o_start, te, side, o_vin, e_v[j], o_pen, o_imp, o_complete, K, p, jlo)
                        nimp += 1
                    o_side = 0
            else:
                n_rev += 1
            if keep_events:
                ev[nev, 0] = te
                ev[nev, 1] = kind
                ev[nev, 2] = e_x[j]
                ev[nev, 3] = e_v[j]
                ev[nev, 4] = side
                # The direction of motion after the event: the new one at a reversal, else that of V.
                ev[nev, 5] = e_dir[j]
                nev += 1
            n_events += 1
            if n_events >= max_events:
                stop = True
                t_stop = max(te, t0)
                break

        if stop:
            # End the run at the event: integrate the statistics over [t0, t_stop] only,
            # with the state linearly interpolated like the event itself.
            th = (t_stop - t0) / h
            x1 = x + th * (x1 - x)
            v1 = v + th * (v1 - v)
            f1 = _forcing_at(F, Om, phase, harm, t_stop)
            h = t_stop - t0
            t1 = t_stop
            if damp is not None:
                dvsq = 0.5 * h * (v * v + v1 * v1)
            dqu, dsqu, dctu, dql, dsql, dctl = _flange_quads(x, x1, v, v1, h, K, p, jlo, gu, gl)
            status = _EVENT_LIMIT

        qu += dqu
        ql += dql
        squ += dsqu
        sql += dsql
        ctu += dctu
        ctl += dctl
        work += 0.5 * h * (v * f0 + v1 * f1)
        vsq += dvsq
        slip += abs(x1 - x)
        pen = x1 - gu
        if pen > mpu:
            mpu = pen
        pen_l = -x1 - gl
        if pen_l > mpl:
            mpl = pen_l
        # A contact still open at the end of the step collects this step's part.
        if o_side == 1 and in_up != 0:
            o_imp += dqu
            if pen > o_pen:
                o_pen = pen
        elif o_side == -1 and in_lo != 0:
            o_imp += dql
            if pen_l > o_pen:
                o_pen = pen_l

        x = x1
        v = v1
        c0 = c1
        s0 = s1
        k += 1
        t_now = t1
        if keep_traj and (stop or last or k % every == 0):
            tr_t[ntr] = t1
            tr_x[ntr] = x1
            tr_v[ntr] = v1
            tr_qu[ntr] = qu
            tr_ql[ntr] = ql
            ntr += 1
        if stop:
            break

    S[_S_X], S[_S_V] = x, v
    S[_S_QU], S[_S_QL], S[_S_SQU], S[_S_SQL] = qu, ql, squ, sql
    S[_S_CTU], S[_S_CTL], S[_S_MPU], S[_S_MPL] = ctu, ctl, mpu, mpl
    S[_S_WORK], S[_S_SLIP], S[_S_TZ], S[_S_XZ] = work, slip, tz, xz
    S[_S_OSTART], S[_S_OVIN], S[_S_OPEN_PEN], S[_S_OIMP] = o_start, o_vin, o_pen, o_imp
    S[_S_T] = t_now
    S[_S_VSQ] = vsq
    I[_I_K], I[_I_UP], I[_I_LO], I[_I_SV] = k, in_up, in_lo, sv
    I[_I_OSIDE], I[_I_OCOMPLETE], I[_I_NEV], I[_I_NIMP], I[_I_NTRAJ] = o_side, o_complete, nev, nimp, ntr
    I[_I_START_UP], I[_I_START_LO], I[_I_END_UP], I[_I_END_LO] = n_start_up, n_start_lo, n_end_up, n_end_lo
    I[_I_REV], I[_I_NEVENTS], I[_I_STATUS] = n_rev, n_events, status


@_njit
def _init_state(x0, v0, region, gu=1.0, gl=1.0):
    """State vectors for a run starting at ``(x0, v0)`` in flange region ``region`` (flanges at ``gu``, ``-gl``)."""
    S = np.zeros(_NS)
    I = np.zeros(_NI, dtype=np.int64)
    S[_S_X] = x0
    S[_S_V] = v0
    S[_S_MPU] = max(x0 - gu, 0.0)
    S[_S_MPL] = max(-x0 - gl, 0.0)
    I[_I_SV] = 1 if v0 > 0.0 else (-1 if v0 < 0.0 else 0)
    if region != 0:
        # A run that starts inside a flange: a contact in progress (incomplete), as in the engine.
        I[_I_UP] = 1 if region == 1 else 0
        I[_I_LO] = 1 if region == -1 else 0
        I[_I_OSIDE] = region
        S[_S_OPEN_PEN] = max(region * x0 - (gu if region == 1 else gl), 0.0)
        S[_S_OVIN] = v0
    return S, I


@_njit_parallel
def _batch_kernel(F, Om, phase, harm, beta, damp, K, p, jlo, dt, t_end, n_steps, x0, v0, region,
                  mean_up, mean_lo, n_up, n_lo, pen_up, pen_lo, status):
    """One :func:`_kernel` run per set.

    ``harm`` (``harm[i]``: the further harmonics of set ``i``), ``damp`` and ``p`` are
    arrays, or all ``None`` when every set is eq. 3.
    """
    empty1 = np.empty(0)
    empty2 = np.empty((0, 9))
    for i in _prange(F.shape[0]):
        S, I = _init_state(x0[i], v0[i], region[i])
        if harm is None or damp is None or p is None:
            _kernel(F[i], Om[i], phase[i], None, beta[i], None, K[i], None, jlo[i], dt[i], t_end[i], n_steps[i],
                    S, I, empty2, empty2, False, empty1, empty1, empty1, empty1, empty1, 1, _NO_EVENT_LIMIT)
        else:
            _kernel(F[i], Om[i], phase[i], harm[i], beta[i], damp[i], K[i], p[i], jlo[i], dt[i], t_end[i],
                    n_steps[i], S, I, empty2, empty2, False, empty1, empty1, empty1, empty1, empty1, 1,
                    _NO_EVENT_LIMIT)
        mean_up[i] = S[_S_QU] / S[_S_T]
        mean_lo[i] = S[_S_QL] / S[_S_T]
        n_up[i] = I[_I_START_UP]
        n_lo[i] = I[_I_START_LO]
        pen_up[i] = S[_S_MPU]
        pen_lo[i] = S[_S_MPL]
        status[i] = I[_I_STATUS]
