"""The certified guard search finds what a cheaper model of the guard could miss.

A guard that rises 1e-13 above its zero (a grazing) and one whose two roots are 1e-9 apart in the
first search window (a fast mode brushing a flange) are exactly where a sampled, interpolated or
truncated model of the closed form loses a crossing or reports one twice. Closed forms: an
undamped mass ``q = (v0 / w) sin(w t)`` has its extreme ``A = v0 / w`` at ``t = pi / (2 w)``; a
stop at ``A - delta`` is crossed at ``w t = pi / 2 -+ acos(1 - delta / A)``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import MechanicalSystem, simulate_mechanical
from impactosc.model import Contact


def _mass(w: float, gap: float, **law) -> MechanicalSystem:
    """A unit mass on a spring of stiffness ``w^2``, undamped and unforced, below a stop at ``gap``."""
    return MechanicalSystem(M=[[1.0]], K=[[w * w]], contacts=[Contact([1.0], gap, **law)])


def _roots(w: float, amplitude: float, delta: float) -> tuple[float, float]:
    """The two crossings of ``amplitude sin(w t) = amplitude - delta`` around the first extreme."""
    half = math.acos(1.0 - delta / amplitude)
    return (math.pi / 2 - half) / w, (math.pi / 2 + half) / w


@pytest.mark.parametrize("w", [1.0, 1e3])
def test_a_spring_stop_grazed_by_1e_13_opens_and_closes_once_each(w):
    """A stop 1e-13 below the extreme: the contact closes and opens once, at the two roots of the
    guard (``2 sqrt(2e-13) / w`` apart: 9e-7 for ``w = 1``, 9e-10 for ``w = 1e3``, both in the
    first window of the search), and nothing else happens in the half period."""
    amplitude, delta = 1.0, 1e-13
    # a soft spring: inside the contact the motion is the free one to ~k delta, far below the tolerances
    sol = simulate_mechanical(_mass(w, amplitude - delta, law="spring", stiffness=1e-6), math.pi / w,
                              [0.0], [amplitude * w])
    ev = sol.events
    assert list(ev.kind) == ["contact_start", "contact_end"]
    t1, t2 = _roots(w, amplitude, delta)
    # the guard's slope at a root is w sqrt(2 delta); its rounding ~1e-16 moves the root by ~2e-16 / slope
    tol = 1e-15 / (w * math.sqrt(2 * delta))
    assert ev.t[0] == pytest.approx(t1, abs=tol)
    assert ev.t[1] == pytest.approx(t2, abs=tol)
    assert ev.t[1] - ev.t[0] == pytest.approx(t2 - t1, rel=1e-3)


@pytest.mark.parametrize("w", [1.0, 1e3])
def test_a_rigid_stop_grazed_by_1e_13_is_hit(w):
    """The same grazing on a rigid stop: the impact is found at the first root (whatever the rule
    makes of so slow a rebound afterwards), and a stop 1e-13 beyond the extreme is never hit."""
    amplitude, delta = 1.0, 1e-13
    hit = simulate_mechanical(_mass(w, amplitude - delta, law="rigid", restitution=1.0), math.pi / w,
                              [0.0], [amplitude * w])
    assert hit.events["kind"][0] == "impact"
    assert hit.events["t"][0] == pytest.approx(_roots(w, amplitude, delta)[0],
                                               abs=1e-15 / (w * math.sqrt(2 * delta)))
    miss = simulate_mechanical(_mass(w, amplitude + delta, law="rigid", restitution=1.0), math.pi / w,
                               [0.0], [amplitude * w])
    assert len(miss.events) == 0
    q, _ = miss.sample([math.pi / (2 * w)])
    assert amplitude + delta - q[0, 0] == pytest.approx(delta, rel=0.05)  # it did come within 1e-13


def test_two_stops_crossed_1e_9_apart_are_both_hit_in_order():
    """Two uncoupled masses, each against its own stop, crossing 1e-9 apart in one window: both
    impacts, in order, once each, at their closed-form times."""
    w = 1.0
    t_first = math.pi / 6
    gaps = [math.sin(t_first), math.sin(t_first + 1e-9)]
    system = MechanicalSystem(M=np.eye(2), K=np.eye(2),
                              contacts=[Contact([1.0, 0.0], gaps[0], law="rigid", restitution=0.5),
                                        Contact([0.0, 1.0], gaps[1], law="rigid", restitution=0.5)])
    sol = simulate_mechanical(system, 1.0, [0.0, 0.0], [w, w])
    ev = sol.events
    assert list(ev.kind) == ["impact", "impact"]
    assert list(ev["index"]) == [0, 1]
    np.testing.assert_allclose(ev.t, [t_first, t_first + 1e-9], rtol=0, atol=1e-14)
