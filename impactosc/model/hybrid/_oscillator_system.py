"""The paper's oscillator family written as a user hybrid system (eq. 3 with spring or rigid flanges)."""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache

from .._oscillator import Oscillator
from ._definition import EngineRule, Guard, HybridMode, HybridSystem
from ._friction import stick_slip

__all__ = ["oscillator_system", "WallChatter", "StickTest", "layer_thickness"]

#: A flange mode may be entered a few rounding errors outside its surface: a stop located inside a
#: spring flange at the turning point of a grazing contact can round to ``X = gap (1 - eps)``, where
#: no candidate mode of the stop would otherwise be admissible (the run failed). The guard that
#: leaves the flange then fires at once from there (the state lies on it, moving out).
_SURFACE_ROUNDING = 4.0 * 2.0**-52
#: How far beyond a rigid flange an impact may be located (scipy's event location put one 16 eps beyond
#: it): the rebound into the free modes is admissible there, and so is the rest on the wall.
_IMPACT_ROUNDING = 64.0 * 2.0**-52
#: A speed away from a rigid wall below this is none (the engine's kinematic guard offset).
_NO_SPEED = 1e-300
#: The spring force at the edge of a power-law flange's boundary layer: the unit roundoff (see layer_thickness).
_LAYER_FORCE = 2.0**-53
#: The layer's least thickness: a few ulps of the flange's position ``|X| ~ 1`` (see layer_thickness).
_LAYER_FLOOR = 4.0 * 2.0**-52


def layer_thickness(osc: Oscillator) -> float:
    """The thickness ``delta`` of a power-law flange's boundary layer: ``max((u / K)^(1/p), 4 eps)``.

    ``d^p`` (``p > 1``; a Taylor integrator computes it as ``exp(p log d)``) is not analytic at
    ``d = 0``, where each contact starts: its Taylor coefficients divide by ``d``, so a step that
    starts at ``d = 0`` has non-finite coefficients, and near ``d = 0`` the steps shrink
    geometrically. The spring is therefore off in the layer ``0 <= d < delta`` (see
    :func:`oscillator_system`). The force left out there is below ``K delta^p = max(u, K (4 eps)^p)``
    with ``u = 2^-53``: the unit roundoff, below the rounding of the tape-spring term ``X``
    (``|X| >= 1``) that every evaluation of the net force carries, wherever ``K <= u / (4 eps)^p``
    (``K <= 4.2e6`` for ``p = 1.5``, ``K <= 1.4e14`` for ``p = 2``); beyond, ``K (4 eps)^p`` is
    ``8 / p`` times the error that the rounding of ``X`` (``eps / 2``) puts into ``K d^p`` at ``d = 4 eps``.
    Over a stay of length ``T`` in the layer the omission moves ``V`` by at most ``K delta^p T``
    and leaves out at most that much of the flange impulse; a contact entered at speed ``v``
    crosses the layer in ``T ~ delta / v``. A numerical device, not a change of the model: a
    contact still starts and ends at ``d = 0``, the flange's surface.

    Examples
    --------
    >>> import impactosc
    >>> from impactosc.model.hybrid._oscillator_system import layer_thickness
    >>> f"{layer_thickness(impactosc.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5)):.3g}"
    '4.98e-14'
    """
    p, K = osc.exponent, osc.K
    return max((_LAYER_FORCE / K) ** (1.0 / p), _LAYER_FLOOR)


#: The least time a power-law contact spends crossing its layer, in ulps of the time (see _resolved_layer).
_LAYER_CROSSING_ULPS = 64.0


def _resolved_layer(layer, v):
    """The layer's thickness ``max(layer, 64 eps |V| (1 + t))``: crossed in at least 64 ulps of the time.

    Beyond the layer's edge the steps are limited by the radius of convergence of ``d^p``, the
    time ``d / |V|`` to reach ``d = 0``. Where that is a few ulps of the time, the steps fall to
    the rounding of the time and the run crawls (a contact entered at 30 with ``K = 1e6`` at
    ``t = 0.1``: ``layer = 2.3e-15`` is crossed in 8e-17). The floor keeps every step beyond the
    edge at 32 ulps of the time or more. The force it leaves out, ``K (64 eps |V| t)^p`` for a
    time ``64 eps t``, changes ``V`` by ``K (64 eps t)^(p+1) |V|^p``: 4e-17 of 30 at ``t = 1e4``
    with ``K = 1e6``, ``p = 1.5``. ``|V|`` as a ``select`` (no singular derivative).
    """
    import heyoka as hy

    # (1 + t, not 1 + |t|: a run at t < -1 keeps the plain layer, where the product is negative)
    resolved = hy.select(hy.gt(v, 0.0), v, -v) * ((_LAYER_CROSSING_ULPS * 2.0**-52) * (1.0 + hy.time))
    return hy.select(hy.gt(resolved, layer), resolved, layer)


def _power_law(K, exponent, depth, layer):
    """The force ``K d^p`` of a power-law flange at depth ``d``, off while a step starts in the boundary layer.

    Every mode's vector field is one expression of the integrator (gated by the mode), so the
    force must be finite at every state, also outside the flange: ``select(delta / 2 > d, 0, (d^2)^(p/2))``
    takes one branch, and the other's non-finite Taylor coefficients (``d = 0``) stay out of it;
    ``(d^2)^(p/2)`` is ``d^p`` where it is taken and is finite for ``d < 0``, where the evaluators
    (which may compute both branches) would take ``d^p`` of a negative number. heyoka's
    ``select`` decides on the value at the start of each step, so the force is on for a
    whole step that starts beyond ``delta / 2`` and off for one that starts before it. The
    guards ``d = delta`` (``"upper layer in"``, ``"upper layer out"``) end a step there, so
    that moving in the spring comes on at ``d = delta``; moving out it goes off at the first
    step that starts below ``delta / 2``, and a step that starts beyond it stays within the
    radius of convergence ``d / |V|`` of ``d^p`` (heyoka's steps do), so never reaches ``d = 0``.
    Evaluated (guards, entry conditions, resets), the force is ``K d^p`` for ``d > delta / 2``.
    """
    import heyoka as hy

    return K * hy.select(hy.gt(0.5 * layer, depth), 0.0, (depth * depth) ** (0.5 * exponent))


@dataclasses.dataclass(frozen=True)
class WallChatter(EngineRule):
    """The accumulation rule of a rigid flange of the family: the engine's chatter (``Guard.accumulation``).

    A declaration: the engine resolves it to its chatter model (``impactosc.engine._chatter``,
    the one copy, through ``impactosc.engine._hybrid.wall_chatter``), which decides from the
    state at each impact whether the rest of the sequence is known to its time tolerance.
    It holds no parameter value (it is part of the system's structure): :meth:`member` reads
    the member from the system's parameter values at the impact.
    """

    side: int  #: the flange, +1 (upper) or -1 (lower)
    names: tuple[str, ...]  #: the system's parameter names, in order
    position: int = 0  #: the index of ``x`` among the states
    velocity: int = 1  #: the index of ``v``

    def member(self, values) -> Oscillator:
        """The member of the family whose parameters (in the order of :attr:`names`) are ``values``."""
        return _member(self.names, tuple(float(c) for c in values))


@dataclasses.dataclass(frozen=True)
class StickTest(EngineRule):
    """The transition rule of a region's stop and release guards: the engine's stick test at rest (``Guard.choose``).

    A declaration: the engine resolves it to the Filippov stick test of the built-in family
    (``impactosc.model._rule.motion_at_rest``, the one copy, through
    ``impactosc.engine._hybrid.stick_test``), which decides a tie at rest (the net force at the
    static friction level, or zero without friction, within its rounding) by the forcing's
    trend, where the stick mode's entry conditions would decide by the sign of a rounding
    error. It answers the mode of :attr:`region` with the motion the test gives (``"free0"``,
    ``"free+"``, ``"free-"``, ...), and nothing on a rigid flange's wall (the rest on it is the
    wall's rule). It holds no parameter value: :meth:`member` reads the member from the
    system's parameter values.
    """

    region: str  #: the prefix of the region's modes: "free", "upper" or "lower"
    position: int = 0  #: the index of ``x`` among the states

    def member(self, names: tuple[str, ...], values) -> Oscillator:
        """The member of the family whose parameters, named ``names`` in order, are ``values``."""
        return _member(tuple(names), tuple(float(c) for c in values))


@lru_cache(maxsize=256)
def _member(names: tuple[str, ...], values: tuple[float, ...]) -> Oscillator:
    named = dict(zip(names, values, strict=True))
    terms: list[tuple[float, float, float]] = []
    while f"F{len(terms) + 1 if terms else ''}" in named:
        tag = str(len(terms) + 1) if terms else ""
        terms.append((named[f"F{tag}"], named[f"Omega{tag}"], named[f"phase{tag}"]))
    (F, Omega, phase), harmonics = terms[0], terms[1:]
    rigid = "e" in named  # a rigid member's restitution; a spring member's stiffness is K
    flange = dict(flange="rigid", restitution=named["e"]) if rigid else {}
    return Oscillator(F, Omega, named["beta"], 0.0 if rigid else named["K"], phase, zeta=named.get("zeta", 0.0),
                      beta_static=named["beta_s"], harmonics=harmonics, exponent=named.get("exponent", 1.0),
                      **flange,  # type: ignore[arg-type]
                      gap_lower=named.get("gap_lower", math.inf), gap_upper=named.get("gap_upper", math.inf))


def oscillator_system(osc: Oscillator, *, energy: bool = False, integral_scale: float = 1.0) -> HybridSystem:
    """The member ``osc`` of the family as a :class:`HybridSystem` (paper eq. 3 and its family).

    ``X'' + 2 zeta X' + X + beta sgn(X') = sum_i F_i cos(Omega_i t + phase_i) - flange(X)``
    with Coulomb friction as :func:`stick_slip` modes in each region (``free``, ``upper``,
    ``lower``: ``"free+"``, ``"free0"``, ``"free-"``, ...), whose stops and releases choose
    the mode after them by the engine's stick test at rest (``StickTest``, the guards'
    ``choose``: a tie is decided by the forcing's trend, as the built-in engine decides it). A spring flange compresses
    with the force ``K (X - gap_upper)`` (upper) or ``K (X + gap_lower)`` (lower), and the
    integral ``Q`` is the flange impulse ``int K d dt``. A rigid flange is a guard with the
    reset ``V -> -e V`` in the free modes (``"impact upper"``, ``"impact lower"``) and a mode of
    rest on it (``"upper0"``, ``"lower0"``: ``X' = V' = 0``), entered where an impact keeps no
    speed (``e = 0``), where a slip ends on the wall (moving to it or off it) and, at the accumulation time, where the
    engine's chatter model resolves a sequence of impacts (``WallChatter``, the guard's
    ``accumulation``; the run goes on with the engine's jump, from the same impact), and left by
    the release away from the wall (``"upper release-"``: ``f + beta_s`` falls through 0;
    ``"lower release+"``), the built-in engine's rule. The parameters keep the
    oscillator's names (``F, Omega, phase, beta, beta_s, K, zeta, e, gap_upper,
    gap_lower``, and ``F2, Omega2, phase2, ...`` for the harmonics); the forcing period
    is ``2 pi / Omega``.

    With ``energy=True`` the system also integrates what the built-in :class:`~impactosc.Solution`
    reports (its rms flange force and energy balance): ``Q2 = int (K d)^2 dt`` (spring flanges),
    ``W = int V f dt`` (the forcing's work) and, with damping, ``VV = int V^2 dt`` (the damping
    loss is ``2 zeta VV``).

    ``integral_scale`` multiplies every integrand (so every integral). A Taylor integrator
    controls its error relative to the largest state: integrals that grow large (``Q2``
    grows like ``(K d)^2 t``) would loosen the control of ``x`` and ``v``; with a small power of
    two (the built-in heyoka backend takes ``2**-40``) they stay out of it, and the
    integrals divided by it are the same numbers to rounding.

    A power-law flange (``exponent = p > 1``, the Hertz contact ``K d^p``) has the parameters
    ``exponent`` and ``layer`` (``layer_thickness``): ``d^p`` is not analytic at ``d = 0``, where
    each contact starts, so the spring is off in a boundary layer ``0 <= d < layer`` whose left-out
    force is below the unit roundoff, and each flange has one more mode, ``"upper_layer+"``
    (``"lower_layer-"``): moving in with the layer's edge ahead, left at the edge by the internal
    guard ``"upper layer in"`` (``_boundary_layers``). Contacts still start and end at ``d = 0``.
    The layer is as thin as the unit roundoff allows, and at least as thick as the mass
    crosses in 64 ulps of the time (``_resolved_layer``: a fast contact would otherwise take
    steps at the rounding of the time beyond its edge).

    Examples
    --------
    >>> import impactosc
    >>> from impactosc.model.hybrid import oscillator_system
    >>> system = oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4))
    >>> system.mode_names[:3], system.integrals
    (('free0', 'free+', 'free-'), ('Q',))

    The integrals scaled by a power of two (divide them by it; the flange impulse of the
    closed-form ``exact`` backend is 18.34965206764):

    >>> scaled = oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), integral_scale=2.0**-40)
    >>> sol = impactosc.simulate(scaled, 50.0, [0.95, 0.0])
    >>> round(sol.integrals["Q"] / 2.0**-40, 6)
    18.349652

    A rigid flange under a constant push: its impacts accumulate (at ``pi / 3 + sum_k 2 atan(sqrt(3) / 2^k)``),
    where the engine's chatter rule jumps to rest on the wall:

    A Hertz contact (``p = 1.5``): the layer's edge is an internal event of each contact:

    >>> hertz = oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4, exponent=1.5))
    >>> hertz.mode_names[-2:], hertz.guard_names[-1]
    (('upper_layer+', 'lower_layer-'), 'lower layer in')

    >>> rigid = oscillator_system(impactosc.Oscillator(F=2.0, Omega=0.0, beta=0.0, flange="rigid", restitution=0.5))
    >>> rest = impactosc.simulate(rigid, 10.0, [0.0, 0.0]).events[-1]
    >>> rest.kind, rest.mode_after, round(rest.t, 9)
    ('rest', 'upper0', 4.150405283)
    """
    import heyoka as hy

    from ._definition import symbols

    if not isinstance(osc, Oscillator):
        raise TypeError(f"osc must be an impactosc.Oscillator, got {osc!r}")
    if not (isinstance(integral_scale, (int, float)) and math.isfinite(integral_scale) and integral_scale > 0.0):
        raise ValueError(f"integral_scale must be a finite number > 0, got {integral_scale!r}")
    x, v = symbols("x v")
    params: dict[str, float] = {}

    def par(name: str, value: float):
        params[name] = float(value)
        return symbols(name)

    forcing = None
    amplitudes = []
    for i, (F, Om, ph) in enumerate(osc.terms):
        tag = "" if i == 0 else str(i + 1)
        amplitudes.append(par(f"F{tag}", F))
        term = amplitudes[-1] * hy.cos(par(f"Omega{tag}", Om) * hy.time + par(f"phase{tag}", ph))
        forcing = term if forcing is None else forcing + term
    beta, beta_s = par("beta", osc.beta), par("beta_s", osc.beta_s)
    base = forcing - x
    if osc.zeta != 0.0:
        base = base - 2.0 * par("zeta", osc.zeta) * v
    flanges = [(side, gap) for side, gap in ((1, osc.gap_upper), (-1, osc.gap_lower)) if gap != math.inf]
    gaps = {side: par("gap_upper" if side > 0 else "gap_lower", gap) for side, gap in flanges}
    modes, guards = [], []
    # the region of each mode's entry: between the flanges, or into one (an initial state decides); an
    # impact on a rigid flange is located a rounding error either side of it, where the rebound is free
    slack = {side: (_IMPACT_ROUNDING * (1.0 + gaps[side]) if osc.rigid else 0.0) for side, _ in flanges}
    inside = [gaps[side] - side * x + slack[side] for side, _ in flanges]
    regions = [("free", base, None, inside)]
    if not osc.rigid:
        K = par("K", osc.K)
        if not osc.linear:
            exponent = par("exponent", osc.exponent)
            unit = par("layer", layer_thickness(osc))
            layer = _resolved_layer(unit, v)
        for side, _ in flanges:
            wall = side * gaps[side]
            if osc.linear:
                force, spring = base - K * (x - wall), side * K * (x - wall)
            else:  # the force's magnitude K d^p, with its boundary layer (_power_law)
                spring = _power_law(K, exponent, side * x - gaps[side], layer)
                force = base - side * spring
            regions.append(("upper" if side > 0 else "lower", force, spring,
                            [side * x - gaps[side] + _SURFACE_ROUNDING * (1.0 + gaps[side])]))
    for prefix, force, impulse, region in regions:
        ints: dict = {"Q": impulse} if impulse is not None else {}
        stuck = dict(ints)
        if energy:
            if impulse is not None:
                ints["Q2"] = stuck["Q2"] = impulse * impulse
            ints["W"] = v * forcing  # 0 while stuck (V = 0)
            if osc.zeta != 0.0:
                ints["VV"] = v * v
        if integral_scale != 1.0:
            ints = {q: integral_scale * r for q, r in ints.items()}
            stuck = {q: integral_scale * r for q, r in stuck.items()}
        m, g = stick_slip(prefix, v, force, beta, beta_s, rates={x: v}, integrands=ints, stick_integrands=stuck,
                          entry=region, choose=StickTest(prefix))
        modes += m
        guards += g
    if osc.rigid:
        modes, guards = _rigid_flanges(modes, guards, flanges, gaps, x, v, base, beta_s,
                                       par("e", osc.restitution), tuple(params))
    else:
        for side, _ in flanges:
            name, into, out = ("upper", "+", "-") if side > 0 else ("lower", "-", "+")
            surface = x - side * gaps[side]
            guards.append(Guard(f"enter {name}", surface, side, armed=f"free{into}", to=f"{name}{into}"))
            guards.append(Guard(f"leave {name}", surface, -side, armed=f"{name}{out}", to=f"free{out}"))
        if not osc.linear:
            modes, guards = _boundary_layers(modes, guards, flanges, gaps, x, layer, unit)
    period = 2.0 * math.pi / symbols("Omega") if osc.Omega > 0.0 else None
    integrals = [] if osc.rigid else ["Q"]
    if energy:
        integrals += ([] if osc.rigid else ["Q2"]) + ["W"] + (["VV"] if osc.zeta != 0.0 else [])
    return HybridSystem("x v", params, modes, guards, integrals=integrals, period=period,
                        name="eq3" if not osc.rigid else "eq3 rigid", scale=_force_level(amplitudes, beta, beta_s))


def _force_level(amplitudes, beta, beta_s):
    """``min(1, sum |F_i| + beta + beta_s)``: the size of the states near rest (``HybridSystem.scale``).

    A member's motion from rest is as large as its forces (the spring's stiffness is 1). Below 1
    the loops' tolerances follow it, so that a member with forcing and friction of 1e-45 is not on
    every guard at every instant; at 1 and above they are those of any system.
    """
    import heyoka as hy

    level = beta + beta_s
    for F in amplitudes:
        level = level + hy.select(hy.lt(F, 0.0), -F, F)
    return hy.select(hy.lt(level, 1.0), level, 1.0)


def _boundary_layers(modes: list, guards: list, flanges, gaps: dict, x, layer, unit) -> tuple[list, list]:
    """The modes and guards of power-law flanges with each flange's boundary layer crossed moving in.

    Per flange one more mode, ``"upper_layer+"`` (``"lower_layer-"``): moving into the flange with
    the layer's edge ``d = delta`` ahead, the vector field and integrands those of ``"upper+"``. Its
    guard ``"upper layer in"`` (``d`` rises through ``delta``, into ``"upper+"``) ends the step
    there, so that the spring comes on (:func:`_power_law`); it is an internal event, no contact
    event. Every way into the flange moving in goes through it: the contact's start (``"enter
    upper"``), a release from sticking and a stop moving out that turns back in (the mass may lie
    inside the layer there), and so does a run started moving in (the built-in replay's mode of
    ``(region, motion)``): deeper than the layer its edge is behind, and the mode is ``"upper+"`` in
    all but name. Its slip's stop (``"upper_layer+ stop"``) is that of ``"upper+"``. Moving out
    needs no edge: the spring goes off at the first step that starts within ``delta / 2``, and
    ``"leave upper"`` ends the contact.
    """
    for side, _ in flanges:
        name, into = ("upper", "+") if side > 0 else ("lower", "-")
        spring, layered = f"{name}{into}", f"{name}_layer{into}"
        model = next(m for m in modes if m.name == spring)
        modes.append(HybridMode(layered, dict(model.field), entry=model.entry, integrands=dict(model.integrands)))
        stop = next(g for g in guards if g.name == f"{spring} stop")
        # every way in but the edge: with the edge ahead
        guards = [dataclasses.replace(g, to=tuple(layered if m == spring else m for m in g.to)) if spring in g.to
                  else g for g in guards]
        guards.append(dataclasses.replace(stop, name=f"{layered} stop", armed=(layered,)))  # the slip's stop
        # In units of the layer's least thickness (``unit``, a parameter; dividing by the resolved
        # thickness, an expression, made each step 1.6 times dearer): on the flange's surface it is 1 or
        # more, far from the loop's tolerance of a state on a guard (1e-12 (1 + |y|), which took the
        # surface for the edge and skipped the layer). It crosses in the direction opposite to the
        # contact's start: heyoka shares one event among guards of one direction armed in disjoint modes,
        # and the contact start's cooldown (1e-12) hid an edge crossed 7e-14 later.
        edge = side * (gaps[side] + layer - side * x) / unit
        guards.append(Guard(f"{name} layer in", edge, -side, armed=(layered,), to=(spring,)))
    return modes, guards


def _rigid_flanges(modes: list, guards: list, flanges, gaps: dict, x, v, force, beta_s, e,
                   names: tuple[str, ...]) -> tuple[list, list]:
    """The free modes and guards with each rigid flange's impact, rest mode and release (the engine's rule).

    At an impact the reset ``X -> wall, V -> -e V`` (the state snapped onto the wall, as the engine
    snaps it; the saltation matrix is that of ``V -> -e V`` alone, the guard's normal being ``X``;
    ``V -> 0`` at a touch, where ``V`` is not towards the wall: the engine's stick test decides)
    leads into the free slip away from the wall, or, where no speed is left and the force does not
    pull the mass off the wall beyond ``beta_s``, into the rest on it; a slip that ends exactly on
    the wall (a touch) rests there on the same condition. Resting, the
    mass has ``X' = V' = 0`` and the wall takes any push into it; it is released when the force
    pulls it away beyond ``beta_s``. The rest is entered with no speed away from the wall only
    (``side V >= -1e-300``, the engine's rule), wherever the impact was located.
    """
    import heyoka as hy

    for side, _ in flanges:
        up = side > 0
        name, rest = ("upper", "upper0") if up else ("lower", "lower0")
        toward, away = ("free+", "free-") if up else ("free-", "free+")
        # on the wall exactly, as the engine has it (a slip that ends a hair short of it falls back and
        # hits it: a chatter's flights end 1e-14 short of it before its jump); an impact puts it there
        on_wall = side * x - gaps[side]
        still = hy.select(hy.lt(side * v, -_NO_SPEED), -1.0, 1.0)
        modes.append(HybridMode(rest, {x: 0.0, v: 0.0}, entry=(on_wall, side * force + beta_s, still)))
        guards.append(Guard(f"impact {name}", x - side * gaps[side], side, armed=toward, to=(away, rest),
                            reset={x: side * gaps[side], v: hy.select(hy.gt(side * v, 0.0), -e * v, 0.0)}, rest=rest,
                            accumulation=WallChatter(side, names)))
        release = "release-" if up else "release+"
        guards.append(Guard(f"{name} {release}", force + side * beta_s, -side, armed=rest, to=away))
        # a slip that ends on the wall (either way: a flight off it can turn back on it): the rest on it
        # comes first among the stops' candidates (its entry holds on its own wall only)
        guards = [dataclasses.replace(g, to=(rest, *g.to)) if g.name in ("free+ stop", "free- stop") else g
                  for g in guards]
    return modes, guards
