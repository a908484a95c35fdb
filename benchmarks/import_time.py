"""What ``import impactosc`` costs, and the first run after it.

Each measurement is a fresh interpreter (the import is cached after the first time in a
process, so only a new process measures it). Three timings per tree, medians over
``--repeats`` processes, every tree measured in the same interleaved rounds so that the
noise of a shared machine falls on all of them alike:

- ``import``: ``import impactosc`` alone (timed inside the child, interpreter start-up
  excluded);
- ``import + Oscillator``: the import and one model built;
- ``import + first simulate``: the import and a first 400-unit run of the contact case on
  the default backend (heyoka, whose integrator is compiled on first use in every process)
  and on the exact backend (numba's on-disk cache warm: run the script twice).

The heavy modules that the import pulled in are listed too: after the change none of
numba, heyoka, xarray, pandas, matplotlib, scipy.signal or dask is loaded by ``import
impactosc; impactosc.Oscillator(...)``.

Usage::

    python benchmarks/import_time.py                      # this checkout only
    python benchmarks/import_time.py --baseline e07f4b9   # and a commit beside it (git worktree)

Writes ``benchmarks/results/import_time.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
HEAVY = ("numba", "heyoka", "xarray", "pandas", "matplotlib", "scipy.signal", "dask", "scipy.linalg")

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import impactosc as io
t1 = time.perf_counter()
osc = io.Oscillator(0.5, 1.1, 0.01, 1e4)
t2 = time.perf_counter()
heavy = [m for m in {heavy!r} if m in sys.modules]
run = {run!r}
t3 = t2
if run:
    io.simulate(osc, 400.0, 0.95, 0.0, backend=run, record="stats")
    t3 = time.perf_counter()
print(json.dumps({{"import": t1 - t0, "oscillator": t2 - t0, "simulate": t3 - t0, "heavy": heavy}}))
"""


def _child(tree: Path, run: str | None) -> dict:
    code = CHILD.format(heavy=HEAVY, run=run)
    out = subprocess.run([sys.executable, "-c", code], cwd=tree, capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(tree)})
    return json.loads(out.stdout.strip().splitlines()[-1])


def _measure(trees: dict[str, Path], repeats: int) -> dict:
    rows: dict[str, dict[str, list]] = {name: {} for name in trees}
    for tree in trees.values():  # warm the disk caches (pyc, numba) before timing
        for run in (None, "heyoka", "exact"):
            _child(tree, run)
    for _ in range(repeats):
        for name, tree in trees.items():
            for run in (None, "heyoka", "exact"):
                r = _child(tree, run)
                key = run or "import"
                rows[name].setdefault(key, []).append(r)
    return rows


def _table(rows: dict) -> str:
    lines = ["| tree | import [s] | import + Oscillator [s] | + first simulate, heyoka [s] | "
             "+ first simulate, exact [s] | heavy modules after import + Oscillator |",
             "|---|---:|---:|---:|---:|---|"]
    for name, r in rows.items():
        imp = statistics.median(x["import"] for x in r["import"])
        osc = statistics.median(x["oscillator"] for x in r["import"])
        hey = statistics.median(x["simulate"] for x in r["heyoka"])
        exa = statistics.median(x["simulate"] for x in r["exact"])
        heavy = ", ".join(r["import"][0]["heavy"]) or "none"
        lines.append(f"| {name} | {imp:.3f} | {osc:.3f} | {hey:.3f} | {exa:.3f} | {heavy} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", help="a git revision to measure beside this checkout")
    parser.add_argument("--repeats", type=int, default=10, help="fresh processes per timing (median)")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be at least 1, got {args.repeats}")
    trees = {"this checkout": ROOT}
    with tempfile.TemporaryDirectory() as tmp:
        if args.baseline:
            base = Path(tmp) / "baseline"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(base), args.baseline],
                           check=True)
            trees = {f"baseline {args.baseline}": base, **trees}
        try:
            table = _table(_measure(trees, args.repeats))
        finally:
            if args.baseline:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)], check=False)
    text = (f"# Import cost\n\nMedians of {args.repeats} fresh processes each, trees interleaved "
            f"(`python benchmarks/import_time.py{' --baseline ' + args.baseline if args.baseline else ''}`).\n\n"
            f"{table}\n")
    (ROOT / "benchmarks" / "results" / "import_time.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
