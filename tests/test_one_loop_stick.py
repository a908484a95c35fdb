"""Issue 27 item 4: the hybrid loops decide a tie at rest with a guard's transition rule (``Guard.choose``).

The oscillator family's stops and releases carry the engine's stick test
(``model._rule.motion_at_rest``); a user's ``stick_slip`` takes a rule of its own. Checked
against the closed-form ``exact`` backend, on the hybrid heyoka loop directly
(``run_on_hybrid_loop``, not the heyoka backend's dispatch).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, stick_slip, symbols
from impactosc.backends.heyoka._replay import run_on_hybrid_loop

x, v, F, w, phase = symbols("x v F w phase")


def hybrid(osc, t_end, x0, v0):
    return run_on_hybrid_loop(osc, t_end, x0, v0, record="full", max_events=10_000, tol=2.0**-52, max_wall_time=60.0)


def tie_system(choose=None):
    """A frictionless mass at rest on x = -1 under F cos(w t + pi): the net force 1 - cos(w t) is zero at
    t = 0 with a zero first derivative (rounded to -F w sin(pi) = -1.2e-28 for w = 1e-12)."""
    modes, guards = stick_slip("m", v, F * impactosc_cos(w) - x, 0.0, rates={x: v}, choose=choose)
    return HybridSystem("x v", {"F": 1.0, "w": 1e-12, "phase": math.pi}, modes, guards, period=2 * math.pi / w)


def impactosc_cos(w_):
    import heyoka as hy

    return hy.cos(w_ * hy.time + phase)


def slips_up_at_a_tie(t, state, p):
    """The tie's rule: where the net force is zero to rounding the mass moves the way it grows (up)."""
    force, w_, ph = p
    f = force * math.cos(w_ * t + ph) - state[0]
    return "m+" if abs(f) <= 1e-12 else None


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_users_transition_rule_decides_the_tie_at_rest(backend):
    """Without a rule, the stop's entry conditions decided the tie by rounding: stop, release and stop at
    one instant; with it the mass slips up from rest and never stops (x + 1 = w^2 t^4 / 24, below rounding)."""
    sol = impactosc.simulate(tie_system(slips_up_at_a_tie), 1.0, [-1.0, 0.0], mode="m+", backend=backend)
    assert sol.status == 0, sol.message
    assert [e.kind for e in sol.events if e.kind == "crossing"] == []
    assert sol.state_final[0] == pytest.approx(-1.0, abs=1e-12)


def test_a_start_at_rest_without_a_mode_takes_the_rules_mode():
    """The entry conditions admit the stuck mode first (|f| <= 0 at f = 0); the rule at the start says slip up."""
    sol = impactosc.simulate(tie_system(slips_up_at_a_tie), 1.0, [-1.0, 0.0])
    assert sol.status == 0, sol.message
    assert all(e.kind != "crossing" for e in sol.events)
    assert sol.pieces[0][1] == "m+"


def test_a_rule_that_answers_no_mode_fails_the_run_with_its_name():
    def wrong(t, state, p):
        return "sliding"

    sol = impactosc.simulate(tie_system(wrong), 1.0, [-1.0, 0.0], mode="m+")
    assert sol.status == -1
    assert "'m+ stop'" in sol.message or "release" in sol.message
    assert "'sliding'" in sol.message and "choose" in sol.message


@pytest.mark.parametrize("choose, error, words", [
    (42, TypeError, ["guard 'stop'", "choose", "42"]),
    ([lambda *a: None], TypeError, ["guard 'stop'", "choose"]),
])
def test_a_bad_rule_is_named_at_construction(choose, error, words):
    with pytest.raises(error) as info:
        Guard("stop", v, -1, armed="m+", to="m0", choose=choose)
    for word in words:
        assert word in str(info.value)


def test_a_marker_has_no_transition_to_choose():
    with pytest.raises(ValueError, match="guard 'mark'.*non-terminal"):
        Guard("mark", v, -1, armed="m+", terminal=False, choose=slips_up_at_a_tie)


def test_a_rule_is_part_of_the_structure():
    assert tie_system(slips_up_at_a_tie).structure != tie_system().structure


def test_a_systems_scale_is_checked():
    mode = HybridMode("m", {x: v, v: -x})
    with pytest.raises(ValueError, match="'q'"):
        HybridSystem("x v", {"F": 1.0}, [mode], scale=symbols("q"))
    negative = HybridSystem("x v", {"F": 1.0}, [mode], scale=-F)
    with pytest.raises(ValueError, match="scale"):
        negative.scale_value()
    assert HybridSystem("x v", {"F": 1e-20}, [mode], scale=F).scale_value() == 1e-20
    assert HybridSystem("x v", {"F": 1.0}, [mode]).scale_value() == 1.0


def test_the_familys_stops_and_releases_carry_the_engines_stick_test():
    from impactosc.model.hybrid import oscillator_system
    from impactosc.model.hybrid._oscillator_system import StickTest

    system = oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4))
    ruled = {g.name: g.choose for g in system.guards if g.choose is not None}
    assert set(ruled) == {f"{r}{s}" for r in ("free", "upper", "lower")
                          for s in ("+ stop", "- stop", " release+", " release-")}
    assert ruled["upper- stop"] == StickTest("upper")
    assert system.scale_value() == pytest.approx(0.52, rel=1e-15)  # min(1, F + beta + beta_s)


# -- the tie of the built-in family on the hybrid loop --------------------------------------------------------
TIES = [
    # frictionless at rest on a flange's surface, net force 1 - cos(1e-12 t) (zero, growing)
    (impactosc.Oscillator(F=1.0, Omega=1e-12, beta=0.0, K=1.0, phase=np.pi), -1.0),
    # the same inside the lower flange: f = -cos(w t) - x - K (x + 1) at x = -1.5 with F = 1 + 0.5 (1 + K)
    (impactosc.Oscillator(F=1.5 + 0.5 * 3.0, Omega=1e-12, beta=0.0, K=3.0, phase=np.pi), -1.5),
    # at rest on the friction level, F = beta_s, where F cos t - beta_s touches zero at t = 0 and turns back
    (impactosc.Oscillator(F=0.5, Omega=1.0, beta=0.5, K=1.0), 0.0),
]


@pytest.mark.parametrize("osc, x0", TIES, ids=["surface", "in the flange", "touch of the level"])
def test_a_tie_at_rest_on_the_hybrid_loop_agrees_with_exact(osc, x0):
    ref = impactosc.simulate(osc, 7.0, x0, 0.0, backend="exact")
    sol = hybrid(osc, 7.0, x0, 0.0)
    assert sol.status == ref.status == 0, sol.message
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-9)
    assert (sol.x_final, sol.v_final) == pytest.approx((ref.x_final, ref.v_final), abs=1e-12)


# -- tiny forces ---------------------------------------------------------------------------------------------
def members(level):
    """(name, member) with forcing and friction of size ``level``: stuck, sticking and releasing, slipping, a tie."""
    L = level
    return [("stuck", impactosc.Oscillator(F=L, Omega=0.7, beta=2 * L, K=1.0)),
            ("stick and release", impactosc.Oscillator(F=2 * L, Omega=0.7, beta=L, K=1.0, beta_static=1.5 * L)),
            ("slip", impactosc.Oscillator(F=L, Omega=0.7, beta=0.1 * L, K=1.0, beta_static=0.15 * L)),
            ("tie", impactosc.Oscillator(F=L, Omega=0.7, beta=L, K=1.0))]


CASES = [(level, name, osc, moving) for level in (1e-45, 1e-20, 1e-10) for name, osc in members(level)
         for moving in (False, True)]


@pytest.mark.parametrize("level, name, osc, moving", CASES,
                         ids=[f"{c[0]:g}-{c[1]}-{'moving' if c[3] else 'at rest'}" for c in CASES])
def test_tiny_forces_on_the_hybrid_loop_agree_with_exact(level, name, osc, moving):
    """Forcing and friction of 1e-45 .. 1e-10 (the member's scale, min(1, F + beta + beta_s), sets the loop's
    tolerances): the events and the final state of the closed form.

    Tolerances: heyoka's error control is absolute for states below 1 (its norm is max(1, |y|)), so a
    motion of size ``level`` is integrated to a relative accuracy that its conservative estimate leaves
    at ~1e-8 here, and the event times of the piece loop are off the closed form by the same 2.3e-7: a
    speed of size ``level`` then moves the states by ~1e-6 ``level`` (the bound is 1e-5 ``level``).
    """
    v0 = level if moving else 0.0
    ref = impactosc.simulate(osc, 20.0, 0.0, v0, backend="exact")
    sol = hybrid(osc, 20.0, 0.0, v0)
    assert sol.status == ref.status == 0, sol.message
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-6)
    np.testing.assert_allclose(sol.events.x, ref.events.x, rtol=0, atol=1e-5 * level)
    assert (sol.x_final, sol.v_final) == pytest.approx((ref.x_final, ref.v_final), abs=1e-5 * level)


def test_tiny_forces_stuck_for_a_long_time_cost_a_few_periods():
    """F < beta = 2e-45: stuck from rest for good; the stuck phase is jumped over whole periods."""
    osc = impactosc.Oscillator(F=1e-45, Omega=1.0, beta=2e-45, K=1.0)
    sol = hybrid(osc, 1e9, 0.0, 0.0)
    assert sol.status == 0, sol.message
    assert sum(sol.counts.values()) == 0 and (sol.x_final, sol.v_final) == (0.0, 0.0)
    assert sol.n_steps < 100


@pytest.mark.parametrize("level", [1e-3, 1e-20])
def test_small_forces_on_the_scipy_hybrid_loop(level):
    """The scipy loop takes the same Switch (scale, transition rule); its absolute tolerance scaled with the
    forces, its events agree with the closed form (DOP853 at rtol 1e-12: event times to ~1e-9).

    The first stop (v = 0 at t = 1.968) is also the position's extremum, whose check fired first and
    split the piece there with v = -7e-20: solve_ivp saw no sign change of v after it and the mass
    slipped on against friction (one event of seven, status 0, at 1e-3 as at 1e-20)."""
    from impactosc.model.hybrid import oscillator_system

    osc = members(level)[1][1]
    ref = impactosc.simulate(osc, 20.0, 0.0, 0.0, backend="exact")
    sol = impactosc.simulate(oscillator_system(osc), 20.0, [0.0, 0.0], backend="scipy", atol=1e-12 * level)
    assert sol.status == 0, sol.message
    crossings = [e for e in sol.events if e.kind == "crossing"]
    assert len(crossings) == len(ref.events)
    np.testing.assert_allclose([e.t for e in crossings], ref.events.t, rtol=0, atol=1e-8)


def sizes(low, high):
    """0, or a number of size 1e-2 .. high (never subnormal once scaled down by 1e-45)."""
    return st.one_of(st.just(0.0), st.floats(low, high))


@given(exponent=st.floats(-45.0, 0.0), F=sizes(1e-2, 3.0), beta=sizes(1e-2, 2.0), extra=sizes(1e-2, 1.0),
       Omega=st.floats(0.3, 2.0), phase=st.floats(0.0, 2.0 * np.pi), x0=st.one_of(sizes(1e-2, 1.0), sizes(-1.0, -1e-2)),
       v0=st.one_of(sizes(1e-2, 1.0), sizes(-1.0, -1e-2)))
def test_a_member_scaled_down_agrees_with_exact_on_the_hybrid_loop(exponent, F, beta, extra, Omega, phase, x0, v0):
    """Forcing, friction and the start scaled by 10^exponent (the flanges at +-1 out of reach below 1e-1):
    the loop's decisions do not depend on the scale, so its events are the closed form's, in order.

    Their times are not compared: below 1 heyoka's flow is accurate to ~1e-8 of the motion's size (its
    error control is absolute there), and an event time to that over the guard's slope, which is small at
    a release by a slow forcing (1.3e-4 at exponent -14, F = 2, beta = 0.5, Omega = 0.375).
    """
    scale = 10.0**exponent
    osc = impactosc.Oscillator(F=F * scale, Omega=Omega, beta=beta * scale, K=1.0, phase=phase,
                               beta_static=(beta + extra) * scale)
    ref = impactosc.simulate(osc, 20.0, x0 * scale, v0 * scale, backend="exact")
    sol = hybrid(osc, 20.0, x0 * scale, v0 * scale)
    assert sol.status == ref.status == 0, sol.message
    assert list(sol.events.kind) == list(ref.events.kind)
