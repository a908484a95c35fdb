"""sweep(): grid -> Dataset in SI units, on every executor, with a resumable store and failed points recorded.

Short runs (2 ms of tape motion) on a drive with a 50 um clearance, so that the tape
edge does hit the flanges (F = run-out / L > 1) and the force statistics are not all zero.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import os
import sys
import threading
from concurrent.futures.process import BrokenProcessPool

import numpy as np
import pytest
import xarray as xr

import impactosc
from impactosc.model import TapeDrive

from impactosc.runner import _exec as _runner_exec  # isort: skip
from impactosc.sweeps import STATUS_EXCEPTION, STATUS_LOST, STATUS_NOT_COMPUTED, load_sweep, sweep  # isort: skip

DURATION = 2e-3
BASE = TapeDrive(clearance=50e-6)
GRID = {"pack_diameter": [0.05, 0.09], "speed": [4.0, 8.0]}


class RecordingExecutor(cf.Executor):
    """Runs tasks in this process at submit time and remembers every point it was given."""

    def __init__(self, fail_when=None):
        self.points = []  # drive fields of every submitted point
        self.tasks = 0
        self.fail_when = fail_when  # fields -> exception to raise for the whole task, or None

    def submit(self, fn, /, *args, **kwargs):
        self.tasks += 1
        chunk = args[1]  # run_batch(point_function, chunk, *point_args)
        self.points.extend(fields for _, fields in chunk)
        fut = cf.Future()
        exc = next((e for _, f in chunk if self.fail_when and (e := self.fail_when(f)) is not None), None)
        if exc is not None:
            fut.set_exception(exc)
        else:
            fut.set_result(fn(*args, **kwargs))
        return fut


@pytest.fixture(scope="module")
def serial():
    return sweep(BASE, GRID, duration=DURATION, executor="serial", progress=False)


def test_serial_values_equal_direct_simulate_calls(serial):
    ds = serial
    assert ds["mean_flange_force"].dims == ("pack_diameter", "speed")
    np.testing.assert_array_equal(ds["pack_diameter"].values, GRID["pack_diameter"])
    np.testing.assert_array_equal(ds["speed"].values, GRID["speed"])
    for d in GRID["pack_diameter"]:
        for v in GRID["speed"]:
            drive = BASE.replace(pack_diameter=d, speed=v)
            sol = impactosc.simulate(drive.oscillator(), drive.seconds_to_lambda(DURATION), 0.95, 0.0,
                                     record="stats", backend="auto")  # sweep's default
            pt = ds.sel(pack_diameter=d, speed=v)
            fs = drive.force_scale
            assert int(pt["status"]) == 0 and pt["message"].item() == sol.message
            assert float(pt["mean_flange_force"]) == pytest.approx(sol.mean_flange_force() * fs, rel=1e-12)
            assert float(pt["mean_flange_force_upper"]) == pytest.approx(sol.mean_flange_force(1) * fs, rel=1e-12)
            assert float(pt["rms_flange_force"]) == pytest.approx(sol.rms_flange_force() * fs, rel=1e-12)
            assert float(pt["impacts"]) == sol.contact_entries()
            assert float(pt["impacts_lower"]) == sol.contact_entries(-1)
            assert float(pt["impact_rate"]) == pytest.approx(sol.contact_entries() / DURATION, rel=1e-9)
            assert float(pt["sticks"]) == sol.counts["stick"]
            assert float(pt["releases"]) == sol.counts["release"]
            assert float(pt["reversals"]) == sol.counts["reversal"]
            assert float(pt["max_penetration"]) == pytest.approx(sol.max_penetration() * 50e-6 * 1e6, rel=1e-12)
            assert float(pt["peak_flange_force"]) == pytest.approx(sol.max_flange_force() * fs, rel=1e-12)
            assert float(pt["contact_fraction"]) == pytest.approx(sol.contact_time() / sol.t_final, rel=1e-12)
            assert (float(pt["F"]), float(pt["Omega"]), float(pt["beta"]), float(pt["K"])) == (
                drive.F, drive.Omega, drive.beta, drive.K)
    # the chosen drive really contacts the flanges, so the force comparison means something
    assert (ds["impacts"] > 0).all() and (ds["mean_flange_force"] > 0).all()
    assert ds["mean_flange_force"].attrs["units"] == "N" and ds["mean_flange_force"].attrs["long_name"]
    assert ds["max_penetration"].attrs["units"] == "um"
    assert ds["impact_rate"].attrs["units"] == "1/s"
    assert ds["speed"].attrs["units"] == "m/s" and ds["pack_diameter"].attrs["units"] == "m"
    assert ds.attrs["base_clearance"] == 50e-6 and ds.attrs["base_bending"] == "in-plane"
    assert ds.attrs["duration"] == DURATION and ds.attrs["backend"] == "auto"
    assert ds.attrs["backend_used"] == "exact"  # the linear spring flange, with numba
    assert ds.attrs["x0"] == 0.95 and ds.attrs["v0"] == 0.0
    assert ds.attrs["impactosc_version"] == impactosc.__version__


@pytest.mark.slow  # a process pool
def test_process_pool_equals_serial(serial):
    pooled = sweep(BASE, GRID, duration=DURATION, progress=False)  # default: local process pool
    xr.testing.assert_identical(pooled, serial)


@pytest.mark.slow  # a dask LocalCluster
def test_dask_local_cluster_equals_serial(serial):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
            distributed.Client(cl) as client:
        ds = sweep(BASE, GRID, duration=DURATION, executor=client, progress=False)
        current = sweep(BASE, GRID, duration=DURATION, executor="dask", progress=False)  # the current client
    xr.testing.assert_identical(ds, serial)
    xr.testing.assert_identical(current, serial)


def test_a_closed_dask_client_is_refused_by_name():
    distributed = pytest.importorskip("distributed")
    client = distributed.Client(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None)
    client.close()
    with pytest.raises(ValueError, match=r"executor is a dask\.distributed\.Client that is closed"):
        sweep(BASE, GRID, duration=DURATION, executor=client, progress=False)


def test_dask_missing_gives_install_hint(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # makes `import distributed` fail
    with pytest.raises(ImportError, match=r"pip install impactosc\[dask\]"):
        sweep(BASE, GRID, duration=DURATION, executor="dask", progress=False)


def test_store_resume_recomputes_nothing_then_only_missing_points(tmp_path, serial):
    store = tmp_path / "st"
    sub = {"pack_diameter": [0.05], "speed": [4.0, 8.0]}
    first = RecordingExecutor()
    sweep(BASE, sub, duration=DURATION, executor=first, progress=False, store=store)
    assert len(first.points) == 2

    # The full grid into the same store: only the two new points run.
    second = RecordingExecutor()
    ds = sweep(BASE, GRID, duration=DURATION, executor=second, progress=False, store=store)
    assert sorted((p["pack_diameter"], p["speed"]) for p in second.points) == [(0.09, 4.0), (0.09, 8.0)]
    xr.testing.assert_identical(ds, serial)

    # Same arguments again: nothing is submitted, everything is read back exactly.
    third = RecordingExecutor()
    again = sweep(BASE, GRID, duration=DURATION, executor=third, progress=False, store=store)
    assert third.tasks == 0
    xr.testing.assert_identical(again, serial)
    xr.testing.assert_identical(load_sweep(store), serial)
    assert sweep.load is load_sweep  # impactosc.sweep.load once the package root exports the function

    # A lost point file (as after a crash) is the only thing recomputed.
    files = sorted((store / "points").glob("*.nc"))
    assert len(files) == 4
    files[0].unlink()
    with pytest.warns(RuntimeWarning, match="1 of 4 points not computed"):
        partial = load_sweep(store)
    assert int((partial["status"] == STATUS_NOT_COMPUTED).sum()) == 1
    fourth = RecordingExecutor()
    xr.testing.assert_identical(sweep(BASE, GRID, duration=DURATION, executor=fourth, progress=False, store=store),
                                serial)
    assert len(fourth.points) == 1


def test_interrupted_sweep_keeps_finished_points(tmp_path, serial):
    store = tmp_path / "st"

    class Interrupting(RecordingExecutor):
        def submit(self, fn, /, *args, **kwargs):
            if self.tasks == 2:  # Ctrl-C while the third task runs
                self.tasks += 1
                fut = cf.Future()
                # Delivered (1 s later) after the finished tasks, as a real interrupt would be: done
                # at submit time, as_completed could yield it first (set order) - a flaky test.
                threading.Timer(1.0, fut.set_exception, args=(KeyboardInterrupt(),)).start()
                return fut
            return super().submit(fn, *args, **kwargs)

    ex = Interrupting()
    with pytest.raises(KeyboardInterrupt):
        sweep(BASE, GRID, duration=DURATION, executor=ex, progress=False, store=store)
    done = len(list((store / "points").glob("*.nc")))
    assert 0 < done < 4 and not list((store / "points").glob(".tmp-*"))
    rerun = RecordingExecutor()
    ds = sweep(BASE, GRID, duration=DURATION, executor=rerun, progress=False, store=store)
    assert len(rerun.points) == 4 - done
    xr.testing.assert_identical(ds, serial)


@pytest.mark.parametrize(
    ("change", "expected"),
    [({"duration": 3e-3}, "duration"), ({"base": BASE.replace(speed=5.0)}, "base.speed"),
     ({"tol": 1e-12}, "options.tol"), ({"x0": 0.5}, "x0")],
)
def test_store_with_other_settings_raises(tmp_path, change, expected):
    store = tmp_path / "st"
    grid = {"speed": [4.0]}
    sweep(BASE, grid, duration=DURATION, executor="serial", progress=False, store=store)
    kwargs = {"duration": DURATION, "executor": "serial", "progress": False, "store": store, **change}
    base = kwargs.pop("base", BASE)
    with pytest.raises(ValueError, match=expected):
        sweep(base, grid, **kwargs)


def test_failed_points_are_recorded_not_raised():
    # 0.2 m is outside the run-out law (an invalid drive); the 50 um clearance runs into the
    # event limit (status 1); the 1 mm clearance is fine.
    grid = {"pack_diameter": [0.05, 0.2], "clearance": [1e-3, 50e-6]}
    with pytest.warns(RuntimeWarning, match=r"3 of 4 points failed.*pack_diameter=0\.2") as rec:
        ds = sweep(BASE, grid, duration=DURATION, executor="serial", progress=False, max_events=400)
    assert len(rec) == 1
    ok = ds.sel(pack_diameter=0.05, clearance=1e-3)
    assert int(ok["status"]) == 0 and float(ok["reversals"]) > 0
    limit = ds.sel(pack_diameter=0.05, clearance=50e-6)
    assert int(limit["status"]) == 1 and "event" in limit["message"].item().lower()
    assert math.isnan(float(limit["mean_flange_force"])) and math.isnan(float(limit["sticks"]))
    assert float(limit["F"]) == BASE.replace(pack_diameter=0.05).F  # the inputs are still known
    bad = ds.sel(pack_diameter=0.2)
    assert (bad["status"] == STATUS_EXCEPTION).all()
    assert all("pack_diameter" in str(m) for m in bad["message"].values)
    assert bool(np.isnan(bad["mean_flange_force"]).all()) and bool(np.isnan(bad["F"]).all())


def test_a_crashed_worker_loses_only_its_point(monkeypatch):
    # The task holding the guilty point dies as a whole (as when its process crashes), taking
    # the innocent points of its batch with it: they are retried, the guilty point is lost alone.
    monkeypatch.setattr(_runner_exec, "TASK_SECONDS", 1e9)  # batches as large as load balance allows
    grid = {"pack_diameter": [0.05, 0.09], "speed": [4.0, 8.0, 12.0, 16.0]}

    def guilty(f):
        return f["pack_diameter"] == 0.05 and f["speed"] == 16.0

    class Sizes(RecordingExecutor):
        def submit(self, fn, /, *args, **kwargs):
            self.sizes.append([guilty(f) for _, f in args[1]])
            return super().submit(fn, *args, **kwargs)

    ex = Sizes(fail_when=lambda f: BrokenProcessPool("worker died") if guilty(f) else None)
    ex.sizes, ex._max_workers = [], 1
    with pytest.warns(RuntimeWarning, match=r"1 of 8 points failed.*pack_diameter=0\.05, speed=16\.0"):
        ds = sweep(BASE, grid, duration=DURATION, executor=ex, progress=False)
    bad = ds.sel(pack_diameter=0.05, speed=16.0)
    assert int(bad["status"]) == STATUS_LOST and "worker died" in bad["message"].item()
    serial = sweep(BASE, grid, duration=DURATION, executor="serial", progress=False)
    good = ds["status"] == 0
    assert int(good.sum()) == 7
    xr.testing.assert_identical(ds["mean_flange_force"].where(good), serial["mean_flange_force"].where(good))
    # first in a batch with innocent points, then retried alone, then alone with nothing else running
    with_guilty = [s for s in ex.sizes if any(s)]
    assert len(with_guilty[0]) > 1 and [len(s) for s in with_guilty[1:]] == [1, 1]
    # the innocent points of that batch were retried one per task, and not lost
    assert sum(len(s) == 1 and not any(s) for s in ex.sizes) >= len(with_guilty[0]) - 1


def test_a_sweep_that_loses_every_point_raises():
    ex = RecordingExecutor(fail_when=lambda f: BrokenProcessPool("no worker would start"))
    with pytest.raises(RuntimeError, match=r"all 4 points run were lost.*no worker would start"):
        sweep(BASE, GRID, duration=DURATION, executor=ex, progress=False)


def test_cheap_points_share_tasks_and_each_runs_once():
    # Batches are sized from the measured cost of a point (issue #12): many cheap points
    # share a task, and every point is submitted exactly once.
    grid = {"speed": [4.0 + i for i in range(40)]}
    ex = RecordingExecutor()
    ex._max_workers = 2
    ds = sweep(BASE, grid, duration=1e-5, executor=ex, progress=False)
    assert (ds["status"] == 0).all()
    assert sorted(p["speed"] for p in ex.points) == grid["speed"]
    assert ex.tasks < len(grid["speed"]) / 2


class _ExitOnUnpickle(float):
    """A valid ``tol`` here that kills the process unpickling it: a stand-in for a worker that segfaults."""

    def __reduce__(self):
        return (os._exit, (3,))


@pytest.mark.slow  # process pools
def test_a_real_crashed_pool_worker_breaks_the_pool_which_is_replaced():
    # Every task kills its worker process, so the default pool breaks and is replaced each
    # round; the point is lost, and a sweep losing every point raises.
    with pytest.raises(RuntimeError, match="all 1 points run were lost.*TerminatedWorkerError"):
        sweep(BASE, {"speed": [4.0]}, duration=DURATION, progress=False, tol=_ExitOnUnpickle(1e-15))
    # the replaced pool works
    ds = sweep(BASE, {"speed": [4.0]}, duration=DURATION, progress=False)
    assert int(ds["status"].item()) == 0


def test_t_sin_half_theta_sets_the_tension_keeping_theta():
    ds = sweep(BASE, {"t_sin_half_theta": [0.5, 1.0], "wrap_angle": [60.0, 90.0]}, duration=1e-4,
               executor="serial", progress=False)
    assert ds["t_sin_half_theta"].attrs["units"] == "N"
    for tst in (0.5, 1.0):
        for theta in (60.0, 90.0):
            drive = TapeDrive.from_t_sin_half_theta(tst, **{**_fields(BASE), "wrap_angle": theta})
            assert float(ds["beta"].sel(t_sin_half_theta=tst, wrap_angle=theta)) == drive.beta
    # beta depends on T sin(theta/2) only
    np.testing.assert_allclose(ds["beta"].sel(wrap_angle=60.0), ds["beta"].sel(wrap_angle=90.0), rtol=1e-14)


def _fields(drive):
    return {f: getattr(drive, f) for f in drive.__dataclass_fields__ if f != "tension"}


@pytest.mark.parametrize(
    ("grid", "kwargs", "exc", "match"),
    [
        ({"sped": [4.0]}, {}, ValueError, r"'sped'.*valid keys:.*pack_diameter"),
        ({"speed": []}, {}, ValueError, r"grid\['speed'\] is empty"),
        ({"speed": [4.0, float("nan")]}, {}, ValueError, r"grid\['speed'\] must be finite"),
        ({"speed": [4.0, np.inf]}, {}, ValueError, r"grid\['speed'\] must be finite"),
        ({"speed": [4.0, 8.0, 4.0]}, {}, ValueError, r"grid\['speed'\] has duplicate values \[4\.0\]"),
        ({"speed": 4.0}, {}, ValueError, r"grid\['speed'\] must be a 1-D sequence"),
        ({"tension": [1.0], "t_sin_half_theta": [0.5]}, {}, ValueError, "both 'tension' and 't_sin_half_theta'"),
        ({"speed": [4.0]}, {"duration": 0.0}, ValueError, "duration must be > 0"),
        ({"speed": [4.0]}, {"duration": -1.0}, ValueError, "duration must be > 0"),
        ({"speed": [4.0]}, {"duration": float("nan")}, ValueError, "duration must be finite"),
        ({"speed": [4.0]}, {"record": "full"}, ValueError, "record"),
        ({"speed": [4.0]}, {"backend": "nope"}, ValueError, "backend must be one of"),
        ({"speed": [4.0]}, {"tolerance": 1e-9}, TypeError, "tolerance"),
        # option values are checked by the backend itself, in one short run before anything else
        ({"speed": [4.0]}, {"tol": 0.0}, ValueError, r"rejected by backend 'heyoka'.*tol must be in \[1e-18, 0.01\]"),
        ({"speed": [4.0]}, {"tol": "x"}, TypeError, "tol must be a real number"),
        ({"speed": [4.0]}, {"backend": "scipy", "rtol": 0.0}, ValueError, r"rtol must be in \[2.22.*e-14, 0.001\]"),
        ({"speed": [4.0]}, {"backend": "rk4", "dt": -1.0}, ValueError, "dt must be > 0"),
        ({"speed": [4.0]}, {"max_events": 0}, ValueError, "max_events"),
        ({"speed": [4.0]}, {"executor": "threads"}, ValueError, "executor must be"),
        ({"speed": [4.0]}, {"executor": object()}, TypeError, "submit"),
    ],
)
def test_bad_arguments_raise_before_running(grid, kwargs, exc, match):
    ex = RecordingExecutor()
    kwargs = {"executor": ex, "progress": False, **kwargs}
    with pytest.raises(exc, match=match):
        sweep(BASE, grid, **kwargs)
    assert ex.tasks == 0


def test_load_of_a_directory_without_manifest_raises(tmp_path):
    with pytest.raises(FileNotFoundError, match="manifest.json"):
        load_sweep(tmp_path)


def test_result_is_writable_with_the_builtin_netcdf3_engine(serial, tmp_path):
    path = os.fspath(tmp_path / "sweep.nc")
    serial.to_netcdf(path, engine="scipy")
    with xr.open_dataset(path, engine="scipy") as back:
        np.testing.assert_array_equal(back["sticks"].values, serial["sticks"].values)
        assert back["mean_flange_force"].attrs["units"] == "N"


def test_progress_bar_is_shown_only_when_asked(capsys):
    grid = {"speed": [4.0, 8.0]}
    sweep(BASE, grid, duration=1e-4, executor="serial", progress=True)
    assert "2/2" in capsys.readouterr().err
    sweep(BASE, grid, duration=1e-4, executor="serial", progress=False)
    assert capsys.readouterr().err == ""


def test_an_error_of_the_first_drive_itself_is_recorded_not_raised():
    # rk4 refuses a run of more than 2e9 steps: the stiff first point (K = 1e6) is refused
    # with or without the options, so that is its own failure, not the options': the sweep runs.
    ex = RecordingExecutor()
    with pytest.warns(RuntimeWarning, match="2 of 2 points failed"):
        ds = sweep(TapeDrive(), {"stiffness_ratio": [1e6, 1e4]}, duration=1.0, backend="rk4", executor=ex,
                   progress=False, flange="consistent", max_events=5)
    assert len(ex.points) == 2
    stiff = ds.sel(stiffness_ratio=1e6)
    assert int(stiff["status"]) == STATUS_EXCEPTION and "steps" in stiff["message"].item()
    assert int(ds["status"].sel(stiffness_ratio=1e4)) == 1  # the event limit: it did run
