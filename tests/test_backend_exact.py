"""The closed-form backend: hand-derived solutions, the ODE itself, and agreement with heyoka.

heyoka locates its events on Taylor polynomials at machine precision, so two independent
numerics meeting at 1e-12 is the evidence that both are right. Windows are chosen short
enough that the dynamics' own amplification of rounding (each contact multiplies a
perturbation) keeps the event times comparable at that level.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import Mode, Oscillator, simulate
from impactosc.backends import exact

CONTACT = Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


def _pair(osc, t_end, x0, v0, **kw):
    return (simulate(osc, t_end, x0, v0, backend="heyoka", **kw),
            simulate(osc, t_end, x0, v0, backend="exact", **kw))


def _assert_agree(h, e, *, t_tol=1e-12, force_rtol=1e-10):
    assert h.status == e.status == 0
    assert e.counts == h.counts
    he, ee = h.events, e.events
    assert len(he) == len(ee)
    np.testing.assert_array_equal(ee.kind, he.kind)
    np.testing.assert_array_equal(ee.side, he.side)
    np.testing.assert_allclose(ee.t, he.t, rtol=0, atol=t_tol)
    for side in (1, -1):
        hf, ef = h.mean_flange_force(side), e.mean_flange_force(side)
        assert ef == pytest.approx(hf, rel=force_rtol, abs=0.0)


# -- hand-derived solutions --------------------------------------------------------------
def test_free_coulomb_oscillator_reversals_and_final_stick():
    # X'' + X = -beta s: half cycles of length pi about +-beta, amplitude shrinking by 2 beta.
    sol = simulate(Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4), 20.0, 0.95, 0.0, backend="exact")
    ev = sol.events
    assert list(ev.kind) == ["reversal"] * 4 + ["stick"]
    k = np.arange(1, 6)
    np.testing.assert_allclose(ev.t, k * math.pi, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ev.x[:4], (-1.0) ** k[:4] * (0.95 - 0.2 * k[:4]), rtol=0, atol=1e-12)
    assert ev.x[4] == pytest.approx(0.05, abs=1e-12)
    assert np.all(ev.v == 0.0)
    # F = 0: the stuck mass is never released and the run ends at t_end, still stuck.
    assert sol.status == 0 and sol.t_final == 20.0
    assert sol.x_final == pytest.approx(0.05, abs=1e-12) and sol.v_final == 0.0
    assert sol.final_mode == Mode(0, 0, True)


def test_frictionless_contact_entry_and_exit():
    # X = 2 sin t reaches the flange at pi/6 with V = sqrt(3); inside, Y'' + 25 Y = -1.
    w = 5.0
    sol = simulate(Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 1.5, 0.0, 2.0, backend="exact")
    ev = sol.events
    assert list(ev.kind) == ["contact_start", "reversal", "contact_end"]
    t_in = math.pi / 6
    t_out = t_in + (2.0 / w) * math.atan(w * math.sqrt(3.0))
    assert ev.t[0] == pytest.approx(t_in, abs=1e-12)
    assert ev.v[0] == pytest.approx(math.sqrt(3.0), abs=1e-12)
    assert ev.t[2] == pytest.approx(t_out, abs=1e-12)
    assert ev.v[2] == pytest.approx(-math.sqrt(3.0), abs=1e-12)
    # Impulse-momentum over the contact: K int Y = 2 v_in - int X = 2 v_in - tau_c - int Y.
    tau_c = t_out - t_in
    impulse = (2.0 * math.sqrt(3.0) - tau_c) / (1.0 + 1.0 / 24.0)
    assert sol.impacts.impulse[0] == pytest.approx(impulse, rel=1e-12)


@pytest.mark.parametrize("osc", [
    Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4),
    Oscillator(F=0.3, Omega=1.0, beta=0.02, K=1e4),  # free-region resonance w == Omega
    Oscillator(F=0.5, Omega=math.sqrt(1.0 + 1e4), beta=0.01, K=1e4),  # contact resonance
    Oscillator(F=0.2, Omega=1.0 + 1e-9, beta=0.0, K=3.0, phase=0.7),  # near resonance
    Oscillator(F=0.2, Omega=0.0, beta=0.1, K=5.0),  # constant force
])
@pytest.mark.parametrize("region, motion", [(0, 1), (0, -1), (1, 1), (1, -1), (-1, -1)])
def test_closed_form_satisfies_the_mode_ode(osc, region, motion):
    # The piece must solve Y'' + w^2 Y = cY + F cos(Omega t + phase) with the start state,
    # also at and next to resonance, where the classical particular solution breaks down.
    st = exact._Stepper(osc)
    t0, x0, v0 = 123.4, region + 0.3 * (motion if region == 0 else 1e-3), 0.7 * motion
    p = st._slip_piece(Mode(region, motion), t0, x0, v0)
    mc = p.mc
    y, v = p.yv(0.0)
    assert y + mc.ref == pytest.approx(x0, abs=1e-15) and v == pytest.approx(v0, abs=1e-15)
    for tau in (1e-3, 0.37, 2.0, 9.0):
        y, v = p.yv(tau)
        v2, a2 = p.va(tau)
        a2b, _ = p.aj(tau)
        rhs = mc.cY + osc.F * math.cos(osc.Omega * (t0 + tau) + osc.phase) - mc.w2 * y
        scale = 1.0 + abs(mc.cY) + osc.F + mc.w2 * abs(y)
        # The reference rounds the phase Omega t (~1e4 rad for the contact resonance) itself.
        phase_rounding = 4.0 * 2.0**-52 * osc.Omega * (t0 + tau) * osc.F
        assert a2 == pytest.approx(rhs, abs=1e-13 * scale + phase_rounding)
        # The guard search evaluates V through the half-sum and half-difference angles
        # (two sin/cos pairs), the state directly: the two agree to the rounding of the phase
        # w tau (at w tau = 900 an ulp is 1.1e-13 rad, times the velocity amplitude).
        amplitude = abs(v0) + mc.w * abs(x0 - mc.ref) + osc.F + abs(mc.cY)
        assert a2b == a2 and v2 == pytest.approx(v, abs=1e-14 * (1.0 + abs(v)) + 4 * 2.0**-52 * mc.w * tau * amplitude)
        # V is the derivative of Y and Y''' that of Y'' (central differences).
        h = 1e-5 / mc.w
        ym, _ = p.yv(tau - h)
        yp, _ = p.yv(tau + h)
        assert (yp - ym) / (2 * h) == pytest.approx(v, abs=1e-7 * (1.0 + abs(v)))
        am, _ = p.aj(tau - h)
        ap, _ = p.aj(tau + h)
        _, a3 = p.aj(tau)
        assert (ap - am) / (2 * h) == pytest.approx(a3, abs=1e-6 * (1.0 + abs(a3)))


def test_resonant_formula_is_continuous_in_omega():
    # At w == Omega the exact formula takes the tau/2 limit; a hair off resonance it must
    # agree to first order in the detuning, without cancellation.
    st0 = exact._Stepper(Oscillator(F=0.3, Omega=1.0, beta=0.02, K=1e4))
    st1 = exact._Stepper(Oscillator(F=0.3, Omega=1.0 + 1e-10, beta=0.02, K=1e4))
    taus = np.linspace(0.0, 30.0, 61)
    y0, v0 = st0._slip_piece(Mode(0, 1), 5.0, 0.1, 0.4).yv(taus)
    y1, v1 = st1._slip_piece(Mode(0, 1), 5.0, 0.1, 0.4).yv(taus)
    np.testing.assert_allclose(y1, y0, rtol=0, atol=1e-7)
    np.testing.assert_allclose(v1, v0, rtol=0, atol=1e-7)


# -- the paper's contact case --------------------------------------------------------------
def test_contact_case_matches_reference_and_heyoka():
    h, e = _pair(CONTACT, 400.0, 0.95, 0.0)
    assert e.contact_entries(1) == 47 and e.contact_entries(-1) == 47
    assert e.mean_flange_force(1) == pytest.approx(0.180165173509774, rel=1e-10)
    _assert_agree(h, e)
    # The streamed integrals: rms force and forcing work (energy balance in exact).
    assert e.rms_flange_force() == pytest.approx(h.rms_flange_force(), rel=1e-10)
    assert e.forcing_work == pytest.approx(h.forcing_work, rel=1e-10)
    np.testing.assert_allclose(e.impacts.impulse, h.impacts.impulse, rtol=1e-9)
    np.testing.assert_allclose(e.impacts.peak_penetration, h.impacts.peak_penetration, rtol=1e-9)


def test_dense_output_and_windowed_impulse_match_heyoka():
    h, e = _pair(CONTACT, 120.0, 0.95, 0.0)
    # Dense enough to land inside many contact pieces (each ~0.016 long).
    times = np.concatenate([np.linspace(0.0, 120.0, 4001), e.events.t[:40] + 1e-3])
    times = times[times <= 120.0]
    xe, ve = e.sample(times)
    xh, vh = h.sample(times)
    np.testing.assert_allclose(xe, xh, rtol=0, atol=1e-12)
    # Inside a contact V changes at |X''| ~ K (|X| - 1) ~ 100 per unit time, so the 1e-13
    # agreement of the contact times is worth |X''| * 1e-13 in V at a fixed sample time.
    accel = np.abs(CONTACT.net_force(times, xe)) + CONTACT.beta
    assert np.all(np.abs(ve - vh) <= 1e-12 + 2e-13 * accel)
    # A window that cuts through contacts uses the dense impulse of the cut pieces.
    for side in (1, -1):
        lo, hi = e.events.t[3] - 0.005, e.events.t[60] + 0.004
        assert e.flange_impulse(side, lo, hi) == pytest.approx(h.flange_impulse(side, lo, hi), rel=1e-10)
    x, v = e.sample(e.events.t[5])
    assert np.ndim(x) == 0 and x == pytest.approx(e.events.x[5], abs=1e-15)


# -- agreement with heyoka on the other regimes ----------------------------------------------
def test_den_hartog_steady_state():
    h, e = _pair(Oscillator(F=0.5, Omega=1.5, beta=0.1, K=1e4), 200.0, 0.0, 0.0)
    assert e.counts["reversal"] > 80 and e.counts["stick"] == 0
    _assert_agree(h, e)


def test_forced_stick_and_release():
    h, e = _pair(Oscillator(F=0.5, Omega=0.3, beta=0.3, K=1e4), 100.0, 0.95, 0.0)
    assert e.counts["stick"] >= 5 and e.counts["release"] >= 5
    # After a release the acceleration is zero: the mass must slip on, not be swallowed.
    kinds = list(e.events.kind)
    for i, k in enumerate(kinds[:-1]):
        if k == "release":
            assert kinds[i + 1] != "release"
    _assert_agree(h, e)


def test_near_grazing_contacts():
    # v0 barely above 1: the turning points lie 5e-7 beyond the flanges. Every contact is
    # found: one contact per flange and period 2 pi, i.e. 4 contact events per period.
    h, e = _pair(Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0), 20.0, 0.0, 1.000001)
    n_per = (e.counts["contact_start"] + e.counts["contact_end"]) / 3.0
    assert e.t_final > 3 * 2 * math.pi
    assert n_per == 4.0
    assert np.all(e.impacts.complete)
    # The penetration is set by v_in^2 = v0^2 - 1 = 2e-6, itself carrying eps/2e-6 ~ 1e-10 of
    # rounding in any double-precision run, and a contact's impulse grows like v_in^3: the
    # forces agree to three times that conditioning (heyoka's contact times move by 2e-14
    # with the set of events it is given, which moved its forces by 3.5e-10: issue 20 item 9).
    _assert_agree(h, e, force_rtol=5e-10)


def test_free_resonance_without_contacts():
    # Omega = 1 = w in the free region; F < 4 beta / pi keeps the amplitude bounded (Den Hartog).
    h, e = _pair(Oscillator(F=0.01, Omega=1.0, beta=0.01, K=1e4), 200.0, 0.5, 0.0)
    assert e.contact_entries() == 0 and e.counts["reversal"] > 50
    _assert_agree(h, e)


def test_contact_resonance():
    # Omega equal to the contact frequency sqrt(1 + K): the exact w == Omega branch in contact.
    osc = Oscillator(F=0.5, Omega=math.sqrt(1.0 + 1e4), beta=0.01, K=1e4)
    h, e = _pair(osc, 8.0, 0.95, 1.0)
    assert e.contact_entries() >= 4
    _assert_agree(h, e)


def test_constant_force_sticks_for_ever():
    h, e = _pair(Oscillator(F=0.3, Omega=0.0, beta=0.1, K=1e4), 50.0, 0.95, 0.5)
    assert e.counts["stick"] == 1 and e.counts["release"] == 0
    assert e.final_mode.motion == 0
    _assert_agree(h, e)


def test_long_creep_run_event_counts():
    # Omega = 1e-3 over 1e5: thousands of stick/release pairs, each stick jumped by an arccos.
    osc = Oscillator(F=0.1, Omega=1e-3, beta=0.05, K=1e4)
    h, e = _pair(osc, 1e5, 0.95, 0.0, record="stats")
    assert e.status == 0 and e.t_final == 1e5
    assert e.counts["release"] > 1000
    assert e.counts == h.counts
    assert e.forcing_work == pytest.approx(h.forcing_work, rel=1e-9)


# -- run control -----------------------------------------------------------------------------
def test_event_limit_and_recording_levels():
    sol = simulate(CONTACT, 400.0, 0.95, 0.0, backend="exact", max_events=10)
    assert sol.status == 1 and len(sol.events) == 10
    full = simulate(CONTACT, 100.0, 0.95, 0.0, backend="exact")
    stats = simulate(CONTACT, 100.0, 0.95, 0.0, backend="exact", record="stats")
    assert stats.counts == full.counts
    assert stats.mean_flange_force(1) == full.mean_flange_force(1)
    with pytest.raises(ValueError, match="record='full'"):
        stats.sample(1.0)
    assert full.backend == "exact" and full.n_steps == full.n_pieces


def test_unknown_option_is_rejected():
    with pytest.raises(TypeError, match="does not accept"):
        simulate(CONTACT, 10.0, backend="exact", tol=1e-12)


# -- the linear family: damping and harmonic sums (issue #10 item 4) ------------------------
DAMPED_CONTACT = Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4, zeta=0.02)


@pytest.mark.parametrize("osc, t_end", [
    (DAMPED_CONTACT, 400.0),
    (Oscillator(0.5, 1.1, 0.01, 1e4, harmonics=[(0.2, 2.2, 0.3), (0.05, 3.3, 1.0)]), 60.0),
    (Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.05, harmonics=[(0.2, 2.2, 0.3)]), 100.0),
    (Oscillator(0.8, 0.4, 0.05, 50.0, 0.3, zeta=0.3, beta_static=0.1), 60.0),
])
def test_family_members_match_heyoka(osc, t_end):
    # Measured: event times within 4e-11, mean flange forces within 2e-13 relative.
    h, e = _pair(osc, t_end, 0.95, 0.0)
    _assert_agree(h, e, t_tol=1e-10, force_rtol=1e-11)
    assert e.contact_entries() > 0 or e.counts["stick"] > 0  # the last: stick-slip, no contact
    for sol in (h, e):
        bal = sol.energy_balance()
        assert abs(bal["residual"]) <= 1e-12 * bal["scale"]
    assert e.forcing_work == pytest.approx(h.forcing_work, rel=1e-10)
    if osc.zeta:
        assert e.energy_balance()["damping_work"] == pytest.approx(h.energy_balance()["damping_work"], rel=1e-10)


def test_damped_coulomb_decay_turns_to_1e10():
    from family_reference import coulomb_decay_turns

    osc = Oscillator(0.0, 0.0, 0.05, 1e4, zeta=0.05, beta_static=0.06)
    turns, t_stick = coulomb_decay_turns(0.95, 0.05, 0.06, zeta=0.05)
    ev = simulate(osc, 40.0, 0.95, 0.0, backend="exact").events
    assert ev.kind[-1] == "stick" and len(ev) == len(turns) and ev.t[-1] == pytest.approx(t_stick, abs=1e-10)
    np.testing.assert_allclose(ev.t, [t for t, _ in turns], rtol=0, atol=1e-10)
    np.testing.assert_allclose(ev.x, [x for _, x in turns], rtol=0, atol=1e-10)


@pytest.mark.parametrize("zeta", [1.0, 2.5, 1.0 - 1e-9, 1.0 + 1e-9])
def test_critically_and_over_damped_free_decay(zeta):
    # X'' + 2 zeta X' + X = 0 from (x0, v0): never turns, tends to 0. Closed forms:
    # critical (1 + t) e^{-t} x0 + t e^{-t} v0; over with roots l1,2 = -zeta +- mu.
    x0, v0 = 0.8, 0.3
    sol = simulate(Oscillator(0.0, 0.0, 0.0, 1e4, zeta=zeta), 12.0, x0, v0, backend="exact")
    assert sol.status == 0 and len(sol.events) == 1 and sol.events.kind[0] == "reversal"
    ts = np.linspace(0.0, 12.0, 49)
    x, v = sol.sample(ts)
    if zeta == 1.0:
        ref_x = ((1.0 + ts) * x0 + ts * v0) * np.exp(-ts)
        ref_v = (v0 - ts * (x0 + v0)) * np.exp(-ts)
    else:
        mu = np.sqrt(complex(zeta * zeta - 1.0))
        l1, l2 = -zeta + mu, -zeta - mu
        c1, c2 = (v0 - l2 * x0) / (l1 - l2), (l1 * x0 - v0) / (l1 - l2)
        ref_x = (c1 * np.exp(l1 * ts) + c2 * np.exp(l2 * ts)).real
        ref_v = (c1 * l1 * np.exp(l1 * ts) + c2 * l2 * np.exp(l2 * ts)).real
        if abs(zeta - 1.0) < 1e-6:  # the two-root form cancels there: compare with looser bounds
            np.testing.assert_allclose(x, ref_x, rtol=0, atol=1e-6)
            return
    np.testing.assert_allclose(x, ref_x, rtol=0, atol=1e-14)
    np.testing.assert_allclose(v, ref_v, rtol=0, atol=1e-14)
    # The turning point (velocity zero) of the critical/over-damped motion from v0 > 0.
    bal = sol.energy_balance()
    assert abs(bal["residual"]) <= 1e-13 * bal["scale"]


def test_harmonic_sum_forced_response_closed_form():
    # Free region, no friction, no contact: X = steady response of each harmonic + a
    # homogeneous part fixed by X(0), V(0) (undamped: cos/sin; damped: e^{-zeta t}).
    terms = [(0.1, 0.5, 0.3), (0.05, 1.7, 1.1), (0.02, 3.1, 0.0)]
    for zeta in (0.0, 0.1):
        osc = Oscillator.from_harmonics(terms, beta=0.0, K=1e4, zeta=zeta)
        ts = np.linspace(0.0, 30.0, 301)
        sol = simulate(osc, 30.0, 0.0, 0.0, backend="exact", sample_at=ts)
        assert sol.contact_entries() == 0
        gains = [F / complex(1.0 - Om * Om, 2.0 * zeta * Om) * np.exp(1j * ph) for F, Om, ph in terms]
        xs = sum((g * np.exp(1j * Om * ts)).real for g, (_, Om, _) in zip(gains, terms, strict=True))
        a = -sum(g.real for g in gains)
        b = -sum((1j * Om * g).real for g, (_, Om, _) in zip(gains, terms, strict=True))
        wd = math.sqrt(1.0 - zeta * zeta)
        xs = xs + np.exp(-zeta * ts) * (a * np.cos(wd * ts) + (b + zeta * a) / wd * np.sin(wd * ts))
        np.testing.assert_allclose(sol.samples.x, xs, rtol=0, atol=1e-14)


def test_damped_piece_bounds_hold():
    # The guard search's derivative bounds must dominate the true derivatives everywhere.
    for osc in (DAMPED_CONTACT, Oscillator(0.3, 0.7, 0.05, 50.0, zeta=3.0, harmonics=[(0.2, 2.2, 0.3)]),
                Oscillator(0.3, 0.7, 0.05, 50.0, zeta=1.0), Oscillator(0.3, 0.7, 0.05, 50.0, zeta=math.sqrt(51.0))):
        st = exact._Stepper(osc)
        for mode, x0, v0 in ((Mode(0, 1), 0.2, 0.5), (Mode(1, 1), 1.001, 0.8), (Mode(1, -1), 1.01, -0.3)):
            p = st._slip_piece(mode, 3.7, x0, v0)
            taus = np.linspace(0.0, 6.0, 3001)
            m2, m3 = p.bounds(6.0, 0)  # bounds of |Y''| and |Y'''| on [0, 6]
            a2 = np.array([p.aj(t)[0] for t in taus])
            a3 = np.array([p.aj(t)[1] for t in taus])
            assert np.max(np.abs(a2)) <= m2 and np.max(np.abs(a3)) <= m3
            # Y'''' (central differences of Y''') against the order-4 bound the ACCEL_ZERO search uses.
            assert np.max(np.abs(np.gradient(a3, taus))) <= p.bounds(6.0, 1)[1]


def test_exact_refuses_near_resonance_and_power_law():
    with pytest.raises(ValueError, match="exact backend does not support a forcing harmonic at resonance"):
        simulate(Oscillator(0.5, 1.1, 0.01, 1e4, harmonics=[(0.1, 1.0, 0.0)]), 1.0, backend="exact")
    with pytest.raises(ValueError, match="exact backend does not support a power-law flange"):
        simulate(Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.1, exponent=1.5), 1.0, backend="exact")
    # Damped, the same harmonic is fine: no singularity.
    assert simulate(Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.05, harmonics=[(0.1, 1.0, 0.0)]), 5.0,
                    backend="exact").status == 0
