"""Boundaries in two parameters from a user system's special points (issue 27, item 3).

eq. 3 written as a user system (``oscillator_system``): the grazing curve of a rigid stop in
``(F, Omega)`` against its closed form ``F = |1 - W^2 + 2 i zeta W|`` and against the built-in
family's boundary of the same point, and a fold curve of the symmetric spring-flange member
against the built-in's fold curve, compared where both reach the same parameter values (the
limits of ``Omega``, where each curve ends).
"""

from __future__ import annotations

import impact_closed_form as cf
import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc.dynamics import HybridMap, periodic_orbit_of
from impactosc.model.hybrid import oscillator_system

W, ZETA, E = 0.8, 0.05, 0.8


def _ends(branch) -> dict:
    """``Omega -> F`` at the two ends of a boundary."""
    return {round(p.parameters["Omega"], 12): p.parameters["F"] for p in (branch.points[0], branch.points[-1])}


@pytest.fixture(scope="module")
def rigid_grazings():
    osc = io.Oscillator(0.2, W, 0.0, None, zeta=ZETA, flange="rigid", restitution=E, gap_lower=None)
    hmap = HybridMap(oscillator_system(osc))
    start = periodic_orbit_of(hmap, cf.free_state(0.2, W, ZETA, 0.0))
    user = dy.continuation(start, "F", (0.02, 0.5), base=hmap, direction="forward", progress=False)
    orbit = dy.periodic_orbit(osc, guess=tuple(start.z), backend="exact")
    builtin = dy.continuation(orbit, "F", (0.02, 0.5), direction="forward", progress=False)
    return user.find("grazing")[0], builtin.find("grazing")[0]


def test_the_grazing_curve_of_a_user_stop_is_the_closed_form_and_the_builtin_one(rigid_grazings):
    user_point, builtin_point = rigid_grazings
    limits = {"Omega": (0.6, 1.0)}
    user = dy.continuation(user_point, ("F", "Omega"), limits, progress=False)
    builtin = dy.continuation(builtin_point, ("F", "Omega"), limits, progress=False)
    assert user.status == 0 and builtin.status == 0, (user.message, builtin.message)
    assert user.names == ("F", "Omega") and len(user.points) >= 10
    for p in user.points:
        assert abs(p.parameters["F"] - cf.grazing_amplitude(p.parameters["Omega"], ZETA)) < 1e-10
    ours, theirs = _ends(user), _ends(builtin)
    assert sorted(ours) == sorted(theirs) == [0.6, 1.0]
    for omega, F in ours.items():
        assert abs(F - theirs[omega]) < 1e-9
    # each point's orbit is one of the system's (its map's fixed point, rerun with the stop)
    hmap = HybridMap(user.model(user.points[-1]), names=("F", "Omega"))
    p = user.points[-1]
    assert np.max(np.abs(hmap.evaluate(p.state).residual)) < 1e-9


def test_the_fold_curve_of_a_user_system_is_the_builtin_one():
    osc = io.Oscillator(0.3, 1.1, beta=0.0, K=1e2, zeta=0.05)
    orbit = dy.periodic_orbit(osc, backend="exact", transient_periods=300)
    builtin = dy.continuation(orbit, "F", (0.05, 0.5), progress=False)
    hmap = HybridMap(oscillator_system(osc), t0=orbit.t0)
    start = periodic_orbit_of(hmap, [orbit.x, orbit.v])
    user = dy.continuation(start, "F", (0.05, 0.5), base=hmap, progress=False)
    ref = builtin.find("fold")[0]
    (fold,) = [f for f in user.find("fold") if abs(f.parameter - ref.parameter) < 1e-6]
    limits = {"Omega": (1.05, 1.15)}
    ours = dy.continuation(fold, ("F", "Omega"), limits, progress=False)
    theirs = dy.continuation(ref, ("F", "Omega"), limits, progress=False)
    assert ours.status == 0 and theirs.status == 0, (ours.message, theirs.message)
    a, b = _ends(ours), _ends(theirs)
    assert sorted(a) == sorted(b) == [1.05, 1.15]
    for omega, F in a.items():
        assert abs(F - b[omega]) < 1e-9
    for p in ours.points:  # a multiplier +1 all along
        assert np.min(np.abs(p.multipliers - 1.0)) < 1e-6


def test_a_user_boundary_refuses_backend_options(rigid_grazings):
    user_point, _ = rigid_grazings
    with pytest.raises(TypeError, match="backend"):
        dy.continuation(user_point, ("F", "Omega"), {"Omega": (0.6, 1.0)}, backend="scipy", progress=False)
    with pytest.raises(ValueError, match="parameters of the system"):
        dy.continuation(user_point, ("F", "nope"), {"F": (0.1, 0.5)}, progress=False)


def test_the_fold_grazing_points_of_a_user_stop_are_the_resonant_grazings():
    # a fold curve of the impacting orbits ends on the grazing curve where the square-root term vanishes: at
    # Omega = 2 w_d / k (k = 2, 3 in (0.5, 1.5)), as the built-in family finds (test_codim2_issue26)
    zeta = 0.05
    w_d = (1.0 - zeta * zeta) ** 0.5
    osc = io.Oscillator(0.05, 1.0, 0.0, None, zeta=zeta, flange="rigid", restitution=E, gap_lower=None)
    hmap = HybridMap(oscillator_system(osc))
    start = periodic_orbit_of(hmap, cf.free_state(0.05, 1.0, zeta, 0.0))
    branch = dy.continuation(start, "F", (0.02, 1.0), base=hmap, direction="forward", progress=False)
    curve = dy.continuation(branch.find("grazing")[0], ("F", "Omega"), {"Omega": (0.5, 1.5)}, max_points=400,
                            progress=False)
    assert curve.status == 0, curve.message
    points = sorted(curve.find("fold_grazing"), key=lambda s: s.parameters["Omega"])
    assert len(points) == 2, curve.summary()
    for s, W in zip(points, [2.0 * w_d / 3.0, w_d], strict=True):
        assert abs(s.parameters["Omega"] - W) < 1e-8 and s.accuracy < 1e-8
        assert abs(s.parameters["F"] - cf.grazing_amplitude(W, zeta)) < 1e-8
        assert s.guard == "impact upper" and s.label.startswith("FG")
        assert 0 < s.index < len(curve.points) - 1  # the grazing curve goes on past it
