"""Properties of the exact n-DOF backend on random systems (hypothesis).

The energy identity (forcing work = change of energy + damping + friction + impact losses)
to 1e-9 relative; the dense output continuous through every event but impacts (where only
the velocity jumps) and equal to the recorded state after the last event of each instant; gaps of rigid stops
never positive beyond rounding; the event times increasing.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mdof_systems import initial_state, random_system

from impactosc import simulate_mechanical

systems = st.tuples(st.integers(0, 10_000), st.integers(2, 7), st.sampled_from([("spring",), ("rigid",),
                                                                                ("spring", "rigid")]),
                    st.integers(0, 2))


# 25 cases in CI; the dev profile (HYPOTHESIS_PROFILE=dev) runs 200
@settings(max_examples=25 if settings().max_examples <= 40 else 200, deadline=None)
@given(systems)
def test_energy_identity_and_dense_output(case):
    seed, n, laws, friction = case
    system = random_system(seed, n, laws=laws, friction=min(friction, n), contacts=2)
    q0, v0 = initial_state(seed, n)
    sol = simulate_mechanical(system, 10.0, q0, v0)
    assert sol.status == 0, sol.message
    assert sol.energy_balance()["relative"] < 1e-9
    ev = sol.events
    assert np.all(np.diff(ev.t) >= 0.0)
    last = ev[np.append(ev.t[1:] != ev.t[:-1], True)] if len(ev) else ev  # the last event at each instant
    if len(last):
        q, v = sol.sample(last.t)
        scale = 1.0 + np.abs(last.q).max()
        np.testing.assert_allclose(q, last.q, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(v, last.v, rtol=0, atol=1e-10 * (1.0 + np.abs(last.v).max()))
    t = np.linspace(0.0, 10.0, 201)
    q, _ = sol.sample(t)
    gaps = system.gaps(q)
    rigid = [i for i, c in enumerate(system.contacts) if c.rigid]
    assert np.all(gaps[:, rigid] <= 1e-12)
