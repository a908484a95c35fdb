"""heyoka backend against closed forms (issue 2 acceptance)."""

import math

import numpy as np
import pytest

import impactosc as io
from impactosc.backends.heyoka import compiled_integrator

CONTACT_CASE = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


def test_free_coulomb_oscillator_closed_form():
    # Each half period loses 2*beta of amplitude: X_k = (-1)^k (0.95 - 0.2 k) at t = k pi,
    # and at t = 5 pi the amplitude 0.05 < beta: the mass sticks for good.
    sol = io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4), 20.0, x0=0.95, v0=0.0)
    ev = sol.events
    assert list(ev.kind) == ["reversal"] * 4 + ["stick"]
    for k in range(1, 5):
        assert abs(ev.t[k - 1] - k * math.pi) <= 1e-12
        assert abs(ev.x[k - 1] - (-1) ** k * (0.95 - 0.2 * k)) <= 1e-12
        assert ev.v[k - 1] == 0.0 and ev.side[k - 1] == 0
    assert abs(ev.t[4] - 5 * math.pi) <= 1e-12 and abs(ev.x[4] - 0.05) <= 1e-12
    assert sol.status == 0 and sol.x_final == ev.x[4] and sol.v_final == 0.0
    # Dense output follows X = beta + (0.95 - beta) cos t on the first half period.
    x, v = sol.sample(np.array([0.5, 1.0, 2.0]))
    np.testing.assert_allclose(x, 0.1 + 0.85 * np.cos([0.5, 1.0, 2.0]), rtol=0, atol=1e-13)
    np.testing.assert_allclose(v, -0.85 * np.sin([0.5, 1.0, 2.0]), rtol=0, atol=1e-13)


def test_frictionless_contact_closed_form():
    K = 24.0
    w = math.sqrt(1 + K)
    sol = io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=K), 3.0, x0=0.0, v0=2.0)
    ev = sol.events
    assert list(ev.kind[:3]) == ["contact_start", "reversal", "contact_end"]
    t_in = math.pi / 6  # 2 sin t = 1
    duration = (2 / w) * math.atan(w * math.sqrt(3))  # not pi/w: the contact starts at speed
    assert abs(ev.t[0] - t_in) <= 1e-12 and abs(ev.v[0] - math.sqrt(3)) <= 1e-12
    assert abs(ev.t[2] - (t_in + duration)) <= 1e-12 and abs(ev.v[2] + math.sqrt(3)) <= 1e-12
    assert ev.side[0] == 1 and ev.side[2] == 1
    imp = sol.impacts[0]
    # Inside the flange X - 1 = -1/25 + cos(5 tau)/25 + (sqrt3/5) sin(5 tau); integrate K(X-1).
    T = duration
    impulse = K * (-T / 25 + math.sin(5 * T) / 125 + math.sqrt(3) / 25 * (1 - math.cos(5 * T)))
    assert imp.impulse == pytest.approx(impulse, rel=1e-12)
    peak = -1 / 25 + math.hypot(1 / 25, math.sqrt(3) / 5)
    assert imp.peak_penetration == pytest.approx(peak, rel=1e-12)
    assert imp.peak_force == pytest.approx(K * peak, rel=1e-12)
    assert imp.entry_velocity == pytest.approx(math.sqrt(3), rel=1e-12)
    assert imp.exit_velocity == pytest.approx(-math.sqrt(3), rel=1e-12)
    assert imp.complete


def test_contact_case_reference_numbers():
    sol = io.simulate(CONTACT_CASE, 400.0, x0=0.95, v0=0.0)
    assert sol.status == 0
    assert sol.contact_entries(1) == 47 and sol.contact_entries(-1) == 47
    assert sol.mean_flange_force(1) == pytest.approx(0.180165173509774, rel=1e-10)
    assert len(sol.impacts) == 94
    # Impact rows agree with the streamed totals.
    im = sol.impacts
    assert im.impulse[im.side == 1].sum() == pytest.approx(sol.flange_impulse(1), rel=1e-12)
    assert im.peak_penetration.max() == pytest.approx(sol.max_penetration(), rel=0)
    assert np.all(im.end > im.start) and np.all(im.entry_velocity * im.side > 0)


@pytest.mark.parametrize("eps", [1e-6, 1e-9, 1e-12, 1e-14])
def test_grazing_contacts_are_never_missed(eps):
    # X = v0 sin t reaches 1 + eps: a double root of |X| - 1 in the limit.
    sol = io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 4 * math.pi - 0.1, x0=0.0, v0=1.0 + eps)
    ev = sol.events
    starts = ev[ev.kind == "contact_start"]
    ends = ev[ev.kind == "contact_end"]
    assert list(starts.side) == [1, -1, 1, -1]
    assert list(ends.side) == [1, -1, 1, -1]
    assert np.all(ends.t > starts.t)


def test_release_is_not_swallowed():
    # Forced stick-slip: every release must be followed by real motion, and the mass never
    # "re-sticks" at the instant it is released (the double root of V at a release).
    osc = io.Oscillator(F=0.5, Omega=0.3, beta=0.3, K=1e4)
    sol = io.simulate(osc, 200.0, x0=0.0, v0=0.0)
    ev = sol.events
    assert sol.counts["stick"] >= 5 and sol.counts["release"] >= 5
    rel = np.flatnonzero(ev.kind == "release")
    for i in rel[rel + 1 < len(ev)]:
        assert ev.t[i + 1] > ev.t[i] + 1e-6
        assert abs(ev.x[i + 1] - ev.x[i]) > 1e-9
    # Stick test and release threshold, both with the net force including the flange spring.
    for e in ev[ev.kind == "stick"]:
        assert abs(osc.net_force(e.t, e.x)) <= osc.beta + 1e-12
    for e in ev[ev.kind == "release"]:
        assert abs(abs(osc.net_force(e.t, e.x)) - osc.beta) <= 1e-12
    # While stuck the mass does not move.
    st = np.flatnonzero(ev.kind == "stick")
    for i in st[st + 1 < len(ev)]:
        assert ev.kind[i + 1] == "release" and ev.x[i + 1] == ev.x[i]


def test_no_duplicate_events_at_restarts():
    sol = io.simulate(CONTACT_CASE, 400.0)
    ev = sol.events
    assert np.all(np.diff(ev.t) > 0)
    # Contact events alternate start/end on each flange.
    kinds = [(k, s) for k, s in zip(ev.kind, ev.side, strict=True) if k.startswith("contact")]
    for a, b in zip(kinds[::2], kinds[1::2], strict=False):
        assert a[0] == "contact_start" and b[0] == "contact_end" and a[1] == b[1]


def test_energy_identity():
    sol = io.simulate(CONTACT_CASE, 400.0)
    e0 = CONTACT_CASE.energy(sol.x0, sol.v0)
    e1 = CONTACT_CASE.energy(sol.x_final, sol.v_final)
    assert e1 - e0 == pytest.approx(sol.forcing_work - sol.friction_work, abs=1e-9)


def test_integrator_is_compiled_once_and_reused_without_leaking_state():
    other = io.Oscillator(F=0.2, Omega=0.7, beta=0.05, K=1e3, phase=1.0)
    ta = compiled_integrator(CONTACT_CASE)
    assert compiled_integrator(other) is ta  # the same structure: its numbers are runtime parameters
    a1 = io.simulate(CONTACT_CASE, 50.0)
    b = io.simulate(other, 50.0, x0=-0.3, v0=0.4)
    a2 = io.simulate(CONTACT_CASE, 50.0)
    assert compiled_integrator(CONTACT_CASE) is ta
    assert b.counts != a1.counts
    np.testing.assert_array_equal(a1.events.t, a2.events.t)
    assert a1.mean_flange_force() == a2.mean_flange_force()


def test_tolerance_option():
    loose = io.simulate(CONTACT_CASE, 100.0, tol=1e-8)
    tight = io.simulate(CONTACT_CASE, 100.0)
    assert list(loose.events.kind) == list(tight.events.kind)
    assert np.max(np.abs(loose.events.t - tight.events.t)) < 1e-5
    for bad in (0.0, -1e-9, 1.0, math.nan):
        with pytest.raises(ValueError, match="tol"):
            io.simulate(CONTACT_CASE, 10.0, tol=bad)
