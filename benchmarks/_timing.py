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
