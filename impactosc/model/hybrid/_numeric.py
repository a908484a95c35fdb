"""A hybrid system's expressions in numeric form: parameters as ``par[i]``, Lie derivatives, evaluators.

The backends need the definition in three forms: heyoka expressions with the parameters
as runtime parameters ``hy.par[i]`` (for the Taylor integrator), the Lie derivative
``h' = dh/dt + grad h . f`` of every guard in every mode (its zeros are the guard's
extrema, where a grazing is checked), and functions that evaluate the small per-event
expressions (resets, guard values at a new state, entry conditions, vector fields for
scipy) at a point.

The per-event functions are Python functions generated from the expressions' text (about
1 us a call), checked against heyoka's compiled function (``hy.cfunc``, about 7 us a call
from Python) at a random point when they are built; an expression the generated code
cannot reproduce uses the compiled function.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any

import numpy as np

from ..._util.cache import BuiltOnce
from ..._util.heyoka_log import log_on_stderr

if TYPE_CHECKING:  # annotations only: the definition imports this module for its period
    from ._definition import HybridSystem

__all__ = ["Numeric", "numeric", "evaluator", "Rules", "rules", "gated_sum", "plan"]

_TIME_VAR = "_time"  # the time as a variable, to differentiate with respect to it


def _select(cond, a, b):
    return a if cond else b


def _sigmoid(x):
    return 1.0 / (1.0 + math.exp(-x))


_NAMESPACE = {
    **{name: getattr(math, name) for name in ("sin", "cos", "tan", "exp", "log", "sqrt", "asin", "acos", "atan",
                                              "atan2", "sinh", "cosh", "tanh", "asinh", "acosh", "atanh", "erf")},
    "select": _select, "relu": lambda x: x if x > 0.0 else 0.0, "sigmoid": _sigmoid,
    "__builtins__": {},
}


class Numeric:
    """The numeric forms of one system's structure (shared by every parameter value).

    Attributes
    ----------
    states : list of heyoka variables
        The state variables, then the integrals' (the integrator's state vector).
    rates : list of list of expressions
        ``rates[m]`` the vector field of mode ``m`` (states then integrands), parameters as ``par[i]``.
    guards : list of expressions
        Each guard's expression, parameters as ``par[i]``.
    lie : dict (mode, guard) -> expression
        The Lie derivative of each guard armed in each mode.
    """

    def __init__(self, system: HybridSystem):
        import heyoka as hy

        self.system = system
        self.rules: Rules | None = None  # the per-event functions, built on first use
        self.second: dict = {}  # (mode, guard) -> the guard's second Lie derivative, built on first use
        self._period = None
        names = list(system.states) + list(system.integrals)
        self.states = list(hy.make_vars(*names)) if len(names) > 1 else [hy.make_vars(*names)]
        self.n_params = len(system.parameters)
        subs = {name: hy.par[i] for i, name in enumerate(system.parameter_names)}
        self._subs = subs
        self.rates = [[hy.subs(r, subs) for r in m.field] for m in system.modes]
        self.guards = [hy.subs(g.expression, subs) for g in system.guards]
        self.armed = [tuple(system.mode_names.index(a) for a in g.armed) for g in system.guards]
        self.armed_in = [tuple(g for g, modes in enumerate(self.armed) if m in modes)
                         for m in range(len(system.modes))]
        # each guard's direction, whether it is terminal and its candidate next modes, as the loops read them
        self.direction = [g.direction for g in system.guards]
        self.terminal = [g.terminal for g in system.guards]
        self.to = [tuple(system.mode_names.index(m) for m in g.to) for g in system.guards]
        self.rest = [system.mode_names.index(g.rest) if g.rest is not None else -1 for g in system.guards]
        self.lie = {(m, g): self.lie_derivative(self.guards[g], self.rates[m])
                    for g, modes in enumerate(self.armed) for m in modes}

    def lie_derivative(self, expr, rates):
        """``dh/dt + sum_i dh/dy_i f_i`` of ``expr`` along ``rates``.

        heyoka differentiates with respect to variables only: the time becomes the variable
        ``_time`` for the derivative and is put back after.
        """
        import heyoka as hy

        tvar = hy.make_vars(_TIME_VAR)
        timed = hy.subs(expr, {hy.time: tvar})
        used = set(hy.get_variables(expr))
        terms = [hy.diff(timed, _TIME_VAR)]
        terms += [hy.diff(timed, str(var)) * rate for var, rate in zip(self.states, rates, strict=True)
                  if str(var) in used]
        total = hy.sum(terms) if len(terms) > 1 else terms[0]
        return hy.subs(total, {_TIME_VAR: hy.time})

    def derivatives(self, expr) -> list:
        """``[d expr / d y_j for every state and integral] + [d expr / dt] + [d expr / d p_k for every parameter]``."""
        import heyoka as hy

        tvar = hy.make_vars(_TIME_VAR)
        timed = hy.subs(expr, {hy.time: tvar})
        out = [hy.diff(timed, str(var)) for var in self.states] + [hy.diff(timed, _TIME_VAR)]
        out += [hy.diff(timed, hy.par[k]) for k in range(self.n_params)]
        return [hy.subs(e, {_TIME_VAR: hy.time}) for e in out]

    def period_function(self):
        """``f(t, y, p) -> (T, dT/dp_1, ..., dT/dp_P)`` of the system's forcing period (built on first use)."""
        import heyoka as hy

        if self._period is None:
            period = self.with_params(self.system.period)
            exprs = [period] + [hy.diff(period, hy.par[k]) for k in range(self.n_params)]
            self._period = evaluator(self, exprs, "the period")
        return self._period

    def with_params(self, expr):
        """``expr`` (in the named parameters) with the parameters as ``par[i]``."""
        import heyoka as hy

        return hy.subs(expr, self._subs)


_by_structure: BuiltOnce[Numeric] = BuiltOnce()


def numeric(system: HybridSystem) -> Numeric:
    """The :class:`Numeric` of ``system``'s structure (cached: shared across parameter values)."""
    return _by_structure.get(system.structure, lambda: Numeric(system))


def evaluator(num: Numeric, exprs, label: str):
    """A function ``f(t, y, p) -> tuple of float`` evaluating ``exprs`` (parameters as ``par[i]``).

    Generated Python source from the expressions' text, checked against ``hy.cfunc`` at a
    random point; the compiled function is used when the two disagree or the text uses a
    function the generated code does not know. ``label`` names the expressions in errors.
    """
    import heyoka as hy

    exprs = list(exprs)
    n = len(num.states)
    names = [f"_y{i}" for i in range(n)]
    internal = hy.make_vars(*names) if n > 1 else [hy.make_vars(*names)]
    renamed = [hy.subs(e, {str(v): w for v, w in zip(num.states, internal, strict=True)}) for e in exprs]
    if not exprs:
        return lambda t, y, p: ()
    compiled = log_on_stderr(lambda: hy.cfunc(exprs, num.states))  # heyoka's log on stderr (see there)
    args = ", ".join(names)
    pars = ", ".join(f"p{i}" for i in range(num.n_params))
    body = ["def _f(t, y, p):", f"    {args}{',' if n == 1 else ''} = y"]
    if num.n_params:
        body.append(f"    {pars}{',' if num.n_params == 1 else ''} = p")
    body.append(f"    return ({', '.join(str(e) for e in renamed)},)")
    source = "\n".join(body)
    rng = np.random.default_rng(12345)
    y = rng.uniform(0.3, 0.9, n)
    p = rng.uniform(0.3, 0.9, num.n_params)
    t = 0.37
    n_pars = compiled.nparams
    with np.errstate(all="ignore"):
        want = compiled(y, pars=p[:n_pars], time=t) if n_pars else compiled(y, time=t)
    try:
        space = dict(_NAMESPACE)
        exec(compile(source, f"<{label}>", "exec"), space)  # noqa: S102 - our own text of heyoka expressions
        fast = space["_f"]
        got = np.array(fast(t, tuple(y), tuple(p)), dtype=float)
        agree = bool(np.allclose(got, want, rtol=1e-12, atol=1e-300, equal_nan=True))
    except Exception:  # an operator or function the generated code does not reproduce
        agree = False
    if agree:
        fast.texts = [str(e) for e in renamed]  # checked: transition plans compose them (see plan)
        return fast
    out = np.empty(len(exprs))

    def slow(t, y, p):
        pars = np.asarray(p[:n_pars], dtype=float)
        compiled(np.asarray(y, dtype=float), pars=pars, time=t, outputs=out)
        return tuple(out.tolist())

    return slow


def plan(num: Numeric, rules: Rules, g: int, mode: int):
    """The transition of guard ``g`` fired in ``mode`` as one generated function, or None.

    ``f(t, y, p, touch) -> (target, after, next)``: the reset (``after`` is ``y`` itself for
    the identity), the first candidate mode whose entry conditions hold (``target = -1``
    when none does), and what the state after does at a guard armed in the target, as
    :meth:`~impactosc.engine._hybrid.Switch.pending` decides it: ``next = -1`` on none,
    a guard's index when it lies on that guard and crosses it now (its Lie derivative beyond
    the tolerance, its way), ``-2`` when only the full check can tell (a tangency). The same
    arithmetic as the separate evaluators, whose checked texts it is built from, in one call
    instead of a dozen (it runs at every event): each ``select`` as a conditional expression
    (:func:`_conditional`), each repeated ``sin``/``cos`` and arithmetic group computed once
    (:func:`_hoisted`). None when one of them is not generated code.
    """
    system = num.system
    n, n_all = system.dimension, len(num.states)
    targets = num.to[g] or (mode,)
    multiple = len(targets) > 1
    reset = rules.reset[g]
    pieces = [reset] if reset is not None else []
    if multiple:
        pieces += [rules.entry[m] for m in targets if rules.entry[m] is not None]
    pieces += [rules.probe[m] for m in targets if num.armed_in[m]]
    if not all(hasattr(f, "texts") for f in pieces):
        return None
    names = [f"_y{i}" for i in range(n_all)]
    lines = ["def _plan(t, y, p, touch):", f"    {', '.join(names)}{',' if n_all == 1 else ''} = y"]
    if num.n_params:
        pars = ", ".join(f"p{i}" for i in range(num.n_params))
        lines.append(f"    {pars}{',' if num.n_params == 1 else ''} = p")
    after = "y"
    if reset is not None:
        lines.append(f"    {', '.join(names[:n])}{',' if n == 1 else ''} = "
                     f"{', '.join(f'({e})' for e in reset.texts)},")
        after = "_after"
        lines.append(f"    _after = [{', '.join(names)}]")

    def largest(vs):
        return f"_abs({vs[0]})" if len(vs) == 1 else f"_max({', '.join(f'_abs({v})' for v in vs)})"

    # One scale for both tests: a guard beyond it on every target is on none (pending's quicker
    # test with all states and integrals only sends more states to the detailed test, which
    # answers -1 for every guard beyond this scale).
    lines.append(f"    _scale = touch * (1.0 + {largest(names[:n])})")
    body: list[str] = []
    for k, m in enumerate(targets):
        test = "True"
        entry = rules.entry[m]
        if multiple and entry is not None:
            test = " and ".join(f"({c}) >= 0.0" for c in entry.texts)
        body.append(f"    {'if' if k == 0 else 'elif'} {test}:")
        armed = num.armed_in[m]
        texts = rules.probe[m].texts if armed else []
        count = len(armed)
        # a marker never fires here; a guard crossed without a reset is not fired again
        fires = [i for i, guard in enumerate(armed) if num.terminal[guard] and not (guard == g and reset is None)]
        if not fires:
            body.append(f"        return {m}, {after}, -1")
            continue
        body.append(f"        if {' and '.join(f'_abs({texts[i]}) > _scale' for i in fires)}:")
        body.append(f"            return {m}, {after}, -1")
        for i in fires:
            guard = armed[i]
            d = num.direction[guard]
            body.append(f"        if _abs({texts[i]}) <= _scale:")
            body.append(f"            _rate = {texts[count + i]}")
            body.append("            if _abs(_rate) <= _scale:")
            body.append(f"                return {m}, {after}, -2")
            body.append(f"            if {'True' if d == 0 else f'{d} * _rate > 0.0'}:")
            body.append(f"                return {m}, {after}, {guard}")
        body.append(f"        return {m}, {after}, -1")
    body.append(f"    return -1, {after}, -1")
    lines += _hoisted([_conditional(line) for line in body])
    space = {**_NAMESPACE, "_abs": abs, "_max": max}
    exec(compile("\n".join(lines), f"<transition of guard {system.guards[g].name!r}>", "exec"), space)  # noqa: S102
    return space["_plan"]


def _conditional(text: str) -> str:
    """``text`` with each ``select(c, a, b)`` written as ``(a if c else b)``: the same value, without the call,
    and only the branch taken is evaluated (a Python call costs more than the arithmetic of eq. 3's stick test)."""
    start = _SELECT.search(text)
    if start is None:
        return text
    i = start.end()  # just after "select("
    args, depth, first = [], 0, i
    for k in range(i, len(text)):
        c = text[k]
        if c == "(":
            depth += 1
        elif c == ")" and depth:
            depth -= 1
        elif c in ",)" and not depth:
            args.append(text[first:k].strip())
            first = k + 1
            if c == ")":
                break
    else:  # pragma: no cover - our own balanced text
        return text
    if len(args) != 3:  # pragma: no cover - heyoka's select takes three arguments
        return text
    cond, a, b = (_conditional(arg) for arg in args)
    return text[:start.start()] + f"({a} if {cond} else {b})" + _conditional(text[k + 1:])


_SELECT = re.compile(r"(?<![\w])select\(")

_HOISTED = ("sin", "cos")  # total on finite numbers: evaluating one early never raises where the branch would not


def _hoisted(body: list[str]) -> list[str]:
    """``body`` with each ``sin(...)``/``cos(...)`` and each arithmetic group it evaluates more than once
    computed once, first.

    The same arithmetic (the same call or operation on the same operands gives the same float);
    a transition's entry conditions and guard checks repeat the forcing's ``cos`` a few times
    and eq. 3's net force ``((F cos - x) - K (x - gap))`` eight times (:func:`_shared`).
    """
    text = "\n".join(body)
    calls: dict[str, int] = {}
    for name in _HOISTED:
        start = text.find(f"{name}(")
        while start >= 0:
            if start == 0 or not (text[start - 1].isalnum() or text[start - 1] == "_"):
                depth, end = 0, start + len(name)
                for end in range(start + len(name), len(text)):
                    depth += {"(": 1, ")": -1}.get(text[end], 0)
                    if depth == 0:
                        break
                call = text[start:end + 1]
                calls[call] = calls.get(call, 0) + 1
            start = text.find(f"{name}(", start + 1)
    repeated = sorted((c for c, k in calls.items() if k > 1), key=len)
    defs = []
    for i, call in enumerate(repeated):
        defs.append(f"    _h{i} = {call}")
        # the call itself, not the tail of a longer name (acos(t) holds cos(t))
        pattern = re.compile(r"(?<![A-Za-z0-9_])" + re.escape(call))
        text = pattern.sub(f"_h{i}", text)
        repeated[i + 1:] = [pattern.sub(f"_h{i}", c) for c in repeated[i + 1:]]
    return defs + _shared(text.split("\n"))


#: A group that may be computed before the branch that uses it: names, numbers, ``+ - *`` and
#: parentheses only (on floats these never raise; a call, a division, a power or a comparison may).
# The names possessive: with plain quantifiers a long group that fails (a power-law flange's select)
# backtracked through every split of its names, and building one transition took minutes. The group's
# own repetition may not be possessive: one of its alternatives is the closing parenthesis, which it
# would then keep from the pattern's end (no group matched: nothing was hoisted).
_ARITHMETIC = re.compile(r"\((?:[\w.]++|\s[-+*]\s|[-(]|\))+\)")
_OPERATOR = re.compile(r"\s[-+*]\s")
_ASSIGNED = re.compile(r"^\s*(\w+)\s*=[^=]", re.MULTILINE)
_WORD = re.compile(r"[A-Za-z_]\w*")


def _shared(body: list[str]) -> list[str]:
    """``body`` with each parenthesised arithmetic group that it evaluates more than once computed once, first.

    Longest first (a group inside a hoisted one is counted in its definition); a group that
    uses a name ``body`` assigns, or a call (a call's argument list is not a group), stays.
    The definitions go before ``body``, each after those it uses.
    """
    text = "\n".join(body)
    local = set(_ASSIGNED.findall(text))
    defs: list[tuple[str, str]] = []
    while True:
        counts: dict[str, int] = {}
        for source in [e for _, e in defs] + [text]:
            for group in _groups(source):
                counts[group] = counts.get(group, 0) + 1
        repeated = [g for g, k in counts.items()
                    if k > 1 and _ARITHMETIC.fullmatch(g) and _OPERATOR.search(g) and "**" not in g
                    and not local.intersection(_WORD.findall(g))]
        if not repeated:
            break
        group = max(repeated, key=len)
        name = f"_c{len(defs)}"
        # the group itself, not the argument list of a call that reads the same
        pattern = re.compile(r"(?<![\w])" + re.escape(group))
        text = pattern.sub(name, text)
        defs = [(n, pattern.sub(name, e)) for n, e in defs] + [(name, group)]
    # a later (shorter) group never holds an earlier one: in reverse order each comes after those it uses
    return [f"    {n} = {e}" for n, e in reversed(defs)] + text.split("\n")


def _groups(text: str) -> list[str]:
    """The parenthesised groups of ``text`` that are not a call's argument list, one per occurrence."""
    out, opened = [], []
    for i, c in enumerate(text):
        if c == "(":
            opened.append(i)
        elif c == ")" and opened:
            start = opened.pop()
            if start == 0 or not (text[start - 1].isalnum() or text[start - 1] == "_"):
                out.append(text[start:i + 1])
    return out


class Rules:
    """The per-event functions of one structure, built on first use and kept (see :func:`rules`).

    ``reset[g]`` (``None`` for the identity), ``entry[m]`` (``None`` without conditions),
    ``probe[m]``, which gives the values of the guards armed in ``m`` followed by their Lie
    derivatives, and ``values[m]``, the values alone, each ``f(t, y, p) -> tuple``.
    """

    def __init__(self, num: Numeric):
        system = num.system
        n = system.dimension
        self.reset: list = []
        for guard in system.guards:
            given = dict(guard.reset)
            if not given:
                self.reset.append(None)
                continue
            exprs = [num.with_params(given[s]) if s in given else num.states[i] for i, s in enumerate(system.states)]
            self.reset.append(evaluator(num, exprs, f"reset of guard {guard.name!r}"))
        self.rest_reset: list = []
        for guard in system.guards:
            given = dict(guard.rest_reset)
            exprs = [num.with_params(given[s]) if s in given else num.states[i] for i, s in enumerate(system.states)]
            self.rest_reset.append(evaluator(num, exprs, f"rest reset of guard {guard.name!r}") if given else None)
        self.entry = [evaluator(num, [num.with_params(c) for c in m.entry], f"entry of mode {m.name!r}")
                      if m.entry else None for m in system.modes]
        self.probe = []
        self.values = []
        for m, mode in enumerate(system.modes):
            armed = num.armed_in[m]
            exprs = [num.guards[g] for g in armed] + [num.lie[(m, g)] for g in armed]
            self.probe.append(evaluator(num, exprs, f"guards of mode {mode.name!r}"))
            # the values alone: after each transition the loops ask whether the state lies on a guard
            self.values.append(evaluator(num, exprs[:len(armed)], f"guard values of mode {mode.name!r}"))
        self.field = [evaluator(num, num.rates[m], f"vector field of mode {system.modes[m].name!r}")
                      for m in range(len(system.modes))]
        self.guard = [evaluator(num, [num.guards[g]], f"guard {system.guards[g].name!r}")
                      for g in range(len(system.guards))]
        self.dimension = n
        # the transition's generated function (see plan) of guard g in mode m at g * modes + m: None until
        # first asked for, then the function, or False where the transition is not generated code
        self.plans: list = [None] * (len(system.guards) * len(system.modes))
        self._num = num
        self._jacobians: dict[int, tuple] = {}

    def jacobians(self, g: int) -> tuple:
        """``(guard, reset)`` functions of guard ``g``'s derivatives (built on first use), each ``f(t, y, p)``.

        ``guard`` gives ``dh/dy`` (every state and integral), ``dh/dt`` and ``dh/dp`` (every
        parameter); ``reset`` gives, row by row for each state, ``dR_i/dy``, ``dR_i/dt``,
        ``dR_i/dp`` (``None`` for the identity reset).
        """
        found = self._jacobians.get(g)
        if found is None:
            num = self._num
            guard = num.system.guards[g]
            h = num.guards[g]
            guard_fn = evaluator(num, num.derivatives(h), f"derivatives of guard {guard.name!r}")
            reset_fn = None
            given = dict(guard.reset)
            if given:
                rows = []
                for i, s in enumerate(num.system.states):
                    rows += num.derivatives(num.with_params(given[s]) if s in given else num.states[i])
                reset_fn = evaluator(num, rows, f"derivatives of the reset of guard {guard.name!r}")
            found = self._jacobians[g] = (guard_fn, reset_fn)
        return found


def rules(system: HybridSystem) -> Rules:
    """The :class:`Rules` of ``system``'s structure (built once per structure)."""
    num = numeric(system)
    found = num.rules
    if found is None:
        found = num.rules = Rules(num)
    return found


def gated_sum(exprs_by_mode, indicators):
    """``sum_m [mode == m] e_m``, one term per distinct expression, zeros left out.

    ``indicators[m]`` is the expression of ``[mode == m]`` (a runtime parameter): the vector
    field of every mode in one expression, for one integrator per system.
    """
    import heyoka as hy

    # Keyed by the expression itself (hashable, compared by structure), never by its printed
    # text, which heyoka cuts after about 1000 characters.
    groups: dict[Any, tuple] = {}
    for m, e in enumerate(exprs_by_mode):
        key = e
        if e == hy.expression(0.0):
            continue
        expr, modes = groups.get(key, (e, []))
        modes.append(m)
        groups[key] = (expr, modes)
    terms = []
    for expr, modes in groups.values():
        gate = indicators[modes[0]] if len(modes) == 1 else hy.sum([indicators[m] for m in modes])
        terms.append(gate * expr)
    if not terms:
        return hy.expression(0.0)
    return terms[0] if len(terms) == 1 else hy.sum(terms)
