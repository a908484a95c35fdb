"""Sphinx configuration of the impactosc documentation (``make docs``).

The site is built from the package and the repository as they are: the API reference from
the docstrings (``_ext/apipages.py`` lists every public name), the notebooks of
``notebooks/`` executed at build time in quick mode, and the paper reproduction report and
the benchmark results read in place (``notebooks``, ``reports`` and ``benchmarks`` in this
folder are symbolic links to the repository's folders: nothing is copied).
"""

from __future__ import annotations

import atexit
import json
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE / "_ext"))
# The checkout's package, also when it is not installed: here and in the notebooks' kernels.
sys.path.insert(0, str(ROOT))
os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))

import apitopics  # noqa: E402
from numpydoc.xref import DEFAULT_LINKS  # noqa: E402
from sphinx.ext import autosummary  # noqa: E402

import impactosc  # noqa: E402

# -- project -------------------------------------------------------------------------------
project = "impactosc"
author = "the impactosc developers"
copyright = "the impactosc developers"
release = impactosc.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",  # a [source] link beside every documented object
    "sphinx-mathjax-offline",  # MathJax from the site itself: the equations need no network
    "sphinx_design",  # the gallery's cards
    "numpydoc",
    "myst_nb",
    "apipages",
    "gallery",
    "linkedfolders",
    "knownwarnings",
]

root_doc = "index"
templates_path = ["_templates"]
exclude_patterns = [
    "_build",
    "Thumbs.db",
    ".DS_Store",
    "notebooks/README.md",  # the tutorials page says the same, with the notebooks in its toctree
    "notebooks/src",
    "benchmarks/results/quick",  # git-ignored output of the benchmarks' --quick runs
    "reports/figures/quick",
    "**/.ipynb_checkpoints",
]

# -- cross-references ----------------------------------------------------------------------
# Every reference must resolve: a broken one is a warning, and the build runs with -W.
nitpicky = True
# No intersphinx: CI reaches PyPI only, so other projects' inventories cannot be fetched.
# References to them (and to builtins) stay plain text instead of failing the build.
# numpydoc would link builtin and numpy type names ("float", "callable") to intersphinx
# targets such as "python:float", shown as such when they cannot resolve: keep them plain.
_PLAIN_TYPES = [name for name, link in DEFAULT_LINKS.items() if "python:" in link or "numpy:" in link]
_EXTERNAL = r"(builtins|numpy|np|scipy|xarray|xr|pandas|pd|dask|distributed|matplotlib|heyoka|hy|numba|tqdm"
_EXTERNAL += r"|concurrent|collections|typing|pathlib|os|math|numbers|argparse|types|dataclasses)"
nitpick_ignore_regex = [
    ("py:.*", _EXTERNAL + r"(\..+)?"),
    # Builtin type names in numpydoc sections (see numpydoc_xref_aliases below).
    ("py:.*", "|".join(re.escape(name) for name in _PLAIN_TYPES)),
]

# -- the API reference, by topic (_ext/apipages.py; the topics are in _ext/apitopics.py) -----
api_topics = apitopics.TOPICS
api_internal = apitopics.INTERNAL

# -- autodoc, autosummary, numpydoc --------------------------------------------------------
autosummary_generate = True
autosummary_ignore_module_all = False
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # the numpydoc sections carry the types; signatures stay readable
numpydoc_show_class_members = False  # the class template documents the members itself
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = True
# Types named in "Parameters"/"Returns" link to the package's own pages.
numpydoc_xref_aliases = {name: name for name in _PLAIN_TYPES}
numpydoc_xref_aliases.update({name: f"impactosc.{name}" for name in impactosc.__all__})
# autosummary's tables show a name's first sentence, and a period followed by a space ends a
# sentence unless it closes one of these abbreviations: the docstrings cite "the paper's eq. 3"
# and "Fig. 7", which must not end the summary at "eq.".
autosummary.WELL_KNOWN_ABBREVIATIONS = (*autosummary.WELL_KNOWN_ABBREVIATIONS,
                                         "eq.", "Eq.", "eqs.", "Eqs.", "Fig.", "Figs.", "fig.", "sec.", "ch.")
numpydoc_xref_ignore = {"optional", "default", "of", "or", "and", "the", "a", "an", "shape", "with", "each", "per",
                        # plain words of a user system's types ("mapping", "heyoka expression or number")
                        "mapping", "expression", "expressions", "variable", "number"}

# -- notebooks (myst-nb) -------------------------------------------------------------------
# Executed at build time, in quick mode (the notebooks read IMPACTOSC_QUICK; quick is also
# their default). A failing cell is reported as a warning, which -W turns into a failure,
# and its traceback is saved under <build>/reports/.
os.environ.setdefault("IMPACTOSC_QUICK", "1")
nb_execution_mode = os.environ.get("IMPACTOSC_DOCS_EXECUTE", "force")
nb_execution_timeout = 600  # s per cell; quick mode needs far less, but the machine may be shared
nb_execution_raise_on_error = False
nb_execution_show_tb = True
nb_merge_streams = True
# Markdown that a cell displays (display(Markdown(...)): the notebooks' tables) is read as GitHub-flavoured
# Markdown, as Jupyter reads it: CommonMark, the default, has no tables.
nb_render_markdown_format = "gfm"
nb_mime_priority_overrides = [("html", "application/vnd.jupyter.widget-view+json", None)]
myst_enable_extensions = ["dollarmath", "amsmath", "substitution"]
# {{ version }} and {{ n_notebooks }} in the pages: facts read from the package and the repository.
myst_substitutions = {"version": release,
                      "n_notebooks": str(len(list((ROOT / "notebooks").glob("[0-9][0-9]-*.ipynb"))))}
myst_heading_anchors = 3


def _kernel_for_this_interpreter() -> str:
    """A ``python3`` kernelspec that runs ipykernel in the interpreter building the docs.

    Prepended to JUPYTER_PATH so that a ``python3`` kernel of another Python on the machine
    (a user-wide kernelspec) cannot run the notebooks against another installation.
    """
    root = Path(tempfile.mkdtemp(prefix="impactosc-docs-jupyter-"))
    atexit.register(shutil.rmtree, root, ignore_errors=True)
    spec_dir = root / "kernels" / "python3"
    spec_dir.mkdir(parents=True)
    # --log-level: the kernel's own start-up notices (not the notebooks' warnings, which are
    # cell outputs) would otherwise fill the build log.
    spec = {"argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}", "--log-level=ERROR"],
            "display_name": "impactosc docs kernel", "language": "python",
            "env": {"MPLBACKEND": "module://matplotlib_inline.backend_inline",
                    # tqdm.auto, imported by the library's progress bars (shown or not), warns
                    # "IProgress not found" in a kernel without ipywidgets, with the path of the
                    # building machine's tqdm; the site has no widgets to show anyway.
                    "PYTHONWARNINGS": "ignore:IProgress not found"}}
    (spec_dir / "kernel.json").write_text(json.dumps(spec))
    return str(root)


os.environ["JUPYTER_PATH"] = os.pathsep.join(filter(None, [_kernel_for_this_interpreter(),
                                                            os.environ.get("JUPYTER_PATH")]))

# -- HTML ----------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"impactosc {release}"
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_show_sourcelink = False
# Pages without sub-pages: no empty "Section Navigation" column beside them.
html_sidebars = {page: [] for page in ("install", "gallery", "theory", "architecture", "changelog")}
html_static_path = ["_static"]
html_css_files = ["gallery.css", "site.css"]

# -- known defects outside docs/ -------------------------------------------------------------
# Each entry drops exactly one kind of warning at one place (see _ext/knownwarnings.py). They
# are defects in files other people are editing now; fix the file, then delete the entry
# (the build says so when an entry no longer matches anything).
known_warnings: list[tuple[str, str]] = []

