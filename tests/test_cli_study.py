"""``impactosc paper --study --quick``: the Fig. 4 study end to end, its files and report."""

from __future__ import annotations

import json

import pytest

from impactosc.cli import main


@pytest.mark.slow
def test_paper_study_quick(tmp_path, capsys):
    out = tmp_path / "reports"
    assert main(["paper", "--study", "--quick", "--out", str(out), "--serial", "--no-progress"]) == 0
    text = (out / "fig4_study.md").read_text()
    # the criteria come first, before any result
    assert text.index("## 1. The criteria, fixed before the search") < text.index("## 4. Candidate models")
    for name in ("paper", "long_span", "air_film"):
        assert f"**{name}**" in text
    summary = json.loads((out / "fig4_study.json").read_text())
    assert summary["quick"] is True
    assert set(summary["best"]["trends"]) == {"mid_pack", "speed", "tension", "double"}
    # the paper's parameters touch no flange (the reproduction's finding) and so hold no trend
    assert not any(any(t.values()) for t in summary["candidates"]["paper"]["trends"].values())
    rows = (out / "fig4_study.csv").read_text().splitlines()
    assert rows[0] == "model,observable,pack_diameter_mm,speed_m_s,t_sin_half_theta_N,value"
    assert len(rows) > 100
    assert (out / "figures" / "fig4_study_best.png").stat().st_size > 0
    assert (out / "figures" / "fig4_study_search.png").stat().st_size > 0
    assert "best:" in capsys.readouterr().out


def test_paper_study_refuses_a_bad_output_dir(tmp_path, capsys):
    """A file where the output directory should be: a one-line error, status 2, before any computation."""
    target = tmp_path / "file"
    target.write_text("x")
    assert main(["paper", "--study", "--quick", "--out", str(target)]) == 2
    assert "not a directory" in capsys.readouterr().err
