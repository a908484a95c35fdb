"""Parameter sweeps of the tape drive: the outer product of a grid, run in parallel, as an xarray Dataset.

:func:`sweep` runs :func:`impactosc.simulate` at every point of a grid of
:class:`~impactosc.tape.TapeDrive` fields (the paper's Fig. 7 is pack diameter x speed x
tension, its Fig. 8 is ``T sin(theta/2)``) and returns the results in SI units, one
dimension per swept field.

Points are run on a local process pool by default, or on any
:class:`concurrent.futures.Executor`, or on a ``dask.distributed`` client. The points are
submitted in chunks, because each worker process compiles the heyoka integrator once and
then reuses it; chunks are filled round-robin so that slow and fast corners of the grid are
spread over all chunks.

A failed point never stops the sweep: an exception, a run that did not reach the end
(``status != 0``), or even a worker process that crashed costs that point only. It gets NaN
results, its status and message, and a warning names it.

With ``store=`` every finished point is saved as a small netCDF file, so that an
interrupted or extended sweep only runs what is missing; :func:`load_sweep` reads a store
back.

Status codes of the ``status`` variable:

==  ===========================================================================
 0  the run reached the end (the only status with results)
 1  the event limit ``max_events`` was reached (:attr:`Solution.status`)
-1  the integration failed (:attr:`Solution.status`)
-2  an exception was raised (invalid drive, bad option, ...): see ``message``
-3  the task was lost: its worker process crashed or was killed
-4  not computed (only in :func:`load_sweep` of an incomplete store)
==  ===========================================================================
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import hashlib
import inspect
import itertools
import json
import math
import multiprocessing
import os
import tempfile
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import xarray as xr

from . import _validation as _v
from .backends import get_backend
from .simulate import simulate
from .tape import BENDING_OPTIONS, TapeDrive

__all__ = ["sweep", "load_sweep", "load", "SWEEP_KEYS", "STATUS_EXCEPTION", "STATUS_LOST", "STATUS_NOT_COMPUTED"]

STATUS_EXCEPTION = -2
STATUS_LOST = -3
STATUS_NOT_COMPUTED = -4

#: Chunks submitted per worker. heyoka compiles its integrator once per worker process, so
#: fewer, larger tasks amortise that; a few chunks per worker still balance the load and
#: bound what an interruption loses (a chunk's points are saved when the chunk returns).
CHUNKS_PER_WORKER = 4

_STORE_FORMAT = 1
_MANIFEST = "manifest.json"
_POINTS_DIR = "points"

_FIELDS = tuple(f.name for f in dataclasses.fields(TapeDrive))
#: The keys a grid may use: every TapeDrive field, and ``t_sin_half_theta`` (Fig. 8).
SWEEP_KEYS = _FIELDS + ("t_sin_half_theta",)

# (units, long name) of the grid coordinates.
_FIELD_ATTRS = {
    "speed": ("m/s", "tape speed V"),
    "tension": ("N", "tape tension T"),
    "pack_diameter": ("m", "supply pack diameter D"),
    "wrap_angle": ("deg", "wrap angle theta"),
    "width": ("m", "tape width w"),
    "thickness": ("m", "tape thickness h"),
    "free_length": ("m", "free span length l"),
    "youngs_modulus": ("Pa", "Young's modulus E of the tape"),
    "density": ("kg/m^3", "tape density rho"),
    "clearance": ("m", "tape edge to flange clearance L"),
    "stiffness_ratio": ("1", "flange to tape stiffness ratio k0/k"),
    "friction": ("1", "Coulomb friction coefficient mu"),
    "bending": ("", "second moment of area reading of eq. 4"),
    "hub_diameter": ("m", "hub diameter"),
    "full_pack_diameter": ("m", "full pack diameter"),
    "runout_hub": ("m", "reel run-out at the hub"),
    "runout_full": ("m", "reel run-out at full pack"),
    "damping_ratio": ("1", "viscous damping ratio zeta"),
    "static_friction": ("1", "static (breakaway) friction coefficient mu_s"),
    "flange": ("", "flange law (spring or rigid)"),
    "flange_exponent": ("1", "exponent p of the flange spring law k0 d^p"),
    "flange_stiffness": ("N/m^p", "flange stiffness k0 of the spring law"),
    "restitution": ("1", "coefficient of restitution of a rigid flange"),
    "runout_harmonics": ("", "run-out harmonics (n, fraction, phase)"),
    "t_sin_half_theta": ("N", "T sin(theta/2), half the roller normal force (eq. 5)"),
}

# The result variables: name -> (units, long name). Counts are float64 so that a failed
# point can hold NaN; ``status`` (int32) and ``message`` (str) are added separately.
_RESULTS = {
    "mean_flange_force": ("N", "mean flange force, both flanges"),
    "mean_flange_force_upper": ("N", "mean flange force, upper flange"),
    "mean_flange_force_lower": ("N", "mean flange force, lower flange"),
    "rms_flange_force": ("N", "rms flange force, both flanges"),
    "rms_flange_force_upper": ("N", "rms flange force, upper flange"),
    "rms_flange_force_lower": ("N", "rms flange force, lower flange"),
    "impacts": ("1", "number of flange contacts, both flanges"),
    "impacts_upper": ("1", "number of flange contacts, upper flange"),
    "impacts_lower": ("1", "number of flange contacts, lower flange"),
    "impact_rate": ("1/s", "flange contacts per second, both flanges"),
    "sticks": ("1", "number of stick events"),
    "releases": ("1", "number of release events"),
    "reversals": ("1", "number of friction reversals (slip direction changes)"),
    "max_penetration": ("um", "deepest penetration into a flange"),
    "peak_flange_force": ("N", "peak flange force"),
    "contact_fraction": ("1", "fraction of the time in flange contact"),
}
# Inputs of the point, defined whenever the drive is: kept even when the run failed.
_PARAMETERS = {
    "F": ("1", "nondimensional forcing amplitude F = F_a/(kL) (eq. 3)"),
    "Omega": ("1", "nondimensional forcing frequency omega_r/omega_n (eq. 3)"),
    "beta": ("1", "nondimensional friction level mu N/(kL) (eq. 3)"),
    "K": ("1", "flange to tape stiffness ratio (eq. 3)"),
    "simulated_time": ("s", "time actually simulated"),
}
_FLOAT_VARS = {**_RESULTS, **_PARAMETERS}
_STATUS_DOC = ("0 ok; 1 event limit reached; -1 integration failed; -2 exception (see message); "
               "-3 task lost (worker crashed); -4 not computed")


# ---------------------------------------------------------------------------------------
# The worker: module level and plain arguments, so that it pickles under spawn and dask.
# ---------------------------------------------------------------------------------------
def _run_chunk(points: list, duration: float, backend: str, x0: float, v0: float, options: dict) -> list:
    """Run the points ``[(key, drive_fields), ...]``; return ``[(key, result_dict), ...]``.

    Every exception of a point is caught here, so a bad point costs only itself; what
    escapes this function (a crash of the process) is handled by the caller.
    """
    return [(key, _run_point(fields, duration, backend, x0, v0, options)) for key, fields in points]


def _run_point(fields: dict, duration: float, backend: str, x0: float, v0: float, options: dict) -> dict:
    out = dict.fromkeys(_FLOAT_VARS, math.nan)
    try:
        drive = TapeDrive(**fields)
        out.update(F=drive.F, Omega=drive.Omega, beta=drive.beta, K=drive.K)
        sol = simulate(drive.oscillator(), drive.seconds_to_lambda(duration), x0, v0,
                       backend=backend, record="stats", **options)
    except Exception as exc:  # noqa: BLE001 - any failure of one point is recorded, not raised
        out.update(status=STATUS_EXCEPTION, message=f"{type(exc).__name__}: {exc}")
        return out
    out.update(status=int(sol.status), message=str(sol.message))
    dur = sol.t_final - sol.t0
    out["simulated_time"] = drive.lambda_to_seconds(dur)
    if sol.status != 0:
        # A partial run's averages are over a different window than the other points': not comparable.
        return out
    fs = drive.force_scale
    impacts = {s: sol.contact_entries(s) for s in (None, 1, -1)}
    out.update(
        mean_flange_force=sol.mean_flange_force() * fs,
        mean_flange_force_upper=sol.mean_flange_force(1) * fs,
        mean_flange_force_lower=sol.mean_flange_force(-1) * fs,
        rms_flange_force=sol.rms_flange_force() * fs,
        rms_flange_force_upper=sol.rms_flange_force(1) * fs,
        rms_flange_force_lower=sol.rms_flange_force(-1) * fs,
        impacts=float(impacts[None]),
        impacts_upper=float(impacts[1]),
        impacts_lower=float(impacts[-1]),
        impact_rate=impacts[None] / out["simulated_time"],
        sticks=float(sol.counts["stick"]),
        releases=float(sol.counts["release"]),
        reversals=float(sol.counts["reversal"]),
        max_penetration=sol.max_penetration() * drive.clearance * 1e6,
        peak_flange_force=sol.max_flange_force() * fs,
        contact_fraction=sol.contact_time() / dur if dur > 0 else math.nan,
    )
    return out


def _failure(status: int, message: str) -> dict:
    out = dict.fromkeys(_FLOAT_VARS, math.nan)
    out.update(status=status, message=message)
    return out


# ---------------------------------------------------------------------------------------
# Arguments
# ---------------------------------------------------------------------------------------
def _check_grid(grid) -> dict[str, np.ndarray]:
    if not isinstance(grid, Mapping):
        raise TypeError(f"grid must be a dict of TapeDrive field -> 1-D sequence of values, got {type(grid).__name__}")
    out = {}
    for key, values in grid.items():
        if key not in SWEEP_KEYS:
            raise ValueError(f"grid key {key!r} is not a TapeDrive field; valid keys: {', '.join(SWEEP_KEYS)}")
        name = f"grid[{key!r}]"
        if isinstance(values, str | bytes) or np.ndim(values) != 1:
            raise ValueError(f"{name} must be a 1-D sequence of values, got {values!r}")
        values = list(values)
        if not values:
            raise ValueError(f"{name} is empty: give at least one value")
        if key == "bending":
            for b in values:
                if not isinstance(b, str):
                    raise TypeError(f"{name} values must be strings, got {b!r}")
                _v.choice(name, b, BENDING_OPTIONS)
            arr = np.array(values, dtype=str)
        else:
            # Coordinates are float64, as TapeDrive stores them (and netCDF3 has no int64).
            arr = np.array([_v.real(name, x) for x in values], dtype=float)
        if len(set(arr.tolist())) != arr.size:
            dup = sorted({x for x in arr.tolist() if arr.tolist().count(x) > 1})
            raise ValueError(f"{name} has duplicate values {dup}: each value must appear once")
        out[key] = arr
    if "t_sin_half_theta" in out and "tension" in out:
        raise ValueError("grid cannot sweep both 'tension' and 't_sin_half_theta': the latter sets the tension")
    return out


def _check_options(backend: str, x0, v0, options: dict) -> tuple[float, float, dict]:
    x0 = _v.real("x0", x0)
    v0 = _v.real("v0", v0)
    if "record" in options:
        raise ValueError("sweep() always runs simulate(..., record='stats'); do not pass record")
    run = get_backend(backend)  # an unknown or uninstalled backend fails here, not at every point
    backend_options = {k: v for k, v in options.items() if k != "max_events"}
    if "max_events" in options:
        _v.integer("max_events", options["max_events"])
    try:
        inspect.signature(run).bind(None, 1.0, x0, v0, record="stats", max_events=1, **backend_options)
    except TypeError as exc:
        raise TypeError(f"backend {backend!r} does not accept these options {sorted(backend_options)}: {exc}") from None
    return x0, v0, dict(options)


def _drive_fields(drive: TapeDrive) -> dict:
    return {f: getattr(drive, f) for f in _FIELDS}


def _resolve(base: TapeDrive, point: dict) -> TapeDrive:
    """The drive of one grid point (may raise TypeError/ValueError for an invalid point)."""
    if "t_sin_half_theta" in point:
        fields = _drive_fields(base)
        del fields["tension"]
        fields.update({k: v for k, v in point.items() if k != "t_sin_half_theta"})
        return TapeDrive.from_t_sin_half_theta(point["t_sin_half_theta"], **fields)
    return base.replace(**point)


def _point_key(fields: dict, settings_: dict) -> str:
    # A point is identified by its resolved drive, not by its grid index: a grid that is
    # extended, reordered or re-parametrised (tension <-> t_sin_half_theta) still finds it.
    text = json.dumps({"drive": fields, "settings": settings_}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _settings(base: TapeDrive, duration: float, backend: str, x0: float, v0: float, options: dict) -> dict:
    """Everything besides the grid that determines the results (JSON-normal form)."""
    return json.loads(json.dumps({"base": _drive_fields(base), "duration": duration, "backend": backend,
                                  "x0": x0, "v0": v0, "options": options}, sort_keys=True, default=repr))


def _point_label(point: dict) -> str:
    return "(" + ", ".join(f"{k}={v!r}" for k, v in point.items()) + ")"


# ---------------------------------------------------------------------------------------
# Executors: one small interface over serial, process pools, any Executor and dask
# ---------------------------------------------------------------------------------------
def _check_executor(executor) -> None:
    # Before the store is touched; the executor itself is only started if something is left to run.
    if executor is None or (isinstance(executor, str) and executor in ("serial", "dask")):
        return
    if isinstance(executor, str):
        raise ValueError(f"executor must be None, 'serial', 'dask', a concurrent.futures.Executor or a "
                         f"dask.distributed.Client, got {executor!r}")
    if not callable(getattr(executor, "submit", None)):
        raise TypeError(f"executor must have a submit() method (concurrent.futures.Executor or "
                        f"dask.distributed.Client), got {type(executor).__name__}")


class _LazyFuture:
    """A future of the serial runner: runs on ``result()`` so that points are saved one by one."""

    def __init__(self, fn, args):
        self._fn, self._args, self._done, self._value = fn, args, False, None

    def result(self):
        if not self._done:
            self._value, self._done = self._fn(*self._args), True
        return self._value


class _Runner:
    """Submits chunks to one kind of executor: "serial", "pool" (owned), "dask" or any "executor".

    ``owned`` executors (the default pool, a dask cluster started for ``executor="dask"``)
    are shut down at the end; a user's executor is left running.
    """

    def __init__(self, executor, n_points: int):
        self.owned = False
        self.kind = "executor"
        self._executor = executor
        self.n_workers = 1
        if executor is None:
            self.kind, self.owned = "pool", True
            self.n_workers = max(1, min(os.cpu_count() or 1, n_points))
            self._executor = self._new_pool()
        elif isinstance(executor, str) and executor == "serial":
            self.kind = "serial"
        elif isinstance(executor, str) and executor == "dask":
            self.kind = "dask"
            self._executor, self.owned = _dask_client()
        elif _is_dask_client(executor):
            self.kind = "dask"
        if self.kind == "dask":
            self.n_workers = max(1, sum(self._executor.nthreads().values()))
        elif self.kind == "executor":
            self.n_workers = getattr(executor, "_max_workers", None) or os.cpu_count() or 1

    def _new_pool(self):
        # spawn: a forked child would inherit the parent's heyoka/LLVM threads and locks.
        return cf.ProcessPoolExecutor(max_workers=self.n_workers, mp_context=multiprocessing.get_context("spawn"))

    def submit(self, *args):
        if self.kind == "serial":
            return _LazyFuture(_run_chunk, args)
        if self.kind == "dask":
            return self._executor.submit(_run_chunk, *args, pure=False)
        return self._executor.submit(_run_chunk, *args)

    def as_completed(self, futures):
        if self.kind == "serial":
            return iter(futures)
        if self.kind == "dask":
            import distributed

            return distributed.as_completed(list(futures))
        return cf.as_completed(futures)

    def recover(self) -> None:
        """After lost tasks: replace a broken pool that we own (a user's executor is theirs to fix)."""
        if self.kind == "pool" and getattr(self._executor, "_broken", False):
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = self._new_pool()

    def cancel(self, futures) -> None:
        for fut in futures:
            cancel = getattr(fut, "cancel", None)
            if cancel is not None:
                cancel()

    def close(self, wait: bool = True) -> None:
        if not self.owned:
            return
        if self.kind == "pool":
            # wait=False after an interrupt: do not sit out the chunks still running.
            self._executor.shutdown(wait=wait, cancel_futures=True)
        elif self.kind == "dask":
            cluster = self._executor.cluster
            self._executor.close()
            if cluster is not None:
                cluster.close()


def _is_dask_client(obj) -> bool:
    try:
        import distributed
    except ImportError:
        return False
    return isinstance(obj, distributed.Client)


def _dask_client():
    try:
        import distributed
    except ImportError:
        raise ImportError("executor='dask' needs dask.distributed: pip install impactosc[dask]") from None
    try:
        return distributed.get_client(), False  # a client the user already started: theirs to close
    except ValueError:
        n = os.cpu_count() or 1
        return distributed.Client(n_workers=n, threads_per_worker=1, processes=True), True


def _execute(runner: _Runner, todo: list, args: tuple, on_result, bar) -> None:
    """Run ``todo = [(key, fields), ...]`` and call ``on_result(key, result)`` for each point.

    A task that raises as a whole (its worker process died, dask gave up on it, the pool
    broke) does not say which of its points was guilty: its points are retried one per task,
    then, if lost again, one at a time, so that only a point that crashes its worker alone
    is recorded as lost.
    """
    n_chunks = min(len(todo), CHUNKS_PER_WORKER * runner.n_workers)
    # Round-robin: neighbouring grid points cost about the same, so each chunk gets a mix.
    rounds = [[todo[i::n_chunks] for i in range(n_chunks)] if todo else []]
    for attempt in range(3):
        tasks, lost = rounds[-1], []
        if attempt < 2:
            futures = {}
            for task in tasks:
                try:
                    futures[runner.submit(task, *args)] = task
                except Exception as exc:  # noqa: BLE001 - e.g. a broken user pool: record, go on
                    lost.append((task, exc))
            try:
                for fut in runner.as_completed(futures):
                    _collect(fut, futures[fut], on_result, bar, lost)
            except BaseException:
                runner.cancel(futures)
                raise
        else:
            # Last round: one point at a time, so a crash is the crashing point's alone.
            for task in tasks:
                try:
                    fut = runner.submit(task, *args)
                except Exception as exc:  # noqa: BLE001
                    lost.append((task, exc))
                    continue
                _collect(fut, task, on_result, bar, lost)
                runner.recover()
        if not lost:
            return
        runner.recover()
        if attempt == 2:
            break
        rounds.append([[p] for task, _ in lost for p in task])
    for task, exc in lost:
        for key, _ in task:
            on_result(key, _failure(STATUS_LOST, f"task lost ({type(exc).__name__}: {exc})"))
            bar.update(1)


def _collect(fut, task, on_result, bar, lost) -> None:
    try:
        results = fut.result()
    except Exception as exc:  # noqa: BLE001 - the whole task failed: retried by the caller
        lost.append((task, exc))
        return
    for key, result in results:
        on_result(key, result)
    bar.update(len(results))


# ---------------------------------------------------------------------------------------
# Store: a directory with a manifest and one netCDF file per finished point
# ---------------------------------------------------------------------------------------
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


def _open_store(store, settings_: dict, grid: dict) -> Path:
    root = Path(store)
    manifest_path = root / _MANIFEST
    if manifest_path.exists():
        old = json.loads(manifest_path.read_text())
        if old.get("format") != _STORE_FORMAT:
            raise ValueError(f"store {str(root)!r} has format {old.get('format')!r}, expected {_STORE_FORMAT}")
        diffs = _diff(old["settings"], settings_)
        if diffs:
            raise ValueError(f"store {str(root)!r} was made with different settings; its points would not be "
                             f"comparable with this sweep's ({'; '.join(diffs)}). Use a new store, or delete this "
                             f"one to start over. Only the grid may change between runs into one store.")
    (root / _POINTS_DIR).mkdir(parents=True, exist_ok=True)
    manifest = {"format": _STORE_FORMAT, "settings": settings_,
                "grid": {k: v.tolist() for k, v in grid.items()}, "impactosc_version": _version()}
    _atomic_write(manifest_path, lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=1)))
    return root


def _diff(old: dict, new: dict, prefix: str = "") -> list[str]:
    out = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k, "<absent>"), new.get(k, "<absent>")
        if isinstance(a, dict) and isinstance(b, dict):
            out += _diff(a, b, f"{prefix}{k}.")
        elif a != b:
            out.append(f"{prefix}{k}: stored {a!r}, now {b!r}")
    return out


def _point_path(root: Path, key: str) -> Path:
    return root / _POINTS_DIR / f"{key}.nc"


def _save_point(root: Path, key: str, fields: dict, result: dict) -> None:
    data = {name: ((), np.float64(result[name])) for name in _FLOAT_VARS}
    data["status"] = ((), np.int32(result["status"]))
    ds = xr.Dataset(data, attrs={"key": key, "message": result["message"], "drive": json.dumps(fields)})
    _atomic_write(_point_path(root, key), lambda tmp: ds.to_netcdf(tmp, engine="scipy"))


def _load_point(path: Path) -> dict:
    with xr.open_dataset(path, engine="scipy") as ds:
        out = {name: float(ds[name].values) for name in _FLOAT_VARS}
        out["status"] = int(ds["status"].values)
        out["message"] = str(ds.attrs["message"])
    return out


def _version() -> str:
    # Read lazily: impactosc/__init__.py imports this module before it sets __version__.
    from . import __version__

    return __version__


# ---------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------
def sweep(base: TapeDrive, grid: Mapping, *, duration: float = 1.0, backend: str = "heyoka", executor=None,
          progress: bool = True, store=None, x0: float = 0.95, v0: float = 0.0, **simulate_options) -> xr.Dataset:
    """Simulate every point of a grid of tape-drive parameters; results in SI units as a Dataset.

    Each point of the outer product of ``grid`` is the drive ``base.replace(**point)``, run
    for ``duration`` seconds with ``simulate(drive.oscillator(), drive.seconds_to_lambda(duration),
    x0, v0, backend=backend, record="stats", **simulate_options)``.

    Parameters
    ----------
    base : TapeDrive
        The drive whose fields are kept where the grid does not set them.
    grid : dict
        ``{field: values}`` with a 1-D sequence of distinct, finite values per key. Keys are
        :class:`TapeDrive` field names (``"pack_diameter"``, ``"speed"``, ``"tension"``,
        ``"wrap_angle"``, ...; ``"bending"`` takes strings) or ``"t_sin_half_theta"`` (N),
        which sets the tension through :meth:`TapeDrive.from_t_sin_half_theta`, keeping the
        wrap angle (the paper's Fig. 8 axis). The order of the keys is the order of the
        dimensions. An empty dict runs ``base`` alone.
    duration : float
        Simulated time per point in seconds (> 0). The paper averages over 1 s.
    backend : str
        Backend of :func:`impactosc.simulate` (default ``"heyoka"``).
    executor : None, "serial", "dask", concurrent.futures.Executor or dask.distributed.Client
        Where the points run. ``None`` (default): a local pool of ``os.cpu_count()``
        processes (spawned; in a script, call ``sweep`` under ``if __name__ == "__main__":``).
        ``"serial"``: in this process, for debugging. ``"dask"``: the current
        ``dask.distributed`` client, or a new local cluster (needs ``impactosc[dask]``).
        Anything with ``submit(fn, *args)`` returning futures: used as is, and not shut down.
    progress : bool
        Show a tqdm progress bar over the points.
    store : str or path-like, optional
        Directory in which every finished point is saved (one netCDF file each, next to a
        ``manifest.json`` of the settings). A rerun with the same settings loads the saved
        points and runs only the missing ones, so an interrupted sweep resumes and an
        extended grid runs only its new points. Read it back with :func:`load_sweep`.
        Points lost with a crashed worker are not saved (they are retried by a rerun).
    x0, v0 : float
        Initial state ``X = x/L``, ``V`` (nondimensional, as in :func:`impactosc.simulate`).
    **simulate_options
        Passed to :func:`impactosc.simulate`: ``max_events`` and backend options such as
        ``tol``. They must be picklable (and JSON-representable for ``store``).

    Returns
    -------
    xarray.Dataset
        One dimension per grid key, coordinates as given (float64, or str for
        ``bending``). Data variables, each with ``units`` and ``long_name`` attributes:
        ``mean_flange_force``, ``rms_flange_force`` (N, both flanges; ``_upper``/``_lower``
        per flange), ``impacts`` (contacts; ``_upper``/``_lower``), ``impact_rate`` (1/s),
        ``sticks``, ``releases``, ``reversals``, ``max_penetration`` (um),
        ``peak_flange_force`` (N), ``contact_fraction``, the nondimensional ``F``,
        ``Omega``, ``beta``, ``K`` of each point, ``simulated_time`` (s), ``status`` (int32,
        see the module docstring) and ``message`` (str). Counts are float64 so that a
        failed point can be NaN. ``attrs`` hold the base drive's fields (``base_<field>``),
        ``duration`` (s), ``backend``, ``x0``, ``v0``, ``simulate_options`` (JSON) and
        ``impactosc_version``.

    Raises
    ------
    TypeError, ValueError
        For a bad argument, before anything runs: an unknown grid key (the message lists
        the valid ones), an empty, non-1-D or duplicated list of values, a non-finite value,
        ``duration <= 0``, an unknown backend or option, or a ``store`` made with other
        settings (the message lists the differences).
    ImportError
        ``executor="dask"`` without dask installed.

    Warns
    -----
    RuntimeWarning
        When points failed (``status != 0``): they hold NaN results and their status and
        message; the warning names them. The sweep itself always completes.

    Examples
    --------
    >>> from impactosc import TapeDrive
    >>> from impactosc.sweep import sweep
    >>> ds = sweep(TapeDrive(), {"pack_diameter": [0.05, 0.07, 0.09], "speed": [4.0, 8.0]},
    ...            duration=0.01, progress=False)                        # doctest: +SKIP
    >>> ds.mean_flange_force.sel(speed=4.0)                              # doctest: +SKIP
    """
    plan = _plan(base, grid, duration, backend, x0, v0, simulate_options)
    _check_executor(executor)
    root = _open_store(store, plan["settings"], plan["grid"]) if store is not None else None

    results: dict[str, dict] = dict(plan["invalid"])
    todo = []
    for key, fields in plan["unique"].items():
        if root is not None and _point_path(root, key).exists():
            results[key] = _load_point(_point_path(root, key))
        else:
            todo.append((key, fields))

    def on_result(key: str, result: dict) -> None:
        results[key] = result
        if root is not None and result["status"] != STATUS_LOST:
            _save_point(root, key, plan["unique"][key], result)

    if todo:
        from tqdm.auto import tqdm

        runner = _Runner(executor, len(todo))
        n_total = len(plan["unique"])
        args = (plan["duration"], backend, plan["x0"], plan["v0"], plan["options"])
        try:
            with tqdm(total=n_total, initial=n_total - len(todo), disable=not progress, desc="sweep",
                      unit="point") as bar:
                _execute(runner, todo, args, on_result, bar)
        except BaseException:
            runner.close(wait=False)
            raise
        runner.close()

    ds = _assemble(plan, results)
    _warn_failures(plan, ds)
    return ds


def load_sweep(store) -> xr.Dataset:
    """Read a sweep store written by :func:`sweep` back as the Dataset of its latest grid.

    Nothing is simulated: points not yet computed (an interrupted sweep) have
    ``status = -4`` and NaN results, and a warning says how many.

    Parameters
    ----------
    store : str or path-like
        The directory passed as ``sweep(..., store=...)``.

    Returns
    -------
    xarray.Dataset
        As returned by :func:`sweep`.
    """
    root = Path(store)
    manifest_path = root / _MANIFEST
    if not manifest_path.exists():
        raise FileNotFoundError(f"{str(root)!r} is not a sweep store: it has no {_MANIFEST}")
    manifest = json.loads(manifest_path.read_text())
    s = manifest["settings"]
    plan = _plan(TapeDrive(**s["base"]), manifest["grid"], s["duration"], s["backend"], s["x0"], s["v0"],
                 s["options"])
    results = dict(plan["invalid"])
    for key in plan["unique"]:
        path = _point_path(root, key)
        results[key] = (_load_point(path) if path.exists()
                        else _failure(STATUS_NOT_COMPUTED, "not computed yet: rerun sweep() with this store"))
    ds = _assemble(plan, results)
    missing = int((ds["status"] == STATUS_NOT_COMPUTED).sum())
    if missing:
        warnings.warn(f"store {str(root)!r} is incomplete: {missing} of {ds['status'].size} points not computed",
                      RuntimeWarning, stacklevel=2)
    return ds


#: ``impactosc.sweep.load``: also reachable once the package root exports the function
#: ``sweep`` (which then shadows this module's name), see the end of this module.
load = load_sweep


def _plan(base, grid, duration, backend, x0, v0, options) -> dict:
    """Validate the arguments and resolve every grid point to a drive and a key."""
    if not isinstance(base, TapeDrive):
        raise TypeError(f"base must be a TapeDrive, got {type(base).__name__}")
    duration = _v.positive("duration", duration)
    grid = _check_grid(grid)
    x0, v0, options = _check_options(backend, x0, v0, options)
    settings_ = _settings(base, duration, backend, x0, v0, options)
    points, unique, invalid = [], {}, {}
    names = list(grid)
    for combo in itertools.product(*(v.tolist() for v in grid.values())):
        point = dict(zip(names, combo, strict=True))
        try:
            fields = _drive_fields(_resolve(base, point))
        except (TypeError, ValueError) as exc:
            # An invalid drive is known here already: recorded without a task (and without a store file).
            key = "invalid:" + _point_label(point)
            invalid[key] = _failure(STATUS_EXCEPTION, f"{type(exc).__name__}: {exc}")
        else:
            key = _point_key(fields, settings_)
            unique[key] = fields
        points.append((point, key))
    return {"grid": grid, "points": points, "unique": unique, "invalid": invalid, "settings": settings_,
            "base": base, "duration": duration, "backend": backend, "x0": x0, "v0": v0, "options": options}


def _assemble(plan: dict, results: dict) -> xr.Dataset:
    grid = plan["grid"]
    dims = list(grid)
    shape = tuple(v.size for v in grid.values())
    floats = {name: np.full(shape, np.nan) for name in _FLOAT_VARS}
    status = np.full(shape, STATUS_NOT_COMPUTED, dtype=np.int32)
    message = np.full(shape, "", dtype=object)
    for flat, (_, key) in enumerate(plan["points"]):
        idx = np.unravel_index(flat, shape) if shape else ()
        res = results[key]
        for name in _FLOAT_VARS:
            floats[name][idx] = res[name]
        status[idx] = res["status"]
        message[idx] = res["message"]

    def attrs(units, long_name):
        return {"units": units, "long_name": long_name}

    data = {name: (dims, floats[name], attrs(*_FLOAT_VARS[name])) for name in _FLOAT_VARS}
    data["status"] = (dims, status, {"long_name": "run status", "flag_meanings": _STATUS_DOC})
    data["message"] = (dims, message.astype(str), {"long_name": "status message"})
    coords = {k: (k, v, attrs(*_FIELD_ATTRS[k])) for k, v in grid.items()}
    base = plan["base"]
    ds_attrs = {f"base_{f}": _attr_value(getattr(base, f)) for f in _FIELDS}
    ds_attrs.update(duration=plan["duration"], duration_units="s", backend=plan["backend"], x0=plan["x0"],
                    v0=plan["v0"], simulate_options=json.dumps(plan["options"], sort_keys=True, default=repr),
                    impactosc_version=_version())
    return xr.Dataset(data, coords=coords, attrs=ds_attrs)


def _attr_value(value):
    """A drive field as a netCDF attribute: ``None`` as ``"None"``, nested tuples as JSON text."""
    if value is None:
        return "None"
    if isinstance(value, tuple):
        return json.dumps(value)
    return value


def _warn_failures(plan: dict, ds: xr.Dataset) -> None:
    failed = []
    for flat, (point, _) in enumerate(plan["points"]):
        idx = np.unravel_index(flat, ds["status"].shape) if ds["status"].ndim else ()
        st = int(ds["status"].values[idx])
        if st != 0:
            failed.append(f"{_point_label(point)}: status {st}, {ds['message'].values[idx]}")
    if failed:
        shown = "; ".join(failed[:5]) + (f"; and {len(failed) - 5} more" if len(failed) > 5 else "")
        warnings.warn(f"sweep: {len(failed)} of {len(plan['points'])} points failed (NaN results, see the status "
                      f"and message variables): {shown}", RuntimeWarning, stacklevel=3)


# When the package root does ``from .sweep import sweep``, the name ``impactosc.sweep`` is
# the function, so ``impactosc.sweep.load`` must also work on the function.
sweep.load = load_sweep
