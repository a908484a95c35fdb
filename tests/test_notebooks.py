"""The tutorial notebooks match their sources and are committed without outputs.

The notebooks are generated from ``notebooks/src/*.py`` by ``notebooks/build.py`` and are
committed without outputs; these tests check both. They are *run* by the documentation
build (tests/test_docs.py), in a kernel of this interpreter with ``IMPACTOSC_QUICK=1``,
which also checks that no cell raises and that every cell that prints or shows a figure
produced that output: running them here as well would execute them twice in ``make test``.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
PATHS = sorted(NOTEBOOKS.glob("[0-9][0-9]-*.ipynb"))


def _builder():
    spec = importlib.util.spec_from_file_location("_notebook_build", NOTEBOOKS / "build.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_every_source_has_a_notebook():
    sources = sorted(p.stem for p in (NOTEBOOKS / "src").glob("[0-9][0-9]-*.py"))
    assert sources, "no notebook sources in notebooks/src"
    assert sources == [p.stem for p in PATHS]


@pytest.mark.parametrize("path", PATHS, ids=[p.stem for p in PATHS])
def test_notebook_matches_source_and_has_no_outputs(path):
    nb = nbformat.read(path, as_version=4)
    built = _builder().build(NOTEBOOKS / "src" / f"{path.stem}.py")
    def cells(notebook):
        return [(c.cell_type, c.source, c.metadata.get("tags", [])) for c in notebook.cells]

    assert cells(nb) == cells(built), (
        f"{path.name} differs from notebooks/src/{path.stem}.py: run python notebooks/build.py")
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name} is committed with outputs"
    first = next(c for c in nb.cells if c.cell_type == "code")
    assert 'QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"' in first.source


def test_cell_tags_of_a_source_reach_the_notebook():
    """``# %% tags=[...]`` (jupytext's spelling) becomes the cell's tags: the docs' gallery reads them."""
    cells = _builder().cells_from_script('# %% [markdown]\n# Title\n\n# %% tags=["gallery"]\nx = 1\n\n# %%\ny = 2\n')
    assert [c.cell_type for c in cells] == ["markdown", "code", "code"]
    assert cells[1].metadata["tags"] == ["gallery"] and "tags" not in cells[2].metadata
    assert cells[1].source == "x = 1"
