"""Property: power-law flanges on the one hybrid heyoka loop agree with scipy (see test_one_loop_power.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import impactosc
from impactosc.backends.heyoka._replay import run_on_hybrid_loop

pytestmark = pytest.mark.slow

members = st.builds(
    lambda F, Omega, beta, K, p, upper, lower: impactosc.Oscillator(F, Omega, beta, K, exponent=p, gap_upper=upper,
                                                                     gap_lower=lower),
    st.floats(0.0, 1.0), st.floats(0.3, 2.0), st.floats(0.0, 0.2), st.floats(10.0, 1e4), st.floats(1.2, 3.0),
    st.floats(0.7, 1.5), st.floats(0.7, 1.5))


def _near_grazing(sol, osc) -> bool:
    """A turn within 1e-7 of a flange: whether it touches is decided by rounding, differently per backend."""
    ev = sol.events
    turns = ev["x"][np.isin(ev["kind"], ["reversal", "stick"])]
    return bool(np.any(np.abs(turns - osc.gap_upper) < 1e-7) or np.any(np.abs(turns + osc.gap_lower) < 1e-7))


@settings(max_examples=6 if settings().max_examples <= 40 else settings().max_examples // 10)
@given(osc=members, x0=st.floats(-1.0, 1.0), v0=st.floats(-1.5, 1.5))
def test_power_law_members_agree_with_scipy(osc, x0, v0):
    sol = run_on_hybrid_loop(osc, 20.0, x0, v0, record="events", max_events=10**5, tol=2.0**-52)
    ref = impactosc.simulate(osc, 20.0, x0, v0, backend="scipy", rtol=1e-13, atol=1e-13)
    assert sol.status == 0, sol.message
    assume(not (_near_grazing(sol, osc) or _near_grazing(ref, osc)))
    assert list(sol.events["kind"]) == list(ref.events["kind"])
    if len(ref.events):
        # 1e-7: over 20 time units an orbit with stick-slip and contacts amplifies scipy's 1e-13 steps
        assert np.max(np.abs(sol.events["t"] - ref.events["t"])) < 1e-7
    assert sol.x_final == pytest.approx(ref.x_final, abs=1e-6)
    assert sol.flange_impulse() == pytest.approx(ref.flange_impulse(), rel=1e-7, abs=1e-9)
    balance = sol.energy_balance()
    assert abs(balance["residual"]) < 1e-9 * (1.0 + balance["scale"])
