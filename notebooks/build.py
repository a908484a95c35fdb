"""Build the notebooks from their percent-format sources: ``python notebooks/build.py``.

Each ``notebooks/src/NN-name.py`` becomes ``notebooks/NN-name.ipynb``, one cell per
``# %%`` block (``# %% [markdown]`` blocks are markdown, written as ``# `` comments; a marker
may carry cell tags as jupytext writes them, ``# %% tags=["gallery"]``: the docs' gallery
shows the figure of the cell tagged ``gallery``). The
notebooks are written without outputs; ``tests/test_notebooks.py`` checks that they match
their sources and runs them.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import nbformat

HERE = Path(__file__).resolve().parent
SRC = HERE / "src"

KERNELSPEC = {"name": "python3", "display_name": "Python 3 (ipykernel)", "language": "python"}


def _markdown(lines: list[str]) -> str:
    out = []
    for line in lines:
        if line.startswith("# "):
            out.append(line[2:])
        elif line.rstrip() in ("#", ""):
            out.append("")
        else:
            raise ValueError(f"markdown lines must start with '# ' or be '#' or blank, got {line!r}")
    return "\n".join(out).strip("\n")


def cells_from_script(text: str) -> list:
    """Split a percent-format script into notebook cells."""
    blocks: list[tuple[str, list[str], list[str]]] = []
    for line in text.splitlines():
        if line.startswith("# %%"):
            kind = "markdown" if "[markdown]" in line else "code"
            tags = re.search(r"\btags=(\[.*?\])", line)
            blocks.append((kind, [], json.loads(tags.group(1)) if tags else []))
        elif blocks:
            blocks[-1][1].append(line)
        elif line.strip():
            raise ValueError(f"text before the first '# %%' cell marker: {line!r}")
    cells = []
    for kind, lines, tags in blocks:
        if kind == "markdown":
            cells.append(nbformat.v4.new_markdown_cell(_markdown(lines)))
        else:
            source = "\n".join(lines).strip("\n")
            if source:
                cells.append(nbformat.v4.new_code_cell(source))
            else:
                continue
        if tags:
            cells[-1].metadata["tags"] = tags
    return cells


def build(script: Path) -> nbformat.NotebookNode:
    """The notebook (without outputs) of one source script."""
    nb = nbformat.v4.new_notebook()
    nb.cells = cells_from_script(script.read_text())
    for i, cell in enumerate(nb.cells):
        cell["id"] = f"{script.stem[:2]}-{i:03d}"
    nb.metadata["kernelspec"] = dict(KERNELSPEC)
    nb.metadata["language_info"] = {"name": "python"}
    nbformat.validate(nb)
    return nb


def main(argv: list[str] | None = None) -> int:
    for script in sorted(SRC.glob("[0-9][0-9]-*.py")):
        target = HERE / f"{script.stem}.ipynb"
        nbformat.write(build(script), target)
        print(f"wrote {target.relative_to(HERE.parent)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
