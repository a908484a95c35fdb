"""Smoke test of the issue-4 benchmark scripts: they run end to end on tiny sizes and write
finite numbers. No timing assertions (the machine is shared)."""

from __future__ import annotations

import importlib.util
import json
import math
import re
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"

pytest.importorskip("matplotlib")
pytest.importorskip("numba")


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", BENCH / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def _table_numbers(md: str) -> list[str]:
    """Every cell of every markdown table row that should hold a number."""
    cells = []
    for line in md.splitlines():
        if line.startswith("|") and not line.startswith("| ---"):
            cells += [c.strip() for c in line.strip("|").split("|")]
    return [c for c in cells if re.fullmatch(r"[-+]?[\d,]*\.?\d+(e[-+]?\d+)?", c.replace(",", ""), re.I)]


def test_work_precision_quick(tmp_path):
    mod = _load("work_precision")
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "work_precision.md").read_text()
    for case in "abcd":
        png = tmp_path / f"work_precision_{case}.png"
        assert png.is_file() and png.stat().st_size > 1000
        assert f"work_precision_{case}.png" in md
    assert "## Targets" in md and "(issue" not in md
    nums = _table_numbers(md)
    assert nums and all(math.isfinite(float(c.replace(",", ""))) for c in nums)
    raw = json.loads((tmp_path / "work_precision.json").read_text())
    for case in raw.values():
        for row in case["rows"]:
            if row["method"] in ("exact", "heyoka", "rk4"):
                assert math.isfinite(row["wall"]) and row["wall"] > 0
                assert math.isfinite(row["mean_force"])
            if row["method"] == "heyoka":
                assert row["seq_ok"], row  # tiny runs: heyoka must reproduce the exact events
    assert not re.search(r"\bnan\b", md, re.I)


def test_throughput_quick(tmp_path):
    mod = _load("throughput")
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "throughput.md").read_text()
    assert (tmp_path / "throughput_profile.txt").read_text().strip()
    raw = json.loads((tmp_path / "throughput.json").read_text())
    rows = raw["throughput"]
    assert {r["backend"] for r in rows} == {"heyoka", "exact", "scipy", "rk4"}
    for r in rows:
        assert "error" not in r, r
        assert r["events"] > 0 and math.isfinite(r["events_per_s"]) and r["events_per_s"] > 0
    mem = raw["memory"]
    assert {m["record"] for m in mem} == {"full", "events", "stats"}
    for m in mem:
        assert "error" not in m, m
        assert m["maxrss_kib"] > 0 and m["tracemalloc_peak"] > 0
    split = raw["split"]
    assert 0 < split["us_loop_event"] < split["us_event"] and split["us_tiny_call"] > 0
    nums = _table_numbers(md)
    assert nums and all(math.isfinite(float(c.replace(",", ""))) for c in nums)


def test_speed_quick(tmp_path):
    mod = _load("speed")
    assert mod.main(["--quick", "--rounds", "2", "--events", "300", "--skip", "fig7", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "speed.md").read_text()
    raw = json.loads((tmp_path / "speed.json").read_text())
    backends = {r["backend"] for r in raw["contact"]["rows"]}
    assert {"heyoka", "rk4 (default dt)", "exact (compiled loop)", "exact (Python driver)"} <= backends
    for r in raw["contact"]["rows"] + raw["stickslip"]["rows"]:
        assert r["events"] > 0 and math.isfinite(r["wall"]) and r["wall"] > 0, r
    assert math.isfinite(raw["stickslip"]["ratios"]["heyoka"])
    compiled = raw["compiled"]
    assert compiled["events"] > 0 and compiled["events_per_s"] > 0
    # The compiled loop and the Python driver run the same closed forms: the same mean force.
    assert compiled["mean_force"] == compiled["python_driver"]
    assert "## Targets" in md and "(issue" not in md and "compiled closed form: >= 1e6 events/s" in md
    nums = _table_numbers(md)
    assert nums and all(math.isfinite(float(c.replace(",", ""))) for c in nums)


def test_continuation_speed_quick(tmp_path):
    mod = _load("continuation_speed")
    assert mod.main(["--quick", "--repeats", "1", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "continuation_speed.md").read_text()
    assert "grazing curve" in md and "branch of the contact case" in md
    nums = _table_numbers(md)
    assert nums and all(math.isfinite(float(c.replace(",", ""))) for c in nums)
