"""Sphinx extension: the API reference of impactosc, generated from the package itself.

No name is listed by hand, so a name added to the package appears in the documentation
without editing ``docs/``. What ``conf.py`` lists is the *topics*: ``api_topics``, each a
title, a sentence and the public modules it covers, and ``api_internal``, the public-looking
modules that are internals of the library (documented on the architecture page, not in the
reference). A new module of a documented subpackage takes its parent's topic; a public
module (no part of its dotted name starts with ``_``) left in no topic and not internal (a
new subpackage of the package itself) stops the build: it cannot be left out silently. A
topic's ``pending`` modules (``fnmatch`` patterns) are documented once they exist.

What this extension writes, and what it leaves to ``sphinx.ext.autosummary``:

* ``api/index.rst`` (written here): the reference's front page, one section per topic: an
  autosummary table of its modules, whose ``:toctree:`` makes autosummary write each
  module's page from ``_templates/autosummary/module.rst`` (and puts them in the navigation
  under the topic's title), then each module's names, each with its first sentence;
* ``api/generated/<module>.rst`` (autosummary): a module's page. The template lists the
  names documented there in a table whose ``:toctree:`` has autosummary write a page per
  name (``class.rst``, ``base.rst``), and links to the others. What each page lists is
  computed here (``autosummary_context["api_pages"]``, :func:`page_context`): a name
  re-exported at the top level is documented once, as ``impactosc.<name>``, and a name a
  subpackage re-exports from a public submodule once, with that submodule;
* ``api/cli.rst`` (written here): the command line's subcommands and their ``--help``, read
  from its parser (the docs extra has no argparse extension).

The files are written when the configuration is read, before autosummary scans the sources
for its stubs, and are git-ignored. Stale pages of removed names are deleted first.

A name re-exported at the top level is documented once, as ``impactosc.<name>``. The
``missing-reference`` handler sends references written in the package's docstrings and type
hints as ``Oscillator``, ``impactosc.model.Oscillator`` or ``Oscillator.net_force`` to that
page, the way Python resolves them.
"""

from __future__ import annotations
import __future__

import argparse
import fnmatch
import functools
import importlib
import inspect
import pkgutil
import shutil
import types
from pathlib import Path

from numpydoc.docscrape import NumpyDocString
from sphinx.application import Sphinx
from sphinx.errors import ExtensionError, PycodeError
from sphinx.ext.autosummary.generate import AutosummaryRenderer
from sphinx.pycode import ModuleAnalyzer
from sphinx.util import logging as sphinx_logging

logger = sphinx_logging.getLogger(__name__)

PACKAGE = "impactosc"
GENERATED = Path("api", "generated")
MODULES = Path("api", "modules")
MODULE_TEMPLATE = "autosummary/module.rst"  # in docs/_templates
CLI_PAGE = Path("api", "cli.rst")
INDEX_PAGE = Path("api", "index.rst")


# -- what is public ------------------------------------------------------------------------
def public_modules(package: str = PACKAGE) -> list[str]:
    """Dotted names of the public submodules of ``package``, sorted."""
    pkg = importlib.import_module(package)
    names = []
    for info in pkgutil.walk_packages(pkg.__path__, prefix=package + "."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return sorted(names)


def public_names(module: types.ModuleType) -> list[str]:
    """``module.__all__``, or, without one, the public names the module itself defines."""
    if hasattr(module, "__all__"):
        return list(module.__all__)
    names = []
    for name, obj in vars(module).items():
        if name.startswith("_") or inspect.ismodule(obj) or isinstance(obj, __future__._Feature):
            continue
        defined_in = getattr(obj, "__module__", module.__name__)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            if defined_in != module.__name__:
                continue  # imported from elsewhere
        names.append(name)
    return names


def toplevel_names(package: str = PACKAGE) -> list[str]:
    """``impactosc.__all__``: the names documented as ``impactosc.<name>``."""
    return list(importlib.import_module(package).__all__)


def _reexported(module: types.ModuleType, name: str, top: types.ModuleType) -> bool:
    """True when ``module.name`` is the very object documented as ``impactosc.name``."""
    return name in top.__all__ and getattr(top, name, None) is getattr(module, name, None)


def _public_home(dotted: str) -> str:
    """The public module a dotted module name belongs to: ``a.b._c._d`` -> ``a.b``."""
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        if part.startswith("_"):
            return ".".join(parts[:i])
    return dotted


def _from_submodule(module: types.ModuleType, name: str) -> str | None:
    """For a subpackage (``impactosc.dynamics``) re-exporting ``name`` from one of its public
    submodules (``impactosc.dynamics.shooting``, or a subpackage such as
    ``impactosc.dynamics.continuation`` that defines it in a private module of its own), that
    submodule's dotted name: the object is documented there, once."""
    if not hasattr(module, "__path__"):
        return None
    home = getattr(getattr(module, name, None), "__module__", None)
    if not isinstance(home, str):
        return None
    home = _public_home(home)
    if home.startswith(module.__name__ + ".") and name in public_names(importlib.import_module(home)):
        return home
    return None


# -- topics ----------------------------------------------------------------------------------
class TopicError(ValueError):
    """The topics of ``conf.py`` do not cover the package's public modules exactly."""


def _topic_modules(topic: dict) -> tuple[list[str], list[str]]:
    return list(topic.get("modules", ())), list(topic.get("pending", ()))


def assign_topics(modules: list[str], topics: list[dict], internal: list[str],
                  package: str = PACKAGE) -> dict[str, str]:
    """Public module -> the title of its topic, for every module of ``modules`` not internal.

    A module that no topic lists takes the topic of its nearest ancestor below the package
    (``impactosc.model.hybrid`` that of ``impactosc.model``), or is internal with an internal
    ancestor: a new module of a documented subpackage is documented without an edit here.
    Raises `TopicError` naming every public module left without a topic (a new subpackage of
    the package itself must be given one, or be listed as internal), every module that two
    topics claim, and every module a topic lists (not as pending) that does not exist.
    """
    existing = set(modules) | {package}
    home: dict[str, str] = {}
    problems = []
    for topic in topics:
        listed, pending = _topic_modules(topic)
        for modname in listed:
            if modname not in existing:
                problems.append(f"topic {topic['title']!r} lists {modname}, which is not a public module")
        matched = [m for m in sorted(existing) if m in listed or any(fnmatch.fnmatchcase(m, pat) for pat in pending)]
        for modname in matched:
            if modname in home:
                problems.append(f"{modname} is in two topics: {home[modname]!r} and {topic['title']!r}")
            home[modname] = topic["title"]
    for modname in internal:
        if modname in home:
            problems.append(f"{modname} is internal and in topic {home[modname]!r}")
    explicit = dict(home)
    for modname in sorted(existing - set(home) - set(internal)):
        parts = modname.split(".")
        for i in range(len(parts) - 1, 1, -1):  # its ancestors, nearest first, the package excluded
            ancestor = ".".join(parts[:i])
            if ancestor in internal:
                break  # an internal module's submodule is internal too
            if ancestor in explicit:
                home[modname] = explicit[ancestor]
                break
    orphans = sorted(m for m in existing - set(home) - set(internal)
                     if not any(m.startswith(i + ".") for i in internal))
    if orphans:
        problems.append("public modules in no topic of docs/conf.py's api_topics (give each a topic, or "
                        "list it in api_internal if it is not for users): " + ", ".join(orphans))
    if problems:
        raise TopicError("; ".join(problems))
    return home


def documented_modules(topics: list[dict], internal: list[str], package: str = PACKAGE) -> list[str]:
    """The public modules that have a page: every module of every topic (sorted)."""
    home = assign_topics(public_modules(package), topics, internal, package)
    return sorted(m for m in home if m != package)


# -- the pages -----------------------------------------------------------------------------
def _title(text: str) -> str:
    return f"{text}\n{'=' * len(text)}\n"


def _autosummary(names: list[str], toctree: str | None = None, caption: str | None = None) -> str:
    lines = [".. autosummary::"]
    if toctree is not None:
        lines.append(f"   :toctree: {toctree}")
    if caption is not None:
        lines.append(f"   :caption: {caption}")
    lines.append("   :nosignatures:")
    lines.append("")
    lines.extend(f"   {name}" for name in names)
    return "\n".join(lines) + "\n"


def documented_at(modname: str, name: str, package: str = PACKAGE) -> tuple[str, str]:
    """``(page, anchor)`` of ``modname.name`` in the built site (page relative, no suffix).

    A re-exported object is documented once, as ``impactosc.<name>``; a module (a name in
    ``__all__`` may be one) on its module page; anything else on its own page.
    """
    module, top = importlib.import_module(modname), importlib.import_module(package)
    obj = getattr(module, name)
    if inspect.ismodule(obj):
        return f"{MODULES.as_posix()}/{obj.__name__}", f"module-{obj.__name__}"
    if modname == package or _reexported(module, name, top):
        return f"{GENERATED.as_posix()}/{package}.{name}", f"{package}.{name}"
    home = _from_submodule(module, name)
    if home is not None:
        return documented_at(home, name, package)
    return f"{GENERATED.as_posix()}/{modname}.{name}", f"{modname}.{name}"


def page_context(modname: str, package: str = PACKAGE) -> dict:
    """What the page of module ``modname`` lists (read by ``_templates/autosummary/module.rst``).

    ``own``: the names documented on pages of their own from here (for the package, all of
    ``__all__``); ``modules``: the modules its ``__all__`` names; ``toplevel``: the names it
    shares with the package, documented as ``impactosc.<name>``; ``from_submodules``: the
    names a subpackage re-exports from one of its public submodules, documented there
    (written relative to ``modname``, as autosummary wants them).
    """
    module, top = importlib.import_module(modname), importlib.import_module(package)
    names = public_names(module)
    modules = [n for n in names if inspect.ismodule(getattr(module, n, None))]
    objects = [n for n in names if n not in modules]
    if modname == package:
        own, shared, homes = objects, [], {}
    else:
        homes = {n: _from_submodule(module, n) for n in objects}
        own = [n for n in objects if not _reexported(module, n, top) and homes[n] is None]
        shared = [n for n in objects if _reexported(module, n, top)]
    # ``impactosc.<x>`` may be a module *and* a function the package re-exports under the same
    # dotted name: registering the module as well would be a duplicate object description.
    shadowed = modname.count(".") == 1 and not inspect.ismodule(getattr(top, modname.rsplit(".", 1)[-1], module))
    return {"fullname": modname, "package": modname == package, "top": package, "own": own,
            # where autosummary writes the pages of the names documented here
            "toctree": "." if modname == package else f"../{GENERATED.name}", "modules": modules, "toplevel": shared,
            "from_submodules": [f"~{homes[n][len(modname) + 1:]}.{n}" for n in objects
                                if homes.get(n) is not None and n not in shared],
            "no_index": shadowed}


def _first_line(text: str | None) -> str:
    return next((line.strip() for line in (text or "").strip().splitlines() if line.strip()), "")


def description(modname: str, name: str | None = None) -> str:
    """The first line of the documentation of module ``modname`` or of its ``name``: the text
    of the reference's tables ("" when there is none)."""
    module = importlib.import_module(modname)
    if name is None:
        return _first_line(module.__doc__)
    obj = getattr(module, name)
    if inspect.isclass(obj) or inspect.isroutine(obj) or inspect.ismodule(obj):
        return _first_line(inspect.getdoc(obj))
    return _first_line(" ".join(_doc_comment(obj, name)))


def names_documented_here(modname: str, package: str = PACKAGE) -> list[str]:
    """The names whose documentation is on the page of ``modname``: for the package, every
    name of its ``__all__``; for a module, those it neither re-exports at the top level nor
    from a public submodule (its page's "Defined here")."""
    module = importlib.import_module(modname)
    if modname == package:
        return [n for n in public_names(module) if not inspect.ismodule(getattr(module, n, None))]
    top = importlib.import_module(package)
    return [n for n in public_names(module)
            if not inspect.ismodule(getattr(module, n, None)) and not _reexported(module, n, top)
            and _from_submodule(module, n) is None]


def index_page(topics: list[dict], home: dict[str, str], package: str = PACKAGE) -> str:
    """The front page of the reference: per topic, its modules, each with the names
    documented on its page, and a toctree of the topic's pages."""
    parts = [_title("API reference"),
             "Every public module and name of the library, by topic, generated from the docstrings. "
             f"The names of ``{package}.__all__`` are documented once, as ``{package}.<name>`` (under "
             "*Simulation*); modules whose names start with ``_`` and the internals described on the "
             ":doc:`architecture page <../architecture>` are not part of the reference.\n"]
    for topic in topics:
        listed = [m for m in topic.get("modules", ()) if home.get(m) == topic["title"]]
        modules = listed + sorted(m for m in home if home[m] == topic["title"] and m not in listed)
        if not modules:
            continue  # a topic whose modules are all pending
        parts.append(_title(topic["title"]).replace("=", "-"))
        parts.append(topic["blurb"].strip() + "\n")
        for modname in modules:
            # Each table in its module's context: the summaries' references are written relative to it.
            parts.append(f".. currentmodule:: {modname}\n")
            summary = description(modname)
            if summary.lower().startswith(modname.rsplit(".", 1)[-1] + ":"):  # "impactosc: event-driven ..."
                summary = summary.split(":", 1)[1].strip()
            parts.append(f":mod:`{modname}`: {summary}\n")
            names = names_documented_here(modname, package)
            if names:
                parts.append(_autosummary(names, toctree=None))
        pages = [f"generated/{package}" if m == package else f"modules/{m}" for m in modules]
        pages += list(topic.get("pages", ()))
        parts.append(".. toctree::\n   :hidden:\n   :caption: " + topic["title"] + "\n\n"
                     + "\n".join(f"   {p}" for p in pages) + "\n")
    return "\n".join(parts)


def undocumented(modules: list[str], package: str = PACKAGE) -> list[str]:
    """Modules, classes and functions of ``modules`` (and the package) without a docstring."""
    missing = []
    for modname in [package, *modules]:
        module = importlib.import_module(modname)
        if not description(modname):
            missing.append(modname)
        for name in public_names(module):
            obj = getattr(module, name)
            if (inspect.isclass(obj) or inspect.isroutine(obj)) and not description(modname, name):
                missing.append(f"{modname}.{name}")
    return sorted(set(missing))


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _literal(text: str) -> str:
    body = "\n".join(("   " + line) if line.strip() else "" for line in text.rstrip().splitlines())
    return f".. code-block:: text\n\n{body}\n"


def _build_parser(package: str = PACKAGE) -> argparse.ArgumentParser:
    """The parser of the command line: ``build_parser()`` of ``<package>.cli`` or of the first
    of its modules that defines one (the package keeps it in a private module)."""
    cli = importlib.import_module(f"{package}.cli")
    modules = [cli.__name__]
    modules += [info.name for info in pkgutil.iter_modules(cli.__path__, prefix=cli.__name__ + ".")]
    for modname in modules:
        build = getattr(importlib.import_module(modname), "build_parser", None)
        if callable(build):
            return build()
    raise ImportError(f"no build_parser() in {package}.cli or its modules")


def _subcommand_table(parser: argparse.ArgumentParser, package: str) -> str:
    """A table of the subcommands and their one-line help, each linked to its section."""
    rows = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            rows = [(sub.dest, " ".join((sub.help or "").split())) for sub in action._get_subactions()]
    lines = [".. list-table::", "   :header-rows: 1", "   :widths: 1 4", "", "   * - subcommand", "     - what it does"]
    for name, text in rows:
        lines += [f"   * - :ref:`{package} {name} <{package}-{name}>`", f"     - {text}"]
    return "\n".join(lines) + "\n"


def cli_page(package: str = PACKAGE) -> str:
    """The command line's page: its subcommands in a table, then every ``--help``, read from the parser."""
    parser = _build_parser(package)
    parser.prog = package
    parts = [_title("Command line"),
             f"``{package} <subcommand> [options]``, also ``python -m {package}``. Every subcommand "
             "is listed here from the parser itself, with its ``--help`` below.\n",
             _subcommand_table(parser, package),
             _literal(parser.format_help())]
    for name, sub in _subcommands(parser).items():
        sub.prog = f"{package} {name}"
        parts.append(f".. _{package}-{name}:\n")
        parts.append(_title(f"{package} {name}").replace("=", "-"))
        parts.append(_literal(sub.format_help()))
    return "\n".join(parts)


def write_pages(app: Sphinx, topics: list[dict], internal: list[str], package: str = PACKAGE) -> list[Path]:
    """(Re)write every generated page under the source folder; returns the files written.

    The package's and the modules' pages are ``_templates/autosummary/module.rst`` rendered
    by autosummary's own renderer with :func:`page_context`; their autosummary tables then
    have autosummary write a page per name. Raises `TopicError` when the topics do not cover
    the public modules (see `assign_topics`).
    """
    srcdir = Path(app.srcdir)
    home = assign_topics(public_modules(package), topics, internal, package)
    for folder in (GENERATED, MODULES):  # stale pages of removed names and modules go
        shutil.rmtree(srcdir / folder, ignore_errors=True)
        (srcdir / folder).mkdir(parents=True)
    renderer = AutosummaryRenderer(app)
    written = {srcdir / INDEX_PAGE: index_page(topics, home, package),
               srcdir / GENERATED / f"{package}.rst": renderer.render(MODULE_TEMPLATE, page_context(package, package))}
    for modname in sorted(m for m in home if m != package):
        written[srcdir / MODULES / f"{modname}.rst"] = renderer.render(MODULE_TEMPLATE, page_context(modname, package))
    written[srcdir / CLI_PAGE] = cli_page(package)
    for path, text in written.items():
        path.write_text(text, encoding="utf-8")
    return list(written)


# -- references ----------------------------------------------------------------------------
def _canonical_targets(target: str, module: str | None, cls: str | None, package: str = PACKAGE) -> list[str]:
    """Where ``target`` may be documented when it names a public object another way.

    ``module`` and ``cls`` are the context of the reference (the page's current module and
    class). A docstring of a re-exported object is rendered on its top-level page, where the
    current module is the package, so its own module's names are tried as well.
    """
    top = importlib.import_module(package)
    target = target.lstrip(".~")
    candidates = []
    head = target.partition(".")[0]
    if head in top.__all__:  # ``Oscillator`` or ``Oscillator.net_force``
        candidates.append(f"{package}.{target}")
    if target.startswith(package + "."):  # ``impactosc.model.Oscillator[.method]``
        parts = target.split(".")
        for i in range(2, len(parts)):
            try:
                defining = importlib.import_module(".".join(parts[:i]))
            except ImportError:
                break
            if _reexported(defining, parts[i], top):
                candidates.append(".".join([package, *parts[i:]]))
                break
            home = _from_submodule(defining, parts[i])
            if home is not None:
                candidates.append(".".join([home, *parts[i:]]))
                break
        return candidates
    contexts = [module] if module else []
    if module == package and cls and cls.partition(".")[0] in top.__all__:
        contexts.append(getattr(getattr(top, cls.partition(".")[0]), "__module__", None))
    if module and module.startswith(package + "."):
        # Inside a subpackage (``impactosc.dynamics.onset``), its package's names too.
        parts = module.split(".")
        contexts.extend(".".join(parts[:i]) for i in range(len(parts) - 1, 1, -1))
    candidates.extend(f"{mod}.{target}" for mod in contexts if mod)
    return _subpackage_homes(candidates, package)


def _subpackage_homes(candidates: list[str], package: str) -> list[str]:
    """Each candidate, followed by its home when a subpackage re-exports it from a submodule."""
    out = []
    for dotted in candidates:
        out.append(dotted)
        modname, _, name = dotted.rpartition(".")
        try:
            module = importlib.import_module(modname)
        except ImportError:
            continue
        home = _from_submodule(module, name)
        if home is not None:
            out.append(f"{home}.{name}")
    return out


def _documented_attribute(cls, attr: str) -> bool:
    """True when the numpydoc "Attributes" section of ``cls`` describes ``attr``."""
    try:
        section = NumpyDocString(inspect.getdoc(cls) or "")["Attributes"]
    except Exception:  # a docstring numpydoc cannot parse documents no attribute
        return False
    return any(attr in (name.strip() for name in param.name.split(",")) for param in section)


def resolve_reexports(app: Sphinx, env, node, contnode):
    """Resolve a Python reference that names a public object another way (see the module doc).

    An instance attribute listed in a class's "Attributes" section has no target of its
    own (only properties and methods do): ``Solution.status`` links to the class's page.
    """
    if node.get("refdomain") != "py":
        return None
    domain = env.get_domain("py")
    candidates = _canonical_targets(node["reftarget"], node.get("py:module"), node.get("py:class"))
    for target in candidates:
        found = domain.resolve_any_xref(env, node["refdoc"], app.builder, target, node, contnode)
        if found:
            return found[0][1]
    if node.get("reftype") == "attr":
        for target in candidates:
            owner, _, attr = target.rpartition(".")
            try:
                cls = _import_object(owner)
            except (ImportError, AttributeError):
                continue
            if inspect.isclass(cls) and _documented_attribute(cls, attr):
                found = domain.resolve_any_xref(env, node["refdoc"], app.builder, owner, node, contnode)
                if found:
                    return found[0][1]
    return None


def _import_object(dotted: str):
    """The object at a dotted path such as ``impactosc.Solution``."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for part in parts[i:]:
            obj = getattr(obj, part)
        return obj
    raise ImportError(dotted)


# -- module-level data -----------------------------------------------------------------------
@functools.cache
def _all_modules(package: str = PACKAGE) -> tuple[str, ...]:
    """Every module of the package, private ones included (where constants are defined)."""
    pkg = importlib.import_module(package)
    return (package, *sorted(info.name for info in pkgutil.walk_packages(pkg.__path__, prefix=package + ".")))


def _doc_comment(obj, name: str, package: str = PACKAGE) -> list[str]:
    """The ``#:`` comment above ``name = ...`` in the module that defines ``obj``: the public
    modules first, then the private ones (a constant re-exported by a public module is often
    defined, with its comment, in a private one)."""
    public = [package, *public_modules(package)]
    for modname in [*public, *(m for m in _all_modules(package) if m not in public)]:
        module = importlib.import_module(modname)
        if getattr(module, name, None) is not obj:
            continue
        try:
            comments = ModuleAnalyzer.for_module(modname).find_attr_docs()
        except PycodeError:
            continue
        if ("", name) in comments:
            return list(comments[("", name)])
    return []


def _value_line(obj) -> list[str]:
    text = repr(obj)
    return [f"Value: ``{text if len(text) <= 100 else text[:97] + '...'}``."]


def data_docstring(app: Sphinx, what: str, name: str, obj, options, lines: list[str]) -> None:
    """A constant's documentation is its ``#:`` comment, never its type's docstring.

    autodoc falls back to ``type(obj).__doc__`` for a constant without a comment (a tuple
    would be documented as "Built-in immutable sequence", a dtype with numpy's page), and a
    re-exported constant's comment is in the module that defines it, not in the package.
    A constant without any comment is described by its value (and listed at the end of the
    build, so that it gets one).
    """
    if what not in ("data", "attribute") or inspect.isroutine(obj) or inspect.isclass(obj):
        return
    type_doc = type(obj).__doc__
    type_doc = inspect.cleandoc(type_doc).splitlines() if isinstance(type_doc, str) else []
    if lines and [line.strip() for line in lines if line.strip()] != [t.strip() for t in type_doc if t.strip()]:
        return
    short = name.rsplit(".", 1)[-1]
    lines[:] = _doc_comment(obj, short)
    if not lines and what == "data":
        lines[:] = _value_line(obj)
        _UNCOMMENTED.add(name)


_UNCOMMENTED: set[str] = set()


def _is_internal(target: str, internal: list[str]) -> bool:
    return any(target == mod or target.startswith(mod + ".") for mod in internal)


def internal_reference(app: Sphinx, env, node, contnode):
    """A reference to an internal module (``impactosc.engine``) or one of its names is shown as
    code without a link: those modules have no page (see ``api_internal``). Private names
    (``_``) are not covered: a public docstring must not name them."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip(".~")
    if any(part.startswith("_") for part in target.split(".")):
        return None
    context = (node.get("py:module") or "").split(".")
    candidates = [target] + [".".join([*context[:i], target]) for i in range(len(context), 0, -1)]
    if any(_is_internal(c, app.config.api_internal) for c in candidates):
        return contnode
    return None


def _on_config_inited(app: Sphinx, config) -> None:
    try:
        write_pages(app, config.api_topics, config.api_internal)
    except TopicError as exc:
        raise ExtensionError(f"apipages: {exc}") from exc
    missing = undocumented(documented_modules(config.api_topics, config.api_internal))
    for dotted in missing:
        logger.warning("apipages: %s has no docstring: its entry in the API reference has no description",
                       dotted)


def _on_build_finished(app: Sphinx, exc) -> None:
    if _UNCOMMENTED:
        logger.info("apipages: constants described by their value only (give each a #: comment): %s",
                    ", ".join(sorted(_UNCOMMENTED)))


def setup(app: Sphinx) -> dict:
    app.add_config_value("api_topics", [], "env", types=[list])
    app.add_config_value("api_internal", [], "env", types=[list])
    app.connect("config-inited", _on_config_inited)
    app.connect("missing-reference", resolve_reexports)
    app.connect("missing-reference", internal_reference, priority=600)  # after resolve_reexports
    app.connect("build-finished", _on_build_finished)
    app.connect("autodoc-process-docstring", data_docstring, priority=100)  # before numpydoc's (500)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

