"""Chatter on a rigid flange: impacts that accumulate in finite time, resolved by a jump.

With a net force ``p`` pushing the mass into a rigid flange, restitution ``e < 1`` or kinetic
friction ``beta > 0`` (or both) make every rebound lower than the last, and the impacts
accumulate at a finite time ``t_inf`` (a Zeno point; Budd & Dux 1994, Nordmark 1991). An
event loop that followed them one by one would never reach ``t_inf``. The engine follows them
until a local model predicts the rest of the sequence to a stated accuracy, then jumps to
``t_inf`` and lets the mass rest on the flange.

Local model
-----------
Near the wall, over a flight of duration ``T``, the force on the mass is the push ``p`` (into
the wall: ``p = side * f_net(t, side)``) plus kinetic friction ``beta`` opposing the motion.
Moving away from the wall the mass decelerates at ``a_out = p + beta``, moving back it
accelerates at ``a_in = p - beta``. The mass returns only if it slips at the apex, so the
model needs ``p > beta_s`` (with ``p <= beta_s`` it sticks at the first apex, which the engine
handles as a stick). After an impact at speed ``u`` the mass leaves at ``e u``, returns at
``rho u`` and spends ``c u`` in flight, with::

    rho = e sqrt(a_in / a_out),     c = e (1 / a_out + 1 / sqrt(a_out a_in)).

``rho < 1`` unless ``e = 1`` and ``beta = 0`` (then nothing is lost and the impacts do not
accumulate). The remaining impacts form a geometric series: they accumulate after
``c u / (1 - rho)``, their impulses add to ``(1 + e) u rho / (1 - rho)``, the slip path to
``e^2 u^2 / (a_out (1 - rho^2))`` and the impact losses to
``(1 - e^2) u^2 rho^2 / (2 (1 - rho^2))`` (these three keep the energy identity balanced over
the jump). :meth:`ChatterJump.state_at` gives the state and the partial sums at any time of
the tail, for a run or a sample time that ends inside it.

Error of the model
------------------
The model freezes ``p`` and neglects damping. Over the remaining time ``T_rem`` the push
changes by the drift ``|f'| T_rem + |f''| T_rem^2 / 2`` of the forcing (the second term
matters at an extremum of the forcing, where ``f' = 0``), by the displacement
``h = (e u)^2 / (2 a_out)`` (the tape spring's slope is 1) and the damping force is at most
``2 zeta e u``. Relative to ``a_in`` these give a relative error ``delta`` of the flight times,
so ``t_inf`` is in error by about ``delta T_rem``. The jump is taken as soon as that estimate
is below :data:`TIME_TOLERANCE` (relative to ``max(1, |t|)``) and the push stays above
``beta_s`` over the whole tail. The decision uses the state at the impact only, never the
history of the sequence: the flights that follow an impact of speed ``u`` are at most
``(e u)^2 / (2 a_out)`` high, and once that is at the rounding level of ``X`` no integrator can
measure the next impact speed (with ``e = 1e-4`` the third impact of a chatter is already
rounding noise). Since ``T_rem`` and ``delta`` both shrink like ``u``, the error shrinks like
``u^2`` per impact: with ``e = 0.8`` the jump comes after a few dozen impacts.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._util.jit import njit
from ..model._rule import P_BETA, P_BETA_S, P_RESTITUTION, P_ZETA, forcing_derivatives, net_force, wall

#: Relative accuracy (of ``max(1, |t|)``) of the accumulation time at which a jump is taken.
TIME_TOLERANCE = 1e-12

# The fields of a jump as the compiled event loop keeps it (a row of floats), in the order
# of ChatterJump.
(J_T_INF, J_SIDE, J_IMPACTS, J_IMPULSE, J_PATH, J_LOSS, J_ERROR, J_T0, J_SPEED, J_E, J_A_OUT, J_A_IN,
 J_WALL) = range(13)
J_SIZE = 13


@njit
def predict_jump(p, t, side, speed, count, out):
    """The jump after an impact of ``speed`` on ``side`` at ``t``, written into ``out``; True if taken.

    ``count`` is the number of impacts of the sequence so far, this one included. See the
    module docstring for the model and the criterion.
    """
    e, beta, beta_s = p[P_RESTITUTION], p[P_BETA], p[P_BETA_S]
    at = wall(p, side)
    push = side * net_force(p, t, at)
    a_out, a_in = push + beta, push - beta
    if not (a_in > 0.0 and push > beta_s and speed > 0.0 and e > 0.0):
        return False  # no return to the wall (or no rebound: e = 0 rests at once)
    rho = e * math.sqrt(a_in / a_out)
    if not rho < 1.0:
        return False  # e = 1 without friction: nothing is lost, the impacts do not accumulate
    flight = e * speed * (1.0 / a_out + 1.0 / math.sqrt(a_out * a_in))
    t_rem = flight / (1.0 - rho)
    d1, d2, _ = forcing_derivatives(p, t)
    drift = abs(d1) * t_rem + 0.5 * abs(d2) * t_rem * t_rem
    height = (e * speed) ** 2 / (2.0 * a_out)
    if not push - drift - height > beta_s:
        return False  # the push may fall to the static level: the mass could stick at an apex
    delta = (drift + height + 2.0 * p[P_ZETA] * e * speed) / a_in
    error = delta * t_rem
    if error > TIME_TOLERANCE * max(1.0, abs(t)):
        return False
    u2 = speed * speed
    out[J_T_INF], out[J_SIDE], out[J_IMPACTS] = t + t_rem, float(side), float(count)
    out[J_IMPULSE] = (1.0 + e) * speed * rho / (1.0 - rho)
    out[J_PATH] = e * e * u2 / (a_out * (1.0 - rho * rho))
    out[J_LOSS] = (1.0 - e * e) * u2 * rho * rho / (2.0 * (1.0 - rho * rho))
    out[J_ERROR], out[J_T0], out[J_SPEED], out[J_E], out[J_A_OUT], out[J_A_IN] = error, t, speed, e, a_out, a_in
    out[J_WALL] = at
    return True


@njit
def jump_state(jump, t):
    """:meth:`ChatterJump.state_at` of the jump ``jump`` (a row of floats): ``(x, v, motion, impulse, path, loss)``."""
    side, e, a_out, a_in = int(jump[J_SIDE]), jump[J_E], jump[J_A_OUT], jump[J_A_IN]
    at = jump[J_WALL]
    if t >= jump[J_T_INF]:
        return at, 0.0, 0, jump[J_IMPULSE], jump[J_PATH], jump[J_LOSS]
    rho = e * math.sqrt(a_in / a_out)
    c = e * (1.0 / a_out + 1.0 / math.sqrt(a_out * a_in))
    u, t0 = jump[J_SPEED], jump[J_T0]
    # The k-th flight starts at t0 + c u (1 - rho^k) / (1 - rho): invert for k.
    span = (t - t0) * (1.0 - rho) / (c * u)
    k = 0
    if span > 0.0 and rho > 0.0:
        k = int(math.log1p(-min(span, 1.0 - 1e-16)) / math.log(rho))
    start = t0 + c * u * (1.0 - rho**k) / (1.0 - rho)
    if start > t and k > 0:  # rounding of the logarithm
        k -= 1
        start = t0 + c * u * (1.0 - rho**k) / (1.0 - rho)
    uk = u * rho**k  # impact speed that started flight k
    w = e * uk  # its rebound speed
    height = w * w / (2.0 * a_out)
    tau = max(t - start, 0.0)
    t_up = w / a_out
    if tau <= t_up:
        dist, away = w * tau - 0.5 * a_out * tau * tau, w - a_out * tau
        travelled = dist
    else:
        fall = min(tau - t_up, math.sqrt(2.0 * height / a_in))
        dist, away = height - 0.5 * a_in * fall * fall, -a_in * fall
        travelled = 2.0 * height - dist
    dist = max(dist, 0.0)
    r2 = rho * rho
    geo1 = (1.0 - rho**k) / (1.0 - rho)  # 1 + rho + ... + rho^(k-1)
    geo2 = (1.0 - r2**k) / (1.0 - r2)
    impulse = (1.0 + e) * u * rho * geo1
    loss = 0.5 * (1.0 - e * e) * u * u * r2 * geo2
    path = e * e * u * u / a_out * geo2 + travelled
    motion = -side if away > 0.0 else side
    return at - side * dist, -side * away, motion, impulse, path, loss


class ChatterJump(NamedTuple):
    """The resolved remainder of a chatter sequence (see the module docstring)."""

    t_inf: float  #: accumulation time
    side: int  #: the flange, +1 or -1
    impacts: int  #: impacts followed one by one before the jump
    impulse: float  #: impulse of the infinitely many remaining impacts
    path: float  #: slip path of the remaining flights
    loss: float  #: energy lost in the remaining impacts
    error: float  #: estimated error of ``t_inf``
    t0: float  #: time of the last impact followed one by one
    speed: float  #: its impact speed ``u``
    restitution: float  #: ``e``
    a_out: float  #: deceleration moving away from the wall, ``p + beta``
    a_in: float  #: acceleration back towards it, ``p - beta``
    wall: float  #: position of the wall, ``side * gap`` (``side`` for the paper's flanges)

    @classmethod
    def from_row(cls, row) -> ChatterJump:
        """The jump of a row of :func:`predict_jump` (the compiled loop's record)."""
        return cls(float(row[J_T_INF]), int(row[J_SIDE]), int(row[J_IMPACTS]), *(float(v) for v in row[J_IMPULSE:]))

    def state_at(self, t: float):
        """The local model's state at ``t`` in ``[t0, t_inf]``, and the tail's totals up to ``t``.

        Returns ``(x, v, motion, impulse, path, loss)``: position, velocity and direction of
        motion (``-side`` moving away from the wall, ``side`` moving back), and the impulse,
        slip path and impact loss of the impacts and flights of the tail before ``t``. At
        ``t >= t_inf`` these are the jump's totals and the mass is at rest on the wall.
        """
        return jump_state(np.array(self, dtype=float), float(t))


class ChatterTracker:
    """Watches the impacts of a run and predicts their accumulation point.

    The engine calls :meth:`impact` after every impact and :meth:`interrupt` after every
    other recorded event except a reversal (an out-and-back flight has one reversal).
    """

    __slots__ = ("osc", "side", "count")

    def __init__(self, osc):
        self.osc = osc
        self.interrupt()

    def interrupt(self) -> None:
        """An event that breaks a chatter sequence (a stick, a release, a resting contact)."""
        self.side = 0
        self.count = 0

    def impact(self, t: float, side: int, speed: float) -> ChatterJump | None:
        """Record an impact of ``speed`` (> 0) on ``side`` at ``t``; return a jump or ``None``."""
        if side != self.side:
            self.side, self.count = side, 0
        self.count += 1
        row = np.empty(J_SIZE)
        if not predict_jump(self.osc._p, float(t), int(side), float(speed), self.count, row):
            return None
        return ChatterJump.from_row(row)
