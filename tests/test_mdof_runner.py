"""The exact n-DOF backend keeps a system's mode table between runs: runs of one system, serial or in
threads, and of a fresh copy, give the same events."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from mdof_systems import initial_state, random_system

from impactosc import simulate_mechanical


def _same(a, b) -> bool:
    # one process, one machine, the same code: the runs are the same computation, to the last bit
    return (len(a.events) == len(b.events) and np.array_equal(a.events.t, b.events.t)
            and np.array_equal(a.events.q, b.events.q) and list(a.events.kind) == list(b.events.kind))


def test_runs_of_one_system_in_threads_equal_a_serial_run():
    """Four threads run the same system (sharing its table) and a fresh copy of it (building its
    modes at once): every run equals the serial run of a third copy."""
    make = lambda: random_system(7, 4, laws=("spring", "rigid"), friction=1, contacts=3)  # noqa: E731
    q0, v0 = initial_state(7, 4)
    reference = simulate_mechanical(make(), 30.0, q0, v0)
    assert reference.status == 0 and len(reference.events) > 10
    shared, fresh = make(), make()
    simulate_mechanical(shared, 30.0, q0, v0)  # its table built once
    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(lambda s: simulate_mechanical(s, 30.0, q0, v0), [shared] * 4 + [fresh] * 4))
    assert all(_same(run, reference) for run in runs)
    q, v = runs[0].sample([5.0, 20.0])
    q_ref, v_ref = reference.sample([5.0, 20.0])
    np.testing.assert_array_equal(q, q_ref)
    np.testing.assert_array_equal(v, v_ref)
