"""numba, when it is installed: one decorator for the code that runs compiled or as plain Python.

The transition rule (:mod:`impactosc._rule`) and the exact backend's closed forms are
written once, in the subset of Python that numba compiles. With numba installed they run
compiled (cached on disk after the first call); without it the very same functions run
as plain Python, and the compiled event loop of the exact backend falls back to the
Python driver (:func:`impactosc.engine.drive`) with a one-line hint.
"""

from __future__ import annotations

import warnings

__all__ = ["HAVE_NUMBA", "njit", "INSTALL_HINT", "warn_no_numba"]

try:
    import numba as _numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is absent
    _numba = None
    HAVE_NUMBA = False

#: How to get the compiled paths.
INSTALL_HINT = "pip install 'impactosc[fast]' (numba)"


def njit(func):
    """``numba.njit(cache=True)`` when numba is installed, else ``func`` itself.

    The plain function stays reachable as ``.py_func`` either way, for callers that pass it
    Python callables (:func:`impactosc.backends._exact_roots.first_rising`).
    """
    if _numba is None:  # pragma: no cover
        func.py_func = func
        return func
    return _numba.njit(cache=True)(func)


_warned = False


def warn_no_numba(what: str) -> None:
    """One-line hint, once per process, that ``what`` runs as plain Python without numba."""
    global _warned
    if not _warned:
        _warned = True
        warnings.warn(f"numba is not installed: {what} runs as plain Python; {INSTALL_HINT} compiles it",
                      RuntimeWarning, stacklevel=3)
