"""Chatter on a rigid flange: impacts that accumulate in finite time, resolved by a jump.

With restitution ``e < 1`` and a net force ``p`` pushing the mass into a rigid flange, every
rebound is lower than the last and the impacts accumulate at a finite time ``t_inf`` (a Zeno
point; Budd & Dux 1994, Nordmark 1991). An event loop that followed them one by one would
never reach ``t_inf``. The engine follows them until a local model predicts the rest of the
sequence to a stated accuracy, then jumps to ``t_inf`` and lets the mass rest on the flange.

Local model
-----------
Near the wall, over a flight of duration ``T``, the force on the mass is the push ``p`` (into
the wall: ``p = side * f_net(t, side)``) plus kinetic friction ``beta`` opposing the motion.
Moving away from the wall the mass decelerates at ``a_out = p + beta``, moving back it
accelerates at ``a_in = p - beta`` (chatter needs ``p > beta``; with ``p <= beta_s`` it would
stick at the apex, which the engine already handles). After an impact at speed ``u`` the
mass leaves at ``e u``, returns at ``rho u`` and spends ``c u`` in flight, with::

    rho = e sqrt(a_in / a_out),     c = e (1 / a_out + 1 / sqrt(a_out a_in)).

The remaining impacts form a geometric series: they accumulate after ``c u / (1 - rho)``,
their impulses add to ``(1 + e) u rho / (1 - rho)``, the slip path to
``e^2 u^2 / (a_out (1 - rho^2))`` and the impact losses to ``(1 - e^2) u^2 rho^2 / (2 (1 - rho^2))``
(these three keep the energy identity balanced over the jump).

Error of the model
------------------
The model freezes ``p`` and neglects damping. Over the remaining time ``T_rem`` the push
changes by about ``|p'| T_rem`` (forcing rate), by the displacement ``h = (e u)^2 / (2 a_out)``
(the tape spring's slope is 1) and the damping force is at most ``2 zeta e u``. Relative to
``a_in`` these give a relative error ``delta`` of the flight times, so ``t_inf`` is in error by
about ``delta T_rem``. The jump is taken when that estimate is below :data:`TIME_TOLERANCE`
(relative to ``max(1, |t|)``), after at least :data:`MIN_IMPACTS` impacts on the same flange
whose speed ratio agrees with ``rho`` (the model describes what is happening). Since
``T_rem`` and ``delta`` both shrink like ``u``, the error shrinks like ``u^2`` per impact: with
``e = 0.8`` the jump comes after a few dozen impacts.
"""

from __future__ import annotations

import math
from typing import NamedTuple

#: Relative accuracy (of ``max(1, |t|)``) of the accumulation time at which a jump is taken.
TIME_TOLERANCE = 1e-12
#: Impacts on the same flange needed before the local model is trusted.
MIN_IMPACTS = 3
#: How far the observed speed ratio may stray from the model's ``rho`` (relative).
RATIO_AGREEMENT = 0.05


class ChatterJump(NamedTuple):
    """The resolved remainder of a chatter sequence (see the module docstring)."""

    t_inf: float  #: accumulation time
    side: int  #: the flange, +1 or -1
    impacts: int  #: impacts followed one by one before the jump
    impulse: float  #: impulse of the infinitely many remaining impacts
    path: float  #: slip path of the remaining flights
    loss: float  #: energy lost in the remaining impacts
    error: float  #: estimated error of ``t_inf``


class ChatterTracker:
    """Watches the impacts of a run and predicts their accumulation point.

    The engine calls :meth:`impact` after every impact and :meth:`interrupt` after every
    other recorded event except a reversal (an out-and-back flight has one reversal).
    """

    __slots__ = ("osc", "side", "count", "last_speed", "last_ratio")

    def __init__(self, osc):
        self.osc = osc
        self.interrupt()

    def interrupt(self) -> None:
        """An event that breaks a chatter sequence (a stick, a release, a resting contact)."""
        self.side = 0
        self.count = 0
        self.last_speed = math.nan
        self.last_ratio = math.nan

    def impact(self, t: float, side: int, speed: float) -> ChatterJump | None:
        """Record an impact of ``speed`` (> 0) on ``side`` at ``t``; return a jump or ``None``."""
        osc = self.osc
        if side != self.side:
            self.side, self.count, self.last_speed, self.last_ratio = side, 0, math.nan, math.nan
        ratio = speed / self.last_speed if self.count else math.nan
        self.count += 1
        self.last_speed, self.last_ratio = speed, ratio
        e = osc.restitution
        if e >= 1.0 or self.count < MIN_IMPACTS:
            return None
        p = side * osc._net_force_scalar(t, float(side))
        a_out, a_in = p + osc.beta, p - osc.beta
        if not (a_in > 0.0 and speed > 0.0):
            return None
        rho = e * math.sqrt(a_in / a_out)
        if not abs(ratio - rho) <= RATIO_AGREEMENT * rho:
            return None
        flight = e * speed * (1.0 / a_out + 1.0 / math.sqrt(a_out * a_in))
        t_rem = flight / (1.0 - rho)
        push_rate = abs(osc._forcing_derivatives(t)[0])
        height = (e * speed) ** 2 / (2.0 * a_out)
        delta = (push_rate * t_rem + height + 2.0 * osc.zeta * e * speed) / a_in
        error = delta * t_rem
        if error > TIME_TOLERANCE * max(1.0, abs(t)):
            return None
        u2 = speed * speed
        return ChatterJump(
            t_inf=t + t_rem,
            side=side,
            impacts=self.count,
            impulse=(1.0 + e) * speed * rho / (1.0 - rho),
            path=e * e * u2 / (a_out * (1.0 - rho * rho)),
            loss=(1.0 - e * e) * u2 * rho * rho / (2.0 * (1.0 - rho * rho)),
            error=error,
        )
