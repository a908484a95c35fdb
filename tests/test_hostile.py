"""Hostile input and hard regimes (issue 5): a correct result or a clear error, never a hang."""

import math

import numpy as np
import pytest
from invariants import assert_sound

import impactosc as io

CONTACT = dict(F=0.5, Omega=1.1, beta=0.01)


@pytest.mark.parametrize("eps", [1e-12, 1e-15])
def test_grazing_within_tolerance_is_a_contact(eps):
    # X = v0 sin t peaks at 1 + eps: a contact of depth eps, two per period.
    sol = io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 4 * math.pi - 0.1, x0=0.0, v0=1.0 + eps)
    assert_sound(sol, 4 * math.pi - 0.1)
    assert sol.contact_entries(1) == 2 and sol.contact_entries(-1) == 2
    assert 0 < sol.max_penetration() <= 2 * eps


def test_exact_touch_is_consistent():
    # X = sin t touches |X| = 1 exactly: whether rounding calls it a contact, it must be a
    # paired, zero-depth one, and the motion must not change.
    sol = io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 10.0, x0=0.0, v0=1.0)
    assert_sound(sol, 10.0)
    assert sol.max_penetration() <= 1e-15
    x, _ = sol.sample(np.linspace(0, 10, 101))
    np.testing.assert_allclose(x, np.sin(np.linspace(0, 10, 101)), atol=1e-12)


@pytest.mark.parametrize("v0, region", [(0.0, 1), (0.3, 1), (-0.3, 0)])
def test_starting_exactly_on_the_upper_flange(v0, region):
    # F = 2 pushes outwards from X = 1 (f_net = 2 - 1 = 1 > beta): the contact starts at once.
    osc = io.Oscillator(F=2.0, Omega=0.5, beta=0.01, K=100.0)
    sol = io.simulate(osc, 20.0, x0=1.0, v0=v0)
    assert_sound(sol, 20.0)
    first = sol.impacts[0]
    if region:
        assert first.start == 0.0 and first.side == 1 and not first.complete
        assert sol.events.kind[0] != "contact_start"  # the initial mode is not an event
    else:
        assert first.start > 0.0


def test_starting_at_rest_on_the_lower_flange_pushed_in():
    osc = io.Oscillator(F=0.5, Omega=1.0, beta=0.1, K=100.0, phase=math.pi)  # f_net(0) = -0.5 + 1 > beta
    sol = io.simulate(osc, 10.0, x0=-1.0, v0=0.0)
    assert_sound(sol, 10.0)
    assert sol.events.kind[0] == "reversal" or sol.impacts[0].start > 0


@pytest.mark.parametrize("rising", [True, False])
def test_exactly_stuck_on_the_release_threshold(rising):
    # f_net(0) = F cos(phase) - x0 = beta exactly, rising or falling with the forcing.
    beta, F = 0.25, 1.0
    phase = -0.5 if rising else 0.5
    x0 = F * math.cos(phase) - beta
    osc = io.Oscillator(F=F, Omega=1.0, beta=beta, K=1e4, phase=phase)
    assert osc.net_force(0.0, x0) == pytest.approx(beta, abs=1e-15)
    sol = io.simulate(osc, 10.0, x0=x0, v0=0.0)
    assert_sound(sol, 10.0)
    ev = sol.events
    if rising:  # released at once, moving up
        assert sol.sample(0.1)[0] > x0
    else:  # stays stuck at t = 0, released downwards when f_net = cos(t + 0.5) - x0 reaches -beta
        assert ev.kind[0] == "release"
        assert ev.t[0] == pytest.approx(math.acos(x0 - beta) - phase, abs=1e-12)
        assert sol.sample(ev.t[0] + 0.1)[0] < x0


def test_chattering_quasi_static_contact_regime():
    # F > 1, Omega << 1, small beta: the tape rests against the flange and sticks once per
    # contact period; thousands of stick/release pairs must stay correct and finish.
    osc = io.Oscillator(F=2.0, Omega=0.01, beta=0.01, K=1e4)
    sol = io.simulate(osc, 2000.0, x0=0.0, v0=0.0, record="events")
    assert_sound(sol, 2000.0)
    assert sol.counts["stick"] > 1000 and sol.counts["release"] >= sol.counts["stick"] - 1
    assert sol.contact_entries() > 100


@pytest.mark.parametrize("K", [1.0, 1e2, 1e6, 1e8, 1e10])
def test_flange_stiffness_extremes(K):
    sol = io.simulate(io.Oscillator(K=K, **CONTACT), 100.0, record="events")
    assert_sound(sol, 100.0)
    assert sol.contact_entries() > 0
    # Stiffer flanges: shallower contacts, peak force bounded (the impulse per contact stays finite).
    assert sol.max_penetration() < 2.0 / math.sqrt(K) + 1.0


@pytest.mark.parametrize(
    "osc",
    [
        io.Oscillator(F=0.5, Omega=1.1, beta=0.0, K=1e4),  # no friction
        io.Oscillator(F=0.0, Omega=1.1, beta=0.01, K=1e4),  # no forcing
        io.Oscillator(F=0.5, Omega=0.0, beta=0.01, K=1e4),  # constant force
        io.Oscillator(F=0.3, Omega=1.0, beta=0.01, K=1e4),  # resonance
        io.Oscillator(F=0.5, Omega=math.sqrt(1 + 1e4), beta=0.01, K=1e4),  # at the contact frequency
    ],
)
def test_parameter_extremes(osc):
    sol = io.simulate(osc, 200.0, x0=0.95, v0=0.0, record="events")
    assert_sound(sol, 200.0)


def test_end_time_extremes():
    osc = io.Oscillator(**CONTACT, K=1e4)
    assert_sound(io.simulate(osc, 1e-9), 1e-9)
    # 1e7 time units of a mass that sticks for good after its free decay: cheap and exact.
    long_run = io.simulate(io.Oscillator(F=0.1, Omega=1e-4, beta=0.2, K=1e4), 1e7, x0=0.5, v0=0.0)
    assert_sound(long_run, 1e7)
    assert long_run.counts["stick"] == 1 and long_run.counts["release"] == 0


def test_event_limit_keeps_everything_up_to_it():
    sol = io.simulate(io.Oscillator(F=2.0, Omega=0.01, beta=0.01, K=1e4), 2000.0, x0=0.0, v0=0.0,
                      record="events", max_events=500)
    assert sol.status == 1 and len(sol.events) == 500 and "max_events=500" in sol.message
    assert sol.t_final == sol.events.t[-1] and sol.t_final < 2000.0
    assert sol.mean_flange_force() >= 0.0


@pytest.mark.parametrize(
    "kwargs, exc, name",
    [
        (dict(F="0.5"), TypeError, "F"),
        (dict(K=np.nan), ValueError, "K"),
        (dict(beta=-np.inf), ValueError, "beta"),
        (dict(Omega=[1.0]), TypeError, "Omega"),
    ],
)
def test_bad_model_input(kwargs, exc, name):
    args = dict(F=0.5, Omega=1.1, beta=0.01, K=1e4)
    args.update(kwargs)
    with pytest.raises(exc, match=name):
        io.Oscillator(**args)
