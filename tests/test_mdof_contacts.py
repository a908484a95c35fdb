"""Rest, chatter and lift-off on rigid stops, grazings, and the checks of MechanicalSystem's input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import MechanicalSystem, simulate_mechanical
from impactosc.model import Contact, Friction


def _ball(g=1.0, e=0.6, harmonics=()):
    """A mass above a floor at q = -1 (normal -1, gap 1), pulled down by the constant force g."""
    return MechanicalSystem(M=[[1.0]], harmonics=[([-g], 0.0, 0.0), *harmonics],
                            contacts=[Contact([-1.0], 1.0, law="rigid", restitution=e)])


def test_bouncing_ball_impact_times_and_rest():
    """Dropped from rest at height 1: first impact at ``sqrt(2/g)`` with speed ``u = sqrt(2 g)``, then
    flights of ``2 e^k u / g``; the rebounds are summed into rest once a flight rises less than 1e-13."""
    g, e = 1.0, 0.6
    sol = simulate_mechanical(_ball(g, e), 10.0, [0.0], [0.0])
    ev = sol.events
    u = math.sqrt(2 * g)
    k_rest = math.ceil(math.log(math.sqrt(2 * g * 1e-13) / u) / math.log(e))  # (e^k u)^2 / (2g) <= 1e-13
    times = math.sqrt(2 / g) + np.concatenate([[0.0], np.cumsum(2 * u * e ** np.arange(1, k_rest) / g)])
    assert list(ev.kind) == ["impact"] * k_rest + ["rest"]
    np.testing.assert_allclose(ev.t[:-1], times, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ev.v[:-1, 0], u * e ** np.arange(1, k_rest + 1), rtol=1e-9, atol=0)
    assert ev.t[-1] == ev.t[-2]
    q, v = sol.sample([ev.t[-1] + 0.5, 10.0])
    np.testing.assert_array_equal(v, 0.0)
    np.testing.assert_allclose(q, -1.0, rtol=0, atol=1e-15)
    t_inf = math.sqrt(2 / g) + 2 * u * e / (g * (1 - e))
    assert abs(ev.t[-1] - t_inf) < 1e-5  # the summed tail of the chatter lasts a few microseconds
    energy = sol.energy_balance()
    assert energy["relative"] < 1e-12
    assert energy["impacts"] == pytest.approx(1.0 * g, rel=1e-12)  # all the potential energy of the drop


def test_lift_off_where_the_push_into_the_stop_vanishes():
    """Resting on the floor with the force ``-g + A cos(w t)``: lift-off at ``cos(w t) = g / A``."""
    g, A, w = 1.0, 2.0, 0.5
    # phase pi: the force starts at -3, pushing into the floor
    system = _ball(g, 0.5, harmonics=[([A], w, math.pi)])
    sol = simulate_mechanical(system, 40.0, [-1.0], [0.0])
    ev = sol.events
    assert ev.kind[0] == "lift"
    assert ev.t[0] == pytest.approx((2 * math.pi - math.acos(g / A) - math.pi) / w, abs=1e-12)
    assert ev.kind[1] == "impact" and ev.t[1] > ev.t[0] + 1.0  # a real flight, not a rounding-level touch
    assert sol.energy_balance()["relative"] < 1e-9


def test_chatter_rest_and_lift_off_repeat_with_the_forcing():
    """A weaker pull (``A = 1.2 g``): every period the mass lifts off where ``cos(w t + pi) = g / A``,
    flies, chatters down to rest, and lifts off again one period later."""
    g, A, w = 1.0, 1.2, 0.5
    sol = simulate_mechanical(_ball(g, 0.5, harmonics=[([A], w, math.pi)]), 40.0, [-1.0], [0.0])
    ev = sol.events
    lifts = ev.t[ev.kind == "lift"]
    first = (2 * math.pi - math.acos(g / A) - math.pi) / w
    np.testing.assert_allclose(lifts, first + 2 * math.pi / w * np.arange(len(lifts)), rtol=0, atol=1e-10)
    assert len(lifts) == 3 and (ev.kind == "rest").sum() >= 2
    assert sol.energy_balance()["relative"] < 1e-9


@pytest.mark.parametrize("law", ["spring", "rigid"])
@pytest.mark.parametrize("offset", [-1e-12, -1e-10, 1e-12, 1e-10])
@pytest.mark.parametrize("seed", range(4))
def test_grazing_within_1e_12_of_a_gap_is_never_missed(law, offset, seed):
    """Free vibration in one mode shape ``phi``: ``n . q = -a cos(w t)`` peaks at ``a`` at ``t = pi / w``.

    A stop at ``gap = a + offset`` is touched iff ``offset < 0``; two stops on two other
    coordinates graze at the same instant (the near-simultaneous events of two guides).
    """
    rng = np.random.default_rng(seed)
    n = 3
    A = rng.normal(size=(n, n))
    M = A @ A.T / n + np.eye(n)
    Kb = rng.normal(size=(n, n))
    K = Kb @ Kb.T + np.eye(n)
    w2, vecs = np.linalg.eig(np.linalg.solve(M, K))
    phi = vecs[:, 0].real
    w = math.sqrt(w2[0].real)
    q0 = -phi
    a = np.abs(phi)
    kw = {"stiffness": 1e3} if law == "spring" else {"restitution": 0.9}
    contacts = [Contact(np.eye(n)[j] * np.sign(phi[j]), a[j] + offset * max(1.0, a[j]), law=law, **kw)
                for j in (0, 1)]
    system = MechanicalSystem(M=M, K=K, contacts=contacts)
    sol = simulate_mechanical(system, 1.5 * math.pi / w, q0, np.zeros(n))
    assert sol.status == 0
    touched = sorted(set(int(i) for i in sol.events.index))
    if offset < 0:
        assert touched == [0, 1]
        first = {int(i): t for t, i in zip(sol.events.t[::-1], sol.events.index[::-1], strict=True)}
        for j in (0, 1):
            assert abs(first[j] - math.pi / w) < 1e-4
    else:
        assert touched == []


def test_validation_names_the_field_the_rule_and_the_value():
    with pytest.raises(ValueError, match="M must be symmetric"):
        MechanicalSystem(M=[[1.0, 0.1], [0.0, 1.0]])
    with pytest.raises(ValueError, match="M must be positive definite"):
        MechanicalSystem(M=[[1.0, 0.0], [0.0, -1.0]])
    with pytest.raises(ValueError, match=r"K must be 2x2 \(n = 2 coordinates, from M\), got shape \(3, 3\)"):
        MechanicalSystem(M=np.eye(2), K=np.eye(3))
    with pytest.raises(ValueError, match="K must be symmetric"):
        MechanicalSystem(M=np.eye(2), K=[[1.0, 2.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="Contact.gap .* must be > 0, got -0.5"):
        Contact([1.0], -0.5, law="rigid")
    with pytest.raises(ValueError, match=r"Contact.restitution must be in \[0, 1\].*1.5"):
        Contact([1.0], 1.0, law="rigid", restitution=1.5)
    with pytest.raises(ValueError, match="Contact.stiffness of a spring contact must be > 0"):
        Contact([1.0], 1.0, law="spring")
    with pytest.raises(ValueError, match="Contact.normal must not be the zero vector"):
        Contact([0.0, 0.0], 1.0, law="rigid")
    with pytest.raises(ValueError, match=r"contacts\[0\].normal must have one entry per coordinate \(2\)"):
        MechanicalSystem(M=np.eye(2), contacts=[Contact([1.0], 1.0, law="rigid")])
    with pytest.raises(ValueError, match=r"friction\[0\].coordinate must be < n = 2, got 2"):
        MechanicalSystem(M=np.eye(2), friction=[Friction(2, 0.1)])
    with pytest.raises(ValueError, match="Friction.static must be >= Friction.kinetic"):
        Friction(0, 0.2, 0.1)
    with pytest.raises(ValueError, match=r"harmonics\[0\] frequency must be >= 0"):
        MechanicalSystem(M=np.eye(1), harmonics=[([1.0], -1.0, 0.0)])
    with pytest.raises(ValueError, match="same line"):
        MechanicalSystem(M=np.eye(2), contacts=[Contact([2.0, 0.0], 1.0, law="rigid", restitution=0.5)],
                         friction=[Friction(0, 0.1)])
    # opposite stops on one line never touch together: accepted
    MechanicalSystem(M=np.eye(1), contacts=[Contact([1.0], 1.0, law="rigid", restitution=0.5),
                                            Contact([-1.0], 1.0, law="rigid", restitution=0.5)])


def test_run_arguments_are_checked():
    system = _ball()
    with pytest.raises(ValueError, match="q0 penetrates the rigid stop"):
        simulate_mechanical(system, 1.0, [-1.5], [0.0])
    with pytest.raises(ValueError, match="q0 must be 1 finite numbers"):
        simulate_mechanical(system, 1.0, [0.0, 1.0], [0.0])
    with pytest.raises(ValueError, match="t_end must be > 0"):
        simulate_mechanical(system, 0.0, [0.0], [0.0])
    hertz = MechanicalSystem(M=np.eye(1), contacts=[Contact([1.0], 1.0, stiffness=10.0, exponent=1.5)])
    with pytest.raises(ValueError, match=r"linear spring contacts only: contacts\[0\].exponent = 1.5"):
        simulate_mechanical(hertz, 1.0, [0.0], [0.0])


def test_a_run_that_stops_at_max_events_keeps_what_it_computed():
    sol = simulate_mechanical(_ball(), 10.0, [0.0], [0.0], max_events=3)
    assert sol.status == 1 and "max_events" in sol.message
    assert len(sol.events) == 3
    q, _ = sol.sample([sol.t])
    np.testing.assert_allclose(q[0], sol.q)


def test_two_coupled_stops_touched_at_once_come_to_rest_together():
    """A corner: two rigid stops whose normals couple through M^-1, pushed into both, with friction.

    Before the joint rest the masses knocked each other off the two stops at the rounding
    level until the run gave up (status -1); the run now reaches its end, rests on both stops
    at the same instant, never penetrates a stop and keeps the energy identity.
    """
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    M = A @ A.T / 3 + np.eye(3)
    system = MechanicalSystem(
        M=M, C=0.05 * np.eye(3), K=np.diag([1.0, 0.5, 2.0]),
        harmonics=[(np.array([1.5, 0.0, 1.0]), 0.0, 0.0), (np.array([1.0, 0.5, 0.8]), 0.7, 0.3)],
        contacts=[Contact([1.0, 0.3, 0.0], 0.5, law="rigid", restitution=0.3),
                  Contact([0.0, 0.2, 1.0], 0.4, law="rigid", restitution=0.4)],
        friction=[Friction(1, 0.1, 0.15)])
    sol = simulate_mechanical(system, 30.0, np.zeros(3), np.zeros(3))
    assert sol.status == 0, sol.message
    ev = sol.events
    rests = ev[ev.kind == "rest"]
    together = [t for t in np.unique(rests.t) if set(rests.index[rests.t == t]) == {0, 1}]
    assert together
    q, _ = sol.sample(np.linspace(0.0, 30.0, 3001))
    assert system.gaps(q).max() <= 1e-12
    assert sol.energy_balance()["relative"] < 1e-9
