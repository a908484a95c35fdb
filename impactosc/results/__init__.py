"""Results of a run: the :class:`Solution`, its tables as data frames, and its figures.

pandas is imported when a frame is first asked for, matplotlib when a figure is.
"""

from ._frames import Units, draw_flanges, events_frame, impacts_frame, units_of
from ._hybrid import HybridEvent, HybridSolution
from ._mechanical import MechanicalSolution
from ._observables import (
    CONTACT_DTYPE,
    OBSERVABLES,
    contact_observables,
    contact_table,
    elastic_impact_force,
    impact_force_law,
    moving_rms_force,
)
from ._plotting import plot_solution
from ._solution import EVENT_DTYPE, IMPACT_DTYPE, RECORD_OPTIONS, Solution
from ._tape_path import TapePathRun

__all__ = ["Solution", "RECORD_OPTIONS", "EVENT_DTYPE", "IMPACT_DTYPE", "Units", "units_of", "events_frame",
           "impacts_frame", "plot_solution", "draw_flanges", "HybridSolution", "HybridEvent",
           "MechanicalSolution", "contact_table", "contact_observables", "moving_rms_force",
           "CONTACT_DTYPE", "OBSERVABLES", "TapePathRun", "elastic_impact_force", "impact_force_law"]
