"""The event loop of the exact n-DOF backend: closed-form pieces, the transition rule, the records.

The pieces run in one compiled call (:func:`._closed.run_modes`) across the events that only
change the mode (springs, lift-offs, releases: every mode built so far is a row of its table)
and the impacts that keep the mode (no stop resting, no friction coordinate reversed, a
rebound too fast for rest); every other event, and a mode not built yet, returns here, to the
transition rule of the model (module docstring of :mod:`impactosc.model._mechanical`): springs engage and release,
stops rest (chatter summed once the rebounds are below the rounding of the gap, stops
touched together resting together) and lift off, friction coordinates stick, reverse and
release, with the constraint forces of all active constraints solved together.
"""

from __future__ import annotations

import math
import threading
import weakref

import numpy as np

from ..._util.jit import HAVE_NUMBA
from ...model._mechanical import MechanicalSystem
from ...results._mechanical import MechanicalSolution
from . import _closed, _forms, _records, _setup
from ._modes import ENTER, IMPACT, LEAVE, LIFT, RELEASE, SLIP_END, Mode, build_mode, describe
from ._records import KIND_NAMES, EventLog

__all__ = ["run"]

#: Rebounds on a rigid stop are summed into rest once the next flight rises less than this
#: (relative to the stop's scale ``max(1, gap)``): the next impacts are below the rounding of
#: the gap, where no integrator can measure them (the engine's chatter rule on one coordinate).
_CHATTER_HEIGHT = 1e-13
#: Margin of the cheap bound of a push that decides whether the rest test is needed at all.
_PUSH_MARGIN = 1e6
#: Events and pieces the compiled loop of one mode records before it hands back.
_BUFFER = 4096


#: Transitions without time passing, per contact and friction entry, before a run gives up:
#: the active-set iteration of coupled stick and lift-off tests settles in a few.
_MAX_ZERO_TIME = 4


class _Runner:
    def __init__(self, system: MechanicalSystem):
        self.system = system
        self.modes: dict[tuple, Mode] = {}
        n = system.n
        harm = [(f, om, ph) for f, om, ph in system.harmonics if om > 0.0]
        self.om = np.array([om for _, om, _ in harm], dtype=float)
        self.fh = np.array([f * np.exp(1j * ph) for f, _, ph in harm], dtype=complex).reshape(len(harm), n)
        self.csym = 0.5 * (system.C + system.C.T)
        self.minv = system._minv
        # per contact: M^-1 n and n . M^-1 n, the direction and the inverse effective mass of an impulse
        self.mn = [self.minv @ c.normal for c in system.contacts]
        self.nmn = [float(c.normal @ mn) for c, mn in zip(system.contacts, self.mn, strict=True)]
        # norms for the cheap bound of a push (max-row-sum norms: |A x| <= |A|_inf |x|_1 entrywise bounds)
        self.mn_norm = [float(np.abs(mn).sum()) for mn in self.mn]
        self.f_norm = float(np.abs(self.fh).sum())
        self.c_norm = float(np.abs(system.C).max(initial=0.0))
        self._k_norms: dict[tuple, float] = {}
        # the same, as arrays for the compiled loop of a mode
        nc = len(system.contacts)
        self.normals = np.array([c.normal for c in system.contacts], dtype=float).reshape(nc, n)
        self.mn_array = np.array(self.mn, dtype=float).reshape(nc, n)
        self.nmn_array = np.array(self.nmn, dtype=float)
        self.mn_norm_array = np.array(self.mn_norm, dtype=float)
        self.restitution = np.array([c.restitution if c.rigid else 1.0 for c in system.contacts], dtype=float)
        self.can_rest = system.can_rest
        self.can_rest_array = np.array(self.can_rest, dtype=np.bool_)
        self.gaps = np.array([c.gap for c in system.contacts], dtype=float)
        self.fr_coord = np.array([f.coordinate for f in system.friction], dtype=np.int64)
        self.fr_kinetic = np.array([f.kinetic for f in system.friction], dtype=float)
        self.fr_static = np.array([f.static for f in system.friction], dtype=float)
        self.f0 = np.zeros(n)
        for f, om, ph in system.harmonics:
            if om == 0.0:
                self.f0 += f * math.cos(ph)
        self.lock = threading.Lock()
        # the compiled loop's table of the modes built so far, and their numbers
        nf = len(system.friction)
        self.coded = 2 * nc + math.log2(3.0) * nf < 62.0
        self.spring_bit = np.array([2**c if self.coded else 0 for c in range(nc)], dtype=np.int64)
        self.rest_bit = np.array([2 ** (nc + c) if self.coded else 0 for c in range(nc)], dtype=np.int64)
        self.fric_unit = np.array([3**i * 2 ** (2 * nc) if self.coded else 0 for i in range(nf)], dtype=np.int64)
        self.table = None  # a typed list of Mode.entry() rows, made at the first mode
        self.index_of = _index()
        self.max_zero_time = _MAX_ZERO_TIME * (1 + nc + nf)
        self.keys: list[tuple] = []
        self.rows: dict[tuple, int] = {}
        self.constants: dict[tuple, tuple] = {}  # each mode's _setup.mode_constants


    def k_norm(self, mode: Mode) -> float:
        norm = self._k_norms.get(mode.key)
        if norm is None:
            norm = self._k_norms[mode.key] = float(np.abs(mode.kmode).max(initial=0.0))
        return norm

    def mode(self, key: tuple) -> Mode:
        mode = self.modes.get(key)
        if mode is None:
            with self.lock:  # runs of one system in threads share its table: rows and numbers must match
                return self._add(key)
        return mode

    def _add(self, key: tuple) -> Mode:
        mode = self.modes.get(key)
        if mode is None:
            mode = build_mode(self.system, key)
            # the row first, then its numbers: a run in another thread never finds a number without its row
            constants = _setup.mode_constants(mode.lam, mode.gin, mode.gv, mode.wk, mode.ga, mode.gu, mode.gc,
                                              mode.kmode, mode.const, self.om, self.fh)
            if self.table is None:
                self.table = _closed.new_table(*mode.entry(), constants)
            else:
                _closed.push_mode(self.table, *mode.entry(), constants)
            self.constants[key] = constants
            self.keys.append(key)
            self.rows[key] = len(self.keys) - 1
            if self.coded:
                self.index_of[self.code(key)] = len(self.keys) - 1
            self.modes[key] = mode
        return mode

    def code(self, key: tuple) -> int:
        """The mode's number in the compiled loop's table (:func:`._closed.run_modes`); -1 when the
        numbers of this system's modes do not fit in 62 bits (then every mode change returns here)."""
        if not self.coded:
            return -1
        engaged, resting, motion = key
        return (sum(int(on) * int(b) for on, b in zip(engaged, self.spring_bit, strict=True))
                + sum(int(on) * int(b) for on, b in zip(resting, self.rest_bit, strict=True))
                + sum((s + 1) * int(u) for s, u in zip(motion, self.fric_unit, strict=True)))

    def setup(self, mode: Mode, t0: float, q0: np.ndarray, v0: np.ndarray):
        return _setup.setup_piece(mode.lam, mode.pair, mode.gin, mode.gv, mode.wk, mode.N, mode.gin0, mode.gv0,
                                  mode.wk0, mode.ga, mode.gc, mode.kmode, mode.const, self.om, self.fh,
                                  self.constants[mode.key], t0, q0, v0)

    def evaluate(self, mode: Mode, piece, q0: np.ndarray, taus: np.ndarray):
        a, P, beta, res, _, _, _, _, _, _, omt, _, _, _, Xi, X = piece
        qs = np.empty((taus.size, self.system.n))
        vs = np.empty_like(qs)
        for i, tau in enumerate(taus):
            qs[i], vs[i] = _forms.state_at(mode.vq, mode.vv, mode.lam, mode.pair, a, P, beta, res, omt, mode.vq0,
                                            mode.vv0, Xi, X, q0, float(tau))
        return qs, vs

    # --- forces needed by the transition rule -------------------------------------------------
    def residual_force(self, key: tuple, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``r = f(t) + const_mode - K_mode q - C v``: every force but the constraint forces of ``key``."""
        mode = self.mode(key)
        f = (self.fh * np.exp(1j * self.om * t)[:, None]).real.sum(axis=0)  # const holds the omega = 0 terms
        return f + mode.const - mode.kmode @ q - self.system.C @ v


def _initial_key(runner: _Runner, q: np.ndarray, v: np.ndarray, t: float) -> tuple:
    system = runner.system
    engaged, resting = [], []
    for c, contact in enumerate(system.contacts):
        g = float(contact.normal @ q) - contact.gap
        tol = 1e-12 * max(1.0, contact.gap)
        if contact.rigid and g > tol:
            raise ValueError(f"q0 penetrates the rigid stop contacts[{c}]: n . q0 - gap = {g!r} > 0")
        engaged.append((not contact.rigid) and g > 0.0)
        resting.append(False)
    motion = [int(np.sign(v[f.coordinate])) for f in system.friction]
    key = (tuple(engaged), tuple(resting), tuple(motion))
    for c, contact in enumerate(system.contacts):
        g = float(contact.normal @ q) - contact.gap
        if runner.can_rest[c] and abs(g) <= 1e-12 * max(1.0, contact.gap) \
                and float(contact.normal @ v) == 0.0:
            r = runner.residual_force(key, t, q, v)
            if float(contact.normal @ runner.minv @ r) > 0.0:  # pushed into the stop
                resting[c] = True
    key = (tuple(engaged), tuple(resting), tuple(motion))
    for i in range(len(system.friction)):
        if motion[i] == 0:
            motion[i] = _stick_test(runner, key, i, t, q, v)
            key = (tuple(engaged), tuple(resting), tuple(motion))
    return key


def _stick_test(runner: _Runner, key: tuple, i: int, t: float, q: np.ndarray, v: np.ndarray) -> int:
    """0 if friction entry ``i`` holds its coordinate at rest, else the direction it slips in.

    The holding force is computed together with the forces of the other active constraints
    (stuck coordinates, resting stops); a violation of theirs that this causes fires as
    their guard at the start of the next piece (an active-set iteration).
    """
    fr = runner.system.friction[i]
    motion = list(key[2])
    motion[i] = 0
    stuck = (key[0], key[1], tuple(motion))
    runner.mode(stuck)
    push = _closed.holding_force(runner.table, runner.rows[stuck], i, runner.om, runner.fh, runner.system.C, t, q, v)
    if abs(push) <= fr.static:
        return 0
    return 1 if push > 0.0 else -1


def run(system: MechanicalSystem, t_end: float, q0, v0, *, max_events: int, energy: bool) -> MechanicalSolution:
    """Run ``system`` from ``(q0, v0)`` at ``t = 0`` to ``t_end`` (see :func:`simulate_mechanical`)."""
    runner = _runner(system)
    buffers: list = []  # this run's buffers of the compiled loop (a runner may serve several runs at once)
    n = system.n
    q = np.array(q0, dtype=float)
    v = np.array(v0, dtype=float)
    t = 0.0
    key = _initial_key(runner, q, v, t)
    for s, fr in zip(key[2], system.friction, strict=True):
        if s == 0:
            v[fr.coordinate] = 0.0
    events = EventLog(n)
    pieces: list[tuple] = []  # chunks (start times, mode rows, q, v) of the compiled loop's piece records
    e0 = float(system.energy(q, v))
    terms = {"work": 0.0, "damping": 0.0, "friction": 0.0, "impacts": 0.0, "energy_max": abs(e0)}
    status, message = 0, "reached t_end"
    n_events = 0
    zero_time = 0
    while True:
        try:
            mode = runner.mode(key)
        except ValueError as err:
            status, message = -1, f"no closed form at t = {t!r} in the mode {describe(system, key)}: {err}"
            break
        key, tau, g, st, zero_time, t, q, v = _compiled_pieces(runner, key, t, q, v, t_end, energy, max_events,
                                                               zero_time, events, pieces, terms, buffers)
        mode = runner.mode(key)
        if st != 0:
            status, message = -1, (f"the guard search failed at t = {t + tau!r} in the mode {describe(system, key)} "
                                   f"(guard {mode.guards[g]}): non-finite values or no certified bracket")
            break
        if len(events) >= max_events:
            status, message = 1, f"stopped after max_events = {max_events} events at t = {t!r}"
            break
        if g < 0:
            break
        zero_time = zero_time + 1 if tau == 0.0 else 0
        if zero_time > runner.max_zero_time:
            status, message = -1, (f"no consistent mode at t = {t!r}: the stick, lift-off and contact tests keep "
                                   f"switching without time passing (last mode {describe(system, key)})")
            break
        key, q, v = _transition(runner, mode, g, key, t, q, v, events, terms, energy)
        n_events = len(events)
        if n_events >= max_events:
            status, message = 1, f"stopped after max_events = {max_events} events at t = {t!r}"
            break
    if energy:
        terms["delta_energy"] = float(system.energy(q, v)) - e0
    starts, rows, pq, pv = (np.concatenate([c[i] for c in pieces]) for i in range(4))
    keys = list(runner.keys)

    def evaluator(index: int, taus: np.ndarray):
        mode = runner.mode(keys[rows[index]])
        return runner.evaluate(mode, runner.setup(mode, starts[index], pq[index], pv[index]), pq[index], taus)

    return MechanicalSolution(n=n, t_end=t_end, events=events.array(), pieces=starts, evaluator=evaluator, t=t, q=q,
                              v=v, status=status, message=message, energy=terms if energy else {})


def _index():
    """An empty index of the modes' numbers: numba's typed dict when it is there."""
    if HAVE_NUMBA:
        from numba import types
        from numba.typed import Dict

        return Dict.empty(types.int64, types.int64)
    return {}  # pragma: no cover - plain Python runs the same loop on it


#: Runners of the systems simulated last (their mode tables), reused by later runs of the same object.
_RUNNERS: dict[int, tuple[weakref.ref, _Runner]] = {}
_KEEP_RUNNERS = 8


def _runner(system: MechanicalSystem) -> _Runner:
    """The runner of ``system``: the one of its last run (modes already built) or a new one."""
    held = _RUNNERS.get(id(system))
    if held is not None and held[0]() is system:
        runner = held[1]
    else:
        runner = _Runner(system)
        if len(_RUNNERS) >= _KEEP_RUNNERS:
            _RUNNERS.pop(next(iter(_RUNNERS)))
        _RUNNERS[id(system)] = (weakref.ref(system), runner)
    return runner


def _compiled_pieces(runner: _Runner, key: tuple, t: float, q: np.ndarray, v: np.ndarray, t_end: float,
                     energy: bool, max_events: int, zero_time: int, events: EventLog, pieces: list, terms: dict,
                     held: list):
    """Pieces and mode changes from ``(t, q, v)`` in ``key`` in one compiled call, recorded.

    Returns ``(key, tau, guard, status, zero_time, t, q, v)``: the mode reached, the offset and
    guard of its last piece's event (left to the Python rule when ``guard >= 0``).
    """
    system = runner.system
    cap = max(1, min(_BUFFER, max_events - len(events)))
    buffers = _records.buffers(held, system.n, cap)
    mi = runner.rows[key]
    (n_ev, n_pc, tau, g, st, mi, _, zero_time, t, q, v, work, diss, fric, loss, escale) = _closed.run_modes(
        runner.table, runner.index_of, mi, runner.code(key), runner.spring_bit, runner.rest_bit, runner.fric_unit,
        runner.om, runner.fh, runner.csym, runner.normals, runner.mn_array, runner.nmn_array, runner.restitution,
        runner.can_rest_array, runner.gaps, runner.mn_norm_array, runner.fr_coord, runner.fr_kinetic,
        runner.fr_static, runner.f0, system.M, system.C, runner.f_norm, runner.c_norm, _CHATTER_HEIGHT, _PUSH_MARGIN,
        t, q, v, t_end, energy, zero_time, runner.max_zero_time, *buffers)
    ev_t, ev_kind, ev_index, ev_q, ev_v, pc_t, pc_mode, pc_q, pc_v = buffers
    pieces.append((pc_t[:n_pc].copy(), pc_mode[:n_pc].copy(), pc_q[:n_pc].copy(), pc_v[:n_pc].copy()))
    if n_ev:
        events.block(ev_t[:n_ev], KIND_NAMES[ev_kind[:n_ev]], ev_index[:n_ev], ev_q[:n_ev], ev_v[:n_ev])
    if energy:
        terms["work"] += work
        terms["damping"] += diss
        terms["friction"] += fric
        terms["impacts"] += loss
        terms["energy_max"] = max(terms["energy_max"], escale)
    return runner.keys[mi], tau, g, st, zero_time, t, q, v


def _with(key: tuple, part: int, index: int, value) -> tuple:
    items = list(key[part])
    items[index] = value
    out = list(key)
    out[part] = tuple(items)
    return tuple(out)


def _transition(runner: _Runner, mode: Mode, g: int, key: tuple, t: float, q: np.ndarray, v: np.ndarray,
                events: EventLog, terms: dict, energy: bool):
    """The next mode and state after guard ``g`` of ``mode`` fired at ``(t, q, v)``; events appended."""
    system = runner.system
    kind, index, sign = mode.guards[g]
    if kind == ENTER:
        key = _with(key, 0, index, True)
        events.append((t, "contact_start", index, q, v))
    elif kind == LEAVE:
        key = _with(key, 0, index, False)
        events.append((t, "contact_end", index, q, v))
    elif kind == LIFT:
        key = _with(key, 1, index, False)
        events.append((t, "lift", index, q, v))
    elif kind == SLIP_END:
        coord = system.friction[index].coordinate
        v = v.copy()
        v[coord] = 0.0
        s = _stick_test(runner, key, index, t, q, v)
        key = _with(key, 2, index, s)
        events.append((t, "stick" if s == 0 else "reversal", index, q, v))
    elif kind == RELEASE:
        key = _with(key, 2, index, sign)
        events.append((t, "release", index, q, v))
    elif kind == IMPACT:
        key, q, v = _impact(runner, key, index, t, q, v, events, terms, energy)
    return key, q, v


def _impact(runner: _Runner, key: tuple, c: int, t: float, q: np.ndarray, v: np.ndarray, events: EventLog,
            terms: dict, energy: bool):
    """An impact on the rigid stop ``c``, then rest if the rebounds accumulate.

    Alone, the impulse acts along ``M^-1 n_c`` (module docstring of the model). While other
    stops hold the system at rest, the impulses of all of them are solved together
    (``n_c . v+ = -e n_c . v-``, ``n_b . v+ = 0``); a resting stop whose impulse would have to
    pull lifts off and the rest are solved again (the impact's small complementarity
    problem). A stuck coordinate the impulse sets moving slips that way (friction takes no
    impulse).
    """
    system = runner.system
    minv = runner.minv
    contact = system.contacts[c]
    nrm = contact.normal
    v_before = v
    resting = list(key[1])
    held = [b for b, on in enumerate(resting) if on]
    u = float(nrm @ v)
    if u > 0.0 and not held:
        v = v - (1.0 + contact.restitution) * u / runner.nmn[c] * runner.mn[c]
    elif u > 0.0:
        while True:
            G = np.array([system.contacts[k].normal for k in [c, *held]])
            change = np.concatenate([[-(1.0 + contact.restitution) * u], -(G[1:] @ v)])
            S = G @ minv @ G.T
            if np.linalg.cond(S) > 1e12:  # dependent with a resting stop: that one lets go
                held = []
                continue
            impulse = np.linalg.solve(S, change)  # v+ = v + M^-1 G^T impulse; a stop pushes with impulse <= 0
            pulling = [b for b, p in zip(held, impulse[1:], strict=True) if p > 0.0]
            if not pulling:
                break
            held = [b for b in held if b not in pulling]
        v = v + minv @ (G.T @ impulse)
    events.append((t, "impact", c, q, v))
    for b, on in enumerate(resting):
        if on and b not in held:
            resting[b] = False
            events.append((t, "lift", b, q, v))
    if runner.can_rest[c]:  # e = 1 too: damping or a slow approach leaves rebounds below the rounding
        resting, q, v = _chatter_rest(runner, key, c, t, q, v, resting, events)
    if energy:
        terms["impacts"] += 0.5 * float((v_before - v) @ system.M @ (v_before + v))
    # Friction coordinates that the impulse set moving (or reversed) slip the new way.
    motion = list(key[2])
    for i, fr in enumerate(system.friction):
        s = int(np.sign(v[fr.coordinate]))
        if s != motion[i] and s != 0:
            motion[i] = s
    return (key[0], tuple(resting), tuple(motion)), q, v


def _may_settle(runner: _Runner, key: tuple, c: int, q: np.ndarray, v: np.ndarray) -> bool:
    """False when the rebound from stop ``c`` is too fast for rest under any push the forces can give.

    A cheap bound of the push, ``|M^-1 n|_1 (sum |f_h| + |const|_1 + max|K_mode| |q|_1 + max|C| |v|_1)``
    (times a margin), spares the rest test (a mode and its constraint forces) after most impacts.
    """
    mode = runner.mode(key)
    contact = runner.system.contacts[c]
    w = -float(contact.normal @ v)
    if w <= 0.0:
        return True
    forces = (runner.f_norm + float(np.abs(mode.const).sum()) + runner.k_norm(mode) * float(np.abs(q).sum())
              + runner.c_norm * float(np.abs(v).sum()))
    # The bound holds for the push of stop c alone; the margin covers a joint rest with other stops.
    bound = _PUSH_MARGIN * runner.mn_norm[c] * forces
    return w * w <= 2.0 * bound * _CHATTER_HEIGHT * max(1.0, contact.gap)


def _settles(runner: _Runner, b: int, q: np.ndarray, v: np.ndarray, push: float) -> bool:
    """True when stop ``b`` is touched and its next flight, pushed by ``push``, is below the rounding."""
    contact = runner.system.contacts[b]
    scale = max(1.0, contact.gap)
    g = float(contact.normal @ q) - contact.gap
    w = max(-float(contact.normal @ v), 0.0)
    return abs(g) <= 1e-12 * scale and push > 0.0 and w * w / (2.0 * push) <= _CHATTER_HEIGHT * scale


def _chatter_rest(runner: _Runner, key: tuple, c: int, t: float, q: np.ndarray, v: np.ndarray, resting: list,
                  events: EventLog):
    """Rest on stop ``c`` (and on any other stop touched with it) once the rebounds are below the rounding.

    The push into each candidate stop is its force in the rest mode of all of them (solved
    together); a candidate that would pull is dropped and the rest solved again. Stops touched
    at once (a corner: two guides) thus come to rest together instead of knocking each other off.
    """
    system = runner.system
    minv = runner.minv
    if not _may_settle(runner, key, c, q, v):
        return resting, q, v
    others = [b for b, contact in enumerate(system.contacts)
              if b != c and runner.can_rest[b] and not resting[b]
              and abs(float(contact.normal @ q) - contact.gap) <= 1e-12 * max(1.0, contact.gap)]
    candidates = [c, *others]
    while candidates:
        flags = list(resting)
        for b in candidates:
            flags[b] = True
        rest_key = (key[0], tuple(flags), key[2])
        try:
            mode = runner.mode(rest_key)
        except ValueError:
            return resting, q, v  # dependent constraints: no consistent rest, it keeps bouncing
        lam = mode.weights[:sum(flags)] @ runner.residual_force(rest_key, t, q, v)
        row = {b: i for i, b in enumerate(k for k, on in enumerate(flags) if on)}
        pulling = [b for b in candidates if lam[row[b]] <= 0.0]
        if pulling:
            if c in pulling:
                return resting, q, v
            candidates = [b for b in candidates if b not in pulling]
            continue
        if not all(_settles(runner, b, q, v, lam[row[b]] * runner.nmn[b]) for b in candidates):
            return resting, q, v
        # zero the normal velocities of the resting stops, and put the coordinates on them
        # exactly (rest after rest would otherwise let the rounding of the gaps drift)
        on = [k for k, r in enumerate(flags) if r]
        G = np.array([system.contacts[k].normal for k in on])
        gaps = np.array([system.contacts[k].gap for k in on])
        S = G @ minv @ G.T
        v = v - minv @ (G.T @ np.linalg.solve(S, G @ v))
        q = q - minv @ (G.T @ np.linalg.solve(S, G @ q - gaps))
        for b in candidates:
            resting[b] = True
            events.append((t, "rest", b, q, v))
        return resting, q, v
    return resting, q, v
