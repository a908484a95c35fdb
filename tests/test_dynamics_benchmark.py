"""Smoke test of benchmarks/dynamics_speed.py: it runs end to end on tiny sizes (no timing assertions)."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent / "benchmarks" / "dynamics_speed.py"


def test_dynamics_speed_quick(tmp_path):
    spec = importlib.util.spec_from_file_location("_bench_dynamics_speed", BENCH)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "dynamics_speed.md").read_text()
    assert md.count("\n| ") >= 8
    assert "12/12 runs ok" in md and "24/24 runs ok" in md
    assert not re.search(r"\bnan\b", md, re.I)
