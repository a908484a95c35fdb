"""The definition of a user's piecewise-smooth (hybrid) system: states, parameters, modes, guards.

A hybrid system is a finite set of *modes*, each a smooth vector field ``y' = f_m(y, t; p)``
written as heyoka expressions in the named states, the time ``hy.time`` and the named
parameters, and a set of *guards*, each a scalar expression ``h(y, t; p)`` with a crossing
direction, the modes in which it is armed and a transition: the next mode (or an ordered
list of candidates, the first whose entry holds) and a reset map ``y -> g(y, t; p)``
(identity where not given). Sticking and sliding are modes of their own with release
guards (see :func:`stick_slip`).

Everything is symbolic: the backends compile the expressions (heyoka's Taylor integrator,
heyoka's compiled functions for scipy) and differentiate them (Lie derivatives of the
guards for grazing detection). The classes are frozen dataclasses; the parameter values
are data (:meth:`HybridSystem.with_parameters`), the structure is what a backend compiles
once (:attr:`HybridSystem.structure`).
"""

from __future__ import annotations

import copy
import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from ._checks import check_system

__all__ = ["symbols", "HybridMode", "Guard", "HybridSystem", "DIRECTIONS"]

#: Crossing directions of a guard: +1 (``h`` rises through 0), -1 (falls), 0 (either way).
DIRECTIONS = (-1, 0, 1)


def _hy():
    import heyoka as hy

    return hy


def symbols(names: str | Sequence[str]):
    """Named symbols (heyoka variables) for states and parameters: ``x, v = symbols("x v")``.

    Parameters
    ----------
    names : str or sequence of str
        Whitespace- or comma-separated names, or a sequence of names.

    Returns
    -------
    heyoka.expression or tuple of heyoka.expression
        One variable per name (a single name gives the variable itself).

    Examples
    --------
    >>> from impactosc import symbols
    >>> x, v, g = symbols("x v g")
    >>> str(v * g)
    '(v * g)'
    """
    if isinstance(names, str):
        names = names.replace(",", " ").split()
    names = [str(n) for n in names]
    if not names:
        raise ValueError("symbols() needs at least one name, got none")
    return _hy().make_vars(*names)


def _is_expression(value) -> bool:
    return type(value).__name__ == "expression"


def _expression(where: str, value):
    """``value`` as a heyoka expression (numbers become constants), or a TypeError naming ``where``."""
    if _is_expression(value):
        return value
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        if not math.isfinite(float(value)):
            raise ValueError(f"{where} must be finite, got {value!r}")
        return _hy().expression(float(value))
    raise TypeError(f"{where} must be a heyoka expression or a number, got {value!r} of type {type(value).__name__}")


def _name_of(where: str, key) -> str:
    """A state or integral named by a string or by its variable."""
    if isinstance(key, str):
        return key
    if _is_expression(key):
        names = _hy().get_variables(key)
        if len(names) == 1 and str(key) == names[0]:
            return names[0]
    raise TypeError(f"{where}: a key must be a state's name or its variable, got {key!r}")


def _by_name(where: str, values) -> tuple[tuple[str, Any], ...]:
    """A mapping name -> expression as a tuple of pairs, in the mapping's order."""
    if values is None:
        return ()
    if not isinstance(values, Mapping):
        raise TypeError(f"{where} must be a mapping of state names (or variables) to expressions, got {values!r}")
    out = []
    for key, value in values.items():
        name = _name_of(where, key)
        out.append((name, _expression(f"{where}[{name!r}]", value)))
    return tuple(out)


def _names(where: str, value) -> tuple[str, ...]:
    if value is None:
        return ()
    if isinstance(value, str):
        value = value.replace(",", " ").split()
    out = tuple(value)
    for name in out:
        if not isinstance(name, str):
            raise TypeError(f"{where} must name modes by strings, got {name!r}")
    return out


@dataclass(frozen=True, eq=False)
class HybridMode:
    """One mode of a hybrid system: a smooth vector field and, optionally, entry conditions.

    Parameters
    ----------
    name : str
        The mode's name (unique in the system).
    field : mapping or sequence
        The vector field: a mapping from each state (its name or its variable) to its rate,
        or a sequence with one rate per state in the system's order. Rates are heyoka
        expressions in the states, ``heyoka.time`` and the parameters (or numbers).
    entry : sequence of expressions, optional
        Entry conditions ``c(y, t; p) >= 0``, all of which must hold for the mode to be
        entered: a transition with several candidate modes takes the first whose
        conditions hold at the state after the reset (how a Filippov stick mode is entered
        or not, see :func:`stick_slip`), and a run without a given initial mode starts in
        the first mode whose conditions hold. They may use ``heyoka.select`` and the
        comparisons ``heyoka.gt``/``heyoka.lt`` (they are evaluated, never integrated).
    integrands : mapping, optional
        The rate of each of the system's ``integrals`` (:class:`HybridSystem`) in this mode
        (default 0), integrated with the flow as an extra state.

    Examples
    --------
    >>> from impactosc import HybridMode, symbols
    >>> x, v, g = symbols("x v g")
    >>> flight = HybridMode("flight", {x: v, v: -g}, entry=[x])
    >>> flight.name
    'flight'
    """

    name: str
    field: Any
    entry: tuple = ()
    integrands: Any = ()

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise TypeError(f"a mode's name must be a non-empty string, got {self.name!r}")
        where = f"mode {self.name!r}"
        if isinstance(self.field, Mapping):
            rates: Any = _by_name(f"{where}: field", self.field)
        elif isinstance(self.field, Sequence) and not isinstance(self.field, str):
            rates = tuple(_expression(f"{where}: field[{i}]", f) for i, f in enumerate(self.field))
        else:
            raise TypeError(f"{where}: field must be a mapping state -> rate or a sequence of rates, "
                            f"got {self.field!r}")
        object.__setattr__(self, "field", rates)
        entry = self.entry
        if _is_expression(entry) or isinstance(entry, numbers.Real):
            entry = (entry,)
        object.__setattr__(self, "entry", tuple(_expression(f"{where}: entry[{i}]", c)
                                                 for i, c in enumerate(entry)))
        object.__setattr__(self, "integrands", _by_name(f"{where}: integrands", dict(self.integrands)))


class EngineRule:
    """A rule that the engine implements (``Guard.accumulation``, ``Guard.choose``): a declaration, not a callable.

    The model says *which* physics a guard follows, the engine (a layer above) holds that
    physics once; a subclass carries only what names it, such as the flange of a member of
    the oscillator family whose chatter the engine resolves
    (:class:`~impactosc.model.hybrid._oscillator_system.WallChatter`), or the region whose
    stick test at rest is the engine's (:class:`~impactosc.model.hybrid._oscillator_system.StickTest`).
    """

    __slots__ = ()


@dataclass(frozen=True, eq=False)
class Guard:
    """A switching surface ``h(y, t; p) = 0``: where it is armed, which way it fires, what follows.

    Parameters
    ----------
    name : str
        The guard's name (unique in the system); events carry it.
    expression : heyoka expression
        ``h`` in the states, ``heyoka.time`` and the parameters.
    direction : {-1, 0, 1}
        Fire when ``h`` falls through 0 (-1), rises through 0 (+1) or either (0).
    armed : str or sequence of str
        The modes in which the guard is armed.
    to : str or sequence of str, optional
        The next mode, or candidates in order (the first whose entry conditions, ``HybridMode.entry``, hold
        after the reset). ``None`` (default): the mode does not change.
    reset : mapping, optional
        The reset map: the new value of each state it changes, an expression in the states
        (their values just before the event), the time and the parameters. States left
        out keep their values.
    terminal : bool, optional
        False: the guard only marks an event (a Poincare section, a crossing to count):
        no transition, no reset. Default True.
    rest : str, optional
        The mode entered where this guard's events accumulate (Zeno: rebounds of shrinking
        height, such as a ball coming to rest on the floor or a mass chattering against a
        rigid stop): instead of ending with status 2, the run goes on from the estimated
        accumulation time in ``rest``, with the state of the last event and ``rest_reset``
        applied (an event of kind ``"rest"``). The flights left out last less than the
        accumulation tolerance ``zeno_tol (1 + |t|)`` in all. The rest mode is left by its own
        guards (a release when the force that holds the state there changes sign).
    rest_reset : mapping, optional
        The reset into ``rest`` (e.g. ``{v: 0}``), written like ``reset``.
    accumulation : callable, optional
        A rule that recognises an accumulation of this guard's events from the state at one
        of them, instead of from the event times: ``rule(t, before, after, parameters)`` is
        called at every crossing of the guard, with its time, the state (states, then
        integrals) before and after the reset and the parameter values (in the system's
        order), and returns ``None`` (the run goes on) or ``(time, state)`` or ``(time, state,
        increments)``: the events accumulate at ``time`` (``>= t``), where the run goes on in
        ``rest`` (an event of kind ``"rest"``) with ``state`` (the states only) and each
        integral moved on by its increment over the flights left out (default 0). A rule
        needs ``rest``; it is part of the system's structure, so it must be hashable (and
        picklable, for a system sent to other processes), and must read the parameters from
        its arguments, not hold their values. It replaces the watch of event times for this
        guard: that watch then acts only where the time left is a hundred times below
        ``zeno_tol (1 + |t|)`` (a rule that never answers cannot run into flights below rounding).
        The oscillator family's rigid flanges (:func:`~impactosc.model.hybrid.oscillator_system`)
        carry the engine's chatter rule.
    choose : callable, optional
        A transition rule that chooses the mode a crossing of this guard leads to, where the
        candidates' entry conditions would decide by rounding: at a tie, such as a mass that
        comes to rest where the net force equals the static friction level (or, without friction,
        vanishes), the force's own trend decides whether it sticks or slips, and which way.
        ``rule(t, state, parameters)`` gets the time, the state after the reset (states, then
        integrals) and the parameter values (in the system's order), and returns the name of
        the mode to enter, the name of the mode the guard is armed in (the crossing was
        rounding: no event, the run goes on in that mode), or ``None`` (the entry conditions
        of ``to`` decide, as without a rule). It is asked at every crossing of the guard, where
        a state lies on the guard tangent to it at an instant (after another transition, at the
        start of a run: the rule says whether it crosses, not the sign of a rounded curvature),
        and at the start of a run without an initial mode. Part of the
        system's structure, like ``accumulation``: hashable, and reading the parameters from
        its arguments. :func:`~impactosc.stick_slip` gives it to its stop and release guards
        (``choose=``), and the oscillator family's carry the engine's stick test at rest.

    Examples
    --------
    >>> from impactosc import Guard, symbols
    >>> x, v, e = symbols("x v e")
    >>> impact = Guard("impact", x, direction=-1, armed="flight", to="flight", reset={v: -e * v})
    >>> impact.armed
    ('flight',)

    A ball that comes to rest on the floor (mode ``"floor"``, with ``x' = 0, v' = 0``):

    >>> landing = Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v},
    ...                 rest="floor", rest_reset={x: 0.0, v: 0.0})

    The same ball with its accumulation time in closed form (gravity ``g``, restitution
    ``e``: after an impact at speed ``u`` the flights add up to ``2 e u / (g (1 - e))``):

    >>> def zeno(t, before, after, p):
    ...     g, e = p
    ...     u = abs(before[1])
    ...     return (t + 2.0 * e * u / (g * (1.0 - e)), (0.0, 0.0)) if u < 1e-3 else None
    >>> landing = Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v},
    ...                 rest="floor", accumulation=zeno)
    >>> import impactosc
    >>> from impactosc import HybridMode, HybridSystem
    >>> g = symbols("g")
    >>> ball = HybridSystem("x v", {"g": 9.81, "e": 0.8},
    ...                     [HybridMode("flight", {x: v, v: -g}), HybridMode("floor", {x: 0.0, v: 0.0})], [landing])
    >>> rest = impactosc.simulate(ball, 10.0, [1.0, 0.0]).events[-1]   # sqrt(2 / g) (1 + 2 e / (1 - e))
    >>> rest.kind, round(rest.t, 9), rest.state_after
    ('rest', 4.063712769, (0.0, 0.0))
    """

    name: str
    expression: Any
    direction: int
    armed: Any
    to: Any = None
    reset: Any = ()
    terminal: bool = True
    rest: Any = None
    rest_reset: Any = ()
    accumulation: Any = None
    choose: Any = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise TypeError(f"a guard's name must be a non-empty string, got {self.name!r}")
        where = f"guard {self.name!r}"
        object.__setattr__(self, "expression", _expression(f"{where}: expression", self.expression))
        if self.direction not in DIRECTIONS or isinstance(self.direction, bool):
            raise ValueError(f"{where}: direction must be -1, 0 or 1, got {self.direction!r}")
        object.__setattr__(self, "direction", int(self.direction))
        object.__setattr__(self, "armed", _names(f"{where}: armed", self.armed))
        object.__setattr__(self, "to", _names(f"{where}: to", self.to))
        object.__setattr__(self, "reset", _by_name(f"{where}: reset", dict(self.reset)))
        if not self.terminal and (self.to or self.reset):
            raise ValueError(f"{where}: a non-terminal guard (terminal=False) has no transition or reset, "
                             f"got to={self.to!r}, reset={dict(self.reset)!r}")
        if self.rest is not None and (not isinstance(self.rest, str) or not self.rest):
            raise TypeError(f"{where}: rest must be the name of a mode, got {self.rest!r}")
        object.__setattr__(self, "rest_reset", _by_name(f"{where}: rest_reset", dict(self.rest_reset)))
        if self.rest_reset and self.rest is None:
            raise ValueError(f"{where}: rest_reset={dict(self.rest_reset)!r} is given without a rest mode (rest=...)")
        if self.rest is not None and not self.terminal:
            raise ValueError(f"{where}: a non-terminal guard (terminal=False) has no rest mode, got rest={self.rest!r}")
        if self.accumulation is not None:
            if not (callable(self.accumulation) or isinstance(self.accumulation, EngineRule)):
                raise TypeError(f"{where}: accumulation must be a callable rule(t, before, after, parameters), "
                                f"got {self.accumulation!r}")
            if self.rest is None:
                raise ValueError(f"{where}: accumulation={self.accumulation!r} is given without a rest mode "
                                 "(rest=...), where the run goes on after the accumulation")
            try:
                hash(self.accumulation)
            except TypeError:
                raise TypeError(f"{where}: accumulation must be hashable (it is part of the system's structure), "
                                f"got {self.accumulation!r}") from None
        if self.choose is not None:
            if not (callable(self.choose) or isinstance(self.choose, EngineRule)):
                raise TypeError(f"{where}: choose must be a callable rule(t, state, parameters) that returns a mode's "
                                f"name or None, got {self.choose!r}")
            if not self.terminal:
                raise ValueError(f"{where}: a non-terminal guard (terminal=False) has no transition to choose, "
                                 f"got choose={self.choose!r}")
            try:
                hash(self.choose)
            except TypeError:
                raise TypeError(f"{where}: choose must be hashable (it is part of the system's structure), "
                                f"got {self.choose!r}") from None


@dataclass(frozen=True, eq=False)
class HybridSystem:
    """A piecewise-smooth system of any dimension: states, parameters, modes and guards.

    Parameters
    ----------
    states : str or sequence of str
        The state names in order (``"x v"`` or ``("x", "v")``).
    parameters : mapping str -> float, optional
        The parameters and their values; the expressions use them as symbols of the same name.
    modes : sequence of HybridMode
        Their fields are completed at construction: a tuple of rates in the order of the
        states, then of the integrals (0 where a mode gives no integrand).
    guards : sequence of Guard
    integrals : str or sequence of str, optional
        Names of integrals (a contact force's impulse, a dissipated energy), each integrated
        exactly with the flow as an extra state, with the rate each mode gives in
        its ``integrands`` (:class:`HybridMode`).
    period : float or expression, optional
        The forcing period (for stroboscopic maps), a number or an expression in the
        parameters such as ``2 * pi / Omega``. The simulation loops also use it to jump over
        a long stay in a *frozen* mode (every state's rate zero, such as a mass stuck by
        friction): after a whole period there without an event, whose guards take the same
        values at its two ends, they go on to the last whole period before the end time.
    scale : float or expression, optional
        The size of the states near rest, a number or an expression in the parameters (default 1):
        the loops take a guard to lie on its zero within ``touch_tol (scale + max |state|)``, a
        touch of zero within rounding as ``16 eps (scale + max |state|)`` and an extremum of a
        guard as a grazing within ``graze_tol (scale + max |state|)``. With the default, a system
        whose forces and states are all far below 1 has every guard on its zero at every instant
        (a mass stuck with forcing and friction of 1e-20 was released at once, its releases
        taken for touches); it declares the size of its forces here (the oscillator family
        declares ``min(1, F + beta + beta_s)``, :func:`~impactosc.model.hybrid.oscillator_system`).
    section : str, optional
        The name of a guard whose events are the Poincare section of an autonomous system
        (:class:`impactosc.dynamics.hybrid_map.HybridMap` maps the state on it to its next
        return when the system has no period).
    name : str, optional
        A label for messages and tables.

    Raises
    ------
    TypeError, ValueError
        Naming the mode, guard or expression at fault: an unknown symbol, a vector field or
        reset of the wrong size, a guard armed in no mode or in an unknown one, a transition
        to an unknown mode, a duplicate name.

    Examples
    --------
    The bouncing ball, ``x'' = -g`` with ``v -> -e v`` at ``x = 0``:

    >>> from impactosc import Guard, HybridSystem, HybridMode, symbols
    >>> x, v, g, e = symbols("x v g e")
    >>> ball = HybridSystem(
    ...     states="x v", parameters={"g": 9.81, "e": 0.8},
    ...     modes=[HybridMode("flight", {x: v, v: -g})],
    ...     guards=[Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})])
    >>> ball.dimension, ball.parameter_names
    (2, ('g', 'e'))
    """

    states: Any
    parameters: Any = ()
    modes: Any = ()
    guards: Any = ()
    integrals: Any = ()
    period: Any = None
    section: str | None = None
    name: str = "system"
    scale: Any = None
    structure: tuple = field(init=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "states", _names("states", self.states))
        object.__setattr__(self, "integrals", _names("integrals", self.integrals))
        params = dict(self.parameters)
        values = []
        for key, value in params.items():
            if not isinstance(key, str):
                raise TypeError(f"parameters: names must be strings, got {key!r}")
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
                raise ValueError(f"parameter {key!r} must be a finite real number, got {value!r}")
            values.append((key, float(value)))
        object.__setattr__(self, "parameters", tuple(values))
        object.__setattr__(self, "modes", tuple(self.modes))
        object.__setattr__(self, "guards", tuple(self.guards))
        if self.period is not None:
            object.__setattr__(self, "period", _expression("period", self.period))
        if self.scale is not None:
            object.__setattr__(self, "scale", _expression("scale", self.scale))
        for m in self.modes:
            if not isinstance(m, HybridMode):
                raise TypeError(f"modes must be impactosc.HybridMode objects, got {m!r}")
        for g in self.guards:
            if not isinstance(g, Guard):
                raise TypeError(f"guards must be impactosc.Guard objects, got {g!r}")
        check_system(self)
        object.__setattr__(self, "modes", tuple(_complete_mode(self, m) for m in self.modes))
        object.__setattr__(self, "structure", _structure(self))

    # -- names and indices ------------------------------------------------------------
    @property
    def dimension(self) -> int:
        """The number of states."""
        return len(self.states)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(k for k, _ in self.parameters)

    @property
    def parameter_values(self) -> tuple[float, ...]:
        return tuple(v for _, v in self.parameters)

    @property
    def mode_names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.modes)

    @property
    def guard_names(self) -> tuple[str, ...]:
        return tuple(g.name for g in self.guards)

    def mode_index(self, name: str) -> int:
        """The index of the mode ``name``, or a ValueError listing the modes."""
        try:
            return self.mode_names.index(name)
        except ValueError:
            raise ValueError(f"{self.name}: no mode named {name!r}; the modes are {list(self.mode_names)}") from None

    def with_parameters(self, **values: float) -> HybridSystem:
        """A copy with new parameter values (the same structure: compiled code is reused).

        Raises
        ------
        ValueError
            For a name that is not a parameter of the system.
        """
        known = dict(self.parameters)
        for key in values:
            if key not in known:
                raise ValueError(f"{self.name}: {key!r} is not a parameter; the parameters are {list(known)}")
        for key, value in values.items():
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
                raise ValueError(f"parameter {key!r} must be a finite real number, got {value!r}")
            known[key] = float(value)
        # The structure is unchanged, and validated: a copy with the new values, not a new construction.
        new = copy.copy(self)
        object.__setattr__(new, "parameters", tuple(known.items()))
        return new

    def period_value(self) -> float | None:
        """The forcing period at the current parameter values (None when there is none)."""
        if self.period is None:
            return None
        from ._numeric import numeric

        num = numeric(self)
        value = num.period_function()(0.0, [0.0] * len(num.states), self.parameter_values)[0]
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{self.name}: the period {self.period} is {value!r} at the parameters "
                             f"{dict(self.parameters)}; it must be finite and > 0")
        return float(value)

    def scale_value(self) -> float:
        """The size of the states near rest (``scale``) at the current parameter values: 1 without one.

        Raises
        ------
        ValueError
            When it is not a finite number ``>= 0`` there.
        """
        if self.scale is None:
            return 1.0
        from ._numeric import evaluator, numeric

        num = numeric(self)
        fn = _scale_functions.get(self.structure)
        if fn is None:
            fn = _scale_functions[self.structure] = evaluator(num, [num.with_params(self.scale)], "the scale")
        value = fn(0.0, [0.0] * len(num.states), self.parameter_values)[0]
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{self.name}: the scale {self.scale} is {value!r} at the parameters "
                             f"{dict(self.parameters)}; it must be finite and >= 0")
        return float(value)


#: The evaluator of each structure's scale (built on first use).
_scale_functions: dict = {}


def _complete_mode(system: HybridSystem, mode: HybridMode) -> HybridMode:
    """``mode`` with its field as a tuple of rates in state order, then the integrands in integral order."""
    zero = _hy().expression(0.0)
    if mode.field and isinstance(mode.field[0], tuple):
        given = dict(mode.field)
        rates = [given[s] for s in system.states]
    else:
        rates = list(mode.field)
    integrands = dict(mode.integrands)
    rates += [integrands.get(q, zero) for q in system.integrals]
    return replace(mode, field=tuple(rates), integrands=mode.integrands)


class _Structure(tuple):
    """A system's structure: a tuple that hashes once (the key of the compiled-code caches).

    Hashing heyoka expressions walks them (about 0.05 ms for eq. 3), and each run looks its
    integrator and numeric forms up by the structure: the hash is kept after the first. It is
    not pickled (string hashes differ between processes).
    """

    def __hash__(self):
        found = self.__dict__.get("_hash")
        if found is None:
            found = self.__dict__["_hash"] = tuple.__hash__(self)
        return found

    def __reduce__(self):
        return (_Structure, (tuple(self),))


def _structure(system: HybridSystem) -> tuple:
    """Everything a backend compiles: the key of its cache (parameter values left out).

    The expressions are kept as expressions (hashable, compared by structure), never as their
    printed text: heyoka cuts ``str(expr)`` after about 1000 characters with "...", so two
    different long vector fields could print alike and share a compiled integrator.
    """
    modes = tuple((m.name, tuple(m.field), tuple(m.entry), tuple(m.integrands)) for m in system.modes)
    guards = tuple((g.name, g.expression, g.direction, tuple(g.armed), tuple(g.to), tuple(g.reset), g.terminal,
                    g.rest, tuple(g.rest_reset), g.accumulation, g.choose) for g in system.guards)
    return _Structure((tuple(system.states), tuple(system.integrals), tuple(system.parameter_names), system.period,
                       system.section, modes, guards, system.scale))
