"""The backends by name; each is imported when first asked for."""

from __future__ import annotations

import importlib

__all__ = ["BACKENDS", "get_backend"]

#: name -> "module:callable" of a function ``run(osc, t_end, x0, v0, record, max_events, **options)``
BACKENDS = {
    "heyoka": "impactosc.backends.heyoka:run",
    "scipy": "impactosc.backends.scipy:run",
    "exact": "impactosc.backends.exact:run",
    "rk4": "impactosc.backends.rk4:run",
}


def get_backend(name):
    """Return the ``run`` function of the backend called ``name``."""
    if not isinstance(name, str):
        raise TypeError(f"backend must be a string, got {name!r} of type {type(name).__name__}")
    if name not in BACKENDS:
        known = ", ".join(repr(b) for b in BACKENDS)
        raise ValueError(f"backend must be one of {known}, got {name!r}")
    module, func = BACKENDS[name].split(":")
    return getattr(importlib.import_module(module), func)
