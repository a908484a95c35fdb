"""Continuation's labels do not depend on the step: the contact case's symmetry-breaking pitchfork.

On ``Oscillator(0.2, 1.1, 0.01, 1e4)`` followed in F over 0.05-2 a multiplier passes +1 at
F = 1.14880658 while the branch goes on in F (a symmetric orbit's pitchfork). The arclength
locator near a branch point can stop on a node whose multipliers are still 1e-3 from +1;
the point used to be relabelled a border ("the multipliers jump") at both step 0.02 and
0.05, at places 5.6e-7 apart. It is a branch point, located in the parameter when the
arclength fails, at the same place for both steps.
"""

from __future__ import annotations

import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy

#: Where the +1 crossing lies (the previous session's note, and both steps below agree to 1e-10).
PITCHFORK = 1.14880658


@pytest.fixture(scope="module")
def contact_orbit():
    orbit = dy.periodic_orbit(io.Oscillator(0.2, 1.1, 0.01, 1e4), backend="exact", transient_periods=200)
    assert orbit.status == 0
    return orbit


@pytest.fixture(scope="module")
def branches(contact_orbit):
    return {step: dy.continuation(contact_orbit, "F", (0.05, 2.0), step=step, progress=False)
            for step in (0.02, 0.05)}


@pytest.mark.parametrize("step", [0.02, 0.05])
def test_the_pitchfork_is_a_branch_point_at_either_step(branches, step):
    branch = branches[step]
    near = [s for s in branch.special if abs(s.parameter - PITCHFORK) < 1e-5]
    assert [s.kind for s in near] == ["branch_point"], [(s.label, s.kind, s.message) for s in near]
    point = near[0]
    assert point.located
    # on its zero: one multiplier at +1 (the other is the damped one, det M < 1)
    assert np.min(np.abs(point.multipliers - 1.0)) < 1e-6
    assert abs(point.parameter - PITCHFORK) < 1e-8


def test_both_steps_put_the_branch_point_at_one_place(branches):
    where = [next(s.parameter for s in branches[step].special if s.kind == "branch_point") for step in (0.02, 0.05)]
    assert abs(where[0] - where[1]) < 1e-9
