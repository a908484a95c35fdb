"""How fast a sweep stops: Ctrl-C (SIGINT) and SIGKILL of the parent.

Runs a stored sweep on the default process pool in a subprocess and

1. sends SIGINT once some points are stored, to the parent alone (``kill -INT``) and to its
   whole process group (what Ctrl-C in a terminal does); prints the time until the parent
   and every worker it started have exited, and how many points the store kept;
2. sends SIGKILL to the parent while its workers compute; prints the time until every
   worker has exited.

Linux only (worker processes are found through /proc). No assertions: a table of numbers.

    python benchmarks/sweep_interrupt.py [--points 16] [--duration 0.5] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

DRIVER = textwrap.dedent("""
    import sys
    import impactosc as io
    store, n, duration = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    speeds = [4.0 + 0.25 * i for i in range(n)]
    io.sweep(io.TapeDrive(), {"speed": speeds}, duration=duration, store=store, progress=False)
    print("finished", flush=True)
""")


def _children(pid: int) -> set[int]:
    """Every live descendant of ``pid`` (from /proc)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            fields = stat[stat.rindex(")") + 2:].split()
            if fields[0] != "Z":
                parents[int(entry.name)] = int(fields[1])
    out, frontier = set(), {pid}
    while frontier:
        frontier = {c for c, p in parents.items() if p in frontier} - out
        out |= frontier
    return out


def _alive(pids) -> set[int]:
    alive = set()
    for p in pids:
        try:
            state = Path(f"/proc/{p}/stat").read_text()
        except OSError:
            continue
        if state[state.rindex(")") + 2] != "Z":
            alive.add(p)
    return alive


def _start(tmp: Path, points: int, duration: float):
    store = tmp / f"store-{time.monotonic_ns()}"
    script = tmp / "driver.py"
    script.write_text(DRIVER)
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    proc = subprocess.Popen([sys.executable, str(script), str(store), str(points), str(duration)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)  # its own process group, as a shell job has
    return proc, store


def _stored(store: Path) -> int:
    # not the ".tmp-*" files of writes in progress
    return sum(not f.name.startswith(".") for f in (store / "points").glob("*.nc")) if store.exists() else 0


def _wait_for(pred, limit: float, step: float = 0.02) -> bool:
    end = time.monotonic() + limit
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(step)
    return pred()


def interrupt(tmp: Path, points: int, duration: float, group: bool) -> dict:
    proc, store = _start(tmp, points, duration)
    workers: set[int] = set()

    def started():
        workers.update(_children(proc.pid))
        return _stored(store) >= 2 or proc.poll() is not None

    _wait_for(started, 120)
    workers.update(_children(proc.pid))
    before = _stored(store)
    t0 = time.monotonic()
    if group:
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGINT)
    proc.wait(120)
    parent_s = time.monotonic() - t0
    _wait_for(lambda: not _alive(workers), 120)
    all_s = time.monotonic() - t0
    proc.communicate()
    return {"parent_s": parent_s, "all_s": all_s, "stored_before": before, "stored_after": _stored(store),
            "workers": len(workers), "left_alive": len(_alive(workers)), "rc": proc.returncode}


def kill_parent(tmp: Path, points: int, duration: float) -> dict:
    proc, store = _start(tmp, points, duration)
    workers: set[int] = set()

    def computing():
        workers.update(_children(proc.pid))
        return _stored(store) >= 1 or proc.poll() is not None

    _wait_for(computing, 120)
    workers.update(_children(proc.pid))
    t0 = time.monotonic()
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    gone = _wait_for(lambda: not _alive(workers), 60)
    s = time.monotonic() - t0
    left = _alive(workers)
    for p in left:  # do not leave them behind on this machine
        os.kill(p, signal.SIGKILL)
    proc.communicate()
    return {"all_s": s if gone else float("nan"), "workers": len(workers), "left_alive": len(left)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=16)
    ap.add_argument("--duration", type=float, default=0.5, help="simulated seconds per point")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"sweep of {args.points} points of the paper's drive, {args.duration:g} s each, default executor, "
          f"{os.cpu_count()} CPUs, {args.repeat} runs per row (median, min-max)\n")
    print("| signal | parent exits [s] | parent and workers exit [s] | points stored at signal -> after "
          "| workers left alive |")
    print("| --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for label, group in (("SIGINT to the parent", False), ("SIGINT to the process group (Ctrl-C)", True)):
            rows = [interrupt(tmp, args.points, args.duration, group) for _ in range(args.repeat)]
            p = [r["parent_s"] for r in rows]
            a = [r["all_s"] for r in rows]
            stored = ", ".join(f"{r['stored_before']} -> {r['stored_after']}" for r in rows)
            print(f"| {label} | {statistics.median(p):.2f} ({min(p):.2f}-{max(p):.2f}) | "
                  f"{statistics.median(a):.2f} ({min(a):.2f}-{max(a):.2f}) | {stored} | "
                  f"{sum(r['left_alive'] for r in rows)} of {sum(r['workers'] for r in rows)} |")
        rows = [kill_parent(tmp, args.points, args.duration) for _ in range(args.repeat)]
        a = [r["all_s"] for r in rows]
        print(f"| SIGKILL to the parent | - | {statistics.median(a):.2f} ({min(a):.2f}-{max(a):.2f}) | - | "
              f"{sum(r['left_alive'] for r in rows)} of {sum(r['workers'] for r in rows)} (killed by this script) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
