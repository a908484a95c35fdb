"""Sweeps: one run per point of a parameter grid, on any executor, into an xarray Dataset.

A sweep can be stored point by point (a verified, resumable store) and loaded back with
:func:`load_sweep`. Tape paths: :func:`simulate_path` runs one, :func:`sweep_path` a grid of
their SI parameters (:func:`load_path_sweep` reads its store back), :func:`critical_clearance`,
:func:`critical_clearance_chart` and :func:`contact_boundary` say where contact starts.
"""

from ._path_contact import contact_boundary, critical_clearance, critical_clearance_chart, steady_deflection
from ._path_point import simulate_path
from ._path_sweep import load_path_sweep, sweep_path
from ._sweep import STATUS_EXCEPTION, STATUS_LOST, STATUS_NOT_COMPUTED, SWEEP_KEYS, load, load_sweep, sweep

__all__ = ["sweep", "load_sweep", "load", "SWEEP_KEYS", "STATUS_EXCEPTION", "STATUS_LOST", "STATUS_NOT_COMPUTED",
           "simulate_path", "sweep_path", "steady_deflection", "critical_clearance", "critical_clearance_chart",
           "contact_boundary", "load_path_sweep"]
