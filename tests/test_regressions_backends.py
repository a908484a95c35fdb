"""Regressions of issue 14: wrong answers from the two reference backends (exact, heyoka).

1. A flange crossing located exactly at a turning point on ``|X| = 1`` started a piece whose
   velocity already pointed against its motion (or was exactly zero with the force pointing
   back): the slip end was never seen and a whole period ran with the wrong vector field
   (negative impulses, a trajectory 1.9 away from the truth, or status -1).
2. heyoka missed an acceleration-zero root after a release when ``F == beta``: the force
   guard offset was below the rounding of ``F cos(Omega t + phase)`` at large ``Omega t``.
3. The exact backend rounded the position to ``eps * beta`` (the particular solution
   ``-beta s / w^2`` cancelled against the homogeneous part).

Each test pins the reproducer of the issue and a small seeded sample of its class
(``benchmarks/fuzz_differential.py`` scans the classes at length).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import Oscillator, simulate
from impactosc.engine import (
    ENTER_UPPER,
    LEAVE,
    NO_GUARD,
    SLIP_END,
    Mode,
    force_guard_offset,
    guard_offsets,
    missed_guard,
    pending_guard,
)

EPS = 2.0**-52


def _piece_violations(sol) -> list[str]:
    """Dense-output points (a quarter, half and three quarters into every piece) whose
    position contradicts the piece's region or whose velocity opposes its motion."""
    seg = sol._segments
    ends = np.append(seg["t"][1:], sol.t_final)
    length = ends - seg["t"]
    keep = length > 1e-9
    frac = np.array([0.25, 0.5, 0.75])
    times = (seg["t"][keep][:, None] + length[keep][:, None] * frac).ravel()
    x, v = sol.sample(times)
    r = np.repeat(seg["region"][keep], 3)
    s = np.repeat(seg["motion"][keep], 3)
    tol = 1e-9
    bad_region = np.where(r == 0, np.abs(x) > 1.0 + tol, r * x < 1.0 - tol)
    bad_motion = s * v < -tol
    return [f"t={t:.6g} region={ri} motion={si} X={xi:.6g} V={vi:.3g}"
            for t, ri, si, xi, vi, b in zip(times, r, s, x, v, bad_region | bad_motion, strict=True) if b]


def _assert_sound(sol):
    assert sol.status == 0, sol.message
    assert not _piece_violations(sol)
    if len(sol.impacts):
        assert np.all(sol.impacts.impulse >= 0.0)
    assert sol.mean_flange_force() >= 0.0


# -- item 1: exact touches ---------------------------------------------------------------
@pytest.mark.parametrize("K", [24.0, 1.0])
def test_exact_touch_of_both_flanges_follows_the_sine(K):
    # X = -sin t touches X = -1 and X = +1 at every turning point, with zero penetration.
    sol = simulate(Oscillator(F=0.0, Omega=0.0, beta=0.0, K=K), 120.0, x0=0.0, v0=-1.0, backend="exact")
    _assert_sound(sol)
    t = np.linspace(0.0, 120.0, 2001)
    x, _ = sol.sample(t)
    assert np.max(np.abs(x + np.sin(t))) < 1e-12
    assert sol.mean_flange_force() < 1e-20
    assert sol.counts["reversal"] == 38


@pytest.mark.parametrize(("osc", "t_end", "x0", "v0"), [
    (Oscillator(0.5, 0.0, 0.0, 1.0), 13.0, 1.5, -1.0),
    (Oscillator(3.0, 0.0, 0.0, 5.9557), 116.2, 1.0, 0.0),
    (Oscillator(0.0, 2.5, 0.0, 84.0), 67.0, 0.6, 0.8),  # the touch lands on V == 0 exactly
    (Oscillator(0.0, 0.0, 0.4375, 35.0), 40.0, -0.4375, 1.4375),  # Coulomb: turning point at X = 1
])
def test_touch_reproducers_agree_with_heyoka(osc, t_end, x0, v0):
    e = simulate(osc, t_end, x0=x0, v0=v0, backend="exact")
    h = simulate(osc, t_end, x0=x0, v0=v0, backend="heyoka")
    _assert_sound(e)
    _assert_sound(h)
    t = np.linspace(0.0, t_end, 1001)
    assert np.max(np.abs(e.sample(t)[0] - h.sample(t)[0])) < 1e-9
    assert e.mean_flange_force() == pytest.approx(h.mean_flange_force(), rel=1e-9, abs=1e-15)
    assert (e.x_final, e.v_final) == pytest.approx((h.x_final, h.v_final), abs=1e-9)


def test_touch_class_seeded_sample():
    # Amplitude exactly 1 (x0^2 + v0^2 = 1 in dyadic numbers or with one of them 0), and
    # a constant force with x0 on the boundary: every turning point is on |X| = 1.
    rng = np.random.default_rng(14)
    for _ in range(12):
        K = float(rng.integers(1, 101))
        x0, v0 = [(0.0, 1.0), (1.0, 0.0), (0.6, 0.8), (0.8, -0.6)][rng.integers(4)]
        sgn = float(rng.choice([-1.0, 1.0]))
        _assert_sound(simulate(Oscillator(0.0, 0.0, 0.0, K), 60.0, x0=sgn * x0, v0=v0, backend="exact"))
        F = float(rng.integers(1, 48)) / 16.0
        _assert_sound(simulate(Oscillator(F, 0.0, 0.0, K), 60.0, x0=sgn, v0=0.0, backend="exact"))


def test_pending_slip_end_when_the_velocity_already_points_back():
    osc = Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0)
    # Contact started a rounding error past the turning point: V < 0 while moving up.
    assert pending_guard(osc, Mode(1, 1, True), ENTER_UPPER, 36.1, 1.0, -3.4e-15) == SLIP_END
    # Contact started exactly on the turning point, the spring force pulling back.
    assert pending_guard(osc, Mode(1, 1, True), ENTER_UPPER, 0.9, 1.0, 0.0) == SLIP_END
    # ... but a force pushing on into the flange keeps the motion.
    pushing = Oscillator(F=3.0, Omega=0.0, beta=0.0, K=24.0)
    assert pending_guard(pushing, Mode(1, 1, True), ENTER_UPPER, 0.9, 1.0, 0.0) == NO_GUARD
    # A reversal snaps V to 0: no second slip end; moving back out of the flange it leaves.
    assert pending_guard(osc, Mode(1, -1, True), SLIP_END, 0.9, 1.0, 0.0) == LEAVE
    assert pending_guard(osc, Mode(0, -1, True), LEAVE, 0.9, 1.0, 0.0) == NO_GUARD


def test_integrity_check_has_no_absolute_slack():
    osc = Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0)
    up = Mode(1, 1, True)
    # A piece that starts moving against its motion is caught, however small V is.
    assert missed_guard(osc, up, SLIP_END, 1.0, 1.0, -1e-15, 2.0, 1.0, 0.0) == "slip_end"
    # A flange piece that ends 1e-12 outside its flange (the old slack was 1e-9).
    assert missed_guard(osc, up, NO_GUARD, 1.0, 1.0, 0.0, 2.0, 1.0 - 1e-12, 0.1) == "leave"
    assert missed_guard(osc, up, NO_GUARD, 1.0, 1.0, 0.0, 2.0, 1.0 - 1e-15, 0.1) is None  # rounding
    free = Mode(0, 1, True)
    assert missed_guard(osc, free, NO_GUARD, 1.0, 0.5, 0.1, 2.0, 1.0 + 1e-12, 0.1) == "enter_upper"
    # A velocity of the wrong sign beyond the rounding of the piece's velocities.
    assert missed_guard(osc, free, NO_GUARD, 1.0, 0.0, 0.5, 2.0, 0.5, -1e-10) == "slip_end"
    assert missed_guard(osc, free, NO_GUARD, 1.0, 0.0, 0.5, 2.0, 0.5, -1e-17) is None


# -- item 2: F == beta, heyoka ---------------------------------------------------------------
def test_f_equal_beta_reproducer():
    osc = Oscillator(F=1.0, Omega=2.0, beta=1.0, K=1e6)
    h = simulate(osc, 113.47418258689588, x0=-1.0, v0=-1.0)
    e = simulate(osc, 113.47418258689588, x0=-1.0, v0=-1.0, backend="exact")
    assert h.status == e.status == 0, h.message
    assert h.counts == e.counts
    assert h.x_final == pytest.approx(e.x_final, abs=1e-12)


def test_f_equal_beta_seeded_sample_to_t_1000():
    # Before the fix 49 of 60 such runs (F = beta = 1, Omega = 2, K = 1e6) ended with status -1.
    rng = np.random.default_rng(2)
    osc = Oscillator(F=1.0, Omega=2.0, beta=1.0, K=1e6)
    for _ in range(8):
        sol = simulate(osc, 1000.0, x0=float(rng.uniform(-1.5, 1.5)), v0=float(rng.uniform(-2, 2)), record="stats")
        assert sol.status == 0, sol.message


def test_force_guard_offset_covers_the_rounding_of_the_phase():
    osc = Oscillator(F=1.0, Omega=2.0, beta=1.0, K=1e6)
    for t in (0.0, 100.0, 1e4):
        # cos(Omega t) is computed from Omega t rounded to an ulp of itself.
        phase_rounding = EPS * osc.F * osc.Omega * t
        assert force_guard_offset(osc, t, 0.02) > 2.0 * phase_rounding
        assert guard_offsets(osc, t, 0.02)[4:] == (force_guard_offset(osc, t, 0.02),) * 3
    assert force_guard_offset(osc, 1e4, 0.02) > 1e3 * force_guard_offset(osc, 0.0, 0.02)
    # The phase's own magnitude counts, even where it cancels against Omega t.
    shifted = Oscillator(F=1.0, Omega=2.0, beta=1.0, K=1e6, phase=-200.0)
    assert force_guard_offset(shifted, 100.0, 0.02) >= force_guard_offset(osc, 100.0, 0.02)


# -- item 3: huge beta, exact -----------------------------------------------------------------
def test_huge_beta_slide_keeps_its_displacement():
    osc = Oscillator(F=0.5, Omega=1.0, beta=1e8, K=1e4)
    e = simulate(osc, 10.0, x0=0.2, v0=-0.5, backend="exact")
    h = simulate(osc, 10.0, x0=0.2, v0=-0.5)
    assert e.status == 0 and e.counts["stick"] == 1
    # Decelerated by beta + X - F cos(0) over the slide: X drops by v0^2 / (2 (beta - 0.3)).
    drop = 0.25 / (2.0 * (1e8 - 0.3))
    assert e.x_final - 0.2 == pytest.approx(-drop, rel=1e-6)
    assert e.friction_work == pytest.approx(0.125, rel=1e-6)
    assert e.forcing_work == pytest.approx(h.forcing_work, rel=1e-6)
    assert e.x_final == pytest.approx(h.x_final, abs=1e-15)


@pytest.mark.parametrize(("x0", "v0"), [(1.0, 0.5), (-1.0, -0.7), (1.0000001, -0.3)])
def test_huge_beta_in_a_flange_keeps_its_tiny_impulse(x0, v0):
    osc = Oscillator(F=0.5, Omega=1.0, beta=1e8, K=1e4)
    e = simulate(osc, 10.0, x0=x0, v0=v0, backend="exact")
    h = simulate(osc, 10.0, x0=x0, v0=v0)
    assert e.status == h.status == 0
    assert e.flange_impulse() > 0.0
    assert e.flange_impulse() == pytest.approx(h.flange_impulse(), rel=1e-9)
    assert e.x_final == pytest.approx(h.x_final, abs=1e-15)
    assert e.friction_work == pytest.approx(h.friction_work, rel=1e-9)


def test_huge_beta_seeded_sample_agrees_with_heyoka():
    rng = np.random.default_rng(3)
    for _ in range(20):
        osc = Oscillator(float(rng.uniform(0, 2)), float(rng.uniform(0.1, 3)), float(10 ** rng.uniform(2, 9)),
                         float(10 ** rng.uniform(0, 6)))
        x0, v0 = float(rng.uniform(-1.5, 1.5)), float(rng.uniform(-2, 2))
        e = simulate(osc, 10.0, x0=x0, v0=v0, backend="exact")
        h = simulate(osc, 10.0, x0=x0, v0=v0)
        assert e.status == h.status == 0
        assert e.x_final == pytest.approx(h.x_final, abs=1e-14 * max(1.0, abs(x0)))
        assert e.friction_work == pytest.approx(h.friction_work, rel=1e-6)
        scale = 0.5 * v0 * v0 + osc.beta * max(1.0, abs(x0)) * EPS * 64
        assert math.isclose(e.forcing_work, h.forcing_work, rel_tol=1e-6, abs_tol=scale * 1e-12)
