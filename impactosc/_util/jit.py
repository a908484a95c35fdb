"""numba, when it is installed: one decorator for the code that runs compiled or as plain Python.

The transition rule (:mod:`impactosc._rule`) and the exact backend's closed forms are
written once, in the subset of Python that numba compiles. With numba installed they run
compiled (cached on disk after the first call); without it the very same functions run
as plain Python, and the compiled event loop of the exact backend falls back to the
Python driver (:func:`impactosc.engine.drive`) with a one-line hint.

The first compile after an install or an upgrade takes 15-60 s (later processes load the
machine code from numba's cache in about a second). numba announces a compile only on a
cache miss (its ``numba:compile`` event); a listener turns the first one of impactosc's
functions into a one-line notice (:func:`impactosc._util.notice.notice`).
"""

from __future__ import annotations

import hashlib
import warnings
from pathlib import Path
from typing import Any

__all__ = ["HAVE_NUMBA", "njit", "njit_inline", "INSTALL_HINT", "COMPILE_NOTICE", "warn_no_numba"]

_numba: Any
try:
    import numba as _numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is absent
    _numba = None
    HAVE_NUMBA = False

#: The modules whose functions numba compiles and caches; they call one another (and the modules
#: whose constants they bake in: the n-DOF mode's guard kinds).
COMPILED_MODULES = ("model/_rule.py", "model/_wall.py", "engine/_stuck.py", "engine/_chatter.py", "_util/roots.py",
                    "backends/exact/_piece.py", "backends/exact/_family.py", "backends/exact/_loop.py",
                    "backends/_exact_mdof/_forms.py", "backends/_exact_mdof/_guards.py",
                    "backends/_exact_mdof/_closed.py", "backends/_exact_mdof/_modes.py",
                    "backends/_exact_mdof/_setup.py")


def _drop_stale_caches() -> None:
    """Delete numba's cached machine code of :data:`COMPILED_MODULES` when any of them changed.

    numba keys a function's cache on its own file only: a compiled caller (the exact
    backend's loop) would keep the old copy of a callee edited in another file, and the
    compiled and Python drivers would quietly disagree. One fingerprint of all the sources,
    kept beside the caches, catches that (it costs reading these few files at the first compiled import).
    """
    root = Path(__file__).resolve().parent.parent  # the package
    try:
        digest = hashlib.sha256(b"".join((root / rel).read_bytes() for rel in COMPILED_MODULES)).hexdigest()
        stamp = root / "__pycache__" / "impactosc-numba.sha256"
        if stamp.is_file() and stamp.read_text() == digest:
            return
        for rel in COMPILED_MODULES:
            path = root / rel
            for cached in path.parent.glob(f"__pycache__/{path.stem}.*.nb[ic]"):
                cached.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:  # a read-only install: numba then caches elsewhere or not at all
        pass


#: How to get the compiled paths: the one wording of every "numba is not installed" hint.
INSTALL_HINT = "pip install 'impactosc[fast]' (numba)"

#: The notice logged when numba starts compiling impactosc's code (a cache miss).
COMPILE_NOTICE = ("impactosc: numba is compiling the event rules and closed forms (once after an install or "
                  "upgrade, up to a minute; later runs load them from numba's cache)")


def _notice_compiles() -> None:
    """Register a listener of numba's compile event: a notice at the first compile of impactosc's code.

    numba fires ``numba:compile`` after its disk cache missed, just before compiling; a cache
    hit fires nothing, so a warm process says nothing and pays nothing.
    """
    from numba.core import event

    from .notice import notice

    class _FirstCompile(event.Listener):
        def on_start(self, ev) -> None:
            data = ev.data if isinstance(ev.data, dict) else {}
            func = getattr(data.get("dispatcher"), "py_func", None)
            module = getattr(func, "__module__", "") or ""
            if module.startswith("impactosc."):
                notice("numba-compile", COMPILE_NOTICE)

        def on_end(self, ev) -> None:
            pass

    event.register("numba:compile", _FirstCompile())


if HAVE_NUMBA:
    _drop_stale_caches()
    _notice_compiles()


def njit(func):
    """``numba.njit(cache=True)`` when numba is installed, else ``func`` itself."""
    if _numba is None:  # pragma: no cover
        return func
    return _numba.njit(cache=True)(func)


def njit_inline(func):
    """A compiled copy of ``func`` that numba inlines into its compiled callers.

    For generic code that takes a compiled function as an argument (the root finder of
    :mod:`impactosc.backends._exact_roots`): inlined, the argument is a known function and
    the caller stays cacheable; passed as a first-class value it would not be (numba
    recompiles such callers in every process). ``func`` itself stays plain Python for
    Python callers.
    """
    if _numba is None:  # pragma: no cover
        return func
    return _numba.njit(cache=True, inline="always")(func)


_warned = False


def warn_no_numba(what: str) -> None:
    """One-line hint, once per process, that ``what`` runs as plain Python without numba."""
    global _warned
    if not _warned:
        _warned = True
        warnings.warn(f"numba is not installed: {what} runs as plain Python; {INSTALL_HINT} compiles it",
                      RuntimeWarning, stacklevel=3)
