"""A killed bifurcation_diagram leaves no worker behind (they stayed 14 minutes before the shared runner)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
       "LOKY_MAX_CPU_COUNT": "2"}
# Two continuation passes (two tasks: they go to the pool), each far longer than the test waits.
LONG = textwrap.dedent("""\
    import impactosc as io
    from impactosc import dynamics as dy
    osc = io.Oscillator(0.3, 0.8, 0.05, 1e4)
    dy.bifurcation_diagram(osc, "F", [0.2 + 0.01 * i for i in range(40)], continuation="both",
                           transient_periods=20000, record_periods=5, progress=False)
    print("returned", flush=True)
""")


def _children(pid: int) -> set[int]:
    parent_of = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            fields = stat[stat.rindex(")") + 2:].split()
            if fields[0] != "Z":
                parent_of[int(entry.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {c for c, p in parent_of.items() if p in frontier} - found
        found |= frontier
    return found


def _alive(pids) -> set[int]:
    out = set()
    for p in pids:
        try:
            stat = Path(f"/proc/{p}/stat").read_text()
        except OSError:
            continue
        if stat[stat.rindex(")") + 2] != "Z":
            out.add(p)
    return out


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds worker processes via /proc")
def test_workers_of_a_killed_bifurcation_diagram_exit():
    proc = subprocess.Popen([sys.executable, "-c", LONG], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=ENV, cwd=ROOT)
    workers: set[int] = set()
    deadline = time.monotonic() + 120
    while len(workers) < 2 and proc.poll() is None and time.monotonic() < deadline:
        workers |= _children(proc.pid)
        time.sleep(0.1)
    time.sleep(2.0)  # the workers are busy with the passes
    workers |= _children(proc.pid)
    assert proc.poll() is None and workers, proc.stderr.read() if proc.poll() is not None else "no worker found"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    deadline = time.monotonic() + 10  # each worker checks on its parent every 0.5 s
    while _alive(workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = _alive(workers)
    for p in left:  # leave nothing running on the machine, whatever the outcome
        os.kill(p, signal.SIGKILL)
    assert not left, f"{len(left)} of {len(workers)} worker processes outlived their killed parent"


@pytest.mark.slow
def test_no_loky_teardown_noise_after_the_pool_served_a_test_session():
    """The pool is let go at exit, not collected during the interpreter's teardown.

    Collected then, loky's weak-reference callback found ``multiprocessing.util`` half gone and
    printed "Exception ignored in ... weakref_cb" after the last test (exit code 0, but on every
    run of these two files together, and at the end of ``make test``).
    """
    root = Path(__file__).resolve().parent.parent
    env = dict(os.environ, PYTHONPATH=str(root))
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "tests/test_sweep_store.py", "tests/test_sweep.py", "-k", "pool or store"],
                         cwd=root, env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-2000:]
    assert "Exception ignored" not in out.stderr + out.stdout, out.stderr[-2000:]
