"""The sweep store under damage: unusable point files and manifests are named, set aside and recomputed."""

from __future__ import annotations

import json
import shutil
import signal
import threading
import time

import pytest
import xarray as xr

from impactosc.model import TapeDrive
from impactosc.runner import _store as _runner_store
from impactosc.sweeps import STATUS_NOT_COMPUTED, load_sweep, sweep
from impactosc.sweeps._store import STORE_FORMAT

BASE = TapeDrive(clearance=50e-6)
GRID = {"speed": [4.0, 8.0, 12.0]}
DURATION = 2e-4
KW = {"duration": DURATION, "executor": "serial", "progress": False}


class Counting:
    """A serial executor that counts the points it runs."""

    def __init__(self):
        self.n_points = 0

    def submit(self, fn, *args):
        import concurrent.futures as cf

        self.n_points += len(args[1])  # run_batch(point_function, points, *point_args)
        fut = cf.Future()
        fut.set_result(fn(*args))
        return fut


@pytest.fixture()
def filled(tmp_path):
    """A complete store of GRID and the Dataset it gives."""
    store = tmp_path / "st"
    ds = sweep(BASE, GRID, store=store, **KW)
    return store, ds


def _points(store):
    return sorted((store / "points").glob("[!.]*.nc"))


def _rerun(store):
    ex = Counting()
    ds = sweep(BASE, GRID, store=store, **{**KW, "executor": ex})
    return ds, ex.n_points


@pytest.mark.parametrize(
    "damage",
    [
        pytest.param(lambda p: p.write_bytes(b""), id="empty"),
        pytest.param(lambda p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2]), id="truncated"),
        pytest.param(lambda p: p.write_bytes(b"not a netCDF file at all\n" * 20), id="garbage"),
    ],
)
def test_an_unreadable_point_file_is_named_quarantined_and_recomputed(filled, damage):
    store, ds = filled
    bad = _points(store)[1]
    damage(bad)
    # load_sweep reads only: it names the file, counts the point as not computed, moves nothing
    with pytest.warns(RuntimeWarning) as rec:
        partial = load_sweep(store)
    messages = " | ".join(str(w.message) for w in rec)
    assert f"1 point file(s) unusable (treated as not computed): {bad.name}" in messages
    assert "incomplete: 1 of 3 points not computed" in messages
    assert int((partial["status"] == STATUS_NOT_COMPUTED).sum()) == 1 and bad.exists()
    with pytest.warns(RuntimeWarning, match=rf"unusable \(moved to quarantine/ and computed again\): {bad.name}"):
        again, n_run = _rerun(store)
    assert n_run == 1  # only the damaged point
    xr.testing.assert_identical(again, ds)
    assert (store / "quarantine" / bad.name).exists()
    assert len(_points(store)) == 3
    xr.testing.assert_identical(load_sweep(store), ds)  # and the store is whole again


def test_swapped_point_files_are_detected_by_their_keys(filled):
    store, ds = filled
    a, b = _points(store)[:2]
    tmp = a.with_suffix(".swap")
    shutil.move(a, tmp)
    shutil.move(b, a)
    shutil.move(tmp, b)
    with pytest.warns(RuntimeWarning, match=r"2 point file\(s\) unusable.*holds point"):
        again, n_run = _rerun(store)
    assert n_run == 2
    xr.testing.assert_identical(again, ds)


def test_a_point_file_of_other_settings_under_a_valid_name_is_not_used(filled, tmp_path):
    # Same drive, other duration: the file's own key is right for its settings, not for this store's.
    store, ds = filled
    other = tmp_path / "other"
    sweep(BASE, GRID, store=other, **{**KW, "duration": 2 * DURATION})
    target = _points(store)[0]
    src = _points(other)[0]
    with xr.open_dataset(src, engine="scipy") as d:
        d = d.load()
    d.attrs["key"] = target.stem  # a forged name: only the settings stored in the file can tell
    target.unlink()
    d.to_netcdf(target, engine="scipy")
    with pytest.warns(RuntimeWarning, match=r"computed with other settings \(duration: stored 0\.0004, now 0\.0002"):
        again, n_run = _rerun(store)
    assert n_run == 1
    xr.testing.assert_identical(again, ds)


@pytest.mark.parametrize("text", ["", "{not json", "[1, 2]", f'{{"format": {STORE_FORMAT}}}'])
def test_a_damaged_manifest_is_replaced_and_the_points_still_resume(filled, text):
    store, ds = filled
    manifest = store / "manifest.json"
    manifest.write_text(text)
    with pytest.raises(ValueError, match=r"manifest\.json"):
        load_sweep(store)  # read-only: it cannot know the grid, and says which file is at fault
    with pytest.warns(RuntimeWarning, match=r"manifest\.json.*moved to .*quarantine"):
        again, n_run = _rerun(store)
    assert n_run == 0  # every point file still matches this sweep's settings
    xr.testing.assert_identical(again, ds)
    assert json.loads(manifest.read_text())["format"] == STORE_FORMAT
    xr.testing.assert_identical(load_sweep(store), ds)


def test_a_manifest_of_another_format_is_refused_not_quarantined(filled):
    store, _ = filled
    manifest = store / "manifest.json"
    doc = json.loads(manifest.read_text())
    doc["format"] = 99
    manifest.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=f"format 99, expected {STORE_FORMAT}"):
        sweep(BASE, GRID, store=store, **KW)
    assert json.loads(manifest.read_text())["format"] == 99


def test_a_store_that_is_a_file_raises_before_running(tmp_path):
    path = tmp_path / "a_file"
    path.write_text("x")
    ex = Counting()
    with pytest.raises(ValueError, match=r"store .*a_file.* is not a directory"):
        sweep(BASE, GRID, store=path, **{**KW, "executor": ex})
    assert ex.n_points == 0


def test_a_bad_option_writes_no_store(tmp_path):
    store = tmp_path / "st"
    with pytest.raises(ValueError, match="tol"):
        sweep(BASE, GRID, store=store, tol=0.0, **KW)
    assert not store.exists()


def test_a_failing_save_warns_once_and_the_sweep_keeps_its_results(tmp_path, monkeypatch):
    atomic_write = _runner_store.atomic_write

    def disk_full(path, write):  # the manifest still fits, the point files do not
        if path.suffix == ".nc":
            raise OSError(28, "No space left on device")
        atomic_write(path, write)

    store = tmp_path / "st"
    sweep(BASE, {"speed": [4.0]}, store=store, **KW)
    monkeypatch.setattr(_runner_store, "atomic_write", disk_full)
    with pytest.warns(RuntimeWarning, match="cannot save point .*No space left") as rec:
        ds = sweep(BASE, GRID, store=store, **KW)
    assert len([w for w in rec if "cannot save" in str(w.message)]) == 1
    assert (ds["status"] == 0).all()


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="POSIX signals")
@pytest.mark.usefixtures("sigint_raises")  # Ctrl-C must raise, however pytest was started
def test_a_ctrl_c_during_a_point_write_is_delivered_after_it(tmp_path, monkeypatch):
    # An interrupt inside xarray's file manager could leave its lock held: the sweep then
    # deadlocked on its own cleanup instead of stopping. The write now finishes first.
    to_netcdf = xr.Dataset.to_netcdf

    def interrupted_write(self, *args, **kwargs):
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)  # Ctrl-C, mid-write
        time.sleep(0.05)  # Python runs signal handlers here, inside the write
        return to_netcdf(self, *args, **kwargs)

    store = tmp_path / "st"
    monkeypatch.setattr(xr.Dataset, "to_netcdf", interrupted_write)
    with pytest.raises(KeyboardInterrupt):
        sweep(BASE, GRID, store=store, **KW)
    monkeypatch.undo()
    assert len(_points(store)) == 1  # the point being written when Ctrl-C came is whole, and the sweep stopped
    assert not list((store / "points").glob(".tmp-*"))
    with pytest.warns(RuntimeWarning, match="2 of 3 points not computed"):
        assert int((load_sweep(store)["status"] == 0).sum()) == 1
