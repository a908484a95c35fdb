"""Continuation through a grazing (issue 26, item 1): closed forms of the rigid one-sided stop first.

The model is COCO's impact demo, ``X'' + 0.1 X' + X = F cos(W t)`` with Newton's impact
``V -> -0.8 V`` at ``X = 1`` and no lower flange. Its contact-free orbit has the amplitude
``F / |1 - W^2 + 0.1 i W|`` and grazes at ``F = |1 - W^2 + 0.1 i W|``; its single-impact
orbits, their period doubling and fold have closed forms (``impact_closed_form``).
"""

from __future__ import annotations

import math

import impact_closed_form as cf
import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc.dynamics.continuation._problem import MapProblem

ZETA, E = 0.05, 0.8
RIGID = dict(zeta=ZETA, flange="rigid", restitution=E, gap_lower=None)


def stop(F, W):
    return io.Oscillator(F, W, 0.0, None, **RIGID)


def _branch(F0, W, limits=(0.02, 0.5), **kw):
    orb = dy.periodic_orbit(stop(F0, W), backend="exact", transient_periods=300)
    assert orb.status == 0 and abs(orb.t0) < 1e-12  # the section at t = 0 (forcing phase 0)
    kw.setdefault("tol", 1e-12)
    return dy.continuation(orb, "F", limits, **kw)


def _closed_form_distance(p, W) -> float:
    """Distance of a branch point from the closed-form orbit of its kind (contact-free or single-impact)."""
    z = np.array([p.x, p.v])
    if not p.signature:
        return float(np.linalg.norm(z - cf.free_state(p.parameter, W, ZETA, 0.0)))
    orbits = cf.orbits(p.parameter, W, ZETA, E, 0.0)
    return min(float(np.linalg.norm(z - cf.section_state(p.parameter, W, ZETA, E, 0.0, o))) for o in orbits)


@pytest.fixture(scope="module", params=[0.8, 1.0, 1.2])
def crossed(request):
    W = request.param
    # steps no longer than 0.03 of the scaled arclength: the parameter is scaled by its range (0.48), and the
    # multiplier check wants a handful of impacting points to sample
    return W, _branch(0.05, W, max_step=0.03)


def test_a_branch_from_below_grazing_crosses_onto_the_impacting_family(crossed):
    W, br = crossed
    assert br.status == 0, br.message
    graze = br.find("grazing")
    assert len(graze) == 1, br.summary()
    # located as a regular point of the contact-free family, not extrapolated
    assert abs(graze[0].parameter - cf.grazing_amplitude(W, ZETA)) < 1e-10
    assert graze[0].accuracy < 1e-10
    assert graze[0].context[2]["side"] == 1 and "upper flange" in graze[0].message
    assert any(p.signature for p in br.points) and any(not p.signature for p in br.points)
    for p in br.points:
        assert _closed_form_distance(p, W) < 1e-9, (p.parameter, p.signature)


def test_the_crossed_branch_finds_the_closed_form_period_doubling():
    W = 0.8
    br = _branch(0.05, W, limits=(0.02, 0.6))
    pd = br.find("period_doubling")
    assert pd, br.summary()
    ref = cf.period_doubling_near(W, ZETA, E, 0.0, pd[0].parameter)
    assert ref is not None, f"no closed-form period doubling near F = {pd[0].parameter}"
    assert abs(pd[0].parameter - ref) < 1e-9


@pytest.mark.parametrize("W, case", [(0.8, "persistent"), (1.0, "nonsmooth_fold")])
def test_the_crossing_says_whether_the_family_goes_on_or_folds(W, case):
    # W = 0.8: the impacting family lies beyond the grazing (a persistent crossing); at W = 1 it lies on the
    # contact-free side and turns at a smooth fold 3e-5 below (the discontinuous grazing case)
    br = _branch(0.05, W)
    graze = br.find("grazing")[0]
    assert graze.context[2]["case"] == case
    if case == "nonsmooth_fold":
        assert "nonsmooth fold" in graze.message
        fold = br.find("fold")
        assert fold and fold[0].parameter < graze.parameter


def test_the_issue_example_crosses_back_from_the_impacting_side():
    # issue 26: from the impacting orbit at F = 0.3 the branch ended at the grazing (status 2), extrapolated
    br = _branch(0.3, 1.0)
    assert br.status == 0, br.message
    graze = br.find("grazing")
    assert len(graze) == 1 and abs(graze[0].parameter - 0.1) < 1e-10
    assert "extrapolated" not in graze[0].message
    assert br.values().min() == pytest.approx(0.02) and br.values().max() == pytest.approx(0.5)
    for p in br.points:
        assert _closed_form_distance(p, 1.0) < 1e-9


def test_multipliers_of_the_crossed_branch_agree_with_central_differences(crossed):
    W, br = crossed
    problem = MapProblem(br.base, ("F",), 1, 0.0, "exact", {})
    impacting = [p for p in br.points if p.signature and -p.upper_margin > 5e-2]
    assert len(impacting) > 5
    for p in impacting[:: max(1, len(impacting) // 6)]:
        z = np.array([p.x, p.v])
        h = 1e-6
        cols = []
        for i in range(2):
            d = np.zeros(2)
            d[i] = h
            cols.append((problem.evaluate(z + d, (p.parameter,)).image
                         - problem.evaluate(z - d, (p.parameter,)).image) / (2 * h))
        fd = np.linalg.eigvals(np.column_stack(cols))
        mus = np.asarray(p.multipliers)
        assert abs(np.sum(fd) - np.sum(mus)) < 1e-5 * max(1.0, abs(np.sum(mus)))
        assert abs(np.prod(fd) - np.prod(mus)) < 1e-5 * max(1.0, float(np.max(np.abs(mus))))


def test_at_the_grazing_the_result_says_the_map_is_not_differentiable(crossed):
    W, br = crossed
    graze = br.find("grazing")[0]
    assert np.all(np.isnan(graze.multipliers))
    node = graze.context[1]
    assert "not differentiable" in node.info.singular
    # the real map itself at the grazing orbit: a touch of the rigid wall, no Jacobian
    problem = MapProblem(br.base, ("F",), 1, 0.0, "exact", {})
    ev = problem.evaluate(np.array([graze.x, graze.v]), (graze.parameter,))
    # the located state is the grazing orbit to rounding: the real orbit touches the wall at zero speed, or at a
    # speed of rounding size (a few 1e-7), where the 1/V saltation makes the derivative explode instead
    assert ev.ok and ("not differentiable" in ev.singular or np.linalg.norm(ev.monodromy) > 1e5)


@pytest.mark.slow
@pytest.mark.parametrize("beta", [0.0, 0.05])
def test_a_stiff_spring_flange_branch_crosses_its_grazing(beta):
    # issue 26: at K = 1e4 with friction the branch from the contact-free orbit stopped at the grazing
    W = 0.7
    osc = io.Oscillator(0.3, W, beta, 1e4, zeta=0.05)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=200)
    br = dy.continuation(orb, "F", (0.05, 0.6), direction="forward", max_points=200)
    graze = br.find("grazing")
    assert graze, br.summary()
    assert br.status in (0, 1), br.message
    beyond = [p for p in br.points if p.parameter > graze[0].parameter and p.upper_margin < 0]
    assert beyond
    # the symmetric guide's contact-free orbit touches both flanges at once: said, not hidden
    assert "both at once" in graze[0].message
    if beta == 0.0:  # the contact-free orbit is the linear one: it grazes at |1 - W^2 + 2 i zeta W|
        assert abs(graze[0].parameter - cf.grazing_amplitude(W, 0.05)) < 1e-10


@pytest.mark.slow
def test_a_power_law_flange_branch_crosses_its_grazing():
    W = 0.8
    osc = io.Oscillator(0.3, W, 0.0, 1e3, zeta=0.05, exponent=1.5)
    orb = dy.periodic_orbit(osc, backend="heyoka", transient_periods=200)
    br = dy.continuation(orb, "F", (0.2, 0.45), direction="forward", max_points=60)
    graze = br.find("grazing")
    assert graze and br.status in (0, 1), br.summary()
    assert abs(graze[0].parameter - cf.grazing_amplitude(W, 0.05)) < 1e-9
    contacting = [p for p in br.points if p.upper_margin < 0]
    assert contacting
    # a scipy oracle at tight tolerance: the crossed points are fixed points of its map too
    problem = graze[0].context[0]
    oracle = MapProblem(problem.base, ("F",), 1, problem.section_phase, "scipy", {"rtol": 1e-12, "atol": 1e-14})
    for p in contacting[:: max(1, len(contacting) // 4)]:
        ev = oracle.evaluate(np.array([p.x, p.v]), (p.parameter,))
        assert ev.ok and np.linalg.norm(ev.residual) < 1e-8


@pytest.mark.slow
def test_a_stiff_spring_flange_branch_crosses_back_off_the_flange():
    # from the contacting family at K = 1e4 down through the grazing to the contact-free orbits (a one-sided stop:
    # with both flanges the symmetric contact-free orbit grazes both at once, where several families meet)
    W = 0.8
    spring = dict(zeta=0.05, gap_lower=None)
    orb = dy.periodic_orbit(io.Oscillator(0.32, W, 0.0, 1e4, **spring), backend="exact", transient_periods=300)
    up = dy.continuation(orb, "F", (0.32, 0.42), direction="forward", max_points=200)
    top = up.points[-1]
    assert top.upper_margin < 0 and top.parameter == pytest.approx(0.42)
    br = dy.continuation((top.x, top.v), "F", (0.3, 0.42), base=io.Oscillator(0.42, W, 0.0, 1e4, **spring),
                         direction="backward", max_points=200)
    assert br.status == 0, br.message
    graze = br.find("grazing")
    assert graze and abs(graze[0].parameter - cf.grazing_amplitude(W, 0.05)) < 1e-10
    below = [p for p in br.points if p.parameter < graze[0].parameter]
    assert below and all(not p.signature for p in below)


def test_continuation_in_exponent_refuses_the_exact_backend_that_cannot_run_the_member():
    # issue 25: from a linear member the exact backend ran power-law members as if linear ("stable" points)
    osc = io.Oscillator(0.3, 0.8, 0.0, 1e3, zeta=0.05)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=100)
    with pytest.raises(ValueError, match="backend='exact' does not run every member of the range of exponent"):
        dy.continuation(orb, "exponent", (1.0, 2.0), backend="exact", direction="forward", max_points=20)
    # without a backend named, the branch runs on one that supports every member of the range, and says so
    br = dy.continuation(orb, "exponent", (1.0, 1.2), direction="forward", max_points=20)
    assert br.backend == "heyoka", br.backend


def test_the_rigid_stop_grazing_is_the_same_from_both_sides_at_several_frequencies():
    for W in (0.6, 1.4):
        below = _branch(0.5 * cf.grazing_amplitude(W, ZETA), W, limits=(0.02, 1.0), max_points=300)
        g = below.find("grazing")
        assert g and abs(g[0].parameter - cf.grazing_amplitude(W, ZETA)) < 1e-10, below.summary()
        assert math.isfinite(g[0].x)


def test_a_state_resting_on_a_rigid_wall_is_stable_not_marginal():
    # issue 26: a constant push into the wall and a weak forcing: the mass rests on the wall all period, and every
    # perturbation (off the wall: there is no other) falls back and comes to rest on it again. Multipliers 0, not 1.
    osc = io.Oscillator.from_harmonics([(0.05, 0.8, 0.0), (2.0, 0.0, 0.0)], beta=0.0, zeta=0.05, flange="rigid",
                                       restitution=0.5)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=100)
    assert orb.status == 0 and orb.x == 1.0 and orb.v == 0.0
    assert np.all(np.abs(orb.multipliers) == 0.0)
    br = dy.continuation(orb, "F", (0.01, 0.09), max_points=20)
    assert br.status == 0 and all(p.stability == "stable" for p in br.points)
    problem = MapProblem(osc, ("F",), 1, 0.0, "exact", {})
    for dz in ([-1e-6, 0.0], [0.0, -1e-6], [-1e-6, 1e-6]):  # the map is locally constant: every neighbour returns
        image = problem.evaluate(np.array([1.0, 0.0]) + dz, (0.05,)).image
        assert np.array_equal(image, [1.0, 0.0])


def test_an_impact_crossing_the_section_is_a_border_not_the_end():
    # issue 26: as the impact's time passes the section's, the state on the section jumps across the reset
    # (from just after the impact to just before it); the corrector left the branch there (status -1)
    F, phase = 0.5, 1.0
    orb = dy.periodic_orbit(stop(F, 0.9), backend="exact", transient_periods=300, phase=phase)
    br = dy.continuation(orb, "Omega", (0.5, 2.5), direction="forward", max_points=300, tol=1e-12)
    assert br.status == 0, br.message
    border = [s for s in br.find("border") if "crosses the section" in s.message]
    assert len(border) == 1
    assert any(p.x == pytest.approx(1.0) and p.v > 0 for p in br.points)  # just before the impact, past the border
    for p in br.points:
        if p.signature != ((("impact", 1), 1),):
            continue
        W = p.parameter
        orbits = cf.orbits(F, W, ZETA, E, 0.0)
        z = np.array([p.x, p.v])
        states = [cf.section_state(F, W, ZETA, E, 0.0, o, phase / W) for o in orbits]
        # the closed form's state at the section: after the impact if it falls exactly there
        states += [np.array([1.0, -E * s[1]]) for s in states if abs(s[0] - 1.0) < 1e-6 and s[1] > 0]
        assert min(float(np.linalg.norm(z - s)) for s in states) < 1e-8, (W, z)


def test_a_two_impact_orbit_is_not_crossed_by_taking_its_flange_away():
    # an orbit with two impacts a period whose slower impact slows down: taking the flange away (the crossing of a
    # single contact) found the contact-free grazing far below the limits, and the branch went there
    osc = io.Oscillator.from_harmonics([(1.0, 0.8, 0.0), (0.5, 0.0, 0.0)], beta=0.0, zeta=ZETA, flange="rigid",
                                       restitution=0.5, gap_lower=None)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=100)
    br = dy.continuation(orb, "F", (0.5, 3.0), max_points=200)
    assert all(0.5 <= p.parameter <= 3.0 for p in br.points)
    assert all(0.5 <= s.parameter <= 3.0 for s in br.special)


def test_a_grazing_stepped_over_is_located_as_a_regular_point():
    # where one step goes past a grazing (no crossing was started), the margin's sign change is located on the
    # contact-free orbits with the flange taken away, not by a regula falsi across the nonsmooth point
    from impactosc.dynamics.continuation._api import _settings, _start_node
    from impactosc.dynamics.continuation._follow import locate_between

    W = 0.8
    F_gr = cf.grazing_amplitude(W, ZETA)
    problem = MapProblem(stop(0.36, W), ("F",), 1, 0.0, "exact", {})
    settings = _settings(0.02, 1e-7, 0.1, 100, 1e-12, 8, True, 1e-12, ())
    a = _start_node(problem, cf.free_state(0.36, W, ZETA, 0.0), settings)
    impacting = cf.orbits(0.38, W, ZETA, E, 0.0)
    b_problem = MapProblem(stop(0.38, W), ("F",), 1, 0.0, "exact", {}, scales=problem.scales)
    b = None
    for o in impacting:
        b = _start_node(b_problem, cf.section_state(0.38, W, ZETA, E, 0.0, o), settings)
        if not isinstance(b, str) and b.info.signature:
            break
    assert not isinstance(a, str) and not isinstance(b, str) and b.info.signature
    t = (b.u - a.u) / np.linalg.norm(b.u - a.u)
    found = [f for f in locate_between(problem, a, b, t, settings, 0) if f.kind == "grazing"]
    assert len(found) == 1 and "regular point" in found[0].message
    assert abs(found[0].node.u[2] * problem.scales[0] - F_gr) < 1e-10


def test_a_grazing_that_cannot_be_crossed_says_why():
    # Den Hartog's undamped orbit below resonance turns at its maximum exactly on the section at phase 0 (the
    # response is in phase with the forcing): the contact-free orbits' grazing is degenerate there and the crossing
    # fails. The branch ends at the grazing (status 2) and its message says why the crossing failed.
    W, beta = 0.5, 0.1
    Fc = dy.den_hartog_onset(W, beta)
    orb = dy.periodic_orbit(io.Oscillator(0.9 * Fc, W, beta, 24.0), backend="exact", transient_periods=300)
    br = dy.continuation(orb, "F", (0.5 * Fc, 1.05 * Fc), direction="forward")
    assert br.status == 2
    assert "crossing the upper flange's grazing failed" in br.message and "discontinuous grazing" in br.message
