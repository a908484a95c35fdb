"""Dynamics of the nonsmooth impact oscillator, built on the exact event-driven engine.

What users of an impact oscillator ask about is its dynamics: which steady states exist,
whether they are stable, where the motion starts touching a flange, where it becomes
periodic-n or chaotic as a parameter changes. This subpackage answers those questions
for every member of the model family (:class:`~impactosc.Oscillator`) and for the tape
drive in SI units (:class:`~impactosc.TapeDrive`):

=================================  ====================================================
:func:`stroboscopic_section`       Poincare section once per forcing period (exact time events)
:func:`event_section`              Poincare section at every event of one kind (contact, stick, ...)
:func:`periodic_orbit`             period-n orbits by Newton shooting, Floquet multipliers, verdict
:func:`monodromy`                  the stroboscopic map and its Jacobian (saltation product)
:func:`lyapunov_exponent`          largest Lyapunov exponent of the nonsmooth flow, with history
                                   (the built-in family, a user system, any map)
:func:`bifurcation_diagram`        stroboscopic points over a parameter, parallel, resumable,
                                   forward/backward continuation (hysteresis)
:func:`contact_onset`              critical parameter value at which the steady state touches a flange
:func:`onset_chart`                that critical value over a 2-D grid: the design chart
:func:`continuation`               follow a family of periodic orbits in one parameter (a
                                   :class:`Branch`) with its folds, period doublings, grazings
                                   and stick onsets located; a located point in two parameters;
                                   a tape path's critical clearance continued against the speed
                                   or the run-out (:func:`critical_clearance_boundary`)
:class:`HybridMap`                 the stroboscopic (or section) map of a user system
                                   (:class:`~impactosc.HybridSystem`) and its Jacobians by saltation
:func:`periodic_orbit_of`          a periodic orbit of a user system by Newton's method on its
                                   map, with its Floquet multipliers (the same shooting as
                                   :func:`periodic_orbit`, the same :class:`PeriodicOrbit`)
:class:`OscillatorMap`             the built-in family's stroboscopic map behind the same
                                   interface (:class:`PoincareMap`) as :class:`HybridMap`
:func:`shoot`                      Newton + Floquet on any :class:`PoincareMap`
=================================  ====================================================

The Jacobians come from the smooth pieces' state-transition matrices (:mod:`.flow`) and a
saltation matrix at every event (:mod:`.saltation`), derived from the model's own vector
fields and guards (:mod:`impactosc.engine`), so new members of the family need no new code.
For a user's own piecewise-smooth system the same rule is built from the symbolic derivatives
of its definition (:mod:`.hybrid_map`).
"""

from ._common import OSCILLATOR_PARAMETERS, TAPE_PARAMETERS, forcing_period, parameter_names
from ._map import MapValue, PoincareMap
from ._newton import PeriodicOrbit, Shot, floquet_multipliers, shoot
from .bifurcation import bifurcation_diagram, load_bifurcation, plot_bifurcation
from .chart import onset_chart, plot_onset_chart
from .closed_form import (
    den_hartog_amplitude,
    den_hartog_multipliers,
    den_hartog_onset,
    quasi_static_critical_clearance,
)
from .continuation import SPECIAL_KINDS, Branch, BranchPoint, SpecialPoint, continuation, critical_clearance_boundary
from .hybrid_map import HybridMap, HybridMapValue, periodic_orbit_of
from .hybrid_map import HybridOrbit as HybridOrbit  # the former name of PeriodicOrbit for user systems
from .lyapunov import LyapunovResult, lyapunov_exponent, map_lyapunov_exponent
from .onset import ContactOnset, contact_margin, contact_onset
from .oscillator_map import OscillatorMap, OscillatorMapValue
from .poincare import Section, detect_period, event_section, stroboscopic_section
from .saltation import Saltation, saltation_matrix
from .shooting import Monodromy, monodromy, periodic_orbit

__all__ = [
    "stroboscopic_section",
    "event_section",
    "detect_period",
    "Section",
    "periodic_orbit",
    "monodromy",
    "Monodromy",
    "floquet_multipliers",
    "PeriodicOrbit",
    "saltation_matrix",
    "Saltation",
    "lyapunov_exponent",
    "LyapunovResult",
    "bifurcation_diagram",
    "load_bifurcation",
    "plot_bifurcation",
    "contact_margin",
    "contact_onset",
    "ContactOnset",
    "onset_chart",
    "plot_onset_chart",
    "continuation",
    "Branch",
    "BranchPoint",
    "SpecialPoint",
    "SPECIAL_KINDS",
    "critical_clearance_boundary",
    "HybridMap",
    "HybridMapValue",
    "periodic_orbit_of",
    "PoincareMap",
    "MapValue",
    "OscillatorMap",
    "OscillatorMapValue",
    "shoot",
    "Shot",
    "map_lyapunov_exponent",
    "den_hartog_amplitude",
    "den_hartog_onset",
    "den_hartog_multipliers",
    "quasi_static_critical_clearance",
    "forcing_period",
    "parameter_names",
    "OSCILLATOR_PARAMETERS",
    "TAPE_PARAMETERS",
]
