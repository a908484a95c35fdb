"""Sweeps of a tape path over any of its SI parameters: per-guide flange forces and contact rates."""

from __future__ import annotations

import json
from collections.abc import Mapping

import xarray as xr

from .._util import validation as _v
from ..backends._simulate import DEFAULT_MAX_EVENTS
from ..model._tape_path import TapePath
from ._path_grid import assemble_paths, plan_paths, read_paths, run_paths
from ._path_point import GUIDE_RESULTS, PATH_RESULTS, path_failure, run_path_point

__all__ = ["sweep_path", "load_path_sweep"]

KIND = "path sweep"


def sweep_path(base: TapePath, grid: Mapping | None, *, duration: float, phase: float = 0.0, executor=None,
               progress: bool = True, store=None, max_events: int = DEFAULT_MAX_EVENTS) -> xr.Dataset:
    """Run a tape path at every point of a grid of its SI parameters; per-guide results as a Dataset.

    Each point of the outer product of ``grid`` is ``base`` with those parameters set
    (:meth:`~impactosc.TapePath.with_parameter`), run from rest on the guides' axes for ``duration``
    seconds on the exact n-DOF backend (:func:`simulate_path`). Points run on the runner of
    :func:`impactosc.sweep` (a local process pool by default, ``"serial"``, any
    ``concurrent.futures.Executor``, ``"dask"`` or a ``dask.distributed`` client), and with
    ``store=`` every finished point is saved and a rerun computes only what is missing.

    Parameters
    ----------
    base : TapePath
        The path whose parameters are kept where the grid does not set them.
    grid : dict or None
        ``{parameter: values}``, 1-D sequences of distinct finite numbers. A parameter is a
        numeric :class:`~impactosc.TapeDrive` field (``"speed"`` m/s, ``"tension"`` N, ``"pack_diameter"``
        m, ``"clearance"`` m: the drive's, for every guide that does not set its own...),
        ``"end_span"`` (m) or ``"guide<i>_<field>"`` for guide ``i``'s own field
        (``"guide2_clearance"``, ``"guide1_guide_offset"``, ``"guide0_position"``...). The
        order of the keys is the order of the dimensions. ``None`` or ``{}``: ``base`` alone.
    duration : float
        Seconds of tape motion per point (> 0).
    phase : float
        The supply reel's angle at ``t = 0`` in radians.
    executor, progress, store
        As in :func:`impactosc.sweep`; :func:`load_path_sweep` reads a store back.
    max_events : int
        Event limit of each run (status 1 when reached).

    Returns
    -------
    xarray.Dataset
        One dimension per grid key (coordinates with ``units`` and ``long_name``) and
        ``guide`` (with ``guide_position`` in m). Per guide: ``mean_flange_force``,
        ``mean_flange_force_upper``, ``mean_flange_force_lower`` (N), ``flange_impulse``
        (N s), ``contacts`` and ``impact_rate`` (1/s) (spring contacts closing and rigid
        impacts). Per point: ``events``, ``simulated_time`` (s), ``status`` (0: the run
        reached its end, the only status with results; 1 event limit; -1 failed; -2 an
        exception, e.g. an invalid path: see ``message``; -3 the task was lost) and
        ``message``. ``attrs``: ``base_path`` (the base path's dict form as JSON),
        ``duration`` (s), ``phase`` (rad), ``max_events``, ``backend`` and
        ``impactosc_version``.

    Raises
    ------
    TypeError, ValueError
        Before anything runs: an unknown parameter (the message lists the valid forms), a
        guide index beyond the path, an empty, non-1-D or duplicated list of values, a
        non-finite value, ``duration <= 0``, a bad executor or store.

    Warns
    -----
    RuntimeWarning
        When points failed: they hold NaN results, their status and message.

    Examples
    --------
    >>> from impactosc import Guide, TapeDrive, TapePath
    >>> from impactosc.sweeps import sweep_path
    >>> path = TapePath(TapeDrive(clearance=40e-6, friction=0.0, damping_ratio=0.01),
    ...                 [Guide(0.02, clearance=150e-6), Guide(0.05)], end_span=0.03)
    >>> ds = sweep_path(path, {"speed": [2.0, 4.0], "guide1_clearance": [30e-6, 60e-6]}, duration=2e-3,
    ...                 executor="serial", progress=False)
    >>> ds.mean_flange_force.dims
    ('speed', 'guide1_clearance', 'guide')
    >>> ds.mean_flange_force.attrs["units"], ds.impact_rate.attrs["units"]
    ('N', '1/s')
    >>> bool((ds.status == 0).all())
    True
    """
    duration = _v.positive("duration", duration)
    phase = _v.real("phase", phase)
    max_events = _v.integer("max_events", max_events)
    settings = json.loads(json.dumps({"duration": duration, "phase": phase, "max_events": max_events,
                                      "backend": "exact"}, sort_keys=True))
    plan = plan_paths(base, grid, settings)
    n = base.n
    results = run_paths(plan, run_path_point, (duration, phase, max_events),
                        lambda status, message: path_failure(status, message, n), kind=KIND, store=store,
                        executor=executor, progress=progress)
    return assemble_paths(plan, results, GUIDE_RESULTS, PATH_RESULTS, _attrs(settings))


def _attrs(settings: dict) -> dict:
    return {"duration": settings["duration"], "duration_units": "s", "phase": settings["phase"],
            "phase_units": "rad", "max_events": settings["max_events"], "backend": settings["backend"]}


def load_path_sweep(store) -> xr.Dataset:
    """Read a store written by :func:`sweep_path` back as its Dataset, without computing anything.

    Points not computed yet (an interrupted sweep) have status -4 and NaN results, and a
    warning says how many; an unusable point file counts as not computed (a warning names it).

    Raises
    ------
    FileNotFoundError
        ``store`` has no manifest.
    ValueError
        The manifest is not a path sweep's, or does not describe a valid one.

    Examples
    --------
    >>> from impactosc.sweeps import load_path_sweep
    >>> ds = load_path_sweep("path-sweep-store")          # doctest: +SKIP
    """
    import warnings

    plan, results, manifest = read_paths(store, kind=KIND, failure=path_failure)
    ds = assemble_paths(plan, results, GUIDE_RESULTS, PATH_RESULTS, _attrs(manifest["settings"]), warn=False)
    missing = int((ds.status == -4).sum())
    if missing:
        warnings.warn(f"store {str(store)!r} is incomplete: {missing} of {ds.status.size} points not computed",
                      RuntimeWarning, stacklevel=2)
    return ds
