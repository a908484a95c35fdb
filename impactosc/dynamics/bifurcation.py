"""Bifurcation diagrams: the stroboscopic section after a transient, over one parameter.

For every value of the parameter the motion runs ``transient_periods`` forcing periods,
which are discarded, then ``record_periods`` more, sampled once per period at the section
phase (exact time events, :mod:`.poincare`). A period-``n`` orbit shows ``n`` points per
value, a chaotic or quasi-periodic motion a smear.

Continuation. With ``continuation="none"`` every value starts from ``(x0, v0)`` and the
values run in parallel. ``"forward"`` runs the values in increasing order, each from the
final state of the previous one (the final time is a whole number of forcing periods, so
the forcing phase carries over too); ``"backward"`` the same in decreasing order; ``"both"``
runs the two passes concurrently. Where two attractors coexist the passes follow different
branches: hysteresis shows as two diagrams that differ over an interval.

Execution. The work is module-level functions with plain arguments (``_run_values``,
``_run_pass``), submitted to any :class:`concurrent.futures.Executor` (default: a local
process pool), and every finished value is written at once to a store directory: one small
``.npz`` file per value, written atomically (a temporary file renamed into place), so an
interrupted diagram resumes where it stopped (a pass from its last finished value). The main
process follows the store to drive a tqdm progress bar.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import math
import multiprocessing
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .._util import validation as _v
from ..backends._simulate import simulate
from ._common import (
    check_base,
    check_parameter,
    check_values,
    forcing_period,
    oscillator_of,
    parameter_attrs,
    section_offset,
    with_parameter,
)

__all__ = ["bifurcation_diagram", "plot_bifurcation", "load_bifurcation", "CONTINUATIONS"]

CONTINUATIONS = ("none", "forward", "backward", "both")
STATUS_EXCEPTION = -2
STATUS_LOST = -3
STATUS_NOT_COMPUTED = -4
_STORE_FORMAT = 1
_MANIFEST = "manifest.json"
#: Tasks per worker for independent values: few enough to amortise each worker's heyoka
#: compilation, enough to balance the load.
CHUNKS_PER_WORKER = 4


# ---------------------------------------------------------------------------------------
# The work: module level, plain arguments (pickles for process pools and dask)
# ---------------------------------------------------------------------------------------
def _run_value(base, parameter: str, value: float, x0: float, v0: float, settings: dict) -> dict:
    """One value: transient, then the recorded section points. Never raises."""
    n_rec = settings["record_periods"]
    out: dict[str, Any] = {"x": np.full(n_rec, math.nan), "v": np.full(n_rec, math.nan), "t": np.full(n_rec, math.nan),
           "x_final": math.nan, "v_final": math.nan}
    try:
        osc = oscillator_of(with_parameter(base, parameter, value))
        T = forcing_period(osc)
        n_tr = settings["transient_periods"]
        t_s = section_offset(osc, settings["phase"])
        t_end = (n_tr + n_rec) * T
        times = t_s + T * np.arange(n_tr, n_tr + n_rec)
        sol = simulate(osc, t_end, x0, v0, backend=settings["backend"], record="stats", sample_at=times,
                       **settings["options"])
    except Exception as exc:  # noqa: BLE001 - one bad value is recorded, not raised
        out.update(status=STATUS_EXCEPTION, message=f"{type(exc).__name__}: {exc}")
        return out
    s = sol.samples
    k = len(s)
    out["x"][:k], out["v"][:k], out["t"][:k] = s.x, s.v, s.t
    out.update(x_final=sol.x_final, v_final=sol.v_final, status=int(sol.status), message=str(sol.message))
    return out


def _run_values(store: str, label: str, items: list, base, parameter: str, x0: float, v0: float,
                settings: dict) -> int:
    """Independent values ``[(index, value), ...]``, each saved to the store when done."""
    for index, value in items:
        _save(Path(store), label, index, value, _run_value(base, parameter, value, x0, v0, settings))
    return len(items)


def _run_pass(store: str, label: str, items: list, base, parameter: str, x0: float, v0: float,
              settings: dict) -> int:
    """A continuation pass over ``[(index, value), ...]`` in order, each from the last final state.

    Resumes after the values of this pass already in the store. A value whose run failed
    hands on its own start state (the next value does not start from NaN).
    """
    root = Path(store)
    done = 0
    for index, value in items:
        path = _path(root, label, index)
        if path.exists():
            prev = _load(path)
        else:
            prev = _run_value(base, parameter, value, x0, v0, settings)
            _save(root, label, index, value, prev)
        done += 1
        if math.isfinite(prev["x_final"]) and math.isfinite(prev["v_final"]):
            x0, v0 = float(prev["x_final"]), float(prev["v_final"])
    return done


# ---------------------------------------------------------------------------------------
# Store: manifest.json + <label>-<index>.npz
# ---------------------------------------------------------------------------------------
def _path(root: Path, label: str, index: int) -> Path:
    return root / f"{label}-{index:06d}.npz"


def _save(root: Path, label: str, index: int, value: float, result: dict) -> None:
    fd, tmp = tempfile.mkstemp(dir=root, prefix=".tmp-", suffix=".npz")
    os.close(fd)
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, value=value, x=result["x"], v=result["v"], t=result["t"], x_final=result["x_final"],
                     v_final=result["v_final"], status=result["status"], message=result["message"])
        os.replace(tmp, _path(root, label, index))
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _load(path: Path) -> dict:
    with np.load(path) as f:
        return {"value": float(f["value"]), "x": f["x"], "v": f["v"], "t": f["t"], "x_final": float(f["x_final"]),
                "v_final": float(f["v_final"]), "status": int(f["status"]), "message": str(f["message"])}


def _open_store(root: Path, manifest: dict) -> None:
    path = root / _MANIFEST
    if path.exists():
        old = json.loads(path.read_text())
        if old != manifest:
            diffs = [k for k in sorted(set(old) | set(manifest)) if old.get(k) != manifest.get(k)]
            raise ValueError(f"store {str(root)!r} holds a diagram with different settings ({', '.join(diffs)}); "
                             "use a new store, or delete this one to start over")
        return
    root.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=root, prefix=".tmp-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump(manifest, fh, indent=1)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------
# The driver
# ---------------------------------------------------------------------------------------
def bifurcation_diagram(base, parameter: str, values, *, transient_periods: int = 200, record_periods: int = 50,
                        continuation: str = "none", x0: float = 0.95, v0: float = 0.0, phase: float | None = None,
                        backend: str = "heyoka", executor=None, store=None, progress: bool = True,
                        **options):
    """Stroboscopic bifurcation diagram of ``base`` over ``parameter``.

    Parameters
    ----------
    base : Oscillator or TapeDrive
        The model; ``parameter`` is one of its fields (a drive: SI units, e.g. ``speed``).
    parameter : str
        The parameter to vary (see ``impactosc.dynamics.parameter_names``).
    values : sequence of float
        Its values: finite and distinct (continuation passes visit them sorted).
    transient_periods, record_periods : int
        Forcing periods discarded, then recorded, at every value.
    continuation : {"none", "forward", "backward", "both"}
        See the module docstring.
    x0, v0 : float
        Initial state (of every value, or of the first value of each pass).
    phase : float, optional
        Forcing phase of the section (default: the phase at t = 0).
    backend : str
        Backend (``**options`` are its options).
    executor : concurrent.futures.Executor, "serial" or None
        Where the work runs. None: a local process pool (spawn) of ``os.cpu_count()``
        workers, shut down at the end. ``"serial"``: in this process.
    store : str or os.PathLike, optional
        Directory of the resumable store (created if needed). A rerun with the same
        settings loads what is finished and computes the rest.
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    xarray.Dataset
        Dimensions ``direction`` (``independent`` or ``forward``/``backward``), the
        parameter, and ``period`` (the recorded periods); variables ``x``, ``v``, ``t`` (the
        section points), ``x_final``, ``v_final``, ``status`` (0 ok, 1 event limit, -1 run
        failed, -2 exception, -3 task lost, -4 not computed) and ``message``.
    """
    check_base(base)
    check_parameter(base, parameter)
    vals = check_values(f"values of {parameter!r}", values)
    transient_periods = _v.integer("transient_periods", transient_periods, minimum=0)
    record_periods = _v.integer("record_periods", record_periods)
    _v.choice("continuation", continuation, CONTINUATIONS)
    x0, v0 = _v.real("x0", x0), _v.real("v0", v0)
    if phase is not None:
        phase = _v.real("phase", phase)
    if isinstance(executor, str) and executor != "serial":
        raise ValueError(f"executor must be None, 'serial' or a concurrent.futures.Executor, got {executor!r}")
    if executor is not None and not isinstance(executor, str) and not callable(getattr(executor, "submit", None)):
        raise TypeError(f"executor must have a submit() method, got {type(executor).__name__}")
    # The first value must make a valid model: a bad backend or option fails here, once.
    simulate(oscillator_of(with_parameter(base, parameter, float(vals[0]))), 1e-9, x0, v0, backend=backend,
             record="stats", **options)
    settings = {"transient_periods": transient_periods, "record_periods": record_periods, "phase": phase,
                "backend": backend, "options": dict(options)}
    labels = {"none": ["independent"], "forward": ["forward"], "backward": ["backward"],
              "both": ["forward", "backward"]}[continuation]
    order = np.argsort(vals, kind="stable")
    sequences = {"independent": list(range(vals.size)), "forward": [int(i) for i in order],
                 "backward": [int(i) for i in order[::-1]]}
    manifest = json.loads(json.dumps({"format": _STORE_FORMAT, "base": repr(base),
                                      "base_type": type(base).__name__, "parameter": parameter,
                                      "values": vals.tolist(), "continuation": continuation, "x0": x0, "v0": v0,
                                      "settings": settings}, default=repr))
    owned_store = store is None
    root = Path(tempfile.mkdtemp(prefix="impactosc-bifurcation-")) if owned_store else Path(store)
    try:
        _open_store(root, manifest)
        tasks = []
        for label in labels:
            items = [(i, float(vals[i])) for i in sequences[label] if not _path(root, label, i).exists()]
            if not items:
                continue
            if label == "independent":
                tasks += [(_run_values, label, chunk) for chunk in _chunks(items, executor)]
            else:
                tasks.append((_run_pass, label, [(i, float(vals[i])) for i in sequences[label]]))
        total = len(labels) * vals.size
        _execute(tasks, root, base, parameter, x0, v0, settings, executor, progress, total, labels)
        return _dataset(root, base, parameter, vals, labels, manifest)
    finally:
        if owned_store:
            shutil.rmtree(root, ignore_errors=True)


def _chunks(items: list, executor) -> list[list]:
    if executor == "serial":
        return [items]
    workers = getattr(executor, "_max_workers", None) or os.cpu_count() or 1
    n = max(1, min(len(items), CHUNKS_PER_WORKER * workers))
    return [items[i::n] for i in range(n)]


def _count(root: Path, labels) -> int:
    return sum(1 for p in root.iterdir() if p.suffix == ".npz" and p.name.split("-")[0] in labels)


def _execute(tasks, root, base, parameter, x0, v0, settings, executor, progress, total, labels) -> None:
    from tqdm.auto import tqdm

    bar = tqdm(total=total, initial=_count(root, labels), disable=not progress, desc=f"bifurcation {parameter}",
               unit="value")
    args = (base, parameter, x0, v0, settings)
    try:
        if not tasks:
            return
        if executor == "serial":
            for fn, label, items in tasks:
                fn(str(root), label, items, *args)
                bar.n = _count(root, labels)
                bar.refresh()
            return
        owned = executor is None
        if owned:
            workers = max(1, min(os.cpu_count() or 1, len(tasks)))
            executor = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))
        futures = {}
        try:
            futures = {executor.submit(fn, str(root), label, items, *args): (label, items)
                       for fn, label, items in tasks}
            pending = set(futures)
            while pending:
                done, pending = cf.wait(pending, timeout=0.25, return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    try:
                        fut.result()
                    except Exception as exc:  # noqa: BLE001 - a lost task costs its unfinished values only
                        label, items = futures[fut]
                        for index, value in items:
                            if not _path(root, label, index).exists():
                                _save(root, label, index, value, _lost(settings, exc))
                bar.n = _count(root, labels)
                bar.refresh()
        except BaseException:
            for fut in futures:
                fut.cancel()
            if owned:  # an interrupt: do not sit out the tasks still running
                executor.shutdown(wait=False, cancel_futures=True)
                owned = False
            raise
        finally:
            if owned:
                executor.shutdown(wait=True, cancel_futures=True)
    finally:
        bar.n = _count(root, labels)
        bar.close()


def _lost(settings: dict, exc: BaseException) -> dict:
    n = settings["record_periods"]
    nan = np.full(n, math.nan)
    return {"x": nan, "v": nan, "t": nan, "x_final": math.nan, "v_final": math.nan, "status": STATUS_LOST,
            "message": f"task lost ({type(exc).__name__}: {exc})"}


def _dataset(root: Path, base, parameter: str, vals: np.ndarray, labels: list, manifest: dict):
    import xarray as xr

    n_rec = manifest["settings"]["record_periods"]
    shape = (len(labels), vals.size, n_rec)
    x, v, t = np.full(shape, math.nan), np.full(shape, math.nan), np.full(shape, math.nan)
    xf, vf = np.full(shape[:2], math.nan), np.full(shape[:2], math.nan)
    status = np.full(shape[:2], STATUS_NOT_COMPUTED, dtype=np.int32)
    message = np.full(shape[:2], "not computed", dtype=object)
    for d, label in enumerate(labels):
        for i in range(vals.size):
            path = _path(root, label, i)
            if not path.exists():
                continue
            r = _load(path)
            x[d, i], v[d, i], t[d, i] = r["x"], r["v"], r["t"]
            xf[d, i], vf[d, i], status[d, i], message[d, i] = r["x_final"], r["v_final"], r["status"], r["message"]
    dims = ("direction", parameter, "period")
    settings = manifest["settings"]
    first = settings["transient_periods"]
    ds = xr.Dataset(
        {"x": (dims, x, {"units": "1", "long_name": "position X = x/L on the stroboscopic section"}),
         "v": (dims, v, {"units": "1", "long_name": "velocity V on the stroboscopic section"}),
         "t": (dims, t, {"units": "1", "long_name": "section time Lambda"}),
         "x_final": (dims[:2], xf, {"long_name": "final position (start of the next value in a pass)"}),
         "v_final": (dims[:2], vf, {"long_name": "final velocity"}),
         "status": (dims[:2], status, {"long_name": "0 ok; 1 event limit; -1 run failed; -2 exception; "
                                                    "-3 task lost; -4 not computed"}),
         "message": (dims[:2], message.astype(str))},
        coords={"direction": labels, parameter: (parameter, vals, parameter_attrs(base, parameter)),
                "period": np.arange(first, first + n_rec)},
        attrs={"parameter": parameter, "base": repr(base), "continuation": manifest["continuation"],
               "transient_periods": first, "record_periods": n_rec, "backend": settings["backend"],
               "section_phase": "phase at t = 0" if settings["phase"] is None else settings["phase"],
               "x0": manifest["x0"], "v0": manifest["v0"]})
    return ds


def load_bifurcation(store):
    """Read a bifurcation store back (finished values only; the rest have status -4)."""
    from ..model._oscillator import Oscillator
    from ..model._tape import TapeDrive

    root = Path(store)
    manifest = json.loads((root / _MANIFEST).read_text())
    labels = {"none": ["independent"], "forward": ["forward"], "backward": ["backward"],
              "both": ["forward", "backward"]}[manifest["continuation"]]
    vals = np.array(manifest["values"], dtype=float)
    # a stand-in of the base's type, for the units of the parameter (the manifest keeps its repr)
    base = TapeDrive() if manifest.get("base_type") == "TapeDrive" else Oscillator(0.0, 0.0, 0.0, 1.0)
    ds = _dataset(root, base, manifest["parameter"], vals, labels, manifest)
    ds.attrs["base"] = manifest["base"]
    return ds


def plot_bifurcation(ds, variable: str = "x", *, ax=None, onset=None, onset_label: str = "contact onset",
                     markersize: float = 1.0):
    """The classic diagram: every recorded section point against the parameter.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`bifurcation_diagram`.
    variable : {"x", "v"}
    ax : matplotlib.axes.Axes, optional
    onset : float or sequence of float, optional
        Parameter values to mark with a vertical line (e.g. a contact onset).
    """
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()

    if variable not in ("x", "v"):
        raise ValueError(f"variable must be 'x' or 'v', got {variable!r}")
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 4))
    parameter = ds.attrs["parameter"]
    p = ds[parameter].values
    colors = {"independent": "k", "forward": "C0", "backward": "C3"}
    for d, label in enumerate(ds["direction"].values.tolist()):
        y = ds[variable].values[d]
        px = np.broadcast_to(p[:, None], y.shape)
        ok = np.isfinite(y)
        ax.plot(px[ok], y[ok], marker=".", ms=markersize, ls="none", color=colors.get(label, None),
                alpha=0.6 if len(ds["direction"]) > 1 else 1.0, label=label if len(ds["direction"]) > 1 else None)
    if onset is not None:
        for k, o in enumerate(np.atleast_1d(onset)):
            ax.axvline(float(o), color="C2", lw=1.0, ls="--", label=onset_label if k == 0 else None)
    if variable == "x":
        for edge in (-1.0, 1.0):
            ax.axhline(edge, color="0.6", lw=0.8, ls=":")
    units = ds[parameter].attrs.get("units", "")
    ax.set_xlabel(f"{parameter}" + (f" [{units}]" if units not in ("", "1") else ""))
    ax.set_ylabel("X on the section" if variable == "x" else "V on the section")
    if len(ds["direction"]) > 1 or onset is not None:
        ax.legend(fontsize=8, markerscale=6)
    return ax
