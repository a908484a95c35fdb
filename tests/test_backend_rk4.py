"""rk4 backend: the paper's fixed-step baseline, its genuine errors measured against heyoka."""

import dataclasses
import math
import warnings

import numpy as np
import pytest
from scipy.integrate import quad

import impactosc as io
from impactosc.backends import rk4

CONTACT_CASE = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


@pytest.fixture(scope="module")
def contact_pair():
    """The contact case with rk4 at its default step and with heyoka (the reference)."""
    return (io.simulate(CONTACT_CASE, 400.0, 0.95, 0.0, backend="rk4"),
            io.simulate(CONTACT_CASE, 400.0, 0.95, 0.0, backend="heyoka"))


def test_free_oscillator_is_fourth_order():
    # |X| stays below the flanges and beta = 0, so the right-hand side is smooth: classic RK4.
    osc = io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=1e4)
    errors = []
    for dt in (0.1, 0.05):
        sol = io.simulate(osc, 10.0, 0.5, 0.0, backend="rk4", dt=dt, record="stats")
        assert sol.status == 0 and sol.t_final == 10.0 and sol.n_steps == round(10.0 / dt)
        errors.append(abs(sol.x_final - 0.5 * math.cos(10.0)))
    assert 12.0 <= errors[0] / errors[1] <= 20.0


def test_contact_case_against_heyoka(contact_pair):
    sol, ref = contact_pair
    assert sol.status == 0 and sol.backend == "rk4"
    # The default step resolves every contact: same count per flange as the reference.
    assert sol.contact_entries(1) == ref.contact_entries(1) == 47
    assert sol.contact_entries(-1) == ref.contact_entries(-1) == 47
    assert sol.counts["stick"] == sol.counts["release"] == 0
    # First entry: only free flight precedes it, so its error is the O(dt^2) linear
    # interpolation of the crossing (measured 3.9e-8). Later entries carry the error RK4
    # makes every time a step straddles the kink of the flange force (and the jump of
    # sign(V)): they drift by up to ~1e-3 over the run (measured 1.3e-3).
    first = abs(sol.events.t[0] - ref.events.t[0])
    assert 1e-8 < first < 1e-2
    drift = np.abs(sol.impacts.start - ref.impacts.start).max()
    assert 1e-4 < drift < 1e-2
    # Mean flange force (measured relative errors 5.4e-6 upper, 3.1e-5 lower).
    for side in (1, -1):
        rel = abs(sol.mean_flange_force(side) / ref.mean_flange_force(side) - 1.0)
        assert 1e-8 < rel < 1e-2
        assert sol.rms_flange_force(side) == pytest.approx(ref.rms_flange_force(side), rel=1e-3)
        assert sol.contact_time(side) == pytest.approx(ref.contact_time(side), rel=1e-4)
        assert sol.max_penetration(side) == pytest.approx(ref.max_penetration(side), rel=1e-3)
    assert sol.forcing_work == pytest.approx(ref.forcing_work, rel=1e-3)
    assert sol.friction_work == pytest.approx(ref.friction_work, rel=1e-4)


def test_tables_and_recording_levels(contact_pair):
    full, _ = contact_pair
    ev = io.simulate(CONTACT_CASE, 400.0, 0.95, 0.0, backend="rk4", record="events")
    st = io.simulate(CONTACT_CASE, 400.0, 0.95, 0.0, backend="rk4", record="stats")
    for s in (ev, st):
        assert s.counts == full.counts
        assert s.mean_flange_force(-1) == full.mean_flange_force(-1)
        assert s.rms_flange_force() == full.rms_flange_force()
        assert s.max_penetration(1) == full.max_penetration(1)
    np.testing.assert_array_equal(ev.events.t, full.events.t)
    assert list(full.events.kind[:3]) == ["contact_start", "reversal", "contact_end"]
    # Impacts: the per-contact impulses add up to the streamed totals, penetrations are positive.
    imp = full.impacts
    assert len(imp) == 94 and imp.complete.all()
    for side in (1, -1):
        assert imp.impulse[imp.side == side].sum() == pytest.approx(full.flange_impulse(side), rel=1e-12)
    assert (imp.peak_penetration > 0).all()
    np.testing.assert_allclose(imp.peak_force, CONTACT_CASE.K * imp.peak_penetration)


def test_dense_output_and_windows(contact_pair):
    full, ref = contact_pair
    # Free flight before the first contact: only the naive sign(0) of the very first stage
    # differs from the exact solution (an O(beta dt) velocity error, ~1e-6).
    t = np.linspace(0.0, 3.0, 13)
    x, v = full.sample(t)
    xr, vr = ref.sample(t)
    np.testing.assert_allclose(x, xr, atol=1e-5)
    np.testing.assert_allclose(v, vr, atol=1e-5)
    cuts = [0.0, 37.3, 100.0, 100.01, 255.5, 400.0]
    parts = [full.flange_impulse(None, a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    assert sum(parts) == pytest.approx(full.flange_impulse(), rel=1e-12)
    imp = full.impacts[3]
    mid = 0.5 * (imp.start + imp.end)
    a = full.flange_impulse(int(imp.side), imp.start, mid)
    b = full.flange_impulse(int(imp.side), mid, imp.end)
    assert a > 0 and b > 0 and a + b == pytest.approx(imp.impulse, rel=1e-12)
    # Keeping every 10th step: same streamed statistics, interpolation still close.
    thin = io.simulate(CONTACT_CASE, 400.0, 0.95, 0.0, backend="rk4", every=10)
    assert thin.mean_flange_force() == full.mean_flange_force()
    tt = np.linspace(0.0, 400.0, 1001)
    np.testing.assert_allclose(thin.sample(tt)[0], full.sample(tt)[0], atol=1e-4)


def test_naive_sign_never_sticks():
    # Exact answer: reversals at k pi (k = 1..4), then stuck at X = 0.05 from t = 5 pi on.
    osc = io.Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4)
    sol = io.simulate(osc, 30.0, 0.95, 0.0, backend="rk4")
    assert sol.counts["stick"] == 0 and sol.counts["release"] == 0
    # At the default step RK4 does not chatter at the step ends, contrary to what one might
    # expect: with |f_net| < beta the stages straddle V = 0 inside each step (sign(V) flips
    # between stages) and the map V_n -> V_n+1 keeps V on one side, |V| ~ beta dt. So only
    # the 4 true reversals are seen, and the "stuck" mass creeps at that spurious speed.
    assert sol.counts["reversal"] == 4
    np.testing.assert_allclose(sol.events.t, [math.pi, 2 * math.pi, 3 * math.pi, 4 * math.pi], atol=1e-3)
    x, v = sol.sample(np.array([16.0, 23.0, 30.0]))
    assert np.all(np.diff(x) < 0)  # still moving long after the exact solution stopped
    assert 1e-5 < 0.05 - sol.x_final < 1e-3  # measured 2.2e-4 of creep by t = 30
    assert 0 < -sol.v_final < 1e-3 * sol.oscillator.beta
    # A coarse step (as a long baseline run would use) chatters: V changes sign at step
    # ends, reported as spurious reversals after 5 pi (measured 10 at dt = 0.1).
    coarse = io.simulate(osc, 30.0, 0.95, 0.0, backend="rk4", dt=0.1)
    assert coarse.counts["stick"] == 0
    assert np.count_nonzero(coarse.events.t > 5 * math.pi + 0.1) >= 5
    assert coarse.counts["reversal"] > 4 + 4


def test_paper_flange_misprint_throws_the_mass_out():
    # Eq. 3 as printed, -K H(X^2-1)(X-1), is K(1+|X|) >= 2K for X < -1: the lower flange
    # does not pull the mass in, it becomes a wall that jumps from 0 to 2K at X = -1 and
    # stops the mass in far less than one step. The fixed step then hands the mass a
    # spurious kick whose size depends on where the steps fall (energy gain from ~1x to
    # ~25x for starting points in [0, 0.3]): the run gains energy with every bounce.
    free = io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=1e4)
    runs = {fl: io.simulate(free, 1.5, 0.0, -2.0, backend="rk4", flange=fl) for fl in ("consistent", "paper")}
    for fl, s in runs.items():
        first = s.impacts[0] if fl == "consistent" else None
        xs, _ = s.sample(np.linspace(0.0, 1.5, 30001))
        if fl == "consistent":
            assert first.side == -1 and abs(first.exit_velocity + first.entry_velocity) < 1e-3
            assert 0.0172 < -xs.min() - 1.0 < 0.0173  # sqrt(3)/sqrt(1+K)
        else:
            assert -xs.min() - 1.0 < 1e-3  # barely enters: not pulled through
    energy = {fl: 0.5 * s.v_final**2 + 0.5 * s.x_final**2 for fl, s in runs.items()}
    assert energy["consistent"] == pytest.approx(2.0, rel=1e-3)
    assert energy["paper"] > 3.0  # measured 7.83

    # Forcing pushing down from near the lower flange (the brief's case): the statistics
    # are off by orders of magnitude (measured 854/753 vs 47/47 contacts, mean force ~97
    # vs 0.18, upper penetration 0.90 vs 0.0084).
    osc = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4, phase=math.pi)
    cons = io.simulate(osc, 400.0, -0.95, 0.0, backend="rk4", record="stats")
    paper = io.simulate(osc, 400.0, -0.95, 0.0, backend="rk4", record="stats", flange="paper")
    assert cons.contact_entries(-1) == 47 and paper.contact_entries(-1) > 5 * 47
    assert paper.mean_flange_force() > 100 * cons.mean_flange_force()
    assert paper.max_penetration(1) > 10 * cons.max_penetration(1)


def test_event_limit_keeps_results_up_to_the_limit(contact_pair):
    full, _ = contact_pair
    sol = io.simulate(CONTACT_CASE, 400.0, 0.95, 0.0, backend="rk4", max_events=10)
    assert sol.status == 1 and "max_events=10" in sol.message
    assert len(sol.events) == 10 and sol.t_final == sol.events.t[-1]
    np.testing.assert_array_equal(sol.events.t, full.events.t[:10])
    assert sol.events.kind[-1] == "contact_end"
    n = len(sol.impacts)
    assert n == 3 and sol.flange_impulse() == pytest.approx(full.impacts.impulse[:n].sum(), rel=1e-12)


def test_start_inside_a_flange_and_blow_up():
    sol = io.simulate(CONTACT_CASE, 5.0, 1.02, 0.5, backend="rk4")
    first = sol.impacts[0]
    assert first.start == 0.0 and first.side == 1 and not first.complete and first.entry_velocity == 0.5
    assert list(sol.events.kind[:2]) == ["reversal", "contact_end"]
    # Far too coarse a step for K = 1e4 (omega dt = 10): RK4 is unstable in contact.
    bad = io.simulate(CONTACT_CASE, 400.0, 0.95, 0.0, backend="rk4", dt=0.1)
    assert bad.status == -1 and "non-finite" in bad.message and bad.t_final < 400.0
    assert math.isfinite(bad.x_final)


@pytest.mark.parametrize("dt, match", [(0.0, "dt must be > 0"), (-1.0, "dt must be > 0"),
                                       (math.nan, "dt must be finite"), (11.0, "dt must be <= t_end"),
                                       (1e-12, "steps")])
def test_bad_dt(dt, match):
    with pytest.raises(ValueError, match=match):
        io.simulate(CONTACT_CASE, 10.0, backend="rk4", dt=dt)


def test_bad_flange_and_every():
    with pytest.raises(ValueError, match="flange.*'nope'"):
        io.simulate(CONTACT_CASE, 10.0, backend="rk4", flange="nope")
    with pytest.raises(ValueError, match="every"):
        io.simulate(CONTACT_CASE, 10.0, backend="rk4", every=0)
    with pytest.raises(ValueError, match="flange.*'nope'"):
        rk4.rk4_batch(0.5, 1.1, 0.01, 1e4, flange="nope")


def test_batch_equals_single_runs():
    F = np.array([0.5, 0.3, 0.7])
    Om = np.array([1.1, 0.9, 1.3])
    beta = np.array([0.01, 0.02, 0.0])
    res = rk4.rk4_batch(F, Om, beta, 1e4, 0.0, 100.0, 0.95, 0.0)
    assert res.mean_force_upper.shape == (3,)
    for i in range(3):
        s = io.simulate(io.Oscillator(F[i], Om[i], beta[i], 1e4), 100.0, 0.95, 0.0, backend="rk4", record="stats")
        assert res.mean_force_upper[i] == s.mean_flange_force(1)
        assert res.mean_force_lower[i] == s.mean_flange_force(-1)
        assert res.contacts_upper[i] == s.contact_entries(1) and res.contacts_lower[i] == s.contact_entries(-1)
        assert res.max_penetration_upper[i] == s.max_penetration(1)
        assert res.max_penetration_lower[i] == s.max_penetration(-1)
        assert res.status[i] == 0
    assert res.contacts_upper.min() > 0
    with pytest.raises(ValueError, match="K"):
        rk4.rk4_batch(0.5, 1.1, 0.01, [1e4, -1.0])


def test_plain_python_fallback_warns_and_agrees(monkeypatch):
    """Without numba the same loop runs as plain Python, with a one-time install hint."""
    fast = io.simulate(CONTACT_CASE, 4.0, 0.95, 0.0, backend="rk4")
    monkeypatch.setattr(rk4, "_HAVE_NUMBA", False)
    monkeypatch.setattr(rk4, "_warned_slow", False)
    monkeypatch.setattr(rk4, "_KERNEL", getattr(rk4._kernel, "py_func", rk4._kernel))
    with pytest.warns(RuntimeWarning, match=r"pip install 'impactosc\[fast\]' \(numba\)"):
        slow = io.simulate(CONTACT_CASE, 4.0, 0.95, 0.0, backend="rk4")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        io.simulate(CONTACT_CASE, 0.5, 0.95, 0.0, backend="rk4")  # warned once only
    assert slow.counts == fast.counts
    np.testing.assert_allclose(slow.events.t, fast.events.t, rtol=1e-12)
    assert slow.mean_flange_force() == pytest.approx(fast.mean_flange_force(), rel=1e-12)


# -- the model family (issue #10): what the fixed-step scheme can express -------------------
def test_damped_free_decay_is_fourth_order():
    # X'' + 2 zeta X' + X = 0 from rest at x0 (|X| < 1, beta = 0): a smooth right-hand side.
    zeta, x0, t_end = 0.05, 0.5, 10.0
    wd = math.sqrt(1.0 - zeta * zeta)

    def v_exact(t):
        return -x0 * math.exp(-zeta * t) / wd * math.sin(wd * t)

    x_end = x0 * math.exp(-zeta * t_end) * (math.cos(wd * t_end) + zeta / wd * math.sin(wd * t_end))
    loss = 2.0 * zeta * quad(lambda t: v_exact(t) ** 2, 0.0, t_end, epsabs=1e-14, limit=200)[0]
    osc = io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=1e4, zeta=zeta)
    errors = []
    for dt in (0.1, 0.05):
        sol = io.simulate(osc, t_end, x0, 0.0, backend="rk4", dt=dt, record="stats")
        errors.append((abs(sol.x_final - x_end), abs(sol.v_final - v_exact(t_end)), abs(sol.damping_work - loss)))
        # The identity E(end) - E(0) = -2 zeta int V^2, with int V^2 integrated by RK4 itself.
        balance = sol.energy_balance()
        assert abs(balance["residual"]) < 1e-6 * balance["scale"]  # measured 4.2e-7, 5.4e-8 relative
    for coarse, fine in zip(*errors, strict=True):
        assert 1e-9 < fine < coarse
        assert 12.0 <= coarse / fine <= 32.0  # measured 15.3 (X), 16.7 (V), 24.7 (int V^2)


HARMONICS = [(0.1, 2.3, 0.3), (0.05, 3.7, 1.0)]


def test_harmonic_sum_against_scipy():
    # Free flight (|X| < 0.71, beta = 0) under three harmonics and damping: fourth order
    # against scipy's DOP853 at rtol 1e-13, so each harmonic's phase rotation is exact.
    osc = io.Oscillator(0.1, 1.1, 0.0, 1e4, zeta=0.02, harmonics=HARMONICS)
    ref = io.simulate(osc, 20.0, 0.1, 0.0, backend="scipy", record="stats")
    assert ref.counts["contact_start"] == 0
    errors = []
    for dt in (0.1, 0.05):
        sol = io.simulate(osc, 20.0, 0.1, 0.0, backend="rk4", dt=dt, record="stats")
        errors.append((abs(sol.x_final - ref.x_final), abs(sol.v_final - ref.v_final)))
        assert sol.damping_work == pytest.approx(ref.damping_work, rel=1e-5)
        # The forcing work is the trapezoid rule, O(dt^2) (measured 7.9e-5, 2.0e-5 of 1.5).
        assert sol.forcing_work == pytest.approx(ref.forcing_work, abs=2e-4)
    for coarse, fine in zip(*errors, strict=True):
        assert 1e-9 < fine < coarse
        assert 12.0 <= coarse / fine <= 20.0  # measured 13.9 (X), 16.2 (V)


def test_harmonics_damping_and_contacts_against_scipy():
    # Contacts with a linear flange and small friction that never sticks here: RK4 at its
    # default step across the kinks of the force, against scipy's located events.
    osc = io.Oscillator(0.5, 1.1, 0.01, 100.0, zeta=0.02, harmonics=[(0.1, 2.2, 0.3), (0.05, 3.3, 1.0)])
    ref = io.simulate(osc, 60.0, 0.95, 0.0, backend="scipy")
    sol = io.simulate(osc, 60.0, 0.95, 0.0, backend="rk4")
    assert ref.counts["stick"] == 0 and ref.contact_entries(1) == 9
    assert sol.counts == ref.counts
    t = np.linspace(0.0, 60.0, 601)
    np.testing.assert_allclose(sol.sample(t)[0], ref.sample(t)[0], atol=5e-3)  # measured 1.1e-3
    assert abs(sol.events.t[0] - ref.events.t[0]) < 3e-5  # first entry, free flight only: 3.1e-6
    for side in (1, -1):
        # measured relative errors 1.5e-4 and 3.8e-4 (mean force), 2.1e-4 (peak penetration)
        assert sol.mean_flange_force(side) == pytest.approx(ref.mean_flange_force(side), rel=2e-3)
        assert sol.max_penetration(side) == pytest.approx(ref.max_penetration(side), rel=2e-3)
    balance = sol.energy_balance()
    assert balance["damping_work"] == pytest.approx(ref.damping_work, rel=1e-3)
    assert abs(balance["residual"]) < 1e-3 * balance["scale"]  # measured 4.4e-5 relative


def test_hertz_contact_against_scipy():
    osc = io.Oscillator(0.5, 1.1, 0.0, 1e4, exponent=1.5)
    ref = io.simulate(osc, 60.0, 0.95, 0.0, backend="scipy")
    sol = io.simulate(osc, 60.0, 0.95, 0.0, backend="rk4")
    assert sol.counts == ref.counts and ref.contact_entries() == 14
    t = np.linspace(0.0, 60.0, 601)
    x, v = sol.sample(t)
    xr, vr = ref.sample(t)
    np.testing.assert_allclose(x, xr, atol=2e-5)  # measured 3.8e-6
    np.testing.assert_allclose(v, vr, atol=3e-4)  # measured 5.9e-5
    assert sol.mean_flange_force() == pytest.approx(ref.mean_flange_force(), rel=1e-5)  # measured 1.1e-6
    np.testing.assert_allclose(sol.impacts.peak_penetration, ref.impacts.peak_penetration, rtol=1e-3)
    # The streamed peak force is the power law of the sampled peak penetration.
    np.testing.assert_allclose(sol.impacts.peak_force, 1e4 * sol.impacts.peak_penetration**1.5, rtol=1e-14)
    # Energy with the Hertz potential K d^2.5 / 2.5 balances: the kernel's force is K d^1.5.
    balance = sol.energy_balance()
    assert abs(balance["residual"]) < 1e-5 * balance["scale"]  # measured 2.2e-6 relative


def test_family_kernel_reduces_to_eq3():
    base = io.simulate(CONTACT_CASE, 20.0, 0.95, 0.0, backend="rk4")
    # Static = kinetic friction is eq. 3 itself (same kernel, same numbers).
    same = io.simulate(dataclasses.replace(CONTACT_CASE, beta_static=CONTACT_CASE.beta), 20.0, 0.95, 0.0,
                       backend="rk4")
    assert (same.x_final, same.v_final, same.mean_flange_force()) == (base.x_final, base.v_final,
                                                                      base.mean_flange_force())
    # A zero-amplitude harmonic runs the kernel compiled with the family terms (damping 0,
    # p = 1): it must give eq. 3's numbers.
    fam = io.simulate(dataclasses.replace(CONTACT_CASE, harmonics=[(0.0, 2.0, 0.0)]), 20.0, 0.95, 0.0,
                      backend="rk4")
    assert fam.counts == base.counts and fam.counts["contact_start"] == 4
    np.testing.assert_allclose(fam.events.t, base.events.t, rtol=1e-13)
    assert fam.mean_flange_force() == pytest.approx(base.mean_flange_force(), rel=1e-12)
    assert fam.forcing_work == pytest.approx(base.forcing_work, rel=1e-12)
    assert fam.damping_work == 0.0


@pytest.mark.parametrize("osc, kwargs, match", [
    (io.Oscillator(0.5, 1.1, 0.01, 1.0, flange="rigid", restitution=0.8), {},
     r"rk4 baseline does not support a rigid flange \(restitution=0.8\).*event location.*heyoka"),
    (io.Oscillator(0.5, 1.1, 0.1, 1e4, beta_static=0.2), {},
     r"does not support static friction beta_static=0.2 > beta=0.1.*no stick logic.*heyoka"),
    (io.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5), {"flange": "paper"},
     r"flange='paper'.*linear flange law only, got exponent=1.5"),
    (CONTACT_CASE, {"sample_at": [1.0]}, r"sample_at needs time events.*heyoka"),
])
def test_family_refusals(osc, kwargs, match):
    with pytest.raises(ValueError, match=match):
        io.simulate(osc, 10.0, 0.5, 0.0, backend="rk4", **kwargs)


def test_batch_family_equals_single_runs():
    zeta = np.array([0.0, 0.03, 0.01])
    p = np.array([1.0, 1.5, 1.0])
    F2 = np.array([0.0, 0.1, 0.2])
    res = rk4.rk4_batch(0.5, 1.1, 0.01, 1e4, 0.0, 50.0, 0.95, 0.0, zeta=zeta, exponent=p,
                        harmonics=[(F2, 2.2, 0.3)])
    for i in range(3):
        osc = io.Oscillator(0.5, 1.1, 0.01, 1e4, zeta=zeta[i], exponent=p[i], harmonics=[(F2[i], 2.2, 0.3)])
        s = io.simulate(osc, 50.0, 0.95, 0.0, backend="rk4", record="stats")
        assert (res.mean_force_upper[i], res.mean_force_lower[i]) == (s.mean_flange_force(1), s.mean_flange_force(-1))
        assert res.contacts_upper[i] == s.contact_entries(1) > 0
        assert res.max_penetration_lower[i] == s.max_penetration(-1)
    assert len(set(res.mean_force_upper.tolist())) == 3  # the family terms reached the kernel
    with pytest.raises(ValueError, match="linear flange law only, got exponent=1.5"):
        rk4.rk4_batch(0.5, 1.1, 0.01, 1e4, exponent=p, flange="paper")
    with pytest.raises(ValueError, match="zeta must be finite and >= 0"):
        rk4.rk4_batch(0.5, 1.1, 0.01, 1e4, zeta=[0.1, -0.1])
    with pytest.raises(ValueError, match="exponent must be finite and >= 1"):
        rk4.rk4_batch(0.5, 1.1, 0.01, 1e4, exponent=0.5)
    with pytest.raises(ValueError, match=r"harmonics\[0\] amplitude"):
        rk4.rk4_batch(0.5, 1.1, 0.01, 1e4, harmonics=[([0.1, -0.1], 2.0, 0.0)])
    with pytest.raises(TypeError, match=r"harmonics\[0\] must be a triple"):
        rk4.rk4_batch(0.5, 1.1, 0.01, 1e4, harmonics=[0.1])


def test_plain_python_fallback_agrees_on_a_family_member(monkeypatch):
    osc = io.Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.02, exponent=1.5, harmonics=HARMONICS)
    fast = io.simulate(osc, 3.0, 0.95, 1.0, backend="rk4")
    monkeypatch.setattr(rk4, "_warned_slow", True)
    monkeypatch.setattr(rk4, "_KERNEL", getattr(rk4._kernel, "py_func", rk4._kernel))
    slow = io.simulate(osc, 3.0, 0.95, 1.0, backend="rk4")
    assert slow.counts == fast.counts and slow.contact_entries(1) == 1
    assert slow.x_final == pytest.approx(fast.x_final, rel=1e-12)
    assert slow.damping_work == pytest.approx(fast.damping_work, rel=1e-12)
    assert slow.flange_impulse() == pytest.approx(fast.flange_impulse(), rel=1e-12)
