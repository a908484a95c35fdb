"""The backends by name; each is imported when first asked for. ``"auto"`` picks one per member."""

from __future__ import annotations

import importlib

__all__ = ["BACKENDS", "AUTO", "OPTIONS", "get_backend", "resolve_backend", "MAX_ZETA_OF", "MAX_HEYOKA_TERMS"]

#: name -> "module:callable" of a function ``run(osc, t_end, x0, v0, record, max_events, **options)``
BACKENDS = {
    "heyoka": "impactosc.backends.heyoka:run",
    "scipy": "impactosc.backends.scipy:run",
    "exact": "impactosc.backends.exact:run",
    "rk4": "impactosc.backends.rk4:run",
}
#: The options each backend's ``run`` takes (a test holds them to the signatures), so that
#: ``"auto"`` knows whose options it is given without importing every backend.
OPTIONS = {"heyoka": ("tol", "max_wall_time"), "scipy": ("method", "rtol", "atol"), "exact": ("compiled",),
           "rk4": ("dt", "flange", "every")}
#: The name that picks the fastest backend that runs a member (:func:`resolve_backend`).
AUTO = "auto"

#: Largest damping ratio per backend, where it is below ``MAX_ZETA`` (measured on random
#: members and starts): the exact backend's guard search loses the sign of a velocity that
#: creeps at ``|f_net| / (2 zeta)`` next to its fast transient (status -1 in 2 of 30 runs at
#: ``zeta = 1e4``, none of 30 at 1e3); heyoka works at 1e12 and stops at 1e20.
MAX_ZETA_OF = {"exact": 1e3, "heyoka": 1e12}
#: Most forcing terms (the fundamental and the harmonics) the heyoka backend compiles an
#: integrator for: its compile time grows faster than linearly (measured 8 s for 30 terms,
#: 35 s for 60, over 2 minutes for 200), once per process and number of terms.
MAX_HEYOKA_TERMS = 40


def get_backend(name):
    """Return the ``run`` function of the backend called ``name`` (``"auto"``: ``run_auto``)."""
    if not isinstance(name, str):
        raise TypeError(f"backend must be a string, got {name!r} of type {type(name).__name__}")
    if name == AUTO:
        return run_auto
    if name not in BACKENDS:
        known = ", ".join(repr(b) for b in (*BACKENDS, AUTO))
        raise ValueError(f"backend must be one of {known}, got {name!r}")
    module, func = BACKENDS[name].split(":")
    return getattr(importlib.import_module(module), func)


def resolve_backend(name: str, osc, options=()) -> str:
    """The backend that runs ``osc`` for the name ``name``: ``name`` itself, or a choice for ``"auto"``.

    ``"auto"`` is the fastest backend that runs the member with events at machine
    precision: ``"exact"`` (closed-form pieces in a compiled loop; on the README's sweep of
    the paper's drive the same forces as heyoka, several times faster) when every mode is
    linear (``osc.linear``: a rigid or a linear spring flange), numba is installed and
    ``zeta <= MAX_ZETA_OF["exact"]``; else ``"heyoka"``, which runs every member; ``"scipy"``
    where heyoka's compile time would dominate (more than ``MAX_HEYOKA_TERMS = 40`` forcing
    terms). Given backend ``options`` (their names), ``"auto"`` is the backend they are for
    (``tol``: heyoka; ``rtol``: scipy, ...; the table ``OPTIONS`` of this module).

    Raises
    ------
    TypeError
        ``"auto"`` with options that no single backend takes.
    ValueError
        An unknown name.

    Examples
    --------
    >>> from impactosc import Oscillator
    >>> resolve_backend("auto", Oscillator(0.5, 1.1, 0.01, 1e4))                 # with numba
    'exact'
    >>> resolve_backend("auto", Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5))   # Hertz: not linear
    'heyoka'
    >>> resolve_backend("auto", Oscillator(0.5, 1.1, 0.01, 1e4), ["tol"])        # heyoka's option
    'heyoka'
    """
    get_backend(name)
    if name != AUTO:
        return name
    given = sorted(options)
    if given:
        owners = [b for b, names in OPTIONS.items() if set(given) <= set(names)]
        if len(owners) != 1:
            table = "; ".join(f"{b}: {', '.join(names)}" for b, names in OPTIONS.items())
            raise TypeError(f"backend='auto' was given the options {', '.join(given)}, which no single backend "
                            f"takes ({table}): name the backend they are for")
        return owners[0]
    from .._util.jit import HAVE_NUMBA

    if osc.linear and HAVE_NUMBA and osc.zeta <= MAX_ZETA_OF["exact"]:
        return "exact"
    return "heyoka" if len(osc.terms) <= MAX_HEYOKA_TERMS else "scipy"


def run_auto(osc, t_end, x0, v0, *, record, max_events, sample_at=(), **options):
    """``run`` of the backend :func:`resolve_backend` picks for ``osc`` and ``options`` (``backend="auto"``)."""
    chosen = get_backend(resolve_backend(AUTO, osc, options))
    return chosen(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=sample_at, **options)
