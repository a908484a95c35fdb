"""numba, when it is installed: one decorator for the code that runs compiled or as plain Python.

The transition rule (:mod:`impactosc._rule`) and the exact backend's closed forms are
written once, in the subset of Python that numba compiles. With numba installed they run
compiled (cached on disk after the first call); without it the very same functions run
as plain Python, and the compiled event loop of the exact backend falls back to the
Python driver (:func:`impactosc.engine.drive`) with a one-line hint.
"""

from __future__ import annotations

import hashlib
import warnings
from pathlib import Path
from typing import Any

__all__ = ["HAVE_NUMBA", "njit", "njit_inline", "INSTALL_HINT", "warn_no_numba"]

_numba: Any
try:
    import numba as _numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is absent
    _numba = None
    HAVE_NUMBA = False

#: The modules whose functions numba compiles and caches; they call one another.
COMPILED_MODULES = ("model/_rule.py", "model/_wall.py", "engine/_stuck.py", "engine/_chatter.py", "_util/roots.py",
                    "backends/exact/_piece.py", "backends/exact/_family.py", "backends/exact/_loop.py")


def _drop_stale_caches() -> None:
    """Delete numba's cached machine code of :data:`COMPILED_MODULES` when any of them changed.

    numba keys a function's cache on its own file only: a compiled caller (the exact
    backend's loop) would keep the old copy of a callee edited in another file, and the
    compiled and Python drivers would quietly disagree. One fingerprint of all the sources,
    kept beside the caches, catches that (it costs reading eight files at the first compiled import).
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


if HAVE_NUMBA:
    _drop_stale_caches()

#: How to get the compiled paths.
INSTALL_HINT = "pip install 'impactosc[fast]' (numba)"


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
