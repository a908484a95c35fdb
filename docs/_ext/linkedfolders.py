"""Sphinx extension: links between documents inside folders that ``docs/`` links to.

``docs/notebooks``, ``docs/reports`` and ``docs/benchmarks`` are symbolic links to the
repository's folders, so that their Markdown files and notebooks are read in place. Sphinx
resolves a relative link of a document through the symbolic link (``relfn2path`` calls
``Path.resolve``), so a link such as ``results/throughput.md`` in ``benchmarks/README.md``
comes out as the absolute path of the real file, outside the source folder, and MyST reports
an unknown document. This post-transform, run just before MyST resolves its references,
maps such a target back to the document name under the linked folder.
"""

from __future__ import annotations

from pathlib import Path

from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.transforms.post_transforms import SphinxPostTransform


def linked_folders(srcdir: Path) -> dict[Path, str]:
    """Real folder -> its name in ``srcdir``, for the symbolic links to folders in ``srcdir``."""
    return {child.resolve(): child.name for child in srcdir.iterdir() if child.is_symlink() and child.is_dir()}


class MapLinkedFolderTargets(SphinxPostTransform):
    default_priority = 8  # MyST's reference resolver runs at 9

    def run(self, **kwargs) -> None:
        folders = linked_folders(Path(self.env.srcdir))
        for node in self.document.findall(addnodes.pending_xref):
            if node.get("refdomain") != "doc" or not Path(node["reftarget"]).is_absolute():
                continue
            target = Path(node["reftarget"])
            for real, name in folders.items():
                if target.is_relative_to(real):
                    node["reftarget"] = (Path(name) / target.relative_to(real)).as_posix()
                    break


def setup(app: Sphinx) -> dict:
    app.add_post_transform(MapLinkedFolderTargets)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
