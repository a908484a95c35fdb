"""Continuation on user systems (issue 27, item 3): the built-in family's follow loop on a HybridMap.

Closed forms first (the contact-free orbit's grazing amplitude, the rigid stop's period
doubling from ``impact_closed_form``), then agreement with the built-in family on the same
equation (eq. 3 written by ``oscillator_system``: the same special points within 1e-10 in
the parameter), then a system the built-in family cannot express (two masses, one stop)
against an independent root search on ``periodic_orbit_of``.
"""

from __future__ import annotations

import math

import heyoka as hy
import impact_closed_form as cf
import numpy as np
import pytest
from scipy.optimize import brentq

import impactosc as io
import impactosc.dynamics as dy
from impactosc import Guard, HybridMode, HybridSystem, symbols
from impactosc.dynamics import HybridMap, periodic_orbit_of
from impactosc.model.hybrid import oscillator_system

#: The spring-flange member without friction: its contact-free orbit has the amplitude F / |1 - W^2 + 0.1 i W|.
SPRING = dict(beta=0.0, K=1e2, zeta=0.05)


def _pair(osc: io.Oscillator, parameter: str, limits):
    """The built-in branch and the user system's branch of ``osc``, from the same orbit on the same section."""
    orbit = dy.periodic_orbit(osc, backend="exact", transient_periods=300)
    assert orbit.status == 0
    builtin = dy.continuation(orbit, parameter, limits, progress=False)
    hmap = HybridMap(oscillator_system(osc), t0=orbit.t0)
    start = periodic_orbit_of(hmap, [orbit.x, orbit.v])
    assert start.status == 0 and np.allclose(start.z, [orbit.x, orbit.v], atol=1e-9)
    user = dy.continuation(start, parameter, limits, base=hmap, progress=False)
    return builtin, user


@pytest.fixture(scope="module")
def in_F():
    return _pair(io.Oscillator(0.3, 1.1, **SPRING), "F", (0.05, 0.5))


def test_eq3_in_F_grazes_where_the_closed_form_and_the_builtin_do(in_F):
    builtin, user = in_F
    assert user.status == 0, user.message
    exact = math.hypot(1.0 - 1.1**2, 0.1 * 1.1)  # amplitude 1: the contact-free orbit touches X = +-1
    grazings = user.find("grazing")
    # the symmetric orbit touches both flanges at once: one grazing per guard, each labelled with it
    assert sorted(g.guard for g in grazings) == ["enter lower", "enter upper"], user.summary()
    for g in grazings:
        assert abs(g.parameter - exact) < 1e-10
        assert abs(g.parameter - builtin.find("grazing")[0].parameter) < 1e-10
        assert g.flange == "" and g.guard in g.message


def test_eq3_in_F_has_the_builtin_fold(in_F):
    builtin, user = in_F
    ref = [s.parameter for s in builtin.find("fold")]
    assert ref, builtin.summary()
    folds = [s for s in user.find("fold") if abs(s.parameter - ref[0]) < 1e-6]
    assert len(folds) == 1, user.summary()
    assert abs(folds[0].parameter - ref[0]) < 1e-10
    assert np.min(np.abs(folds[0].multipliers - 1.0)) < 1e-6


def test_eq3_in_Omega_grazes_where_the_closed_form_and_the_builtin_do():
    builtin, user = _pair(io.Oscillator(0.3, 0.7, **SPRING), "Omega", (0.6, 0.86))
    # |1 - W^2 + 0.1 i W| = 0.3: W^2 = (1.99 - sqrt(1.99^2 - 4 * 0.91)) / 2
    exact = math.sqrt((1.99 - math.sqrt(1.99**2 - 4 * 0.91)) / 2)
    first = builtin.find("grazing")[0]
    assert abs(first.parameter - exact) < 1e-10
    grazings = user.find("grazing")
    assert grazings, user.summary()
    for g in grazings:
        assert abs(g.parameter - exact) < 1e-10
        assert abs(g.parameter - first.parameter) < 1e-10


def test_eq3_with_friction_finds_the_builtin_stick_onsets():
    """Sliding bifurcations of a slowly forced Coulomb oscillator: sticks per period change twice in 0.2-0.8.

    The user system's are located by bisection on the event signature (a stick-mode entry
    appearing), which the engine's stick test stops short of the built-in's 1e-10: right at
    the onset the slip-or-stick decision fails in the user-system loop (no admissible mode,
    or a lost root), so the bracket ends ~1e-5 wide; the located point lies within it.
    """
    builtin, user = _pair(io.Oscillator(0.5, 0.3, 0.05, 1e2, zeta=0.05), "F", (0.2, 0.8))
    ref = [s.parameter for s in builtin.find("stick_onset")]
    found = user.find("stick_onset")
    assert len(ref) == 2 and len(found) == 2, user.summary()
    for s, r in zip(found, ref, strict=True):
        assert s.accuracy < 1e-4
        assert abs(s.parameter - r) <= 2 * s.accuracy
        assert "stick mode" in s.message


# -- the rigid one-sided stop (COCO's impact demo): eq. 3 as a user system against closed forms -------------
W, ZETA, E = 0.8, 0.05, 0.8


@pytest.fixture(scope="module")
def stop_start():
    osc = io.Oscillator(0.5, W, 0.0, None, zeta=ZETA, flange="rigid", restitution=E, gap_lower=None)
    hmap = HybridMap(oscillator_system(osc))
    stable = cf.orbits(0.5, W, ZETA, E, 0.0)[1]
    start = periodic_orbit_of(hmap, cf.section_state(0.5, W, ZETA, E, 0.0, stable))
    assert start.status == 0
    return hmap, start


def test_the_rigid_stop_period_doubles_where_the_closed_form_and_the_builtin_do(stop_start):
    hmap, start = stop_start
    branch = dy.continuation(start, "F", (0.45, 0.6), base=hmap, direction="forward", progress=False)
    pd = branch.find("period_doubling")
    assert len(pd) == 1, branch.summary()
    ref = cf.period_doubling_near(W, ZETA, E, 0.0, pd[0].parameter)
    assert ref is not None
    assert abs(pd[0].parameter - ref) < 1e-10
    assert np.min(np.abs(pd[0].multipliers + 1.0)) < 1e-6
    osc = io.Oscillator(0.5, W, 0.0, None, zeta=ZETA, flange="rigid", restitution=E, gap_lower=None)
    orbit = dy.periodic_orbit(osc, guess=tuple(start.z), backend="exact")
    builtin = dy.continuation(orbit, "F", (0.45, 0.6), direction="forward", progress=False)
    assert abs(builtin.find("period_doubling")[0].parameter - pd[0].parameter) < 1e-10


def test_a_rigid_grazing_is_crossed_and_labelled_with_its_guard(stop_start):
    hmap, start = stop_start
    branch = dy.continuation(start, "F", (0.02, 0.5), base=hmap, direction="backward", progress=False)
    assert branch.status == 0, branch.message
    (graze,) = branch.find("grazing")
    assert graze.guard == "impact upper"
    # located on the orbits without the stop, not extrapolated: to the Newton tolerance
    assert graze.accuracy < 1e-10
    assert abs(graze.parameter - cf.grazing_amplitude(W, ZETA)) < 1e-10


# -- a system the built-in family cannot express: two masses, one rigid stop ------------------------------------
def two_masses(A: float) -> HybridSystem:
    x1, v1, x2, v2, k, c, a, w, d, e = symbols("x1 v1 x2 v2 k c A w d e")
    field = {x1: v1, v1: a * hy.cos(w * hy.time) - x1 - k * (x1 - x2) - c * v1, x2: v2, v2: -k * (x2 - x1) - c * v2}
    return HybridSystem("x1 v1 x2 v2", {"k": 2.0, "c": 0.05, "A": A, "w": 0.9, "d": 0.5, "e": 0.8},
                        [HybridMode("free", field)],
                        [Guard("stop", x1 - d, 1, armed="free", to="free", reset={v1: -e * v1})],
                        period=2 * math.pi / w, name="two masses")


@pytest.fixture(scope="module")
def two_mass_branch():
    # from rest at A = 1.5 the motion settles near an orbit with two impacts a period (unstable: a multiplier
    # -2.6, which Newton does not mind); down in A its branch period-doubles, then a torus is born
    system = two_masses(1.5)
    T = 2 * math.pi / 0.9
    settled = io.simulate(system, 300 * T, [0.0] * 4).sample([300 * T])[0][:4]
    hmap = HybridMap(system)
    start = periodic_orbit_of(hmap, settled)
    assert start.status == 0 and len(start.signature) == 2
    return hmap, dy.continuation(start, "A", (0.45, 1.5), base=hmap, direction="backward", progress=False)


def _root(hmap, branch, point, test):
    """The zero of ``test(multipliers)`` in A by Brent's method on periodic_orbit_of, bracketed by branch points."""
    i = point.index

    def g(A):
        w = (A - branch.points[i].parameter) / (branch.points[i + 1].parameter - branch.points[i].parameter)
        guess = (1 - w) * branch.points[i].z + w * branch.points[i + 1].z
        orbit = periodic_orbit_of(HybridMap(two_masses(A)), guess)
        assert orbit.status == 0
        return test(orbit.multipliers)

    return brentq(g, branch.points[i].parameter, branch.points[i + 1].parameter, xtol=1e-14, rtol=1e-15)


def test_two_masses_period_doubling_and_torus_against_periodic_orbit_of(two_mass_branch):
    hmap, branch = two_mass_branch
    assert branch.status == 0, branch.message
    (pd,) = branch.find("period_doubling")
    (ns,) = branch.find("neimark_sacker")
    assert [s.kind for s in branch.special] == ["neimark_sacker", "period_doubling"], branch.summary()
    # four multipliers: the torus is a complex pair on the unit circle, the doubling a real one at -1
    assert len(ns.multipliers) == 4
    ref_pd = _root(hmap, branch, pd, lambda mus: float(np.real(np.prod(mus + 1.0))))
    ref_ns = _root(hmap, branch, ns, lambda mus: float(np.max(np.abs(mus[np.abs(mus.imag) > 0])) - 1.0))
    assert abs(pd.parameter - ref_pd) < 1e-10
    assert abs(ns.parameter - ref_ns) < 1e-10


def test_two_masses_switch_onto_the_period_two_branch(two_mass_branch):
    _, branch = two_mass_branch
    (pd,) = branch.find("period_doubling")
    doubled = dy.continuation(pd, "A", (0.45, 0.6), progress=False, max_points=60)
    assert doubled.n == 2 and doubled.status == 0, doubled.message
    for p in doubled.points[:: max(1, len(doubled.points) // 4)]:
        system = two_masses(p.parameter)
        assert np.linalg.norm(HybridMap(system, 2).evaluate(p.z).residual) < 1e-9  # a fixed point of P^2
        assert np.linalg.norm(HybridMap(system, 1).evaluate(p.z).residual) > 1e-6  # not of P


# -- the result -------------------------------------------------------------------------------------------------
def test_a_user_branch_is_a_branch(two_mass_branch):
    hmap, branch = two_mass_branch
    table = branch.table()
    assert [r["type"] for r in table] == ["EP", "NS", "PD", "EP"], branch.summary()
    ds = branch.to_xarray()
    assert ds["state"].shape == (len(branch.points), 4)
    assert list(ds["component"].values) == ["x1", "v1", "x2", "v2"]
    assert ds["multiplier_abs"].shape == (len(branch.points), 4)
    assert "two masses" in repr(branch.base) or branch.base.name == "two masses"
    orbit = branch.orbit("PD1")
    assert orbit.status == 0 and np.min(np.abs(orbit.multipliers + 1.0)) < 1e-6
    assert "NS1" in branch.summary()
    restarted = dy.continuation(branch.points[1], "A", (0.45, 0.47), progress=False, direction="backward")
    assert restarted.status == 0 and restarted.points[-1].parameter == pytest.approx(branch.points[1].parameter)
    assert np.allclose(restarted.points[-1].z, branch.points[1].z, atol=1e-9)
    # a guess of the state and the system itself (its map over one forcing period from t = 0)
    last = branch.points[-1]
    again = dy.continuation(last.z + 1e-6, "A", (1.45, 1.5), base=two_masses(1.5), progress=False, max_points=3)
    first = next(p for p in again.points if p.arclength == 0.0)  # Newton at the system's A first
    assert first.parameter == 1.5
    assert np.allclose(first.z, last.z, atol=1e-9)
    assert all(p.signature == ((("stop", "free->free"), 2),) for p in again.points)  # two impacts a period


def test_a_user_branch_is_not_saved_silently(two_mass_branch, tmp_path):
    _, branch = two_mass_branch
    with pytest.raises(TypeError, match="two masses.*cannot be saved"):
        branch.save(tmp_path / "branch.nc")
    assert not (tmp_path / "branch.nc").exists()


def test_bad_input_names_what_is_wrong(two_mass_branch):
    hmap, branch = two_mass_branch
    start = branch.orbit(len(branch.points) - 1)  # the start of the branch, at the map's A = 1.5
    assert start.status == 0
    with pytest.raises(ValueError, match="parameters are.*got 'B'"):
        dy.continuation(start, "B", (0.4, 0.5), base=hmap)
    with pytest.raises(TypeError, match="does not carry its map"):
        dy.continuation(start, "A", (0.4, 0.5))
    with pytest.raises(ValueError, match="4 finite numbers"):
        dy.continuation([0.1, 0.2], "A", (0.4, 0.5), base=hmap)
    with pytest.raises(ValueError, match="outside the limits"):
        dy.continuation(start, "A", (0.6, 0.7), base=hmap)
    with pytest.raises(ValueError, match="parameters of the system.*got 'nope'"):
        dy.continuation(branch.special[0], ("A", "nope"), {"A": (0.4, 1.5)})


@pytest.mark.slow  # the built-in example's transient and branch, ~10 s
def test_the_continuation_docstring_examples_run():
    import doctest

    from impactosc.dynamics.continuation import _api

    result = doctest.testmod(_api)
    assert result.attempted > 0 and result.failed == 0
