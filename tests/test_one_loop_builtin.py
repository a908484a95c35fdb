"""Issue 27 item 4: the built-in family's heyoka simulation on the one hybrid event loop.

``run_on_hybrid_loop(osc, ...)`` runs a member that ``oscillator_system`` writes on the user
systems' heyoka loop and replays it into the built-in ``Solution``
(``impactosc/backends/heyoka/_replay.py``); ``simulate(osc, backend="heyoka")`` runs every member
there. Checked against the closed-form ``exact`` backend first, then against the user system's own
run (the same loop: the same numbers to rounding, where the old piece loop, now deleted, differed
by ~6e-13 over the contact case).
"""

from __future__ import annotations

import numpy as np
import pytest

import impactosc
from impactosc.backends.heyoka._replay import INTEGRAL_SCALE, run_on_hybrid_loop
from impactosc.model.hybrid import oscillator_system

CONTACT = impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
MEMBERS = {
    "contact": CONTACT,
    "static friction, damping": impactosc.Oscillator(F=0.3, Omega=0.7, beta=0.1, beta_static=0.2, K=1e3, zeta=0.05),
    "harmonic, one flange": impactosc.Oscillator(F=0.4, Omega=0.9, beta=0.02, K=1e3, harmonics=[(0.1, 2.2, 0.3)],
                                                 gap_upper=1.2, gap_lower=None),
}


def hybrid(osc, t_end, x0, v0, *, record="full", max_events=10**6, sample_at=()):
    return run_on_hybrid_loop(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=sample_at,
                              tol=2.0**-52)


def test_every_member_runs_on_the_hybrid_loop_by_default(monkeypatch):
    """One loop: ``simulate(osc, backend="heyoka")`` is ``run_on_hybrid_loop`` for every member, rigid and
    incommensurate harmonics included (they had reasons to stay on the old piece loop)."""
    seen: list = []

    def spy(osc, *a, **k):
        seen.append(osc)
        return run_on_hybrid_loop(osc, *a, **k)

    monkeypatch.setattr("impactosc.backends.heyoka.run_on_hybrid_loop", spy)
    members = [CONTACT, MEMBERS["static friction, damping"], CONTACT.replace(flange="rigid"),
               MEMBERS["harmonic, one flange"], CONTACT.replace(harmonics=[(0.1, 3.3, 0.2)])]
    for osc in members:
        sol = impactosc.simulate(osc, 20.0, 0.95, 0.0)
        assert sol.status == 0, sol.message
    assert seen == members


@pytest.mark.parametrize("case", list(MEMBERS))
def test_builtin_heyoka_agrees_with_the_closed_forms(case):
    osc = MEMBERS[case]
    times = np.linspace(0.0, 200.0, 41)
    ref = impactosc.simulate(osc, 200.0, 0.95, 0.0, backend="exact", sample_at=times)
    sol = hybrid(osc, 200.0, 0.95, 0.0, sample_at=times)
    assert sol.status == 0 and sol.message == ref.message
    assert sol.counts == ref.counts
    assert list(sol.events.kind) == list(ref.events.kind)
    assert list(sol.events.side) == list(ref.events.side)
    assert list(sol.events.direction) == list(ref.events.direction)
    np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-10)
    np.testing.assert_allclose(sol.samples.x, ref.samples.x, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(sol.samples.motion, ref.samples.motion)
    assert sol.flange_impulse() == pytest.approx(ref.flange_impulse(), rel=1e-9, abs=1e-12)
    assert sol.forcing_work == pytest.approx(ref.forcing_work, rel=1e-9, abs=1e-12)
    assert sol.damping_work == pytest.approx(ref.damping_work, rel=1e-9, abs=1e-12)
    assert sol.friction_work == pytest.approx(ref.friction_work, rel=1e-9)
    if sol.contact_entries():
        assert sol.rms_flange_force() == pytest.approx(ref.rms_flange_force(), rel=1e-9)
        np.testing.assert_allclose(sol.impacts.impulse, ref.impacts.impulse, rtol=1e-8, atol=1e-12)
    # dense output between the events
    xs, _ = sol.sample(times[:-1] + 0.37)
    xr, _ = ref.sample(times[:-1] + 0.37)
    np.testing.assert_allclose(xs, xr, rtol=0, atol=1e-9)


def test_builtin_heyoka_is_the_user_systems_run():
    """The same loop: the event times of the user system with the same integrals, to rounding."""
    sol = hybrid(CONTACT, 400.0, 0.95, 0.0)
    own = impactosc.simulate(oscillator_system(CONTACT, energy=True, integral_scale=INTEGRAL_SCALE), 400.0,
                             [0.95, 0.0])
    assert len(sol.events) == 328
    np.testing.assert_allclose(sol.events.t, own.event_times(), rtol=0, atol=1e-14)
    assert sol.flange_impulse() == pytest.approx(own.integrals["Q"] / INTEGRAL_SCALE, rel=1e-14)
    assert sol.forcing_work == pytest.approx(own.integrals["W"] / INTEGRAL_SCALE, rel=1e-14)


def test_large_integrals_do_not_loosen_the_control_of_the_motion():
    """heyoka's error is relative to the largest state: unscaled, Q2 ~ 1e3 by t = 50 moved event times by 0.16
    at tol = 1e-2 (scaled by INTEGRAL_SCALE they stay within the tolerance of the closed forms)."""
    ref = impactosc.simulate(CONTACT, 50.0, 0.95, 0.0, backend="exact")
    sol = run_on_hybrid_loop(CONTACT, 50.0, 0.95, 0.0, record="full", max_events=10**6, tol=1e-2)
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-2)
    assert sol.flange_impulse() == pytest.approx(ref.flange_impulse(), rel=1e-2)


@pytest.mark.parametrize("record", ["events", "stats"])
def test_record_modes_keep_the_same_statistics(record):
    full = hybrid(CONTACT, 100.0, 0.95, 0.0)
    less = hybrid(CONTACT, 100.0, 0.95, 0.0, record=record)
    assert less.counts == full.counts
    assert less.flange_impulse() == full.flange_impulse()
    assert less.max_penetration() == full.max_penetration()


def test_event_limit_ends_with_status_1_after_that_event():
    sol = hybrid(CONTACT, 400.0, 0.95, 0.0, max_events=10)
    assert sol.status == 1 and len(sol.events) == 10
    assert "max_events=10" in sol.message
    assert sol.t_final == sol.events.t[-1]
