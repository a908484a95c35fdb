"""One run of a tape path, and one point of a path sweep as a worker runs it; its store file.

Module-level functions of plain arguments (a path's dict form, numbers), so that they pickle
by reference under any executor, as ``_point.py`` does for drives.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .._util import validation as _v
from ..backends._exact_mdof import simulate_mechanical
from ..backends._mechanical_hybrid import run_as_system
from ..backends._simulate import DEFAULT_MAX_EVENTS
from ..model._tape_path import TapePath
from ..results._tape_path import TapePathRun
from ._point import STATUS_EXCEPTION

__all__ = ["simulate_path", "run_path_point", "path_failure", "GUIDE_RESULTS", "PATH_RESULTS", "PATH_CODEC"]

#: Per-guide result variables of a path sweep: name -> (units, long name).
GUIDE_RESULTS = {
    "mean_flange_force": ("N", "mean flange force, both flanges"),
    "mean_flange_force_upper": ("N", "mean flange force, upper flange"),
    "mean_flange_force_lower": ("N", "mean flange force, lower flange"),
    "flange_impulse": ("N s", "flange impulse over the run, both flanges"),
    "contacts": ("1", "flange contacts (spring contacts closing, rigid impacts)"),
    "impact_rate": ("1/s", "flange contacts per second"),
}
#: Per-point result variables: name -> (units, long name).
PATH_RESULTS = {
    "events": ("1", "events of the run (all kinds)"),
    "simulated_time": ("s", "time actually simulated"),
}


def simulate_path(path: TapePath, duration: float, *, phase: float = 0.0, q0=None, v0=None,
                  max_events: int = DEFAULT_MAX_EVENTS, backend: str = "exact", **options) -> TapePathRun:
    """Run a tape path for ``duration`` seconds (on the exact n-DOF backend by default); its SI results.

    ``simulate(path.mechanical_system(phase), path.seconds_to_time(duration), q0, v0, backend=...)``
    read by :class:`~impactosc.TapePathRun`.

    Parameters
    ----------
    path : TapePath
    duration : float
        Seconds of tape motion (> 0).
    phase : float
        The supply reel's angle at ``t = 0`` in radians.
    q0, v0 : array_like or None
        Lateral positions in m and velocities in m/s of the tape at the guides at ``t = 0``
        (relative to each guide, as :attr:`~impactosc.TapePath.length_scale` scales them); ``None``: at
        rest on the guides' axes.
    max_events : int
        Stop with status 1 after this many events (what was computed is kept).
    backend : {"exact", "heyoka", "scipy"}
        ``"exact"`` (default): the compiled closed-form n-DOF backend. ``"heyoka"`` and
        ``"scipy"``: the path's system written as a user system on their event loops, the
        independent cross-checks (slower; a chatter that the exact backend sums into rest on a
        flange ends their run with status 2). ``**options`` are the backend's (e.g. ``tol``).

    Returns
    -------
    TapePathRun
        Per-guide flange impulses and forces, impacts, contact starts, the lateral motion
        anywhere along the path; ``run.status`` and ``run.solution.message`` say whether the
        run reached its end.

    Examples
    --------
    >>> from impactosc import Guide, TapeDrive, TapePath
    >>> from impactosc.sweeps import simulate_path
    >>> path = TapePath(TapeDrive(clearance=40e-6, friction=0.0, damping_ratio=0.01),
    ...                 [Guide(0.02, clearance=150e-6), Guide(0.05)], end_span=0.03)
    >>> run = simulate_path(path, 2e-3)
    >>> run.status, (run.impacts_per_second() > 0).tolist()     # both guides' flanges are touched
    (0, [True, True])
    >>> forces = run.mean_flange_force()                          # N, one per guide
    """
    if not isinstance(path, TapePath):
        raise TypeError(f"path must be a TapePath, got {path!r} of type {type(path).__name__}")
    duration = _v.positive("duration", duration)
    phase = _v.real("phase", phase)
    state = []
    for name, value, scale in (("q0", q0, path.length_scale), ("v0", v0, path.length_scale / path.time_scale)):
        arr = np.zeros(path.n) if value is None else np.asarray(value, dtype=float)
        if arr.shape != (path.n,) or not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must hold {path.n} finite numbers (one per guide, SI units), got {value!r}")
        state.append(arr / scale)
    _v.choice("backend", backend, ("exact", "heyoka", "scipy"))
    system, t_end = path.mechanical_system(phase), path.seconds_to_time(duration)
    if backend == "exact":
        sol = simulate_mechanical(system, t_end, state[0], state[1], max_events=max_events, **options)
    else:
        sol = run_as_system(system, t_end, state[0], state[1], backend=backend, max_events=max_events, **options)
    return TapePathRun(path, sol, phase=phase)


def path_failure(status: int, message: str, n_guides: int) -> dict:
    """The result dict of a point that has no results."""
    out: dict[str, Any] = {name: np.full(n_guides, math.nan) for name in GUIDE_RESULTS}
    out.update(dict.fromkeys(PATH_RESULTS, math.nan))
    out.update(status=status, message=message)
    return out


def run_path_point(fields: dict, duration: float, phase: float, max_events: int) -> dict:
    """The result dict of one path (its dict form ``fields``): ``GUIDE_RESULTS`` arrays, ``PATH_RESULTS``,
    ``status``, ``message``; never raises."""
    n = len(fields.get("guides", ()))
    try:
        path = TapePath.from_dict(fields)
        run = simulate_path(path, duration, phase=phase, max_events=max_events)
    except Exception as exc:  # noqa: BLE001 - any failure of one point is recorded, not raised
        return path_failure(STATUS_EXCEPTION, f"{type(exc).__name__}: {exc}", n)
    out = path_failure(run.status, str(run.solution.message), n)
    out["simulated_time"] = run.duration
    out["events"] = float(len(run.solution.events))
    if run.status != 0:
        return out  # a partial run's averages are over another window than the other points'
    out.update(mean_flange_force=run.mean_flange_force(), mean_flange_force_upper=run.mean_flange_force(side=1),
               mean_flange_force_lower=run.mean_flange_force(side=-1), flange_impulse=run.flange_impulse(),
               contacts=np.array([run.contact_starts(g).size for g in range(n)], dtype=float),
               impact_rate=run.impacts_per_second())
    return out


class _NetcdfPathPoint:
    """One path-sweep point as a small netCDF3 file: per-guide arrays, the path's dict form as JSON."""

    suffix = ".nc"

    def write(self, path: str, record: dict) -> None:
        result = record["result"]
        data: dict[str, Any] = {name: (("guide",), np.asarray(result[name], dtype=np.float64))
                                for name in GUIDE_RESULTS}
        data.update({name: ((), np.float64(result[name])) for name in PATH_RESULTS})
        data["status"] = ((), np.int32(result["status"]))
        ds = xr.Dataset(data, attrs={"key": record["key"], "message": result["message"],
                                     "path": json.dumps(record["fields"]), "settings": json.dumps(record["settings"]),
                                     "checksum": record["checksum"]})
        ds.to_netcdf(path, engine="scipy")

    def read(self, path: Path) -> dict:
        with xr.open_dataset(path, engine="scipy") as ds:
            result: dict[str, Any] = {name: np.asarray(ds[name].values, dtype=float) for name in GUIDE_RESULTS}
            result.update({name: float(ds[name].values) for name in PATH_RESULTS})
            result["status"] = int(ds["status"].values)
            result["message"] = str(ds.attrs["message"])
            return {"key": str(ds.attrs["key"]), "fields": json.loads(ds.attrs["path"]),
                    "settings": json.loads(ds.attrs["settings"]), "result": result,
                    "checksum": str(ds.attrs["checksum"])}


PATH_CODEC = _NetcdfPathPoint()
