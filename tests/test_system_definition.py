"""User-defined hybrid systems: the definition and its validation at construction."""

import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, stick_slip, symbols

x, v, g, e, q = symbols("x v g e q")


def ball(**changes):
    spec = dict(states="x v", parameters={"g": 9.81, "e": 0.8},
                modes=[HybridMode("flight", {x: v, v: -g})],
                guards=[Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})])
    spec.update(changes)
    return HybridSystem(**spec)


def test_definition_reads_back():
    sys = ball()
    assert sys.dimension == 2 and sys.parameter_names == ("g", "e") and sys.mode_names == ("flight",)
    assert sys.with_parameters(e=0.5).parameter_values == (9.81, 0.5)
    assert sys.with_parameters(e=0.5).structure == sys.structure
    assert sys.period_value() is None
    w = symbols("w")
    forced = HybridSystem("x v", {"w": 2.0}, [HybridMode("m", {x: v, v: -x})], period=2 * 3.141592653589793 / w)
    assert forced.period_value() == pytest.approx(3.141592653589793, rel=1e-15)
    assert forced.modes[0].field[1] is not None and len(forced.modes[0].field) == 2
    assert impactosc.HybridSystem is HybridSystem


@pytest.mark.parametrize("changes, words", [
    (dict(modes=[HybridMode("flight", {x: v})]), ["mode 'flight'", "no rate", "'v'"]),
    (dict(modes=[HybridMode("flight", [v])]), ["mode 'flight'", "1 rates", "2 states"]),
    (dict(modes=[HybridMode("flight", {x: v, v: -g * q})]), ["mode 'flight'", "'v'", "['q']"]),
    (dict(guards=[Guard("impact", x * q, -1, armed="flight")]), ["guard 'impact'", "['q']"]),
    (dict(guards=[Guard("impact", x, -1, armed="fly")]), ["guard 'impact'", "armed", "'fly'"]),
    (dict(guards=[Guard("impact", x, -1, armed=())]), ["guard 'impact'", "armed in no mode"]),
    (dict(guards=[Guard("impact", x, -1, armed="flight", to="ground")]), ["guard 'impact'", "'ground'"]),
    (dict(guards=[Guard("impact", x, -1, armed="flight", reset={"w": x})]), ["guard 'impact'", "reset", "'w'"]),
    (dict(modes=[HybridMode("flight", {x: v, v: -g}), HybridMode("flight", {x: v, v: g})]), ["mode", "flight"]),
    (dict(parameters={"g": float("nan"), "e": 0.5}), ["parameter 'g'", "finite"]),
    (dict(section="nothing"), ["section", "'nothing'"]),
])
def test_bad_definitions_name_the_culprit(changes, words):
    with pytest.raises((ValueError, TypeError)) as info:
        ball(**changes)
    for word in words:
        assert word in str(info.value)


def test_bad_direction_and_unknown_parameter():
    with pytest.raises(ValueError, match="guard 'impact': direction"):
        Guard("impact", x, 2, armed="flight")
    with pytest.raises(ValueError, match="'h' is not a parameter"):
        ball().with_parameters(h=1.0)


def test_stick_slip_builds_three_modes_and_four_guards():
    A, w, mu = symbols("A w mu")
    import heyoka as hy

    modes, guards = stick_slip("m", v, A * hy.cos(w * hy.time) - x, mu, rates={x: v})
    sys = HybridSystem("x v", {"A": 2.0, "w": 0.5, "mu": 0.5}, modes, guards)
    assert sys.mode_names == ("m0", "m+", "m-")
    assert sys.guard_names == ("m+ stop", "m- stop", "m release+", "m release-")
    assert [gd.to for gd in sys.guards][:2] == [("m0", "m-"), ("m0", "m+")]


@pytest.mark.parametrize("module", ["impactosc.model.hybrid._definition", "impactosc.model.hybrid._friction",
                                    "impactosc.model.hybrid._oscillator_system", "impactosc.backends._hybrid",
                                    "impactosc.dynamics.hybrid_map"])
def test_examples_in_the_docstrings_run(module):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted > 0 and result.failed == 0


def test_a_period_or_a_section_is_part_of_the_structure():
    """Systems that differ only in their period share no compiled code (the period's function was missing)."""
    w = symbols("w")
    plain = HybridSystem("x v", {"w": 2.0}, [HybridMode("m", {x: v, v: -x})], name="plain")
    impactosc.simulate(plain, 1.0, [1.0, 0.0])
    forced = HybridSystem("x v", {"w": 2.0}, [HybridMode("m", {x: v, v: -x})], period=6.0 / w, name="forced")
    assert forced.structure != plain.structure
    assert forced.period_value() == pytest.approx(3.0, rel=1e-15)
