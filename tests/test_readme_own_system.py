"""The README's "Your own system" example runs, and says what it computes.

The block is executed as it stands; its comments state the status, the accumulation time
(closed form of the bouncing ball: ``sqrt(2 h / g) (1 + 2 e / (1 - e))``), the fixed point
and the multipliers, checked here against the run.
"""

import math
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("heyoka")

README = Path(__file__).resolve().parent.parent / "README.md"


def _block() -> str:
    found = re.search(r"### Your own system\s.*?```python\n(.*?)```", README.read_text(), flags=re.S)
    assert found, "the README has no 'Your own system' example"
    return found.group(1)


def test_readme_own_system_example_runs_and_its_comments_hold():
    scope: dict = {}
    exec(compile(_block(), "README.md: Your own system", "exec"), scope)
    sol, orbit, check = scope["sol"], scope["orbit"], scope["check"]
    h, g, e = 1.0, 9.81, 0.8
    zeno = math.sqrt(2 * h / g) * (1 + 2 * e / (1 - e))
    assert sol.status == 2 and sol.message.startswith("Events accumulate (Zeno)")
    assert sol.accumulation_time == pytest.approx(zeno, abs=1e-9)
    assert f"{zeno:.11f}"[:13] in _block()  # the value the README prints
    assert set(sol.event_table()["guard"]) == {"impact"}
    assert check.status == 0 and len(check.events) > 0
    assert orbit.status == 0 and len(orbit.signature) == 2
    np.testing.assert_allclose(orbit.z, [-0.41614, -0.50486], atol=1e-5)
    np.testing.assert_allclose(np.abs(orbit.multipliers), [0.3309, 0.3309], atol=1e-4)
    # the orbit is a fixed point of the independent scipy run's stroboscopic map as well
    period = 2 * math.pi / 0.8
    again = scope["io"].simulate(scope["stop"], period, orbit.z, backend="scipy", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(again.state_final[:2], orbit.z, atol=1e-8)
    # the continuation: a fold where a multiplier is +1, and the grazing of the guard that ends the branch
    branch = scope["branch"]
    fold = branch.find("fold")[0]
    assert fold.parameter == pytest.approx(0.96866, abs=1e-5)
    assert np.min(np.abs(np.asarray(fold.multipliers) - 1.0)) < 1e-6
    graze = branch.find("grazing")[0]
    assert branch.status == 2 and graze.guard == "impact"
    assert graze.parameter == pytest.approx(1.22499, abs=1e-5)
