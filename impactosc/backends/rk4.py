"""rk4 backend: the paper's method, a fixed-step classic Runge-Kutta scheme on eq. 3.

This is the baseline the event-driven backends are measured against, reproduced as the
paper describes it (section 5: "using the fourth order Runge Kutta method, we solved
Eq. (3)"), errors included:

* one fixed step ``dt`` for the whole run (default: 100 steps per contact period
  ``2 pi / sqrt(1 + K)``); only the last step is shortened so that the run ends exactly
  at ``t_end``;
* the friction term is the naive ``beta * sign(V)`` (``np.sign``: 0 at ``V == 0``).
  There is **no stick logic**, so ``stick`` and ``release`` events never occur with this
  backend. Where the exact solution sticks, the mass does not stop. At fine steps (the
  default) the RK4 stages straddle ``V = 0`` inside every step while the step ends keep
  one sign of ``V``, with ``|V| ~ beta dt``: the "stuck" mass creeps at that spurious
  speed and no reversal is seen. At coarse steps ``V`` changes sign at step ends and the
  chatter shows up as spurious reversals;
* the flange springs are switched by ``|X| > 1`` inside the right-hand side, with **no
  event location**: a step that crosses a flange integrates across the kink of the force.

The model family (issue #10): the scheme integrates every member that its smooth
right-hand side can express, viscous damping ``2 zeta X'``, any sum of forcing harmonics
and the power-law flange ``K d^p`` (``d = |X| - 1``), with the same fixed step and the same
naive ``sign(V)``. It refuses, with a ``ValueError``, what needs the event location it does
not have: a rigid flange (an impact is an instantaneous reset at ``|X| = 1``), a static
friction level ``beta_static > beta`` (only the stick logic could tell the static from the
kinetic level) and ``sample_at`` (time events).

``flange="consistent"`` (default) uses the two-sided spring ``-K (X - sgn X) [|X| > 1]``
(``sgn X K d^p`` for a power law) of :class:`impactosc.Oscillator`. ``flange="paper"``
integrates eq. 2/3 as printed, ``-K H(X^2 - 1)(X - 1)`` at both flanges (a linear law
only: the misprint has no power-law form). At the upper flange the two agree. At the lower
flange the printed term is ``-K (X - 1) = K (1 + |X|) >= 2K`` for ``X < -1``: the force
jumps from 0 to ``2K`` at ``X = -1`` and points up, out of the lower flange. The lower
flange becomes a discontinuous wall ~``2K`` strong that stops the mass within a fraction
of one step, so the fixed-step scheme gives the mass a spurious kick each time it
reaches ``X = -1`` (see the tests for what that does to the contact statistics).

Events are not located, they are *reconstructed* from sign changes between consecutive
steps: ``contact_start``/``contact_end`` from sign changes of ``|X| - 1`` (side by the
sign of ``X``), ``reversal`` from sign changes of ``V`` (a sample with ``V == 0`` exactly
counts once: the reversal is placed at that sample). Times, ``X`` and ``V`` at an event
come from linear interpolation between the two samples; contact events are reported at
``X = +-1``, which is what that interpolation gives.

Statistics are streamed in the compiled loop, so ``record="stats"`` needs O(1) memory
however long the run: per flange, the impulse ``int f dLambda`` and ``int f^2 dLambda``
of the *sampled* flange force ``f`` (the trapezoid rule with its endpoint correction,
i.e. the integral of the cubic Hermite interpolant built from ``f`` and ``f' = +-K p d^(p-1) V``
at the samples; a step that crosses a flange contributes only its in-contact part, cut at
the interpolated crossing), the contact time, the deepest sampled penetration, the
forcing work ``int V f(Lambda)`` (trapezoid rule), the path length of the sampled ``X``
(for the friction work) and, beyond eq. 3, ``int V^2`` (for the damping loss
``2 zeta int V^2``: RK4's own quadrature of ``q' = V^2`` carried along the stages, fourth
order). Eq. 3 runs use a kernel compiled without the family terms (see ``_family_args``),
which keeps their arithmetic and their speed exactly as they were. With
``flange="paper"`` the statistics use the force the integrated equation actually applies
(``K (|X| + 1)`` at the lower flange).
Peak penetrations are the deepest *sample* of each contact (low by up to
``(omega dt)^2 / 8`` relative, 5e-4 at the default step).

numba is an optional dependency (``pip install impactosc[fast]``). Without it the same
loop runs as plain Python, some hundred times slower, and a warning says so once.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, NamedTuple

import numpy as np

from .. import _validation as _v
from ..engine import EVENT_KINDS, Mode, check_run_arguments, initial_mode
from ..model import Oscillator
from ..solution import Solution, _Recorder

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

__all__ = ["run", "rk4_batch", "BatchResult", "default_dt", "FLANGE_OPTIONS", "MAX_STEPS"]

FLANGE_OPTIONS = ("consistent", "paper")
#: Steps per contact period ``2 pi / sqrt(1 + K)`` used when ``dt`` is not given.
STEPS_PER_CONTACT_PERIOD = 100
#: A run needing more steps than this is refused: at ~6e7 steps/s (measured) it would
#: take more than half a minute per run, and a stored trajectory would need >80 GB.
MAX_STEPS = 2_000_000_000

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

_warned_slow = False


def _warn_if_slow() -> None:
    global _warned_slow
    if not _HAVE_NUMBA and not _warned_slow:
        _warned_slow = True
        warnings.warn("numba is not installed: the rk4 backend runs its fixed-step loop in plain Python, "
                      "some hundred times slower. Install it with: pip install impactosc[fast]",
                      RuntimeWarning, stacklevel=3)


# -- the compiled loop --------------------------------------------------------------------
@_njit
def _accel(x, v, fc, beta, damp, K, p, jlo):
    """Right-hand side ``V'`` of eq. 3 and its family with naive ``sign(V)``.

    ``fc`` is the forcing, ``damp = 2 zeta``, ``p`` the flange exponent and ``jlo`` 0 or 2K
    (paper flange, ``p = 1`` only). ``damp = p = None`` compiles eq. 3 alone (see
    :func:`_family_args`).
    """
    a = fc - x
    if v > 0.0:
        a -= beta
    elif v < 0.0:
        a += beta
    if damp is not None:
        a -= damp * v
    if x > 1.0:
        if p is None or p == 1.0:
            a -= K * (x - 1.0)
        else:
            a -= K * (x - 1.0) ** p
    elif x < -1.0:
        if p is None or p == 1.0:
            # consistent: -K (X + 1); as printed in the paper: -K (X - 1) = -K (X + 1) + 2K
            a -= K * (x + 1.0) - jlo
        else:
            a += K * (-x - 1.0) ** p
    return a


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


@_njit
def _kernel(F, Om, phase, harm, beta, damp, K, p, jlo, dt, t_end, n_steps, S, I,
            ev, imp, keep_events, tr_t, tr_x, tr_v, tr_qu, tr_ql, every, max_events):
    """Advance the fixed-step RK4 loop from step ``I[_I_K]`` until the end, the event limit,
    a non-finite state, or (with ``keep_events``) nearly full event/impact buffers.

    ``harm`` holds the further forcing harmonics (rows ``F_i, Omega_i, phase_i``),
    ``damp = 2 zeta`` and ``p`` is the flange exponent; all three are ``None`` for eq. 3
    (see :func:`_family_args`). All state lives in ``S`` (floats) and ``I`` (integers), so
    a call can resume where the previous one returned; the status is left in
    ``I[_I_STATUS]``.
    """
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
        if anchor:
            c0 = math.cos(Om * t0 + phase)
            s0 = math.sin(Om * t0 + phase)
            first = False
        if last:
            cm = math.cos(Om * (t0 + 0.5 * h) + phase)
            c1 = math.cos(Om * t1 + phase)
            s1 = math.sin(Om * t1 + phase)
        else:
            cm = c0 * rc - s0 * rs
            sm = s0 * rc + c0 * rs
            c1 = cm * rc - sm * rs
            s1 = sm * rc + cm * rs
        f0 = F * c0
        fm = F * cm
        f1 = F * c1
        if harm is not None:
            f0, fm, f1 = _harmonics_step(harm, t0, t1, anchor, last, rot, f0, fm, f1)

        # Classic RK4 on (X, V).
        hh = 0.5 * h
        k1v = _accel(x, v, f0, beta, damp, K, p, jlo)
        x2 = x + hh * v
        v2 = v + hh * k1v
        k2v = _accel(x2, v2, fm, beta, damp, K, p, jlo)
        x3 = x + hh * v2
        v3 = v + hh * k2v
        k3v = _accel(x3, v3, fm, beta, damp, K, p, jlo)
        x4 = x + h * v3
        v4 = v + h * k3v
        k4v = _accel(x4, v4, f1, beta, damp, K, p, jlo)
        x1 = x + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
        v1 = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
        if not (math.isfinite(x1) and math.isfinite(v1)):
            status = _NONFINITE
            break

        # -- reconstruct the events of this step from sign changes --------------------
        ne = 0
        ga = x - 1.0
        gb = x1 - 1.0
        if (in_up != 0) != (gb > 0.0):
            th = ga / (ga - gb) if ga != gb else 0.0
            e_t[ne] = t0 + th * h
            e_x[ne] = 1.0
            e_v[ne] = v + th * (v1 - v)
            e_kind[ne] = _CONTACT_START if gb > 0.0 else _CONTACT_END
            e_side[ne] = 1
            ne += 1
        ga = -x - 1.0
        gb = -x1 - 1.0
        if (in_lo != 0) != (gb > 0.0):
            th = ga / (ga - gb) if ga != gb else 0.0
            e_t[ne] = t0 + th * h
            e_x[ne] = -1.0
            e_v[ne] = v + th * (v1 - v)
            e_kind[ne] = _CONTACT_START if gb > 0.0 else _CONTACT_END
            e_side[ne] = -1
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
        dqu, dsqu, dctu = _side_quad(x - 1.0, x1 - 1.0, v, v1, h, K, p, 0.0)
        dql, dsql, dctl = _side_quad(-x - 1.0, -x1 - 1.0, -v, -v1, h, K, p, jlo)

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
                        imp[nimp, 0] = o_start
                        imp[nimp, 1] = te
                        imp[nimp, 2] = side
                        imp[nimp, 3] = o_vin
                        imp[nimp, 4] = e_v[j]
                        imp[nimp, 5] = o_pen
                        if p is None or p == 1.0:
                            imp[nimp, 6] = K * o_pen + (jlo if side == -1 else 0.0)
                        else:
                            imp[nimp, 6] = K * o_pen**p
                        imp[nimp, 7] = o_imp
                        imp[nimp, 8] = o_complete
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
            dqu, dsqu, dctu = _side_quad(x - 1.0, x1 - 1.0, v, v1, h, K, p, 0.0)
            dql, dsql, dctl = _side_quad(-x - 1.0, -x1 - 1.0, -v, -v1, h, K, p, jlo)
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
        pen = x1 - 1.0
        if pen > mpu:
            mpu = pen
        pen_l = -x1 - 1.0
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
def _init_state(x0, v0, region):
    """State vectors for a run starting at ``(x0, v0)`` in flange region ``region``."""
    S = np.zeros(_NS)
    I = np.zeros(_NI, dtype=np.int64)
    S[_S_X] = x0
    S[_S_V] = v0
    S[_S_MPU] = max(x0 - 1.0, 0.0)
    S[_S_MPL] = max(-x0 - 1.0, 0.0)
    I[_I_SV] = 1 if v0 > 0.0 else (-1 if v0 < 0.0 else 0)
    if region != 0:
        # A run that starts inside a flange: a contact in progress (incomplete), as in the engine.
        I[_I_UP] = 1 if region == 1 else 0
        I[_I_LO] = 1 if region == -1 else 0
        I[_I_OSIDE] = region
        S[_S_OPEN_PEN] = max(region * x0 - 1.0, 0.0)
        S[_S_OVIN] = v0
    return S, I


_EMPTY_1D = np.empty(0)
_NO_EVENT_LIMIT = 2**62


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


#: Kernels used by run() and rk4_batch(); module attributes so that the plain-Python
#: fallback can be exercised in tests where numba is installed.
_KERNEL = _kernel
_INIT_STATE = _init_state
_BATCH_KERNEL = _batch_kernel


# -- arguments ----------------------------------------------------------------------------
def default_dt(K: float) -> float:
    """Default step: ``STEPS_PER_CONTACT_PERIOD`` steps per contact period ``2 pi / sqrt(1 + K)``."""
    return 2.0 * math.pi / (STEPS_PER_CONTACT_PERIOD * math.sqrt(1.0 + K))


def _step_count(dt: float, t_end: float) -> int:
    """Number of steps: whole steps of ``dt``, plus a shortened last one unless the remainder
    is rounding noise (then the last whole step simply ends at ``t_end``)."""
    n_full = math.floor(t_end / dt)
    rem = t_end - n_full * dt
    return max(1, n_full + (1 if rem > 1e-9 * dt else 0))


def _check_dt(dt, t_end: float, K: float) -> tuple[float, int]:
    if dt is None:
        dt = min(default_dt(K), t_end)
    dt = _v.real("dt", dt)
    if not dt > 0.0:
        raise ValueError(f"dt must be > 0, got {dt!r}")
    if dt > t_end:
        raise ValueError(f"dt must be <= t_end={t_end!r}, got dt={dt!r}")
    if t_end / dt > MAX_STEPS:
        raise ValueError(f"dt={dt!r} needs {t_end / dt:.3g} steps to reach t_end={t_end!r}, more than the limit "
                         f"{MAX_STEPS:.0e}; use a larger dt or a shorter run")
    return dt, _step_count(dt, t_end)


def _flange_jump(flange, K: float, exponent: float = 1.0) -> float:
    """Jump ``jlo`` of the lower flange force: ``2K`` for eq. 2/3 as printed, else 0."""
    _v.choice("flange", flange, FLANGE_OPTIONS)
    if flange == "paper" and exponent != 1.0:
        raise ValueError(f"flange='paper' (eq. 2/3 as printed, -K H(X^2 - 1)(X - 1)) applies to the linear "
                         f"flange law only, got exponent={exponent!r}; use flange='consistent' for K d^p")
    return 2.0 * K if flange == "paper" else 0.0


def _refuse_unsupported(osc: Oscillator, sample_at=()) -> None:
    """Refuse what the fixed-step scheme cannot express: each needs event location (or stick logic)."""
    if len(sample_at):
        raise ValueError("sample_at needs time events, which the rk4 baseline does not locate; "
                         "use backend='heyoka', 'scipy' or 'exact'")
    if osc.rigid:
        raise ValueError(f"the rk4 baseline does not support a rigid flange (restitution={osc.restitution!r}): "
                         "an impact is an instantaneous reset V -> -e V at |X| = 1, which needs event location; "
                         "use backend='heyoka' or 'scipy'")
    if osc.beta_s != osc.beta:
        raise ValueError(f"the rk4 baseline does not support static friction beta_static={osc.beta_static!r} > "
                         f"beta={osc.beta!r}: its naive sign(V) has no stick logic, so a static level cannot "
                         "enter; use backend='heyoka' or 'scipy'")


def _family_args(harmonics, zeta, exponent):
    """``(harm, damp, p)`` for the kernels: all ``None`` for eq. 3, else the further harmonics
    as rows ``F_i, Omega_i, phase_i`` (shape ``(3, n)``, or ``(sets, 3, n)`` in a batch),
    ``2 zeta`` and ``p``.

    The right-hand side lies on RK4's serial chain of stages: any extra operation there,
    even a multiplication by zero, costs some 10% of the step rate, and so do the unused
    harmonics loop and ``int V^2``. ``None`` lets numba prune the family code at compile
    time, so eq. 3 runs keep their speed and their exact arithmetic; the one family variant
    compiles on first use (and is cached like the other).
    """
    zeta = np.asarray(zeta, dtype=float)
    exponent = np.asarray(exponent, dtype=float)
    harm = np.ascontiguousarray(harmonics, dtype=float)
    if harm.shape[-1] == 0 and not np.any(zeta != 0.0) and not np.any(exponent != 1.0):
        return None, None, None
    damp = 2.0 * zeta
    if damp.ndim == 0:
        return harm, float(damp), float(exponent)
    return harm, damp, exponent


# -- dense output -------------------------------------------------------------------------
def _impulse_np(pa, pb, h, K, j, p=1.0):
    """Trapezoid integral of the linearly interpolated force over the in-contact part of each interval."""
    with np.errstate(divide="ignore", invalid="ignore"):
        both = (pa > 0.0) & (pb > 0.0)
        L = np.where(both, h, np.where(pa > 0.0, h * pa / (pa - pb), h * pb / (pb - pa)))
        if p == 1.0:
            fa = np.where(pa > 0.0, K * pa + j, j)
            fb = np.where(pb > 0.0, K * pb + j, j)
        else:
            fa = np.where(pa > 0.0, K * np.maximum(pa, 0.0) ** p + j, j)
            fb = np.where(pb > 0.0, K * np.maximum(pb, 0.0) ** p + j, j)
        return np.where((pa > 0.0) | (pb > 0.0), 0.5 * (fa + fb) * L, 0.0)


class _Trajectory:
    """Stored samples of one run and their interpolation (the evaluator handed to Solution).

    ``X`` and ``V`` are interpolated by cubic Hermite polynomials built from the stored
    ``V`` and the acceleration of eq. 3 (with the member's family terms) at each sample
    (``X' = V`` and ``V' = a`` are known at every sample). The cumulative flange impulse
    is the streamed value at the stored samples; in between it follows the trapezoid
    integral of the linearly interpolated force, scaled to reach the next sample's value,
    so it is monotonic, continuous and windows add up exactly to the streamed totals.
    """

    def __init__(self, osc: Oscillator, jlo: float, t, x, v, qu, ql):
        self.osc, self.jlo = osc, jlo
        self.t, self.x, self.v, self.qu, self.ql = t, x, v, qu, ql

    def _accel(self, t, x, v):
        o = self.osc
        a = o.forcing(t) - x - o.beta * np.sign(v)
        if o.zeta:
            a = a - 2.0 * o.zeta * v
        if o.exponent == 1.0:
            a = a - np.where(x > 1.0, o.K * (x - 1.0), 0.0)
            return a - np.where(x < -1.0, o.K * (x + 1.0) - self.jlo, 0.0)
        return a - np.sign(x) * o.flange_force(x)

    def _locate(self, times):
        j = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, len(self.t) - 2)
        h = self.t[j + 1] - self.t[j]
        return j, h, (times - self.t[j]) / h

    def state(self, times):
        j, h, s = self._locate(times)
        t, x, v = self.t, self.x, self.v
        a0 = self._accel(t[j], x[j], v[j])
        a1 = self._accel(t[j + 1], x[j + 1], v[j + 1])
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        xs = h00 * x[j] + h10 * h * v[j] + h01 * x[j + 1] + h11 * h * v[j + 1]
        vs = h00 * v[j] + h10 * h * a0 + h01 * v[j + 1] + h11 * h * a1
        return xs, vs

    def cumulative_impulse(self, side: int, times):
        j, h, s = self._locate(times)
        cum = self.qu if side == 1 else self.ql
        jump = 0.0 if side == 1 else self.jlo
        pa = side * self.x[j] - 1.0
        pb = side * self.x[j + 1] - 1.0
        p = self.osc.exponent
        part = _impulse_np(pa, pa + s * (pb - pa), s * h, self.osc.K, jump, p)
        whole = _impulse_np(pa, pb, h, self.osc.K, jump, p)
        frac = np.where(whole > 0.0, part / np.where(whole > 0.0, whole, 1.0), s)
        return cum[j] + (cum[j + 1] - cum[j]) * frac

    def evaluator(self, mode: Mode, t0: float, x0: float, v0: float, times):
        xs, vs = self.state(times)
        if mode.region == 0:
            q = np.zeros_like(xs)
        else:
            q = (self.cumulative_impulse(mode.region, times)
                 - self.cumulative_impulse(mode.region, np.array([t0]))[0])
        return xs, vs, q


# -- public entry points -------------------------------------------------------------------
def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int, sample_at=(),
        dt: float | None = None, flange: str = "consistent", every: int = 1) -> Solution:
    """Integrate ``osc`` with the paper's fixed-step RK4 scheme (see the module docstring).

    Parameters
    ----------
    osc : Oscillator
        The model.
    t_end : float
        End time (> 0).
    x0, v0 : float
        Initial state.
    record : {"full", "events", "stats"}
        What to keep. ``"full"`` keeps every ``every``-th step for :meth:`Solution.sample`
        (cubic Hermite interpolation from the stored ``X``, ``V`` and the acceleration);
        ``"stats"`` streams the statistics in O(1) memory.
    max_events : int
        Stop with status 1 at the ``max_events``-th reconstructed event; the statistics
        then run to that event's time.
    dt : float, optional
        Fixed step (finite, > 0, <= ``t_end``). Default: ``2 pi / (100 sqrt(1 + K))``,
        100 steps per contact period. The last step is shortened to land on ``t_end``.
    flange : {"consistent", "paper"}
        ``"consistent"``: the two-sided spring ``-K (X - sgn X) [|X| > 1]`` (``K d^p`` for a
        power law); ``"paper"``: eq. 2/3 as printed, ``-K H(X^2 - 1)(X - 1)`` at both
        flanges (linear law only).
    every : int, optional
        With ``record="full"``, keep every ``every``-th step (default 1: all of them).

    Returns
    -------
    Solution
        With events ``contact_start``, ``contact_end`` and ``reversal`` only: the naive
        ``sign(V)`` has no stick logic, so ``stick``/``release`` never occur.

    Raises
    ------
    ValueError
        For a bad ``dt`` (not finite, <= 0, > ``t_end``, or more than ``MAX_STEPS`` steps),
        an unknown ``flange`` (or ``"paper"`` with a power law) or a bad ``every``, and for
        what needs event location: ``sample_at`` (time events), a rigid flange, and static
        friction ``beta_static > beta`` (stick logic).
    """
    osc, t_end, x0, v0, max_events = check_run_arguments(osc, t_end, x0, v0, max_events)
    # The kernel counts in int64; a larger limit can never be reached anyway.
    kernel_max_events = min(max_events, np.iinfo(np.int64).max)
    _v.choice("record", record, ("full", "events", "stats"))
    _refuse_unsupported(osc, sample_at)
    jlo = _flange_jump(flange, osc.K, osc.exponent)
    dt, n_steps = _check_dt(dt, t_end, osc.K)
    every = _v.integer("every", every, minimum=1)
    _warn_if_slow()

    mode0 = initial_mode(osc, 0.0, x0, v0)
    S, I = _INIT_STATE(x0, v0, mode0.region)
    keep_events = record != "stats"
    keep_traj = record == "full"
    if keep_traj:
        n_store = n_steps // every + 2
        tr = [np.empty(n_store) for _ in range(5)]
        tr[0][0], tr[1][0], tr[2][0], tr[3][0], tr[4][0] = 0.0, x0, v0, 0.0, 0.0
        I[_I_NTRAJ] = 1
    else:
        tr = [_EMPTY_1D] * 5
    cap = _EVENT_BUFFER if keep_events else 0
    ev = np.empty((cap, 5))
    imp = np.empty((cap, 9))

    traj = None
    rec = _Recorder(record, "rk4", None)
    rec.begin(osc, 0.0, x0, v0, mode0)
    impacts: list[tuple] = []
    harm, damp, p = _family_args(np.array(osc.harmonics, dtype=float).reshape(-1, 3).T, osc.zeta, osc.exponent)
    while True:
        _KERNEL(osc.F, osc.Omega, osc.phase, harm, osc.beta, damp, osc.K, p, jlo, dt, t_end, n_steps, S, I,
                ev, imp, keep_events, tr[0], tr[1], tr[2], tr[3], tr[4], every, kernel_max_events)
        for t, kind, x, v, side in ev[:I[_I_NEV]]:
            rec.event(float(t), EVENT_KINDS[int(kind)], float(x), float(v), int(side))
        impacts.extend((r[0], r[1], int(r[2]), r[3], r[4], r[5], r[6], r[7], bool(r[8])) for r in imp[:I[_I_NIMP]])
        I[_I_NEV] = 0
        I[_I_NIMP] = 0
        if I[_I_STATUS] != _BUFFER_FULL:
            break

    status = int(I[_I_STATUS])
    t_f, x_f, v_f = float(S[_S_T]), float(S[_S_X]), float(S[_S_V])
    if not keep_events:
        # No per-event calls in "stats": the kernel's counters are the record.
        rec.counts.update(contact_start=int(I[_I_START_UP] + I[_I_START_LO]),
                          contact_end=int(I[_I_END_UP] + I[_I_END_LO]), reversal=int(I[_I_REV]))
        rec.entries = {1: int(I[_I_START_UP]), -1: int(I[_I_START_LO])}
        rec.n_events = int(I[_I_NEVENTS])
    rec.impulse = {1: float(S[_S_QU]), -1: float(S[_S_QL])}
    rec.impulse_sq = {1: float(S[_S_SQU]), -1: float(S[_S_SQL])}
    rec.contact_time = {1: float(S[_S_CTU]), -1: float(S[_S_CTL])}
    rec.max_pen = {1: float(S[_S_MPU]), -1: float(S[_S_MPL])}
    rec.forcing_work = float(S[_S_WORK])
    rec.slip_path = float(S[_S_SLIP])  # total variation of the sampled X (friction_work = beta * this)
    rec.v_squared = float(S[_S_VSQ])  # int V^2 (damping_work = 2 zeta * this)
    rec.steps = int(I[_I_K])
    rec.pieces = int(I[_I_NEVENTS]) + 1  # stretches between reconstructed events

    region = 1 if I[_I_UP] else (-1 if I[_I_LO] else 0)
    motion = 1 if v_f > 0.0 else (-1 if v_f < 0.0 else 0)
    mode_f = Mode(region, motion, True)
    if status == _DONE:
        message = "The end time was reached."
    elif status == _EVENT_LIMIT:
        message = (f"The event limit max_events={max_events} was reached at t={t_f!r}; "
                   "results up to that time are kept.")
    else:
        message = (f"RK4 produced a non-finite state in the step after t={t_f!r} (dt={dt!r}); "
                   "results up to that time are kept. Use a smaller dt.")
    if I[_I_OSIDE] != 0 and keep_events:
        # A contact in progress at the end of the run: incomplete, no exit velocity.
        side = int(I[_I_OSIDE])
        pen = float(S[_S_OPEN_PEN])
        peak = (osc.K * pen + (jlo if side == -1 else 0.0)) if osc.exponent == 1.0 else osc.K * pen**osc.exponent
        impacts.append((float(S[_S_OSTART]), t_f, side, float(S[_S_OVIN]), math.nan, pen,
                        peak, float(S[_S_OIMP]), False))
    rec.finish(t_f, x_f, v_f, mode_f, status, message)
    if keep_events:
        # The recorder's own impact rows know nothing of penetration or impulse (no pieces were
        # streamed into it); the kernel tracked both per contact.
        rec.impacts = impacts

    if keep_traj:
        n = int(I[_I_NTRAJ])
        # Views, not copies, unless the run stopped early and most of the buffers are unused.
        traj = _Trajectory(osc, jlo, *((a[:n].copy() if 2 * n < len(a) else a[:n]) for a in tr))
        rec.evaluator = traj.evaluator
        # Solution credits an evaluator's impulse only to its segment's flange region, so the
        # run is split into segments at every contact start/end, each carrying the
        # cumulative impulse at its start.
        ev_all = rec.events
        sel = [i for i, e in enumerate(ev_all) if e[1] != "reversal"]
        if sel:
            times = np.array([ev_all[i][0] for i in sel])
            cu = traj.cumulative_impulse(1, times)
            cl = traj.cumulative_impulse(-1, times)
            for i, q_up, q_lo in zip(sel, cu, cl, strict=True):
                t, kind, x, v, side = ev_all[i][:5]
                reg = side if kind == "contact_start" else 0
                mot = 1 if v > 0.0 else (-1 if v < 0.0 else 0)
                rec.segments.append((t, x, v, reg, mot, True, float(q_up), float(q_lo)))
    return Solution(rec, t_end)


class BatchResult(NamedTuple):
    """Per-parameter-set results of :func:`rk4_batch` (arrays of the broadcast shape)."""

    mean_force_upper: np.ndarray
    mean_force_lower: np.ndarray
    contacts_upper: np.ndarray
    contacts_lower: np.ndarray
    max_penetration_upper: np.ndarray
    max_penetration_lower: np.ndarray
    status: np.ndarray


def rk4_batch(F, Omega, beta, K, phase=0.0, t_end=400.0, x0=0.95, v0=0.0, dt=None,
              flange: str = "consistent", *, zeta=0.0, exponent=1.0, harmonics=()) -> BatchResult:
    """Run the RK4 baseline for many parameter sets at once, statistics only.

    Every argument except ``flange`` may be an array; they are broadcast together and the
    sets run in parallel (numba ``prange``) through the same compiled loop as :func:`run`,
    so each set gives bit for bit what ``simulate(..., backend="rk4", record="stats")``
    gives for it.

    Parameters
    ----------
    F, Omega, beta, K, phase : float or array_like
        Model parameters (see :class:`impactosc.Oscillator`).
    t_end, x0, v0 : float or array_like
        End time (> 0) and initial state.
    dt : float, array_like or None
        Fixed step; None (or NaN entries in an array) selects the default per set.
    flange : {"consistent", "paper"}
        Flange force law (see :func:`run`; ``"paper"`` needs ``exponent == 1`` in every set).
    zeta, exponent : float or array_like, keyword-only
        Viscous damping ratio (>= 0) and flange exponent ``p >= 1`` (see :class:`impactosc.Oscillator`).
    harmonics : sequence of tuple, keyword-only
        Further forcing harmonics ``(F_i, Omega_i, phase_i)``, the same number in every set; each entry of a triple
        may be an array broadcast with the other arguments.

    Returns
    -------
    BatchResult
        Mean flange force per flange over the run (units of ``k L``), contact counts per
        flange, deepest sampled penetration per flange and the status (0: reached ``t_end``,
        -1: non-finite state), each of the broadcast shape.

    Raises
    ------
    ValueError
        For a parameter out of its range in any set (the message names it), and for
        ``flange="paper"`` with a power law. Rigid flanges and static friction are not
        parameters here: the fixed-step scheme cannot express them (see :func:`run`).
    """
    _v.choice("flange", flange, FLANGE_OPTIONS)
    terms = _batch_harmonics(harmonics)
    if dt is None:
        dt = np.nan
    args = (F, Omega, beta, K, phase, t_end, x0, v0, dt, zeta, exponent, *(a for term in terms for a in term))
    arrs = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    shape = arrs[0].shape
    flat = [np.ascontiguousarray(a).ravel() for a in arrs]
    F, Om, beta, K, phase, t_end, x0, v0, dt, zeta, exponent = flat[:11]
    extra = flat[11:]
    for name, a, lo in (("F", F, 0.0), ("Omega", Om, 0.0), ("beta", beta, 0.0), ("zeta", zeta, 0.0),
                        ("exponent", exponent, 1.0)):
        if not (np.all(np.isfinite(a)) and np.all(a >= lo)):
            raise ValueError(f"{name} must be finite and >= {lo:g} in every set")
    for name, a in (("K", K), ("t_end", t_end)):
        if not (np.all(np.isfinite(a)) and np.all(a > 0.0)):
            raise ValueError(f"{name} must be finite and > 0 in every set")
    for name, a in (("phase", phase), ("x0", x0), ("v0", v0)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite in every set")
    if flange == "paper" and np.any(exponent != 1.0):
        _flange_jump(flange, 1.0, float(exponent[exponent != 1.0][0]))  # raises, naming the exponent
    n = F.shape[0]
    dt = dt.copy()
    n_steps = np.empty(n, dtype=np.int64)
    region = np.empty(n, dtype=np.int64)
    for i in range(n):
        d = None if math.isnan(dt[i]) else float(dt[i])
        dt[i], n_steps[i] = _check_dt(d, float(t_end[i]), float(K[i]))
        osc = Oscillator(float(F[i]), float(Om[i]), float(beta[i]), float(K[i]), float(phase[i]),
                         zeta=float(zeta[i]), exponent=float(exponent[i]),
                         harmonics=[(float(a[i]), float(b[i]), float(c[i]))
                                    for a, b, c in zip(extra[0::3], extra[1::3], extra[2::3], strict=True)])
        region[i] = initial_mode(osc, 0.0, float(x0[i]), float(v0[i])).region
    jlo = 2.0 * K if flange == "paper" else np.zeros(n)
    _warn_if_slow()
    out_f = [np.empty(n) for _ in range(2)]
    out_n = [np.empty(n, dtype=np.int64) for _ in range(2)]
    out_p = [np.empty(n) for _ in range(2)]
    status = np.empty(n, dtype=np.int64)
    # harm[i] = rows F_i, Omega_i, phase_i of the further harmonics of set i.
    harm = np.array(extra, dtype=float).reshape(len(terms), 3, n).transpose(2, 1, 0) if terms else np.empty((n, 3, 0))
    harm, damp, p = _family_args(harm, zeta, exponent)
    _BATCH_KERNEL(F, Om, phase, harm, beta, damp, K, p, jlo, dt, t_end, n_steps, x0, v0, region,
                  out_f[0], out_f[1], out_n[0], out_n[1], out_p[0], out_p[1], status)
    return BatchResult(*(a.reshape(shape) for a in (*out_f, *out_n, *out_p, status)))


def _batch_harmonics(harmonics) -> list[tuple]:
    """``harmonics`` of :func:`rk4_batch`: triples (or pairs, phase 0) of scalars or arrays."""
    if isinstance(harmonics, str | bytes) or not hasattr(harmonics, "__iter__"):
        raise TypeError(f"harmonics must be a sequence of (F_i, Omega_i, phase_i) triples, got {harmonics!r}")
    out = []
    for i, term in enumerate(harmonics):
        if isinstance(term, str | bytes) or not hasattr(term, "__len__"):
            raise TypeError(f"harmonics[{i}] must be a triple (F_i, Omega_i, phase_i), got {term!r}")
        items = tuple(term)
        if len(items) == 2:
            items = (*items, 0.0)
        if len(items) != 3:
            raise ValueError(f"harmonics[{i}] must be a triple (F_i, Omega_i, phase_i), got {term!r}")
        out.append(items)
    return out
