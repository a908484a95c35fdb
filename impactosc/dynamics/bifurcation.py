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

Execution. The values (or, with continuation, the passes: one pass is one task) are points
of :func:`impactosc.runner.run_points`: the reusable local pool by default (a small diagram
runs in this process, see the runner's rule), ``"serial"``, any
:class:`concurrent.futures.Executor` or a ``dask.distributed.Client``. With ``store=``
every finished value is saved at once in the runner's verified store (one ``.npz`` file per
value, format ``STORE_FORMAT``), so an interrupted diagram resumes where it stopped (a
pass from its last finished value).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .._util import validation as _v
from ..backends._simulate import simulate
from ..model.hybrid._definition import HybridSystem
from ..runner import PointStore, check_executor, check_store_path, point_key, run_points
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
from .system_bifurcation import system_bifurcation_diagram

__all__ = ["bifurcation_diagram", "plot_bifurcation", "load_bifurcation", "CONTINUATIONS"]

CONTINUATIONS = ("none", "forward", "backward", "both")
STATUS_EXCEPTION = -2
STATUS_LOST = -3
STATUS_NOT_COMPUTED = -4
#: Format 1 (before the shared runner) kept unverified ``<direction>-<index>.npz`` files
#: beside the manifest; such a store is refused with a message naming its manifest.
STORE_FORMAT = 2
_KIND = "bifurcation diagram"
_LABELS = {"none": ["independent"], "forward": ["forward"], "backward": ["backward"],
           "both": ["forward", "backward"]}


# ---------------------------------------------------------------------------------------
# The work: module level, plain arguments (pickles for process pools and dask)
# ---------------------------------------------------------------------------------------
def _run_value(base, parameter: str, value: float, x0: float, v0: float, settings: dict) -> dict:
    """One value: transient, then the recorded section points. Never raises."""
    n_rec = settings["record_periods"]
    out: dict[str, Any] = {"x": np.full(n_rec, math.nan), "v": np.full(n_rec, math.nan),
                           "t": np.full(n_rec, math.nan), "x_final": math.nan, "v_final": math.nan}
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
    out.update(x_final=float(sol.x_final), v_final=float(sol.v_final), status=int(sol.status),
               message=str(sol.message))
    return out


def _value_task(value: float, base, parameter: str, x0: float, v0: float, settings: dict) -> dict:
    """A runner point: one value from ``(x0, v0)``."""
    return _run_value(base, parameter, value, x0, v0, settings)


def _pass_task(payload: tuple, base, parameter: str, settings: dict) -> dict:
    """A runner point: a continuation pass ``[(key, fields), ...]`` in order, from ``(x0, v0)``.

    Each value starts from the final state of the one before; a value whose run failed hands
    on its own start state (the next value does not start from NaN). With a store, every
    value is saved as soon as it is done, so an interrupted pass resumes from there.
    """
    items, x0, v0, store = payload
    out = {}
    for key, fields in items:
        result = _run_value(base, parameter, fields["value"], x0, v0, settings)
        if store is not None:
            store.save(key, fields, result)
        out[key] = result
        if math.isfinite(result["x_final"]) and math.isfinite(result["v_final"]):
            x0, v0 = result["x_final"], result["v_final"]
    return out


def _failure(n_rec: int, status: int, message: str) -> dict:
    nan = np.full(n_rec, math.nan)
    return {"x": nan, "v": nan, "t": nan, "x_final": math.nan, "v_final": math.nan, "status": status,
            "message": message}


# ---------------------------------------------------------------------------------------
# Store: the runner's, one .npz per value
# ---------------------------------------------------------------------------------------
class _NpzValue:
    """One value of a diagram as a ``.npz`` file (its key, inputs and settings as JSON text)."""

    suffix = ".npz"

    def write(self, path: str, record: dict) -> None:
        r = record["result"]
        with open(path, "wb") as fh:
            np.savez(fh, x=r["x"], v=r["v"], t=r["t"], x_final=r["x_final"], v_final=r["v_final"],
                     status=r["status"], message=r["message"], key=record["key"],
                     fields=json.dumps(record["fields"]), settings=json.dumps(record["settings"]),
                     checksum=record["checksum"])

    def read(self, path: Path) -> dict:
        with np.load(path) as f:
            result = {"x": f["x"], "v": f["v"], "t": f["t"], "x_final": float(f["x_final"]),
                      "v_final": float(f["v_final"]), "status": int(f["status"]), "message": str(f["message"])}
            return {"key": str(f["key"]), "fields": json.loads(str(f["fields"])),
                    "settings": json.loads(str(f["settings"])), "result": result, "checksum": str(f["checksum"])}


_CODEC = _NpzValue()


def _plan(settings: dict) -> dict:
    """Every value of every direction: ``{label: [(key, fields), ...]}`` in the order run."""
    vals = np.array(settings["values"], dtype=float)
    order = np.argsort(vals, kind="stable")
    sequences = {"independent": list(range(vals.size)), "forward": [int(i) for i in order],
                 "backward": [int(i) for i in order[::-1]]}
    plan = {}
    for label in _LABELS[settings["continuation"]]:
        items = []
        for i in sequences[label]:
            fields = {"direction": label, "index": i, "value": float(vals[i])}
            items.append((point_key(fields, settings), fields))
        plan[label] = items
    return plan


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
    base : Oscillator, TapeDrive or HybridSystem
        The model; ``parameter`` is one of its fields (a drive: SI units, e.g. ``speed``). A
        user system (with a forcing period) goes to :func:`.system_bifurcation.system_bifurcation_diagram`
        (``state0=``, ``t0=`` instead of ``x0, v0, phase``; no store).
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
    executor : None, "serial", "dask", concurrent.futures.Executor or dask.distributed.Client
        Where the work runs (:func:`impactosc.runner.run_points`). None: the reusable local
        process pool (no ``__main__`` guard needed), or this process for a small diagram or
        a single pass. ``"serial"``: in this process. A dask client is used as it is.
    store : str or os.PathLike, optional
        Directory of the resumable store (created if needed). A rerun with the same
        settings loads what is finished and computes the rest; a damaged or swapped value
        file is moved to ``quarantine/`` with a warning naming it and computed again.
    progress : bool
        Show a tqdm progress bar (over values, or over passes with continuation).

    Returns
    -------
    xarray.Dataset
        Dimensions ``direction`` (``independent`` or ``forward``/``backward``), the
        parameter, and ``period`` (the recorded periods); variables ``x``, ``v``, ``t`` (the
        section points), ``x_final``, ``v_final``, ``status`` (0 ok, 1 event limit, -1 run
        failed, -2 exception, -3 task lost, -4 not computed) and ``message``.

    Raises
    ------
    TypeError, ValueError
        A bad argument, before anything runs: the parameter, a value (NaN, duplicate; the
        first one the model refuses), an option the backend refuses, the executor, a ``store`` that
        is a file, was made with other settings or by an older version (format 1).
    RuntimeError
        Every value (or pass) run was lost with its task (the workers crashed or could not start).
    """
    if isinstance(base, HybridSystem):  # a user system: its own sampling, the same runner
        if store is not None or (x0, v0, phase) != (0.95, 0.0, None):
            raise TypeError("x0, v0, phase and store are the built-in family's; a user system takes state0= and t0=")
        return system_bifurcation_diagram(base, parameter, values, transient_periods=transient_periods,
                                          record_periods=record_periods, continuation=continuation, backend=backend,
                                          executor=executor, progress=progress, **options)
    settings = _check(base, parameter, values, transient_periods, record_periods, continuation, x0, v0, phase,
                      backend, options)
    check_executor(executor)
    st = None
    if store is not None:
        check_store_path(store)
        st = PointStore.create(store, settings, _CODEC, kind=_KIND, fmt=STORE_FORMAT)
    plan = _plan(settings)
    results = _stored(st, plan, settings["continuation"])
    n_rec = settings["record_periods"]
    args = (base, parameter, settings)

    def on_lost(key, message):
        for k, _ in todo_items.get(key, [(key, None)]):
            if k not in results:
                stored = st.load(k) if st is not None else None  # saved by the pass before it was lost
                results[k] = stored if stored is not None else _failure(n_rec, STATUS_LOST, message)

    desc = f"bifurcation {parameter}"
    if settings["continuation"] == "none":
        fields_of = dict(plan["independent"])
        todo = [(key, fields["value"]) for key, fields in plan["independent"] if key not in results]
        todo_items: dict = {}

        def on_result(key, result):
            results[key] = result
            if st is not None:
                st.save(key, fields_of[key], result)

        run_points(_value_task, todo, (base, parameter, settings["x0"], settings["v0"], settings),
                   executor=executor, on_result=on_result, on_lost=on_lost, progress=progress, desc=desc,
                   unit="value", initial=len(plan["independent"]) - len(todo), what="bifurcation_diagram",
                   try_here_first=True)
    else:
        todo, todo_items = _pass_todo(plan, results, settings, st)
        run_points(_pass_task, todo, args, executor=executor, on_result=lambda _, done: results.update(done),
                   on_lost=on_lost, progress=progress, desc=desc, unit="pass", initial=len(plan) - len(todo),
                   what="bifurcation_diagram", batch=False, try_here_first=len(todo) == 1)
    if st is not None:
        st.warn_unusable(stacklevel=2)
    return _dataset(base, settings, plan, results)


def _check(base, parameter, values, transient_periods, record_periods, continuation, x0, v0, phase, backend,
           options) -> dict:
    """The validated arguments as the diagram's settings (JSON-normal: they are the store's)."""
    check_base(base)
    check_parameter(base, parameter)
    vals = check_values(f"values of {parameter!r}", values)
    transient_periods = _v.integer("transient_periods", transient_periods, minimum=0)
    record_periods = _v.integer("record_periods", record_periods)
    _v.choice("continuation", continuation, CONTINUATIONS)
    x0, v0 = _v.real("x0", x0), _v.real("v0", v0)
    if phase is not None:
        phase = _v.real("phase", phase)
    # The first value must make a valid model: a bad backend or option fails here, once. (A
    # later value the model refuses costs only itself: status -2 with the reason.)
    simulate(oscillator_of(with_parameter(base, parameter, float(vals[0]))), 1e-9, x0, v0, backend=backend,
             record="stats", **options)
    settings = {"base": repr(base), "base_type": type(base).__name__, "parameter": parameter,
                "values": vals.tolist(), "continuation": continuation, "x0": x0, "v0": v0,
                "transient_periods": transient_periods, "record_periods": record_periods, "phase": phase,
                "backend": backend, "options": dict(options)}
    return json.loads(json.dumps(settings, default=repr))


def _stored(st, plan: dict, continuation: str) -> dict:
    """The values already in the store; a pass counts only up to its first missing value."""
    results: dict = {}
    if st is None:
        return results
    for items in plan.values():
        for key, _ in items:
            stored = st.load(key)
            if stored is None:
                if continuation != "none":
                    break  # the values after a gap started from another state: computed again
                continue
            results[key] = stored
    return results


def _pass_todo(plan: dict, results: dict, settings: dict, st) -> tuple[list, dict]:
    """The unfinished passes as runner points, each from the final state of its last stored value."""
    todo, items_of = [], {}
    for label, items in plan.items():
        x0, v0 = settings["x0"], settings["v0"]
        done = 0
        while done < len(items) and items[done][0] in results:
            r = results[items[done][0]]
            if math.isfinite(r["x_final"]) and math.isfinite(r["v_final"]):
                x0, v0 = r["x_final"], r["v_final"]
            done += 1
        if done < len(items):
            todo.append((label, (items[done:], x0, v0, st)))
            items_of[label] = items[done:]
    return todo, items_of


def _dataset(base, settings: dict, plan: dict, results: dict):
    import xarray as xr

    parameter = settings["parameter"]
    vals = np.array(settings["values"], dtype=float)
    labels = list(plan)
    n_rec = settings["record_periods"]
    shape = (len(labels), vals.size, n_rec)
    x, v, t = np.full(shape, math.nan), np.full(shape, math.nan), np.full(shape, math.nan)
    xf, vf = np.full(shape[:2], math.nan), np.full(shape[:2], math.nan)
    status = np.full(shape[:2], STATUS_NOT_COMPUTED, dtype=np.int32)
    message = np.full(shape[:2], "not computed", dtype=object)
    for d, label in enumerate(labels):
        for key, fields in plan[label]:
            r = results.get(key)
            if r is None:
                continue
            i = fields["index"]
            x[d, i], v[d, i], t[d, i] = r["x"], r["v"], r["t"]
            xf[d, i], vf[d, i], status[d, i], message[d, i] = r["x_final"], r["v_final"], r["status"], r["message"]
    dims = ("direction", parameter, "period")
    first = settings["transient_periods"]
    return xr.Dataset(
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
        attrs={"parameter": parameter, "base": settings["base"], "continuation": settings["continuation"],
               "transient_periods": first, "record_periods": n_rec, "backend": settings["backend"],
               "section_phase": "phase at t = 0" if settings["phase"] is None else settings["phase"],
               "x0": settings["x0"], "v0": settings["v0"]})


def load_bifurcation(store):
    """Read a bifurcation store back (finished values only; the rest have status -4).

    Nothing on disk changes; an unusable value file counts as not computed, with a warning
    naming it. A store of format 1 (before the shared runner) is refused with a
    ``ValueError`` naming its manifest.
    """
    from ..model._oscillator import Oscillator
    from ..model._tape import TapeDrive

    st, manifest = PointStore.read(store, _CODEC, kind=_KIND, fmt=STORE_FORMAT)
    settings = manifest["settings"]
    # a stand-in of the base's type, for the units of the parameter (the store keeps its repr)
    base = TapeDrive() if settings.get("base_type") == "TapeDrive" else Oscillator(0.0, 0.0, 0.0, 1.0)
    plan = _plan(settings)
    results = {}
    for items in plan.values():
        for key, _ in items:
            stored = st.load(key)
            if stored is not None:
                results[key] = stored
    st.warn_unusable(stacklevel=2)
    return _dataset(base, settings, plan, results)


def plot_bifurcation(ds, variable: str = "x", *, ax=None, onset=None, onset_label: str = "contact onset",
                     markersize: float = 1.0, base=None):
    """The classic diagram: every recorded section point against the parameter.

    With ``variable="x"`` the flanges are drawn where the member has them
    (:func:`impactosc.results.draw_flanges`), following the parameter when it moves them
    (a drive's ``guide_offset``); an absent flange is not drawn.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`bifurcation_diagram`.
    variable : {"x", "v"}
    ax : matplotlib.axes.Axes, optional
    onset : float or sequence of float, optional
        Parameter values to mark with a vertical line (e.g. a contact onset).
    markersize : float
        Size of the section points.
    base : Oscillator or TapeDrive, optional
        The study's base, for the flanges; default: read back from ``ds.attrs["base"]`` (its
        repr, parsed, never evaluated). Without either, no flanges are drawn.

    Returns
    -------
    matplotlib.axes.Axes

    Examples
    --------
    >>> from impactosc import Oscillator
    >>> from impactosc.dynamics import bifurcation_diagram, plot_bifurcation
    >>> osc = Oscillator(0.3, 0.8, 0.05, flange="rigid", restitution=0.8, gap_upper=0.6)
    >>> ds = bifurcation_diagram(osc, "F", [0.2, 0.4], transient_periods=20, record_periods=5, x0=0.0,
    ...                          executor="serial", progress=False)
    >>> ax = plot_bifurcation(ds)   # the rigid wall at X = 0.6, the lower flange at -1
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
        _draw_flanges_along(ax, ds, parameter, p, base)
    units = ds[parameter].attrs.get("units", "")
    ax.set_xlabel(f"{parameter}" + (f" [{units}]" if units not in ("", "1") else ""))
    ax.set_ylabel("X on the section" if variable == "x" else "V on the section")
    if ax.get_legend_handles_labels()[0]:  # directions, onsets, flanges
        ax.legend(fontsize=8, markerscale=6)
    return ax


def _draw_flanges_along(ax, ds, parameter: str, values: np.ndarray, base) -> None:
    """The flanges of the member at every value of the diagram (where the model accepts it)."""
    from ..results import draw_flanges

    base = _base_of(ds) if base is None else check_base(base)
    if base is None:
        return
    members, along = [], []
    for value in values:
        try:
            members.append(oscillator_of(with_parameter(base, parameter, float(value))))
        except (TypeError, ValueError):  # a value the model refuses has status -2 and no points
            continue
        along.append(float(value))
    if members:
        draw_flanges(ax, members, along=np.array(along))


def _base_of(ds):
    """The base of the diagram rebuilt from ``ds.attrs["base"]``, or None where it cannot be.

    The attribute is the base's repr: ``Oscillator(F=..., ...)`` or ``TapeDrive(...)``. It is
    parsed, not evaluated (a netCDF file may come from anywhere): a call of one of the two
    classes whose arguments are literals (numbers, strings, tuples, ``inf`` and ``nan``).
    """
    import ast

    from ..model import Oscillator, TapeDrive

    classes = {"Oscillator": Oscillator, "TapeDrive": TapeDrive}
    try:
        call = ast.parse(str(ds.attrs.get("base", "")), mode="eval").body
        if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id in classes):
            return None

        def literal(node):
            if isinstance(node, ast.Name) and node.id in ("inf", "nan"):
                return float(node.id)
            if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and isinstance(node.operand, ast.Name):
                return -literal(node.operand)
            if isinstance(node, ast.Tuple | ast.List):
                return tuple(literal(e) for e in node.elts)
            return ast.literal_eval(node)

        args = [literal(a) for a in call.args]
        kwargs = {k.arg: literal(k.value) for k in call.keywords if k.arg is not None}
        return classes[call.func.id](*args, **kwargs)
    except (SyntaxError, ValueError, TypeError):
        return None
