"""Solution: recording levels, windows, dense output, limits and errors."""

import math

import numpy as np
import pytest

import impactosc as io

CONTACT_CASE = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


@pytest.fixture(scope="module")
def full():
    return io.simulate(CONTACT_CASE, 400.0)


def test_recording_levels_agree_on_statistics(full):
    ev = io.simulate(CONTACT_CASE, 400.0, record="events")
    st = io.simulate(CONTACT_CASE, 400.0, record="stats")
    for s in (ev, st):
        assert s.counts == full.counts
        assert s.mean_flange_force(1) == full.mean_flange_force(1)
        assert s.rms_flange_force() == full.rms_flange_force()
        assert s.max_penetration(-1) == full.max_penetration(-1)
    np.testing.assert_array_equal(ev.events.t, full.events.t)
    with pytest.raises(ValueError, match="record='events'"):
        _ = st.events
    with pytest.raises(ValueError, match="record='events'"):
        _ = st.impacts
    with pytest.raises(ValueError, match="record='full'"):
        ev.sample(1.0)
    with pytest.raises(ValueError, match="record='full'"):
        ev.mean_flange_force(t0=10.0, t1=20.0)


def test_windows_add_up_to_the_whole_run(full):
    total = full.flange_impulse()
    cuts = [0.0, 37.3, 100.0, 100.01, 255.5, 400.0]
    parts = [full.flange_impulse(None, a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    assert sum(parts) == pytest.approx(total, rel=1e-12)
    assert full.mean_flange_force(t0=0.0, t1=400.0) == full.mean_flange_force()
    # A window inside one contact: compare with the impact's own impulse split.
    imp = full.impacts[3]
    mid = 0.5 * (imp.start + imp.end)
    a = full.flange_impulse(int(imp.side), imp.start, mid)
    b = full.flange_impulse(int(imp.side), mid, imp.end)
    assert a > 0 and b > 0 and a + b == pytest.approx(imp.impulse, rel=1e-11)


@pytest.mark.parametrize("t0, t1", [(-1.0, 10.0), (10.0, 500.0), (20.0, 10.0), (5.0, 5.0), (math.nan, 3.0)])
def test_window_outside_run_is_an_error(full, t0, t1):
    with pytest.raises(ValueError, match="window|t0"):
        full.mean_flange_force(t0=t0, t1=t1)


def test_bad_side(full):
    for bad in (0, 2, "upper", True):
        with pytest.raises(ValueError, match="side"):
            full.mean_flange_force(side=bad)


def test_sample_is_exact_at_events_and_continuous(full):
    ev = full.events
    x, v = full.sample(ev.t[:50])
    # At an event the recorded (snapped) state is returned; several events never share a time here.
    np.testing.assert_array_equal(x, ev.x[:50])
    np.testing.assert_array_equal(v, ev.v[:50])
    # Just around an event the dense output joins the event state continuously.
    t = ev.t[10]
    xs, _ = full.sample([t - 1e-9, t + 1e-9])
    assert np.all(np.abs(xs - ev.x[10]) < 1e-8)
    # Flange force from samples is zero exactly when |X| <= 1.
    ts = np.linspace(0, 400, 4001)
    xs, _ = full.sample(ts)
    f = full.flange_force(ts)
    assert np.all((f > 0) == (np.abs(xs) > 1))
    with pytest.raises(ValueError, match="sample times"):
        full.sample([-1.0])
    with pytest.raises(ValueError, match="sample times"):
        full.sample([401.0])
    x0, v0 = full.sample(0.0)
    assert (x0, v0) == (0.95, 0.0)


def test_event_limit_returns_status_and_keeps_results():
    sol = io.simulate(CONTACT_CASE, 400.0, max_events=10)
    assert sol.status == 1 and not sol.success
    assert "max_events=10" in sol.message
    assert len(sol.events) == 10 and sol.t_final == sol.events.t[-1]
    full_run = io.simulate(CONTACT_CASE, 400.0)
    np.testing.assert_array_equal(sol.events.t, full_run.events.t[:10])
    assert sol.mean_flange_force() > 0


def test_starting_inside_a_flange_and_stuck():
    sol = io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.01, K=100.0), 1.0, x0=1.02, v0=0.0)
    im = sol.impacts
    assert im.start[0] == 0.0 and not im.complete[0] and im.side[0] == 1
    assert sol.events.kind[0] in ("contact_end", "reversal")
    stuck = io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4), 50.0, x0=0.05, v0=0.0)
    assert sum(stuck.counts.values()) == 0 and stuck.x_final == 0.05 and stuck.v_final == 0.0


def test_tables_and_summary(full):
    assert "contact_start" in full.event_table(limit=5)
    assert "more events" in full.event_table(limit=5)
    assert "penetration" in full.impact_table(limit=3)
    assert "47 upper / 47 lower contacts" in full.summary()
    assert "heyoka" in repr(full)
