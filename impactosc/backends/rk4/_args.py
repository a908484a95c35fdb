"""Arguments of the rk4 backend: the step, the flange law, the family terms and what the
fixed-step scheme refuses (see :mod:`impactosc.backends.rk4`)."""

from __future__ import annotations

import math

import numpy as np

from ..._util import validation as _v
from ...model._oscillator import Oscillator

# The public constants, re-exported and documented (with the reasons for their values) by rk4.py.
FLANGE_OPTIONS = ("consistent", "paper")
STEPS_PER_CONTACT_PERIOD = 100
MAX_STEPS = 2_000_000_000


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
