"""impactosc: event-driven simulation of the tape-edge / roller-flange impact oscillator.

The model is the one-dimensional impact oscillator with Coulomb friction of
"Characterization of Tape Edge Contact Force With Acoustic Emission" (ASME, DOI
10.1115/1.2748775), section 5. Every flange contact, friction reversal, stick and
release is a located event.

The public names below are imported when first used (PEP 562), so ``import impactosc``
loads none of numba, heyoka, xarray, pandas or matplotlib; each comes in with the first
call that needs it. The layers of the package, from the bottom: ``model`` (the one
definition), ``engine`` (the driver loop), ``results``, ``backends`` (and
:func:`simulate`), ``runner`` (many independent points), ``sweeps`` / ``dynamics`` /
``signal``, ``paper``, ``cli``. See the architecture page of the docs.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__ as __version__

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names are lazy
    from . import dynamics as dynamics
    from . import signal as signal
    from .backends import simulate
    from .backends._exact_mdof import simulate_mechanical
    from .engine import EVENT_KINDS, Mode
    from .model import Contact, Friction, Guide, MechanicalSystem, Oscillator, TapeDrive, TapePath
    from .model.hybrid import Guard, HybridMode, HybridSystem, stick_slip, symbols
    from .results import MechanicalSolution, Solution, TapePathRun
    from .sweeps import load_path_sweep, load_sweep, simulate_path, sweep, sweep_path

__all__ = ["Oscillator", "TapeDrive", "simulate", "sweep", "load_sweep", "Solution", "Mode", "EVENT_KINDS",
           "HybridSystem", "HybridMode", "Guard", "symbols", "stick_slip",
           "MechanicalSystem", "Contact", "Friction", "simulate_mechanical", "MechanicalSolution", "TapePath", "Guide",
           "TapePathRun", "simulate_path", "sweep_path", "load_path_sweep"]

#: public name -> the subpackage that defines it
_LAZY = {
    "Oscillator": "model",
    "TapeDrive": "model",
    "simulate": "backends",
    "sweep": "sweeps",
    "load_sweep": "sweeps",
    "Solution": "results",
    "Mode": "engine",
    "EVENT_KINDS": "engine",
    "HybridSystem": "model.hybrid",
    "HybridMode": "model.hybrid",
    "Guard": "model.hybrid",
    "symbols": "model.hybrid",
    "stick_slip": "model.hybrid",
    "MechanicalSystem": "model",
    "Contact": "model",
    "Friction": "model",
    "simulate_mechanical": "backends._exact_mdof",
    "MechanicalSolution": "results",
    "TapePath": "model",
    "Guide": "model",
    "TapePathRun": "results",
    "simulate_path": "sweeps",
    "sweep_path": "sweeps",
    "load_path_sweep": "sweeps",
}
_SUBPACKAGES = ("dynamics", "signal")


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    elif name in _SUBPACKAGES:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'impactosc' has no attribute {name!r}")
    globals()[name] = value  # the next lookup is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | set(_SUBPACKAGES))
