"""Saltation matrices and monodromy: finite differences of the Poincare map, Liouville, closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from impactosc import Oscillator
from impactosc.dynamics import monodromy, periodic_orbit, saltation_matrix
from impactosc.dynamics.flow import linear_transition
from impactosc.dynamics.tangent import tangent_run
from impactosc.engine import ENTER_UPPER, SLIP_END, Mode

# (name, oscillator, period n, backend, finite-difference step): one converged orbit of each
# member of the family, with the events each member brings.
FAMILY = [
    ("contact case (eq. 3), period 3", Oscillator(0.5, 1.1, 0.01, 1e4), 3, "heyoka", 1e-6),
    ("contact case, exact", Oscillator(0.5, 1.1, 0.01, 1e4), 3, "exact", 1e-6),
    ("rigid flange, e = 0.7", Oscillator(0.8, 0.7, 0.02, 1e4, flange="rigid", restitution=0.7), 1, "exact", 1e-6),
    ("static friction, sticks", Oscillator(0.5, 0.5, 0.05, 1e4, beta_static=0.08), 1, "exact", 1e-6),
    ("damped", Oscillator(0.5, 1.1, 0.01, 100.0, zeta=0.05), 1, "scipy", 1e-5),
    ("Hertz flange p = 1.5", Oscillator(0.8, 0.8, 0.02, 100.0, exponent=1.5), 1, "scipy", 1e-5),
]


def central_differences(osc, orbit, backend, h):
    z = np.array([orbit.x, orbit.v])
    J = np.empty((2, 2))
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        plus = monodromy(osc, *(z + e), orbit.n, t0=orbit.t0, backend=backend)[:2]
        minus = monodromy(osc, *(z - e), orbit.n, t0=orbit.t0, backend=backend)[:2]
        J[:, k] = (np.array(plus) - np.array(minus)) / (2.0 * h)
    return J


@pytest.mark.parametrize("name, osc, n, backend, h", FAMILY, ids=[f[0] for f in FAMILY])
def test_monodromy_matches_finite_differences(name, osc, n, backend, h):
    # scipy is ~100x slower than heyoka: a short transient, Newton does the rest
    transient = 200 if n == 3 else (10 if backend == "scipy" else 60)
    orbit = periodic_orbit(osc, n, transient_periods=transient, backend=backend)
    assert orbit.status == 0, orbit.message
    fd = central_differences(osc, orbit, backend, h)
    err = np.abs(fd - orbit.monodromy).max()
    print(f"{name}: |M_saltation - M_fd| = {err:.2e}, |M| = {np.abs(orbit.monodromy).max():.3g}")
    assert err < 1e-7


def test_stick_zeroes_a_multiplier():
    osc = Oscillator(0.5, 0.5, 0.05, 1e4, beta_static=0.08)
    orbit = periodic_orbit(osc, 1, transient_periods=60, backend="exact")
    assert "stick" in orbit.events.kind
    assert orbit.collapsed
    assert orbit.multipliers[1] == 0.0  # exactly, not a rounding residue
    assert orbit.multipliers[0] == pytest.approx(np.trace(orbit.monodromy), rel=1e-12)
    assert "multiplier 0" in orbit.summary()


def test_saltation_formulas_at_single_events():
    osc = Oscillator(0.3, 1.0, 0.1, 1e4, flange="rigid", restitution=0.6)
    # Impact on the upper wall at V = 0.5: [[-e, 0], [(a+ + e a-)/V, -e]].
    v = 0.5
    a_minus = osc._accel_scalar(1.0, 1.0, v, 0, 1)
    a_plus = osc._accel_scalar(1.0, 1.0, -0.6 * v, 0, -1)
    s = saltation_matrix(osc, 1.0, Mode(0, 1), ENTER_UPPER, Mode(0, -1), 1.0, v, 1.0, -0.6 * v, "impact")
    np.testing.assert_allclose(s.matrix, (-0.6, 0.0, (a_plus + 0.6 * a_minus) / v, -0.6), rtol=1e-14)
    assert s.det == pytest.approx(0.36, rel=1e-14)
    # Reversal: diag(1, a+/a-).
    spring = Oscillator(0.3, 1.0, 0.1, 1e4)
    t, x = 2.0, 0.9
    f = spring._net_force_scalar(t, x)
    s = saltation_matrix(spring, t, Mode(0, 1), SLIP_END, Mode(0, -1), x, 0.0, x, 0.0, "reversal")
    np.testing.assert_allclose(s.matrix, (1.0, 0.0, 0.0, (f + 0.1) / (f - 0.1)), rtol=1e-14, atol=1e-300)
    # Spring flange entry: the vector field is continuous, S = I.
    s = saltation_matrix(spring, t, Mode(0, 1), ENTER_UPPER, Mode(1, 1), 1.0, 0.3, 1.0, 0.3, "contact_start")
    assert s.matrix == (1.0, 0.0, 0.0, 1.0)


def test_grazing_impact_is_reported_not_divided():
    osc = Oscillator(0.3, 1.0, 0.1, 1e4, flange="rigid", restitution=0.6)
    s = saltation_matrix(osc, 1.0, Mode(0, 1), ENTER_UPPER, Mode(0, -1), 1.0, 0.0, 1.0, -0.0, "impact")
    assert s.singular and all(math.isnan(m) for m in s.matrix)


# -- Liouville: det M = prod det S * exp(-2 zeta t_slip) ------------------------------------
def predicted_determinant(osc, sol, rec):
    """The determinant from the event table alone (independent of the matrix product)."""
    ev = sol.events
    det = 0.0 if rec.mode0.motion == 0 else 1.0  # a start inside the stick band forgets V0
    for e in ev:
        if e.kind == "reversal" and osc.beta > 0.0:  # without friction V' is continuous: det 1
            f = abs(float(osc.net_force(e.t, e.x)))
            det *= (f - osc.beta) / (f + osc.beta)
        elif e.kind == "impact":
            det *= osc.restitution**2
        elif e.kind in ("stick", "chatter"):
            det = 0.0
    # time spent stuck, from the stick/release pairs of the table
    stuck, since = 0.0, (0.0 if rec.mode0.motion == 0 else None)
    for e in ev:
        if e.kind == "stick" or (e.kind == "contact_start" and osc.rigid and e.v == 0.0):
            since = e.t if since is None else since
        elif e.kind == "release" or (e.kind == "contact_end" and osc.rigid):
            if since is not None:
                stuck += e.t - since
            since = None
    if since is not None:
        stuck += sol.t_final - since
    return det * math.exp(-2.0 * osc.zeta * (sol.t_final - stuck))


def assert_liouville(osc, sol, rec):
    if rec.singular is not None:  # a tangential crossing (V and V' vanish together): no matrix
        assert all(math.isnan(m) for m in rec.singular.matrix)
        return
    det = float(np.linalg.det(np.array(rec.jacobian).reshape(2, 2)))
    pred = predicted_determinant(osc, sol, rec)
    if pred == 0.0:
        # rank one by construction: zero up to the rounding of the products after the stick
        assert rec.collapsed
        assert abs(det) <= 1e-12 * max(1.0, float(np.abs(rec.jacobian).max()) ** 2)
    else:
        assert det == pytest.approx(pred, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(F=st.floats(0.05, 2.0), Omega=st.floats(0.2, 2.0), beta=st.floats(0.0, 0.2),
       extra=st.floats(0.0, 0.05), K=st.sampled_from([10.0, 1e3, 1e4]), rigid=st.booleans(),
       e=st.floats(0.5, 1.0), x0=st.floats(-0.9, 0.9), v0=st.floats(-1.0, 1.0))
def test_liouville_exact_members(F, Omega, beta, extra, K, rigid, e, x0, v0):
    family = {"flange": "rigid", "restitution": e} if rigid else {}
    osc = Oscillator(F, Omega, beta, K, beta_static=beta + extra, **family)
    sol, rec = tangent_run(osc, 15.0, x0, v0, backend="exact", record="events")
    assert sol.status == 0
    if sol.counts["chatter"]:
        return
    assert_liouville(osc, sol, rec)


@settings(max_examples=8, deadline=None)
@given(zeta=st.floats(0.01, 0.3), beta=st.floats(0.0, 0.05), exponent=st.sampled_from([1.0, 1.5]),
       x0=st.floats(-0.9, 0.9))
def test_liouville_damped_members(zeta, beta, exponent, x0):
    osc = Oscillator(1.2, 1.0, beta, 50.0, zeta=zeta, exponent=exponent)
    sol, rec = tangent_run(osc, 8.0, x0, 0.5, backend="scipy", record="events")
    assert sol.status == 0
    assert_liouville(osc, sol, rec)


def test_liouville_without_damping_or_friction_conserves_area():
    osc = Oscillator(0.5, 1.1, 0.0, 1e4)  # eq. 3 with beta = 0: contacts, no dissipation
    sol, rec = tangent_run(osc, 200.0, 0.95, 0.0, backend="heyoka", record="events")
    assert sol.counts["contact_start"] > 10
    det = float(np.linalg.det(np.array(rec.jacobian).reshape(2, 2)))
    assert det == pytest.approx(1.0, abs=1e-9)


def test_linear_transition_all_damping_regimes():
    from scipy.linalg import expm

    for w2, zeta, tau in [(1.0, 0.05, 2.0), (1.0 + 1e4, 0.05, 0.03), (1.0, 2.0, 1.0), (1.0, 1.0, 1.0), (4.0, 0.0, 3.0)]:
        A = np.array([[0.0, 1.0], [-w2, -2.0 * zeta]])
        np.testing.assert_allclose(np.reshape(linear_transition(w2, zeta, tau), (2, 2)), expm(A * tau),
                                   rtol=1e-12, atol=1e-14)
