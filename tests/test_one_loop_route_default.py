"""Issue 27 item 4: the built-in members on the one hybrid heyoka loop (``run_on_hybrid_loop``), by default.

``run_on_hybrid_loop`` replays the hybrid run into the built-in ``Solution``; ``simulate(osc,
backend="heyoka")`` sends every member there (the heyoka backend's one loop). Checked against the
closed-form ``exact`` backend, with the degenerate
runs the property tests found (a release guard that touches zero, a stop at a net force of
rounding size).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import impactosc
from impactosc.backends.heyoka._replay import run_on_hybrid_loop


def hybrid(osc, t_end, x0, v0, *, record="full", max_wall_time=None):
    return run_on_hybrid_loop(osc, t_end, x0, v0, record=record, max_events=10**6, tol=2.0**-52,
                              max_wall_time=max_wall_time)


def test_a_spring_member_runs_on_the_hybrid_loop_by_default(monkeypatch):
    seen: list = []
    real = run_on_hybrid_loop

    def spy(osc, *a, **k):
        seen.append(osc)
        return real(osc, *a, **k)

    monkeypatch.setattr("impactosc.backends.heyoka.run_on_hybrid_loop", spy)
    osc = impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
    sol = impactosc.simulate(osc, 20.0)
    assert seen == [osc] and sol.status == 0
    ref = impactosc.simulate(osc, 20.0, backend="exact")
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-9)


@pytest.mark.parametrize("osc", [impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4, exponent=1.5),
                                 impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4,
                                                      harmonics=((0.1, 2.0**0.5, 0.0),)),
                                 impactosc.Oscillator(F=1e-45, Omega=1.0, beta=1e-45, K=1e4)],
                         ids=["power law", "incommensurate harmonic", "tiny forces"])
def test_what_stayed_on_the_piece_loop_runs_on_the_hybrid_loop(monkeypatch, osc):
    """Power-law flanges, incommensurate harmonics and forces below 1e-9 had the old piece loop; it is gone."""
    seen: list = []
    real = run_on_hybrid_loop

    def spy(osc, *a, **k):
        seen.append(osc)
        return real(osc, *a, **k)

    monkeypatch.setattr("impactosc.backends.heyoka.run_on_hybrid_loop", spy)
    sol = impactosc.simulate(osc, 20.0)
    assert seen == [osc] and sol.status == 0, sol.message
    ref = impactosc.simulate(osc, 20.0, backend="exact" if osc.exponent == 1.0 else "scipy")
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-9)


def test_a_release_guard_that_touches_zero_is_no_release():
    """Stuck at rest with F = beta: F cos t - beta reaches 0 at t = 2 pi and turns back (no release)."""
    osc = impactosc.Oscillator(F=0.5, Omega=1.0, beta=0.5, K=1.0)
    ref = impactosc.simulate(osc, 7.0, 0.0, 0.0, backend="exact")
    sol = hybrid(osc, 7.0, 0.0, 0.0)
    assert sol.status == 0, sol.message
    assert sol.counts == ref.counts


def test_a_friction_free_stop_at_a_rounding_force_has_a_mode():
    """Every force 1e-53: at the stop the rate of the slip's guard (-7e-53) is below the touch tolerance,
    and a tolerance absolute in the rate took it for a tangency and fired the other slip's stop at once."""
    osc = impactosc.Oscillator(F=6.711272095005328e-53, Omega=1.0, beta=0.0, K=1.0, phase=np.pi)
    ref = impactosc.simulate(osc, 1.0, 0.0, 6.711272095005328e-53, backend="exact")
    sol = hybrid(osc, 1.0, 0.0, 6.711272095005328e-53)
    assert sol.status == 0, sol.message
    assert sol.counts == ref.counts


def test_creep_with_a_release_from_a_long_stick_in_the_flange_agrees_with_exact():
    """A tape drive's member (Omega ~ 1.5e-4): it sticks in the flange and is released with v = v' = 0.

    Rounding took v a hair the wrong way right after the release; the loop took that for a
    crossing lost inside a step and applied it at the piece start, where the release fired
    again: the same instant for ever (a hang on this branch before the fix).
    """
    osc = impactosc.Oscillator(F=3.2830188679245285, Omega=0.0001548192732628624, beta=0.0077490468691723555,
                               K=1e4)
    ref = impactosc.simulate(osc, 1148.2922896552739, backend="exact", record="events")
    sol = hybrid(osc, 1148.2922896552739, 0.95, 0.0, record="events", max_wall_time=60.0)
    assert sol.status == 0, sol.message
    assert sol.counts == ref.counts and ref.counts["release"] == 1
    np.testing.assert_allclose(sol.events.t[:-1], ref.events.t[:-1], rtol=0, atol=1e-7)
    # the release: the force + beta falls through 0 at the slope F Omega |sin| ~ 5e-4, so a rounding
    # of the spring force K d (~1e-12 of it) moves it by ~1e-8 / 5e-4; exact and the piece loop
    # differ by 1.2e-6 there too
    assert sol.events.t[-1] == pytest.approx(ref.events.t[-1], abs=1e-5)
    assert sol.mean_flange_force() == pytest.approx(ref.mean_flange_force(), rel=1e-8)


@pytest.mark.parametrize("x0", [0.0, 1.01])
def test_a_builtin_member_stuck_for_ever_costs_a_few_periods(x0):
    """Stuck between the flanges (F < beta), or in the upper flange (|F cos - x - K d| <= 2.11 < beta): to t = 1e12."""
    osc = impactosc.Oscillator(F=0.1, Omega=0.5, beta=2.5, K=100.0)
    sol = hybrid(osc, 1e12, x0, 0.0)
    assert sol.status == 0 and sol.t_final == 1e12
    assert sum(sol.counts.values()) == 0 and sol.x_final == x0 and sol.v_final == 0.0
    assert sol.n_steps < 1000
    # dense output deep in the stuck phase (the re-integration skips whole periods too)
    x, v = sol.sample([2.5, 7.7e9, 5e11])
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(v, 0.0)
    if x0 > 1.0:  # the flange's impulse K d t, to the rounding of 1e11 periods' sums
        assert sol.flange_impulse(1) == pytest.approx(100.0 * (x0 - 1.0) * 1e12, rel=1e-12)


# v0 is 0 or at least 1e-6: a start within the loop's touch tolerance (1e-12) of v = 0 is a stop
# at t = 0 there, where the piece loop and exact stop at v0 / a (5e-201 for v0 = 1e-200), or
# record nothing (v0 <= 1e-300)
speeds = st.one_of(st.just(0.0), st.floats(1e-6, 1.0), st.floats(-1.0, -1e-6))


@given(F=st.floats(0.0, 0.5, allow_subnormal=False), Omega=st.floats(0.1, 3.0), phase=st.floats(0.0, 2.0 * np.pi),
       extra=st.floats(1.5, 3.0), K=st.floats(0.0, 4.0).map(lambda e: 10.0**e),
       x0=st.floats(-1.0, 1.0), v0=speeds, t_end=st.floats(3.0, 9.0).map(lambda e: 10.0**e))
def test_a_member_that_sticks_for_good_agrees_with_exact_to_any_end_time(F, Omega, phase, extra, K, x0, v0, t_end):
    """beta >= F + 1.5: once stuck between the flanges (|x| <= 1) the mass never moves again, and the
    hybrid loop jumps over the periods that the exact backend solves in closed form. A start deep in a
    flange (x0 = 1.25, K = 3.2) can stick and release there every period for ever: not this test's case."""
    osc = impactosc.Oscillator(F=F, Omega=Omega, beta=F + extra, K=K, phase=phase)
    ref = impactosc.simulate(osc, t_end, x0, v0, backend="exact", record="events")
    sol = hybrid(osc, t_end, x0, v0, record="events", max_wall_time=5.0)
    assert sol.status == ref.status == 0, sol.message
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-9)
    assert (sol.x_final, sol.v_final) == pytest.approx((ref.x_final, ref.v_final), abs=1e-9)
    # integrals over up to 1e9 time units: the forcing's phase there is known to ~eps Omega t; a mass stuck
    # within a flange's spring presses K d for t_end, d = x - 1 known to the ulps of x where the two
    # backends stop it (x0 = 1 - 1e-16, v0 = 1e-6, K = 1e4: d = 2e-13 +- 2e-16, the impulse off by 1e-3 rel)
    position = 8.0 * 2.0**-52 * max(1.0, abs(sol.x_final)) * K * t_end
    assert sol.flange_impulse() == pytest.approx(ref.flange_impulse(), rel=1e-8, abs=1e-9 + position)
    assert sol.forcing_work == pytest.approx(ref.forcing_work, rel=1e-8, abs=1e-9)


def test_a_slip_that_starts_at_a_triple_root_of_its_stop_is_not_a_stick():
    """At rest on x = -1 with F cos(t + pi) - x = 1 - cos t and no friction: the net force is zero and
    turns positive (v ~ t^3 / 6). The hybrid loop's stop guard fired at t = 0 (its second derivative
    sin(pi) ~ 1e-16 by rounding), stuck, released, stopped, for ever: status -1 where exact has no event."""
    osc = impactosc.Oscillator(F=1.0, Omega=1.0, beta=0.0, K=1.0, phase=np.pi)
    ref = impactosc.simulate(osc, 1.0, -1.0, 0.0, backend="exact")
    sol = hybrid(osc, 1.0, -1.0, 0.0)
    assert sol.status == 0, sol.message
    assert sol.counts == ref.counts
    assert (sol.x_final, sol.v_final) == pytest.approx((ref.x_final, ref.v_final), abs=1e-12)


@pytest.mark.slow  # a subprocess
def test_heyoka_warnings_of_the_hybrid_loop_do_not_reach_stdout():
    """The hybrid loop's integrator may be the first heyoka builds: its logger must write to stderr.

    Inside the loop heyoka's root-finding warnings are muted (the lost-crossing check handles what
    they report), so the warning here comes from the same integrator propagated afterwards, outside
    the loop, from a non-finite state: the level is back at warning once the loop has ended."""
    import os
    import subprocess
    import sys

    code = ("import math\n"
            "import impactosc as io\n"
            "from impactosc.backends.heyoka import compiled_integrator\n"
            "from impactosc.backends.heyoka._replay import run_on_hybrid_loop\n"
            "print('table start', flush=True)\n"
            "osc = io.Oscillator(F=1.0, Omega=1.0, beta=0.0, K=1.0, phase=3.141592653589793)\n"
            "run_on_hybrid_loop(osc, 1.0, -1.0, 0.0, record='full', max_events=100, tol=2.0**-52)\n"
            "ta = compiled_integrator(osc).ta\n"
            "ta.time = 0.0\n"
            "ta.state[:] = [0.5, math.inf] + [0.0] * (ta.dim - 2)\n"
            "ta.propagate_until(1.0)\n"
            "print('table end', flush=True)\n")
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": repo})
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["table start", "table end"]
    assert "[warning]" in out.stderr


def test_a_release_on_a_slow_forcing_is_not_undone_by_its_rate_rounding():
    """A tape drive's creep (forcing period 3.2e4): after the release the slip's rate is the rounding of
    F cos - x + beta (~1e-16) against a curvature of 9e-6; taking that rate's sign stuck and released the
    mass at one instant 64 times (status -1)."""
    osc = impactosc.TapeDrive(clearance=200e-6).oscillator()
    ref = impactosc.simulate(osc, 400.0, backend="exact", record="events")
    sol = impactosc.simulate(osc, 400.0, record="events")
    assert sol.status == 0, sol.message
    assert sol.counts == ref.counts and ref.counts["release"] == 1
    np.testing.assert_allclose(sol.events.t[:-1], ref.events.t[:-1], rtol=0, atol=1e-8)
    assert sol.events.t[-1] == pytest.approx(ref.events.t[-1], abs=1e-5)  # the slow release, as in the creep test


QUASI_STATIC_TIE = impactosc.Oscillator(F=1.0, Omega=1e-12, beta=0.0, K=1.0, phase=np.pi)  # at rest on x = -1


def test_a_frictionless_tie_at_rest_on_a_flange_surface_on_the_hybrid_loop():
    """At rest on x = -1 with the net force 1 - cos(1e-12 t): zero at t = 0 with a zero first derivative
    (rounded to -1.2e-28 by sin(pi)) and a growing second. The loop decided the stop by the rounded sign and
    stopped, released and stopped at one instant 64 times (status -1); the stops' transition rule is the
    engine's stick test, which decides the tie by the forcing's trend: the mass slips up, with no event."""
    ref = impactosc.simulate(QUASI_STATIC_TIE, 1.0, -1.0, 0.0, backend="exact")
    sol = hybrid(QUASI_STATIC_TIE, 1.0, -1.0, 0.0)
    assert sol.status == 0, sol.message
    assert sol.counts == ref.counts
    # the motion is 1e-25 (x + 1 ~ Omega^2 t^4 / 24): both ends are the start to rounding
    assert (sol.x_final, sol.v_final) == pytest.approx((ref.x_final, ref.v_final), abs=1e-12)

