"""Issue 27 item 4: the generated transitions of the hybrid loop compute the forcing once.

A transition's entry conditions and guard checks repeat the forcing's ``cos`` (eq. 3: the
stick test and the release guards of the stuck mode, the slip-end guard of the other
direction); ``model.hybrid._numeric._hoisted`` computes each repeated ``sin``/``cos`` call
once, first. The answers themselves are checked against the separate rules in
``tests/test_one_loop_transition_plans.py``.
"""

from __future__ import annotations

import math

import pytest

import impactosc
from impactosc.engine._hybrid import Switch
from impactosc.model.hybrid import _numeric, oscillator_system
from impactosc.model.hybrid._numeric import _hoisted, plan


def test_a_reversal_evaluates_the_forcing_once(monkeypatch):
    system = oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4))
    switch = Switch(system)
    calls = []

    def cos(x):
        calls.append(x)
        return math.cos(x)

    monkeypatch.setitem(_numeric._NAMESPACE, "cos", cos)
    g, mode = system.guard_names.index("free+ stop"), system.mode_index("free+")
    step = plan(switch.num, switch.rules, g, mode)
    # a mass stopping where the net force |F cos(Omega t) - x| is below beta (it sticks) or above (it slips back)
    for t in (0.0, 1.0, 2.5):
        for offset, mode_after in ((0.005, "free0"), (0.1, "free-")):
            x = 0.5 * math.cos(1.1 * t) + offset
            calls.clear()
            target, after, _ = step(t, [x, 0.0, 0.0], switch.p, switch.touch_tol)
            assert len(calls) == 1, calls
            assert after[1] == 0.0 and target == system.mode_index(mode_after)


def test_only_repeated_sin_and_cos_calls_are_hoisted():
    body = ["    if log(_y0) > 0.0 and log(_y0) < 1.0:",
            "        return cos(sin(t)) + cos(sin(t)) + sin(t) + asin(_y1) + asin(_y1) + cos(p0)"]
    out = _hoisted(body)
    assert out[:3] == ["    _h0 = sin(t)", "    _h1 = cos(_h0)", "    _h2 = sin(t)"] or out[:2] == [
        "    _h0 = sin(t)", "    _h1 = cos(_h0)"]
    text = "\n".join(out)
    assert text.count("log(_y0)") == 2  # may raise: never moved before the test that guards it
    assert text.count("asin(_y1)") == 2  # not a sin( call
    assert text.count("cos(p0)") == 1  # once: nothing to gain
    assert "return _h1 + _h1 + _h0" in text


@pytest.mark.parametrize("t", [0.0, 0.7, 3.3])
def test_hoisted_code_computes_what_the_original_does(t):
    body = ["    return cos(sin(t)) * cos(sin(t)) - sin(t) * sin(2.0 * t) + cos(sin(2.0 * t))"]
    space_a, space_b = {"sin": math.sin, "cos": math.cos}, {"sin": math.sin, "cos": math.cos}
    exec("\n".join(["def f(t):", *body]), space_a)  # noqa: S102 - test text
    exec("\n".join(["def f(t):", *_hoisted(body)]), space_b)  # noqa: S102 - test text
    assert space_a["f"](t) == space_b["f"](t)


def test_a_longer_name_that_ends_like_a_hoisted_call_is_left_alone():
    body = ["    return cos(t) + cos(t) + acos(t) + arccos(t)"]
    text = "\n".join(_hoisted(body))
    assert "acos(t)" in text and "arccos(t)" in text
    assert text.count("_h0") == 3  # its definition and the two calls
