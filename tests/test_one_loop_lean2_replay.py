"""Issue 27 item 4 (lean, second round): the replay's arrays built without a Python pass per crossing.

``backends/heyoka/_replay._crossings`` finds the touches of a flange (entered, stopped in and
left at one instant) on the arrays and merges them with ``_crossings_without_touches`` only
when there is one. Its arrays must be those of the list path, touches or not (grazings among
the records are dropped before, as ``_replay`` does). The compiled bulk fill and its
plain-Python twin (the path without numba) must give the same ``Solution``.
"""

from __future__ import annotations

import numpy as np
import pytest

import impactosc
from impactosc.backends.heyoka import _replay as replay
from impactosc.engine._hybrid import CROSSING, GRAZING

CONTACT = impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


def _listed(raw, guards, width):
    """The arrays of the list path: the touches merged one crossing at a time, then read."""
    events = replay._crossings_without_touches(raw, guards)
    n = len(events)
    if not n:
        return np.zeros(0), np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros((0, width)), np.zeros((0, width))
    return (np.array([e[0] for e in events]), np.array([e[1] for e in events]), np.array([e[4] for e in events]),
            np.array([e[5] for e in events], dtype=float).reshape(n, width),
            np.array([e[6] for e in events], dtype=float).reshape(n, width))


def _raw(system, steps):
    """Records ``(t, guard, kind, mode before, mode after, state before, state after)`` from ``(t, guard name,
    kind)`` triples, with distinct states so that a merge that takes the wrong record shows."""
    out = []
    for k, (t, name, kind) in enumerate(steps):
        g = system.guard_names.index(name)
        before = (0.1 * k, -0.2 * k, 1e-3 * k, 0.0, 0.0)
        after = (0.1 * k + 0.05, 0.3 * k, 1e-3 * k, 0.0, 0.0)
        out.append((t, g, kind, k % 9, (k + 1) % 9, before, after))
    return out


TOUCH = [(1.0, "enter upper", CROSSING), (1.0, "upper+ stop", CROSSING), (1.0, "leave upper", CROSSING)]
CONTACT_RUN = [(0.5, "enter upper", CROSSING), (0.7, "upper+ stop", CROSSING), (0.9, "leave upper", CROSSING)]
CASES = {
    "no event": [],
    "one crossing": [(0.3, "free+ stop", CROSSING)],
    "a contact": CONTACT_RUN,
    "a touch alone": TOUCH,
    "a touch between contacts": CONTACT_RUN + [(t + 1.0, g, k) for t, g, k in TOUCH] + [
        (t + 3.0, g, k) for t, g, k in CONTACT_RUN],
    "two touches and a grazing": [(0.2, "free+ stop", GRAZING)] + TOUCH + [(2.0, "free- stop", CROSSING)] + [
        (3.0, "enter lower", CROSSING), (3.0, "lower- stop", CROSSING), (3.0, "leave lower", CROSSING)],
    # three records at one instant that are not entry, stop, exit: kept as they are
    "three at an instant, not a touch": [(1.0, "enter upper", CROSSING), (1.0, "leave upper", CROSSING),
                                         (1.0, "upper+ stop", CROSSING)],
}


@pytest.mark.parametrize("case", list(CASES))
def test_crossing_arrays_are_those_of_the_list_path(case):
    system, modes, _, guards, _ = replay._system(CONTACT)
    raw = _raw(system, CASES[case])
    crossings = [e for e in raw if e[2] == CROSSING]  # as _replay hands them over
    got = replay._crossings(crossings, guards, replay._kinds(modes, guards).kind, 5)
    want = _listed(raw, guards, 5)
    for a, b in zip(got, want, strict=True):
        assert a.shape == b.shape
        np.testing.assert_array_equal(a, b)


def test_a_touch_is_one_reversal_from_the_mode_before_the_entry_to_the_mode_after_the_exit():
    system, modes, _, guards, _ = replay._system(CONTACT)
    raw = _raw(system, TOUCH)
    t, guard, target, before, after = replay._crossings(raw, guards, replay._kinds(modes, guards).kind, 5)  # no grazing
    assert t.tolist() == [1.0]
    assert guard.tolist() == [system.guard_names.index("upper+ stop")]
    assert target.tolist() == [raw[2][4]]
    np.testing.assert_array_equal(before[0], raw[0][5])
    np.testing.assert_array_equal(after[0], raw[2][6])


# -- the compiled stream of a whole run and its plain-Python twin (the path without numba) --------------------------

STICKY = impactosc.Oscillator(F=0.3, Omega=0.5, beta=0.25, K=50.0)
RUNS = {
    "contact": (CONTACT, 120.0, 0.95, 0.0, 10**6),
    "starts inside the upper flange": (CONTACT, 60.0, 1.003, 0.5, 10**6),
    "starts inside the lower flange, stuck": (STICKY, 60.0, -1.02, 0.0, 10**6),
    "ends inside a contact": (CONTACT, 5.28, 0.95, 0.0, 10**6),
    "damped, static friction": (impactosc.Oscillator(F=0.3, Omega=0.7, beta=0.1, beta_static=0.2, K=1e3, zeta=0.05),
                                150.0, 0.95, 0.0, 10**6),
}


def _replayed(osc, t_end, x0, v0, max_events):
    from impactosc.backends._hybrid_heyoka import run_system
    from impactosc.engine._driver import initial_mode
    from impactosc.results._solution import Solution, _Recorder

    system, modes, index, guards, slots = replay._system(osc)
    start = initial_mode(osc, 0.0, x0, v0)
    hybrid = run_system(system, t_end, [x0, v0], mode=system.mode_names[index[(start.region, start.motion)]],
                        max_events=max_events)
    rec = _Recorder("full", "heyoka", None)
    replay._replay(osc, hybrid, rec, modes, guards, slots, start, max_events, t_end)
    return Solution(rec, t_end)


@pytest.mark.parametrize("case", list(RUNS))
def test_the_plain_python_stream_is_the_compiled_one(case, monkeypatch):
    from impactosc.results import _bulk

    compiled = _replayed(*RUNS[case])
    monkeypatch.setattr(_bulk, "HAVE_NUMBA", False)
    for name in ("_stream", "_close_contact"):  # as they run without numba: plain Python functions
        monkeypatch.setattr(_bulk, name, getattr(getattr(_bulk, name), "py_func", getattr(_bulk, name)))
    plain = _replayed(*RUNS[case])
    for name in ("counts", "forcing_work", "friction_work", "damping_work", "_entries", "_impulse", "_impulse_sq",
                 "_contact_time", "_max_pen", "_contact_sums"):
        assert getattr(plain, name) == getattr(compiled, name), name
    for table in ("events", "impacts", "_segments"):
        a, b = getattr(plain, table), getattr(compiled, table)
        assert a.dtype == b.dtype and len(a) == len(b), table
        for field in a.dtype.names:
            np.testing.assert_array_equal(a[field], b[field], err_msg=f"{table}.{field}")
    np.testing.assert_array_equal(plain._dissipated, compiled._dissipated)
