"""Issue 27 item 3: one map interface for the built-in family and user systems."""

import math

import numpy as np
import pytest

import impactosc
from impactosc.dynamics import HybridMap
from impactosc.dynamics._map import MapValue, PoincareMap
from impactosc.model.hybrid import oscillator_system

CONTACT = impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


def test_hybrid_map_is_a_poincare_map():
    hmap = HybridMap(oscillator_system(CONTACT), names=["F"])
    assert isinstance(hmap, PoincareMap)
    assert hmap.state_names == ("x", "v")
    assert hmap.period() == pytest.approx(2 * math.pi / 1.1, rel=1e-15)
    assert hmap.period([0.7]) == pytest.approx(2 * math.pi / 1.1, rel=1e-15)
    value = hmap.evaluate([0.95, 0.0])
    assert isinstance(value, MapValue)
    assert value.ok and value.singular == "" and value.failure == ""
    assert np.all(np.isfinite(value.monodromy)) and value.dp.shape == (2, 1)


def test_a_value_without_the_members_is_no_map_value():
    assert not isinstance(object(), MapValue)
    assert not isinstance(object(), PoincareMap)
