"""The shared runner under sweep, bifurcation_diagram and onset_chart: executors, the small-job rule, lost points."""

from __future__ import annotations

import concurrent.futures as cf
import os
import subprocess
import sys
import textwrap
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import numpy as np
import pytest

from impactosc import Oscillator
from impactosc.dynamics import bifurcation as _bifurcation
from impactosc.dynamics import bifurcation_diagram, den_hartog_onset, onset_chart
from impactosc.dynamics import chart as _chart
from impactosc.runner import _pool, _run

ROOT = Path(__file__).resolve().parent.parent
OSC = Oscillator(0.3, 0.8, 0.05, 1e4)
BIF = dict(transient_periods=5, record_periods=3, backend="exact", progress=False)
CHART = dict(progress=False, method="transient", backend="exact", tol=1e-3, transient_periods=5, record_periods=2,
             stop_at_contact=True)


class FailingExecutor(cf.Executor):
    """Every task fails as a whole, as when no worker process would start."""

    def __init__(self):
        self.tasks = 0

    def submit(self, fn, /, *args, **kwargs):
        self.tasks += 1
        fut = cf.Future()
        fut.set_exception(BrokenProcessPool("no worker would start"))
        return fut


def test_a_diagram_that_loses_every_value_raises():
    ex = FailingExecutor()
    with pytest.raises(RuntimeError, match=r"bifurcation_diagram: all 3 points run were lost.*no worker would start"):
        bifurcation_diagram(OSC, "F", [0.2, 0.3, 0.4], executor=ex, **BIF)
    assert ex.tasks >= 3
    with pytest.raises(RuntimeError, match=r"bifurcation_diagram: all 2 points run were lost"):
        bifurcation_diagram(OSC, "F", [0.2, 0.3, 0.4], continuation="both", executor=FailingExecutor(), **BIF)


def test_a_chart_that_loses_every_point_raises():
    with pytest.raises(RuntimeError, match=r"onset_chart: all 4 points run were lost.*no worker would start"):
        onset_chart(OSC, "F", (0.2, 0.5), {"beta": [0.04, 0.05], "Omega": [0.8, 0.9]}, executor=FailingExecutor(),
                    **CHART)


def test_a_continuation_chart_follows_the_branch_at_every_point():
    # issue 19: the chart's points are contact onsets of the followed branch (method="continuation")
    osc = Oscillator(0.3, 0.8, 0.05, 1e4)
    ds = onset_chart(osc, "F", (0.2, 0.6), {"beta": [0.04, 0.05], "Omega": [0.7, 0.8]}, executor="serial",
                     progress=False)
    assert ds.attrs["method"] == "continuation"
    assert np.all(ds["status"].values == 0) and np.all(ds["stable"].values == 1.0)
    for beta in (0.04, 0.05):
        for W in (0.7, 0.8):
            Fc = den_hartog_onset(W, beta)  # the non-stop Den Hartog orbit grazes there
            assert abs(float(ds["critical"].sel(beta=beta, Omega=W)) - Fc) < 1e-9


def test_a_chart_on_a_thread_pool_equals_the_serial_one():
    grid = {"beta": [0.04, 0.05], "Omega": [0.8, 0.9]}
    serial = onset_chart(OSC, "F", (0.2, 0.5), grid, executor="serial", **CHART)
    with cf.ThreadPoolExecutor(2) as pool:
        threaded = onset_chart(OSC, "F", (0.2, 0.5), grid, executor=pool, **CHART)
    # transients of 5 periods have not settled: the search's sign changes are no grazings (status 2,
    # 5 % below Den Hartog's onset); the point here is that both executors say the same
    assert np.all(np.isin(serial["status"].values, (0, 2)))
    np.testing.assert_array_equal(threaded["status"].values, serial["status"].values)
    np.testing.assert_array_equal(threaded["critical"].values, serial["critical"].values)


@pytest.mark.parametrize(
    "call, error, match",
    [
        (lambda: onset_chart(OSC, "F", (0.2, 0.5), {"beta": [0.05], "Omega": [0.8]}, executor="threads"),
         ValueError, r"executor must be None \(the default local process pool\), 'serial', 'dask'.*'threads'"),
        (lambda: onset_chart(OSC, "F", (0.2, 0.5), {"beta": [0.05], "Omega": [0.8]}, executor=object()),
         TypeError, r"executor must have a submit\(\) method"),
        (lambda: bifurcation_diagram(OSC, "F", [0.2], executor="threads"), ValueError, "executor must be"),
        # an unknown option, an invalid grid value: raised before the run, not a status -2 at every point
        (lambda: onset_chart(OSC, "F", (0.2, 0.5), {"beta": [0.05], "Omega": [0.8]}, executor="serial",
                             no_such_option=1), TypeError, "no_such_option"),
        (lambda: onset_chart(OSC, "F", (0.2, 0.5), {"beta": [0.05, -1.0], "Omega": [0.8]}, executor="serial"),
         ValueError, "beta must be >= 0"),
        (lambda: onset_chart(OSC, "F", (0.2, 0.5), {"beta": [0.05], "Omega": [0.8, -0.5]}, executor="serial"),
         ValueError, "Omega"),
    ],
)
def test_bad_runner_arguments_raise_before_anything_runs(call, error, match, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("a point ran")

    monkeypatch.setattr(_chart, "run_points", never)
    monkeypatch.setattr(_bifurcation, "run_points", never)
    with pytest.raises(error, match=match):
        call()


def test_a_store_that_is_a_file_is_refused_by_name(tmp_path):
    not_a_store = tmp_path / "results.txt"
    not_a_store.write_text("my notes")
    with pytest.raises(ValueError, match=r"store .*results\.txt.* exists and is not a directory"):
        bifurcation_diagram(OSC, "F", [0.2], executor="serial", store=not_a_store, **BIF)
    assert not_a_store.read_text() == "my notes"


def test_a_small_job_runs_here_without_starting_the_pool(monkeypatch):
    # issue 22: 8 values took 2.8 s on a fresh pool against 0.7 s serially
    def no_pool():
        raise AssertionError("the pool was started for a small job")

    monkeypatch.setattr(_pool, "default_pool", no_pool)
    monkeypatch.setattr(_pool, "_POOL", None)
    auto = bifurcation_diagram(OSC, "F", [0.2, 0.3, 0.4, 0.5], **BIF)
    serial = bifurcation_diagram(OSC, "F", [0.2, 0.3, 0.4, 0.5], executor="serial", **BIF)
    np.testing.assert_array_equal(auto["x"].values, serial["x"].values)
    onset_chart(OSC, "F", (0.2, 0.5), {"beta": [0.04, 0.05], "Omega": [0.8, 0.9]}, **CHART)
    bifurcation_diagram(OSC, "F", [0.2, 0.3], continuation="forward", **BIF)  # one pass: one task


def test_the_small_job_rule_sends_a_long_rest_to_the_pool(monkeypatch):
    monkeypatch.setattr(_pool, "_POOL", None)
    monkeypatch.setattr(_pool, "pool_workers", lambda: 2)
    ran_here = []

    class Stop(Exception):
        pass

    def runner_called(executor):
        raise Stop(len(ran_here))

    monkeypatch.setattr(_run, "Runner", runner_called)

    def slow(payload):  # as if each point took 3 s: 3 left x 3 s x (1 - 1/2) > POOL_START_SECONDS
        ran_here.append(payload)
        return payload

    monkeypatch.setattr(_run.time, "perf_counter", iter(range(0, 100, 3)).__next__)
    with pytest.raises(Stop):
        _run.run_points(slow, [(i, i) for i in range(4)], on_result=lambda k, r: None, on_lost=None,
                        progress=False, try_here_first=True)
    assert ran_here == [0]


# -- the acceptance of issue 22: a loopback dask cluster and the local pool, from a script ----
# without a main guard fed on standard input: the same values as a serial run, for all three.
SCRIPT = textwrap.dedent("""\
    import numpy as np
    import xarray as xr
    import impactosc as io
    from impactosc import dynamics as dy
    from impactosc.runner import _pool, _run
    print("top level ran", flush=True)
    osc = io.Oscillator(0.3, 0.8, 0.05, 1e4)
    bif = dict(transient_periods=5, record_periods=3, backend="exact", progress=False)
    chart = dict(progress=False, backend="exact")  # the continuation method: status 0 only at a genuine grazing
    drive = io.TapeDrive(clearance=50e-6)

    def run_all(executor):
        return (dy.bifurcation_diagram(osc, "F", [0.2, 0.3, 0.4, 0.5], executor=executor, **bif),
                dy.bifurcation_diagram(osc, "F", [0.3, 0.35, 0.4], continuation="both", executor=executor, **bif),
                dy.onset_chart(osc, "F", (0.2, 0.6), {"beta": [0.04, 0.05], "Omega": [0.7, 0.8]},
                               executor=executor, **chart),
                io.sweep(drive, {"speed": [4.0, 8.0, 12.0]}, duration=1e-4, backend="exact",
                         executor=executor, progress=False))

    serial = run_all("serial")
    _run.POOL_START_SECONDS = 0.0  # the rule would keep jobs this small here: send them to the pool
    pooled = run_all(None)
    print("pool used", _pool._POOL is not None, flush=True)
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster, \\
            Client(cluster) as client:
        on_dask = run_all(client)
    for name, a, b, c in zip(["independent", "passes", "chart", "sweep"], serial, pooled, on_dask):
        assert (a["status"].values == 0).all(), (name, a["status"].values)
        for var in a.data_vars:
            np.testing.assert_array_equal(b[var].values, a[var].values, err_msg=f"pool {name} {var}")
            np.testing.assert_array_equal(c[var].values, a[var].values, err_msg=f"dask {name} {var}")
        print("identical", name, flush=True)
""")


@pytest.fixture(scope="module")
def guardless_run():
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "LOKY_MAX_CPU_COUNT": "2"}
    proc = subprocess.run([sys.executable, "-"], input=SCRIPT, capture_output=True, text=True, env=env,
                          timeout=600, cwd=ROOT)
    return proc


@pytest.mark.slow  # a subprocess with a process pool and a dask cluster
def test_all_three_on_the_pool_and_dask_from_a_guardless_script_on_stdin(guardless_run):
    pytest.importorskip("distributed")
    proc = guardless_run
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.count("top level ran") == 1  # the workers never ran the caller's code
    assert "pool used True" in proc.stdout
    for name in ("independent", "passes", "chart", "sweep"):
        assert f"identical {name}" in proc.stdout, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    print(proc.stdout)


def test_no_progress_bar_imports_no_tqdm():
    # progress=False must not import tqdm at all: importing tqdm.auto in a kernel without ipywidgets
    # prints a TqdmWarning (seen in the rendered notebooks)
    code = textwrap.dedent("""
        import sys
        from concurrent.futures import ThreadPoolExecutor
        from impactosc.runner import run_points
        out = {}
        run_points(lambda p: p * 2, [(i, i) for i in range(3)], executor=ThreadPoolExecutor(1),
                   on_result=out.__setitem__, on_lost=lambda k, m: None, progress=False)
        assert out == {0: 0, 1: 2, 2: 4}, out
        assert not any(m == "tqdm" or m.startswith("tqdm.") for m in sys.modules), "tqdm imported"
    """)
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
