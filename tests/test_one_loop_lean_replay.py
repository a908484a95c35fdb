"""Issue 27 item 4: the hybrid run replayed into the built-in recorder in one bulk call.

``backends/heyoka/_replay._replay`` turns the run's crossings into arrays and hands them to
``results._bulk.bulk``; ``_replay_each`` feeds the same run one ``piece``/``event``/``segment``
call at a time, as the engine's driver does. Every record, count, integral and contact sum
must be the same to the last bit (both add in the same order), whatever the run: contacts
on both flanges, a run that starts inside a flange, one that ends inside a contact or at
the event limit, stick phases, each recording mode.
"""

from __future__ import annotations

import numpy as np
import pytest

import impactosc
from impactosc.backends._hybrid_heyoka import run_system
from impactosc.backends.heyoka import _replay as replay
from impactosc.engine._driver import initial_mode
from impactosc.results._bulk import bulk
from impactosc.results._solution import Solution, _Recorder

CONTACT = impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
DAMPED = impactosc.Oscillator(F=0.3, Omega=0.7, beta=0.1, beta_static=0.2, K=1e3, zeta=0.05)
ONE_FLANGE = impactosc.Oscillator(F=0.4, Omega=0.9, beta=0.02, K=1e3, harmonics=[(0.1, 2.2, 0.3)], gap_upper=1.2,
                                  gap_lower=None)
STICKY = impactosc.Oscillator(F=0.3, Omega=0.5, beta=0.25, K=50.0)

CASES = {
    "contact": (CONTACT, 120.0, 0.95, 0.0, 10**6),
    "starts inside the upper flange": (CONTACT, 60.0, 1.003, 0.5, 10**6),
    "starts inside the lower flange, stuck": (STICKY, 60.0, -1.02, 0.0, 10**6),
    "ends inside a contact": (CONTACT, 5.28, 0.95, 0.0, 10**6),
    "event limit": (CONTACT, 120.0, 0.95, 0.0, 37),
    "damped, static friction": (DAMPED, 150.0, 0.95, 0.0, 10**6),
    "one flange, two harmonics": (ONE_FLANGE, 150.0, 0.95, 0.0, 10**6),
    "stick phases": (STICKY, 150.0, 0.2, 0.0, 10**6),
    # no event at all, inside a flange from the start to the end (the bulk fill indexed the empty events)
    "held inside a flange, no event": (impactosc.Oscillator(F=1.5, Omega=0.2, beta=1.2, K=100.0), 1.0, 1.01, 0.0,
                                       10**6),
}


def _both(osc, t_end, x0, v0, max_events, record):
    system, modes, index, guards, slots = replay._system(osc)
    start = initial_mode(osc, 0.0, x0, v0)
    name = system.mode_names[index[(start.region, start.motion)]]
    hybrid = run_system(system, t_end, [x0, v0], mode=name, max_events=max_events)
    out = []
    for feed in (replay._replay, replay._replay_each):
        rec = _Recorder(record, "heyoka", None)
        feed(osc, hybrid, rec, modes, guards, slots, start, max_events, t_end)
        out.append(Solution(rec, t_end))
    return out


def _same_table(a, b):
    assert a.dtype == b.dtype
    assert len(a) == len(b)
    for field in a.dtype.names:
        np.testing.assert_array_equal(a[field], b[field], err_msg=field)


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("record", ["full", "events", "stats"])
def test_bulk_replay_is_the_replay_call_by_call(case, record):
    osc, t_end, x0, v0, max_events = CASES[case]
    bulk, each = _both(osc, t_end, x0, v0, max_events, record)
    for name in ("status", "message", "t_final", "x_final", "v_final", "final_mode", "counts", "n_pieces",
                 "forcing_work", "friction_work", "damping_work", "impact_loss", "_entries", "_impulse",
                 "_impulse_sq", "_contact_time", "_max_pen", "_contact_sums"):
        assert getattr(bulk, name) == getattr(each, name), name
    if record != "stats":
        _same_table(bulk.events, each.events)
        _same_table(bulk.impacts, each.impacts)
        np.testing.assert_array_equal(bulk._dissipated, each._dissipated)
    if record == "full":
        _same_table(bulk._segments, each._segments)


def test_the_cases_cover_what_the_bulk_path_handles():
    """Contacts open at the start and at the end, both flanges, sticks and releases, the event limit."""
    seen = {}
    for case, (osc, t_end, x0, v0, max_events) in CASES.items():
        bulk, _ = _both(osc, t_end, x0, v0, max_events, "events")
        seen[case] = bulk
    assert not seen["starts inside the upper flange"].impacts.complete[0]
    assert not seen["starts inside the lower flange, stuck"].impacts.complete[0]
    assert not seen["ends inside a contact"].impacts.complete[-1]
    assert seen["event limit"].status == 1
    assert seen["contact"].contact_entries(1) and seen["contact"].contact_entries(-1)
    assert seen["stick phases"].counts["stick"] and seen["stick phases"].counts["release"]
    assert seen["damped, static friction"].damping_work > 0.0


def test_bulk_refuses_a_rigid_flange():
    osc = impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, flange="rigid", restitution=0.8)
    rec = _Recorder("full", "heyoka", None)
    rec.begin(osc, 0.0, 0.0, 0.0, initial_mode(osc, 0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="rigid"):
        bulk(rec, *[np.zeros(0)] * 5)
