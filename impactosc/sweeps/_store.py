"""The store of :func:`impactosc.sweep`: the runner's verified point store, one netCDF file per point.

Layout (format 2: format 1 had no contact observables, ``mean_peak_force`` ... ``dissipation_rate``;
a store of format 1 is refused by name, not reused; see :mod:`impactosc.runner`)::

    store/manifest.json        kind, format, settings (everything but the grid), latest grid
    store/points/<key>.nc      one finished point; <key> hashes its drive and the settings
    store/quarantine/          files that could not be used, kept for inspection

A point file holds the result variables, ``status``, and as attributes its key, message,
drive and settings (JSON) and a checksum of its values (files of older versions have no
checksum: their key, drive and settings are still checked).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..runner import PointStore
from ._point import FLOAT_VARS

#: 2: the contact observables joined the point variables (a format-1 store lacks them).
STORE_FORMAT = 2
KIND = "sweep"
_REQUIRED = ("settings", "grid")


class _NetcdfPoint:
    """One sweep point as a small netCDF3 file (scipy's engine: no extra dependency)."""

    suffix = ".nc"

    def write(self, path: str, record: dict) -> None:
        result = record["result"]
        data: dict[str, Any] = {name: ((), np.float64(result[name])) for name in FLOAT_VARS}
        data["status"] = ((), np.int32(result["status"]))
        ds = xr.Dataset(data, attrs={"key": record["key"], "message": result["message"],
                                     "drive": json.dumps(record["fields"]), "settings": json.dumps(record["settings"]),
                                     "checksum": record["checksum"]})
        ds.to_netcdf(path, engine="scipy")

    def read(self, path: Path) -> dict:
        with xr.open_dataset(path, engine="scipy") as ds:
            result: dict[str, Any] = {name: float(ds[name].values) for name in FLOAT_VARS}
            result["status"] = int(ds["status"].values)
            result["message"] = str(ds.attrs["message"])
            return {"key": str(ds.attrs["key"]), "fields": json.loads(ds.attrs["drive"]),
                    "settings": json.loads(ds.attrs["settings"]) if "settings" in ds.attrs else None,
                    "result": result, "checksum": str(ds.attrs["checksum"]) if "checksum" in ds.attrs else None}


CODEC = _NetcdfPoint()


def create_store(store, settings: dict, grid: dict, version: str) -> PointStore:
    """Open or start the store of a sweep, writing its manifest (see :meth:`PointStore.create`)."""
    return PointStore.create(store, settings, CODEC, kind=KIND, fmt=STORE_FORMAT, required=_REQUIRED,
                             extra={"grid": {k: v.tolist() for k, v in grid.items()}}, version=version)


def read_store(store) -> tuple[PointStore, dict]:
    """An existing sweep store and its manifest, without changing anything on disk."""
    st, manifest = PointStore.read(store, CODEC, kind=KIND, fmt=STORE_FORMAT, required=_REQUIRED)
    if not isinstance(manifest["grid"], dict):
        raise ValueError(f"store manifest {str(st.root / 'manifest.json')!r}: 'grid' must be a JSON object")
    return st, manifest
