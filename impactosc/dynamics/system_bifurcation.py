"""Bifurcation diagrams of a user system: its stroboscopic samples over one parameter.

The user-system side of :func:`~impactosc.dynamics.bifurcation_diagram` (which hands a
:class:`~impactosc.HybridSystem` here): for every value of the parameter the system runs
``transient_periods`` forcing periods, discarded, then ``record_periods`` more, sampled once
per forcing period (the run's dense output at ``t0 + k T``). A period-``n`` orbit shows ``n``
points per value, a chaotic motion a smear. The values run as points of
:func:`impactosc.runner.run_points` (independently), or in passes with continuation, each
value from the final state of the one before (``"forward"``, ``"backward"``, ``"both"``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._util import validation as _v
from ..backends._hybrid import simulate_system
from ..model.hybrid._definition import HybridSystem
from ..runner import check_executor, run_points
from ._common import check_values

__all__ = ["system_bifurcation_diagram"]

_PASSES = {"none": ("independent",), "forward": ("forward",), "backward": ("backward",),
           "both": ("forward", "backward")}


def _run_value(value: float, system: HybridSystem, parameter: str, state0, settings: dict) -> dict:
    """One value: transient, then the recorded section samples. Never raises."""
    n_rec, d = settings["record_periods"], system.dimension
    out: dict[str, Any] = {"samples": np.full((n_rec, d), math.nan), "final": np.full(d, math.nan)}
    try:
        sys_p = system.with_parameters(**{parameter: value})
        T = sys_p.period_value()
        t0, n_tr = settings["t0"], settings["transient_periods"]
        times = t0 + T * np.arange(n_tr, n_tr + n_rec)
        sol = simulate_system(sys_p, t0 + (n_tr + n_rec) * T, state0, t0=t0, backend=settings["backend"],
                              **settings["options"])
        reached = times <= sol.t_final
        if reached.any():
            out["samples"][reached] = sol.sample(times[reached])[:, :d]
        if sol.status == 0:
            out["final"] = sol.state_final[:d].copy()
        out.update(status=int(sol.status), message=str(sol.message))
    except Exception as exc:  # noqa: BLE001 - one bad value is recorded, not raised
        out.update(status=-2, message=f"{type(exc).__name__}: {exc}")
    return out


def _value_task(index: int, values: list, system, parameter: str, state0, settings: dict) -> dict:
    """A runner point: the value ``values[index]`` from ``state0``."""
    return _run_value(values[index], system, parameter, state0, settings)


def _pass_task(order: list, values: list, system, parameter: str, state0, settings: dict) -> dict:
    """A runner point: a continuation pass over ``order``, each value from the final state of the one before."""
    out = {}
    for i in order:
        result = _run_value(values[i], system, parameter, state0, settings)
        out[i] = result
        if np.all(np.isfinite(result["final"])):
            state0 = result["final"]
    return out


def system_bifurcation_diagram(system: HybridSystem, parameter: str, values, *, transient_periods: int = 200,
                               record_periods: int = 50, continuation: str = "none", state0=None, t0: float = 0.0,
                               backend: str = "heyoka", executor=None, progress: bool = True, **options):
    """Stroboscopic bifurcation diagram of a user system over one of its parameters.

    Parameters
    ----------
    system : HybridSystem
        With a forcing period (``period=...``).
    parameter : str
        One of the system's parameters.
    values : sequence of float
        Its values: finite and distinct.
    transient_periods, record_periods : int
        Forcing periods discarded, then recorded, at every value.
    continuation : {"none", "forward", "backward", "both"}
        ``"none"``: every value from ``state0``; otherwise passes in increasing (forward) or
        decreasing (backward) order, each value from the final state of the one before.
    state0 : sequence of float, optional
        Initial state (default zeros).
    t0 : float
        Start time (the section's phase).
    backend : {"heyoka", "scipy"}
        ``**options`` are :func:`impactosc.simulate`'s options for a user system.
    executor, progress
        As for :func:`impactosc.runner.run_points`.

    Returns
    -------
    xarray.Dataset
        Dimensions ``direction``, the parameter and ``period``; one variable per state (its
        section samples), ``<state>_final`` (the start of the next value in a pass),
        ``status`` (0 ok, 2 an accumulation, -1 the run failed, -2 an exception, -3 lost)
        and ``message``.

    Examples
    --------
    >>> import math
    >>> import heyoka as hy
    >>> from impactosc import Guard, HybridMode, HybridSystem, symbols
    >>> from impactosc.dynamics import bifurcation_diagram
    >>> x, v, A, w = symbols("x v A w")
    >>> stop = HybridSystem("x v", {"A": 1.2, "w": 0.8},
    ...                     [HybridMode("free", {x: v, v: A * hy.cos(w * hy.time) - x - 0.1 * v})],
    ...                     [Guard("impact", x - 0.6, 1, armed="free", to="free", reset={v: -0.7 * v})],
    ...                     period=2 * math.pi / w)
    >>> ds = bifurcation_diagram(stop, "A", [1.0, 1.2], transient_periods=50, record_periods=4,
    ...                          executor="serial", progress=False)
    >>> ds.x.shape
    (1, 2, 4)
    """
    if not isinstance(system, HybridSystem):
        raise TypeError(f"system must be an impactosc.HybridSystem, got {type(system).__name__}")
    if system.period is None:
        raise ValueError(f"{system.name}: a bifurcation diagram samples once per forcing period; the system has "
                         "no period (period=...)")
    if parameter not in system.parameter_names:
        raise ValueError(f"parameter must be one of {system.name}'s parameters {list(system.parameter_names)}, got "
                         f"{parameter!r}")
    vals = check_values(f"values of {parameter!r}", values)
    transient_periods = _v.integer("transient_periods", transient_periods, minimum=0)
    record_periods = _v.integer("record_periods", record_periods)
    _v.choice("continuation", continuation, tuple(_PASSES))
    d = system.dimension
    start = np.zeros(d) if state0 is None else np.asarray(state0, dtype=float).ravel()
    if start.size != d or not np.all(np.isfinite(start)):
        raise ValueError(f"state0 must be {d} finite numbers (one per state {system.states}), got {state0!r}")
    check_executor(executor)
    t0 = _v.real("t0", t0)
    settings = {"transient_periods": transient_periods, "record_periods": record_periods, "t0": t0,
                "backend": backend, "options": dict(options)}
    # the first value must run: a bad backend or option fails here, once
    simulate_system(system.with_parameters(**{parameter: float(vals[0])}), t0 + 1e-9, start, t0=t0, backend=backend,
                    **options)
    values_list = [float(q) for q in vals]
    labels = _PASSES[continuation]
    results: dict[str, dict] = {label: {} for label in labels}
    lost = {"status": -3, "samples": np.full((record_periods, d), math.nan), "final": np.full(d, math.nan)}
    desc = f"bifurcation {parameter}"
    if continuation == "none":
        run_points(_value_task, [(str(i), i) for i in range(vals.size)],
                   (values_list, system, parameter, start, settings), executor=executor,
                   on_result=lambda key, r: results["independent"].__setitem__(int(key), r),
                   on_lost=lambda key, msg: results["independent"].__setitem__(int(key), {**lost, "message": msg}),
                   progress=progress, desc=desc, unit="value", what="bifurcation_diagram", try_here_first=True)
    else:
        order = [int(i) for i in np.argsort(vals, kind="stable")]
        todo = [(label, order if label == "forward" else order[::-1]) for label in labels]
        run_points(_pass_task, todo, (values_list, system, parameter, start, settings), executor=executor,
                   on_result=lambda label, done: results[label].update(done),
                   on_lost=lambda label, msg: None, progress=progress, desc=desc, unit="pass",
                   what="bifurcation_diagram", batch=False, try_here_first=len(todo) == 1)
    return _dataset(system, parameter, vals, settings, labels, results, lost)


def _dataset(system: HybridSystem, parameter: str, vals: np.ndarray, settings: dict, labels, results: dict,
             lost: dict):
    import xarray as xr

    n_rec, d = settings["record_periods"], system.dimension
    samples = np.full((len(labels), vals.size, n_rec, d), math.nan)
    final = np.full((len(labels), vals.size, d), math.nan)
    status = np.full((len(labels), vals.size), -3, dtype=np.int32)
    message = np.full((len(labels), vals.size), "lost with its task", dtype=object)
    for k, label in enumerate(labels):
        for i, r in results[label].items():
            samples[k, i], final[k, i], status[k, i] = r["samples"], r["final"], r["status"]
            message[k, i] = r.get("message", "")
    dims = ("direction", parameter, "period")
    data: dict[str, Any] = {}
    for j, name in enumerate(system.states):
        data[name] = (dims, samples[..., j], {"long_name": f"{name} on the stroboscopic section"})
        data[f"{name}_final"] = (dims[:2], final[..., j], {"long_name": f"final {name}"})
    data["status"] = (dims[:2], status, {"long_name": "0 ok; 2 accumulation; -1 run failed; -2 exception; -3 lost"})
    data["message"] = (dims[:2], message.astype(str))
    first = settings["transient_periods"]
    return xr.Dataset(data, coords={"direction": list(labels), parameter: vals,
                                    "period": np.arange(first, first + n_rec)},
                      attrs={"parameter": parameter, "system": system.name, "transient_periods": first,
                             "record_periods": n_rec, "backend": settings["backend"], "t0": settings["t0"]})
