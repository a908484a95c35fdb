"""Power-law flanges (``K d^p``) on the one hybrid heyoka loop, replayed into the built-in ``Solution``.

``run_on_hybrid_loop`` is called directly, so these hold whichever loop the heyoka backend
routes a power-law member to. Checked against closed forms (a frictionless, unforced contact:
its duration from the energy integral, its exit speed equal to its entry speed) and against
scipy's DOP853 at ``rtol = atol = 1e-13``, the independent cross-check: event kinds and counts
equal, event times within 1e-9 (scipy's own error over these runs is ~1e-11; the loop's boundary
layer leaves out a force below the unit roundoff, ``layer_thickness``), the final state, the
mean and rms flange force and the energy identity. Each new structure of system (damping, one
flange) compiles a heyoka integrator of ~20 events once per process (~20 s): the tests are slow.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import beta as beta_function

import impactosc
from impactosc.backends.heyoka._replay import run_on_hybrid_loop
from impactosc.model.hybrid import oscillator_system
from impactosc.model.hybrid._oscillator_system import layer_thickness

pytestmark = pytest.mark.slow

TOL = 2.0**-52


def hybrid(osc, t_end, x0, v0, record="events"):
    return run_on_hybrid_loop(osc, t_end, x0, v0, record=record, max_events=10**6, tol=TOL)


def scipy_run(osc, t_end, x0, v0):
    return impactosc.simulate(osc, t_end, x0, v0, backend="scipy", rtol=1e-13, atol=1e-13)


def assert_agree(sol, ref, times=1e-9):
    """Event by event, the final state, the flange forces and the energy identity."""
    assert sol.status == 0, sol.message
    e, r = sol.events, ref.events
    assert len(e) == len(r)
    assert list(e["kind"]) == list(r["kind"])
    assert np.array_equal(e["side"], r["side"])
    if len(e):
        assert np.max(np.abs(e["t"] - r["t"])) < times
        assert np.max(np.abs(e["x"] - r["x"])) < 10 * times
        assert np.max(np.abs(e["v"] - r["v"])) < 10 * times
    assert sol.x_final == pytest.approx(ref.x_final, abs=10 * times)
    assert sol.v_final == pytest.approx(ref.v_final, abs=10 * times)
    assert sol.mean_flange_force() == pytest.approx(ref.mean_flange_force(), rel=1e-9, abs=1e-12)
    assert sol.rms_flange_force() == pytest.approx(ref.rms_flange_force(), rel=1e-9, abs=1e-12)
    balance = sol.energy_balance()
    assert abs(balance["residual"]) < 1e-10 * (1.0 + balance["scale"])


# -- closed forms -------------------------------------------------------------------------------
def hertz_contact_time(K, p, speed, tape_spring=True):
    """The duration of a contact entered at ``speed`` by an unforced, frictionless mass (``X'' = -X - K d^p``).

    Energy: ``V^2 + X^2 + 2 K d^(p+1) / (p+1) = speed^2 + 1`` (``X = 1 + d``), so
    ``T = 2 int_0^dmax dd / sqrt(R(d))`` with ``R(d) = speed^2 + 1 - (1 + d)^2 - 2 K d^(p+1) / (p+1)``,
    and ``R(dmax) = 0``. With ``d = dmax - s^2`` the root is removed:
    ``R = s^2 (2 + 2 dmax - s^2) + 2 K dmax^(p+1) / (p+1) (1 - (1 - s^2 / dmax)^(p+1))``, the last factor
    as ``-expm1((p+1) log1p(-s^2 / dmax))`` (no cancellation near the turn). ``tape_spring=False``
    drops the ``X`` term (a pure Hertz contact): ``R = speed^2 - 2 K d^(p+1) / (p+1)``.
    """
    c = 2.0 * K / (p + 1.0)
    lin = 1.0 if tape_spring else 0.0
    dmax = brentq(lambda d: speed**2 - lin * (2.0 * d + d * d) - c * d ** (p + 1.0), 0.0, 10.0,
                  xtol=1e-300, rtol=4.0 * 2.0**-52)

    def integrand(s):
        u = s * s / dmax
        power = p + 1.0 if u == 0.0 else -math.expm1((p + 1.0) * math.log1p(-u)) / u
        ratio = lin * (2.0 + 2.0 * dmax - s * s) + c * dmax**p * power  # R / s^2
        return 2.0 / math.sqrt(ratio)

    value, err = quad(integrand, 0.0, math.sqrt(dmax), epsabs=1e-15, epsrel=1e-13, limit=200)
    assert err < 1e-12
    return 2.0 * value


@pytest.mark.parametrize("p", [1.5, 2.0, 3.0])
def test_the_quadrature_is_the_beta_function_closed_form_of_a_pure_hertz_contact(p):
    """``T = 2 dmax / v * B(1/(p+1), 1/2) / (p+1)`` with ``dmax = ((p+1) v^2 / (2K))^(1/(p+1))``:
    ``int_0^dmax dd / sqrt(v^2 - 2K d^(p+1)/(p+1)) = (dmax / v) int_0^1 du / sqrt(1 - u^(p+1))``, and
    ``w = u^(p+1)`` makes the last integral ``B(1/(p+1), 1/2) / (p+1)``."""
    K, v = 1e4, 0.7
    dmax = ((p + 1.0) * v * v / (2.0 * K)) ** (1.0 / (p + 1.0))
    closed = 2.0 * dmax / v * beta_function(1.0 / (p + 1.0), 0.5) / (p + 1.0)
    assert hertz_contact_time(K, p, v, tape_spring=False) == pytest.approx(closed, rel=1e-13)


@pytest.mark.parametrize("p", [1.5, 2.0, 3.0])
@pytest.mark.parametrize("K", [1e2, 1e4, 1e6])
def test_an_unforced_contact_lasts_its_closed_form_and_leaves_at_its_entry_speed(p, K):
    """A free mass (F = 0, no friction) released at X = 0 with V = 1.5: ``X = 1.5 sin t`` meets the
    flange at ``asin(2/3)`` with speed ``sqrt(1.25)``, stays ``hertz_contact_time`` and leaves at that speed."""
    osc = impactosc.Oscillator(0.0, 1.0, 0.0, K, exponent=p)
    sol = hybrid(osc, 3.0, 0.0, 1.5)
    assert sol.status == 0, sol.message
    kinds = list(sol.events["kind"][:3])
    assert kinds == ["contact_start", "reversal", "contact_end"]
    start, _, end = sol.events[:3]
    speed = math.sqrt(1.5**2 - 1.0)
    assert start["t"] == pytest.approx(math.asin(1.0 / 1.5), abs=1e-13)
    assert start["v"] == pytest.approx(speed, abs=1e-12)
    assert end["t"] - start["t"] == pytest.approx(hertz_contact_time(K, p, speed), abs=1e-10)
    assert end["v"] == pytest.approx(-speed, abs=1e-10)
    assert end["x"] == 1.0 and start["x"] == 1.0  # recorded on the flange's surface, as the engine does


# -- against scipy ------------------------------------------------------------------------------
@pytest.mark.parametrize("p", [1.5, 2.0, 3.0])
def test_the_hertz_contact_case_agrees_with_scipy(p):
    """The contact case with Hertz-like flanges (``K = 1e4``), event by event for 40 time units.

    Longer, the orbit amplifies rounding (with ``p = 3`` the piece loop, scipy and this loop drift apart
    to 5e-9..3e-8 by t = 100, each pair growing from 1e-13 at the first events)."""
    osc = impactosc.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=p)
    sol = hybrid(osc, 40.0, 0.95, 0.0)
    assert len(sol.events) > 30
    assert_agree(sol, scipy_run(osc, 40.0, 0.95, 0.0))


@pytest.mark.parametrize("p", [1.5, 2.0, 3.0])
def test_off_centre_gaps_damping_and_a_stick_on_a_flange_agree_with_scipy(p):
    """Soft flanges at +0.8 and -1.3, damping and friction strong enough to stick inside a flange."""
    osc = impactosc.Oscillator(1.5, 0.2, 0.3, 2.0, exponent=p, gap_upper=0.8, gap_lower=1.3, zeta=0.02)
    sol = hybrid(osc, 60.0, 0.1, 0.0)
    ev = sol.events
    inside = (ev["x"] > 0.8) | (ev["x"] < -1.3)
    assert np.any((ev["kind"] == "stick") & inside), "the case must stick inside a flange"
    assert np.any((ev["kind"] == "release") & inside)
    assert_agree(sol, scipy_run(osc, 60.0, 0.1, 0.0))


def test_one_flange_agrees_with_scipy():
    """An upper flange only (gap_lower = inf), started inside it moving in and deeper than its layer."""
    osc = impactosc.Oscillator(0.8, 0.9, 0.05, 300.0, exponent=2.5, gap_lower=math.inf)
    for x0, v0 in ((1.02, 0.3), (1.0, 0.4), (-2.0, 0.0)):
        assert_agree(hybrid(osc, 40.0, x0, v0), scipy_run(osc, 40.0, x0, v0))


def test_dense_output_inside_a_contact_agrees_with_scipy():
    """``Solution.sample`` inside contacts: each built-in piece spans the layer's edge (its hybrid run's
    internal event), so its dense output goes through the layer as the run did."""
    osc = impactosc.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5)
    sol = hybrid(osc, 20.0, 0.95, 0.0, record="full")
    ref = scipy_run(osc, 20.0, 0.95, 0.0)
    ev = sol.events
    starts = ev["t"][ev["kind"] == "contact_start"]
    ends = ev["t"][ev["kind"] == "contact_end"]
    times = np.concatenate([np.linspace(a, b, 7)[1:-1] for a, b in zip(starts, ends, strict=False)])
    x, v = sol.sample(times)
    x_ref, v_ref = ref.sample(times)
    assert np.all(np.abs(x) > 1.0)  # inside a flange
    assert np.max(np.abs(x - x_ref)) < 1e-9
    assert np.max(np.abs(v - v_ref)) < 1e-8


def test_the_layer_edge_is_no_event_and_its_pieces_add_up():
    """The hybrid run has one internal event per contact (the layer's edge); the Solution records none, and
    its flange impulse (integrated across the edge) is the scipy run's."""
    osc = impactosc.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=2.0)
    system = oscillator_system(osc, energy=True)
    edges = [g for g in system.guard_names if g.endswith("layer in")]
    assert edges == ["upper layer in", "lower layer in"]
    run = impactosc.simulate(system, 20.0, [0.95, 0.0])
    internal = sum(e.guard in edges for e in run.events)
    sol = hybrid(osc, 20.0, 0.95, 0.0)
    contacts = int(np.sum(sol.events["kind"] == "contact_start"))
    assert internal == contacts > 0
    assert len(run.events) == len(sol.events) + internal
    assert sol.flange_impulse() == pytest.approx(scipy_run(osc, 20.0, 0.95, 0.0).flange_impulse(), rel=1e-10)


def test_the_layer_is_below_the_unit_roundoff_of_the_force():
    for K, p in ((1e4, 1.5), (1e2, 3.0), (1e6, 2.0)):
        delta = layer_thickness(impactosc.Oscillator(0.5, 1.1, 0.01, K, exponent=p))
        assert K * delta**p <= max(2.0**-53, K * (4.0 * 2.0**-52) ** p) * (1.0 + 1e-12)
        assert delta >= 4.0 * 2.0**-52


@pytest.mark.parametrize("K, v0", [(1e6, 30.0), (1e8, 5.0)])
def test_a_contact_entered_fast_crosses_its_layer_in_resolved_time(K, v0):
    """Entered at 30 with K = 1e6 at t = 0.1065, the layer (2.3e-15) was crossed in 8e-17, a few ulps of
    the time: the steps beyond it fell to the rounding of the time and the run crawled (for ever without
    max_wall_time; the loop now ends such a run with status -1). The layer is at least 64 eps |V| (1 + |t|)
    thick, crossed in 64 ulps of the time, and the run agrees with scipy."""
    osc = impactosc.Oscillator(0.5, 1.1, 0.01, K, exponent=1.5)
    sol = hybrid(osc, 5.0, 0.0, v0)
    assert sol.status == 0, sol.message
    assert sol.counts["contact_start"] >= 5
    assert_agree(sol, scipy_run(osc, 5.0, 0.0, v0))
