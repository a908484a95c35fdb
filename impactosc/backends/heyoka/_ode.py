"""The heyoka backend's compiled integrators: shapes, runtime parameters, expressions, the cache.

See the docstring of :mod:`impactosc.backends.heyoka` for the equations, the guards and the
power-law boundary layer. This module builds them: for each *shape* of family member and
tolerance (and per thread) one :class:`Integrators`, holding one ``taylor_adaptive`` per
*mode family* (:data:`FREE`: slipping between the flanges; :data:`FLANGE`: slipping with a
spring flange compressed). Each family integrator carries only the states and the guards
its modes can use, so a step never evaluates a guard that cannot be armed (measured on a
long creep piece of the tape case: 0.77 us per step against 1.16 us with all seven guards
and the flange impulse states). Stuck modes are closed form (``impactosc._stuck``) and
need no integrator; a rigid flange has no flange family.

Bit for bit: a family integrator's states, vector field and guards are those of the single
integrator with all seven gated guards that this backend compiled before (the eq. 3
integrator of the paper's runs), evaluated with the same runtime parameters. In the free
family the flange term, which the old integrator multiplied by ``r^2 = 0`` (or ``sigma = 0``),
is left out, and so are the flange impulse states, whose derivatives were 0 there; heyoka
chooses its steps from the states' Taylor coefficients, so the steps are the same too.
"""

from __future__ import annotations

import math
import threading
from typing import NamedTuple

from ..._util.notice import notice_if_slow
from ...engine._driver import (
    ACCEL_ZERO,
    ENTER_LOWER,
    ENTER_UPPER,
    GUARD_DIRECTIONS,
    LEAVE,
    N_GUARDS,
    RELEASE_DOWN,
    RELEASE_UP,
    SLIP_END,
    Mode,
    guard_gates,
)
from ...model._oscillator import Oscillator

DEFAULT_TOL = 2.0**-52  # machine epsilon of double precision


class Shape(NamedTuple):
    """What a compiled integrator's expressions depend on; every number is a runtime parameter."""

    harmonics: int  #: forcing terms, the fundamental included (1 for eq. 3)
    damped: bool  #: viscous damping ``2 zeta V``, with the state ``int V^2``
    flange: str  #: ``"linear"`` (``K d``), ``"power"`` (``K d^p``, ``p > 1``) or ``"rigid"``


#: The paper's eq. 3: one harmonic, no damping, linear flange springs.
EQ3 = Shape(1, False, "linear")


def shape_of(osc: Oscillator) -> Shape:
    """The :class:`Shape` of the integrator that runs ``osc``."""
    flange = "rigid" if osc.rigid else ("linear" if osc.exponent == 1.0 else "power")
    return Shape(len(osc.terms), osc.zeta != 0.0, flange)


# Indices into the runtime parameter vector, the same in every family and shape (a family
# integrator's vector ends at the last index its expressions use: heyoka wants exactly that
# length). The first 23 are those of the eq. 3 integrator from before the family.
_P_F, _P_OMEGA, _P_BETA, _P_K, _P_PHASE, _P_REGION, _P_MOTION, _P_REGION2, _P_MOTION2 = range(9)
_P_GATES = 9  # N_GUARDS gate parameters follow, then N_GUARDS guard offsets
_P_OFFSETS = _P_GATES + N_GUARDS
_P_BETA_S = _P_OFFSETS + N_GUARDS  # static friction level (release guards)
_P_DAMPING = _P_BETA_S + 1  # 2 zeta
_P_EXPONENT = _P_DAMPING + 1  # p of the power-law spring
_P_LAYER = _P_EXPONENT + 1  # delta, the thickness of the power-law boundary layer
_P_SIGMA = _P_LAYER + 1  # 1: spring on (d >= delta); 0: in the layer or free
_P_LAYER_DIR = _P_SIGMA + 1  # r * s: +1 moving deeper into the flange, -1 moving out
_P_LAYER_GATE = _P_LAYER_DIR + 1
_P_UPPER = _P_LAYER_GATE + 1  # gap_upper: the upper flange is at X = +gap_upper (0.0 when absent: never armed)
_P_LOWER = _P_UPPER + 1  # gap_lower: the lower flange is at X = -gap_lower (0.0 when absent)
_P_GAP = _P_LOWER + 1  # the gap of the region r (0.0 when free): d = r X - gap
_P_WALL = _P_GAP + 1  # r * gap: where the flange of region r is
_P_HARMONICS = _P_WALL + 1  # (F_i, Omega_i, phase_i) of every harmonic after the first

#: The internal event of power-law shapes: ``d`` crossing ``delta`` (never handed to the engine).
LAYER = N_GUARDS
#: Spring force at the edge of the power-law layer: the unit roundoff (see the heyoka module docstring).
_LAYER_FORCE = 2.0**-53
_LAYER_FLOOR = 4.0 * DEFAULT_TOL
#: Largest layer thickness of a fast crossing (the layer's crossing time stays below 1e-6 / v).
_LAYER_CAP = 1e-6

#: The mode families: slipping with ``region == 0`` (FREE) and with ``region != 0`` (FLANGE).
FREE, FLANGE = 0, 1


def _family_guards(family: int) -> tuple[int, ...]:
    """The guards that :func:`~impactosc.engine.guard_gates` can arm in a slipping mode of ``family``.

    Derived from the engine's gates, not restated: the engine stays the one place that says
    which guard is armed when. A rigid flange arms nothing but releases in a flange region
    (stuck: closed form), so the spring flanges' gates cover both flange laws.
    """
    regions = (0,) if family == FREE else (-1, 1)
    modes = [Mode(r, s, armed) for r in regions for s in (-1, 1) for armed in (True, False)]
    armed = {g for m in modes for rigid in (False, True) for g in range(N_GUARDS) if guard_gates(m, rigid)[g]}
    return tuple(sorted(armed))


#: Guards of each family, in the order of its integrator's events (the layer event follows).
#: (enter upper, enter lower, slip end, acceleration zero) and (leave, slip end, acceleration zero).
FAMILY_GUARDS = {FREE: _family_guards(FREE), FLANGE: _family_guards(FLANGE)}


def families_of(shape: Shape) -> tuple[int, ...]:
    """The families a shape needs: a rigid flange is never slipping inside a flange region."""
    return (FREE,) if shape.flange == "rigid" else (FREE, FLANGE)


def state_names(shape: Shape, family: int = FLANGE) -> list[str]:
    """The states of the ``family`` integrator of ``shape`` (the flange family's are the shape's)."""
    impulse = family == FLANGE and shape.flange != "rigid"
    return ["X", "V", *(("Q", "Q2") if impulse else ()), "W", *(("VV",) if shape.damped else ())]


def integral_slots(shape: Shape, family: int) -> tuple[int, int, int, int]:
    """Where ``(Q, Q2, W, VV)`` sit in a family's state list; -1 is a 0.0 appended to it."""
    names = state_names(shape, family)
    q, q2, w, vv = (names.index(n) if n in names else -1 for n in ("Q", "Q2", "W", "VV"))
    return q, q2, w, vv


def layer_thickness(osc: Oscillator, speed: float = 0.0) -> float:
    """``delta`` of the power-law boundary layer of ``osc`` crossed at ``speed`` (see the heyoka module docstring).

    ``max((u / K)^(1/p), 4 eps, min(((p + 1) u v^2 / K)^(1/(p+1)), 1e-6))``: the spring force
    left out is below the unit roundoff ``u``, or the velocity it would change while the mass
    crosses the layer at ``v`` is below ``u v``.
    """
    p, K = osc.exponent, osc.K
    delta = max((_LAYER_FORCE / K) ** (1.0 / p), _LAYER_FLOOR)
    if speed > 0.0:
        crossing = ((p + 1.0) * _LAYER_FORCE * speed * speed / K) ** (1.0 / (p + 1.0))
        delta = max(delta, min(crossing, _LAYER_CAP))
    return delta


def parameter_values(osc: Oscillator, mode: Mode, gates, offsets) -> list[float]:
    """The whole runtime parameter vector for ``osc`` in ``mode`` (cut to each integrator's length).

    The power-law layer's switch ``(sigma, r s, gate)`` is 0 here: the stepper sets it per piece.
    An absent flange's distance is 0.0 here: the stepper gates its guard off.
    """
    r, s, _ = mode
    upper, lower = (g if g != math.inf else 0.0 for g in (osc.gap_upper, osc.gap_lower))
    gap = (upper if r > 0 else lower) if r else 0.0
    vals = [osc.F, osc.Omega, osc.beta, osc.K, osc.phase, r, s, r * r, s * s, *gates, *offsets,
            osc.beta_s, 2.0 * osc.zeta, osc.exponent, 0.0 if osc.linear else layer_thickness(osc), 0.0, 0.0, 0.0,
            upper, lower, gap, r * gap]
    for term in osc.harmonics:
        vals.extend(term)
    return [float(v) for v in vals]


def _forces(hy, shape: Shape, X, V, p, flange: bool = True):
    """Expressions ``(f, f_net, flange force or None, acceleration while slipping)`` of ``shape``.

    ``flange=False`` (the free family): no flange term, which is 0 there (``r^2 = 0``, ``sigma = 0``).
    """
    harmonics, damped, law = shape
    K, r, r2 = p[_P_K], p[_P_REGION], p[_P_REGION2]
    terms = [(p[_P_F], p[_P_OMEGA], p[_P_PHASE])]
    terms += [tuple(p[_P_HARMONICS + 3 * i:_P_HARMONICS + 3 * i + 3]) for i in range(harmonics - 1)]
    forcing = None
    for F, Om, phase in terms:
        term = F * hy.cos(Om * hy.time + phase)
        forcing = term if forcing is None else forcing + term
    if not flange or law == "rigid":
        f_net = forcing - X
        force = None
    elif law == "linear":
        # In region r the compressed flange (at X = wall = r gap) pushes with -K (X - wall).
        f_net = forcing - X - K * r2 * (X - p[_P_WALL])
        force = K * r2 * (r * X - p[_P_GAP])  # flange force magnitude K (r X - gap) in region r
    else:
        # sigma = 0 (in the boundary layer) evaluates the power at 1, never near 0.
        sigma = p[_P_SIGMA]
        force = K * sigma * (sigma * (r * X - p[_P_GAP]) + (1.0 - sigma)) ** p[_P_EXPONENT]
        f_net = forcing - X - r * force
    accel = (f_net - p[_P_DAMPING] * V if damped else f_net) - p[_P_BETA] * p[_P_MOTION]
    return forcing, f_net, force, accel


def family_system(shape: Shape, family: int):
    """``(rhs, events)`` of one mode family of ``shape``: ``events`` are ``(expression, direction)``.

    The guards of :data:`FAMILY_GUARDS` in that order (then, for a power-law flange, the layer
    event), gated and offset as the module docstring of the heyoka backend says.
    """
    import heyoka as hy

    X, V, *integrals = hy.make_vars(*state_names(shape, family))
    p = [hy.par[i] for i in range(_P_HARMONICS + 3 * (shape.harmonics - 1))]
    r, s, s2 = p[_P_REGION], p[_P_MOTION], p[_P_MOTION2]
    gates = p[_P_GATES:_P_OFFSETS]
    offsets = p[_P_OFFSETS:_P_BETA_S]
    forcing, f_net, force, accel = _forces(hy, shape, X, V, p, flange=family == FLANGE)

    rhs = [(X, V), (V, s2 * accel)]
    rest = iter(integrals)
    if force is not None:
        rhs += [(next(rest), force), (next(rest), force * force)]
    rhs.append((next(rest), V * forcing))
    if shape.damped:
        rhs.append((next(rest), V * V))

    beta_s = p[_P_BETA_S]
    guard_exprs = {
        ENTER_UPPER: X - p[_P_UPPER],
        ENTER_LOWER: X + p[_P_LOWER],
        LEAVE: r * X - p[_P_GAP],
        SLIP_END: s * V,
        ACCEL_ZERO: s * accel,  # re-arms slip end after a release
        RELEASE_UP: f_net - beta_s,
        RELEASE_DOWN: f_net + beta_s,
    }
    # Gated: g * h + (1 - g) is the guard h when the gate g is 1 and the constant 1 (no
    # root) when it is 0. Each guard is shifted by engine.guard_offsets towards the side it
    # crosses from: the engine snaps the state onto guard surfaces, and heyoka, seeing a
    # root exactly at tau = 0 that its direction filter drops, skips the guard's next root
    # if it falls in the same step (measured: a quick second turning point was lost). The
    # offset is a separate term so that constant folding cannot absorb it into the 1.0 of X - 1.
    events = []
    for g in FAMILY_GUARDS[family]:
        gate, off, d = gates[g], offsets[g], GUARD_DIRECTIONS[g]
        events.append((gate * guard_exprs[g] + (1.0 - gate) - d * off * gate, d))
    if shape.flange == "power" and family == FLANGE:
        # d crossing delta in the direction of the motion (r s > 0: deeper). Armed only when
        # that edge lies ahead of the mass, so it never starts on its root (_LayeredStepper).
        gate, q = p[_P_LAYER_GATE], p[_P_LAYER_DIR]
        events.append((gate * (q * (r * X - p[_P_GAP] - p[_P_LAYER])) + (1.0 - gate), 1))
    return rhs, events


def _build_family(tol: float, shape: Shape, family: int):
    """The ``taylor_adaptive`` of one mode family of ``shape``."""
    import heyoka as hy

    rhs, events = family_system(shape, family)
    direction = {1: hy.event_direction.positive, -1: hy.event_direction.negative}
    # cooldown=0: after a guard fires the engine changes the mode, which gates that guard
    # off or flips its sign, so there is nothing to re-trigger; an automatic cooldown
    # could hide a genuine second event shortly after the first.
    t_events = [hy.t_event(expr, direction=direction[d], cooldown=0.0) for expr, d in events]
    # pars are left out: heyoka sizes the vector to the highest index the expressions use.
    return hy.taylor_adaptive(rhs, [0.0] * len(rhs), t_events=t_events, tol=tol, compact_mode=False)


class Integrators:
    """The compiled integrators of one shape and tolerance: one ``taylor_adaptive`` per mode family.

    ``ta[FREE]`` and ``ta[FLANGE]`` (the latter absent for a rigid flange). ``dim`` is the
    number of states of the shape (those of the flange family: ``X, V[, Q, Q2], W[, VV]``).
    """

    def __init__(self, tol: float, shape: Shape):
        self.tol = tol
        self.shape = shape
        self.ta = {family: _build_family(tol, shape, family) for family in families_of(shape)}
        self.dim = len(state_names(shape))


def _build(tol: float, shape: Shape = EQ3) -> Integrators:
    """Compile the integrators of ``shape`` (no cache: :func:`integrator` caches them)."""
    return Integrators(tol, shape)


def _log_to_stderr(build):
    """Call ``build()`` with C's ``stdout`` pointing at ``stderr``, so heyoka's logger goes there.

    heyoka logs through spdlog to a sink on C's ``stdout``; its warnings (e.g. root finding
    during event detection) would corrupt tables and piped output. The sink takes the
    ``FILE *`` that ``stdout`` holds when heyoka creates its logger, on the first
    integrator built in the process: during that one build ``stdout`` holds ``stderr``.
    Python's own ``sys.stdout`` is not a C ``FILE *`` and is unaffected. If heyoka's logger
    already exists (created by an earlier heyoka call outside impactosc), it keeps stdout.
    """
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        for out_name, err_name in (("stdout", "stderr"), ("__stdoutp", "__stderrp")):  # glibc/musl, macOS
            try:
                out = ctypes.c_void_p.in_dll(libc, out_name)
                err = ctypes.c_void_p.in_dll(libc, err_name)
                break
            except ValueError:
                continue
        else:
            return build()
    except (OSError, TypeError, AttributeError):  # no C library to reach (e.g. Windows): leave it
        return build()
    saved = out.value
    out.value = err.value
    try:
        return build()
    finally:
        out.value = saved


_cache = threading.local()
_first_build = threading.Lock()
_logger_routed = False


def log_on_stderr(build):
    """``build()``; the process's first heyoka build is made with C's ``stdout`` on ``stderr``.

    Whichever integrator heyoka builds first creates its logger (:func:`_log_to_stderr`):
    the piece loop's (:func:`integrator`) or the hybrid loop's that a spring-flange member
    runs on (``backends/heyoka/_replay.py``). Later calls cost a flag check.
    """
    global _logger_routed
    if _logger_routed:
        return build()
    with _first_build:
        if not _logger_routed:
            try:
                return _log_to_stderr(build)
            finally:
                _logger_routed = True
    return build()


def integrator(tol: float = DEFAULT_TOL, shape: Shape = EQ3) -> Integrators:
    """The cached :class:`Integrators` for ``tol`` and ``shape`` (compiled on first use in each thread)."""
    store = getattr(_cache, "integrators", None)
    if store is None:
        store = _cache.integrators = {}
    key = (tol, shape)
    found = store.get(key)
    if found is None:
        # A notice if the compile is still running after 2 s (usually 0.1-1 s; tight tolerances take longer).
        with notice_if_slow("heyoka-compile", f"impactosc: heyoka is compiling its integrators (tol={tol:g}); "
                                              "this process compiles them once"):
            found = log_on_stderr(lambda: _build(tol, shape))
        store[key] = found
    return found
