"""Sphinx extension: gallery cards whose pictures are figures of the executed notebooks.

No picture of the site is a file kept by hand: each is a figure that a notebook drew while
the site was being built (myst-nb executes the notebooks and keeps the executed copies in
``<build>/jupyter_execute``), copied from there into ``<build>/jupyter_execute/gallery``.

``notebook-card`` (one sphinx-design ``grid-item-card``, inside a ``grid``)::

    ```{notebook-card} notebooks/06-dynamics
    :title: Dynamics toolkit
    :tag: gallery
    The card's text (Markdown).
    ```

picks the first figure of the notebook's code cell tagged ``gallery`` (``:tag:``), or of the
one code cell whose source contains ``:match:``; the card links to the notebook's page
(``:link:`` for another page). ``notebook-gallery`` makes a grid with a card for every figure
of the notebooks matching its argument (a glob of document names), titled by the section of
the notebook it is in. A figure that cannot be found is a warning (the build runs with
``-W``): a gallery never shows a stale or missing picture silently.

The pages that use these directives are read after every other document, so that the
notebooks have been executed first, and again whenever a notebook is.
"""

from __future__ import annotations

import base64
import fnmatch
import os
import re
from pathlib import Path

import nbformat
from docutils import nodes
from docutils.parsers.rst import directives
from docutils.statemachine import StringList
from sphinx.application import Sphinx
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)
DIRECTIVES = ("notebook-card", "notebook-gallery")


def _output_folder(app: Sphinx) -> Path:
    """Where myst-nb writes the executed notebooks (its ``jupyter_execute`` folder)."""
    return Path(app.outdir).parent.joinpath("jupyter_execute").resolve()


def executed_notebook(app: Sphinx, docname: str) -> nbformat.NotebookNode | None:
    path = _output_folder(app).joinpath(*docname.split("/")).with_suffix(".ipynb")
    return nbformat.read(path, as_version=4) if path.exists() else None


def _png(cell) -> list[bytes]:
    out = []
    for output in cell.get("outputs", []):
        data = output.get("data", {})
        if "image/png" in data:
            out.append(base64.b64decode(data["image/png"]))
    return out


def figures(nb: nbformat.NotebookNode) -> list[tuple[str, str, bytes]]:
    """``(section title, cell id, PNG)`` of every figure of a notebook, in order."""
    section, out = "", []
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if re.match(r"#{1,3} ", line):
                    section = line.lstrip("#").strip()
        elif cell.cell_type == "code":
            out.extend((section, cell.get("id", ""), png) for png in _png(cell))
    return out


def _select(nb, tag: str | None, match: str | None) -> tuple[object, str]:
    """The code cell a card shows, or ``(None, why not)``."""
    code = [c for c in nb.cells if c.cell_type == "code"]
    if tag:
        cells = [c for c in code if tag in c.get("metadata", {}).get("tags", [])]
        what = f"tagged {tag!r}"
    else:
        cells = [c for c in code if match in c.source]
        what = f"whose source contains {match!r}"
    if len(cells) != 1:
        return None, f"{len(cells)} code cells {what} (one is needed)"
    if not _png(cells[0]):
        return None, f"the code cell {what} has no figure output"
    return cells[0], ""


def _title_of(nb) -> str:
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    return ""


class _GalleryDirective(SphinxDirective):
    def _notebook(self, docname: str):
        env = self.env
        env.gallery_docs = getattr(env, "gallery_docs", set()) | {env.docname}
        if docname not in env.found_docs:
            return None, f"no document {docname!r}"
        nb = executed_notebook(env.app, docname)
        if nb is None:
            return None, f"{docname} has not been executed (no copy in {_output_folder(env.app)})"
        return nb, ""

    def _image_uri(self, docname: str, key: str, png: bytes) -> str:
        folder = _output_folder(self.env.app) / "gallery"
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"{docname.replace('/', '-')}-{key}.png"
        if not path.exists() or path.read_bytes() != png:
            path.write_bytes(png)
        # Sphinx reads "/..." as relative to the source folder (so does myst-nb for its images).
        return "/" + Path(_relpath(path, Path(self.env.srcdir))).as_posix()

    def _parse(self, text: str) -> list[nodes.Node]:
        """Parse ``text`` (Markdown) into the directive's parent: sphinx-design checks that a
        card's parent is a grid's row, so the card must be parsed in place."""
        self.state.nested_parse(StringList(text.splitlines(), source=self.env.docname), self.content_offset,
                                self.state_machine.node)
        return []

    def _warn(self, message: str) -> list[nodes.Node]:
        logger.warning(f"{self.name}: {message}", location=self.get_location())
        return []


def _relpath(path: Path, start: Path) -> str:
    return os.path.relpath(path, start)


def _card(title: str, link: str, image: str, alt: str, body: str, fence: str = "```") -> str:
    return "\n".join([f"{fence}{{grid-item-card}} {title}", f":link: {link}", ":link-type: doc",
                      f":img-top: {image}", f":img-alt: {alt}", ":class-card: gallery-card",
                      ":shadow: md", "", body, fence, ""])


class NotebookCard(_GalleryDirective):
    """One card: a figure of one notebook, a title, a text, a link."""

    required_arguments = 1
    has_content = True
    option_spec = {"title": directives.unchanged_required, "tag": directives.unchanged,
                   "match": directives.unchanged, "link": directives.unchanged}

    def run(self) -> list[nodes.Node]:
        docname = self.arguments[0].strip().lstrip("/")
        tag, match = self.options.get("tag"), self.options.get("match")
        if bool(tag) == bool(match):
            return self._warn("give exactly one of :tag: and :match:")
        nb, why = self._notebook(docname)
        if nb is None:
            return self._warn(why)
        cell, why = _select(nb, tag, match)
        if cell is None:
            return self._warn(f"{docname}: {why}")
        image = self._image_uri(docname, cell.get("id", "cell"), _png(cell)[0])
        title = self.options.get("title", _title_of(nb))
        link = "/" + self.options.get("link", docname).lstrip("/")
        return self._parse(_card(title, link, image, f"a figure of {docname}", "\n".join(self.content)))


class NotebookGallery(_GalleryDirective):
    """A grid with a card for every figure of the notebooks whose document names match."""

    required_arguments = 1

    def run(self) -> list[nodes.Node]:
        pattern = self.arguments[0].strip().lstrip("/")
        docnames = sorted(d for d in self.env.found_docs if fnmatch.fnmatchcase(d, pattern)
                          and self.env.doc2path(d).suffix == ".ipynb")
        if not docnames:
            return self._warn(f"no notebook matches {pattern!r}")
        text = []
        for docname in docnames:
            nb, why = self._notebook(docname)
            if nb is None:
                return self._warn(why)
            found = figures(nb)
            if not found:
                return self._warn(f"{docname} has no figure")
            notebook_title = _title_of(nb)
            cards = []
            for k, (section, cell_id, png) in enumerate(found):
                image = self._image_uri(docname, f"{cell_id}-{k}", png)
                title = section if section and section != notebook_title else notebook_title
                cards.append(_card(title, "/" + docname, image, f"figure {k + 1} of {docname}", ""))
            # One rubric (not a heading: the page's sections are its own) and one grid per notebook.
            text.append(f"```{{rubric}} {notebook_title.replace(chr(96), '')}\n```\n")
            text.append("````{grid} 1 2 3 3\n:gutter: 3\n\n" + "\n".join(cards) + "````\n")
        return self._parse("\n".join(text))


# -- the order of reading --------------------------------------------------------------------
def _uses_gallery(env, docname: str) -> bool:
    try:
        text = Path(env.doc2path(docname)).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return any(f"{{{name}}}" in text or f".. {name}::" in text for name in DIRECTIVES)


def read_galleries_last(app: Sphinx, env, docnames: list[str]) -> None:
    """Read the pages with gallery directives after the notebooks they show."""
    last = [d for d in docnames if _uses_gallery(env, d)]
    docnames[:] = [d for d in docnames if d not in last] + last


def reread_with_notebooks(app: Sphinx, env, added, changed, removed) -> list[str]:
    """A page of the gallery is read again whenever a notebook is."""
    notebooks = [d for d in (added | changed) if str(env.doc2path(d)).endswith(".ipynb")]
    if not notebooks:
        return []
    return sorted(d for d in env.found_docs if _uses_gallery(env, d) and d not in added | changed)


def purge(app: Sphinx, env, docname: str) -> None:
    if hasattr(env, "gallery_docs"):
        env.gallery_docs.discard(docname)


def merge(app: Sphinx, env, docnames, other) -> None:
    env.gallery_docs = getattr(env, "gallery_docs", set()) | getattr(other, "gallery_docs", set())


def setup(app: Sphinx) -> dict:
    app.setup_extension("sphinx_design")
    app.add_directive("notebook-card", NotebookCard)
    app.add_directive("notebook-gallery", NotebookGallery)
    app.connect("env-before-read-docs", read_galleries_last)
    app.connect("env-get-outdated", reread_with_notebooks)
    app.connect("env-purge-doc", purge)
    app.connect("env-merge-info", merge)
    return {"parallel_read_safe": False, "parallel_write_safe": True}
