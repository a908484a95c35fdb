"""Validation of a :class:`~impactosc.model.hybrid.HybridSystem` at construction.

Every message names the mode, guard or expression at fault and what was expected.
"""

from __future__ import annotations

from collections import Counter


def _duplicates(kind: str, names) -> None:
    twice = [n for n, c in Counter(names).items() if c > 1]
    if twice:
        raise ValueError(f"{kind} names must be unique, {twice} appear more than once")


def _check_symbols(where: str, expr, allowed: set[str]) -> None:
    import heyoka as hy

    unknown = sorted(set(hy.get_variables(expr)) - allowed)
    if unknown:
        raise ValueError(f"{where} uses {unknown}, which are neither states nor parameters "
                         f"(the states and parameters are {sorted(allowed)}): {expr}")


def check_system(system) -> None:
    """Raise a TypeError/ValueError naming what is wrong in ``system`` (see HybridSystem)."""
    if not system.states:
        raise ValueError("states: a system needs at least one state")
    _duplicates("state", system.states)
    _duplicates("integral", system.integrals)
    params = system.parameter_names
    _duplicates("parameter", params)
    clash = sorted(set(system.states) & set(params) | set(system.integrals) & (set(params) | set(system.states)))
    if clash:
        raise ValueError(f"{clash} are named as more than one of states, parameters and integrals")
    if not system.modes:
        raise ValueError("modes: a system needs at least one mode")
    _duplicates("mode", system.mode_names)
    _duplicates("guard", system.guard_names)
    allowed = set(system.states) | set(params)
    for m in system.modes:
        _check_mode(system, m, allowed)
    for g in system.guards:
        _check_guard(system, g, allowed)
    if system.section is not None and system.section not in system.guard_names:
        raise ValueError(f"section names the guard {system.section!r}, which the system does not have "
                         f"(its guards are {list(system.guard_names)})")
    if system.period is not None:
        _check_symbols("period", system.period, set(params))
    if system.scale is not None:
        _check_symbols("scale", system.scale, set(params))


def _check_mode(system, m, allowed: set[str]) -> None:
    where = f"mode {m.name!r}"
    states, n = set(system.states), len(system.states)
    if m.field and isinstance(m.field[0], tuple):
        given = [k for k, _ in m.field]
        _duplicates(f"{where}: field state", given)
        extra = sorted(set(given) - states)
        if extra:
            raise ValueError(f"{where}: field gives rates for {extra}, which are not states "
                             f"(the states are {list(system.states)})")
        missing = [s for s in system.states if s not in given]
        if missing:
            raise ValueError(f"{where}: field gives no rate for the states {missing} "
                             f"(a vector field needs one rate per state: {list(system.states)})")
        exprs = [dict(m.field)[s] for s in system.states]
    else:
        if len(m.field) != n:
            raise ValueError(f"{where}: field has {len(m.field)} rates, the system has {n} states "
                             f"{list(system.states)}")
        exprs = list(m.field)
    for i, e in enumerate(exprs):
        _check_symbols(f"{where}: the rate of {system.states[i]!r}", e, allowed)
    for i, c in enumerate(m.entry):
        _check_symbols(f"{where}: entry[{i}]", c, allowed)
    for q, e in m.integrands:
        if q not in system.integrals:
            raise ValueError(f"{where}: integrand for {q!r}, which is not a declared integral "
                             f"(the integrals are {list(system.integrals)})")
        _check_symbols(f"{where}: the integrand of {q!r}", e, allowed)


def _check_guard(system, g, allowed: set[str]) -> None:
    where = f"guard {g.name!r}"
    _check_symbols(f"{where}: expression", g.expression, allowed)
    if not g.armed:
        raise ValueError(f"{where} is armed in no mode (armed=...: the modes in which it can fire)")
    for name, kind in [(a, "armed") for a in g.armed] + [(t, "to") for t in g.to]:
        if name not in system.mode_names:
            raise ValueError(f"{where}: {kind} names the mode {name!r}, which the system does not have "
                             f"(its modes are {list(system.mode_names)})")
    for key, e in g.reset:
        if key not in system.states:
            raise ValueError(f"{where}: reset of {key!r}, which is not a state (the reset map has one "
                             f"entry per state it changes, among {list(system.states)})")
        _check_symbols(f"{where}: the reset of {key!r}", e, allowed)
    _duplicates(f"{where}: reset state", [k for k, _ in g.reset])
    if g.rest is not None and g.rest not in system.mode_names:
        raise ValueError(f"{where}: rest names the mode {g.rest!r}, which the system does not have "
                         f"(its modes are {list(system.mode_names)})")
    for key, e in g.rest_reset:
        if key not in system.states:
            raise ValueError(f"{where}: rest_reset of {key!r}, which is not a state (among {list(system.states)})")
        _check_symbols(f"{where}: the rest_reset of {key!r}", e, allowed)
    for i, t in enumerate(g.to[:-1]):
        if not system.modes[system.mode_names.index(t)].entry:
            raise ValueError(f"{where}: the candidate mode {t!r} has no entry conditions, so the candidates after "
                             f"it ({list(g.to[i + 1:])}) could never be taken")
