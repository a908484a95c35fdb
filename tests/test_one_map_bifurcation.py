"""Issue 27 item 3: bifurcation diagrams of user systems (dynamics/system_bifurcation.py)."""

import math

import heyoka as hy
import numpy as np
import pytest

from impactosc import Guard, HybridMode, HybridSystem, symbols
from impactosc.dynamics import HybridMap, bifurcation_diagram, periodic_orbit_of

x, v, zeta, A, w, d, e = symbols("x v zeta A w d e")
STOP = HybridSystem("x v", {"zeta": 0.05, "A": 1.2, "w": 0.8, "d": 0.6, "e": 0.7},
                    [HybridMode("free", {x: v, v: A * hy.cos(w * hy.time) - x - 2 * zeta * v})],
                    [Guard("impact", x - d, 1, armed="free", to="free", reset={v: -e * v})],
                    period=2 * math.pi / w)


@pytest.mark.parametrize("continuation", ["none", "both"])
def test_the_diagram_of_an_impact_oscillator_is_its_stable_periodic_orbit(continuation):
    values = [1.0, 1.2, 1.4]
    ds = bifurcation_diagram(STOP, "A", values, transient_periods=300, record_periods=3, continuation=continuation,
                             state0=[0.0, 0.0], executor="serial", progress=False)
    assert set(ds.data_vars) >= {"x", "v", "x_final", "v_final", "status", "message"}
    assert (ds.status == 0).all()
    for i, a in enumerate(values):
        orbit = periodic_orbit_of(HybridMap(STOP.with_parameters(A=a)), [0.0, 0.0])
        assert orbit.status == 0 and orbit.stable, orbit.message
        for k in range(ds.sizes["direction"]):
            points = np.c_[ds.x[k, i].values, ds.v[k, i].values]
            np.testing.assert_allclose(points, np.tile(orbit.z, (3, 1)), rtol=0, atol=1e-8)


def test_a_value_that_fails_is_recorded_not_raised():
    # w < 0 gives a negative period, which the system refuses: that value alone ends with status -2
    ds = bifurcation_diagram(STOP, "w", [0.8, -0.8], transient_periods=2, record_periods=2, state0=[0.0, 0.0],
                             executor="serial", progress=False)
    assert int(ds.status[0, 0]) == 0
    assert int(ds.status[0, 1]) == -2 and "period" in str(ds.message[0, 1].values)
    assert np.isnan(ds.x[0, 1]).all()


def test_bad_arguments_name_themselves():
    with pytest.raises(ValueError, match="parameter must be one of"):
        bifurcation_diagram(STOP, "K", [1.0], executor="serial", progress=False)
    with pytest.raises(ValueError, match="state0 must be 2 finite numbers"):
        bifurcation_diagram(STOP, "A", [1.0], state0=[0.0], executor="serial", progress=False)
    with pytest.raises(TypeError, match="state0"):
        bifurcation_diagram(STOP, "A", [1.0], x0=0.3, executor="serial", progress=False)
