"""Sphinx extension: the API reference of impactosc, generated from the package itself.

Nothing in the reference is listed by hand, so a name added to the package appears in the
documentation without editing ``docs/``:

* ``api/generated/impactosc.rst``: the package page, one autosummary entry (and so one page)
  per name in ``impactosc.__all__``;
* ``api/modules/<module>.rst``: one page per public submodule (found by walking the package;
  a module is public when no part of its dotted name starts with ``_``), with a page for
  every name in its ``__all__`` that is not re-exported at the top level, and links to the
  top-level pages of those that are;
* ``api/cli.rst``: the ``--help`` of the command line and of each of its subcommands.

The files are written when the extension is set up, before autosummary scans the sources
for its stubs, and are git-ignored. Stale pages of removed names are deleted first.

A name re-exported at the top level is documented once, as ``impactosc.<name>``. The
``missing-reference`` handler sends references written in the package's docstrings and type
hints as ``Oscillator``, ``impactosc.model.Oscillator`` or ``Oscillator.net_force`` to that
page, the way Python resolves them.
"""

from __future__ import annotations
import __future__

import argparse
import importlib
import inspect
import pkgutil
import shutil
import types
from pathlib import Path

from numpydoc.docscrape import NumpyDocString
from sphinx.application import Sphinx
from sphinx.errors import PycodeError
from sphinx.pycode import ModuleAnalyzer

PACKAGE = "impactosc"
GENERATED = Path("api", "generated")
MODULES = Path("api", "modules")
CLI_PAGE = Path("api", "cli.rst")


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


def _from_submodule(module: types.ModuleType, name: str) -> str | None:
    """For a subpackage (``impactosc.dynamics``) re-exporting ``name`` from one of its public
    submodules, that submodule's dotted name (the object is documented there, once)."""
    if not hasattr(module, "__path__"):
        return None
    home = getattr(getattr(module, name, None), "__module__", None)
    if (isinstance(home, str) and home.startswith(module.__name__ + ".")
            and not any(part.startswith("_") for part in home.split("."))
            and name in public_names(importlib.import_module(home))):
        return home
    return None


# -- the pages -----------------------------------------------------------------------------
def _title(text: str) -> str:
    return f"{text}\n{'=' * len(text)}\n"


def _autosummary(names: list[str], toctree: str | None) -> str:
    lines = [".. autosummary::"]
    if toctree is not None:
        lines.append(f"   :toctree: {toctree}")
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
        return f"api/modules/{obj.__name__}", f"module-{obj.__name__}"
    if modname == package or _reexported(module, name, top):
        return f"api/generated/{package}.{name}", f"{package}.{name}"
    home = _from_submodule(module, name)
    if home is not None:
        return documented_at(home, name, package)
    return f"api/generated/{modname}.{name}", f"{modname}.{name}"


def _members(module: types.ModuleType, names: list[str]) -> str:
    """Autosummary tables of ``names``: own pages for objects, links for modules."""
    objects = [n for n in names if not inspect.ismodule(getattr(module, n, None))]
    modules = [n for n in names if n not in objects]  # relative to the page's current module
    parts = []
    if objects:
        toctree = "." if module.__name__ == PACKAGE else "../generated"
        parts.append(_autosummary(objects, toctree=toctree))
    if modules:  # documented on their module pages, in the "Modules" section
        parts.append(".. rubric:: Modules\n")
        parts.append(_autosummary(modules, toctree=None))
    return "\n".join(parts)


def package_page(package: str = PACKAGE) -> str:
    top = importlib.import_module(package)
    parts = [
        _title(f"The ``{package}`` package"),
        f".. automodule:: {package}\n",
        f".. currentmodule:: {package}\n",
        f"Every name in ``{package}.__all__``, importable as ``{package}.<name>``:\n",
        _members(top, toplevel_names(package)),
    ]
    return "\n".join(parts)


def module_page(modname: str, package: str = PACKAGE) -> str:
    module = importlib.import_module(modname)
    top = importlib.import_module(package)
    names = public_names(module)
    homes = {n: _from_submodule(module, n) for n in names}
    own = [n for n in names if not _reexported(module, n, top) and homes[n] is None]
    shared = [n for n in names if _reexported(module, n, top)]
    # relative to the page's current module (autosummary refuses the module's own prefix)
    from_submodules = [f"~{homes[n][len(modname) + 1:]}.{n}" for n in names
                       if homes[n] is not None and not _reexported(module, n, top)]
    parts = [_title(f"``{modname}``")]
    # ``impactosc.simulate`` and ``impactosc.sweep`` are modules *and* the functions the
    # package re-exports under the same dotted name: registering the module as well would
    # be a duplicate object description, so such a module page is not indexed.
    shadowed = modname.count(".") == 1 and not inspect.ismodule(getattr(top, modname.rsplit(".", 1)[-1], module))
    parts.append(f".. automodule:: {modname}" + ("\n   :no-index:\n" if shadowed else "\n"))
    parts.append(f".. currentmodule:: {modname}\n")
    if own:
        parts.append(".. rubric:: Defined here\n")
        parts.append(_members(module, own))
    if shared:
        parts.append(f".. rubric:: Re-exported as ``{package}.<name>``\n")
        parts.append(_autosummary([f"~{package}.{n}" for n in shared], toctree=None))
    if from_submodules:
        parts.append(f".. rubric:: Importable as ``{modname}.<name>``, documented in its submodules\n")
        parts.append(_autosummary(from_submodules, toctree=None))
    return "\n".join(parts)


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


def cli_page(package: str = PACKAGE) -> str:
    parser = _build_parser(package)
    parser.prog = package
    parts = [_title("Command line"), f".. automodule:: {package}.cli\n   :no-index:\n",
             _literal(parser.format_help())]
    for name, sub in _subcommands(parser).items():
        sub.prog = f"{package} {name}"
        parts.append(_title(f"{package} {name}").replace("=", "-"))
        parts.append(_literal(sub.format_help()))
    return "\n".join(parts)


def write_pages(srcdir: Path, package: str = PACKAGE) -> list[Path]:
    """(Re)write every generated page under ``srcdir``; returns the files written."""
    for folder in (GENERATED, MODULES):
        shutil.rmtree(srcdir / folder, ignore_errors=True)
        (srcdir / folder).mkdir(parents=True)
    written = {srcdir / GENERATED / f"{package}.rst": package_page(package)}
    for modname in public_modules(package):
        written[srcdir / MODULES / f"{modname}.rst"] = module_page(modname, package)
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
def _doc_comment(obj, name: str, package: str = PACKAGE) -> list[str]:
    """The ``#:`` comment above ``name = ...`` in the public module that defines ``obj``."""
    for modname in [package, *public_modules(package)]:
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


def data_docstring(app: Sphinx, what: str, name: str, obj, options, lines: list[str]) -> None:
    """A constant's documentation is its ``#:`` comment, never its type's docstring.

    autodoc falls back to ``type(obj).__doc__`` for a constant without a comment (a tuple
    would be documented as "Built-in immutable sequence", a dtype with numpy's page), and a
    re-exported constant's comment is in the module that defines it, not in the package.
    """
    if what not in ("data", "attribute") or inspect.isroutine(obj) or inspect.isclass(obj):
        return
    type_doc = type(obj).__doc__
    type_doc = inspect.cleandoc(type_doc).splitlines() if isinstance(type_doc, str) else []
    if lines and [line.strip() for line in lines if line.strip()] != [t.strip() for t in type_doc if t.strip()]:
        return
    lines[:] = _doc_comment(obj, name.rsplit(".", 1)[-1])


def _on_config_inited(app: Sphinx, config) -> None:
    write_pages(Path(app.srcdir))


def setup(app: Sphinx) -> dict:
    app.connect("config-inited", _on_config_inited)
    app.connect("missing-reference", resolve_reexports)
    app.connect("autodoc-process-docstring", data_docstring, priority=100)  # before numpydoc's (500)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

