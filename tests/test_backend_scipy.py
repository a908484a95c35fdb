"""The scipy backend: closed-form cases, agreement with heyoka, and the pitfalls it must correct.

The scipy backend exists as an independent cross-check of heyoka, so most tests compare the two
event by event: same kinds and sides in the same order, times within 1e-9. The closed-form
cases check both against the truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from impactosc import Oscillator, simulate
from impactosc.backends import scipy as scipy_backend
from impactosc.engine import SLIP_END, Mode

PI = math.pi
CONTACT = Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


def run_scipy(osc, t_end, x0, v0, **options):
    return simulate(osc, t_end, x0, v0, backend="scipy", **options)


def assert_same_events(a, b, time_tol):
    """Same event kinds and sides in the same order, times within ``time_tol``; returns the max time difference."""
    ea, eb = a.events, b.events
    assert len(ea) == len(eb), (a.summary(), b.summary())
    assert list(ea.kind) == list(eb.kind)
    assert list(ea.side) == list(eb.side)
    diff = float(np.max(np.abs(ea.t - eb.t))) if len(ea) else 0.0
    assert diff <= time_tol
    return diff


@pytest.fixture(scope="module")
def contact_pair():
    return run_scipy(CONTACT, 400, 0.95, 0.0), simulate(CONTACT, 400, 0.95, 0.0, backend="heyoka")


# -- closed forms ------------------------------------------------------------------------
def test_free_coulomb_oscillator_reversals_and_stick():
    # X'' + X = -beta sgn V: each half period pi the amplitude drops by 2 beta, and the mass
    # sticks at the first rest point with |X| <= beta.
    sol = run_scipy(Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4), 20, 0.95, 0.0)
    ev = sol.events
    assert list(ev.kind) == ["reversal"] * 4 + ["stick"]
    k = np.arange(1, 6)
    np.testing.assert_allclose(ev.t, k * PI, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ev.x[:4], (-1.0) ** k[:4] * (0.95 - 0.2 * k[:4]), rtol=0, atol=1e-9)
    assert abs(ev.x[4] - 0.05) <= 1e-9
    assert sol.status == 0 and sol.t_final == 20
    assert sol.final_mode.motion == 0 and abs(sol.x_final - 0.05) <= 1e-9


def test_frictionless_contact_entry_and_exit():
    # Free flight X = 2 sin t enters at pi/6 with V = sqrt(3); in contact X'' = -25 X + 24,
    # so X - 24/25 = 0.04 cos 5s + (sqrt(3)/5) sin 5s returns to 1 after (2/5) atan(5 sqrt 3).
    sol = run_scipy(Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 1.5, 0.0, 2.0)
    ev = sol.events
    assert list(ev.kind) == ["contact_start", "reversal", "contact_end"]
    t_in = PI / 6
    t_out = t_in + 0.4 * math.atan(5 * math.sqrt(3))
    assert abs(ev.t[0] - t_in) <= 1e-9 and abs(ev.v[0] - math.sqrt(3)) <= 1e-9
    assert abs(ev.t[2] - t_out) <= 1e-9 and abs(ev.v[2] + math.sqrt(3)) <= 1e-9
    assert abs(ev.t[1] - (t_in + t_out) / 2) <= 1e-9  # symmetric contact
    assert list(ev.side[[0, 2]]) == [1, 1]


# -- agreement with heyoka -----------------------------------------------------------------
def test_contact_case_matches_heyoka(contact_pair):
    sol, ref = contact_pair
    assert sol.status == 0 and sol.backend == "scipy"
    assert sol.contact_entries(1) == 47 and sol.contact_entries(-1) == 47
    assert_same_events(sol, ref, 1e-9)
    assert abs(sol.mean_flange_force(1) / 0.180165173509774 - 1) <= 1e-9
    assert abs(sol.mean_flange_force(-1) / ref.mean_flange_force(-1) - 1) <= 1e-9
    # The impact table is built from the same events: peak penetration is an event state.
    np.testing.assert_allclose(sol.impacts.peak_penetration, ref.impacts.peak_penetration, rtol=1e-8)


def test_dense_output_matches_heyoka(contact_pair):
    sol, ref = contact_pair
    t = np.linspace(0.0, 60.0, 241)[1:]
    # Include instants inside contacts, where the flange force is large.
    t = np.concatenate((t, 0.5 * (sol.impacts.start[:5] + sol.impacts.end[:5])))
    x, v = sol.sample(t)
    xr, vr = ref.sample(t)
    np.testing.assert_allclose(x, xr, rtol=0, atol=1e-10)
    np.testing.assert_allclose(v, vr, rtol=0, atol=1e-8)
    lo, hi = 5.0, 50.0
    assert abs(sol.mean_flange_force(1, lo, hi) / ref.mean_flange_force(1, lo, hi) - 1) <= 1e-8


@pytest.mark.parametrize(
    ("osc", "t_end", "x0", "v0"),
    [
        pytest.param(Oscillator(F=0.5, Omega=1.5, beta=0.1, K=1e4), 200, 0.0, 0.0, id="den-hartog"),
        pytest.param(Oscillator(F=0.5, Omega=0.3, beta=0.3, K=1e4), 100, 0.0, 0.0, id="stick-release"),
    ],
)
def test_friction_cases_match_heyoka(osc, t_end, x0, v0):
    sol = run_scipy(osc, t_end, x0, v0)
    ref = simulate(osc, t_end, x0, v0, backend="heyoka")
    assert_same_events(sol, ref, 1e-9)
    for side in (1, -1):
        a, b = sol.mean_flange_force(side), ref.mean_flange_force(side)
        assert abs(a - b) <= 1e-9 * abs(b)
    assert sol.counts["reversal"] + sol.counts["stick"] > 0
    if osc.Omega == 0.3:
        # The forced stick/release case really sticks and is released, again and again.
        assert sol.counts["stick"] >= 5 and sol.counts["release"] >= 5


def test_near_grazing_matches_heyoka_four_contact_events_per_period():
    osc, v0 = Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 1.000001
    sol = run_scipy(osc, 20, 0.0, v0)
    ref = simulate(osc, 20, 0.0, v0, backend="heyoka")
    assert_same_events(sol, ref, 1e-9)
    ev = sol.events
    contact = np.isin(ev.kind, ["contact_start", "contact_end"])
    per_period = np.bincount((ev.t[contact] // (2 * PI)).astype(int))
    assert list(per_period[:3]) == [4, 4, 4]  # 3 full periods in t_end = 20
    assert abs(ev.t[0] - math.asin(1 / v0)) <= 1e-9
    # The penetration (~1e-6) is 1e-6 of X, so the impulse carries X's ~1e-14 error magnified
    # a millionfold: 1e-9 relative is beyond double precision here, 1e-6 is not.
    assert abs(sol.mean_flange_force(1) / ref.mean_flange_force(1) - 1) <= 1e-6


# -- the pitfalls --------------------------------------------------------------------------
def test_grazing_contact_found_where_plain_solve_ivp_misses_it():
    v0 = 1.0 + 1e-9  # X = v0 sin t in free flight: above the flange for ~9e-5 of each period
    for method, options in (("RK45", {}), ("DOP853", {"rtol": scipy_backend.DEFAULT_RTOL,
                                                      "atol": scipy_backend.DEFAULT_ATOL})):
        def enter(t, y):
            return y[0] - 1.0

        enter.direction = 1
        plain = solve_ivp(lambda t, y: [y[1], -y[0]], (0.0, 3.0), [0.0, v0], method=method, events=enter, **options)
        assert plain.status == 0 and len(plain.t_events[0]) == 0, method  # stepped over: no sign change
        assert plain.y[0].max() < 1.0

    sol = run_scipy(Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 20, 0.0, v0)
    ev = sol.events
    assert list(ev.kind[:3]) == ["contact_start", "reversal", "contact_end"]
    assert sol.contact_entries(1) == 3 and sol.contact_entries(-1) == 3
    # Entry where v0 sin t = 1; its time is ill-conditioned (dt = dX / V, V ~ 4.5e-5).
    assert abs(ev.t[0] - math.asin(1 / v0)) <= 2e-8
    # Energy: v0^2 = (1 + p)^2 + K p^2 at the deepest point.
    p = (-1 + math.sqrt(1 + 25 * (v0 * v0 - 1))) / 25
    assert sol.max_penetration(1) == pytest.approx(p, rel=1e-3)
    ref = simulate(Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 20, 0.0, v0, backend="heyoka")
    assert_same_events(sol, ref, 1e-8)


def test_restarts_on_guard_surfaces_do_not_refire():
    # Starting exactly on the flange surface moving inward, or at rest on it, must not
    # produce a contact at t = 0 (the guard is zero at the start of the piece).
    # (An exact tangency such as X = cos t would be a fair coin toss for both backends.)
    free, rough = Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), Oscillator(F=0.0, Omega=0.0, beta=0.1, K=24.0)
    for osc, x0, v0 in ((free, 1.0, -1.0), (rough, 1.0, 0.0), (free, -1.0, 1.0)):
        sol = run_scipy(osc, 2 * PI, x0, v0)
        ref = simulate(osc, 2 * PI, x0, v0, backend="heyoka")
        assert sol.status == 0
        assert sol.events.t[0] > 0.1
        assert_same_events(sol, ref, 1e-9)


def test_guard_zero_at_piece_start_does_not_fire_when_the_piece_fits_in_one_step():
    # After a reversal the slip-end guard s V is exactly 0. scipy's test g_old <= 0 <= g_new
    # fires it when the first step already reaches the next rest point, and brentq returns
    # the start time. Force that situation with one huge first step at a loose tolerance.
    stepper = scipy_backend._Stepper(Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4), "DOP853", 0.5, 0.5)
    stepper.options["first_step"] = 3.3
    t1, x1, v1, guard, *_, steps = stepper.advance(Mode(0, -1, True), 0.0, 0.5, 0.0, 10.0)
    assert steps == 1  # the whole slip from X = 0.5 to X = -0.3 (at t = pi) in one step
    assert guard == SLIP_END
    assert abs(t1 - PI) < 0.05 and abs(x1 + 0.3) < 0.01  # a crude step, but the right rest point


def test_short_release_window_while_stuck_is_not_stepped_over():
    # Stuck at X = 0 with f_net = -sin(Omega t): released only while |sin| > 0.999, a window
    # of ~9 time units around t = 157 and 471.
    osc = Oscillator(F=1.0, Omega=0.01, beta=0.999, K=1e4, phase=PI / 2)
    t_end = 2 * PI / osc.Omega

    def release(t, y):
        return abs(np.sin(osc.Omega * t)) - osc.beta

    release.direction = 1
    plain = solve_ivp(lambda t, y: [0.0, 0.0], (0.0, t_end), [0.0, 0.0], method="DOP853", events=release,
                      rtol=scipy_backend.DEFAULT_RTOL, atol=scipy_backend.DEFAULT_ATOL)
    assert len(plain.t_events[0]) == 0  # zero error estimate: the steps grow tenfold and jump it

    sol = run_scipy(osc, t_end, 0.0, 0.0)
    ref = simulate(osc, t_end, 0.0, 0.0, backend="heyoka")
    assert list(sol.events.kind) == ["release", "stick", "release", "stick"]
    assert_same_events(sol, ref, 1e-9)


def test_slip_end_hidden_inside_one_step_is_found(monkeypatch):
    # Slow forcing: the velocity stalls, dips below zero and recovers within one step at
    # rtol=1e-8, so scipy sees no sign change of V. Without the watch on the minima of s V
    # (measured) one of the 14 sticks is lost and the mass slips on through V = 0.
    osc = Oscillator(F=0.8489946808046128, Omega=0.03178040522175253, beta=0.3119511000211254,
                     K=204.17433818284553, phase=1.2804928675217582)
    args = (osc, 150.0, -0.38512618193366666, 0.0)
    ref = simulate(*args, backend="heyoka")
    assert ref.counts["stick"] == 14
    sol = run_scipy(*args, rtol=1e-8, atol=1e-11)
    assert_same_events(sol, ref, 1e-6)

    original = scipy_backend._guard_functions

    def without_watch(osc, mode):
        fun, jac, armed = original(osc, mode)
        return fun, jac, [a for a in armed if a[0] != scipy_backend._SV_MIN]

    monkeypatch.setattr(scipy_backend, "_guard_functions", without_watch)
    blind = run_scipy(*args, rtol=1e-8, atol=1e-11)
    assert blind.counts["stick"] < 14


def test_end_time_edge_cases():
    osc = Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0)
    tiny = run_scipy(CONTACT, 1e-9, 0.95, 0.0)
    assert tiny.status == 0 and tiny.t_final == 1e-9 and len(tiny.events) == 0
    # An event at (or within rounding of) t_end.
    t_hit = float(simulate(osc, 1.0, 0.0, 2.0, backend="heyoka").events.t[0])
    for t_end in (t_hit, math.nextafter(t_hit, 0.0), math.nextafter(t_hit, 1.0)):
        sol = run_scipy(osc, t_end, 0.0, 2.0)
        assert sol.status == 0 and sol.t_final == t_end
        assert len(sol.events) <= 1
    stats = run_scipy(CONTACT, 50, 0.95, 0.0, record="stats")
    assert stats.counts == simulate(CONTACT, 50, 0.95, 0.0, backend="heyoka", record="stats").counts
    limited = run_scipy(CONTACT, 400, 0.95, 0.0, max_events=10)
    assert limited.status == 1 and len(limited.events) == 10


# -- options -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("options", "exc", "name"),
    [
        ({"method": "Euler"}, ValueError, "method"),
        ({"rtol": 0.0}, ValueError, "rtol"),
        ({"atol": -1.0}, ValueError, "atol"),
        ({"rtol": math.inf}, ValueError, "rtol"),
        ({"rtol": 1e-16}, ValueError, "rtol"),
        ({"atol": "tight"}, TypeError, "atol"),
        ({"tol": 1e-12}, TypeError, "tol"),
    ],
)
def test_option_errors_name_the_parameter(options, exc, name):
    with pytest.raises(exc, match=name):
        run_scipy(CONTACT, 1.0, 0.95, 0.0, **options)


def test_unknown_method_lists_the_choices():
    with pytest.raises(ValueError, match="method") as info:
        run_scipy(CONTACT, 1.0, 0.95, 0.0, method="rk4")
    for m in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"):
        assert m in str(info.value)


def test_implicit_radau_same_event_sequence():
    # Radau (with the exact Jacobian) is slow at tight tolerances: the full contact case to
    # t_end=400 took 139 s at the default tolerances (times within 6e-12 of heyoka) and 20 s
    # at rtol=1e-9. Here 100 time units (83 events) at rtol=1e-9, a few seconds.
    # Measured: same sequence, event times within 4.2e-9 of heyoka.
    ref = simulate(CONTACT, 100, 0.95, 0.0, backend="heyoka")
    sol = run_scipy(CONTACT, 100, 0.95, 0.0, method="Radau", rtol=1e-9, atol=1e-11)
    assert len(sol.events) == 83
    assert_same_events(sol, ref, 5e-8)
    assert abs(sol.mean_flange_force(1) / ref.mean_flange_force(1) - 1) <= 1e-8
