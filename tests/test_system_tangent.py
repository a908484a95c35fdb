"""The map of a user system and its derivatives: central differences, Liouville's rule, the built-in shooting."""

import math

import heyoka as hy
import numpy as np
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols
from impactosc.dynamics.hybrid_map import HybridMap, periodic_orbit_of
from impactosc.model.hybrid import oscillator_system

x, v, x1, v1, x2, v2 = symbols("x v x1 v1 x2 v2")


def impact_oscillator(**values):
    """x'' + 2 zeta x' + x = A cos(w t), v -> -e v at x = d (rising), forcing period 2 pi / w."""
    zeta, A, w, d, e = symbols("zeta A w d e")
    params = {"zeta": 0.05, "A": 1.2, "w": 0.8, "d": 0.6, "e": 0.7, **values}
    return HybridSystem("x v", params, [HybridMode("free", {x: v, v: A * hy.cos(w * hy.time) - x - 2 * zeta * v})],
                        [Guard("impact", x - d, 1, armed="free", to="free", reset={v: -e * v})],
                        period=2 * math.pi / w, name="impact oscillator")


def two_masses():
    k, c, A, w, d, e = symbols("k c A w d e")
    field = {x1: v1, v1: A * hy.cos(w * hy.time) - x1 - k * (x1 - x2) - c * v1, x2: v2, v2: -k * (x2 - x1) - c * v2}
    return HybridSystem("x1 v1 x2 v2", {"k": 2.0, "c": 0.05, "A": 1.5, "w": 0.9, "d": 0.5, "e": 0.8},
                        [HybridMode("free", field)],
                        [Guard("stop", x1 - d, 1, armed="free", to="free", reset={v1: -e * v1})],
                        period=2 * math.pi / w, name="two masses")


def central_differences(hmap, z, params, h=1e-6):
    n, k = len(z), len(params)
    dz = np.column_stack([(hmap.evaluate(z + h * e).image - hmap.evaluate(z - h * e).image) / (2 * h)
                          for e in np.eye(n)])
    dp = np.column_stack([(hmap.evaluate(z, params + h * e).image - hmap.evaluate(z, params - h * e).image) / (2 * h)
                          for e in np.eye(k)])
    return dz, dp


@pytest.mark.parametrize("make, z", [
    (impact_oscillator, [0.1, 0.3]),
    (two_masses, [0.1, 0.2, -0.1, 0.0]),
    (lambda: oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4, zeta=0.05)), [0.95, 0.1]),
])
def test_jacobians_agree_with_central_differences(make, z):
    system = make()
    hmap = HybridMap(system)
    z = np.array(z)
    params = np.array(hmap.values())
    value = hmap.evaluate(z)
    assert value.ok and not value.singular and len(value.signature) >= 1
    dz, dp = central_differences(hmap, z, params)
    scale = max(1.0, np.abs(value.monodromy).max())
    np.testing.assert_allclose(value.monodromy, dz, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(value.dp, dp, rtol=0, atol=1e-6 * max(1.0, np.abs(value.dp).max()))


@pytest.mark.parametrize("make, z, trace", [
    (impact_oscillator, [0.1, 0.3], lambda p: -2 * p["zeta"]),
    (two_masses, [0.1, 0.2, -0.1, 0.0], lambda p: -2 * p["c"]),
])
def test_liouville_rule(make, z, trace):
    """det M = prod det(R_i) (n.f+)/(n.f-) exp(int trace): here (-e)(-e) per impact and exp(trace T)."""
    system = make()
    hmap = HybridMap(system)
    value = hmap.evaluate(z)
    p = dict(system.parameters)
    impacts = len(value.signature)
    assert impacts >= 1
    sol = impactosc.simulate(system, 2 * math.pi / p["w"], z)
    ratio = 1.0
    for e in sol.events:  # n = e_x: n.f = the velocity of the stopped coordinate
        ratio *= -p["e"] * e.state_after[1] / e.state_before[1]
    want = ratio * math.exp(trace(p) * 2 * math.pi / p["w"])
    assert ratio == pytest.approx(p["e"] ** (2 * impacts), rel=1e-12)
    assert np.linalg.det(value.monodromy) == pytest.approx(want, rel=1e-10)


def test_periodic_orbit_agrees_with_the_builtin_shooting():
    osc = impactosc.Oscillator(F=1.5, Omega=0.8, beta=0.05, K=100.0, zeta=0.1)
    builtin = impactosc.dynamics.periodic_orbit(osc)
    assert builtin.status == 0
    orbit = periodic_orbit_of(HybridMap(oscillator_system(osc)), [builtin.x + 1e-3, builtin.v - 1e-3])
    assert orbit.status == 0
    np.testing.assert_allclose(orbit.z, [builtin.x, builtin.v], rtol=0, atol=1e-10)
    # a complex pair: compared through their sum and product (sorting pairs whose real parts
    # agree to rounding orders them by that rounding)
    np.testing.assert_allclose(np.poly(orbit.multipliers).real, np.poly(builtin.multipliers).real, rtol=0, atol=1e-9)


def test_a_grazing_is_reported_not_a_huge_number():
    """x'' = -x with the wall x = 1 and the period 2 pi: from (0, 1) the orbit touches the wall."""
    w = symbols("w")
    system = HybridSystem("x v", {"w": 1.0}, [HybridMode("free", {x: v, v: -x})],
                          [Guard("wall", x - 1.0, 1, armed="free", to="free", reset={v: -v})],
                          period=2 * math.pi / w, name="graze")
    value = HybridMap(system).evaluate([0.0, 1.0])
    assert value.ok and "wall" in value.singular and np.all(np.isnan(value.monodromy))


def test_bad_map_arguments_are_named():
    with pytest.raises(ValueError, match="period"):
        HybridMap(HybridSystem("x", {}, [HybridMode("a", {x: -x})], name="no period"))
    with pytest.raises(ValueError, match="'q' is not a parameter"):
        HybridMap(impact_oscillator(), names=["q"])
    assert "2 finite numbers" in HybridMap(impact_oscillator()).evaluate([0.0]).failure
    narrowed = HybridMap(impact_oscillator(), 2).with_names(["e"])
    assert narrowed.names == ("e",) and narrowed.n == 2 and narrowed.evaluate([0.1, 0.3]).dp.shape == (2, 1)


def relay(section="switch on"):
    """x'' + 2 zeta x' + x = -sign(x + a x'), as two modes; its section: the switch-on surface."""
    zeta, a = symbols("zeta a")
    s = x + a * v
    modes = [HybridMode("on", {x: v, v: -x - 2 * zeta * v - 1.0}),
             HybridMode("off", {x: v, v: -x - 2 * zeta * v + 1.0})]
    guards = [Guard("switch off", s, -1, armed="on", to="off"), Guard("switch on", s, 1, armed="off", to="on")]
    return HybridSystem("x v", {"zeta": -0.1, "a": 0.05}, modes, guards, section=section, name="relay")


def test_section_map_of_an_autonomous_system():
    """The relay's return map to its switching surface: central differences, and its limit cycle, whose
    multipliers are 0 (along the flow, which the section removes) and, by Liouville's rule,
    mu = exp(int div f) prod (n.f+)/(n.f-) = exp(-2 zeta T) prod (n.f+)/(n.f-)."""
    system = relay()
    hmap = HybridMap(system, mode="on")
    z = np.array([-0.05, 0.9])  # near the cycle, just after a switch on
    value = hmap.evaluate(z)
    assert value.ok and [s[0] for s in value.signature] == ["switch off", "switch on"]
    dz, _ = central_differences(hmap, z, np.array(hmap.values()))
    np.testing.assert_allclose(value.monodromy, dz, rtol=0, atol=1e-7)
    orbit = periodic_orbit_of(hmap, z)
    assert orbit.status == 0
    sol = impactosc.simulate(system, 100.0, orbit.z, mode="on", until=("switch on", 1))
    assert "as asked" in sol.message and sol.events[-1].guard == "switch on"
    a, zeta = 0.05, -0.1
    ratio = 1.0
    for e in sol.events:  # n = (1, a); f = (v, -x - 2 zeta v -+ 1)
        xb, vb = e.state_before[:2]
        sign_before = -1.0 if e.mode_before == "on" else 1.0
        ratio *= (vb + a * (-xb - 2 * zeta * vb - sign_before)) / (vb + a * (-xb - 2 * zeta * vb + sign_before))
    mu = math.exp(-2 * zeta * sol.t_final) * ratio
    multipliers = sorted(orbit.multipliers, key=abs)
    assert abs(multipliers[0]) < 1e-9
    assert multipliers[1] == pytest.approx(mu, rel=1e-9)


def test_until_ends_a_run_after_the_named_event():
    sol = impactosc.simulate(relay(), 100.0, [-0.05, 0.9], mode="on", until=("switch off", 2))
    assert [e.guard for e in sol.events] == ["switch off", "switch on", "switch off"]
    assert sol.t_final == sol.events[-1].t and sol.status == 0
    with pytest.raises(ValueError, match="'nothing'"):
        impactosc.simulate(relay(), 10.0, [0.0, 1.0], mode="on", until=("nothing", 1))
