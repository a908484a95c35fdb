"""heyoka backend on the model family (issue 10): closed forms first, then scipy on random members.

Every member runs on the one heyoka loop, on the compiled integrator of its system structure
(``compiled_integrator``). The closed forms: damped Coulomb decay (turning times k pi / w_d),
static against kinetic friction, a Hertz contact (energy conservation and a quadrature for
its duration), chatter on a rigid flange under a constant push (the impact sequence summed
to convergence), the release from a rigid flange under harmonic forcing (an arccos) and a
forced linear oscillator with a harmonic sum.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.optimize import brentq

import impactosc as io
from impactosc.backends import heyoka as hb

O = io.Oscillator


# -- shapes ---------------------------------------------------------------------------------
def test_each_structure_compiles_its_own_integrator_and_equal_members_share_one():
    eq3 = O(0.5, 1.1, 0.01, 1e4)
    assert hb.compiled_integrator(eq3) is hb.compiled_integrator(eq3, hb.DEFAULT_TOL)
    assert hb.compiled_integrator(eq3) is hb.compiled_integrator(O(0.2, 0.7, 0.05, 1e3, phase=1.0))
    # Equal static friction is the same member: the same integrator, the same run bit for bit.
    same = O(0.5, 1.1, 0.01, 1e4, beta_static=0.01)
    assert hb.compiled_integrator(same) is hb.compiled_integrator(eq3)
    a, b = io.simulate(eq3, 100.0, 0.95, 0.0), io.simulate(same, 100.0, 0.95, 0.0)
    np.testing.assert_array_equal(a.events.t, b.events.t)
    assert a.mean_flange_force() == b.mean_flange_force()
    # int V^2 is a state of damped members only; a rigid flange has no flange impulse states.
    dims = [hb.compiled_integrator(osc).ta.dim for osc in
            (eq3, O(0.5, 1.1, 0.01, 1e4, zeta=0.1), O(0.5, 1.1, 0.01, flange="rigid"),
             O(0.5, 1.1, 0.01, flange="rigid", zeta=0.1))]
    assert dims == [5, 6, 3, 4]
    with pytest.raises(ValueError, match="tol must be in"):
        hb.compiled_integrator(eq3, tol=0.5)


# -- damping and friction -------------------------------------------------------------------
ZETA, BETA = 0.05, 0.02
W_D = math.sqrt(1.0 - ZETA**2)


def _decay_amplitudes(a0: float, n: int) -> list[float]:
    # Each half cycle is a damped arc about the centre -beta s: it turns after pi / w_d with
    # the offset from the centre scaled by -exp(-zeta pi / w_d).
    q = math.exp(-ZETA * math.pi / W_D)
    amps = [a0]
    for _ in range(n):
        amps.append(q * (amps[-1] - BETA) - BETA)
    return amps


@pytest.mark.parametrize("beta_static", [None, 0.1])
def test_damped_coulomb_decay_closed_form(beta_static):
    osc = O(0.0, 0.0, BETA, 1e4, zeta=ZETA, beta_static=beta_static)
    sol = io.simulate(osc, 100.0, x0=0.9, v0=0.0)
    amps = _decay_amplitudes(0.9, 40)
    turn = next(k for k in range(1, 40) if amps[k] <= osc.beta_s)  # |f_net| = |X| <= beta_s: stick
    ev = sol.events
    assert list(ev.kind) == ["reversal"] * (turn - 1) + ["stick"]
    k = np.arange(1, turn + 1)
    np.testing.assert_allclose(ev.t, k * math.pi / W_D, rtol=0, atol=1e-13)
    np.testing.assert_allclose(ev.x, (-1.0) ** k * np.array(amps[1:turn + 1]), rtol=0, atol=1e-13)
    assert sol.x_final == ev.x[-1] and sol.v_final == 0.0
    bal = sol.energy_balance()
    assert bal["damping_work"] > 0.1 and abs(bal["residual"]) <= 1e-14


def test_static_friction_sticks_at_an_earlier_turn_than_equal_coefficients():
    amps = _decay_amplitudes(0.9, 40)
    equal = io.simulate(O(0.0, 0.0, BETA, 1e4, zeta=ZETA), 100.0, 0.9, 0.0).events
    k_equal = len(equal)
    # A static level between two turning amplitudes before the kinetic stick: the same arcs,
    # but the stick test holds the mass two turns earlier.
    beta_s = 0.5 * (amps[k_equal - 2] + amps[k_equal - 3])
    static = io.simulate(O(0.0, 0.0, BETA, 1e4, zeta=ZETA, beta_static=beta_s), 100.0, 0.9, 0.0).events
    assert equal.kind[-1] == static.kind[-1] == "stick" and len(static) == k_equal - 2
    np.testing.assert_array_equal(static.t, equal.t[:k_equal - 2])
    assert abs(static.x[-1]) == pytest.approx(amps[k_equal - 2], abs=1e-13)


def test_static_friction_releases_at_beta_s_and_slips_at_beta():
    osc = O(0.5, 0.3, 0.2, 1e4, beta_static=0.35)
    sol = io.simulate(osc, 200.0)
    ev = sol.events
    assert sol.counts["release"] >= 5 and sol.counts["stick"] >= 5
    for e in ev[ev.kind == "release"]:
        assert abs(abs(osc.net_force(e.t, e.x)) - 0.35) <= 1e-12
    for e in ev[ev.kind == "stick"]:
        assert abs(osc.net_force(e.t, e.x)) <= 0.35 + 1e-12
    # The kinetic level does the work while slipping (the identity holds with beta, not beta_s).
    assert abs(sol.energy_balance()["residual"]) <= 1e-12


# -- Hertz contact ----------------------------------------------------------------------------
def _hertz_contact(K: float, p: float, v0: float):
    """Closed form of a contact entered from free flight (F = beta = 0): energy is conserved.

    Returns ``(t_in, duration, peak penetration, impulse)``. In the contact
    ``V^2 = G(d) = v0^2 - (1 + d)^2 - 2K d^(p+1)/(p+1)``; the duration is ``2 int dd / sqrt(G)``
    up to the peak ``G(d_m) = 0``, taken with ``d = d_m - s^2`` and ``G`` written as
    ``G(d) - G(d_m)`` (no cancellation near the peak).
    """
    c = 2.0 * K / (p + 1.0)
    d_m = brentq(lambda d: v0 * v0 - (1.0 + d) ** 2 - c * d ** (p + 1.0), 0.0, 1.0, xtol=1e-300, rtol=8.9e-16)

    def g(s):
        gap = s * s
        return gap * (2.0 + 2.0 * d_m - gap) - c * d_m ** (p + 1.0) * math.expm1((p + 1.0) * math.log1p(-gap / d_m))

    opts = dict(epsabs=0.0, epsrel=1.2e-14, limit=200)
    root = math.sqrt(d_m)
    duration = 2.0 * quad(lambda s: 2.0 * s / math.sqrt(g(s)), 0.0, root, **opts)[0]
    impulse = 2.0 * quad(lambda s: 2.0 * s * K * (d_m - s * s) ** p / math.sqrt(g(s)), 0.0, root, **opts)[0]
    return math.asin(1.0 / v0), duration, d_m, impulse


@pytest.mark.parametrize("K, p, v0", [(1e4, 1.5, 2.0), (100.0, 2.0, 2.0), (1e6, 1.5, 1.5), (1e4, 1.1, 2.0),
                                      (1e4, 1.5, 1.0001)])
def test_hertz_contact_closed_form(K, p, v0):
    t_in, duration, d_m, impulse = _hertz_contact(K, p, v0)
    v_in = math.sqrt(v0 * v0 - 1.0)
    sol = io.simulate(O(0.0, 0.0, 0.0, K, exponent=p), t_in + duration + 0.5, 0.0, v0)
    ev = sol.events
    assert list(ev.kind) == ["contact_start", "reversal", "contact_end"]
    assert abs(ev.t[0] - t_in) <= 1e-14 and ev.v[0] == pytest.approx(v_in, rel=1e-14)
    assert abs(ev.t[2] - ev.t[0] - duration) <= 1e-10
    assert abs(ev.t[1] - ev.t[0] - duration / 2) <= 1e-10
    assert ev.x[1] - 1.0 == pytest.approx(d_m, rel=1e-12)
    assert ev.v[2] == pytest.approx(-v_in, rel=1e-12)  # exit speed = entry speed
    im = sol.impacts[0]
    assert im.peak_penetration == pytest.approx(d_m, rel=1e-12) and im.impulse == pytest.approx(impulse, rel=1e-10)
    assert im.peak_force == pytest.approx(K * d_m**p, rel=1e-12)
    # Dense output inside the contact (across the boundary layer) conserves the energy.
    ts = np.linspace(ev.t[0], ev.t[2], 41)
    x, v = sol.sample(ts)
    # (the stiffest case, K = 1e6, 155 steps: 1.1e-13 with the layer crossed in 64 ulps of the time, 6.8e-14 with
    # the unit-roundoff layer alone; ~100 eps of the energy either way, the others below 3.5e-14)
    np.testing.assert_allclose(O(0.0, 0.0, 0.0, K, exponent=p).energy(x, v), 0.5 * v0 * v0, rtol=0, atol=2e-13)
    assert abs(sol.energy_balance()["residual"]) <= 1e-13


# -- rigid flange -------------------------------------------------------------------------------
def _chatter_closed_form(e: float, F: float, beta: float):
    """Impacts of a mass pushed into the upper rigid wall by a constant F > 1 + beta from rest at 0.

    Each flight is a harmonic arc: away from the wall about the centre ``F + beta``, back
    about ``F - beta`` (Omega = 0, so time plays no role but as the sum of flight times).
    With ``a = F - beta - 1`` and ``b = F + beta - 1`` the wall distances of the centres, an
    impact at speed ``u`` leaves at ``w = e u``, turns after ``atan2(w, b)`` at the distance
    ``R1 = hypot(b, w)`` from its centre, returns after ``atan2(sqrt(R2^2 - a^2), a)`` with
    ``R2 - a = R1 - b = w^2 / (R1 + b)`` and hits at ``sqrt(R2^2 - a^2)``. Summed until the
    flights stop changing the time.
    """
    a, b = F - beta - 1.0, F + beta - 1.0
    t = math.acos(a / (F - beta))
    u = math.sqrt((F - beta) ** 2 - a * a)
    times, speeds = [t], [u]
    while True:
        w = e * u
        gap = w * w / (math.hypot(b, w) + b)
        u = math.sqrt(gap * (2.0 * a + gap))
        flight = math.atan2(w, b) + math.atan2(u, a)
        t += flight
        times.append(t)
        speeds.append(u)
        if flight < 1e-18 * t:
            return np.array(times), np.array(speeds)


def test_chatter_under_a_constant_push_accumulates_at_the_closed_form_time():
    e, F, beta = 0.8, 2.0, 0.1
    times, speeds = _chatter_closed_form(e, F, beta)
    sol = io.simulate(O(F, 0.0, beta, 1.0, flange="rigid", restitution=e), 12.0, 0.0, 0.0)
    ev = sol.events
    impacts, chatter = ev[ev.kind == "impact"], ev[ev.kind == "chatter"]
    assert len(chatter) == 1 and 3 <= len(impacts) == chatter["count"][0] < len(times)
    assert abs(chatter.t[0] - times[-1]) <= 1e-9
    # The impacts followed one by one: times and speeds. The impact time's conditioning is
    # the rounding of X ~ 1 over the speed, so only the fast ones are held to 1e-12.
    fast = speeds[:len(impacts)] > 1e-2
    np.testing.assert_allclose(impacts.t[fast], times[:len(impacts)][fast], rtol=0, atol=1e-12)
    np.testing.assert_allclose(impacts.v, speeds[:len(impacts)], rtol=0, atol=1e-12)
    # Then the mass rests against the wall until the end, pressed by F - 1.
    assert list(ev.kind[-2:]) == ["chatter", "contact_start"] and (sol.x_final, sol.v_final) == (1.0, 0.0)
    # The wall's impulse: every impact's (1 + e) u (the chatter's tail summed), then the push.
    assert sol.flange_impulse(1) == pytest.approx((1 + e) * speeds.sum() + (F - 1.0) * (12.0 - times[-1]), rel=1e-12)
    assert abs(sol.energy_balance()["residual"]) <= 1e-13


def test_leaving_a_rigid_flange_under_harmonic_forcing():
    # At rest against the upper wall the net force is 2 cos(t/2) - 1; the wall lets go when it
    # falls through -beta_s: 2 cos(t/2) = 1 - 0.3.
    osc = O(2.0, 0.5, 0.1, 1.0, beta_static=0.3, flange="rigid", restitution=0.5)
    sol = io.simulate(osc, 12.0, 1.0, 0.0)
    ev = sol.events
    # Resting on the wall from the start is the initial mode, not an event (issue 20, item 10).
    assert list(ev.kind[:2]) == ["contact_end", "impact"]
    assert ev.side[0] == 1 and ev.x[0] == 1.0 and sol.impacts[0].start == 0.0
    assert abs(ev.t[0] - 2.0 * math.acos(0.35)) <= 1e-14
    assert abs(sol.energy_balance()["residual"]) <= 1e-13


# -- harmonic sums ------------------------------------------------------------------------------
def test_harmonic_sum_forced_oscillator_closed_form():
    terms = [(0.1, 0.5, 0.3), (0.07, 2.3, -1.0), (0.05, 3.1, 2.0)]
    osc = O.from_harmonics(terms, beta=0.0, K=1e4)
    x0, v0 = 0.2, -0.1
    # X'' + X = sum F_i cos(Omega_i t + phase_i) without contact: particular plus free solution.
    amp = [F / (1.0 - Om * Om) for F, Om, _ in terms]
    a = x0 - sum(c * math.cos(ph) for c, (_, _, ph) in zip(amp, terms, strict=True))
    b = v0 + sum(c * Om * math.sin(ph) for c, (_, Om, ph) in zip(amp, terms, strict=True))

    def exact(t):
        forced = sum(c * np.cos(Om * t + ph) for c, (_, Om, ph) in zip(amp, terms, strict=True))
        return a * np.cos(t) + b * np.sin(t) + forced

    ts = np.linspace(0.0, 30.0, 301)
    sol = io.simulate(osc, 30.0, x0, v0, sample_at=ts)
    assert sol.contact_entries() == 0 and sol.counts["reversal"] >= 8
    np.testing.assert_allclose(sol.samples.x, exact(ts), rtol=0, atol=1e-13)  # exact sample times
    between = ts[1:-1] + 0.01
    np.testing.assert_allclose(sol.sample(between)[0], exact(between), rtol=0, atol=1e-13)  # dense output
    # The forcing work is that of the whole sum: the energy identity closes.
    assert abs(sol.energy_balance()["residual"]) <= 1e-14


# -- every kind of member against scipy ---------------------------------------------------------
def _degenerate(osc, e) -> bool:
    """An event whose successor rounding may legitimately decide (graze, threshold, slow touch)."""
    if e.kind in ("contact_start", "contact_end", "impact"):
        return abs(e.v) < 1e-3
    f = abs(float(osc.net_force(e.t, e.x)))
    return abs(abs(e.x) - 1.0) < 1e-6 or abs(f - osc.beta_s) < 1e-6 or abs(f - osc.beta) < 1e-6


def _assert_agree(osc, h, s):
    bal = h.energy_balance()  # heyoka's integrals close the identity (scipy's to its rtol only)
    assert abs(bal["residual"]) <= 1e-11 * max(1.0, bal["scale"])
    eh, es = h.events, s.events
    for i in range(max(len(eh), len(es))):
        if i < len(eh) and i < len(es) and eh.kind[i] == es.kind[i] and eh.side[i] == es.side[i] \
                and abs(eh.t[i] - es.t[i]) <= 1e-9 * max(1.0, abs(eh.t[i])) and abs(eh.x[i] - es.x[i]) <= 1e-9:
            continue
        e = eh[i] if i < len(eh) else es[i]
        assert _degenerate(osc, e), f"event #{i} differs: {eh[i:i + 1]} vs {es[i:i + 1]}"
        return
    assert abs(h.x_final - s.x_final) <= 1e-8 and abs(h.v_final - s.v_final) <= 1e-8


_common = dict(F=st.floats(0.0, 2.0, allow_subnormal=False), Omega=st.floats(0.0, 2.5), beta=st.floats(0.0, 0.4),
               K=st.floats(0.0, 3.0).map(lambda e: 10.0**e), phase=st.floats(0.0, 2 * math.pi))
_MEMBERS = {
    "damped": st.builds(O, **_common, zeta=st.floats(1e-3, 0.3)),
    "static": st.builds(lambda beta, extra, **kw: O(beta=beta, beta_static=beta + extra, **kw),
                        extra=st.floats(0.0, 0.3), **_common),
    "power": st.builds(O, **_common, exponent=st.sampled_from([1.5, 2.0]) | st.floats(1.05, 3.0),
                       zeta=st.sampled_from([0.0, 0.05])),
    "rigid": st.builds(O, **{**_common, "K": st.just(1.0)}, flange=st.just("rigid"),
                       restitution=st.floats(0.3, 1.0), zeta=st.sampled_from([0.0, 0.05])),
    "harmonics": st.builds(O, **_common, harmonics=st.lists(
        st.tuples(st.floats(0.0, 0.5, allow_subnormal=False), st.floats(0.0, 4.0), st.floats(0.0, 2 * math.pi)),
        min_size=1, max_size=2)),
}


@pytest.mark.parametrize("kind", list(_MEMBERS))
def test_heyoka_agrees_with_scipy_on_random_members(kind):
    # Derandomized: the same examples on every run, a few seconds. Fuzzing by hand with 400
    # examples per kind found differences only at degenerate events (see _degenerate).
    positions = st.floats(-1.0, 1.0) if kind == "rigid" else st.floats(-1.3, 1.3)

    @settings(max_examples=10, deadline=None, derandomize=True)
    @given(osc=_MEMBERS[kind], x0=positions, v0=st.floats(-2.0, 2.0), t_end=st.floats(1.0, 12.0))
    def check(osc, x0, v0, t_end):
        h = io.simulate(osc, t_end, x0, v0)
        s = io.simulate(osc, t_end, x0, v0, backend="scipy")
        assert h.status == s.status == 0, (h.message, s.message)
        _assert_agree(osc, h, s)

    check()
