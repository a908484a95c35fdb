"""Continuation of periodic orbits (issue 19): closed forms first, then the map's own derivatives, then bad input."""

from __future__ import annotations

import math

import impact_closed_form as cf
import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc.dynamics import Branch, SpecialPoint, continuation
from impactosc.dynamics.continuation._problem import MapProblem

OMEGA, BETA = 1.5, 0.1
FC = dy.den_hartog_onset(OMEGA, BETA)
#: The issue's start: the contact-free Den Hartog orbit at 0.8 Fc.
DH_GUESS = (-0.7891869048001374, 0.16283153617831878)

# a rigid one-sided stop: X'' + 2 zeta X' + X = F cos(W t) + c, impacts V -> -e V at X = 1
W, ZETA, E, C = 0.8, 0.05, 0.8, 0.5


def stop(F):
    return io.Oscillator.from_harmonics([(F, W, 0.0), (C, 0.0, 0.0)], beta=0.0, K=1.0, zeta=ZETA, flange="rigid",
                                        restitution=E)


@pytest.fixture(scope="module")
def den_hartog_branch():
    orb = dy.periodic_orbit(io.Oscillator(0.8 * FC, OMEGA, BETA, 24.0), guess=DH_GUESS, backend="exact")
    return continuation(orb, "F", (0.5 * FC, 1.1 * FC), tol=1e-12)


@pytest.fixture(scope="module")
def stop_branch():
    # the section half a period after t = 0, away from the impact (near t = 0 at these F)
    orb = dy.periodic_orbit(stop(0.5), phase=math.pi, backend="exact")
    return continuation(orb, "F", (0.05, 0.8), tol=1e-12)


# -- closed forms ------------------------------------------------------------------------
def test_den_hartog_amplitude_and_grazing(den_hartog_branch):
    br = den_hartog_branch
    assert isinstance(br, Branch) and br.status == 0, br.message
    clear = [p for p in br.points if p.upper_margin > 0 and p.signature == br.points[0].signature]
    assert len(clear) > 10
    for p in clear:
        assert abs((1.0 - p.upper_margin) - dy.den_hartog_amplitude(p.parameter, OMEGA, BETA)) < 1e-9
    graze = [s for s in br.find("grazing") if s.context[2]["test"] == "upper_margin"]
    assert graze and abs(graze[0].parameter / FC - 1.0) < 1e-9
    # the story: past the grazing the branch folds back as the unstable contacting orbit
    fold = br.find("fold")
    assert fold and fold[0].parameter > FC
    assert abs(fold[0].multipliers[0] - 1.0) < 1e-8


def test_stick_onset_of_the_den_hartog_orbit():
    # Below the onset A Omega^2 = beta (A the Den Hartog amplitude) a reversal turns into a stick.
    orb = dy.periodic_orbit(io.Oscillator(0.8 * FC, OMEGA, BETA, 24.0), guess=DH_GUESS, backend="exact")
    br = continuation(orb, "F", (0.12, 0.8 * FC), direction="backward", tol=1e-12)
    onset = br.find("stick_onset")
    assert onset, br.summary()
    A = dy.den_hartog_amplitude(onset[0].parameter, OMEGA, BETA)
    assert abs(A * OMEGA**2 / BETA - 1.0) < 1e-9
    assert onset[0].before != onset[0].after


def test_rigid_stop_period_doubling_and_grazing_against_closed_forms(stop_branch):
    br = stop_branch
    pd = br.find("period_doubling")
    assert len(pd) == 1
    F_pd = cf.period_doubling(W, ZETA, E, C, 0.25, 0.3, which=1)
    assert abs(pd[0].parameter - F_pd) < 1e-9
    assert abs(pd[0].multipliers[0] + 1.0) < 1e-8 or abs(pd[0].multipliers[1] + 1.0) < 1e-8
    # the impacting family reaches zero impact speed and the branch crosses the grazing (test_grazing_crossing.py)
    assert br.status == 0, br.message
    end = br.find("grazing")[0]
    assert abs(end.parameter - cf.grazing(W, ZETA, E, C, 0.15, 0.25)) < 1e-8


def test_rigid_stop_multipliers_and_liouville(stop_branch):
    # away from the grazing end, where the multiplier grows like 1/V and V itself is known to ~tol/V
    points = [p for p in stop_branch.points if -p.upper_margin > 1e-2]
    assert len(points) > 10
    for p in points[::3]:
        ref = cf.orbits(p.parameter, W, ZETA, E, C)[1]["multipliers"]
        # the same pair: the same trace and determinant
        assert abs(np.sum(p.multipliers) - np.sum(ref)) < 1e-9 and abs(np.prod(p.multipliers) - np.prod(ref)) < 1e-9
        # Liouville: det M = e^2 exp(-2 zeta T) for one impact a period
        det = float(np.real(np.prod(p.multipliers)))
        assert abs(det - E * E * math.exp(-2.0 * ZETA * 2.0 * math.pi / W)) < 1e-10


# -- the map's own derivatives -----------------------------------------------------------
def _fd_jacobian(problem, z, p, h=1e-6):
    J = np.zeros((2, 3))
    for i in range(3):
        d = np.zeros(3)
        d[i] = h * (max(1.0, abs(p)) if i == 2 else 1.0)
        up = problem.evaluate(z + d[:2], (p + d[2],)).image
        down = problem.evaluate(z - d[:2], (p - d[2],)).image
        J[:, i] = (up - down) / (2.0 * d[i])
    return J


def test_multipliers_and_parameter_derivative_match_finite_differences(den_hartog_branch):
    br = den_hartog_branch
    problem = MapProblem(br.base, ("F",), 1, br.base.phase, "exact", {})
    for p in br.points[::8]:
        z = np.array([p.x, p.v])
        ev = problem.evaluate(z, (p.parameter,))
        fd = _fd_jacobian(problem, z, p.parameter)
        assert np.allclose(ev.monodromy, fd[:, :2], atol=1e-6 * max(1.0, np.abs(fd).max()))
        assert np.allclose(ev.dp[:, 0], fd[:, 2], atol=1e-6 * max(1.0, np.abs(fd).max()))


@pytest.mark.parametrize("name", ["Omega", "beta", "phase", "zeta", "beta_static", "K"])
def test_parameter_derivative_of_every_field(name):
    osc = io.Oscillator(1.0, 1.5, 0.1, 24.0, zeta=0.02, beta_static=0.15)
    problem = MapProblem(osc, (name,), 1, 0.0, "exact", {})
    z = np.array([-0.5, 0.3])
    p = problem.values()[0]
    ev = problem.evaluate(z, (p,))
    h = 1e-6 * max(1.0, abs(p))
    fd = (problem.evaluate(z, (p + h,)).image - problem.evaluate(z, (p - h,)).image) / (2 * h)
    assert np.allclose(ev.dp[:, 0], fd, atol=1e-7 * max(1.0, np.abs(fd).max()))


def test_restitution_derivative_through_the_impact_reset():
    problem = MapProblem(stop(0.5), ("restitution",), 1, 0.0, "exact", {})
    z = np.array([0.5, 0.3])
    ev = problem.evaluate(z, (E,))
    fd = (problem.evaluate(z, (E + 1e-6,)).image - problem.evaluate(z, (E - 1e-6,)).image) / 2e-6
    assert ev.recorder.counts["impact"] >= 1
    assert np.allclose(ev.dp[:, 0], fd, atol=1e-7)


# -- across nonsmooth points -------------------------------------------------------------
def test_points_on_both_sides_of_a_grazing_are_genuine_orbits(den_hartog_branch):
    br = den_hartog_branch
    graze = br.find("grazing")[0]
    before, after = br.points[graze.index], br.points[graze.index + 1]
    assert before.signature != after.signature
    assert graze.before == before.signature
    for p in (before, after):
        m = dy.monodromy(io.Oscillator(p.parameter, OMEGA, BETA, 24.0), p.x, p.v, backend="exact")
        assert math.hypot(m.x - p.x, m.v - p.v) < 1e-9


def test_branch_switching_at_the_period_doubling(stop_branch):
    pd = stop_branch.find("period_doubling")[0]
    br2 = continuation(pd, "F", (0.05, 0.8))
    assert br2.n == 2 and len(br2) > 5
    p = br2.points[len(br2) // 2]
    once = dy.monodromy(stop(p.parameter), p.x, p.v, t0=math.pi / W, backend="exact")
    twice = dy.monodromy(stop(p.parameter), p.x, p.v, n=2, t0=math.pi / W, backend="exact")
    assert math.hypot(once.x - p.x, once.v - p.v) > 1e-3  # not the period-1 orbit
    assert math.hypot(twice.x - p.x, twice.v - p.v) < 1e-9  # a period-2 orbit


def test_grazing_boundary_in_two_parameters_is_den_hartogs_onset(den_hartog_branch):
    graze = den_hartog_branch.find("grazing")[0]
    curve = continuation(graze, ("F", "Omega"), {"Omega": (1.3, 2.0)}, tol=1e-12)
    assert curve.status == 0, curve.message
    assert curve.values("Omega").min() == pytest.approx(1.3) and curve.values("Omega").max() == pytest.approx(2.0)
    for p in curve.points:
        assert abs(p.parameters["F"] / dy.den_hartog_onset(p.parameters["Omega"], BETA) - 1.0) < 1e-9


# -- results -----------------------------------------------------------------------------
def test_branch_views(den_hartog_branch, tmp_path):
    br = den_hartog_branch
    ds = br.to_xarray()
    assert ds.sizes["point"] == len(br)
    for name in ("F", "x", "v", "multiplier_abs", "stability", "signature", "upper_margin", "stick_margin"):
        assert name in ds
    assert "GR1" in ds.attrs["special"] and "LP1" in ds.attrs["special"]
    assert "grazing" in br.summary()
    assert isinstance(br.special[0], SpecialPoint)
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    ax = br.plot(y="max_x")
    assert len(ax.lines) >= 2 and any(t.get_text().startswith("GR") for t in ax.texts)


# -- bad input ---------------------------------------------------------------------------
def test_bad_input_is_refused_or_reported():
    osc = io.Oscillator(0.8 * FC, OMEGA, BETA, 24.0)
    orb = dy.periodic_orbit(osc, guess=DH_GUESS, backend="exact")
    with pytest.raises(ValueError, match="parameter"):
        continuation(orb, "nope", (0.1, 1.0))
    with pytest.raises(ValueError, match="lo < hi"):
        continuation(orb, "F", (1.0, 0.1))
    with pytest.raises(ValueError, match="finite"):
        continuation(orb, "F", (0.1, math.nan))
    with pytest.raises(ValueError, match="outside the limits"):
        continuation(orb, "F", (2.0, 3.0))
    with pytest.raises(ValueError, match="direction"):
        continuation(orb, "F", (0.1, 1.0), direction="up")
    with pytest.raises(TypeError, match="base"):
        continuation((0.1, 0.2), "F", (0.1, 1.0))
    far = continuation((50.0, 80.0), "F", (0.5, 1.1), base=osc, max_iter=3)
    assert far.status == -1 and len(far) == 0 and "no periodic orbit" in far.message


def test_a_failed_end_keeps_the_points_computed():
    orb = dy.periodic_orbit(io.Oscillator(0.8 * FC, OMEGA, BETA, 24.0), guess=DH_GUESS, backend="exact")
    br = continuation(orb, "F", (0.5 * FC, 1.1 * FC), max_points=5, direction="forward")
    assert br.status == 1 and len(br) == 6 and "max_points" in br.message


@pytest.mark.parametrize("gap_lower", [1.5, None])
def test_grazing_of_a_nearer_or_only_flange(gap_lower):
    # Flanges at their own distances (issue 19 item 6): the symmetric Den Hartog orbit reaches the
    # upper flange at gap_upper = 0.8 first, where its closed-form amplitude equals 0.8:
    # F = |1 - Omega^2| sqrt(0.8^2 + (beta tan(pi / (2 Omega)) / Omega)^2).
    gap = 0.8
    lag = BETA * math.tan(math.pi / (2.0 * OMEGA)) / OMEGA
    F_graze = abs(1.0 - OMEGA**2) * math.hypot(gap, lag)
    # the contact-free orbit at 0.8 Fc (amplitude 0.789, clear of the flange at 0.8; a transient
    # from rest lands on a coexisting contacting orbit here); the exact backend has no gaps yet: heyoka
    osc = io.Oscillator(0.8 * FC, OMEGA, BETA, 24.0, gap_upper=gap, gap_lower=gap_lower)
    orb = dy.periodic_orbit(osc, guess=DH_GUESS, backend="heyoka")
    assert orb.status == 0 and orb.stable
    br = continuation(orb, "F", (0.5 * FC, 1.05 * F_graze), direction="forward", tol=1e-12)
    graze = [s for s in br.find("grazing") if s.context[2]["test"] == "upper_margin"]
    assert graze, br.summary()
    assert abs(graze[0].parameter / F_graze - 1.0) < 1e-9
    # up to the grazing the lower flange (or none) stays clear, its margin the closed form's 1.5 - A or inf
    for p in br.points[: graze[0].index + 1]:
        A = dy.den_hartog_amplitude(p.parameter, OMEGA, BETA)
        assert abs(p.lower_margin - ((gap_lower or math.inf) - A)) < 1e-9 or p.lower_margin == math.inf


def test_multipliers_that_jump_across_one_past_a_grazing_are_no_fold():
    # Den Hartog's case at Omega = 0.8, K = 1e4: just past the grazing the multipliers jump across +1
    # (the nearest ends 1e-4 from it at the located point) while F goes on increasing. A fold test
    # alone called it a fold; it is a nonsmooth point of the map, labelled a border.
    orb = dy.periodic_orbit(io.Oscillator(0.3, 0.8, 0.05, 1e4), guess=(0.8, 0.0), backend="exact")
    br = continuation(orb, "F", (0.3, 0.5), direction="forward")
    assert br.status == 0 and not br.find("fold") and not br.find("branch_point")
    # the jump is at the grazing, which the branch now crosses in one step (test_grazing_crossing.py)
    assert br.find("grazing")
    assert np.all(np.diff(br.values()) > 0.0)  # the branch never turns back
