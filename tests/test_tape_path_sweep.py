"""Sweeps of a tape path over its SI parameters (issue 28, item 3), through the runner and its store."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from impactosc import Guide, TapeDrive, TapePath
from impactosc.sweeps import _path_point, simulate_path, sweep_path

PATH = TapePath(TapeDrive(clearance=40e-6, friction=0.0, damping_ratio=0.01),
                [Guide(0.02, clearance=150e-6), Guide(0.05)], end_span=0.03)
DURATION = 1e-3


def test_every_point_is_the_run_of_its_path():
    grid = {"speed": [2.0, 4.0], "guide1_clearance": [30e-6, 60e-6, 1e-3]}
    ds = sweep_path(PATH, grid, duration=DURATION, executor="serial", progress=False)
    assert ds.mean_flange_force.dims == ("speed", "guide1_clearance", "guide")
    assert ds.status.dims == ("speed", "guide1_clearance")
    assert ds.mean_flange_force.attrs["units"] == "N" and ds.flange_impulse.attrs["units"] == "N s"
    assert ds.impact_rate.attrs["units"] == "1/s" and ds.speed.attrs["units"] == "m/s"
    assert ds.guide1_clearance.attrs["units"] == "m" and "guide 1" in ds.guide1_clearance.attrs["long_name"]
    np.testing.assert_array_equal(ds.guide_position, [0.02, 0.05])
    assert ds.attrs["duration"] == DURATION and TapePath.from_dict(__import__("json").loads(ds.attrs["base_path"])) \
        == PATH
    assert (ds.status == 0).all()
    for speed in grid["speed"]:
        for c in grid["guide1_clearance"]:
            run = simulate_path(PATH.with_parameter("speed", speed).with_parameter("guide1_clearance", c), DURATION)
            pt = ds.sel(speed=speed, guide1_clearance=c)
            np.testing.assert_allclose(pt.mean_flange_force, run.mean_flange_force(), rtol=1e-12, atol=0)
            np.testing.assert_allclose(pt.impact_rate, run.impacts_per_second(), rtol=1e-12, atol=0)
            np.testing.assert_allclose(pt.mean_flange_force_upper + pt.mean_flange_force_lower,
                                       pt.mean_flange_force, rtol=1e-12)
            assert pt.simulated_time == pytest.approx(DURATION, rel=1e-12)
    # The widest clearance is never reached; the tightest is.
    assert (ds.contacts.sel(guide1_clearance=1e-3, guide=1) == 0).all()
    assert (ds.contacts.sel(guide1_clearance=30e-6, guide=1) > 0).all()


def test_an_executor_gives_the_same_dataset():
    grid = {"tension": [0.5, 1.0, 2.0]}
    serial = sweep_path(PATH, grid, duration=DURATION, executor="serial", progress=False)
    with ThreadPoolExecutor(2) as pool:
        threaded = sweep_path(PATH, grid, duration=DURATION, executor=pool, progress=False)
    np.testing.assert_allclose(threaded.mean_flange_force, serial.mean_flange_force, rtol=1e-12)
    assert serial.mean_flange_force.dims == ("tension", "guide")


def test_the_store_keeps_points_and_a_rerun_computes_only_new_ones(tmp_path, monkeypatch):
    store = tmp_path / "store"
    first = sweep_path(PATH, {"speed": [2.0, 4.0]}, duration=DURATION, executor="serial", progress=False,
                       store=store)
    assert len(list((store / "points").glob("*.nc"))) == 2
    calls = []
    real = _path_point.simulate_path

    def counting(path, *args, **kwargs):
        calls.append(path.drive.speed)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(_path_point, "simulate_path", counting)
    second = sweep_path(PATH, {"speed": [2.0, 4.0, 8.0]}, duration=DURATION, executor="serial", progress=False,
                        store=store)
    assert calls == [8.0]
    np.testing.assert_array_equal(second.mean_flange_force.sel(speed=[2.0, 4.0]), first.mean_flange_force)
    with pytest.raises(ValueError, match="different settings"):
        sweep_path(PATH, {"speed": [2.0]}, duration=2 * DURATION, executor="serial", progress=False, store=store)


def test_invalid_points_are_recorded_not_raised():
    with pytest.warns(RuntimeWarning, match="1 of 2 points failed"):
        ds = sweep_path(PATH, {"guide0_position": [0.01, 0.06]}, duration=DURATION, executor="serial",
                        progress=False)
    bad = ds.sel(guide0_position=0.06)
    assert int(bad.status) == -2 and r"guides[1].position must be >" in str(bad.message)
    assert np.isnan(bad.mean_flange_force).all()
    assert int(ds.status.sel(guide0_position=0.01)) == 0


def test_no_grid_runs_the_base_path():
    ds = sweep_path(PATH, None, duration=DURATION, executor="serial", progress=False)
    assert ds.mean_flange_force.dims == ("guide",)
    np.testing.assert_allclose(ds.mean_flange_force, simulate_path(PATH, DURATION).mean_flange_force(), rtol=1e-12)


@pytest.mark.parametrize("grid, error, match", [
    ({"sped": [1.0]}, ValueError, "'sped' is not a path parameter"),
    ({"guide2_clearance": [1e-5]}, ValueError, "names guide 2, but the path has 2 guides"),
    ({"speed": []}, ValueError, r"grid\['speed'\] is empty"),
    ({"speed": [1.0, 1.0]}, ValueError, "duplicate values"),
    ({"speed": [[1.0, 2.0]]}, ValueError, "1-D sequence"),
    ({"speed": [float("nan")]}, ValueError, r"grid\['speed'\] must be finite"),
    ({"speed": ["fast"]}, TypeError, r"grid\['speed'\] must be a real number"),
    ([("speed", [1.0])], TypeError, "grid must be a dict"),
])
def test_bad_grids_raise_before_anything_runs(grid, error, match):
    with pytest.raises(error, match=match):
        sweep_path(PATH, grid, duration=DURATION, executor="serial", progress=False)


def test_bad_arguments_name_themselves():
    with pytest.raises(ValueError, match="duration must be > 0"):
        sweep_path(PATH, {}, duration=0.0)
    with pytest.raises(TypeError, match="base must be a TapePath"):
        sweep_path(TapeDrive(), {}, duration=DURATION)
    with pytest.raises(ValueError, match="q0 must hold 2 finite numbers"):
        simulate_path(PATH, DURATION, q0=[0.0])


@pytest.mark.parametrize("module", ["impactosc.sweeps._path_point", "impactosc.sweeps._path_sweep"])
def test_examples_in_the_docstrings_run(module):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted > 0 and result.failed == 0


def test_a_one_guide_path_sweep_is_the_tape_drive_sweep():
    """The one-guide path is the paper's drive: its sweep gives the drive sweep's forces and contact counts."""
    from impactosc import sweep

    drive = TapeDrive(clearance=50e-6, friction=0.0, damping_ratio=0.01)
    grid = {"speed": [2.0, 8.0], "pack_diameter": [0.05, 0.09]}
    path_ds = sweep_path(TapePath.from_drive(drive), grid, duration=DURATION, executor="serial", progress=False)
    drive_ds = sweep(drive, grid, duration=DURATION, backend="exact", executor="serial", progress=False, x0=0.0,
                     v0=0.0)
    assert (path_ds.status == 0).all() and (drive_ds.status == 0).all()
    assert (drive_ds.impacts > 0).any()
    np.testing.assert_allclose(path_ds.mean_flange_force.sel(guide=0), drive_ds.mean_flange_force, rtol=1e-9,
                               atol=1e-12)
    np.testing.assert_allclose(path_ds.mean_flange_force_upper.sel(guide=0), drive_ds.mean_flange_force_upper,
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(path_ds.contacts.sel(guide=0), drive_ds.impacts)


def test_load_path_sweep_reads_the_store_back(tmp_path):
    from impactosc.sweeps import load_path_sweep

    store = tmp_path / "store"
    ds = sweep_path(PATH, {"speed": [2.0, 4.0]}, duration=DURATION, executor="serial", progress=False, store=store)
    loaded = load_path_sweep(store)
    np.testing.assert_array_equal(loaded.mean_flange_force, ds.mean_flange_force)
    assert loaded.attrs["duration"] == DURATION and loaded.mean_flange_force.attrs["units"] == "N"
    # One point file gone: that point is "not computed", the other is kept.
    files = sorted((store / "points").glob("*.nc"))
    files[0].unlink()
    with pytest.warns(RuntimeWarning, match="1 of 2 points not computed"):
        partial = load_path_sweep(store)
    assert sorted(partial.status.values.tolist()) == [-4, 0]
    with pytest.raises(FileNotFoundError, match="no manifest.json"):
        load_path_sweep(tmp_path / "nothing")
