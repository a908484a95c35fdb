"""The resumable store of :func:`impactosc.sweep`: a directory with a manifest and one netCDF file per point.

Layout::

    store/manifest.json        format, settings (everything but the grid), latest grid
    store/points/<key>.nc      one finished point; <key> hashes its drive and the settings
    store/quarantine/          files that could not be used, kept for inspection

A point file is used only if it reads back completely, its stored key equals its name, it
was computed with the current settings, and its stored drive and settings hash to its
name: a truncated, empty, garbage, renamed, swapped or foreign file is moved to ``quarantine/`` with a
warning naming it, and the point is computed again. Every write is atomic (a temporary
file, then a rename), so an interrupted write never leaves half a point file.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import signal
import tempfile
import threading
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._point import FLOAT_VARS

STORE_FORMAT = 1
MANIFEST = "manifest.json"
POINTS_DIR = "points"
QUARANTINE_DIR = "quarantine"


def point_key(fields: dict, settings: dict) -> str:
    """The name of a point's file: a hash of its resolved drive and the sweep's settings.

    A point is identified by its drive, not by its grid index: a grid that is extended,
    reordered or re-parametrised (tension <-> t_sin_half_theta) still finds it.
    """
    text = json.dumps({"drive": fields, "settings": settings}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def check_store_path(store) -> Path:
    """``store`` as a Path; a ``ValueError`` naming it if it exists and is not a directory."""
    root = Path(store)
    if root.exists() and not root.is_dir():
        raise ValueError(f"store {str(root)!r} exists and is not a directory: give a directory for the store")
    return root


@contextlib.contextmanager
def interrupt_deferred():
    """Hold back a Ctrl-C (SIGINT) until the block is done, then deliver it.

    xarray's file manager takes a lock while it writes or reads a netCDF file; a
    KeyboardInterrupt raised inside it can leave the lock held and the process deadlocked
    on its own cleanup (seen: a sweep that never exited after Ctrl-C). The same holds for
    the locks of a process pool while a task is submitted. The blocks are short (one small
    file, one submission), so delaying the interrupt by them costs nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # signals are delivered to the main thread only
        return
    received = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append((signum, frame)))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if received and callable(previous):
            previous(*received[0])


def _atomic_write(path: Path, write) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)  # readers never see half a file; an interrupted write leaves a .tmp-*
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _diff(old: dict, new: dict, prefix: str = "") -> list[str]:
    out = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k, "<absent>"), new.get(k, "<absent>")
        if isinstance(a, dict) and isinstance(b, dict):
            out += _diff(a, b, f"{prefix}{k}.")
        elif a != b:
            out.append(f"{prefix}{k}: stored {a!r}, now {b!r}")
    return out


class _OtherFormat(ValueError):
    """A readable manifest of another store format: not damage, so not for quarantine."""


class _Mismatch(ValueError):
    """A readable point file that belongs to another point or other settings."""


def _read_manifest(path: Path) -> dict:
    """The manifest as a dict; a ``ValueError`` naming the file and what is wrong with it."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"store manifest {str(path)!r} is unreadable ({type(exc).__name__}: {exc})") from None
    if not isinstance(doc, dict):
        raise ValueError(f"store manifest {str(path)!r} is not a JSON object")
    if "format" in doc and doc["format"] != STORE_FORMAT:
        raise _OtherFormat(f"store {str(path.parent)!r} has format {doc['format']!r}, expected {STORE_FORMAT}")
    missing = [k for k in ("format", "settings", "grid") if k not in doc]
    if missing:
        raise ValueError(f"store manifest {str(path)!r} lacks {', '.join(missing)}")
    if not isinstance(doc["settings"], dict) or not isinstance(doc["grid"], dict):
        raise ValueError(f"store manifest {str(path)!r}: 'settings' and 'grid' must be JSON objects")
    return doc


class Store:
    """A sweep store at ``root``; :meth:`create` for a sweep, :meth:`read` for :func:`load_sweep`."""

    def __init__(self, root: Path, settings: dict, *, read_only: bool):
        self.root = root
        self.settings = settings
        self.read_only = read_only
        self.bad: list[str] = []  # "file (reason)" of every file that could not be used
        self.save_error: OSError | None = None

    # -- opening -------------------------------------------------------------------------
    @classmethod
    def create(cls, store, settings: dict, grid: dict, version: str) -> Store:
        """Open or start the store of a sweep, writing its manifest (before anything runs).

        A store made with other settings raises a ``ValueError`` listing the differences; a
        damaged manifest is moved to ``quarantine/`` with a warning (the point files say
        themselves which settings they belong to, so none is used wrongly).
        """
        root = check_store_path(store)
        manifest_path = root / MANIFEST
        if manifest_path.exists():
            try:
                old = _read_manifest(manifest_path)
            except _OtherFormat:
                raise
            except ValueError as exc:
                moved = _quarantine(root, manifest_path)
                warnings.warn(f"{exc}; moved to {str(moved)!r} and replaced: the points already stored are "
                              f"still used where they match this sweep", RuntimeWarning, stacklevel=3)
            else:
                diffs = _diff(old["settings"], settings)
                if diffs:
                    raise ValueError(f"store {str(root)!r} was made with different settings; its points would not "
                                     f"be comparable with this sweep's ({'; '.join(diffs)}). Use a new store, or "
                                     f"delete this one to start over. Only the grid may change between runs into "
                                     f"one store.")
        (root / POINTS_DIR).mkdir(parents=True, exist_ok=True)
        manifest = {"format": STORE_FORMAT, "settings": settings, "grid": {k: v.tolist() for k, v in grid.items()},
                    "impactosc_version": version}
        _atomic_write(manifest_path, lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=1)))
        return cls(root, settings, read_only=False)

    @classmethod
    def read(cls, store) -> tuple[Store, dict]:
        """An existing store and its manifest, without changing anything on disk."""
        root = Path(store)
        manifest_path = root / MANIFEST
        if not manifest_path.is_file():
            raise FileNotFoundError(f"{str(root)!r} is not a sweep store: it has no {MANIFEST}")
        manifest = _read_manifest(manifest_path)
        return cls(root, manifest["settings"], read_only=True), manifest

    # -- points --------------------------------------------------------------------------
    def path(self, key: str) -> Path:
        return self.root / POINTS_DIR / f"{key}.nc"

    def load(self, key: str) -> dict | None:
        """The stored result of point ``key``, or None if it is missing or unusable.

        An unusable file is recorded in :attr:`bad` (see :meth:`warn_unusable`); a writable store
        also moves it to ``quarantine/``, so the point is computed and saved again.
        """
        path = self.path(key)
        if not path.exists():
            return None
        try:
            with interrupt_deferred():
                return self._read_point(path, key)
        except Exception as exc:  # noqa: BLE001 - any damage: the point is recomputed, the file kept aside
            reason = f"{type(exc).__name__}: {exc}" if not isinstance(exc, _Mismatch) else str(exc)
            if not self.read_only:
                try:
                    _quarantine(self.root, path)
                except OSError as move_exc:
                    reason += f"; could not move it aside: {move_exc}"
            self.bad.append(f"{path.name} ({reason})")
            return None

    def _read_point(self, path: Path, key: str) -> dict:
        with xr.open_dataset(path, engine="scipy") as ds:
            stored_key = str(ds.attrs["key"])
            fields = json.loads(ds.attrs["drive"])
            # Files written before the settings were recorded in them have the drive check only.
            settings = json.loads(ds.attrs["settings"]) if "settings" in ds.attrs else self.settings
            out: dict[str, Any] = {name: float(ds[name].values) for name in FLOAT_VARS}
            out["status"] = int(ds["status"].values)
            out["message"] = str(ds.attrs["message"])
        if stored_key != key:
            raise _Mismatch(f"it holds point {stored_key}, not {key}")
        if settings != self.settings:
            raise _Mismatch(f"it was computed with other settings ({'; '.join(_diff(settings, self.settings))})")
        if point_key(fields, settings) != key:
            raise _Mismatch("its drive and settings do not hash to its name")
        return out

    def save(self, key: str, fields: dict, result: dict) -> None:
        """Save one finished point.

        A failed write (disk full, permissions) warns once and the sweep goes on without
        saving: the points computed so far are not thrown away for want of a disk.
        """
        if self.save_error is not None:
            return
        data: dict[str, Any] = {name: ((), np.float64(result[name])) for name in FLOAT_VARS}
        data["status"] = ((), np.int32(result["status"]))
        ds = xr.Dataset(data, attrs={"key": key, "message": result["message"], "drive": json.dumps(fields),
                                     "settings": json.dumps(self.settings)})
        try:
            with interrupt_deferred():
                _atomic_write(self.path(key), lambda tmp: ds.to_netcdf(tmp, engine="scipy"))
        except OSError as exc:
            self.save_error = exc
            warnings.warn(f"store {str(self.root)!r}: cannot save point {key} ({exc}); the sweep goes on, but the "
                          f"points computed from now on are only in the returned Dataset", RuntimeWarning,
                          stacklevel=2)

    def warn_unusable(self, stacklevel: int) -> None:
        """One warning naming the unusable point files met so far (at most five of them)."""
        if self.bad:
            where = "moved to quarantine/ and computed again" if not self.read_only else "treated as not computed"
            shown = "; ".join(self.bad[:5]) + (f"; and {len(self.bad) - 5} more" if len(self.bad) > 5 else "")
            warnings.warn(f"store {str(self.root)!r}: {len(self.bad)} point file(s) unusable ({where}): {shown}",
                          RuntimeWarning, stacklevel=stacklevel + 1)
            self.bad = []


def _quarantine(root: Path, path: Path) -> Path:
    """Move ``path`` into ``root/quarantine/`` under a name not taken yet; return where it went."""
    qdir = root / QUARANTINE_DIR
    qdir.mkdir(exist_ok=True)
    target = qdir / path.name
    n = 1
    while target.exists():
        target = qdir / f"{path.stem}.{n}{path.suffix}"
        n += 1
    os.replace(path, target)
    return target
