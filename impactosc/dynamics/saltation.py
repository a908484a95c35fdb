"""Saltation matrices: how a perturbation crosses an event of the hybrid flow.

At an event the flow switches from the vector field ``f-`` of one mode to ``f+`` of the
next, on the guard surface ``h(X, V, t) = 0``, possibly through a reset ``(X, V) -> g(X, V)``
(Newton's impact ``V -> -e V`` on a rigid flange). A perturbation ``d`` that arrives with the
trajectory reaches the guard ``dt = -n.d / (n.f- + h_t)`` earlier or later, and leaves as
``S d`` with the **saltation matrix** (Aizerman & Gantmacher 1958; Leine & Nijmeijer 2004;
Bernardo et al., *Piecewise-smooth Dynamical Systems*, 2008)::

    S = R + (f+ - R f-) n^T / (n.f- + h_t),

``n = (dh/dX, dh/dV)``, ``h_t = dh/dt`` (the force guards move with the forcing) and
``R = dg/d(X, V)`` the Jacobian of the reset (``diag(1, -e)`` at an impact, the identity
otherwise: the engine's snap onto the guard surface moves a state that is already on it).

Everything here comes from the model's definition: ``f`` from :meth:`Oscillator.acceleration`
(its scalar twin), ``n`` and ``h_t`` from :func:`impactosc.engine.guard_gradient`, the modes
before and after from the engine's transition rule. A new member of the model family
therefore gets its saltation matrices without new code here. The formula itself is the
one every system shares (``_jump.saltation_nd``, n-dimensional; a user system's map
calls it too); what is the built-in family's own is what it is given: the 2-D fields, the
guard gradient from the rule, the reset ``diag(1, -e)`` and the grazing bounds below.
Special cases follow from the formula, they are not coded:

* a continuous vector field across the guard (spring flange entry and exit, the internal
  acceleration-zero re-arming, a release with ``beta_static == beta``) gives ``S = I``;
* a stick (``V -> 0`` and the stuck mode's zero vector field) gives ``[[1, *], [0, 0]]``:
  the ``V`` direction collapses, a multiplier of the orbit is exactly zero;
* a reversal gives ``diag(1, a+/a-)``, the friction jump ratio of the accelerations;
* an impact gives ``[[-e, 0], [(a+ + e a-)/V, -e]]``, determinant ``e^2``.

A guard crossed tangentially (``n.f- + h_t = 0`` while ``f+ != R f-``: a grazing impact, a
release at an extremum of the forcing) has no saltation matrix: the Poincare map is not
differentiable there (its derivative is infinite, Nordmark 1991). :func:`saltation_matrix`
then says so instead of dividing by zero.

"Tangential" is a relative test, not ``== 0``. Near a tangency the guard ``h(t)`` has a
double root, so a crossing located to within the rounding ``eps_h`` of ``h`` has a crossing
rate ``h'`` known only to about ``sqrt(2 eps_h |h''|)`` (a grazing impact on a
rigid flange was located at ``V = 1.2e-16`` by one backend, ``1.6e-8`` by another and as a
touch ``V = 0`` by a third; the first reported a multiplier of -6e15 with status 0). A
crossing whose rate lies within ``GRAZING`` times that bound is a tangency:

* the rigid flange (``h = +-X - gap``, ``+-X - 1`` by default): ``eps_h`` an ulp of ``|X|``, ``h'' = +-V'`` before the
  impact, so an impact slower than about ``1.7e-7 sqrt(|V'|)`` (``4e-7`` of the velocity
  ``sqrt(|V'| L)`` at the wall for ``L = 1``) is a grazing one; a *touch* of the rigid wall
  (``V = 0`` exactly, no impact recorded) is one too, although the vector field may be
  continuous there: a slightly larger orbit hits the wall at a speed ``~ sqrt(distance)``;
* the release guards (``h = f_net -+ beta_s`` with ``X`` frozen): ``eps_h`` the tie tolerance
  of ``f_net`` (``tie_tolerance`` of the model's rule), ``h''`` the forcing's second
  derivative: a release at an extremum of the forcing;
* the slip end (``h = s V``): its rate is the acceleration ``s V'``, tangential when within
  the rounding of ``f_net``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ..engine._driver import (
    AT_WALL,
    ENTER_LOWER,
    ENTER_UPPER,
    GUARD_NAMES,
    IMPACT,
    N_GUARDS,
    RELEASE_DOWN,
    RELEASE_UP,
    SLIP_END,
    Mode,
    guard_gradient,
)
from ..model import _rule
from ..model._layout import EPS
from ..model._oscillator import Oscillator
from ._jump import saltation_nd

__all__ = ["Saltation", "saltation_matrix", "vector_field"]

#: Relative size below which ``n.f- + h_t`` counts as zero against its own terms (cancellation).
TANGENCY = 1e-12
#: Safety factor on the double-root bound ``sqrt(2 eps_h |h''|)`` of a crossing rate (module docstring):
#: 64 ulps of rounding in ``h``, i.e. a factor 8 on the bound.
GRAZING = 8.0
#: Relative size below which ``f+ - R f-`` counts as zero (a continuous vector field).
CONTINUITY = 1e-13


class Saltation(NamedTuple):
    """One event's saltation matrix and what it did."""

    t: float  #: event time
    guard: str  #: guard name (``at_wall`` for the rigid wall's rest test)
    kind: str | None  #: recorded event kind, None for internal transitions
    matrix: tuple  #: ``(a, b, c, d)`` row-major, NaN entries when ``singular``
    det: float  #: its determinant
    singular: bool  #: tangential crossing: no saltation matrix exists
    reason: str = ""  #: why no matrix exists, in words (empty when ``singular`` is False)


def vector_field(osc: Oscillator, t: float, x: float, v: float, mode) -> tuple[float, float]:
    """``(X', V')`` of ``mode`` at a scalar state (zero when stuck)."""
    r, s = mode[0], mode[1]
    if s == 0:
        return 0.0, 0.0
    return v, osc._accel_scalar(t, x, v, r, s)


def saltation_matrix(osc: Oscillator, t: float, mode_before: Mode, guard: int, mode_after: Mode,
                     x_before: float, v_before: float, x_after: float, v_after: float,
                     kind: str | None) -> Saltation:
    """The saltation matrix of one transition of :func:`impactosc.engine.transition`.

    The arguments are those the engine passes to a recorder's ``on_transition``. The rigid
    wall's rest test (``AT_WALL``) is a discrete decision at an instant, taken the same way
    by every nearby trajectory that reaches the wall at rest: ``S = I``.
    """
    if guard == AT_WALL or not 0 <= guard < N_GUARDS:
        return Saltation(t, "at_wall", kind, (1.0, 0.0, 0.0, 1.0), 1.0, False)
    name = GUARD_NAMES[guard]
    fx0, fv0 = vector_field(osc, t, x_before, v_before, mode_before)
    fx1, fv1 = vector_field(osc, t, x_after, v_after, mode_after)
    if kind == IMPACT:
        e = osc.restitution
        r11, r22 = 1.0, -e
    else:
        r11, r22 = 1.0, 1.0
    (nx, nv), ht = guard_gradient(osc, mode_before, guard, t, x_before, v_before)
    denom = nx * fx0 + nv * fv0 + ht
    graze = _grazing_rate(osc, t, mode_before, guard, x_before, fv0)
    if osc.rigid and guard in (ENTER_UPPER, ENTER_LOWER) and not abs(denom) > graze:
        # A grazing impact or a touch of a rigid wall: checked before the continuity test, which
        # a touch without friction passes (V' is continuous there) though the map is not smooth.
        return _singular(t, name, kind, f"the rigid {name} guard (the wall at X = {x_before:+.6g}) is reached at "
                         f"t={t:.12g} with speed |V| = {abs(fx0):.3g}, within the grazing bound {graze:.3g} "
                         "(a grazing impact): the map is not differentiable there")
    if (osc.rigid and guard == SLIP_END and mode_before[1] * x_before > 0.0
            and not osc.gap(mode_before[1]) - mode_before[1] * x_before > GRAZING * GRAZING * EPS):
        # A turning point on the wall it was moving towards, to rounding: the orbit grazes it
        # without an impact event, and a slightly larger one hits it at a speed ~ sqrt(distance).
        # (The apex of a rebound, moving away from the wall, is no grazing.)
        return _singular(t, name, kind, f"the motion turns at X = {x_before!r} on the rigid wall at t={t:.12g} (a "
                         "grazing contact): the map is not differentiable there")
    # jump of the vector field across the event, after the reset
    jx, jv = fx1 - r11 * fx0, fv1 - r22 * fv0
    scale_f = max(abs(fx0), abs(fv0), abs(fx1), abs(fv1), 1e-300)
    into_stick = mode_after[1] == 0 and mode_before[1] != 0
    if abs(jx) <= CONTINUITY * scale_f and abs(jv) <= CONTINUITY * scale_f:
        if into_stick:  # a stick where the vector field already vanished: V stays 0 all the same
            return Saltation(t, name, kind, (r11, 0.0, 0.0, 0.0), 0.0, False)
        return Saltation(t, name, kind, (r11, 0.0, 0.0, r22), r11 * r22, False)
    scale = abs(nx * fx0) + abs(nv * fv0) + abs(ht)
    bound = max(graze, TANGENCY * scale)
    jump = saltation_nd(((r11, 0.0), (0.0, r22)), (fx0, fv0), (fx1, fv1), (nx, nv), h_t=ht, tangential=bound)
    if jump.singular:
        return _singular(t, name, kind, f"the {name} guard is crossed tangentially at t={t:.12g} (its crossing rate "
                         f"{denom:.3g} is within the rounding bound {bound:.3g}): the map is not differentiable "
                         "there")
    (a, b), (c, d) = jump.matrix
    if into_stick:
        # Into a stuck mode V is 0 after the event for every nearby trajectory: the V row is
        # exactly zero (the formula gives 1 - a-/a- up to rounding).
        c = d = 0.0
    return Saltation(t, name, kind, (a, b, c, d), a * d - b * c, False)


def _singular(t: float, name: str, kind, reason: str) -> Saltation:
    nan = float("nan")
    return Saltation(t, name, kind, (nan, nan, nan, nan), nan, True, reason)


def _grazing_rate(osc: Oscillator, t: float, mode, guard: int, x: float, accel: float) -> float:
    """The crossing rate ``|h'|`` below which ``guard`` counts as crossed tangentially (module docstring).

    ``GRAZING * sqrt(2 eps_h |h''|)`` with ``eps_h`` the rounding of ``h`` and ``h''`` its
    second derivative along the flow before the event (``accel`` is ``V'`` there).
    """
    if guard in (ENTER_UPPER, ENTER_LOWER):
        return GRAZING * math.sqrt(2.0 * EPS * max(1.0, abs(x)) * abs(accel))
    tie = _rule.tie_tolerance(osc._p, float(t), float(x), osc._net_force_scalar(t, x))
    if guard in (RELEASE_UP, RELEASE_DOWN):
        _, d2, _ = _rule.forcing_derivatives(osc._p, float(t))
        return GRAZING * math.sqrt(2.0 * tie * abs(d2))
    if guard == SLIP_END:
        return tie
    return 0.0
