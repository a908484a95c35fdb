"""Issue 27 item 4: a frozen mode (every state's rate zero) of a periodic system is jumped over whole periods.

A mass stuck by dry friction under a harmonic force: its release guards are functions of the
time alone, periodic with the forcing period, so a period without an event means none ever
comes. Both hybrid loops (heyoka, scipy) jump to the last whole period before ``t_end``; on
main each stepped through the stuck phase (heyoka ~2 steps a period: ``t_end = 1e12`` would
take ~1e6 s; scipy's ``max_step`` of a 32nd of a period, longer still).

Closed forms: the stuck mass does not move, and an integral of ``(A cos w t)^2`` is
``A^2 (t / 2 + sin(2 w t) / (4 w))``.
"""

from __future__ import annotations

import math

import heyoka as hy
import numpy as np
import pytest

import impactosc
from impactosc import HybridSystem, stick_slip, symbols
from impactosc.engine._hybrid import frozen_modes

BACKENDS = ["heyoka", "scipy"]


def dry_friction(A: float, w: float, mu: float, drift: float = 0.0) -> HybridSystem:
    """``x'' + x + mu sgn(x') = A cos(w t) + drift t`` with ``I = int (A cos w t)^2 dt`` (period ``2 pi / w``)."""
    x, v, a, om, m, c = symbols("x v A w mu c")
    force = a * hy.cos(om * hy.time) + c * hy.time - x
    square = (a * hy.cos(om * hy.time)) ** 2
    modes, guards = stick_slip("m", v, force, m, rates={x: v}, integrands={"I": square},
                               stick_integrands={"I": square})
    return HybridSystem("x v", {"A": A, "w": w, "mu": mu, "c": drift}, modes, guards, integrals=["I"],
                        period=2.0 * math.pi / om, name="dry friction")


def square_integral(A: float, w: float, t: float) -> float:
    return A * A * (0.5 * t + math.sin(2.0 * w * t) / (4.0 * w))


def test_the_stick_mode_is_frozen_and_the_slip_modes_are_not():
    assert frozen_modes(dry_friction(0.1, 0.5, 0.5)) == (True, False, False)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_mass_stuck_for_ever_runs_to_1e12_with_exact_integrals(backend):
    A, w = 0.1, 0.5
    sol = impactosc.simulate(dry_friction(A, w, 0.5), 1e12, [0.0, 0.0], backend=backend)
    assert sol.status == 0 and sol.t_final == 1e12 and sol.mode_final == "m0"
    assert not sol.events
    assert sol.state_final[0] == 0.0 and sol.state_final[1] == 0.0
    # k ~ 1e11 periods times one period's increment (relative error that of the integrator: scipy's
    # rtol = 1e-12), and the forcing's phase at t = 1e12 known to ~eps w t ~ 1e-4 (a term A^2 / (4 w))
    assert sol.integrals["I"] == pytest.approx(square_integral(A, w, 1e12), rel=1e-11)
    # dense output deep inside the stuck phase, without stepping through it
    times = np.array([3.0, 7.77e9, 5e11 + 1.25])
    states = sol.sample(times)
    np.testing.assert_array_equal(states[:, :2], 0.0)
    expected = [square_integral(A, w, t) for t in times]
    np.testing.assert_allclose(states[:, 2], expected, rtol=1e-11)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_mass_that_slips_then_sticks_for_ever_agrees_with_a_short_run(backend):
    """Released from x = 1.4, it slides and sticks at its first stop (t ~ 3.2); then the jump."""
    system = dry_friction(0.1, 0.5, 0.5)
    short = impactosc.simulate(system, 200.0, [1.4, 0.0], backend=backend)
    long = impactosc.simulate(system, 1e10, [1.4, 0.0], backend=backend)
    assert short.status == long.status == 0 and long.t_final == 1e10
    assert short.mode_final == long.mode_final == "m0"
    assert [e.guard for e in long.events] == [e.guard for e in short.events]
    assert len(short.events) >= 1
    np.testing.assert_allclose(long.event_times(), short.event_times(), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(long.state_final[:2], short.state_final[:2])
    # the integral's growth after the last event is the closed form's
    t_stuck = short.events[-1].t
    grown = square_integral(0.1, 0.5, 1e10) - square_integral(0.1, 0.5, t_stuck)
    start = short.sample([t_stuck])[0, 2]
    assert long.integrals["I"] - start == pytest.approx(grown, rel=1e-11)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_guard_that_is_not_periodic_is_not_jumped_over(backend):
    """A declared period that the release guard does not keep (a drift c t): the release comes all the same.

    The mass sticks at rest until ``A cos(w t) + c t`` reaches ``mu``: with ``c = 1e-3`` first
    in the period around ``t = (mu - A) / c``; a blind jump would skip it.
    """
    A, w, mu, c = 0.1, 0.5, 0.5, 1e-3
    sol = impactosc.simulate(dry_friction(A, w, mu, drift=c), 500.0, [0.0, 0.0], backend=backend)
    assert sol.status == 0 and sol.events
    first = sol.events[0]
    assert first.guard == "m release+"
    # the first t with A cos(w t) + c t = mu, found by bisection on the closed form
    t_first = _first_rise(lambda t: A * math.cos(w * t) + c * t - mu, 0.0, 500.0)
    assert first.t == pytest.approx(t_first, abs=1e-6)


def _first_rise(h, lo: float, hi: float) -> float:
    """The first zero of ``h`` on a grid fine enough for one rise per cell, refined by bisection."""
    from scipy.optimize import brentq

    grid = np.linspace(lo, hi, 200_001)
    values = np.array([h(t) for t in grid])
    k = int(np.argmax((values[:-1] < 0.0) & (values[1:] >= 0.0)))
    return float(brentq(h, grid[k], grid[k + 1], xtol=1e-14))


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_frozen_mode_without_a_timed_guard_is_jumped_over_too(backend):
    """No guard of the frozen mode moves with the time (nothing recurs each period to watch): its
    integral ``int cos(w t)^2 dt`` still does, and heyoka would step through it; a tick of its own."""
    x, w = symbols("x w")
    hold = impactosc.HybridMode("hold", {x: 0.0}, integrands={"I": hy.cos(w * hy.time) ** 2})
    system = HybridSystem("x", {"w": 0.5}, [hold], [impactosc.Guard("far", x - 2.0, 1, armed="hold", to="hold")],
                          integrals=["I"], period=2.0 * math.pi / w, name="held")
    sol = impactosc.simulate(system, 1e12, [0.0], backend=backend)
    assert sol.status == 0 and sol.t_final == 1e12 and not sol.events
    assert sol.integrals["I"] == pytest.approx(square_integral(1.0, 0.5, 1e12), rel=1e-11)
