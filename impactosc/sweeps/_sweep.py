"""Parameter sweeps of the tape drive: the outer product of a grid, run in parallel, as an xarray Dataset.

:func:`sweep` runs :func:`impactosc.simulate` at every point of a grid of
:class:`~impactosc.tape.TapeDrive` fields (the paper's Fig. 7 is pack diameter x speed x
tension, its Fig. 8 is ``T sin(theta/2)``) and returns the results in SI units, one
dimension per swept field.

Points are run on a local process pool by default (loky's: it works from a script without
a ``__main__`` guard, standard input, a REPL or a notebook, and its workers, which keep their
compiled heyoka integrator from sweep to sweep, exit when the calling process dies), or on
any :class:`concurrent.futures.Executor`, or on a ``dask.distributed`` client. Points are
sent in batches sized from their measured cost (see :mod:`impactosc.runner`).

Bad arguments raise before anything runs; backend options are checked by one short run of
the base drive in the calling process. A failed point never stops the sweep: an exception,
a run that did not reach the end (``status != 0``), or even a worker process that crashed
costs that point only. It gets NaN results, its status and message, and a warning names it.
Only a sweep that loses every point it runs raises.

With ``store=`` every finished point is saved as a small netCDF file as soon as it arrives,
so that an interrupted (Ctrl-C stops at once) or extended sweep only runs what is missing;
unusable point files are set aside and recomputed (see :mod:`impactosc.runner`).
:func:`load_sweep` reads a store back.

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

import dataclasses
import inspect
import itertools
import json
import warnings
from collections.abc import Mapping

import numpy as np
import xarray as xr

from .._util import validation as _v
from ..backends import get_backend, resolve_backend
from ..backends._simulate import simulate
from ..model._tape import BENDING_OPTIONS, FIELD_UNITS, TapeDrive
from ..runner import check_executor, check_store_path, point_key, run_points
from ._point import FLOAT_VARS, STATUS_EXCEPTION, STATUS_LOST, STATUS_NOT_COMPUTED, failure, run_point
from ._store import create_store, read_store

__all__ = ["sweep", "load_sweep", "load", "SWEEP_KEYS", "STATUS_EXCEPTION", "STATUS_LOST", "STATUS_NOT_COMPUTED"]

_FIELDS = tuple(f.name for f in dataclasses.fields(TapeDrive))
#: The keys a grid may use: every TapeDrive field, and ``t_sin_half_theta`` (Fig. 8).
SWEEP_KEYS = _FIELDS + ("t_sin_half_theta",)


_STATUS_DOC = ("0 ok; 1 event limit reached; -1 integration failed; -2 exception (see message); "
               "-3 task lost (worker crashed); -4 not computed")


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
    backend_options = {k: v for k, v in options.items() if k != "max_events"}
    get_backend(backend)  # an unknown name fails here, not at every point
    # "auto" with options: the backend they are for (it does not depend on the member then).
    run = get_backend(resolve_backend(backend, None, backend_options) if backend_options else backend)
    if "max_events" in options:
        _v.integer("max_events", options["max_events"])
    try:
        inspect.signature(run).bind(None, 1.0, x0, v0, record="stats", max_events=1, **backend_options)
    except TypeError as exc:
        raise TypeError(f"backend {backend!r} does not accept these options {sorted(backend_options)}: {exc}") from None
    return x0, v0, dict(options)


def _probe_options(plan: dict) -> None:
    """Run the first grid point briefly here, so that options a backend rejects raise once, now.

    The backends own their option rules (ranges of ``tol``, ``rtol``, ``dt``, ...); rather than
    repeat them, a run of the first point up to its first event (``max_events=1``: a fraction
    of a period, or a closed-form stick) lets the backend check them. An error is the
    options' fault, and raised, only if the same run without them goes differently; an
    error of the drive itself is left for the point to record.
    """
    if not plan["unique"]:
        return
    drive = TapeDrive(**next(iter(plan["unique"].values())))

    def run(options):
        try:
            simulate(drive.oscillator(), drive.seconds_to_lambda(plan["duration"]), plan["x0"], plan["v0"],
                     backend=plan["backend"], record="stats", **options, max_events=1)
        except (TypeError, ValueError) as exc:
            return exc
        except Exception:  # noqa: BLE001 - not an argument error: the points will record their own outcome
            return None
        return None

    options = {k: v for k, v in plan["options"].items() if k != "max_events"}
    error = run(options)
    if error is None or not options:
        return
    without = run({})
    if without is None or (type(without), str(without)) != (type(error), str(error)):
        chosen = resolve_backend(plan["backend"], drive.oscillator(), options)
        raise type(error)(f"sweep options {options} rejected by backend {chosen!r} (a short run of the "
                          f"first point raised; nothing was run): {error}") from None


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


def _settings(base: TapeDrive, duration: float, backend: str, x0: float, v0: float, options: dict) -> dict:
    """Everything besides the grid that determines the results (JSON-normal form)."""
    return json.loads(json.dumps({"base": _drive_fields(base), "duration": duration, "backend": backend,
                                  "x0": x0, "v0": v0, "options": options}, sort_keys=True, default=repr))


def _version() -> str:
    # Read lazily: impactosc/__init__.py imports this module before it sets __version__.
    from .. import __version__

    return __version__


def _point_label(point: dict) -> str:
    return "(" + ", ".join(f"{k}={v!r}" for k, v in point.items()) + ")"


# ---------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------
def sweep(base: TapeDrive, grid: Mapping, *, duration: float = 1.0, backend: str = "auto", executor=None,
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
        Backend of :func:`impactosc.simulate`. The default ``"auto"`` runs each point on the
        fastest backend that runs its member (:func:`impactosc.backends.resolve_backend`):
        ``"exact"`` for the linear flange laws with numba installed (the paper's drive: the
        same forces as ``"heyoka"``, several times faster), else ``"heyoka"``; with backend
        options, the backend they are for (``tol``: heyoka). The Dataset's
        ``backend_used`` attribute says which ran.
    executor : None, "serial", "dask", concurrent.futures.Executor or dask.distributed.Client
        Where the points run. ``None`` (default): a local pool of one process per CPU
        (loky's), kept for the next sweep; it needs no ``if __name__ == "__main__":`` guard
        and works from standard input, a REPL or a notebook. ``"serial"``: in this process,
        for debugging. ``"dask"``: the current ``dask.distributed`` client, or a new local
        cluster (needs ``impactosc[dask]``). Anything with ``submit(fn, *args)`` returning
        futures: used as is, and not shut down.
    progress : bool
        Show a tqdm progress bar over the points.
    store : str or path-like, optional
        Directory in which every finished point is saved as it arrives (one netCDF file
        each, next to a ``manifest.json`` of the settings). A rerun with the same settings
        loads the saved points and runs only the missing ones, so an interrupted sweep
        resumes and an extended grid runs only its new points. A point file that cannot be
        used (truncated, garbage, or holding another point) is moved to ``quarantine/``
        with a warning and computed again. Read a store back with :func:`load_sweep`.
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
        ``peak_flange_force`` (N), ``contact_fraction``; what a flange sensor reads
        (:func:`impactosc.results.contact_observables`, from the contact sums every run
        streams): ``mean_peak_force`` (N per contact), the AE proxies ``ae_peak_sum`` and
        ``ae_impact_sum`` (N/s: peak forces and elastic impact forces ``sqrt(k0 m) v`` of the
        contacts summed per second; ``_upper``/``_lower`` for the latter),
        ``impact_energy_rate`` and ``dissipation_rate`` (W: kinetic energy brought into
        contacts and energy dissipated in them per second; inf peak and impact forces for a
        rigid flange's impacts); the nondimensional ``F``,
        ``Omega``, ``beta``, ``K`` of each point, ``simulated_time`` (s), ``status`` (int32,
        see the module docstring) and ``message`` (str). Counts are float64 so that a
        failed point can be NaN. ``attrs`` hold the base drive's fields (``base_<field>``),
        ``duration`` (s), ``backend`` (as asked, e.g. ``"auto"``), ``backend_used`` (the
        backends that ran the points, comma-separated), ``x0``, ``v0``,
        ``simulate_options`` (JSON) and ``impactosc_version``.

    Raises
    ------
    TypeError, ValueError
        For a bad argument, before anything runs: an unknown grid key (the message lists
        the valid ones), an empty, non-1-D or duplicated list of values, a non-finite value,
        ``duration <= 0``, an unknown backend, an option or option value the backend
        rejects (``tol=0``, ...), a closed dask Client, a ``store`` that is a file or was
        made with other settings (the message lists the differences).
    ImportError
        ``executor="dask"`` without dask installed.
    RuntimeError
        Every point that had to run was lost (status -3: its task failed as a whole,
        e.g. the workers could not start or kept crashing).
    KeyboardInterrupt
        Passed on at once after an interrupt: the tasks in flight are cancelled, the
        default pool's workers are killed, and every point finished before is in ``store``.

    Warns
    -----
    RuntimeWarning
        When points failed (``status != 0``): they hold NaN results and their status and
        message; the warning names them. When point files of ``store`` were unusable.

    Examples
    --------
    >>> from impactosc import TapeDrive
    >>> from impactosc.sweep import sweep
    >>> ds = sweep(TapeDrive(), {"pack_diameter": [0.05, 0.07, 0.09], "speed": [4.0, 8.0]},
    ...            duration=0.01, progress=False)                        # doctest: +SKIP
    >>> ds.mean_flange_force.sel(speed=4.0)                              # doctest: +SKIP
    >>> ds.attrs["backend"], ds.attrs["backend_used"]                    # doctest: +SKIP
    ('auto', 'exact')
    """
    plan = _plan(base, grid, duration, backend, x0, v0, simulate_options)
    check_executor(executor)
    if store is not None:
        check_store_path(store)
    _probe_options(plan)
    st = create_store(store, plan["settings"], plan["grid"], _version()) if store is not None else None

    results: dict[str, dict] = dict(plan["invalid"])
    args = (plan["duration"], backend, plan["x0"], plan["v0"], plan["options"])
    run_stored(plan["unique"], results, st, run_point, args, failure, executor=executor, progress=progress,
               what="sweep", stacklevel=3)
    ds = _assemble(plan, results)
    _warn_failures(plan, ds)
    return ds


def run_stored(unique: dict, results: dict, st, fn, args: tuple, failure, *, executor, progress: bool, what: str,
               stacklevel: int, batch: bool = True) -> dict:
    """Run ``fn(fields, *args)`` at every point of ``unique`` (key -> fields) that store ``st`` does not hold.

    The stored points are read into ``results``, the others computed and saved as they arrive
    (a lost point's ``failure(STATUS_LOST, message)`` is not saved, so a rerun tries it again);
    ``st`` may be None (nothing stored). Returns ``results``.
    """
    todo = []
    for key, fields in unique.items():
        stored = st.load(key) if st is not None else None
        if stored is None:
            todo.append((key, fields))
        else:
            results[key] = stored
    if st is not None:
        st.warn_unusable(stacklevel=stacklevel)

    def on_result(key: str, result: dict) -> None:
        results[key] = result
        if st is not None and result["status"] != STATUS_LOST:
            st.save(key, unique[key], result)

    if todo:
        run_points(fn, todo, args, executor=executor, on_result=on_result,
                   on_lost=lambda key, message: on_result(key, failure(STATUS_LOST, message)), progress=progress,
                   desc=what, unit="point", initial=len(unique) - len(todo), what=what, batch=batch)
    return results


def load_sweep(store) -> xr.Dataset:
    """Read a sweep store written by :func:`sweep` back as the Dataset of its latest grid.

    Nothing is simulated and nothing on disk changes: points not yet computed (an
    interrupted sweep) have ``status = -4`` and NaN results, and a warning says how many;
    an unusable point file (truncated, garbage, or holding another point) counts as not
    computed, and a warning names it.

    Parameters
    ----------
    store : str or path-like
        The directory passed as ``sweep(..., store=...)``.

    Returns
    -------
    xarray.Dataset
        As returned by :func:`sweep`.

    Raises
    ------
    FileNotFoundError
        ``store`` has no ``manifest.json``.
    ValueError
        The manifest is unreadable or incomplete (the message names the file).
    """
    st, manifest = read_store(store)
    try:
        s = manifest["settings"]
        plan = _plan(TapeDrive(**s["base"]), manifest["grid"], s["duration"], s["backend"], s["x0"], s["v0"],
                     s["options"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"store manifest {str(st.root / 'manifest.json')!r} does not describe a valid sweep "
                         f"({type(exc).__name__}: {exc})") from None
    results = dict(plan["invalid"])
    for key in plan["unique"]:
        stored = st.load(key)
        results[key] = stored if stored is not None else failure(
            STATUS_NOT_COMPUTED, "not computed yet: rerun sweep() with this store")
    st.warn_unusable(stacklevel=2)
    ds = _assemble(plan, results)
    missing = int((ds["status"] == STATUS_NOT_COMPUTED).sum())
    if missing:
        warnings.warn(f"store {str(st.root)!r} is incomplete: {missing} of {ds['status'].size} points not computed",
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
    points, unique, invalid, used = [], {}, {}, set()
    names = list(grid)
    for combo in itertools.product(*(v.tolist() for v in grid.values())):
        point = dict(zip(names, combo, strict=True))
        try:
            drive = _resolve(base, point)
            fields = _drive_fields(drive)
            used.add(resolve_backend(backend, drive.oscillator(), [k for k in options if k != "max_events"]))
        except (TypeError, ValueError) as exc:
            # An invalid drive is known here already: recorded without a task (and without a store file).
            key = "invalid:" + _point_label(point)
            invalid[key] = failure(STATUS_EXCEPTION, f"{type(exc).__name__}: {exc}")
        else:
            key = point_key(fields, settings_)
            unique[key] = fields
        points.append((point, key))
    return {"grid": grid, "points": points, "unique": unique, "invalid": invalid, "settings": settings_,
            "base": base, "duration": duration, "backend": backend, "backend_used": ", ".join(sorted(used)),
            "x0": x0, "v0": v0, "options": options}


def fill_grid(plan: dict, results: dict, trailing: Mapping[str, tuple]) -> tuple[dict, np.ndarray, np.ndarray]:
    """Each point's results placed on the plan's grid: ``(arrays, status, message)``.

    ``trailing[name]`` is the shape of ``name`` at one point (``()`` for a number, ``(n,)`` for
    one value per guide); its array has the grid's shape followed by it, NaN where no
    result says otherwise. ``message`` is a string array.
    """
    shape = tuple(v.size for v in plan["grid"].values())
    arrays = {name: np.full(shape + tuple(extra), np.nan) for name, extra in trailing.items()}
    status = np.full(shape, STATUS_NOT_COMPUTED, dtype=np.int32)
    message = np.full(shape, "", dtype=object)
    for flat, (_, key) in enumerate(plan["points"]):
        idx = np.unravel_index(flat, shape) if shape else ()
        res = results[key]
        for name, array in arrays.items():
            array[idx] = res[name]
        status[idx], message[idx] = res["status"], res["message"]
    return arrays, status, message.astype(str)


def _assemble(plan: dict, results: dict) -> xr.Dataset:
    grid = plan["grid"]
    dims = list(grid)
    floats, status, message = fill_grid(plan, results, dict.fromkeys(FLOAT_VARS, ()))

    def attrs(units, long_name):
        return {"units": units, "long_name": long_name}

    data = {name: (dims, floats[name], attrs(*FLOAT_VARS[name])) for name in FLOAT_VARS}
    data["status"] = (dims, status, {"long_name": "run status", "flag_meanings": _STATUS_DOC})
    data["message"] = (dims, message, {"long_name": "status message"})
    coords = {k: (k, v, attrs(*FIELD_UNITS[k])) for k, v in grid.items()}
    base = plan["base"]
    ds_attrs = {f"base_{f}": _attr_value(getattr(base, f)) for f in _FIELDS}
    ds_attrs.update(duration=plan["duration"], duration_units="s", backend=plan["backend"],
                    backend_used=plan["backend_used"], x0=plan["x0"],
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
# the function, so ``impactosc.sweep.load`` must also work on the function. A function
# attribute is dynamic by nature; setting it through ``__dict__`` (what attribute assignment
# does) says so to type checkers, which know no ``load`` on a function type.
sweep.__dict__["load"] = load_sweep
