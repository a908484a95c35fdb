import math

import numpy as np
import pytest

from impactosc import Oscillator


def test_fields_are_floats_and_frozen():
    osc = Oscillator(F=1, Omega=2, beta=0, K=10)
    assert (osc.F, osc.Omega, osc.beta, osc.K, osc.phase) == (1.0, 2.0, 0.0, 10.0, 0.0)
    assert isinstance(osc.K, float)
    with pytest.raises(AttributeError):
        osc.K = 5.0


@pytest.mark.parametrize(
    "kwargs, name, rule",
    [
        ({"K": -1.0}, "K", "> 0"),
        ({"K": 0.0}, "K", "> 0"),
        ({"F": -0.1}, "F", ">= 0"),
        ({"beta": -1e-3}, "beta", ">= 0"),
        ({"Omega": -1.0}, "Omega", ">= 0"),
        ({"F": math.nan}, "F", "finite"),
        ({"K": math.inf}, "K", "finite"),
        ({"phase": math.nan}, "phase", "finite"),
    ],
)
def test_invalid_parameters_name_parameter_and_rule(kwargs, name, rule):
    base = {"F": 0.5, "Omega": 1.1, "beta": 0.01, "K": 1e4}
    base.update(kwargs)
    with pytest.raises(ValueError) as err:
        Oscillator(**base)
    assert name in str(err.value) and rule in str(err.value)


@pytest.mark.parametrize("bad", ["1.0", None, True, 1 + 2j])
def test_non_numbers_are_type_errors(bad):
    with pytest.raises(TypeError, match="K must be a real number"):
        Oscillator(F=0.5, Omega=1.1, beta=0.01, K=bad)


def test_two_sided_flange_force_is_continuous_and_symmetric():
    osc = Oscillator(F=0.0, Omega=0.0, beta=0.0, K=100.0)
    x = np.array([-1.5, -1.0 - 1e-12, -1.0, -0.3, 0.0, 1.0, 1.0 + 1e-12, 1.5])
    spring = osc.restoring_force(x)
    # Odd symmetry: the lower flange mirrors the upper one (the paper's printed (x - L) does not).
    np.testing.assert_allclose(spring, -osc.restoring_force(-x), rtol=0, atol=0)
    # No jump at |X| = 1: the spring adds K(|X|-1), which vanishes on the boundary.
    assert abs(osc.restoring_force(1.0 + 1e-12) - 1.0) < 1e-9
    assert abs(osc.restoring_force(-1.0 - 1e-12) + 1.0) < 1e-9
    np.testing.assert_allclose(osc.restoring_force(1.5), 1.5 + 100 * 0.5)
    np.testing.assert_allclose(osc.flange_force([-1.5, 0.2, 1.25]), [50.0, 0.0, 25.0])


def test_net_force_includes_flange_spring_and_forcing():
    osc = Oscillator(F=0.5, Omega=2.0, beta=0.1, K=1e4, phase=0.3)
    t, x = 0.7, 1.001
    expected = 0.5 * math.cos(2.0 * 0.7 + 0.3) - 1.001 - 1e4 * (1.001 - 1.0)
    assert osc.net_force(t, x) == pytest.approx(expected, rel=1e-13)
    assert osc._net_force_scalar(t, x) == pytest.approx(expected, rel=1e-13)
    assert osc._net_force_scalar(t, -x) == pytest.approx(0.5 * math.cos(1.7) + 1.001 + 1e4 * (1.001 - 1.0), rel=1e-13)


def test_energy_and_mirror():
    osc = Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
    assert osc.energy(1.01, 2.0) == pytest.approx(2.0 + 0.5 * 1.01**2 + 0.5 * 1e4 * 0.01**2)
    m = osc.mirrored()
    assert m.phase == pytest.approx(math.pi)
    assert m.forcing(0.4) == pytest.approx(-osc.forcing(0.4))
    assert osc.contact_frequency == pytest.approx(math.sqrt(10001.0))
