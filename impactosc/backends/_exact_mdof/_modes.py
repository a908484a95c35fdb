"""The modes of a :class:`~impactosc.model.MechanicalSystem`: reduced dynamics, eigenbasis and guards.

A mode is the set of engaged spring contacts, the rigid stops the system rests on and the
motion of every friction coordinate (-1, 0 stuck, +1). Its constraints (stuck coordinates
``e_j``, resting stops ``n_c``) leave the motion ``q = q0 + B z`` with ``B`` an orthonormal
basis of their common null space; ``z`` obeys the reduced equation
``B^T M B z'' + B^T C B z' + B^T K_mode B z = B^T (f(t) + const_mode - K_mode q0)``, with
``K_mode = K + sum k_c n_c n_c^T`` (engaged springs) and ``const_mode`` the springs' preload
``k_c gap_c n_c``, the kinetic friction ``-mu_k s_j e_j`` of the slipping coordinates and the
constant harmonics. Every guard is a linear functional
``h = a . q + b . v + u . (f(t) + const_mode) + h_c`` of the state and the forces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...model._mechanical import MechanicalSystem

__all__ = ["Mode", "build_mode", "ENTER", "LEAVE", "IMPACT", "LIFT", "SLIP_END", "RELEASE", "STICK", "GUARD_NAMES"]

#: Guard kinds: a spring contact closes / opens, a rigid stop is hit, a resting stop lets go,
#: a slipping coordinate's velocity reaches zero, a stuck coordinate's holding force reaches mu_s.
ENTER, LEAVE, IMPACT, LIFT, SLIP_END, RELEASE = range(6)
#: Event code of a slip ending in a stick (a slip end that goes on, reversed, is a ``SLIP_END``).
STICK = 6
GUARD_NAMES = ("enter", "leave", "impact", "lift", "slip_end", "release")

#: Condition number of the eigenvectors above which a mode counts as defective.
_DEFECTIVE_CONDITION = 1e9


@dataclass(frozen=True)
class Mode:
    """One mode's closed-form data (arrays for the compiled piece code) and its guards."""

    key: tuple
    B: np.ndarray
    lam: np.ndarray
    gin: np.ndarray  # modal forcing from a generalised force vector
    gv: np.ndarray  # modal initial state from the velocity (z0 = 0)
    vq: np.ndarray  # q - q0 = Re(vq eta + vq0 xi)
    vv: np.ndarray
    N: np.ndarray  # the nilpotent zero-eigenvalue block, and its maps as above
    gin0: np.ndarray
    gv0: np.ndarray
    vq0: np.ndarray
    vv0: np.ndarray
    kmode: np.ndarray
    const: np.ndarray
    guards: tuple  # (kind, index, sign) per guard
    wk: np.ndarray
    wk0: np.ndarray
    ga: np.ndarray
    gb: np.ndarray
    gu: np.ndarray
    gc: np.ndarray
    weights: np.ndarray  # Wc: the constraint forces are Wc r (rows: resting stops, then stuck coordinates)
    friction_row: dict  # friction entry -> its row of weights
    guard_kind: np.ndarray  # the guards' kinds and indices as arrays, for the compiled loop
    guard_index: np.ndarray
    pair: np.ndarray  # the index of each eigenvalue's complex conjugate (-1: real or unpaired)
    guard_sign: np.ndarray

    def entry(self) -> tuple:
        """The mode as a row of the compiled loop's table (:func:`._closed.run_modes`): its arrays,
        its friction motions, ``[resting on a stop, |const|_1, max |K_mode|]``, its constraint-force
        weights and each friction entry's row of them (-1: slipping)."""
        info = np.array([float(any(self.key[1])), float(np.abs(self.const).sum()),
                         float(np.abs(self.kmode).max(initial=0.0))])
        rows = np.array([self.friction_row.get(i, -1) for i in range(len(self.key[2]))], dtype=np.int64)
        return (self.lam, self.pair, self.gin, self.gv, self.wk, self.N, self.gin0, self.gv0, self.wk0, self.ga,
                self.gu, self.gc, self.kmode, self.const, self.vq, self.vv, self.vq0, self.vv0, self.guard_kind,
                self.guard_index, self.guard_sign, np.array(self.key[2], dtype=np.int64), info,
                np.ascontiguousarray(self.weights, dtype=float), rows)


def _force_weights(system: MechanicalSystem, G: np.ndarray) -> np.ndarray:
    """``Wc = (G M^-1 G^T)^-1 G M^-1``: ``Wc r`` are the forces the constraints ``G q'' = 0`` take.

    With ``M q'' = r - G^T mu`` and ``G q'' = 0``; all the active constraints are solved
    together, so coupled stick and lift-off tests stay consistent.
    """
    GM = G @ system._minv
    S = GM @ G.T
    if np.linalg.cond(S) > 1e12:
        raise ValueError(f"the active constraints (rows {G.tolist()!r}) are linearly dependent: their forces "
                         "are not unique")
    return np.linalg.solve(S, GM)


def build_mode(system: MechanicalSystem, key: tuple) -> Mode:
    """The mode ``key = (engaged springs, resting stops, friction motions)`` of ``system``."""
    engaged, resting, motion = key
    n = system.n
    kmode = np.array(system.K, dtype=float)
    const = np.zeros(n)
    for f, om, ph in system.harmonics:
        if om == 0.0:
            const += f * np.cos(ph)
    constraints = []  # resting stops first, then stuck coordinates: the rows of the force weights
    for c, contact in enumerate(system.contacts):
        if engaged[c]:
            kmode += contact.stiffness * np.outer(contact.normal, contact.normal)
            const += contact.stiffness * contact.gap * contact.normal
        if resting[c]:
            constraints.append(contact.normal)
    for i, fr in enumerate(system.friction):
        if motion[i] != 0:
            const[fr.coordinate] -= fr.kinetic * motion[i]
        else:
            e = np.zeros(n)
            e[fr.coordinate] = 1.0
            constraints.append(e)
    weights = _force_weights(system, np.array(constraints)) if constraints else np.zeros((0, n))
    if constraints:
        _, sv, vt = np.linalg.svd(np.array(constraints))
        rank = int(np.sum(sv > 1e-12 * sv[0]))
        B = vt[rank:].T
    else:
        B = np.eye(n)
    m = B.shape[1]
    Mr, Cr, Kr = B.T @ system.M @ B, B.T @ system.C @ B, B.T @ kmode @ B
    Mri = np.linalg.inv(Mr) if m else np.zeros((0, 0))
    A = np.zeros((2 * m, 2 * m))
    A[:m, m:] = np.eye(m)
    A[m:, :m] = -Mri @ Kr
    A[m:, m:] = -Mri @ Cr
    V, lam, N = _block_eigenbasis(A, system, key)
    r = lam.shape[0]
    Vi = np.linalg.inv(V) if m else V
    gin = Vi[:, m:] @ Mri @ B.T if m else np.zeros((0, n), complex)
    gv = Vi[:, m:] @ B.T if m else np.zeros((0, n), complex)
    vq, vv = B @ V[:m], B @ V[m:]
    guards, rows = _guard_rows(system, key, kmode, weights)
    ng = len(rows)
    ga = np.array([r[0] for r in rows]).reshape(ng, n)
    gb = np.array([r[1] for r in rows]).reshape(ng, n)
    gu = np.array([r[2] for r in rows]).reshape(ng, n)
    gc = np.array([r[3] for r in rows]).reshape(ng) + gu @ const
    cY = np.hstack([ga @ B, gb @ B])
    wk = cY @ V if m else np.zeros((ng, 0), complex)
    friction_row = {i: sum(resting) + sum(1 for s in motion[:i] if s == 0) for i in range(len(motion))
                    if motion[i] == 0}

    def cx(a: np.ndarray) -> np.ndarray:  # contiguous arrays: one compiled specialisation for every mode
        return np.ascontiguousarray(a, dtype=complex)

    def re(a: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(a, dtype=float)

    return Mode(key, B, cx(lam), cx(gin[:r]), cx(gv[:r]), cx(vq[:, :r]), cx(vv[:, :r]),
                cx(N), cx(gin[r:]), cx(gv[r:]), cx(vq[:, r:]), cx(vv[:, r:]),
                re(kmode), re(const), tuple(guards), cx(wk[:, :r]), cx(wk[:, r:]), re(ga), re(gb), re(gu), re(gc),
                weights, friction_row, np.array([k for k, _, _ in guards], dtype=np.int64),
                np.array([i for _, i, _ in guards], dtype=np.int64), _conjugate_pairs(lam),
                np.array([s for _, _, s in guards], dtype=np.int64))


def _guard_rows(system: MechanicalSystem, key: tuple, kmode: np.ndarray, weights: np.ndarray):
    """The guards of the mode ``key`` as ``(kind, index, sign)`` and rows ``(a, b, u, h_c)`` (module docstring)."""
    engaged, resting, motion = key
    n = system.n
    guards, rows = [], []
    C = system.C
    row = 0
    for c, contact in enumerate(system.contacts):
        nrm = contact.normal
        zero = np.zeros(n)
        if contact.rigid and resting[c]:
            w = weights[row]  # h = -lambda, lambda = w . r
            row += 1
            guards.append((LIFT, c, 0))
            rows.append((kmode.T @ w, C.T @ w, -w, 0.0))
        elif contact.rigid:
            guards.append((IMPACT, c, 0))
            rows.append((nrm, zero, zero, -contact.gap))
        elif engaged[c]:
            guards.append((LEAVE, c, 0))
            rows.append((-nrm, zero, zero, contact.gap))
        else:
            guards.append((ENTER, c, 0))
            rows.append((nrm, zero, zero, -contact.gap))
    for i, fr in enumerate(system.friction):
        e = np.zeros(n)
        e[fr.coordinate] = 1.0
        if motion[i] != 0:
            guards.append((SLIP_END, i, 0))
            rows.append((np.zeros(n), -motion[i] * e, np.zeros(n), 0.0))
        else:
            w = weights[row]
            row += 1
            for sign in (1, -1):  # h = +-(w . r) - mu_s: slips towards sign
                guards.append((RELEASE, i, sign))
                rows.append((-sign * kmode.T @ w, -sign * C.T @ w, sign * w, -fr.static))
    return guards, rows


def _conjugate_pairs(lam: np.ndarray) -> np.ndarray:
    """``pair[k]``: the index of the eigenvalue that is exactly ``conj(lam[k])`` (LAPACK returns
    the pairs of a real matrix exactly conjugate), -1 for a real or unpaired one."""
    pair = np.full(lam.shape[0], -1, dtype=np.int64)
    for k in range(lam.shape[0]):
        if pair[k] >= 0 or lam[k].imag == 0.0:
            continue
        for p in range(k + 1, lam.shape[0]):
            if pair[p] < 0 and lam[p] == np.conj(lam[k]):
                pair[k], pair[p] = p, k
                break
    return pair


def _block_eigenbasis(A: np.ndarray, system: MechanicalSystem, key: tuple):
    """``V`` with ``V^-1 A V = diag(lambda) (+) N``: an eigenbasis, plus the zero eigenvalue's block.

    A zero eigenvalue of multiplicity ``k0`` (rigid-body motion: a free mass, a coordinate
    without stiffness) is often defective; its generalised eigenspace ``ker A^k0`` and the
    invariant complement ``range A^k0`` split ``A``, and ``N`` (nilpotent) is solved as a
    polynomial. Any other repeated eigenvalue without a full set of eigenvectors (critical
    damping) is refused.
    """
    m2 = A.shape[0]
    if m2 == 0:
        return np.zeros((0, 0), complex), np.zeros(0, complex), np.zeros((0, 0))
    eig = np.linalg.eigvals(A)
    scale = max(np.abs(A).max(), 1e-300)
    k0 = int(np.sum(np.abs(eig) <= 1e-8 * scale))
    if k0:
        U, sv, Vt = np.linalg.svd(np.linalg.matrix_power(A, k0))
        V0, Vr = Vt[m2 - k0:].T, U[:, :m2 - k0]
        P = np.hstack([Vr, V0])
        T = np.linalg.solve(P, A @ P)
        r = m2 - k0
        if np.abs(T[:r, r:]).max(initial=0.0) > 1e-9 * scale or np.abs(T[r:, :r]).max(initial=0.0) > 1e-9 * scale:
            raise ValueError(f"the mode {describe(system, key)} has a zero eigenvalue that does not split off")
        N = T[r:, r:]
        lam, W = np.linalg.eig(T[:r, :r]) if r else (np.zeros(0, complex), np.zeros((0, 0)))
        V = np.hstack([Vr @ W, V0.astype(complex)]) if r else V0.astype(complex)
        Wc = W
    else:
        lam, Wc = np.linalg.eig(A)
        V = Wc.astype(complex)
        N = np.zeros((0, 0))
    cond = np.linalg.cond(Wc) if Wc.size else 1.0
    if not cond < _DEFECTIVE_CONDITION:
        raise ValueError(f"the mode {describe(system, key)} is defective or nearly so (eigenvector condition "
                         f"{cond:.3g}, e.g. critical damping): the exact backend needs its nonzero eigenvalues "
                         "to have a full set of eigenvectors")
    return V, lam.astype(complex), N


def describe(system: MechanicalSystem, key: tuple) -> str:
    """A mode in words (for messages)."""
    engaged, resting, motion = key
    parts = [f"spring contact {c} engaged" for c, on in enumerate(engaged) if on]
    parts += [f"resting on stop {c}" for c, on in enumerate(resting) if on]
    parts += [f"coordinate {system.friction[i].coordinate} {('slipping -', 'stuck', 'slipping +')[s + 1]}"
              for i, s in enumerate(motion)]
    return "(" + (", ".join(parts) or "free") + ")"
