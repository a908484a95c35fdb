"""Runs of one system in several threads: each takes its own compiled integrator, none waits on another's run."""

import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols
from impactosc.backends._hybrid_heyoka import DEFAULT_COOLDOWN, DEFAULT_TOL, checked_out

x, v, g, e = symbols("x v g e")


def ball(restitution=0.8):
    return HybridSystem("x v", {"g": 9.81, "e": restitution}, [HybridMode("flight", {x: v, v: -g})],
                        [Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})],
                        name="threaded ball")


def test_a_run_does_not_wait_for_another_thread_holding_the_compiled_integrator():
    """One compiled integrator per structure with a lock made a thread's run wait for any other
    thread's whole run (the deleted piece loop compiled per thread); now a second instance is
    built from heyoka's JIT cache. Thread A holds an instance until B's run has finished: with the lock, B's
    run would block until A lets go, and the join below would time out."""
    system = ball()
    impactosc.simulate(system, 1.0, [1.0, 0.0])  # compiled (and given back) here
    done = threading.Event()
    holding = threading.Event()
    out = {}

    def hold():
        with checked_out(system, DEFAULT_TOL, DEFAULT_COOLDOWN):
            holding.set()
            done.wait(timeout=120)

    def run():
        out["sol"] = impactosc.simulate(system, 30.0, [1.0, 0.0])
        done.set()

    a = threading.Thread(target=hold)
    a.start()
    assert holding.wait(timeout=60)
    b = threading.Thread(target=run)
    b.start()
    b.join(timeout=60)
    finished = not b.is_alive()
    done.set()
    a.join(timeout=60)
    assert finished, "the run waited for the other thread's compiled integrator"
    assert out["sol"].status == 2  # the ball's Zeno accumulation, as alone


def test_runs_in_threads_give_the_results_of_the_same_runs_one_after_another():
    system = ball(0.7)
    starts = [[h, 0.0] for h in np.linspace(0.5, 2.0, 8)]
    alone = [impactosc.simulate(system, 20.0, s) for s in starts]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda s: impactosc.simulate(system, 20.0, s), starts))
    for a, b in zip(alone, threaded, strict=True):
        assert (a.status, len(a.events)) == (b.status, len(b.events))
        # the same compiled code from the same start: the same numbers (one machine, one process)
        np.testing.assert_allclose(b.event_times("impact"), a.event_times("impact"), rtol=0, atol=1e-14)
        assert b.accumulation_time == pytest.approx(a.accumulation_time, abs=1e-14)
