"""Issue 27 item 4 (lean, second round): the generated transitions compute each repeated arithmetic group once.

``model.hybrid._numeric._shared`` hoists every parenthesised group of ``+ - *`` arithmetic that a
transition evaluates more than once (eq. 3's net force ``((F cos - x) - K (x - gap))`` appears
eight times in the transition of a stop in a flange), and ``_conditional`` writes each
``select(c, a, b)`` as ``(a if c else b)``. The code must give the same floats as the code
written out, bit for bit, and leave alone what may raise or is assigned in the body.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import impactosc
from impactosc.engine._hybrid import Switch
from impactosc.model.hybrid import _numeric, oscillator_system
from impactosc.model.hybrid._numeric import _shared, plan

MEMBERS = {
    "contact": impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4),
    "static friction, damping": impactosc.Oscillator(F=0.3, Omega=0.7, beta=0.1, beta_static=0.2, K=50.0, zeta=0.05),
    "one flange, harmonics": impactosc.Oscillator(F=0.4, Omega=0.9, beta=0.02, K=1e3, harmonics=[(0.1, 2.2, 0.3)],
                                                  gap_upper=1.2, gap_lower=None),
}


def _run(body: list[str], **values):
    space = {"sin": math.sin, "cos": math.cos, "_abs": abs}
    exec("\n".join(["def f(" + ", ".join(values) + "):", *body]), space)  # noqa: S102 - test text
    return space["f"](**values)


def test_the_net_force_of_a_stop_in_a_flange_is_computed_once():
    osc = MEMBERS["contact"]
    system = oscillator_system(osc)
    switch = Switch(system)
    g, mode = system.guard_names.index("upper+ stop"), system.mode_index("upper+")
    source = []
    real_compile = compile

    def keep(text, name, kind, *args, **kwargs):
        source.append(text)
        return real_compile(text, name, kind, *args, **kwargs)

    _numeric.compile = keep  # the module's own name for the builtin: read the generated text
    try:
        plan(switch.num, switch.rules, g, mode)
    finally:
        del _numeric.compile
    text = source[-1]
    force = "(((p0 * _h1) - _y0) - (p7 * "
    assert text.count(force) == 1, text


@pytest.mark.parametrize("member", list(MEMBERS))
def test_each_transition_gives_the_floats_of_the_code_written_out(member, monkeypatch):
    system = oscillator_system(MEMBERS[member])
    switch = Switch(system)
    num, rules = switch.num, switch.rules
    pairs = [(g, m) for g, modes in enumerate(num.armed) for m in modes]
    hoisted = {pair: plan(num, rules, *pair) for pair in pairs}
    monkeypatch.setattr(_numeric, "_shared", lambda body: body)
    monkeypatch.setattr(_numeric, "_conditional", lambda line: line)  # the calls of select, as generated
    written = {pair: plan(num, rules, *pair) for pair in pairs}
    rng = np.random.default_rng(3)
    compared = 0
    for pair in pairs:
        for k in range(100):
            y = list(rng.uniform(-1.5, 1.5, len(num.states)))
            if k % 3 == 0:
                y[1] = 0.0  # a stop: the stick test and the slip-end guard decide
            if k % 5 == 0:
                y[0] = float(rng.choice([1.0, -1.0, 1.2]))
            t = float(rng.uniform(0.0, 50.0))
            a = hoisted[pair](t, y, switch.p, switch.touch_tol)
            b = written[pair](t, y, switch.p, switch.touch_tol)
            assert (a[0], a[2]) == (b[0], b[2])
            assert [float(v).hex() for v in a[1]] == [float(v).hex() for v in b[1]]
            compared += 1
    assert compared == 100 * len(pairs)


@pytest.mark.parametrize("t", [0.0, 0.4, 2.9])
def test_hoisted_groups_give_the_same_floats(t):
    body = ["    a = ((t * 0.1) - (t * 0.3)) * ((t * 0.1) - (t * 0.3)) + (t * 0.3)",
            "    return a - ((t * 0.1) - (t * 0.3)) * 1e-17"]
    out = _shared(body)
    assert sum(line.count("(t * 0.1)") for line in out) == 1
    assert _run(out, t=t).hex() == _run(body, t=t).hex()


def test_what_may_raise_or_is_assigned_in_the_body_stays():
    body = ["    _rate = (x * 2.0)",
            "    if (1.0 / (x + y)) > 0.0 and (1.0 / (x + y)) < 2.0:",  # a division: may raise, not hoisted
            "        return (_rate - y) + (_rate - y) + sin(x + y) + sin(x + y) + (x ** (y + 1.0)) + (x ** (y + 1.0))",
            "    return (x > y) + (x > y)"]
    out = _shared(body)
    text = "\n".join(out)
    assert text.count("(1.0 / _c") == 2  # the division stays where it was; only its sum is hoisted
    assert text.count("(_rate - y)") == 2  # uses a name the body assigns
    assert text.count("sin(x + y)") == 2  # a call's argument list is not a group
    assert text.count("(x ** ") == 2  # a power may overflow
    assert text.count("(x > y)") == 2  # a comparison is not arithmetic
    for x, y in ((0.3, 0.5), (1.0, -1.0 + 2.0**-50), (1.0, -1.0)):  # the last divides by zero in both
        space = {"sin": math.sin}
        assert _run_both(body, out, space, x, y)


def _run_both(body, out, space, x, y) -> bool:
    results = []
    for lines in (body, out):
        scope = dict(space)
        exec("\n".join(["def f(x, y):", *lines]), scope)  # noqa: S102 - test text
        try:
            results.append(repr(scope["f"](x, y)))
        except ZeroDivisionError:
            results.append("raised")
    return results[0] == results[1]


@pytest.mark.parametrize("text", [
    "    return select((x > 0.0), (x * 2.0), select((x < 0.0), -1.0, (x + 3.0))) + select(y, 1.0, 2.0)",
    "    return (0.3 - select((y > x), (x - y), sin((y - x)))) * 2.0",
])
def test_select_written_as_a_conditional_gives_the_same_floats(text):
    out = _numeric._conditional(text)
    assert "select(" not in out
    for x, y in ((0.5, -0.25), (-0.5, 0.0), (0.0, 1.0), (-2.0, -3.0)):
        results = []
        for body in (text, out):
            scope = {"sin": math.sin, "select": lambda c, a, b: a if c else b}
            exec("\n".join(["def f(x, y):", body]), scope)  # noqa: S102 - test text
            results.append(float(scope["f"](x, y)).hex())
        assert results[0] == results[1]


def test_a_longer_name_that_ends_in_select_is_left_alone():
    assert _numeric._conditional("    return xselect(x, y)") == "    return xselect(x, y)"
