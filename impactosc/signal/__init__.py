"""Signal analysis of lateral tape motion (LTM): the paper's Fig. 3 pipeline.

Section 4 of the paper ("Detection of Tape/Flange Contact") measures LTM with an edge
sensor and shows, in its Fig. 3, (a) the LTM signal, (b) the LTM high-pass filtered at
1 kHz, (c) the rms impact force and (d) a time-frequency analysis of the LTM. It reads
them as: high-frequency LTM *bursts* occur at the same time as tape/flange impacts, and
their content lies "predominantly in the 1-2 kHz range" -- above the ~1 kHz bandwidth
of the head's servo actuator, which is why 1 kHz is the cutoff.

This module does the same on any uniformly sampled ``(t, x)`` record in SI units
(seconds, metres), measured or simulated:

* :func:`highpass`: zero-phase Butterworth high-pass (``scipy.signal.sosfiltfilt``),
  default cutoff 1 kHz (Fig. 3(b));
* :func:`rms_envelope`: moving rms over a centred window (the rms of Fig. 3(c), here of
  the LTM itself: a simulation has no acoustic emission sensor);
* :func:`spectrogram` (Fig. 3(d)), :func:`spectrum` (Welch) and :func:`band_power`,
  default band 1-2 kHz;
* :func:`burst_times` and :func:`correlate_with_impacts`: bursts of the envelope and how
  they line up with impact times (Fig. 3(b)-(c), "the three vertical dashed lines");
* :func:`analyze` runs all of it in one call and returns an :class:`LTMAnalysis` whose
  :meth:`~LTMAnalysis.plot` draws the four panels of Fig. 3 in one figure;
  :func:`read_ltm_csv`/:func:`analyze_csv` for measured data, :func:`from_solution`/
  :func:`analyze_solution` for a simulated tape-drive run.
"""

# The pipeline lives in package-private modules split by responsibility (defaults and input
# checks, filters, spectra, bursts, the one-call analysis and its figure, CSV and simulated
# records); this module is its public face, and the names documented here are theirs.
from __future__ import annotations

from ._analysis import LTMAnalysis, analyze
from ._bursts import ImpactCorrelation, burst_times, correlate_with_impacts
from ._checks import BAND_HZ as BAND_HZ
from ._checks import CUTOFF_HZ as CUTOFF_HZ
from ._checks import MIN_SAMPLES as MIN_SAMPLES
from ._checks import RESOLUTION_HZ as RESOLUTION_HZ
from ._checks import UNIFORM_RTOL as UNIFORM_RTOL
from ._checks import WINDOW_S as WINDOW_S
from ._checks import check_signal
from ._csv import LENGTH_UNITS as LENGTH_UNITS
from ._csv import TIME_UNITS as TIME_UNITS
from ._csv import analyze_csv, read_ltm_csv
from ._filters import highpass, rms_envelope
from ._solution import analyze_solution, contact_times, from_solution
from ._spectra import Spectrogram, band_power, spectrogram, spectrum

__all__ = ["highpass", "rms_envelope", "spectrum", "spectrogram", "Spectrogram", "band_power", "burst_times",
           "correlate_with_impacts", "ImpactCorrelation", "analyze", "LTMAnalysis", "read_ltm_csv",
           "analyze_csv", "from_solution", "contact_times", "analyze_solution", "check_signal"]
