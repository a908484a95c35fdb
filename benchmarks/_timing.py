"""Timing shared by the benchmark scripts: medians of repeats, with a per-call time limit."""

from __future__ import annotations

import os
import signal
import statistics
import time


class Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise Timeout


def timed(fn, repeats: int, budget: float, timeout: float):
    """Median wall time of up to ``repeats`` calls of ``fn`` (fewer when ``budget`` seconds are spent).

    A single call longer than ``timeout`` seconds raises :class:`Timeout` (SIGALRM; the
    backends loop in Python, so the alarm interrupts them)."""
    times, out = [], None
    use_alarm = timeout > 0 and hasattr(signal, "setitimer")
    old = signal.signal(signal.SIGALRM, _alarm) if use_alarm else None
    try:
        while len(times) < repeats:
            if use_alarm:
                signal.setitimer(signal.ITIMER_REAL, timeout)
            t0 = time.perf_counter()
            try:
                out = fn()
            finally:
                if use_alarm:
                    signal.setitimer(signal.ITIMER_REAL, 0)
            times.append(time.perf_counter() - t0)
            if sum(times) > budget:
                break
    finally:
        if use_alarm:
            signal.signal(signal.SIGALRM, old)
    timed.best = min(times)
    return statistics.median(times), len(times), out


def load_average() -> str:
    """The 1-, 5- and 15-minute load averages, for the tables ("n/a" where the system has none)."""
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def cold_compile(osc, tol: float = 2.0**-52) -> float:
    """Seconds to compile the heyoka integrator ``osc`` runs on, with heyoka's code caches bypassed.

    The integrator of the one hybrid loop (``oscillator_system(osc)`` as the built-in backend
    builds it, ``impactosc.backends._hybrid_heyoka.CompiledSystem``), built afresh: neither the
    backend's own cache nor heyoka's in-memory and on-disk caches of compiled code are used.
    """
    import heyoka as hy

    from impactosc.backends._hybrid_heyoka import DEFAULT_COOLDOWN, CompiledSystem
    from impactosc.backends.heyoka._replay import _system

    system = _system(osc)[0]
    disk = hy.llvm_state.get_diskcache_enabled()
    hy.llvm_state.set_diskcache_enabled(False)
    hy.llvm_state.clear_memcache()
    try:
        t0 = time.perf_counter()
        CompiledSystem(system, tol, DEFAULT_COOLDOWN)
        return time.perf_counter() - t0
    finally:
        hy.llvm_state.set_diskcache_enabled(disk)
