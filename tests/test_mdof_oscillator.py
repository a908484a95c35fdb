"""The one-coordinate case: the Oscillator family's linear members agree with today's exact backend, event by event."""

from __future__ import annotations

import numpy as np
import pytest

import impactosc
from impactosc import MechanicalSystem, Oscillator, simulate_mechanical

MEMBERS = [
    Oscillator(0.5, 1.1, 0.01, 1e4),  # the paper's eq. 3
    Oscillator(0.5, 1.1, 0.05, 100.0, zeta=0.02, beta_static=0.08),
    Oscillator(0.9, 0.3, 0.3, 1e3, beta_static=0.4, harmonics=[(0.2, 0.9, 0.3)], gap_lower=None),
    Oscillator(0.7, 0.8, 0.02, 50.0, phase=0.4, gap_lower=1.5, gap_upper=0.6),
    Oscillator(0.5, 1.1, 0.0, flange="rigid", restitution=1.0),
    Oscillator(1.5, 0.7, 0.0, flange="rigid", restitution=0.7, harmonics=[(0.2, 2.1, 0.3)]),
    Oscillator(0.8, 1.4, 0.0, zeta=0.05, flange="rigid", restitution=0.9, gap_lower=None),
]


@pytest.mark.parametrize("osc", MEMBERS, ids=range(len(MEMBERS)))
@pytest.mark.parametrize("x0, v0", [(0.0, 0.0), (0.3, -0.8)])
def test_n1_agrees_with_the_exact_backend_event_by_event(osc, x0, v0):
    t_end = 100.0
    ref = impactosc.simulate(osc, t_end, x0, v0, backend="exact")
    sol = simulate_mechanical(MechanicalSystem.from_oscillator(osc), t_end, [x0], [v0])
    assert ref.status == 0 and sol.status == 0
    ev = ref.events
    if osc.beta == 0.0:  # without friction the 1-DOF engine also records its turning points
        ev = ev[ev.kind != "reversal"]
    assert len(ev) > 5
    assert list(sol.events.kind) == list(ev.kind)
    np.testing.assert_allclose(sol.events.t, ev.t, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sol.events.q[:, 0], ev.x, rtol=0, atol=1e-10)
    # The 1-DOF table keeps the velocity before an impact, this one the velocity after it.
    v_after = np.where(ev.kind == "impact", -osc.restitution * ev.v, ev.v)
    np.testing.assert_allclose(sol.events.v[:, 0], v_after, rtol=0, atol=1e-9)
    t = np.linspace(0.0, t_end, 97)
    x, v = ref.sample(t)
    q, u = sol.sample(t)
    np.testing.assert_allclose(q[:, 0], x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(u[:, 0], v, rtol=0, atol=1e-8)
    assert sol.energy_balance()["relative"] < 1e-9


def test_a_resting_rigid_flange_with_friction_on_one_line_is_refused():
    osc = Oscillator(0.5, 0.3, 0.1, flange="rigid", restitution=0.5)
    with pytest.raises(ValueError, match="same line"):
        MechanicalSystem.from_oscillator(osc)
