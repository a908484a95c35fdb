"""Arguments and result of :func:`impactosc.backends.rk4.rk4_batch`: the parameter sets
broadcast, checked and prepared for the parallel kernel, and the per-set statistics."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...engine._driver import initial_mode
from ...model._oscillator import Oscillator
from ._args import _check_dt, _family_args, _flange_jump


class BatchResult(NamedTuple):
    """Per-parameter-set results of :func:`rk4_batch` (arrays of the broadcast shape)."""

    mean_force_upper: np.ndarray
    mean_force_lower: np.ndarray
    contacts_upper: np.ndarray
    contacts_lower: np.ndarray
    max_penetration_upper: np.ndarray
    max_penetration_lower: np.ndarray
    status: np.ndarray


class _BatchSets(NamedTuple):
    """The parameter sets of one batch as flat float arrays, ready for the kernel."""

    shape: tuple[int, ...]  # the broadcast shape the results take
    F: np.ndarray
    Om: np.ndarray
    beta: np.ndarray
    K: np.ndarray
    phase: np.ndarray
    t_end: np.ndarray
    x0: np.ndarray
    v0: np.ndarray
    dt: np.ndarray  # NaN: the default step of the set
    zeta: np.ndarray
    exponent: np.ndarray
    extra: tuple[np.ndarray, ...]  # F_i, Omega_i, phase_i of each further harmonic, in turn


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


def _batch_sets(F, Omega, beta, K, phase, t_end, x0, v0, dt, zeta, exponent, terms: list[tuple]) -> _BatchSets:
    """Broadcast the arguments of :func:`rk4_batch` together, flattened, and check their ranges."""
    if dt is None:
        dt = np.nan
    args = (F, Omega, beta, K, phase, t_end, x0, v0, dt, zeta, exponent, *(a for term in terms for a in term))
    arrs = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    flat = [np.ascontiguousarray(a).ravel() for a in arrs]
    F, Om, beta, K, phase, t_end, x0, v0, dt, zeta, exponent = flat[:11]
    sets = _BatchSets(arrs[0].shape, F, Om, beta, K, phase, t_end, x0, v0, dt, zeta, exponent, tuple(flat[11:]))
    for name, a, lo in (("F", sets.F, 0.0), ("Omega", sets.Om, 0.0), ("beta", sets.beta, 0.0),
                        ("zeta", sets.zeta, 0.0), ("exponent", sets.exponent, 1.0)):
        if not (np.all(np.isfinite(a)) and np.all(a >= lo)):
            raise ValueError(f"{name} must be finite and >= {lo:g} in every set")
    for name, a in (("K", sets.K), ("t_end", sets.t_end)):
        if not (np.all(np.isfinite(a)) and np.all(a > 0.0)):
            raise ValueError(f"{name} must be finite and > 0 in every set")
    for name, a in (("phase", sets.phase), ("x0", sets.x0), ("v0", sets.v0)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite in every set")
    return sets


def _batch_steps(sets: _BatchSets) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(dt, n_steps, region)`` per set: the checked step, the step count and the flange
    region of the initial state (each set checked as :func:`run` checks one run)."""
    n = sets.F.shape[0]
    dt = sets.dt.copy()
    n_steps = np.empty(n, dtype=np.int64)
    region = np.empty(n, dtype=np.int64)
    extra = sets.extra
    for i in range(n):
        d = None if math.isnan(dt[i]) else float(dt[i])
        dt[i], n_steps[i] = _check_dt(d, float(sets.t_end[i]), float(sets.K[i]))
        osc = Oscillator(float(sets.F[i]), float(sets.Om[i]), float(sets.beta[i]), float(sets.K[i]),
                         float(sets.phase[i]), zeta=float(sets.zeta[i]), exponent=float(sets.exponent[i]),
                         harmonics=[(float(a[i]), float(b[i]), float(c[i]))
                                    for a, b, c in zip(extra[0::3], extra[1::3], extra[2::3], strict=True)])
        region[i] = initial_mode(osc, 0.0, float(sets.x0[i]), float(sets.v0[i])).region
    return dt, n_steps, region


def _batch_flange_jump(flange: str, sets: _BatchSets) -> np.ndarray:
    """``jlo`` per set (see :func:`_flange_jump`); ``flange="paper"`` with a power law raises."""
    if flange == "paper" and np.any(sets.exponent != 1.0):
        _flange_jump(flange, 1.0, float(sets.exponent[sets.exponent != 1.0][0]))  # raises, naming the exponent
    return 2.0 * sets.K if flange == "paper" else np.zeros(sets.F.shape[0])


def _batch_family(sets: _BatchSets, n_terms: int):
    """``(harm, damp, p)`` of the batch kernel (see :func:`_family_args`); ``harm[i]`` holds the
    rows ``F_i, Omega_i, phase_i`` of the further harmonics of set ``i``."""
    n = sets.F.shape[0]
    harm = (np.array(sets.extra, dtype=float).reshape(n_terms, 3, n).transpose(2, 1, 0) if n_terms
            else np.empty((n, 3, 0)))
    return _family_args(harm, sets.zeta, sets.exponent)
