"""The documentation site builds without a warning, documents every public name, shows the
notebooks with their outputs, and has no broken internal link.

The site is built once for this module, as ``make docs`` builds it: ``sphinx-build -W
--keep-going`` with nitpicky cross-references, the notebooks executed in quick mode. That
build is where ``make test`` runs the notebooks (tests/test_notebooks.py checks that they
match their sources; their outputs are checked here, in the executed copies myst-nb writes
next to the site), so they are executed once, not twice.
"""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

pytest.importorskip("sphinx")
pytest.importorskip("myst_nb")
pytest.importorskip("numpydoc")
pytest.importorskip("pydata_sphinx_theme")
nbformat = pytest.importorskip("nbformat")

import impactosc  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]-*.ipynb"))
BUILD_TIMEOUT = 1800  # s; the build takes about a minute, most of it running the notebooks

sys.path.insert(0, str(DOCS / "_ext"))
import apipages  # noqa: E402
import apitopics  # noqa: E402  (the topics of the API reference: conf.py's api_topics)

# Figures wider than this (in CSS pixels: the PNG's width, or the width it is displayed at)
# are shrunk into the page's column (~730 px) until their labels are unreadable: a 9-inch
# figure at the inline backend's 100 dpi, with its tight bounding box.
MAX_FIGURE_WIDTH = 920
# The notebook whose subject includes the sweeps' progress bar (the others must not leave one).
SHOWS_PROGRESS_BARS = ("04-sweeps-at-scale",)


@dataclass
class Site:
    html: Path
    executed: Path  # the executed notebooks (myst-nb's jupyter_execute folder)
    returncode: int
    output: str
    warnings: str
    seconds: float


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Site:
    out = tmp_path_factory.mktemp("docs")
    scratch = out / "tmp"
    scratch.mkdir()
    env = dict(os.environ, IMPACTOSC_QUICK="1", TMPDIR=str(scratch))  # the notebooks' stores land in TMPDIR
    env.pop("IMPACTOSC_DOCS_EXECUTE", None)
    warnings = out / "warnings.txt"
    cmd = [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", "-w", str(warnings),
           "-d", str(out / "doctrees"), str(DOCS), str(out / "html")]
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=BUILD_TIMEOUT)
    seconds = time.perf_counter() - start
    print(f"docs build: {seconds:.1f} s")
    return Site(out / "html", out / "jupyter_execute", proc.returncode, proc.stdout + proc.stderr,
                warnings.read_text() if warnings.exists() else "", seconds)


def test_site_builds_without_warnings(site):
    assert site.warnings.strip() == "", "the docs build warned:\n" + site.warnings
    assert site.returncode == 0, site.output[-5000:]
    assert (site.html / "index.html").exists()


# -- the API reference ---------------------------------------------------------------------
def _has_target(page: Path, target: str) -> bool:
    return f'id="{target}"' in page.read_text(encoding="utf-8")


def test_every_name_in_all_has_a_page(site):
    missing = []
    for name in impactosc.__all__:
        page, anchor = apipages.documented_at("impactosc", name)
        path = site.html / f"{page}.html"
        if not path.exists() or not _has_target(path, anchor):
            missing.append(name)
    assert not missing, f"no API page documents impactosc.{{{', '.join(missing)}}}"
    package_page = (site.html / "api" / "generated" / "impactosc.html").read_text(encoding="utf-8")
    for name in impactosc.__all__:
        page, anchor = apipages.documented_at("impactosc", name)
        assert re.search(rf'href="[./a-z]*{re.escape(page.rsplit("/", 1)[1])}\.html', package_page), (
            f"the package page does not list {name}")


def _module_pages(site) -> list[Path]:
    """The package's page and every module's page."""
    return [site.html / "api" / "generated" / "impactosc.html",
            *(site.html / "api" / "modules" / f"{m}.html"
              for m in apipages.documented_modules(apitopics.TOPICS, apitopics.INTERNAL))]


def test_every_documented_module_and_its_names_have_pages(site):
    modules = apipages.documented_modules(apitopics.TOPICS, apitopics.INTERNAL)
    assert {"impactosc.model", "impactosc.results", "impactosc.backends.heyoka", "impactosc.dynamics"} <= set(modules)
    missing = []
    for modname in modules:
        if not (site.html / "api" / "modules" / f"{modname}.html").exists():
            missing.append(modname)
            continue
        for name in apipages.public_names(importlib.import_module(modname)):
            page, anchor = apipages.documented_at(modname, name)
            path = site.html / f"{page}.html"
            if not path.exists() or not _has_target(path, anchor):
                missing.append(f"{modname}.{name}")
    assert not missing, f"no API page for: {', '.join(missing)}"


def test_internals_have_no_pages_and_are_not_in_the_index(site):
    index = (site.html / "api" / "index.html").read_text(encoding="utf-8")
    for modname in apitopics.INTERNAL:
        assert not (site.html / "api" / "modules" / f"{modname}.html").exists(), modname
        assert f"{modname}.html" not in index and f'href="#module-{modname}"' not in index, modname


def test_api_index_is_by_topic_and_every_entry_has_a_description(site):
    text = (site.html / "api" / "index.html").read_text(encoding="utf-8")
    home = apipages.assign_topics(apipages.public_modules(), apitopics.TOPICS, apitopics.INTERNAL)
    for topic in apitopics.TOPICS:
        if topic["title"] in home.values():
            assert f">{topic['title']}<" in text, f"no section {topic['title']!r} in the API index"
    for modname in home:
        assert f"module-{modname}" in text or f"{modname}.html" in text, f"the API index does not list {modname}"
    # Every row of every table: a name and a description.
    rows = re.findall(r"<tr[^>]*>\s*<td><p>(.*?)</p></td>\s*<td><p>(.*?)</p></td>", text, flags=re.S)
    assert len(rows) > 50
    empty = [re.sub(r"<[^>]+>", "", name) for name, desc in rows if not re.sub(r"<[^>]+>", "", desc).strip()]
    assert not empty, f"API index entries without a description: {empty}"
    for page in _module_pages(site):
        headings = re.findall(r'<p class="rubric">(.*?)</p>', page.read_text(encoding="utf-8"), flags=re.S)
        assert all("<code" not in h for h in headings), f"{page.name}: code in a rubric heading (it breaks the line)"


def test_api_titles_are_short_names_and_summaries_whole_sentences(site):
    """A name's page is titled by the name itself (the dotted path is on its signature line),
    so no title runs out of the column; no table summary ends at an abbreviation."""
    page = site.html / "api" / "generated" / "impactosc.dynamics.continuation.SpecialPoint.html"
    title = re.search(r"<h1>(.*?)<a class=\"headerlink\"", page.read_text(encoding="utf-8"), flags=re.S)
    assert title and re.sub(r"<[^>]+>", "", title.group(1)).strip() == "SpecialPoint"
    cut = []
    for page in [site.html / "api" / "index.html", *_module_pages(site)]:
        text = page.read_text(encoding="utf-8")
        for desc in re.findall(r"<tr[^>]*>\s*<td><p>.*?</p></td>\s*<td><p>(.*?)</p></td>", text, flags=re.S):
            desc = re.sub(r"<[^>]+>", "", desc).strip()
            if re.search(r"\b(eq|Eq|eqs|Fig|Figs|fig|sec|ch)\.$", desc):
                cut.append(f"{page.name}: {desc}")
    assert not cut, f"summaries cut at an abbreviation: {cut[:5]}"


def test_a_public_module_without_a_topic_stops_the_build():
    modules = apipages.public_modules()
    apipages.assign_topics(modules, apitopics.TOPICS, apitopics.INTERNAL)  # today's package: covered
    with pytest.raises(apipages.TopicError, match=r"in no topic.*impactosc\.brand_new"):
        apipages.assign_topics([*modules, "impactosc.brand_new"], apitopics.TOPICS, apitopics.INTERNAL)
    # A new module of a documented subpackage is documented in its parent's topic, without an
    # edit of the topics; one of an internal module is internal.
    home = apipages.assign_topics([*modules, "impactosc.model.brand_new", "impactosc.dynamics.brand_new.deeper",
                                   "impactosc.runner.brand_new"], apitopics.TOPICS, apitopics.INTERNAL)
    assert home["impactosc.model.brand_new"] == "Simulation"
    assert home["impactosc.dynamics.brand_new.deeper"] == "Dynamics toolkit"
    assert "impactosc.runner.brand_new" not in home
    with pytest.raises(apipages.TopicError, match="not a public module"):
        apipages.assign_topics(modules, [*apitopics.TOPICS, {"title": "x", "blurb": "", "modules": ["impactosc.gone"]}],
                               apitopics.INTERNAL)
    # A pending module (the continuation subpackage) is documented once it exists.
    home = apipages.assign_topics([*modules, "impactosc.dynamics.continuation"], apitopics.TOPICS, apitopics.INTERNAL)
    assert home["impactosc.dynamics.continuation"] == "Continuation and bifurcations"


def test_command_line_page_shows_every_subcommand(site):
    from impactosc.cli import build_parser

    text = (site.html / "api" / "cli.html").read_text(encoding="utf-8")
    table = text.split("<table", 1)[1].split("</table>", 1)[0] if "<table" in text else ""
    subcommands = apipages._subcommands(build_parser())  # the registry, not a list written here
    assert {"simulate", "sweep", "paper", "demo", "bifurcation", "orbit", "onset", "chart"} <= set(subcommands)
    for sub in subcommands:
        assert f"impactosc {sub}" in text, f"the command-line page lacks impactosc {sub}"
        assert f'id="impactosc-{sub}"' in text, f"the command-line page has no section for impactosc {sub}"
        assert f'href="#impactosc-{sub}"' in table, f"the command-line page's table does not list impactosc {sub}"


# -- the front pages --------------------------------------------------------------------------
def _pictures(page: Path) -> list[str]:
    return re.findall(r'<img[^>]+src="([^"]+)"', page.read_text(encoding="utf-8"))


def test_landing_page_shows_the_whole_library_with_a_picture_each(site):
    page = site.html / "index.html"
    text = page.read_text(encoding="utf-8")
    assert impactosc.__version__ in text
    n_notebooks = len(NOTEBOOKS)
    assert f"{n_notebooks} notebooks" in text
    for capability in ("Simulation", "Backends", "model family", "Dynamics toolkit", "Bifurcations", "Sweeps",
                       "Signal analysis", "paper reproduced", "Command line"):
        assert capability in text, f"the landing page does not mention {capability!r}"
    cards = re.findall(r'class="sd-card[^"]*gallery-card', text)
    pictures = [src for src in _pictures(page) if "_images/" in src]
    assert len(cards) >= 9 and len(pictures) >= len(cards), (len(cards), len(pictures))
    for src in pictures:
        assert (page.parent / src).stat().st_size > 5000, f"{src} is not a figure"


def _readme_tour() -> list[str]:
    """The code lines of the README's short tour (its first Python block)."""
    block = re.search(r"## A short tour\s+```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    assert block, "the README has no short tour"
    return [line for line in block.group(1).splitlines() if line.strip()]


def test_landing_page_shows_the_readme_tour_and_every_way_on(site):
    import html as html_lib

    page = (site.html / "index.html").read_text(encoding="utf-8")
    code = html_lib.unescape(re.sub(r"<[^>]+>", "", page))
    for line in _readme_tour():
        assert line in code, f"the landing page lacks the README tour's line {line!r}"
    where = page.split('id="where-to-go-next"')[1]
    for topic in ("continuation", "theory.html", "api/cli.html", "tutorials.html", "install.html"):
        assert topic in where, f"'Where to go next' does not lead to {topic}"


def test_gallery_shows_every_figure_of_the_notebooks(site):
    page = site.html / "gallery.html"
    figures = 0
    for path in NOTEBOOKS:
        nb = nbformat.read(site.executed / "notebooks" / path.name, as_version=4)
        figures += sum("image/png" in o.get("data", {}) for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    assert len([s for s in _pictures(page) if "_images/" in s]) == figures
    assert all(f'href="notebooks/{p.stem}.html"' in page.read_text(encoding="utf-8") for p in NOTEBOOKS)


def test_install_page_explains_every_extra_and_the_make_targets(site):
    import tomllib

    html = (site.html / "install.html").read_text(encoding="utf-8")
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    for extra in extras:  # a row of the table of extras
        row = rf'<tr[^>]*>\s*<td><p><code[^>]*><span class="pre">{extra}</span></code></p></td>'
        assert re.search(row, html), f"the install page does not explain the extra {extra!r}"
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", "", html))
    for target in ("make test", "make test-fast", "make demo", "make docs"):
        assert target in text, target
    assert impactosc.__version__ in text and "whl" in text
    # the command to paste names the wheel that `python -m build` writes
    assert f"dist/impactosc-{impactosc.__version__}-py3-none-any.whl[fast,plot]" in text


def test_no_page_shows_an_unreplaced_substitution(site):
    pages = [p for p in site.html.rglob("*.html") if p.relative_to(site.html).parts[0] not in ("_static", "_modules")]
    shown = []
    for page in pages:
        text = re.sub(r"<[^>]+>", "", page.read_text(encoding="utf-8"))
        found = re.search(r"\{\{\s*\w+\s*\}\}", text)
        if found:
            shown.append(f"{page.relative_to(site.html)}: {found.group(0)}")
    assert not shown, shown


def test_math_is_served_by_the_site(site):
    text = (site.html / "theory.html").read_text(encoding="utf-8")
    scripts = re.findall(r'<script[^>]+src="([^"]+)"', text)
    mathjax = [s for s in scripts if "mathjax" in s.lower() or "tex-" in s]
    assert mathjax, "no MathJax on the theory page"
    for src in mathjax:
        assert not urlsplit(src).scheme and not src.startswith("//"), f"MathJax from the network: {src}"
        assert (site.html / src.split("?")[0]).exists()


def test_architecture_page_is_in_the_navigation(site):
    assert 'href="architecture.html"' in (site.html / "index.html").read_text(encoding="utf-8")


# -- the notebooks ---------------------------------------------------------------------------
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


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_ran_in_quick_mode_with_outputs(site, path):
    """Every cell ran; every cell that prints or shows a figure produced it; quick mode."""
    executed = site.executed / "notebooks" / path.name
    assert executed.exists(), f"{path.name} was not executed by the docs build"
    nb = nbformat.read(executed, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert len(code) == sum(c.cell_type == "code" for c in nbformat.read(path, as_version=4).cells)
    failed = [i for i, c in enumerate(code) if any(o.output_type == "error" for o in c.outputs)]
    assert not failed, f"code cells {failed} of {path.name} failed (traceback under the build's reports/)"
    missing = []
    for i, cell in enumerate(code):
        lacking = _expected_outputs(cell.source) - _produced(cell)
        if lacking:
            missing.append(f"code cell {i} ({cell.source.splitlines()[0]!r}) produced no {', '.join(sorted(lacking))}")
    assert not missing, f"{path.name}:\n" + "\n".join(missing)
    first_out = "".join(o.get("text", "") for o in code[0].outputs if o.output_type == "stream")
    assert "quick mode" in first_out, f"{path.name} did not run in quick mode: {first_out!r}"
    n_images = sum("image" in _produced(c) for c in code)
    assert n_images >= 2, f"{path.name} showed only {n_images} figure(s)"


def _png_width(data: str) -> int:
    import base64
    import struct

    return struct.unpack(">I", base64.b64decode(data)[16:20])[0]


@pytest.mark.parametrize("stem", [p.stem for p in NOTEBOOKS])
def test_notebook_figures_fit_the_column_and_no_progress_bar_or_warning_is_left(site, stem):
    nb = nbformat.read(site.executed / "notebooks" / f"{stem}.ipynb", as_version=4)
    wide, bars, warned = [], [], []
    for i, cell in enumerate(c for c in nb.cells if c.cell_type == "code"):
        for out in cell.outputs:
            data = out.get("data", {})
            if "image/png" in data:
                shown = out.get("metadata", {}).get("image/png", {}).get("width")
                width = int(shown) if shown else _png_width(data["image/png"])
                if width > MAX_FIGURE_WIDTH:
                    wide.append(f"code cell {i}: {width} px")
            if out.output_type == "stream" and re.search(r"\d+%\|", out.text) and stem not in SHOWS_PROGRESS_BARS:
                bars.append(f"code cell {i}: {out.text.splitlines()[0][:80]!r}")
            # a warning on the page shows the building machine's paths and tells the reader nothing
            if out.output_type == "stream" and re.search(r"\w+Warning:", out.text):
                warned.append(f"code cell {i}: {re.search(r'.*Warning:.*', out.text).group(0)[:120]!r}")
    assert not wide, f"{stem}: figures wider than {MAX_FIGURE_WIDTH} px: {wide}"
    assert not bars, f"{stem}: progress bars on the page: {bars}"
    assert not warned, f"{stem}: warnings on the page: {warned}"


def test_continuation_summaries_fit_the_page(site):
    """The branch summaries of the continuation notebook are printed wrapped: no line runs
    past the output column (~90 characters) to be cut off."""
    nb = nbformat.read(site.executed / "notebooks" / "08-continuation.ipynb", as_version=4)
    printed = [line for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs
               if out.output_type == "stream" for line in out.text.splitlines()]
    assert any(line.startswith("branch of period-1 orbits") for line in printed)
    long = [line for line in printed if len(line) > 90]
    assert not long, f"{len(long)} lines longer than 90 characters, e.g. {long[0][:120]!r}"


def test_markdown_outputs_are_rendered_not_shown_as_text(site):
    """A notebook's Markdown output (a table) is rendered: no ``| --- |`` line in any output."""
    tables = 0
    for path in NOTEBOOKS:
        html = (site.html / "notebooks" / f"{path.stem}.html").read_text(encoding="utf-8")
        for piece in html.split('class="cell_output')[1:]:
            output = re.sub(r"<[^>]+>", "", piece.split('class="cell_input')[0])
            assert not re.search(r"\|\s*:?-{3,}:?\s*\|", output), f"{path.name}: a Markdown table shown as text"
            tables += piece.split('class="cell_input')[0].count("<table")
    assert tables >= 2, "no notebook output table was rendered"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_page_shows_its_outputs(site, path):
    page = site.html / "notebooks" / f"{path.stem}.html"
    assert page.exists(), f"no page for {path.name}"
    text = page.read_text(encoding="utf-8")
    assert "cell_output" in text, f"the page of {path.name} has no cell output"
    assert len(re.findall(r'<img[^>]+src="\.\./_images/', text)) >= 2, f"the page of {path.name} shows no figures"
    assert (site.html / "tutorials.html").read_text(encoding="utf-8").count(f'href="notebooks/{path.stem}.html') >= 1


# -- pages read from the repository -----------------------------------------------------------
def test_report_and_benchmark_pages_are_the_repository_files(site):
    pages = {"reports/paper_reproduction": ROOT / "reports" / "paper_reproduction.md",
             "benchmarks/README": ROOT / "benchmarks" / "README.md"}
    pages.update({f"benchmarks/results/{p.stem}": p for p in (ROOT / "benchmarks" / "results").glob("*.md")})
    assert len(pages) >= 4
    for docname, source in pages.items():
        page = site.html / f"{docname}.html"
        assert page.exists(), f"no page for {source.relative_to(ROOT)}"
        title = next(line for line in source.read_text().splitlines() if line.startswith("# "))[2:]
        words = re.findall(r"\w+", title)
        assert all(w in page.read_text(encoding="utf-8") for w in words), f"{docname}.html lacks its title {title!r}"


def test_theory_page_covers_the_model(site):
    text = (site.html / "theory.html").read_text(encoding="utf-8")
    for heading in ("The model", "the modes", "Guards and events", "The stick test", "The energy identity",
                    "What each backend guarantees"):
        assert heading in text
    assert "one-sided stop" in text and "gap_lower=None" in text


def test_theory_page_covers_the_dynamics(site):
    text = (site.html / "theory.html").read_text(encoding="utf-8")
    for heading in ("Dynamics: periodic orbits, stability and bifurcations", "The stroboscopic map",
                    "Shooting and saltation matrices", "Floquet multipliers", "Pseudo-arclength continuation",
                    "Special points and their test functions", "Grazing and its square-root singularity"):
        assert f"{heading}<a class=\"headerlink\"" in text, f"the theory page has no section {heading!r}"
    for label in ("LP", "BP", "PD", "NS", "GR", "ST", "SC"):  # every kind of special point
        assert f"<td><p>{label}</p></td>" in text, label


# -- links -------------------------------------------------------------------------------------
class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if attrs.get("id"):
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("href"):
            self.links.append(attrs["href"])
        elif tag in ("img", "script") and attrs.get("src"):
            self.links.append(attrs["src"])
        elif tag == "link" and attrs.get("href"):
            self.links.append(attrs["href"])


def test_internal_links_resolve(site):
    """Every relative link of every page reaches a file, and its #fragment an element id."""
    parsed: dict[Path, _Links] = {}

    def parse(page: Path) -> _Links:
        if page not in parsed:
            parser = _Links()
            parser.feed(page.read_text(encoding="utf-8"))
            parsed[page] = parser
        return parsed[page]

    pages = sorted(p for p in site.html.rglob("*.html") if p.relative_to(site.html).parts[0] != "_static")
    assert len(pages) > 50
    broken = []
    for page in pages:
        rel_page = page.relative_to(site.html).as_posix()
        for link in parse(page).links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "javascript:")):
                continue  # external: not checked (no network in CI)
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                broken.append(f"{rel_page}: {link} (no such file)")
            elif parts.fragment and target.suffix == ".html" and unquote(parts.fragment) not in parse(target).ids:
                broken.append(f"{rel_page}: {link} (no such anchor)")
    assert not broken, f"{len(broken)} broken internal links:\n" + "\n".join(broken[:50])


# -- the build's strictness ----------------------------------------------------------------------
def _scratch_build(tmp_path: Path, known: list) -> subprocess.CompletedProcess:
    src = tmp_path / "src"
    src.mkdir(parents=True)
    (src / "conf.py").write_text(
        f"import sys\nsys.path.insert(0, {str(DOCS / '_ext')!r})\n"
        "extensions = ['sphinx.ext.autodoc', 'knownwarnings']\nnitpicky = True\n"
        f"known_warnings = {known!r}\n")
    (src / "index.rst").write_text("Scratch\n=======\n\nSee :func:`no_such_function` and :doc:`no_such_page`.\n")
    return subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", str(src),
                           str(tmp_path / "out")], capture_output=True, text=True, timeout=300)


def test_a_broken_reference_fails_the_build_and_known_warnings_are_narrow(tmp_path):
    failed = _scratch_build(tmp_path / "a", [])
    assert failed.returncode != 0 and "no_such_function" in failed.stderr and "no_such_page" in failed.stderr
    # An entry drops the one warning it matches, and only that one.
    still = _scratch_build(tmp_path / "b", [(r"index\.rst:", r"target not found: no_such_function")])
    assert still.returncode != 0 and "no_such_function" not in still.stderr and "no_such_page" in still.stderr
    both = _scratch_build(tmp_path / "c", [(r"index\.rst:", "no_such_function"), (r"index\.rst:", "no_such_page")])
    assert both.returncode == 0, both.stderr


def test_a_gallery_card_without_its_figure_fails_the_build(tmp_path):
    """A card whose notebook, tag or figure cannot be found is a warning, so -W fails the build."""
    src = tmp_path / "src"
    (src / "notebooks").mkdir(parents=True)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# A notebook"), nbformat.v4.new_code_cell("x = 1")]
    nb.cells[1].metadata["tags"] = ["gallery"]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(nb, src / "notebooks" / "01-x.ipynb")
    (src / "conf.py").write_text(
        f"import sys\nsys.path.insert(0, {str(DOCS / '_ext')!r})\n"
        "extensions = ['myst_nb', 'gallery']\nnb_execution_mode = 'off'\n")
    (src / "index.md").write_text(
        "# Scratch\n\n````{grid} 1\n\n"
        "```{notebook-card} notebooks/01-x\n:title: no figure\n:tag: gallery\nText\n```\n\n"
        "```{notebook-card} notebooks/02-missing\n:title: no notebook\n:tag: gallery\nText\n```\n````\n\n"
        "```{toctree}\nnotebooks/01-x\n```\n")
    out = subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", str(src),
                          str(tmp_path / "out" / "html")], capture_output=True, text=True, timeout=300)
    assert out.returncode != 0
    assert "has no figure output" in out.stderr and "no document 'notebooks/02-missing'" in out.stderr, out.stderr
