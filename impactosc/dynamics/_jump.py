"""The saltation formula, once: how a perturbation crosses one event, in any dimension.

At an event the flow leaves the vector field ``f-`` on the guard ``h(y, t; p) = 0`` and,
after the reset ``y -> g(y, t; p)``, continues with ``f+``. A perturbation ``(dy, dp)`` that
arrives with the trajectory meets the guard at the time offset

    dt = -(n . dy + h_p . dp) / (n . f- + h_t),      n = dh/dy,

and leaves as ``S dy + S_p dp`` with the saltation matrix (Aizerman & Gantmacher 1958;
Leine & Nijmeijer 2004; di Bernardo et al., *Piecewise-smooth Dynamical Systems*, 2008)::

    S   = R_y + w n^T / (n . f- + h_t),      w = f+ - R_y f- - R_t,
    S_p = R_p + w h_p^T / (n . f- + h_t),

``R_y``, ``R_t``, ``R_p`` the reset's derivatives (the identity and zeros without a reset).
Where ``n . f- + h_t`` vanishes the orbit reaches the guard tangentially (a grazing) and no
matrix exists: the result says so (``singular``) and holds NaN, never a huge number. What
counts as zero is the caller's (``tangential``): the rounding of the guard near a double
root differs between a user's symbolic guard and the built-in family's rule.

Plain Python over sequences (no NumPy): the built-in family applies it at every event of a
tangent run, where a 2x2 NumPy product would cost more than the formula.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

__all__ = ["Jump", "saltation_nd"]


class Jump(NamedTuple):
    """One event's saltation: ``S``, ``S_p`` and the event time's derivatives (NaN when ``singular``)."""

    matrix: tuple  #: ``S`` as a tuple of rows (d x d)
    params: tuple  #: ``S_p`` as a tuple of rows (d x k)
    time_state: tuple  #: ``d(event time) / dy`` before the event (length d)
    time_params: tuple  #: ``d(event time) / dp`` (length k)
    speed: float  #: ``n . f- + h_t``, the guard's crossing rate
    singular: bool  #: the guard is reached tangentially: no saltation matrix exists


def saltation_nd(reset_jacobian: Sequence[Sequence[float]], f_minus: Sequence[float], f_plus: Sequence[float],
                 normal: Sequence[float], *, h_t: float = 0.0, reset_rate: Sequence[float] | None = None,
                 guard_params: Sequence[float] = (), reset_params: Sequence[Sequence[float]] | None = None,
                 tangential: float = 0.0) -> Jump:
    """The saltation matrix of one event (module docstring), with its parameter columns.

    Parameters
    ----------
    reset_jacobian : d x d rows
        ``R_y = dg/dy`` of the reset (the identity for a guard without one).
    f_minus, f_plus : length d
        The vector fields before the event (at the state before the reset) and after it.
    normal : length d
        ``n = dh/dy``, the guard's gradient at the state before the event.
    h_t : float
        ``dh/dt`` (a guard that moves with the forcing).
    reset_rate : length d, optional
        ``R_t = dg/dt`` (default zeros).
    guard_params : length k
        ``h_p = dh/dp`` for the ``k`` parameter columns (default: none).
    reset_params : d x k rows, optional
        ``R_p = dg/dp`` (default zeros).
    tangential : float
        A crossing rate ``|n . f- + h_t|`` at or below this is a tangency: ``singular``.

    Returns
    -------
    Jump
    """
    d, k = len(f_minus), len(guard_params)
    speed = sum(normal[j] * f_minus[j] for j in range(d)) + h_t
    if not abs(speed) > tangential:
        nan = math.nan
        return Jump(tuple((nan,) * d for _ in range(d)), tuple((nan,) * k for _ in range(d)), (nan,) * d,
                    (nan,) * k, speed, True)
    rate = reset_rate if reset_rate is not None else (0.0,) * d
    jump = [f_plus[i] - sum(reset_jacobian[i][j] * f_minus[j] for j in range(d)) - rate[i] for i in range(d)]
    matrix = tuple(tuple(reset_jacobian[i][j] + jump[i] * normal[j] / speed for j in range(d)) for i in range(d))
    base = reset_params if reset_params is not None else tuple((0.0,) * k for _ in range(d))
    params = tuple(tuple(base[i][c] + jump[i] * guard_params[c] / speed for c in range(k)) for i in range(d))
    return Jump(matrix, params, tuple(-normal[j] / speed for j in range(d)),
                tuple(-guard_params[c] / speed for c in range(k)), speed, False)

