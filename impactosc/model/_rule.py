"""The transition rule, written once in compilable Python (the one copy every backend, compiled or not, calls).

:mod:`impactosc.engine` documents the modes, guards and events; this module holds their
numbers: the model's scalar forces, the Filippov stick test, the gates, the transition
of every guard, the guards left pending at a piece start and the integrity check. Every
function takes the member as a parameter vector (:func:`params`) and plain scalars, so
numba compiles it (:mod:`impactosc._jit`). The Python driver (:func:`impactosc.engine.drive`,
used by the heyoka, scipy and exact backends) and the exact backend's compiled event loop
(:mod:`impactosc.backends._exact_loop`) call these very functions: the switching physics
exists in one copy, compiled once.

A mode is passed as three ints ``(region, motion, armed)``; an event kind as its index in
:data:`EVENT_KINDS` (:data:`NO_KIND` for an internal guard).
"""

from __future__ import annotations

import math

from .._util.jit import njit

# The indices, codes and parameter vector the rule shares with the engine and the backends
# (plain Python, so that a model can be built without importing numba).
from ._layout import (  # noqa: F401  (re-exported: the rule is where callers look for them)
    ACCEL_ZERO,
    AT_WALL,
    CHATTER,
    CONTACT_END,
    CONTACT_START,
    ENTER_LOWER,
    ENTER_UPPER,
    EPS,
    EVENT_KINDS,
    GUARD_DIRECTIONS,
    IMPACT,
    INTEGRITY_ULPS,
    KINEMATIC_GUARD_OFFSET,
    LEAVE,
    N_GUARDS,
    NO_GUARD,
    NO_KIND,
    P_AMPLITUDE,
    P_BETA,
    P_BETA_S,
    P_EXPONENT,
    P_K,
    P_LOWER,
    P_RESTITUTION,
    P_RIGID,
    P_TERMS,
    P_UPPER,
    P_ZETA,
    RELEASE,
    RELEASE_DOWN,
    RELEASE_UP,
    REVERSAL,
    SLIP_END,
    STICK,
    params,
)


# -- the model's scalar forces (eq. 3 and its family) ------------------------------------
@njit
def forcing(p, t):
    """``sum_i F_i cos(Omega_i t + phase_i)``."""
    f = 0.0
    for i in range(P_TERMS, p.shape[0], 3):
        f += p[i] * math.cos(p[i + 1] * t + p[i + 2])
    return f


@njit
def forcing_derivatives(p, t):
    """``(f', f'', noise)`` of the forcing at ``t``; ``noise`` bounds the rounding of ``f'``."""
    d1 = d2 = noise = 0.0
    for i in range(P_TERMS, p.shape[0], 3):
        F, Om = p[i], p[i + 1]
        th = Om * t + p[i + 2]
        d1 -= F * Om * math.sin(th)
        d2 -= F * Om * Om * math.cos(th)
        noise += 8.0 * EPS * F * Om * (1.0 + abs(th))
    return d1, d2, noise


@njit
def gap(p, side):
    """Distance from the rest position to the flange of ``side`` (+1 upper, -1 lower); inf if absent."""
    return p[P_UPPER] if side > 0 else p[P_LOWER]


@njit
def wall(p, side):
    """Position ``side * gap`` of the flange of ``side``: where a crossing of it is snapped to."""
    return side * gap(p, side)


@njit
def beyond(p, x):
    """The side (+1, -1) of the flange that ``x`` lies on or beyond, or 0 strictly between them."""
    if x >= p[P_UPPER]:
        return 1
    if -x >= p[P_LOWER]:
        return -1
    return 0


@njit
def spring(p, x):
    """Restoring force ``X + sgn(X) K d^p``, ``d = |X| - gap`` on the side of ``X`` (no term for a rigid stop)."""
    pen = (x - p[P_UPPER]) if x > 0.0 else (-x - p[P_LOWER])
    if pen > 0.0 and p[P_RIGID] == 0.0:
        e = p[P_EXPONENT]
        f = p[P_K] * (pen if e == 1.0 else pen**e)
        return x + math.copysign(f, x)
    return x


@njit
def region_force(p, x, region):
    """Flange force ``K d^p`` of the spring of ``region``, not clipped at ``d = 0`` (see the model)."""
    if region == 0 or p[P_RIGID] != 0.0:
        return 0.0
    d = region * x - gap(p, region)
    e = p[P_EXPONENT]
    if e == 1.0:
        return p[P_K] * d
    return p[P_K] * d**e if d > 0.0 else 0.0


@njit
def net_force(p, t, x):
    """``f_net = forcing - X - sgn(X) K d^p``: the force the stick test weighs against ``beta_s``."""
    return forcing(p, t) - spring(p, x)


@njit
def accel(p, t, x, v, region, motion):
    """``V'`` of a slipping mode ``(region, motion)`` (zero when stuck)."""
    if motion == 0:
        return 0.0
    return (forcing(p, t) - x - region * region_force(p, x, region)
            - 2.0 * p[P_ZETA] * v - p[P_BETA] * motion)


@njit
def tie_tolerance(p, t, x, f):
    """Rounding level of ``f_net`` at ``(t, x)``: a few ulps of every term that forms it.

    Each forcing term is rounded like ``F_i`` times the error of its phase, an ulp of
    ``|Omega_i t| + |phase_i|``; the spring terms and ``f_net`` to an ulp. The
    floor keeps a force guard from being the zero polynomial when ``f_net`` vanishes
    identically (that guard "crossed" everywhere).
    """
    forced = 0.0
    for i in range(P_TERMS, p.shape[0], 3):
        forced += p[i] * (1.0 + abs(p[i + 1] * t) + abs(p[i + 2]))
    return max(4.0 * EPS * max(forced, abs(spring(p, x)), abs(f)), KINEMATIC_GUARD_OFFSET)


# -- the stick test and the gates --------------------------------------------------------
@njit
def motion_at_rest(p, t, x):
    """Filippov stick test at rest: ``(motion, armed)`` (see :func:`impactosc.engine.motion_at_rest`)."""
    f = net_force(p, t, x)
    b = p[P_BETA_S]
    af = abs(f)
    tie = tie_tolerance(p, t, x, f)
    if af < b - tie:
        return 0, 1
    if af > b + tie:
        return (1 if f > 0.0 else -1), 1
    # On the threshold: X is frozen, so f_net changes with the forcing only; its first
    # derivative decides, the second where the first is rounding noise.
    d1, d2, noise = forcing_derivatives(p, t)
    trend = d1 if abs(d1) > noise else d2
    if af > tie:
        if f * trend > 0.0:
            return (1 if f > 0.0 else -1), 0
        return 0, 1
    if trend != 0.0:  # beta == 0 and f_net == 0: the mass moves the way f_net starts to point
        return (1 if trend > 0.0 else -1), 0
    return 0, 1


@njit
def gate(rigid, region, motion, armed, guard):
    """True when ``guard`` is armed in the mode ``(region, motion, armed)``."""
    moving = motion != 0
    if rigid and region != 0:
        # Resting against the wall: only a pull away beyond static friction ends the rest.
        if guard == RELEASE_UP:
            return not moving and region < 0
        if guard == RELEASE_DOWN:
            return not moving and region > 0
        return False
    # A slipping piece is monotonic in X (every turning point ends it): only the flange ahead
    # can be reached. The one behind is not armed: leaving a wall or a flange surface from
    # rest, its guard has a multiple root at the start (V = V' = 0 at a release), on which an
    # event finder's root search fails (heyoka warned "too many iterations" on stderr).
    if guard == ENTER_UPPER:
        return motion > 0 and region == 0
    if guard == ENTER_LOWER:
        return motion < 0 and region == 0
    if guard == LEAVE:
        return moving and region != 0 and motion == -region
    if guard == SLIP_END:
        return moving and armed != 0
    if guard == ACCEL_ZERO:
        return moving and armed == 0
    return not moving


@njit
def initial_mode(p, t, x, v):
    """Mode ``(region, motion, armed)`` at the initial time (see :func:`impactosc.engine.initial_mode`)."""
    if v > 0.0:
        motion, armed = 1, 1
    elif v < 0.0:
        motion, armed = -1, 1
    else:
        motion, armed = motion_at_rest(p, t, x)
    if p[P_RIGID] != 0.0:
        region = 0
        side = beyond(p, x)
        if v == 0.0 and side != 0 and motion != -side:
            # At rest on the wall and not pulled away beyond beta_s: resting on it is the
            # initial mode, not an event (like a start inside a spring flange, or stuck).
            return side, 0, 1
    elif x > p[P_UPPER] or (x == p[P_UPPER] and motion > 0):
        region = 1
    elif -x > p[P_LOWER] or (-x == p[P_LOWER] and motion < 0):
        region = -1
    else:
        region = 0
    return region, motion, armed


# -- the transition rule -----------------------------------------------------------------
@njit
def _slip_end(p, r, s, t, x):
    s_new, armed_new = motion_at_rest(p, t, x)
    if s_new == 0:
        return r, 0, 1, x, 0.0, STICK, 0
    if s_new == s:
        # Degenerate tangency (V and V' vanish together): the mass pauses and goes on.
        return r, s, 0, x, 0.0, NO_KIND, 0
    return r, s_new, armed_new, x, 0.0, REVERSAL, 0


@njit
def _impact(p, t, side, v):
    """Newton's impact law ``V -> -e V`` on the rigid flange ``side`` (see the engine)."""
    at = wall(p, side)
    if side * v <= 0.0:
        # A touch at a turning point: the stick test at the wall decides, no impact.
        s_new, armed = motion_at_rest(p, t, at)
        if s_new == -side:
            return 0, s_new, armed, at, 0.0, REVERSAL, 0
        return side, 0, 1, at, 0.0, CONTACT_START, side
    v_out = -p[P_RESTITUTION] * v
    if side * v_out < -KINEMATIC_GUARD_OFFSET:
        return 0, -side, 1, at, v_out, IMPACT, side
    return 0, 0, 1, at, 0.0, IMPACT, side


@njit
def _rest_at_wall(p, t, x):
    """A mass at rest exactly against a rigid flange: rest on it, or slide away at once."""
    side = 1 if x > 0.0 else -1
    s_new, armed = motion_at_rest(p, t, x)
    if s_new == -side:
        return 0, s_new, armed, x, 0.0, NO_KIND, side
    return side, 0, 1, x, 0.0, CONTACT_START, side


@njit
def transition(p, r, s, armed, guard, t, x, v):
    """What ``guard`` firing at ``(t, x, v)`` in mode ``(r, s, armed)`` means.

    Returns ``(region, motion, armed, x, v, kind, side)`` (see :func:`impactosc.engine.transition`):
    the state snapped onto the guard surface, the event kind code and its flange side.
    ``guard`` must be a guard index or :data:`AT_WALL`.
    """
    if guard == SLIP_END:
        return _slip_end(p, r, s, t, x)
    if guard == ENTER_UPPER or guard == ENTER_LOWER:
        side = 1 if guard == ENTER_UPPER else -1
        if p[P_RIGID] != 0.0:
            return _impact(p, t, side, v)
        # A velocity against the motion is a turning point passed by rounding.
        return side, s, armed, wall(p, side), (v if s * v > 0.0 else 0.0), CONTACT_START, side
    if guard == LEAVE:
        return 0, s, armed, wall(p, r), (v if s * v > 0.0 else 0.0), CONTACT_END, r
    if guard == ACCEL_ZERO:
        if s * v <= 0.0:
            # The guard fires a rounding-level offset late: if the velocity is already back
            # at zero, the slip ended here.
            return _slip_end(p, r, s, t, x)
        return r, s, 1, x, v, NO_KIND, 0
    if guard == RELEASE_UP or guard == RELEASE_DOWN:
        s_new = 1 if guard == RELEASE_UP else -1
        if p[P_RIGID] != 0.0 and r != 0:
            # Pulled off the rigid wall: the resting contact ends, the mass slides away.
            return 0, s_new, 0, wall(p, r), 0.0, CONTACT_END, r
        return r, s_new, 0, x, 0.0, RELEASE, 0
    return _rest_at_wall(p, t, x)  # AT_WALL


@njit
def pending_guard(p, r, s, fired, t, x, v):
    """A guard that already holds at a piece start (see :func:`impactosc.engine.pending_guard`)."""
    if s == 0:
        if p[P_RIGID] != 0.0 and r == 0 and beyond(p, x) != 0:
            return AT_WALL
        return NO_GUARD
    if s * v < 0.0:
        return SLIP_END
    if v == 0.0 and (fired == ENTER_UPPER or fired == ENTER_LOWER or fired == LEAVE):
        if motion_at_rest(p, t, x)[0] != s:
            return SLIP_END
    if r == 0:
        if s > 0 and x >= p[P_UPPER]:
            return ENTER_UPPER
        if s < 0 and -x >= p[P_LOWER]:
            return ENTER_LOWER
    elif s == -r and r * x <= gap(p, r):
        return LEAVE
    return NO_GUARD


@njit
def missed_guard(p, r, s, guard, t0, x0, v0, t1, x1, v1):
    """Index of a guard crossed unseen in a piece, or :data:`NO_GUARD` (see :func:`impactosc.engine.missed_guard`)."""
    if s == 0:
        if guard == NO_GUARD:
            f = net_force(p, t1, x1)
            if p[P_RIGID] != 0.0 and r != 0:
                f = min(r * f, 0.0) * r  # the wall takes any push into it
            if abs(f) > p[P_BETA_S] + 2.0 * INTEGRITY_ULPS * tie_tolerance(p, t1, x1, f):
                return RELEASE_UP if f > 0 else RELEASE_DOWN
        return NO_GUARD
    if s * v0 < 0.0:
        return SLIP_END
    # The region test against the flanges with an allowance of ulps of X (the cheap test first).
    if r == 0:
        top = x0 if (guard == ENTER_UPPER or guard == ENTER_LOWER) else max(x0, x1)
        low = -x0 if (guard == ENTER_UPPER or guard == ENTER_LOWER) else max(-x0, -x1)
        tol = INTEGRITY_ULPS * EPS * max(abs(x0), abs(x1))
        if top > p[P_UPPER] and top - p[P_UPPER] > tol:
            return ENTER_UPPER
        if low > p[P_LOWER] and low - p[P_LOWER] > tol:
            return ENTER_LOWER
    else:
        g = gap(p, r)
        near = r * x0 if guard == LEAVE else min(r * x0, r * x1)
        if near < g and g - near > INTEGRITY_ULPS * EPS * max(g, abs(x0), abs(x1)):
            return LEAVE
    if guard != SLIP_END and s * v1 < 0.0:
        # V is rounded like the largest velocity the piece can reach from its start.
        force = max(abs(spring(p, x0)), abs(spring(p, x1)))
        a_max = p[P_AMPLITUDE] + p[P_BETA] + 1.0 + force + 2.0 * p[P_ZETA] * max(abs(v0), abs(v1))
        tol_v = INTEGRITY_ULPS * EPS * (abs(v0) + a_max * (t1 - t0 + abs(t1) * EPS))
        if s * v1 < -tol_v:
            return SLIP_END
    return NO_GUARD
