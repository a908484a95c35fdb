"""From the rk4 kernel's buffers to a :class:`impactosc.solution.Solution`: the recorder's
events, totals and final state, and the dense output of a ``record="full"`` run (the stored
samples and their interpolation, the evaluator handed to the solution)."""

from __future__ import annotations

import math

import numpy as np

from ...engine._driver import EVENT_KINDS, Mode
from ...model._oscillator import Oscillator
from ...results._solution import _Recorder
from . import _kernels as _k  # the layout of the state vectors S, I and the status codes

_EMPTY_1D = np.empty(0)


# -- kernel buffers -> recorder ------------------------------------------------------------
def _trajectory_buffers(keep: bool, n_steps: int, every: int, x0: float, v0: float, I) -> list[np.ndarray]:
    """The kernel's trajectory buffers ``t, X, V`` and the cumulative impulses per flange.

    With ``keep`` they hold every ``every``-th step and the initial state (counted in
    ``I[_I_NTRAJ]``); without it they are empty, which tells the kernel to store nothing.
    """
    if not keep:
        return [_EMPTY_1D] * 5
    n_store = n_steps // every + 2
    tr = [np.empty(n_store) for _ in range(5)]
    tr[0][0], tr[1][0], tr[2][0], tr[3][0], tr[4][0] = 0.0, x0, v0, 0.0, 0.0
    I[_k._I_NTRAJ] = 1
    return tr


def _drain_buffers(rec: _Recorder, impacts: list[tuple], ev, imp, I) -> None:
    """Hand the events of one kernel call to ``rec`` and its closed contacts to ``impacts``,
    then empty the buffers so that the next call can refill them."""
    for t, kind, x, v, side, direction in ev[:I[_k._I_NEV]]:
        rec.event(float(t), EVENT_KINDS[int(kind)], float(x), float(v), int(side), 1, int(direction))
    impacts.extend((r[0], r[1], int(r[2]), r[3], r[4], r[5], r[6], r[7], bool(r[8])) for r in imp[:I[_k._I_NIMP]])
    I[_k._I_NEV] = 0
    I[_k._I_NIMP] = 0


def _record_totals(rec: _Recorder, S, I, keep_events: bool) -> None:
    """Copy the kernel's streamed totals (counters, flange integrals, works) into ``rec``."""
    if not keep_events:
        # No per-event calls in "stats": the kernel's counters are the record.
        rec.counts.update(contact_start=int(I[_k._I_START_UP] + I[_k._I_START_LO]),
                          contact_end=int(I[_k._I_END_UP] + I[_k._I_END_LO]), reversal=int(I[_k._I_REV]))
        rec.entries = {1: int(I[_k._I_START_UP]), -1: int(I[_k._I_START_LO])}
        rec.n_events = int(I[_k._I_NEVENTS])
    rec.impulse = {1: float(S[_k._S_QU]), -1: float(S[_k._S_QL])}
    rec.impulse_sq = {1: float(S[_k._S_SQU]), -1: float(S[_k._S_SQL])}
    rec.contact_time = {1: float(S[_k._S_CTU]), -1: float(S[_k._S_CTL])}
    rec.max_pen = {1: float(S[_k._S_MPU]), -1: float(S[_k._S_MPL])}
    rec.forcing_work = float(S[_k._S_WORK])
    rec.slip_path = float(S[_k._S_SLIP])  # total variation of the sampled X (friction_work = beta * this)
    rec.v_squared = float(S[_k._S_VSQ])  # int V^2 (damping_work = 2 zeta * this)
    rec.steps = int(I[_k._I_K])
    rec.pieces = int(I[_k._I_NEVENTS]) + 1  # stretches between reconstructed events


def _status_message(status: int, max_events: int, t_f: float, dt: float) -> str:
    """The solution's message for a kernel status."""
    if status == _k._DONE:
        return "The end time was reached."
    if status == _k._EVENT_LIMIT:
        return (f"The event limit max_events={max_events} was reached at t={t_f!r}; "
                "results up to that time are kept.")
    return (f"RK4 produced a non-finite state in the step after t={t_f!r} (dt={dt!r}); "
            "results up to that time are kept. Use a smaller dt.")


def _open_contact(osc: Oscillator, jlo: float, S, I, t_f: float) -> tuple:
    """The impact row of the contact in progress at the end of the run: incomplete, no exit velocity."""
    side = int(I[_k._I_OSIDE])
    pen = float(S[_k._S_OPEN_PEN])
    peak = (osc.K * pen + (jlo if side == -1 else 0.0)) if osc.exponent == 1.0 else osc.K * pen**osc.exponent
    return (float(S[_k._S_OSTART]), t_f, side, float(S[_k._S_OVIN]), math.nan, pen, peak, float(S[_k._S_OIMP]), False)


def _finish_record(rec: _Recorder, osc: Oscillator, jlo: float, S, I, impacts: list[tuple], keep_events: bool,
                   max_events: int, dt: float) -> None:
    """Close ``rec`` with the kernel's final state, totals, status and impact rows."""
    status = int(I[_k._I_STATUS])
    t_f, x_f, v_f = float(S[_k._S_T]), float(S[_k._S_X]), float(S[_k._S_V])
    _record_totals(rec, S, I, keep_events)
    region = 1 if I[_k._I_UP] else (-1 if I[_k._I_LO] else 0)
    motion = 1 if v_f > 0.0 else (-1 if v_f < 0.0 else 0)
    if I[_k._I_OSIDE] != 0 and keep_events:
        impacts.append(_open_contact(osc, jlo, S, I, t_f))
    rec.finish(t_f, x_f, v_f, Mode(region, motion, True), status, _status_message(status, max_events, t_f, dt))
    if keep_events:
        # The recorder's own impact rows know nothing of penetration or impulse (no pieces were
        # streamed into it); the kernel tracked both per contact.
        rec.impacts = impacts


def _attach_trajectory(rec: _Recorder, osc: Oscillator, jlo: float, tr: list[np.ndarray], I) -> None:
    """Give ``rec`` the dense output of the samples the kernel stored in ``tr`` and the segments it needs."""
    n = int(I[_k._I_NTRAJ])
    # Views, not copies, unless the run stopped early and most of the buffers are unused.
    traj = _Trajectory(osc, jlo, *((a[:n].copy() if 2 * n < len(a) else a[:n]) for a in tr))
    rec.evaluator = traj.evaluator
    # Solution credits an evaluator's impulse only to its segment's flange region, so the
    # run is split into segments at every contact start/end, each carrying the
    # cumulative impulse at its start.
    ev_all = rec.events
    sel = [i for i, e in enumerate(ev_all) if e[1] != "reversal"]
    if not sel:
        return
    times = np.array([ev_all[i][0] for i in sel])
    cu = traj.cumulative_impulse(1, times)
    cl = traj.cumulative_impulse(-1, times)
    for i, q_up, q_lo in zip(sel, cu, cl, strict=True):
        t, kind, x, v, side = ev_all[i][:5]
        reg = side if kind == "contact_start" else 0
        mot = 1 if v > 0.0 else (-1 if v < 0.0 else 0)
        rec.segments.append((t, x, v, reg, mot, True, float(q_up), float(q_lo)))


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
            gu, gl = o.gap_upper, o.gap_lower
            a = a - np.where(x > gu, o.K * (x - gu), 0.0)
            return a - np.where(x < -gl, o.K * (x + gl) - self.jlo, 0.0)
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
        gap = self.osc.gap(side)
        if gap == math.inf:  # no flange on that side: no impulse
            return np.zeros(np.shape(times))
        pa = side * self.x[j] - gap
        pb = side * self.x[j + 1] - gap
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

