"""Design charts: the critical value of one parameter over a 2-D grid of two others.

For a :class:`~impactosc.TapeDrive` this is the chart a tape engineer wants: the critical
flange clearance (or run-out) at which contact starts, against tape speed and tension, in
SI units. Every grid point is one :func:`~impactosc.dynamics.contact_onset`, a point of
:func:`impactosc.runner.run_points` (the reusable local pool by default, a small chart in
this process; any :class:`concurrent.futures.Executor` or a ``dask.distributed.Client``).
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from .._util import validation as _v
from ..backends._simulate import simulate
from ..runner import check_executor, run_points
from ._common import (
    check_base,
    check_study_parameter,
    check_values,
    on_a_terminal,
    oscillator_of,
    parameter_attrs,
    parameter_value,
    with_parameter,
)
from .onset import CONTINUATION_SETTINGS, METHODS, TRANSIENT_ONLY, _default_backend, contact_onset

__all__ = ["onset_chart", "plot_onset_chart"]


def _chart_point(point: dict, base, parameter, bracket, kwargs: dict) -> tuple:
    """One chart point (module level: pickles for process pools and dask). Never raises."""
    try:
        res = contact_onset(_replace(base, point), parameter, bracket, **kwargs)
    except Exception as exc:  # noqa: BLE001 - a bad point is recorded, not raised
        return math.nan, -2, f"{type(exc).__name__}: {exc}", 0, math.nan
    return res.value, res.status, res.message, res.direction, (math.nan if res.stable is None else float(res.stable))


def _replace(base, point: dict):
    for k, v in point.items():
        base = with_parameter(base, k, v)
    return base


def onset_chart(base, parameter: str, bracket, grid: dict, *, executor=None, progress: bool | None = None,
                **kwargs):
    """The critical value of ``parameter`` over a 2-D grid of two other parameters: a design chart.

    Parameters
    ----------
    base : Oscillator or TapeDrive
    parameter : str
        The parameter whose critical value is charted (e.g. ``"clearance"`` of a drive).
    bracket : (float, float)
        Search interval of ``parameter`` at every grid point.
    grid : dict
        Two other parameters -> 1-D sequences of values (finite: NaN is refused).
    executor : None, "serial", "dask", concurrent.futures.Executor or dask.distributed.Client
        Where the points run (:func:`impactosc.runner.run_points`). None: the reusable
        local process pool (no ``__main__`` guard needed), or this process for a small chart.
    progress : bool, optional
        A tqdm progress bar over the grid points. Default: shown when standard error is a
        terminal (not in a notebook, a pipe or a log file).
    **kwargs
        Passed to :func:`contact_onset`: ``method`` (default ``"continuation"``: every point
        follows the orbit at the ``start`` end of the bracket, from its ``guess`` or a
        transient), ``tol``, ``transient_periods``, ... The keywords of the transient search
        (``scan``, ``follow``, ``record_periods``, ``stop_at_contact``,
        ``max_evaluations``) need ``method="transient"`` and are refused otherwise.

    Returns
    -------
    xarray.Dataset
        ``critical`` (the two grid dimensions; units of ``parameter``), ``direction``,
        ``status``, ``message`` and ``stable`` (continuation: the followed orbit just before
        the onset, 1/0, NaN when unknown) per point; the attribute ``method`` says how
        the critical values were found.

    Raises
    ------
    TypeError, ValueError
        Before anything runs: a bad grid (not two parameters, NaN, a value the model refuses
        at either end of the bracket), an unknown option (neither of :func:`contact_onset`
        nor of the backend), an executor that is not one of those above.
    RuntimeError
        Every point was lost with its task (the workers crashed or could not start).
    """
    import xarray as xr

    (k1, a1), (k2, a2) = _check(base, parameter, bracket, grid, executor, kwargs).items()
    points = [((i, j), {k1: float(a1[i]), k2: float(a2[j])}) for i in range(a1.size) for j in range(a2.size)]
    crit = np.full((a1.size, a2.size), math.nan)
    direc = np.zeros((a1.size, a2.size), dtype=np.int8)
    status = np.full((a1.size, a2.size), -4, dtype=np.int32)
    message = np.full((a1.size, a2.size), "not computed", dtype=object)
    stable = np.full((a1.size, a2.size), math.nan)

    def on_result(ij, result):
        crit[ij], status[ij], message[ij], direc[ij], stable[ij] = result

    show = on_a_terminal() if progress is None else bool(progress)
    run_points(_chart_point, points, (base, parameter, bracket, kwargs), executor=executor, on_result=on_result,
               on_lost=lambda ij, msg: on_result(ij, (math.nan, -3, msg, 0, math.nan)), progress=show,
               desc=f"onset of {parameter}", unit="point", what="onset_chart", try_here_first=True)
    attrs = parameter_attrs(base, parameter)
    return xr.Dataset(
        {"critical": ((k1, k2), crit, {**attrs, "long_name": f"critical {attrs['long_name']} (contact onset)"}),
         "direction": ((k1, k2), direc, {"long_name": f"+1: contact above the critical {parameter}; -1: below"}),
         "status": ((k1, k2), status, {"long_name": "0 found; 1 no onset in the bracket; 2 no onset of the "
                                                    "followed orbit (its branch folds before it touches; a "
                                                    "transient search's sign change that is no grazing); -1 run "
                                                    "failed; -2 exception; -3 task lost"}),
         "message": ((k1, k2), message.astype(str)),
         "stable": ((k1, k2), stable, {"long_name": "1: the followed orbit is stable just before the onset; 0: "
                                                    "not; NaN: unknown (method='transient')"})},
        coords={k1: (k1, a1, parameter_attrs(base, k1)), k2: (k2, a2, parameter_attrs(base, k2))},
        attrs={"parameter": parameter, "method": kwargs.get("method", "continuation"),
               "bracket": list(map(float, bracket)), "base": repr(base),
               "base_value": parameter_value(base, parameter)})


def _check(base, parameter, bracket, grid, executor, kwargs) -> dict:
    """The two grid axes; raises for anything that would fail at every point, before the run."""
    check_base(base)
    check_study_parameter(base, parameter)
    check_executor(executor)
    if not isinstance(grid, dict) or len(grid) != 2:
        raise ValueError(f"grid must be a dict of exactly two parameters -> values, got {grid!r}")
    axes = {}
    for key, values in grid.items():
        check_study_parameter(base, key)
        if key == parameter:
            raise ValueError(f"grid may not contain the charted parameter {parameter!r}")
        axes[key] = check_values(f"grid[{key!r}]", values)
        check_study_parameter(base, key, (float(np.min(axes[key])), float(np.max(axes[key]))))
    try:
        lo, hi = (_v.real(f"bracket[{i}]", b) for i, b in enumerate(bracket))
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"bracket must be a pair (lo, hi) of real numbers: {exc}") from None
    (k1, a1), (k2, a2) = axes.items()
    # Every grid point must make a valid model at both ends of the bracket.
    for x1 in a1:
        for x2 in a2:
            point = _replace(base, {k1: float(x1), k2: float(x2)})
            for end in (lo, hi):
                oscillator_of(with_parameter(point, parameter, end))
    # Options: contact_onset's own, the rest go to the backend, which must take them.
    signature = inspect.signature(contact_onset)
    named = {k: v for k, v in kwargs.items() if k in signature.parameters}
    options = {k: v for k, v in kwargs.items() if k not in signature.parameters and k not in CONTINUATION_SETTINGS}
    method = named.get("method", "continuation")
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(map(repr, METHODS))}, got {method!r}")
    if method != "transient":
        for name in TRANSIENT_ONLY:
            if name in named:
                raise ValueError(f"{name}={named[name]!r} applies to method='transient' only (the search on "
                                 f"transients); use method='transient' with it, or leave it out")
    else:
        for name in ("guess", "start"):
            if name in named:
                raise ValueError(f"{name}={named[name]!r} applies to method='continuation' only")
    if "start" in named and named["start"] not in ("lo", "hi"):
        raise ValueError(f"start must be 'lo' or 'hi', got {named['start']!r}")
    backend = named.get("backend") or ("heyoka" if method == "transient" else None)
    first = _replace(base, {k1: float(a1[0]), k2: float(a2[0])})
    first_osc = oscillator_of(with_parameter(first, parameter, lo))
    if backend is None:
        backend = _default_backend(first_osc, None, options)
    simulate(first_osc, 1e-9, _v.real("x0", named.get("x0", 0.95)), _v.real("v0", named.get("v0", 0.0)),
             backend=backend, record="stats", **options)
    return axes


def plot_onset_chart(ds, *, ax=None, scale: float = 1.0, units: str | None = None, levels: int = 12, cmap="viridis"):
    """Filled contours of the critical value over the grid, with labelled contour lines.

    ``scale`` multiplies the values (e.g. ``1e6`` with ``units="um"`` for a clearance in m).
    """
    from .._util.optional import require_matplotlib

    plt = require_matplotlib()

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4.5))
    k1, k2 = ds["critical"].dims
    z = ds["critical"].values * scale
    x, y = ds[k2].values, ds[k1].values
    u = units if units is not None else ds["critical"].attrs.get("units", "")
    if np.isfinite(z).sum() >= 4 and np.nanmax(z) > np.nanmin(z) and min(z.shape) > 1:
        cs = ax.contourf(x, y, z, levels=levels, cmap=cmap)
        lines = ax.contour(x, y, z, levels=cs.levels[::2], colors="k", linewidths=0.6)
        ax.clabel(lines, fontsize=7, fmt="%.5g", inline=True)
    else:
        cs = ax.pcolormesh(x, y, z, cmap=cmap, shading="nearest")
    plt.colorbar(cs, ax=ax, label=f"critical {ds.attrs['parameter']} [{u}]")
    for key, setter in ((k2, ax.set_xlabel), (k1, ax.set_ylabel)):
        a = ds[key].attrs
        setter(f"{a.get('long_name', key)} [{a.get('units', '')}]")
    bad = ds["status"].values != 0
    if bad.any():
        yy, xx = np.meshgrid(y, x, indexing="ij")
        ax.plot(xx[bad], yy[bad], "rx", ms=5, label="no onset found")
        ax.legend(fontsize=8)
    return ax
