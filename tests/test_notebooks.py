"""The tutorial notebooks run top to bottom, in quick mode, and match their sources.

Each notebook in ``notebooks/`` is executed in a fresh kernel of *this* interpreter (a
kernelspec written to a temporary directory, so that a ``python3`` kernel of another
Python on the machine cannot be picked up) with ``IMPACTOSC_QUICK=1``. A notebook passes
when no cell raises and every cell that prints or shows a figure produced that output.

The notebooks are generated from ``notebooks/src/*.py`` by ``notebooks/build.py`` and are
committed without outputs; the first tests check both.
"""

from __future__ import annotations

import importlib.util
import json
import sys
import time
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")
pytest.importorskip("matplotlib")

from jupyter_client.kernelspec import KernelSpecManager  # noqa: E402
from jupyter_client.manager import KernelManager  # noqa: E402

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
PATHS = sorted(NOTEBOOKS.glob("[0-9][0-9]-*.ipynb"))
CELL_TIMEOUT = 600  # s; quick mode needs far less, but the machine is shared


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
    assert [(c.cell_type, c.source) for c in nb.cells] == [(c.cell_type, c.source) for c in built.cells], (
        f"{path.name} differs from notebooks/src/{path.stem}.py: run python notebooks/build.py")
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name} is committed with outputs"
    first = next(c for c in nb.cells if c.cell_type == "code")
    assert 'QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"' in first.source


@pytest.fixture(scope="module")
def kernel_dir(tmp_path_factory):
    """A ``python3`` kernelspec that runs ipykernel in the interpreter running the tests."""
    root = tmp_path_factory.mktemp("kernels")
    spec_dir = root / "python3"
    spec_dir.mkdir()
    spec = {"argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
            "display_name": "impactosc test kernel", "language": "python"}
    (spec_dir / "kernel.json").write_text(json.dumps(spec))
    return root


def _expected_outputs(source: str) -> set[str]:
    want = set()
    if "plt.show()" in source or "display(fig)" in source:
        want.add("image")
    if "print(" in source:
        want.add("text")
    return want


def _produced(cell) -> set[str]:
    got = set()
    for out in cell.outputs:
        if out.output_type == "stream" and out.name == "stdout" and out.text.strip():
            got.add("text")
        data = out.get("data", {})
        if "image/png" in data or "image/svg+xml" in data:
            got.add("image")
        if "text/plain" in data or "text/html" in data:
            got.add("text")
    return got


@pytest.mark.parametrize("path", PATHS, ids=[p.stem for p in PATHS])
def test_notebook_runs(path, kernel_dir, monkeypatch, tmp_path):
    monkeypatch.setenv("IMPACTOSC_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # the notebooks' temporary stores land here
    nb = nbformat.read(path, as_version=4)
    km = KernelManager(kernel_name="python3", kernel_spec_manager=KernelSpecManager(kernel_dirs=[str(kernel_dir)]))
    client = nbclient.NotebookClient(nb, km=km, timeout=CELL_TIMEOUT, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOKS)}})
    start = time.perf_counter()
    client.execute()  # raises CellExecutionError, with the cell and its traceback, if a cell fails
    elapsed = time.perf_counter() - start
    print(f"{path.name}: {elapsed:.1f} s")

    code = [c for c in nb.cells if c.cell_type == "code"]
    first_out = "".join(o.get("text", "") for o in code[0].outputs if o.output_type == "stream")
    missing = []
    for i, cell in enumerate(code):
        assert not any(o.output_type == "error" for o in cell.outputs), f"code cell {i} of {path.name} failed"
        lacking = _expected_outputs(cell.source) - _produced(cell)
        if lacking:
            missing.append(f"code cell {i} ({cell.source.splitlines()[0]!r}) produced no {', '.join(sorted(lacking))}")
    assert not missing, f"{path.name}:\n" + "\n".join(missing)
    assert "quick mode" in first_out, f"{path.name} did not run in quick mode: {first_out!r}"
    n_images = sum("image" in _produced(c) for c in code)
    assert n_images >= 2, f"{path.name} showed only {n_images} figure(s)"
