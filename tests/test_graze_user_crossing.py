"""Grazings of a user system's guards crossed by continuation (issue 27, item 3; the grazing issue's crossing).

eq. 3 written as a user system (``oscillator_system``) against the closed form of the
contact-free orbit's grazing amplitude and against the built-in family's branch on the same
equation: a rigid stop with the reset ``V -> -e V`` (Nordmark's square-root map at the grazing,
crossed both ways: off the stop from the impacting orbits, onto it from the contact-free ones)
and a spring flange. The branch goes on past the grazing, which is labelled with its guard, and
every point after it is a fixed point of the real map.
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
LIMITS = (0.02, 0.5)


def _member(F: float, K=None, **flange) -> io.Oscillator:
    return io.Oscillator(F, W, 0.0, K, zeta=ZETA, gap_lower=None, **flange)


def _builtin_grazing(osc: io.Oscillator, guess, direction: str) -> float:
    orbit = dy.periodic_orbit(osc, guess=tuple(guess), backend="exact")
    assert orbit.status == 0
    branch = dy.continuation(orbit, "F", LIMITS, direction=direction, progress=False)
    (graze,) = branch.find("grazing")
    return graze.parameter


def _check_past_the_grazing(hmap: HybridMap, branch, guard: str, crossing_after: bool) -> None:
    """Status 0, one grazing of ``guard`` at the closed form, every later point a fixed point (1e-9)."""
    assert branch.status == 0, branch.message
    (graze,) = branch.find("grazing")
    assert graze.guard == guard and guard in graze.message
    assert graze.context[2]["case"] == "persistent"
    assert abs(graze.parameter - cf.grazing_amplitude(W, ZETA)) < 1e-10
    in_F = hmap.with_names(("F",))
    after = [p for p in branch.points if (p.parameter - graze.parameter) * (LIMITS[1] - LIMITS[0]) *
             (1 if crossing_after else -1) > 0]
    assert len(after) >= 3, branch.summary()
    for p in after:
        ev = in_F.evaluate(p.state, (p.parameter,))
        assert ev.ok and np.max(np.abs(ev.residual)) < 1e-9
        crossings = sum(1 for g, _, _ in ev.signature if g == guard)
        assert crossings == (1 if crossing_after else 0), (p.parameter, ev.signature)
    # the branch reaches the limit beyond the grazing
    far_end = LIMITS[1] if crossing_after else LIMITS[0]
    assert min(abs(p.parameter - far_end) for p in branch.points) < 1e-12


@pytest.fixture(scope="module")
def rigid_builtin():
    stable = cf.orbits(0.5, W, ZETA, E, 0.0)[1]
    return _builtin_grazing(_member(0.5, flange="rigid", restitution=E), cf.section_state(0.5, W, ZETA, E, 0.0, stable),
                            "backward")


def test_a_rigid_stop_is_crossed_off_the_impacting_orbits(rigid_builtin):
    hmap = HybridMap(oscillator_system(_member(0.5, flange="rigid", restitution=E)))
    stable = cf.orbits(0.5, W, ZETA, E, 0.0)[1]
    start = periodic_orbit_of(hmap, cf.section_state(0.5, W, ZETA, E, 0.0, stable))
    assert start.status == 0
    branch = dy.continuation(start, "F", LIMITS, base=hmap, direction="backward", progress=False)
    # going down in F the impacting orbit's impact speed falls to zero: past it, contact-free orbits
    _check_past_the_grazing(hmap, branch, "impact upper", crossing_after=False)
    (graze,) = branch.find("grazing")
    assert abs(graze.parameter - rigid_builtin) < 1e-10
    assert np.all(np.isnan(graze.multipliers))  # the square-root map has no derivative there


def test_a_rigid_stop_is_crossed_onto_the_impacting_orbits(rigid_builtin):
    hmap = HybridMap(oscillator_system(_member(0.2, flange="rigid", restitution=E)))
    start = periodic_orbit_of(hmap, cf.free_state(0.2, W, ZETA, 0.0))
    assert start.status == 0
    branch = dy.continuation(start, "F", LIMITS, base=hmap, direction="forward", progress=False)
    # the impacting family entered by the impact's time and pre-impact state as unknowns
    _check_past_the_grazing(hmap, branch, "impact upper", crossing_after=True)
    (graze,) = branch.find("grazing")
    assert abs(graze.parameter - rigid_builtin) < 1e-10
    # past the grazing the branch is the closed-form impacting orbit of one impact a period
    last = branch.points[-1]
    orbits = cf.orbits(last.parameter, W, ZETA, E, 0.0)
    states = [cf.section_state(last.parameter, W, ZETA, E, 0.0, o) for o in orbits]
    assert min(np.max(np.abs(np.asarray(s) - last.state)) for s in states) < 1e-8


def test_a_spring_flange_is_crossed_onto_the_contacting_orbits():
    K = 1e2
    hmap = HybridMap(oscillator_system(_member(0.2, K=K)))
    start = periodic_orbit_of(hmap, cf.free_state(0.2, W, ZETA, 0.0))
    assert start.status == 0
    branch = dy.continuation(start, "F", LIMITS, base=hmap, direction="forward", progress=False)
    _check_past_the_grazing(hmap, branch, "enter upper", crossing_after=True)
    (graze,) = branch.find("grazing")
    assert abs(graze.parameter - _builtin_grazing(_member(0.2, K=K), start.z, "forward")) < 1e-10


def test_a_grazing_stepped_over_is_located_on_the_orbits_without_the_guard():
    # a soft flange (K = 1): the branch steps across the grazing smoothly; the sign change of the guard's
    # margin between two points is then solved on the system without the guard, not by regula falsi
    hmap = HybridMap(oscillator_system(_member(0.2, K=1.0)))
    start = periodic_orbit_of(hmap, cf.free_state(0.2, W, ZETA, 0.0))
    branch = dy.continuation(start, "F", LIMITS, base=hmap, direction="forward", step=0.1, max_step=0.1,
                             progress=False)
    assert branch.status == 0, branch.message
    (graze,) = branch.find("grazing")
    assert "between two points of the branch" in graze.message and graze.guard == "enter upper"
    assert abs(graze.parameter - cf.grazing_amplitude(W, ZETA)) < 1e-10 and graze.accuracy < 1e-10


def test_a_section_maps_guard_is_not_crossed_and_says_why():
    # an autonomous system's return map (the relay of test_system_tangent): the extremum's sensitivity is written
    # for a stroboscopic map, so its guards' grazings are refused by name, never a crash inside a branch
    from impactosc import Guard, HybridMode, HybridSystem, symbols
    from impactosc.dynamics.continuation._guard_crossing import GuardlessProblem
    from impactosc.dynamics.continuation._hybrid_problem import SystemProblem

    x, v, zeta, a = symbols("x v zeta a")
    s = x + a * v
    relay = HybridSystem("x v", {"zeta": -0.1, "a": 0.05},
                         [HybridMode("on", {x: v, v: -x - 2 * zeta * v - 1.0}),
                          HybridMode("off", {x: v, v: -x - 2 * zeta * v + 1.0})],
                         [Guard("switch off", s, -1, armed="on", to="off"),
                          Guard("switch on", s, 1, armed="off", to="on")],
                         section="switch on", name="relay")
    problem = SystemProblem(HybridMap(relay, mode="on", names=("a",)))
    virtual = GuardlessProblem(problem, "switch off")
    assert "section" in virtual.peak([-0.05, 0.9], (0.05,))
    with pytest.raises(ValueError, match="section of the map"):
        GuardlessProblem(problem, "switch on")
