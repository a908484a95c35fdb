"""Issue 27 item 3: one saltation formula (dynamics/_jump.saltation_nd) for the built-in family and user systems."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from impactosc import Oscillator
from impactosc.dynamics._jump import saltation_nd
from impactosc.dynamics.tangent import tangent_run


def test_an_impact_has_the_closed_form_matrix():
    # x' = v, v' = a; the wall x = 1 hit at speed V > 0 with v -> -e v:
    # S = [[-e, 0], [(a+ + e a-)/V, -e]], det e^2 (module docstring of dynamics/saltation.py)
    e, V, a_minus, a_plus = 0.7, 0.4, -0.3, -0.25
    jump = saltation_nd(((1.0, 0.0), (0.0, -e)), (V, a_minus), (-e * V, a_plus), (1.0, 0.0))
    assert not jump.singular
    np.testing.assert_allclose(jump.matrix, [[-e, 0.0], [(a_plus + e * a_minus) / V, -e]], rtol=1e-15)
    assert jump.time_state == pytest.approx((-1.0 / V, 0.0))


def test_a_tangential_crossing_is_reported_not_divided():
    jump = saltation_nd(((1.0, 0.0), (0.0, -0.5)), (0.0, -1.0), (0.0, -1.0), (1.0, 0.0), guard_params=(1.0,))
    assert jump.singular
    assert all(math.isnan(q) for row in jump.matrix for q in row)
    assert all(math.isnan(q) for row in jump.params for q in row)
    assert saltation_nd(((1.0,),), (1e-9,), (2e-9,), (1.0,), tangential=1e-8).singular


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 5), st.integers(0, 3), st.integers(0, 2**32 - 1))
def test_parameter_columns_are_the_state_columns_of_an_augmented_system(d, k, seed):
    # A parameter is a state with zero rate that the guard and the reset read: S_p must be
    # the parameter block of the saltation matrix of the system with the parameters as states.
    rng = np.random.default_rng(seed)
    R_y, R_p = rng.normal(size=(d, d)), rng.normal(size=(d, k))
    fm, fp, n, R_t = rng.normal(size=d), rng.normal(size=d), rng.normal(size=d), rng.normal(size=d)
    h_t, h_p = float(rng.normal()), rng.normal(size=k)
    small = saltation_nd(R_y.tolist(), fm.tolist(), fp.tolist(), n.tolist(), h_t=h_t, reset_rate=R_t.tolist(),
                         guard_params=h_p.tolist(), reset_params=R_p.tolist())
    big_R = np.block([[R_y, R_p], [np.zeros((k, d)), np.eye(k)]])
    big = saltation_nd(big_R.tolist(), np.r_[fm, np.zeros(k)].tolist(), np.r_[fp, np.zeros(k)].tolist(),
                       np.r_[n, h_p].tolist(), h_t=h_t, reset_rate=np.r_[R_t, np.zeros(k)].tolist())
    B = np.array(big.matrix)
    scale = 1.0 + np.abs(B).max()
    np.testing.assert_allclose(np.array(small.matrix).reshape(d, d), B[:d, :d], atol=1e-12 * scale)
    np.testing.assert_allclose(np.array(small.params).reshape(d, k), B[:d, d:], atol=1e-12 * scale)
    np.testing.assert_allclose(B[d:, :], np.hstack([np.zeros((k, d)), np.eye(k)]), atol=1e-12 * scale)


@pytest.mark.parametrize("osc, backend", [
    (Oscillator(0.5, 1.1, 0.01, 1e4), "exact"),
    (Oscillator(0.8, 0.7, 0.02, 1e4, flange="rigid", restitution=0.7), "exact"),
    (Oscillator(0.5, 1.1, 0.01, 100.0, zeta=0.05), "scipy"),
])
def test_the_built_in_saltations_are_the_shared_formula(osc, backend):
    # Every saltation matrix of a built-in run (sticks aside, whose V row is zeroed) is the
    # shared formula S = R + w n^T / (n.f-): a rank-one update of R = diag(1, r22).
    _, rec = tangent_run(osc, 40.0, 0.95, 0.0, backend=backend, keep_saltations=True)
    assert rec.saltations
    for s in rec.saltations:
        a, b, c, d = s.matrix
        r22 = -osc.restitution if s.kind == "impact" else 1.0
        delta = np.array([[a - 1.0, b], [c, d - r22]])
        if s.kind == "stick":
            continue
        assert abs(np.linalg.det(delta)) <= 1e-12 * max(1.0, np.abs(delta).max() ** 2), s
