"""One impact of a two-impact orbit grazing a rigid stop: the branch crosses onto the single-impact orbits (issue 26).

The model is ``X'' + 0.1 X' + X = F cos(0.8 t) + 0.5`` with Newton's impact ``V -> -0.5 V`` at ``X = 1``. Its
period-1 orbit with two impacts a period, followed down in ``F``, has one impact slowing to zero speed; there the
branch ended with status 2 (the grazing extrapolated). The grazing orbit has a closed form
(``impact_closed_form.two_impact_grazing``: the flights between impacts are linear), and the single-impact orbits
on the other side too (``impact_closed_form.orbits`` with the constant push ``c = 0.5``).
"""

from __future__ import annotations

import math

import impact_closed_form as cf
import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc.dynamics.continuation._problem import MapProblem

W, ZETA, E, PUSH = 0.8, 0.05, 0.5, 0.5
TWO = ((("impact", 1), 2),)
ONE = ((("impact", 1), 1),)


def _branch_from(F0):
    osc = io.Oscillator.from_harmonics([(F0, W, 0.0), (PUSH, 0.0, 0.0)], beta=0.0, zeta=ZETA, flange="rigid",
                                       restitution=E, gap_lower=None)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=200)
    assert orb.status == 0 and abs(orb.t0) < 1e-12
    return dy.continuation(orb, "F", (0.5, 3.0), max_points=200, tol=1e-12)


@pytest.fixture(scope="module")
def branch():
    return _branch_from(1.0)  # a two-impact orbit


@pytest.fixture(scope="module")
def from_one_impact():
    return _branch_from(0.7)  # a single-impact orbit


def _grazing_closed_form() -> float:
    T = 2.0 * math.pi / W
    return cf.two_impact_grazing(W, ZETA, E, PUSH, (0.94, 7.37 - T, 2.67, 2.25))[0]


def test_the_branch_crosses_from_two_impacts_to_one_at_the_closed_form_grazing(branch):
    assert branch.status == 0, branch.message
    graze = branch.find("grazing")
    assert len(graze) == 1, branch.summary()
    assert abs(graze[0].parameter - _grazing_closed_form()) < 1e-9
    assert "extrapolated" not in graze[0].message and "one of the 2 impacts" in graze[0].message
    assert graze[0].context[2]["side"] == 1 and graze[0].context[2]["case"] == "nonsmooth_fold"
    signatures = {p.signature for p in branch.points}
    assert TWO in signatures and ONE in signatures


def test_every_point_of_the_crossed_branch_is_a_fixed_point_of_the_map(branch):
    problem = MapProblem(branch.base, ("F",), 1, 0.0, "exact", {})
    for p in branch.points:
        ev = problem.evaluate(np.array([p.x, p.v]), (p.parameter,))
        assert ev.ok and np.linalg.norm(ev.residual) < 1e-9, p.parameter


def test_the_single_impact_side_is_the_closed_form(branch):
    one = [p for p in branch.points if p.signature == ONE]
    assert len(one) > 3
    for p in one:
        states = [cf.section_state(p.parameter, W, ZETA, E, PUSH, o) for o in cf.orbits(p.parameter, W, ZETA, E, PUSH)]
        assert min(float(np.linalg.norm(np.array([p.x, p.v]) - s)) for s in states) < 1e-9, p.parameter


def test_its_boundary_is_refused_not_followed_on_the_wrong_condition(branch):
    # taking the whole flange away would follow the grazing of an orbit that lost its other impact too
    graze = branch.find("grazing")[0]
    with pytest.raises(ValueError, match="one impact of several"):
        dy.continuation(graze, ("F", "Omega"), {"Omega": (0.7, 0.9)})


def test_a_branch_of_single_impact_orbits_crosses_the_other_way_where_a_new_impact_is_born(from_one_impact):
    # the same grazing from the other family: a turning point of the single-impact orbit reaches the wall (it ended
    # with status 2, the grazing extrapolated)
    br = from_one_impact
    assert br.status == 0, br.message
    graze = br.find("grazing")
    assert len(graze) == 1, br.summary()
    assert abs(graze[0].parameter - _grazing_closed_form()) < 1e-9
    assert "a new impact is born" in graze[0].message and graze[0].context[2]["case"] == "nonsmooth_fold"
    assert {p.signature for p in br.points} == {ONE, TWO}
    problem = MapProblem(br.base, ("F",), 1, 0.0, "exact", {})
    for p in br.points:
        ev = problem.evaluate(np.array([p.x, p.v]), (p.parameter,))
        assert ev.ok and np.linalg.norm(ev.residual) < 1e-9, p.parameter
    # and it finds the two-impact family's fold where the branch from the other side finds it
    other = _branch_from(1.0).find("fold")
    assert abs(br.find("fold")[0].parameter - other[0].parameter) < 1e-9
