"""The rules a hybrid system's guard declares, as the loops call them (``Guard.choose``, ``Guard.accumulation``).

A guard's transition rule (``Guard.choose``) chooses the mode its crossing leads to where the entry
conditions would decide a tie by rounding; its accumulation rule (``Guard.accumulation``) recognises
an accumulation of its events from the state at one of them. Either is a callable of the user's, or a
declaration of the model (:class:`~impactosc.model.hybrid._definition.EngineRule`) that names physics
the engine holds once: the built-in family's stick test at rest (:func:`stick_test`, for
:class:`~impactosc.model.hybrid._oscillator_system.StickTest`) and its chatter on a rigid flange
(:func:`wall_chatter`, for :class:`~impactosc.model.hybrid._oscillator_system.WallChatter`).
:class:`~impactosc.engine._hybrid.Switch` resolves them once per run.
"""

from __future__ import annotations

import numpy as np

from ..model._rule import P_RIGID, beyond, motion_at_rest
from ..model.hybrid._definition import HybridSystem
from ..model.hybrid._oscillator_system import StickTest, WallChatter
from ._chatter import J_SIZE, J_T_INF, J_WALL, predict_jump

__all__ = ["choice_rule", "accumulation_rule", "stick_test", "wall_chatter"]


def choice_rule(guard, system: HybridSystem):
    """The callable of ``guard``'s transition rule (``Guard.choose``), ``rule(t, after, p) -> mode index or -1``,
    or None: the engine's stick test for a region of the family, a user's rule with its answers checked."""
    rule = guard.choose
    if rule is None:
        return None
    if isinstance(rule, StickTest):
        return stick_test(rule, system)
    names = system.mode_names

    def chosen(t, after, p):
        answer = rule(t, tuple(after), p)
        if answer is None:
            return -1
        if answer not in names:
            raise RuntimeError(f"guard {guard.name!r}: its transition rule (choose) answered {answer!r} at t={t!r}, "
                               f"which is not a mode of {system.name} (its modes are {list(names)}, or None)")
        return names.index(answer)

    return chosen


def stick_test(spec: StickTest, system: HybridSystem):
    """The engine's stick test at rest (:func:`impactosc.model._rule.motion_at_rest`) as a region's transition rule.

    ``rule(t, state, p)``: the index of the mode of ``spec.region`` with the motion the test
    gives at ``(t, x)`` (stick, or slip towards the net force; at a tie the forcing's trend
    decides), for the member that the parameter values ``p`` describe (:meth:`StickTest.member`);
    -1 on a rigid flange's wall, where the wall's rest decides, and for values that describe no
    member (``beta_s < beta``), where the entry conditions decide. The built-in engine decides
    every stop and release with the same call.
    """
    names = system.parameter_names
    # motion 0, 1, -1; moving into a power-law flange, the mode with its boundary layer's edge ahead
    # (oscillator_system's "upper_layer+", "lower_layer-": the spring comes on at the edge)
    names_of = set(system.mode_names)
    by_motion = [system.mode_index(f"{spec.region}_layer{s}" if f"{spec.region}_layer{s}" in names_of
                                   else f"{spec.region}{s}") for s in ("0", "+", "-")]
    x = spec.position
    values, params, rigid = None, None, False  # the parameter values of the run, their member's vector

    def rule(t, state, p):
        nonlocal values, params, rigid
        if p is not values:  # (a run's Switch passes the same tuple at every event: one member per run)
            values = p
            try:
                params = spec.member(names, p)._p
                rigid = bool(params[P_RIGID] != 0.0)
            except ValueError:  # values no member has (beta_s < beta, as a parameter derivative's differences take)
                params = None
        if params is None or (rigid and beyond(params, state[x]) != 0):
            return -1
        return by_motion[motion_at_rest(params, t, state[x])[0]]

    return rule


def accumulation_rule(rule):
    """The callable of a guard's accumulation rule: the engine's chatter for a rigid flange of the family."""
    if isinstance(rule, WallChatter):
        return wall_chatter(rule)
    return rule


def wall_chatter(spec: WallChatter):
    """The engine's chatter rule (:mod:`impactosc.engine._chatter`) for the rigid flange ``spec`` describes.

    ``rule(t, before, after, p)`` at an impact of speed ``|v|`` (before the reset) on the flange of
    ``spec.side``: the accumulation time ``t_inf`` and the state at rest on the wall, when the
    engine's local model (:func:`~impactosc.engine._chatter.predict_jump`, the one copy) predicts the
    rest of the sequence to its time tolerance, else None. ``p`` are the system's parameter values,
    read as the member they describe (:meth:`WallChatter.member`). The engine's loop decides with the
    same call at the same impact, so the two loops jump at the same impact.
    """
    side, x, v = spec.side, spec.position, spec.velocity
    row = np.empty(J_SIZE)

    def rule(t, before, after, p):
        if not predict_jump(spec.member(tuple(p))._p, float(t), side, abs(float(before[v])), 1, row):
            return None
        state = [0.0, 0.0]
        state[x] = float(row[J_WALL])
        return float(row[J_T_INF]), state

    return rule
