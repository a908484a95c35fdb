"""The model family (issue #10) against closed forms, on every backend that supports the member.

heyoka's own family tests live in tests/test_family_heyoka.py; the references are in
tests/family_reference.py.
"""

import math

import numpy as np
import pytest
from family_reference import coulomb_decay_turns, hertz_contact, rigid_chatter_accumulation, rigid_release_time
from hypothesis import given, settings
from hypothesis import strategies as st

from impactosc import Oscillator, simulate
from impactosc.engine import (
    ENTER_UPPER,
    GUARD_NAMES,
    RELEASE_DOWN,
    RELEASE_UP,
    Mode,
    guard_gates,
    guard_gradient,
    guard_value,
    transition,
)
from impactosc.engine._chatter import TIME_TOLERANCE

#: Backends that support each feature (more heyoka cases: tests/test_family_heyoka.py).
RIGID = ["heyoka", "exact", "scipy"]
STATIC = ["heyoka", "exact", "scipy"]
DAMPED = ["heyoka", "exact", "scipy"]
POWER = ["heyoka", "scipy"]
HARMONICS = ["heyoka", "exact", "scipy"]
SCIPY_TIGHT = {"rtol": 1e-13, "atol": 1e-15}


def _run(osc, t_end, x0, v0, backend, **scipy_options):
    return simulate(osc, t_end, x0, v0, backend=backend, **(scipy_options if backend == "scipy" else {}))


# -- rigid flanges: chatter, rest, release -----------------------------------------------
@pytest.mark.parametrize("backend", RIGID)
def test_chatter_reaches_rest_at_the_analytic_accumulation_time(backend):
    osc = Oscillator(2.0, 0.0, 0.1, 1.0, flange="rigid", restitution=0.8)
    t_inf, impact_times = rigid_chatter_accumulation(2.0, 0.1, 0.8)
    sol = _run(osc, 30.0, 0.0, 0.0, backend)
    assert sol.status == 0
    ev = sol.events
    chatter = ev[ev.kind == "chatter"]
    assert len(chatter) == 1
    assert abs(chatter.t[0] - t_inf) <= 1e-9
    # Bounded: a few dozen impacts followed one by one, then the jump; the count says how many.
    impacts = ev[ev.kind == "impact"]
    assert chatter.count[0] == len(impacts) < 100
    np.testing.assert_allclose(impacts.t, impact_times[: len(impacts)], rtol=0, atol=1e-10)
    # After the jump the mass rests on the flange for the rest of the run, pushed with F - 1.
    assert list(ev.kind[-2:]) == ["chatter", "contact_start"]
    assert sol.x_final == 1.0 and sol.v_final == 0.0
    rest = sol.impacts[-1]
    assert rest.peak_force == pytest.approx(1.0, rel=1e-12)
    assert rest.impulse == pytest.approx(30.0 - chatter.t[0], rel=1e-12)
    bal = sol.energy_balance()
    assert abs(bal["residual"]) <= 1e-9 * bal["scale"]


@pytest.mark.parametrize("restitution", [0.0, 0.3, 0.6, 0.9, 0.95, 0.99])
def test_a_sweep_over_restitution_never_hangs(restitution):
    osc = Oscillator(2.0, 0.0, 0.1, 1.0, flange="rigid", restitution=restitution)
    t_inf, _ = rigid_chatter_accumulation(2.0, 0.1, restitution)
    sol = simulate(osc, t_inf + 5.0, 0.0, 0.0, backend="exact", record="events")
    assert sol.status == 0
    assert sol.x_final == 1.0 and sol.v_final == 0.0  # at rest on the flange
    if restitution == 0.0:
        assert sol.counts["impact"] == 1 and sol.counts["chatter"] == 0
    else:
        assert sol.counts["chatter"] == 1
        chatter = sol.events[sol.events.kind == "chatter"][0]
        assert abs(chatter.t - t_inf) <= 1e-9
    assert sol.counts["impact"] < 2000


def test_chatter_tolerance_is_stated():
    assert 0.0 < TIME_TOLERANCE <= 1e-10


def test_elastic_impacts_under_a_push_bounce_forever_without_chatter():
    osc = Oscillator(2.0, 0.0, 0.0, 1.0, flange="rigid", restitution=1.0)
    sol = simulate(osc, 50.0, 0.0, 0.0, backend="exact")
    assert sol.status == 0 and sol.counts["chatter"] == 0
    imp = sol.impacts
    # Without friction or loss every impact has the same speed and the energy is conserved.
    np.testing.assert_allclose(np.abs(imp.entry_velocity), abs(imp.entry_velocity[0]), rtol=1e-12)
    np.testing.assert_allclose(imp.exit_velocity, -imp.entry_velocity, rtol=0, atol=0)
    assert sol.energy_balance()["impact_loss"] == 0.0


@pytest.mark.parametrize("backend", RIGID)
def test_leaving_a_rigid_flange_under_harmonic_forcing(backend):
    F, Om, bs = 2.0, 0.3, 0.3
    osc = Oscillator(F, Om, 0.1, 1.0, flange="rigid", beta_static=bs)
    sol = _run(osc, 8.0, 1.0, 0.0, backend)
    ev = sol.events
    # Resting on the wall from the start is the initial mode, not an event (issue 20, item 10).
    assert ev.kind[0] == "contact_end" and sol.impacts[0].start == 0.0 and not sol.impacts[0].complete
    assert abs(ev.t[0] - rigid_release_time(F, Om, bs)) <= 1e-12
    # The wall took the push F cos(Omega t) - 1 while it was positive: a closed-form integral.
    t0 = math.acos(1.0 / F) / Om
    expected = (F * math.sin(Om * t0) / Om) - t0
    assert sol.impacts[0].impulse == pytest.approx(expected, rel=1e-12)
    assert sol.impacts[0].peak_force == pytest.approx(F - 1.0, rel=1e-12)


@pytest.mark.parametrize("backend", RIGID)
def test_impact_impulse_and_loss(backend):
    osc = Oscillator(0.0, 0.0, 0.0, 1.0, flange="rigid", restitution=0.5)
    sol = _run(osc, 2.0, 0.0, 2.0, backend)  # hits X = 1 at asin(1/2) with speed sqrt(3)
    imp = sol.impacts[0]
    assert imp.start == imp.end == pytest.approx(math.asin(0.5), abs=1e-14)
    assert imp.entry_velocity == pytest.approx(math.sqrt(3.0), rel=1e-13)
    assert imp.exit_velocity == pytest.approx(-0.5 * math.sqrt(3.0), rel=1e-13)
    assert imp.impulse == pytest.approx(1.5 * math.sqrt(3.0), rel=1e-13)
    assert sol.energy_balance()["impact_loss"] == pytest.approx(0.5 * 0.75 * 3.0, rel=1e-13)
    assert sol.flange_impulse(1) == pytest.approx(1.5 * math.sqrt(3.0), rel=1e-13)


# -- static and kinetic friction, damping --------------------------------------------------
@pytest.mark.parametrize("backend", STATIC)
@pytest.mark.parametrize("beta_static", [0.1, 0.2])
def test_static_friction_sticks_at_an_earlier_turn(backend, beta_static):
    osc = Oscillator(0.0, 0.0, 0.1, 1e4, beta_static=beta_static)
    turns, t_stick = coulomb_decay_turns(0.95, 0.1, beta_static)
    sol = _run(osc, 30.0, 0.95, 0.0, backend)
    ev = sol.events
    assert list(ev.kind) == ["reversal"] * (len(turns) - 1) + ["stick"]
    np.testing.assert_allclose(ev.t, [t for t, _ in turns], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ev.x, [x for _, x in turns], rtol=0, atol=1e-12)
    assert ev.t[-1] == pytest.approx(t_stick, abs=1e-12)
    # 5 pi with equal coefficients (the classic case), 4 pi with beta_static = 2 beta.
    assert round(t_stick / math.pi) == (5 if beta_static == 0.1 else 4)


@pytest.mark.parametrize("backend", DAMPED)
def test_damped_coulomb_decay(backend):
    osc = Oscillator(0.0, 0.0, 0.05, 1e4, zeta=0.05, beta_static=0.06)
    turns, t_stick = coulomb_decay_turns(0.95, 0.05, 0.06, zeta=0.05)
    sol = _run(osc, 40.0, 0.95, 0.0, backend, **SCIPY_TIGHT)
    ev = sol.events
    assert ev.kind[-1] == "stick" and len(ev) == len(turns)
    np.testing.assert_allclose(ev.t, [t for t, _ in turns], rtol=0, atol=1e-7)
    np.testing.assert_allclose(ev.x, [x for _, x in turns], rtol=0, atol=1e-7)
    bal = sol.energy_balance()
    assert bal["damping_work"] > 0.0 and abs(bal["residual"]) <= 1e-9 * bal["scale"]


@pytest.mark.parametrize("backend", STATIC)
def test_breakaway_with_static_friction_has_an_acceleration_jump(backend):
    # Stuck at X = 0 under F cos(Omega t + phase): released where F cos(...) = beta_static
    # (an arccos), and then it accelerates at once with beta_static - beta: no double root.
    F, Om, b, bs, ph = 1.0, 0.5, 0.1, 0.4, 1.5
    osc = Oscillator(F, Om, b, 1e4, ph, beta_static=bs)
    sol = _run(osc, 6.0, 0.0, 0.0, backend)
    ev = sol.events
    assert ev.kind[0] == "release"
    t_rel = (math.acos(-bs / F) - ph) / Om  # cos falls through -beta_static
    assert abs(ev.t[0] - t_rel) <= 1e-12
    x = simulate(osc, t_rel + 1e-3, 0.0, 0.0, backend=backend).x_final
    # 1e-3 after the release X has moved by -(beta_s - beta) tau^2 / 2 to first order.
    assert x == pytest.approx(-0.5 * (bs - b) * 1e-6, rel=2e-2)


# -- power-law flanges and harmonic sums ---------------------------------------------------
@pytest.mark.parametrize("backend", POWER)
@pytest.mark.parametrize("p", [1.5, 2.0])
def test_hertz_contact(backend, p):
    osc = Oscillator(0.0, 0.0, 0.0, 1e4, exponent=p)
    t_in, duration, d_max, v_in = hertz_contact(1.5, 1e4, p)
    sol = _run(osc, 3.0, 0.0, 1.5, backend, **SCIPY_TIGHT)
    imp = sol.impacts[0]
    assert imp.start == pytest.approx(t_in, abs=1e-10)
    assert imp.end - imp.start == pytest.approx(duration, abs=1e-9)
    assert imp.peak_penetration == pytest.approx(d_max, rel=1e-9)
    assert imp.peak_force == pytest.approx(1e4 * d_max**p, rel=1e-8)
    assert imp.entry_velocity == pytest.approx(v_in, rel=1e-10)
    assert imp.exit_velocity == pytest.approx(-v_in, rel=1e-9)


@pytest.mark.parametrize("backend", HARMONICS)
def test_harmonic_sum_forcing_work_matches_the_energy_identity(backend):
    osc = Oscillator(0.5, 1.1, 0.01, 1e4, harmonics=[(0.2, 2.2, 0.3), (0.05, 3.3, 1.0)])
    sol = _run(osc, 60.0, 0.95, 0.0, backend, **SCIPY_TIGHT)
    assert sol.status == 0 and sol.contact_entries() > 0
    bal = sol.energy_balance()
    assert abs(bal["residual"]) <= 1e-9 * bal["scale"]


def test_one_term_harmonic_list_is_eq3():
    a = Oscillator(0.5, 1.1, 0.01, 1e4, 0.3)
    b = Oscillator.from_harmonics([(0.5, 1.1, 0.3)], beta=0.01, K=1e4)
    assert a == b
    t = np.linspace(0, 10, 7)
    c = Oscillator.from_harmonics([(0.5, 1.1, 0.3), (0.2, 2.2, 0.0)], beta=0.01, K=1e4)
    np.testing.assert_allclose(c.forcing(t), 0.5 * np.cos(1.1 * t + 0.3) + 0.2 * np.cos(2.2 * t), rtol=1e-15)
    np.testing.assert_allclose(c.forcing_rate(t), -0.55 * np.sin(1.1 * t + 0.3) - 0.44 * np.sin(2.2 * t),
                               rtol=1e-14)
    assert c.mirrored().forcing(1.3) == pytest.approx(-c.forcing(1.3), rel=1e-14)


# -- the energy identity on random members ------------------------------------------------
members = st.builds(
    lambda F, Om, b, extra, z, law, p, e, h: Oscillator(
        F, Om, b, 100.0, zeta=z, beta_static=b + extra, flange=law,
        exponent=p if law == "spring" else 1.0, restitution=e if law == "rigid" else 1.0,
        harmonics=[(h, 2 * Om, 0.4)] if h else ()),
    F=st.floats(0.0, 3.0, allow_subnormal=False), Om=st.floats(0.1, 2.0), b=st.floats(0.0, 0.3),
    extra=st.floats(0.0, 0.2),
    z=st.floats(0.0, 0.2), law=st.sampled_from(["spring", "rigid"]), p=st.sampled_from([1.0, 1.5]),
    e=st.floats(0.0, 1.0), h=st.sampled_from([0.0, 0.3]))


@settings(deadline=None)
@given(osc=members, x0=st.floats(-1.0, 1.0), v0=st.floats(-2.0, 2.0))
def test_energy_identity_holds_for_every_member(osc, x0, v0):
    sol = simulate(osc, 15.0, x0, v0, backend="scipy", record="stats", rtol=1e-12, atol=1e-14)
    assert sol.status == 0, sol.message
    bal = sol.energy_balance()
    assert abs(bal["residual"]) <= 1e-8 * max(bal["scale"], 1.0)
    assert bal["friction_work"] >= 0.0 and bal["damping_work"] >= 0.0 and bal["impact_loss"] >= 0.0
    if osc.rigid:
        assert abs(sol.x_final) <= 1.0


# -- the engine's pieces -----------------------------------------------------------------
def test_rigid_gates_arm_only_the_release_away_from_the_wall():
    names = lambda g: {n for n, on in zip(GUARD_NAMES, g, strict=True) if on}  # noqa: E731
    assert names(guard_gates(Mode(1, 0), rigid=True)) == {"release_down"}
    assert names(guard_gates(Mode(-1, 0), rigid=True)) == {"release_up"}
    assert names(guard_gates(Mode(0, 1), rigid=True)) == names(guard_gates(Mode(0, 1)))


def test_rigid_transitions():
    osc = Oscillator(0.0, 0.0, 0.1, 1.0, flange="rigid", restitution=0.5)
    assert transition(osc, Mode(0, 1), ENTER_UPPER, 1.0, 1.0, 2.0) == (Mode(0, -1), 1.0, -1.0, "impact", 1)
    # Leaving the wall ends the resting contact and slides away (acceleration-zero armed).
    assert transition(osc, Mode(1, 0), RELEASE_DOWN, 1.0, 1.0, 0.0) == (Mode(0, -1, False), 1.0, 0.0,
                                                                         "contact_end", 1)
    assert transition(osc, Mode(-1, 0), RELEASE_UP, 1.0, -1.0, 0.0)[3:] == ("contact_end", -1)


def test_guard_gradients_match_finite_differences():
    osc = Oscillator(0.7, 1.3, 0.1, 50.0, 0.2, zeta=0.1, exponent=1.5, beta_static=0.2)
    t, h = 0.9, 1e-6
    for mode, x, v in ((Mode(1, 1, False), 1.02, 0.3), (Mode(1, 0), 1.02, 0.0), (Mode(0, -1, False), 0.4, -0.3),
                       (Mode(0, 0), 0.4, 0.0), (Mode(-1, -1), -1.03, -0.2)):
        for g in range(7):
            (gx, gv), gt = guard_gradient(osc, mode, g, t, x, v)
            fd = [(guard_value(osc, mode, g, t, x + h, v) - guard_value(osc, mode, g, t, x - h, v)) / (2 * h),
                  (guard_value(osc, mode, g, t, x, v + h) - guard_value(osc, mode, g, t, x, v - h)) / (2 * h),
                  (guard_value(osc, mode, g, t + h, x, v) - guard_value(osc, mode, g, t - h, x, v)) / (2 * h)]
            np.testing.assert_allclose([gx, gv, gt], fd, rtol=1e-6, atol=1e-6, err_msg=f"{mode} {GUARD_NAMES[g]}")


@pytest.mark.parametrize("backend", ["heyoka", "exact", "scipy"])
def test_sample_times_are_exact_time_events(backend):
    osc = Oscillator(0.5, 1.1, 0.01, 1e4)
    period = 2 * math.pi / 1.1
    times = period * np.arange(11)
    sol = simulate(osc, 10 * period, 0.95, 0.0, backend=backend, sample_at=times)
    assert len(sol.samples) == 11
    np.testing.assert_array_equal(sol.samples.t, times)
    plain = simulate(osc, 10 * period, 0.95, 0.0, backend=backend)
    # Sampling does not perturb the run: the same events, and the samples lie on it.
    np.testing.assert_allclose(sol.events.t, plain.events.t, rtol=0, atol=1e-11)
    x, v = plain.sample(times)
    np.testing.assert_allclose(sol.samples.x, x, rtol=0, atol=1e-11)
    np.testing.assert_allclose(sol.samples.v, v, rtol=0, atol=1e-10)


# -- hostile values -----------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, name", [
    ({"restitution": 1.5, "flange": "rigid"}, "restitution"),
    ({"restitution": -0.1, "flange": "rigid"}, "restitution"),
    ({"exponent": 0.5}, "exponent"),
    ({"zeta": -0.1}, "zeta"),
    ({"beta_static": 0.005}, "beta_static"),
    ({"zeta": math.nan}, "zeta"),
    ({"beta_static": math.inf}, "beta_static"),
    ({"flange": "hertz"}, "flange"),
    ({"flange": "rigid", "exponent": 1.5}, "exponent"),
    ({"restitution": 0.5}, "restitution"),
    ({"harmonics": [(0.1, 2.0, 0.0, 1.0)]}, "harmonics[0]"),
    ({"harmonics": [(-0.1, 2.0, 0.0)]}, "harmonics[0] amplitude"),
    ({"harmonics": [(0.1, math.nan, 0.0)]}, "harmonics[0] frequency"),
])
def test_bad_family_values_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name.replace("[", r"\[").replace("]", r"\]")):
        Oscillator(0.5, 1.1, 0.01, 1e4, **kwargs)


@pytest.mark.parametrize("kwargs, name", [({"harmonics": "abc"}, "harmonics"), ({"harmonics": [1.0]}, "harmonics"),
                                          ({"zeta": "0.1"}, "zeta")])
def test_bad_family_types(kwargs, name):
    with pytest.raises(TypeError, match=name):
        Oscillator(0.5, 1.1, 0.01, 1e4, **kwargs)


def test_empty_harmonic_list_and_start_beyond_a_rigid_wall():
    with pytest.raises(ValueError, match="harmonics must hold at least one"):
        Oscillator.from_harmonics([], beta=0.1, K=1.0)
    with pytest.raises(ValueError, match="x0 must satisfy -1 <= x0 <= 1 with a rigid flange"):
        simulate(Oscillator(0.5, 1.1, 0.01, 1.0, flange="rigid"), 1.0, 1.5, 0.0)


def test_unsupported_members_are_refused_clearly():
    hertz = Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5)
    with pytest.raises(ValueError, match="exact backend does not support a power-law flange"):
        simulate(hertz, 1.0, backend="exact")
    with pytest.raises(ValueError, match="rk4 baseline does not support a rigid flange"):
        simulate(Oscillator(0.5, 1.1, 0.01, 1.0, flange="rigid"), 1.0, backend="rk4")


# -- the tape drive in SI units -----------------------------------------------------------
def test_tape_drive_family_fields_reach_the_model():
    from impactosc import TapeDrive

    plain = TapeDrive()
    assert plain.oscillator() == Oscillator(plain.F, plain.Omega, plain.beta, plain.K)  # eq. 3, unchanged
    d = TapeDrive(clearance=50e-6, damping_ratio=0.02, static_friction=0.3, flange_exponent=1.5,
                  flange_stiffness=1e9, runout_harmonics=[(2, 0.1, 0.5)])
    osc = d.oscillator(phase=0.3)
    assert osc.zeta == 0.02
    assert osc.beta_static == pytest.approx(0.3 / 0.2 * osc.beta, rel=1e-14)
    # k0 d^p in newtons at x = L (1 + D): k0 (L D)^p = k L K D^p.
    assert osc.K == pytest.approx(1e9 * (50e-6) ** 0.5 / d.stiffness, rel=1e-14)
    assert osc.exponent == 1.5
    assert osc.harmonics == ((pytest.approx(0.1 * osc.F), pytest.approx(2 * osc.Omega), pytest.approx(0.6 + 0.5)),)
    rigid = TapeDrive(flange="rigid", restitution=0.7).oscillator()
    assert rigid.rigid and rigid.restitution == 0.7


@pytest.mark.parametrize("kwargs, name", [
    ({"damping_ratio": -1.0}, "damping_ratio"), ({"static_friction": 0.1}, "static_friction"),
    ({"flange": "soft"}, "flange"), ({"flange_exponent": 0.9}, "flange_exponent"),
    ({"restitution": 2.0, "flange": "rigid"}, "restitution"), ({"flange_stiffness": -1.0}, "flange_stiffness"),
    ({"runout_harmonics": [(1.5, 0.1, 0.0)]}, "runout_harmonics"), ({"runout_harmonics": [(2, -0.1, 0.0)]},
                                                                   "runout_harmonics"),
])
def test_tape_drive_family_fields_are_validated(kwargs, name):
    from impactosc import TapeDrive

    with pytest.raises(ValueError, match=name):
        TapeDrive(**kwargs)


def test_release_under_a_sum_of_harmonics_is_the_first_crossing():
    # Stuck at X = 0 (f_net = forcing); released where the forcing first reaches +-beta_s.
    h = math.pi / 2
    osc = Oscillator(0.3, 1.0, 0.2, 1e4, h, beta_static=0.3, harmonics=[(0.2, 3.0, h), (0.1, 7.0, h)])
    sol = simulate(osc, 10.0, 0.0, 0.0, backend="scipy", record="events")
    t_rel, kind = sol.events.t[0], sol.events.kind[0]
    assert kind == "release"
    t = np.linspace(0.0, t_rel, 200001)
    f = osc.forcing(t)
    assert np.all(np.abs(f[:-1]) < 0.3)  # nothing earlier reaches the threshold
    assert abs(abs(osc.forcing(t_rel)) - 0.3) <= 1e-14
    # A forcing whose peaks stay below beta_s never releases, however long the run.
    calm = Oscillator(0.1, 1.0, 0.2, 1e4, harmonics=[(0.1, 2.0, 0.0)])
    assert simulate(calm, 1e9, 0.0, 0.0, backend="scipy", record="stats").counts["release"] == 0


def test_tape_drive_describes_its_family_and_the_paper_grid_refuses_it():
    from impactosc import TapeDrive
    from impactosc.paper import rk4_grid

    drive = TapeDrive(damping_ratio=0.02, flange="rigid", restitution=0.5)
    assert "model family: damping zeta=0.02, a rigid flange (restitution=0.5)" in drive.describe()
    assert "model family" not in TapeDrive().describe()
    with pytest.raises(ValueError, match="RK4 grid runs eq. 3 only.*damping"):
        rk4_grid(drive, {"speed": [4.0]}, duration=1e-4)


def test_subnormal_frequencies_in_a_harmonic_sum_do_not_break_the_release_search():
    # Omega_i / Omega_min overflowed to inf in the commensurability test of the release search.
    osc = Oscillator(1.0, 2.2e-313, 0.1, 1.0, harmonics=[(0.1, 3e-313, 0.0)])
    for backend in ("heyoka", "scipy", "exact"):
        assert simulate(osc, 10.0, 1.0, 0.0, backend=backend).status == 0


def test_damping_loss_is_never_a_gain_on_tiny_pieces():
    # Found by the energy identity property: scipy's quadrature state int V^2 ended a tiny
    # piece at -1.7e-42, so damping_work came out negative.
    osc = Oscillator(0.0, 0.3125, 0.3, 100.0, zeta=0.125, harmonics=[(0.3, 0.625, 0.4)])
    sol = simulate(osc, 15.0, 1e-16, 0.0, backend="scipy", record="stats", rtol=1e-12, atol=1e-14)
    assert sol.status == 0 and sol.damping_work >= 0.0
