"""impactosc: event-driven simulation of the tape-edge / roller-flange impact oscillator.

The model is the one-dimensional impact oscillator with Coulomb friction of
"Characterization of Tape Edge Contact Force With Acoustic Emission" (ASME, DOI
10.1115/1.2748775), section 5. Every flange contact, friction reversal, stick and
release is a located event.
"""

from . import dynamics as dynamics  # the dynamics toolkit: impactosc.dynamics.X
from .engine import EVENT_KINDS, Mode
from .model import Oscillator
from .simulate import simulate
from .solution import Solution
from .sweep import load_sweep, sweep
from .tape import TapeDrive

__all__ = ["Oscillator", "TapeDrive", "simulate", "sweep", "load_sweep", "Solution", "Mode", "EVENT_KINDS"]
__version__ = "0.1.0"
