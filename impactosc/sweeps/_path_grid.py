"""A grid of tape paths run through the runner: the plan, the store, the Dataset.

What :func:`~impactosc.sweeps.sweep_path` and the contact charts share: each point of the
outer product of a grid of path parameters (named as :meth:`~impactosc.TapePath.with_parameter` names
them) is the base path's dict form with those values set; points are keyed, stored and run
by :mod:`impactosc.runner` exactly as :func:`~impactosc.sweep` runs drives, and assembled
into an xarray Dataset with one dimension per swept parameter (and ``guide`` for per-guide
variables), SI units in ``attrs``.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Mapping

import numpy as np
import xarray as xr

from .._util import validation as _v
from ..model._tape_path import TapePath
from ..model._tape_path_file import check_parameter, parameter_units, set_parameter
from ..runner import PointStore, check_executor, check_store_path, point_key
from ._path_point import PATH_CODEC
from ._point import STATUS_EXCEPTION, STATUS_NOT_COMPUTED
from ._sweep import _STATUS_DOC, _point_label, _version, _warn_failures, fill_grid, run_stored

__all__ = ["check_path_grid", "plan_paths", "run_paths", "assemble_paths", "read_paths", "STORE_FORMAT"]

STORE_FORMAT = 1


def check_path_grid(grid, n_guides: int) -> dict[str, np.ndarray]:
    """``{parameter: float64 values}``; errors name the key, the rule and the value."""
    if grid is None:
        return {}
    if not isinstance(grid, Mapping):
        raise TypeError(f"grid must be a dict of path parameter -> 1-D sequence of values, got {type(grid).__name__}")
    out = {}
    for key, values in grid.items():
        check_parameter(key, n_guides)
        name = f"grid[{key!r}]"
        if isinstance(values, str | bytes) or np.ndim(values) != 1:
            raise ValueError(f"{name} must be a 1-D sequence of numbers, got {values!r}")
        arr = np.array([_v.real(name, x) for x in values], dtype=float)
        if arr.size == 0:
            raise ValueError(f"{name} is empty: give at least one value")
        if np.unique(arr).size != arr.size:
            raise ValueError(f"{name} has duplicate values: each value must appear once, got {arr.tolist()}")
        out[key] = arr
    return out


def plan_paths(base: TapePath, grid, settings: dict) -> dict:
    """Every grid point as a path's dict form and a key; points whose path is invalid recorded as failures."""
    if not isinstance(base, TapePath):
        raise TypeError(f"base must be a TapePath, got {base!r} of type {type(base).__name__}")
    grid = check_path_grid(grid, base.n)
    base_fields = base.to_dict()
    points, unique, invalid = [], {}, {}
    for combo in itertools.product(*(v.tolist() for v in grid.values())):
        point = dict(zip(grid, combo, strict=True))
        fields = base_fields
        for key, value in point.items():
            fields = set_parameter(fields, key, value)
        try:
            fields = TapePath.from_dict(fields).to_dict()  # validated, in normal form (the store's key)
        except (TypeError, ValueError) as exc:
            key = "invalid:" + _point_label(point)
            invalid[key] = {"status": STATUS_EXCEPTION, "message": f"{type(exc).__name__}: {exc}"}
        else:
            key = point_key(fields, settings)
            unique[key] = fields
        points.append((point, key))
    return {"grid": grid, "points": points, "unique": unique, "invalid": invalid, "settings": settings,
            "base": base}


def run_paths(plan: dict, fn, args: tuple, failure, *, kind: str, executor, progress: bool, store=None,
              codec=PATH_CODEC, batch: bool = True) -> dict:
    """Run ``fn(fields, *args)`` at every planned point not in ``store``; every point's result by key.

    ``failure(status, message)`` makes the result of a lost or invalid point; ``codec`` writes
    and reads a point's file in ``store`` (the path sweep's by default); ``batch=False`` sends one
    point per task (points whose cost varies widely, such as root searches).
    """
    check_executor(executor)
    st = None
    if store is not None:
        check_store_path(store)
        st = PointStore.create(store, plan["settings"], codec, kind=kind, fmt=STORE_FORMAT,
                               required=("settings", "grid"),
                               extra={"grid": {k: v.tolist() for k, v in plan["grid"].items()},
                                      "base": plan["base"].to_dict()}, version=_version())
    results = {key: failure(r["status"], r["message"]) for key, r in plan["invalid"].items()}
    return run_stored(plan["unique"], results, st, fn, args, failure, executor=executor, progress=progress, what=kind,
                      stacklevel=4, batch=batch)


def assemble_paths(plan: dict, results: dict, guide_vars: dict, point_vars: dict, attrs: dict, *,
                   warn: bool = True) -> xr.Dataset:
    """The Dataset: a dimension per swept parameter, ``guide`` for ``guide_vars``; SI units in ``attrs``."""
    grid, base = plan["grid"], plan["base"]
    dims = list(grid)
    values, status, message = fill_grid(plan, results, {**dict.fromkeys(guide_vars, (base.n,)),
                                                        **dict.fromkeys(point_vars, ())})

    def meta(units, long_name):
        return {"units": units, "long_name": long_name}

    data = {name: (dims + ["guide"], values[name], meta(*guide_vars[name])) for name in guide_vars}
    data.update({name: (dims, values[name], meta(*point_vars[name])) for name in point_vars})
    data["status"] = (dims, status, {"long_name": "run status", "flag_meanings": _STATUS_DOC})
    data["message"] = (dims, message, {"long_name": "status message"})
    coords = {k: (k, v, meta(*parameter_units(k))) for k, v in grid.items()}
    coords["guide"] = ("guide", np.arange(base.n), {"long_name": "guide index along the path"})
    coords["guide_position"] = ("guide", np.array([g.position for g in base.guides]),
                                meta("m", "guide position along the path (base path)"))
    ds_attrs = {"base_path": json.dumps(base.to_dict()), **attrs, "impactosc_version": _version()}
    ds = xr.Dataset(data, coords=coords, attrs=ds_attrs)
    if warn:
        _warn_failures(plan, ds)
    return ds


def read_paths(store, *, kind: str, failure, codec=PATH_CODEC) -> tuple[dict, dict, dict]:
    """An existing store's plan, its points' results (``failure(-4, message, n_guides)`` where missing) and manifest.

    Nothing is computed or changed on disk; unusable point files count as not computed (a
    warning names them).
    """
    st, manifest = PointStore.read(store, codec, kind=kind, fmt=STORE_FORMAT, required=("settings", "grid", "base"))
    try:
        plan = plan_paths(TapePath.from_dict(manifest["base"]), manifest["grid"], manifest["settings"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"store manifest {str(st.root / 'manifest.json')!r} does not describe a valid {kind} "
                         f"({type(exc).__name__}: {exc})") from None
    n = plan["base"].n
    results = {key: failure(r["status"], r["message"], n) for key, r in plan["invalid"].items()}
    for key in plan["unique"]:
        stored = st.load(key)
        results[key] = stored if stored is not None else failure(STATUS_NOT_COMPUTED,
                                                                 "not computed yet: rerun with this store", n)
    st.warn_unusable(stacklevel=3)
    return plan, results, manifest
