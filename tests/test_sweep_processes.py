"""The default sweep executor as real programs meet it: entry points, Ctrl-C, a killed parent.

Each test runs Python in a subprocess. The four entry points of issue #13 (standard input,
``python -c``, a script without a ``__main__`` guard, an interactive session fed on a pipe)
are started together by one fixture, so that their worker pools start in parallel.
"""

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
# One worker per pool (loky.cpu_count() reads LOKY_MAX_CPU_COUNT): what is tested here does
# not need more, and each worker imports numpy, xarray and heyoka.
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
       "LOKY_MAX_CPU_COUNT": "1"}

# A tiny sweep; it prints its statuses and how often the top level of the program ran.
TINY = textwrap.dedent("""\
    import impactosc as io
    print("top level ran", flush=True)
    ds = io.sweep(io.TapeDrive(), {"speed": [4.0, 8.0, 12.0]}, duration=1e-5, progress=False)
    print("statuses", ds["status"].values.tolist(), flush=True)
""")

ENTRY_POINTS = ["stdin", "dash-c", "script-without-guard", "interactive-pipe"]


def _start(kind: str, tmp: Path) -> subprocess.Popen:
    py = [sys.executable]
    if kind == "stdin":  # python - <<EOF ... EOF
        args, stdin = py + ["-"], TINY
    elif kind == "dash-c":
        args, stdin = py + ["-c", TINY], ""
    elif kind == "script-without-guard":
        script = tmp / "no_guard.py"
        script.write_text(TINY)
        args, stdin = py + [str(script)], ""
    else:  # a REPL: `python -i` reading its commands from a pipe; __main__ has no file
        args, stdin = py + ["-i", "-q"], TINY + "\n"
    proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=ENV, cwd=tmp)
    proc.stdin.write(stdin)
    proc.stdin.close()
    return proc


@pytest.fixture(scope="module")
def entry_point_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("entry")
    procs = {kind: _start(kind, tmp) for kind in ENTRY_POINTS}
    out = {}
    for kind, proc in procs.items():
        try:
            proc.wait(timeout=300)
        except subprocess.TimeoutExpired:
            proc.kill()
        out[kind] = (proc.returncode, proc.stdout.read(), proc.stderr.read())
    return out


@pytest.mark.parametrize("kind", ENTRY_POINTS)
def test_the_default_executor_works_from_every_entry_point(entry_point_runs, kind):
    rc, out, err = entry_point_runs[kind]
    assert rc == 0, err
    assert "statuses [0, 0, 0]" in out, out + err  # no point lost: the workers never ran the caller's code
    assert out.count("top level ran") == 1
    assert "Warning" not in err and "Traceback" not in err, err


# A point function that makes a multiprocessing lock in the worker, as tqdm does for its write
# lock: in a loky worker that is a named semaphore, registered with a resource tracker until
# the worker's finalizers unregister it. Killing the idle workers at the interpreter's exit
# skipped them, and the tracker warned of "leaked semaphore objects": the warning that made
# the entry-point test fail under load.
HOLDER = textwrap.dedent("""\
    import multiprocessing
    from impactosc.runner import run_points
    _LOCKS = []
    def hold_a_lock(payload):
        _LOCKS.append(multiprocessing.RLock())
        return payload
    def main():
        out = []
        run_points(hold_a_lock, [(str(i), i) for i in range(4)], on_result=lambda k, r: out.append(r),
                   on_lost=lambda k, m: None, progress=False)
        print("results", sorted(out), flush=True)
""")


def test_the_workers_clean_up_what_they_made_when_the_program_ends(tmp_path):
    (tmp_path / "holder.py").write_text(HOLDER)
    env = {**ENV, "LOKY_MAX_CPU_COUNT": "2"}  # the pool runs the four points
    proc = subprocess.run([sys.executable, "-c", "import holder; holder.main()"], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "results [0, 1, 2, 3]" in proc.stdout
    assert "leaked" not in proc.stderr and "Warning" not in proc.stderr, proc.stderr


# -- interrupting ---------------------------------------------------------------------------
# Two cheap points first (the out-of-plane reading sticks at once: milliseconds), then two
# that take about a minute each: an interrupt or a kill lands while the long ones run.
LONG = textwrap.dedent("""\
    import sys
    import impactosc as io
    grid = {"bending": ["out-of-plane", "in-plane"], "speed": [4.0, 8.0]}
    io.sweep(io.TapeDrive(), grid, duration=60.0, store=sys.argv[1], progress=False)
    print("sweep returned", flush=True)
""")
LONG_POINT_S = 30  # far less than one long point takes: a sweep that waited for it would not stop in time

needs_proc = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds worker processes via /proc")


def _descendants(pid: int) -> set[int]:
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


def _stored(store: Path) -> list[Path]:
    points = store / "points"
    return [f for f in points.glob("*.nc") if not f.name.startswith(".")] if points.exists() else []


def _start_long(tmp: Path):
    store = tmp / "store"
    script = tmp / "long.py"
    script.write_text(LONG)
    proc = subprocess.Popen([sys.executable, str(script), str(store)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV, cwd=tmp)
    workers: set[int] = set()
    deadline = time.monotonic() + 120
    while len(_stored(store)) < 2 and proc.poll() is None and time.monotonic() < deadline:
        workers |= _descendants(proc.pid)
        time.sleep(0.05)
    workers |= _descendants(proc.pid)
    assert len(_stored(store)) == 2 and proc.poll() is None, "the cheap points did not arrive"
    return proc, store, workers


def _wait_gone(pids, limit: float) -> set[int]:
    deadline = time.monotonic() + limit
    while _alive(pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = _alive(pids)
    for p in left:  # leave nothing running on the machine, whatever the outcome
        os.kill(p, signal.SIGKILL)
    return left


@needs_proc
@pytest.mark.usefixtures("sigint_raises")  # Ctrl-C must raise, however pytest was started
def test_ctrl_c_stops_at_once_and_keeps_the_finished_points(tmp_path):
    proc, store, workers = _start_long(tmp_path)
    assert workers, "no worker processes found"
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=LONG_POINT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("the sweep did not stop after SIGINT: it waited for the points in flight")
    finally:
        left = _wait_gone(workers, 10)
    out, err = proc.communicate()
    assert proc.returncode != 0 and "KeyboardInterrupt" in err and "sweep returned" not in out
    assert len(_stored(store)) == 2  # the finished points are kept
    assert not left, "worker processes outlived the interrupted sweep"


@needs_proc
def test_workers_exit_when_their_parent_is_killed(tmp_path):
    proc, store, workers = _start_long(tmp_path)
    workers = _alive(workers)
    assert workers, "no worker processes found"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    proc.communicate()
    left = _wait_gone(workers, 10)  # each worker checks on its parent every 0.5 s
    assert not left, f"{len(left)} of {len(workers)} worker processes outlived their killed parent"
