"""The README's "Many degrees of freedom: tape paths" example runs as written."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parent.parent / "README.md"


def test_readme_tape_path_example_runs():
    found = re.search(r"### Many degrees of freedom: tape paths\s.*?```python\n(.*?)```", README.read_text(),
                      flags=re.S)
    assert found, "the README has no tape-path example"
    import impactosc as io

    scope: dict = {"io": io}
    exec(compile(found.group(1), "README.md: tape paths", "exec"), scope)
    sol, run, path = scope["sol"], scope["run"], scope["path"]
    assert sol.status == 0
    forces, rates = run.mean_flange_force(), run.impacts_per_second()
    assert len(forces) == len(rates) == len(path.guides) == 2
    # the 30 um guide nearer the pack is touched, and a touched guide pushes back: force and rate go together
    assert np.all((np.asarray(forces) > 0) == (np.asarray(rates) > 0))
    assert forces[0] > 0
