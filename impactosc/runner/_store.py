"""The resumable store of a many-point run: a directory with a manifest and one verified file per point.

Layout::

    store/manifest.json        kind, format, settings (everything that determines a point's result), extras
    store/points/<key><ext>    one finished point; <key> hashes its inputs and the settings
    store/quarantine/          files that could not be used, kept for inspection

How a point is written is its caller's (a :class:`Codec`: netCDF for sweeps, ``.npz`` for
bifurcation diagrams); what makes a file trustworthy is decided here, once. A point file is
used only if it reads back completely, its stored key equals its name, it was computed with
the current settings, its stored inputs and settings hash to its name, and its checksum
matches its contents: a truncated, empty, garbage, renamed, swapped, foreign or altered file
is moved to ``quarantine/`` with a warning naming it, and the point is computed again.
Every write is atomic (a temporary file, then a rename), so an interrupted write never
leaves half a point file.
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
from typing import Any, Protocol

import numpy as np

MANIFEST = "manifest.json"
POINTS_DIR = "points"
QUARANTINE_DIR = "quarantine"


class Codec(Protocol):
    """How one kind of point file is written and read back.

    ``write(path, record)`` and ``read(path) -> record`` with ``record`` a dict of ``key``
    (str), ``fields`` (the point's inputs, JSON-able), ``settings`` (dict), ``result`` (the
    point's result dict) and ``checksum`` (str; ``read`` gives None for files written
    before checksums were kept).
    """

    suffix: str

    def write(self, path: str, record: dict) -> None: ...

    def read(self, path: Path) -> dict: ...


def point_key(fields: dict, settings: dict) -> str:
    """The name of a point's file: a hash of its inputs and the run's settings.

    A point is identified by its inputs, not by its grid index: a grid that is extended,
    reordered or re-parametrised still finds it. (The inputs are hashed under the name
    ``drive``, as the first stores, of sweeps of drives, did: their points keep their names.)
    """
    text = json.dumps({"drive": fields, "settings": settings}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def checksum(key: str, result: dict) -> str:
    """A hash of a point's key and result values (floats by their exact repr)."""
    text = json.dumps({"key": key, "result": {k: _plain(v) for k, v in result.items()}}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


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


def atomic_write(path: Path, write) -> None:
    """``write(tmp)`` to a temporary file beside ``path``, then rename it to ``path``."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)  # readers never see half a file; an interrupted write leaves a .tmp-*
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def diff(old: dict, new: dict, prefix: str = "") -> list[str]:
    """``key: stored a, now b`` for every leaf where two nested dicts differ."""
    out = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k, "<absent>"), new.get(k, "<absent>")
        if isinstance(a, dict) and isinstance(b, dict):
            out += diff(a, b, f"{prefix}{k}.")
        elif a != b:
            out.append(f"{prefix}{k}: stored {a!r}, now {b!r}")
    return out


class OtherFormat(ValueError):
    """A readable manifest of another kind or format of store: not damage, so not for quarantine."""


class _Mismatch(ValueError):
    """A readable point file that belongs to another point or other settings, or was altered."""


def read_manifest(path: Path, kind: str, fmt: int, required: tuple = ("settings",)) -> dict:
    """The manifest as a dict; a ``ValueError`` naming the file and what is wrong with it."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"store manifest {str(path)!r} is unreadable ({type(exc).__name__}: {exc})") from None
    if not isinstance(doc, dict):
        raise ValueError(f"store manifest {str(path)!r} is not a JSON object")
    if "kind" in doc and doc["kind"] != kind:
        raise OtherFormat(f"store {str(path.parent)!r} holds a {doc['kind']} (its {MANIFEST} says so), not a {kind}: "
                          f"use another store")
    if "format" in doc and doc["format"] != fmt:
        raise OtherFormat(f"store {str(path.parent)!r} has format {doc['format']!r}, expected {fmt} (a {kind} store "
                          f"written by another version of impactosc, see {str(path)!r}): use a new store, or "
                          f"delete this one to start over")
    missing = [k for k in ("format", *required) if k not in doc]
    if missing:
        raise ValueError(f"store manifest {str(path)!r} lacks {', '.join(missing)}")
    if not isinstance(doc["settings"], dict):
        raise ValueError(f"store manifest {str(path)!r}: 'settings' must be a JSON object")
    return doc


class PointStore:
    """A store at ``root``; ``PointStore.create`` for a run, ``PointStore.read`` to load one back."""

    def __init__(self, root: Path, settings: dict, codec: Codec, *, read_only: bool):
        self.root = root
        self.settings = settings
        self.codec = codec
        self.read_only = read_only
        self.bad: list[str] = []  # "file (reason)" of every file that could not be used
        self.save_error: OSError | None = None

    # -- opening -------------------------------------------------------------------------
    @classmethod
    def create(cls, store, settings: dict, codec: Codec, *, kind: str, fmt: int, extra: dict | None = None,
               required: tuple = ("settings",), version: str = "") -> PointStore:
        """Open or start a store, writing its manifest (before anything runs).

        A store made with other settings raises a ``ValueError`` listing the differences; a
        store of another kind or format raises a ``ValueError`` naming it; a damaged
        manifest is moved to ``quarantine/`` with a warning (the point files say themselves
        which settings they belong to, so none is used wrongly).
        """
        root = check_store_path(store)
        manifest_path = root / MANIFEST
        if manifest_path.exists():
            try:
                old = read_manifest(manifest_path, kind, fmt, required)
            except OtherFormat:
                raise
            except ValueError as exc:
                moved = quarantine(root, manifest_path)
                warnings.warn(f"{exc}; moved to {str(moved)!r} and replaced: the points already stored are "
                              f"still used where they match this run", RuntimeWarning, stacklevel=3)
            else:
                diffs = diff(old["settings"], settings)
                if diffs:
                    raise ValueError(f"store {str(root)!r} was made with different settings; its points would not "
                                     f"be comparable with this {kind}'s ({'; '.join(diffs)}). Use a new store, or "
                                     f"delete this one to start over.")
        (root / POINTS_DIR).mkdir(parents=True, exist_ok=True)
        manifest = {"kind": kind, "format": fmt, "settings": settings, **(extra or {}), "impactosc_version": version}
        atomic_write(manifest_path, lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=1)))
        return cls(root, settings, codec, read_only=False)

    @classmethod
    def read(cls, store, codec: Codec, *, kind: str, fmt: int, required: tuple = ("settings",)
             ) -> tuple[PointStore, dict]:
        """An existing store and its manifest, without changing anything on disk."""
        root = Path(store)
        manifest_path = root / MANIFEST
        if not manifest_path.is_file():
            raise FileNotFoundError(f"{str(root)!r} is not a {kind} store: it has no {MANIFEST}")
        manifest = read_manifest(manifest_path, kind, fmt, required)
        return cls(root, manifest["settings"], codec, read_only=True), manifest

    # -- points --------------------------------------------------------------------------
    def path(self, key: str) -> Path:
        return self.root / POINTS_DIR / f"{key}{self.codec.suffix}"

    def load(self, key: str) -> Any:
        """The stored result of point ``key``, or None if it is missing or unusable.

        An unusable file is recorded in ``bad`` (see ``warn_unusable``); a writable
        store also moves it to ``quarantine/``, so the point is computed and saved again.
        """
        path = self.path(key)
        if not path.exists():
            return None
        try:
            with interrupt_deferred():
                return self._verified(path, key)
        except Exception as exc:  # noqa: BLE001 - any damage: the point is recomputed, the file kept aside
            reason = f"{type(exc).__name__}: {exc}" if not isinstance(exc, _Mismatch) else str(exc)
            if not self.read_only:
                try:
                    quarantine(self.root, path)
                except OSError as move_exc:
                    reason += f"; could not move it aside: {move_exc}"
            self.bad.append(f"{path.name} ({reason})")
            return None

    def _verified(self, path: Path, key: str):
        record = self.codec.read(path)
        stored_key = record["key"]
        # Files written before the settings were recorded in them have the input check only.
        settings = record["settings"] if record["settings"] is not None else self.settings
        if stored_key != key:
            raise _Mismatch(f"it holds point {stored_key}, not {key}")
        if settings != self.settings:
            raise _Mismatch(f"it was computed with other settings ({'; '.join(diff(settings, self.settings))})")
        if point_key(record["fields"], settings) != key:
            raise _Mismatch("its inputs and settings do not hash to its name")
        if record["checksum"] is not None and record["checksum"] != checksum(key, record["result"]):
            raise _Mismatch("its values do not match its checksum (altered after it was written)")
        return record["result"]

    def save(self, key: str, fields: dict, result: dict) -> None:
        """Save one finished point.

        A failed write (disk full, permissions) warns once and the run goes on without
        saving: the points computed so far are not thrown away for want of a disk.
        """
        if self.save_error is not None:
            return
        record = {"key": key, "fields": fields, "settings": self.settings, "result": result,
                  "checksum": checksum(key, result)}
        try:
            with interrupt_deferred():
                atomic_write(self.path(key), lambda tmp: self.codec.write(tmp, record))
        except OSError as exc:
            self.save_error = exc
            warnings.warn(f"store {str(self.root)!r}: cannot save point {key} ({exc}); the run goes on, but the "
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


def quarantine(root: Path, path: Path) -> Path:
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
