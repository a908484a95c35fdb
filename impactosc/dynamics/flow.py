"""State-transition matrices of the smooth pieces: how a small change of ``(X, V)`` is carried along.

Over a smooth piece in mode ``(region, motion)`` the perturbation ``(dX, dV)`` obeys the
variational equation ``d' = A(t) d`` with ``A = osc.jacobian(t, x, v, region, motion)``
(the model's own Jacobian, :meth:`Oscillator.jacobian`). Its solution over the piece is the
2x2 state-transition matrix ``Phi``; matrices are row-major tuples ``(a, b, c, d)`` for
``[[a, b], [c, d]]`` (pure Python: the pieces are many and tiny).

* **Stuck** (``motion == 0``): the vector field is identically zero, ``Phi = I``.
* **Linear modes** (free, a linear spring flange ``p = 1``, a rigid flange): the piece is
  ``X'' + 2 zeta X' + w^2 X = forcing(t) + const`` with ``w^2 = 1`` (free) or ``1 + K``
  (compressed spring). ``A`` is constant, so ``Phi = exp(A tau)``, in closed form
  (:func:`linear_transition`) and independent of the forcing.
* **Power-law flange** (``p != 1``, in a flange region): ``A`` depends on ``X(t)`` through
  ``K p d^(p-1)``. ``Phi`` comes from the variational equations integrated alongside the
  piece with scipy's DOP853 (:func:`variational_transition`). Not heyoka's variational
  integrators (``heyoka.var_ode_sys``): every contact piece starts at ``d = 0`` exactly,
  where the Taylor recurrence of ``d^p`` divides by ``d`` (``d^p`` is not analytic there),
  so a heyoka piece would start on a NaN; scipy's Runge-Kutta evaluates ``d^p`` only.
"""

from __future__ import annotations

import math

import numpy as np

from ..engine._driver import Mode
from ..model._oscillator import Oscillator

__all__ = ["IDENTITY", "linear_transition", "variational_transition", "transition_matrix", "matmul"]

IDENTITY = (1.0, 0.0, 0.0, 1.0)

#: Tolerances of the variational integration of a power-law piece (relative, absolute).
VARIATIONAL_RTOL = 1e-12
VARIATIONAL_ATOL = 1e-14


def matmul(p, q):
    """The product ``p q`` of two row-major 2x2 tuples."""
    a, b, c, d = p
    e, f, g, h = q
    return (a * e + b * g, a * f + b * h, c * e + d * g, c * f + d * h)


def linear_transition(w2: float, zeta: float, tau: float):
    """``exp(A tau)`` for ``A = [[0, 1], [-w2, -2 zeta]]`` (closed form, every damping regime).

    With ``q = zeta^2 - w2``: ``Phi = e^(-zeta tau) [[C + zeta S, S], [-w2 S, C - zeta S]]``,
    where ``C, S = cos(mu tau), sin(mu tau)/mu`` with ``mu = sqrt(-q)`` (underdamped), the
    hyperbolic pair with ``kappa = sqrt(q)`` (overdamped), or ``1, tau`` (critical).
    Overdamped exponentials are combined before they are formed, so nothing overflows.
    """
    q = zeta * zeta - w2
    if q < 0.0:
        mu = math.sqrt(-q)
        decay = math.exp(-zeta * tau) if zeta else 1.0
        C = decay * math.cos(mu * tau)
        S = decay * math.sin(mu * tau) / mu
    elif q > 0.0:
        kappa = math.sqrt(q)
        up = math.exp((kappa - zeta) * tau)
        down = math.exp(-(kappa + zeta) * tau)
        C = 0.5 * (up + down)
        S = 0.5 * (up - down) / kappa
    else:
        decay = math.exp(-zeta * tau)
        C, S = decay, decay * tau
    return (C + zeta * S, S, -w2 * S, C - zeta * S)


def variational_transition(osc: Oscillator, mode: Mode, t0: float, x0: float, v0: float, t1: float):
    """``Phi`` over a piece by integrating the piece with its variational equations (scipy DOP853).

    The state ``(X, V, Phi11, Phi12, Phi21, Phi22)`` starts at ``(x0, v0, 1, 0, 0, 1)``;
    ``A(t)`` is :meth:`Oscillator.jacobian` along the integrated trajectory.
    """
    from scipy.integrate import solve_ivp

    r, s = mode.region, mode.motion
    if not t1 > t0:
        return IDENTITY
    accel = osc._accel_scalar
    jac = osc.jacobian

    def rhs(t, y):
        x, v = y[0], y[1]
        A = jac(t, x, v, r, s)
        a, b, c, d = y[2], y[3], y[4], y[5]
        return [v, accel(t, x, v, r, s),
                A[0, 0] * a + A[0, 1] * c, A[0, 0] * b + A[0, 1] * d,
                A[1, 0] * a + A[1, 1] * c, A[1, 0] * b + A[1, 1] * d]

    sol = solve_ivp(rhs, (t0, t1), [x0, v0, 1.0, 0.0, 0.0, 1.0], method="DOP853",
                    rtol=VARIATIONAL_RTOL, atol=VARIATIONAL_ATOL)
    if sol.status != 0 or not np.all(np.isfinite(sol.y[:, -1])):
        raise FloatingPointError(f"the variational equations of the piece [{t0!r}, {t1!r}] in mode "
                                 f"{tuple(mode)} could not be integrated: {sol.message}")
    return tuple(float(z) for z in sol.y[2:, -1])


def transition_matrix(osc: Oscillator, mode: Mode, t0: float, x0: float, v0: float, t1: float):
    """The state-transition matrix of the smooth piece of ``mode`` from ``(t0, x0, v0)`` to ``t1``."""
    r, s = mode.region, mode.motion
    if s == 0:
        return IDENTITY
    if r == 0 or osc.rigid or osc.exponent == 1.0:
        w2 = 1.0 + osc.K if (r != 0 and not osc.rigid) else 1.0
        return linear_transition(w2, osc.zeta, t1 - t0)
    return variational_transition(osc, mode, t0, x0, v0, t1)
