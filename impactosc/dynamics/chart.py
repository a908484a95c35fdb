"""Design charts: the critical value of one parameter over a 2-D grid of two others.

For a :class:`~impactosc.TapeDrive` this is the chart a tape engineer wants: the critical
flange clearance (or run-out) at which contact starts, against tape speed and tension, in
SI units. Every grid point is one :func:`~impactosc.dynamics.contact_onset`, run in
parallel (a module-level function with plain arguments, for process pools).
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import multiprocessing
import os

import numpy as np

from ._common import (
    check_base,
    check_parameter,
    check_values,
    oscillator_of,
    parameter_attrs,
    parameter_value,
    with_parameter,
)
from .onset import contact_onset

__all__ = ["onset_chart", "plot_onset_chart"]


def _chart_point(base, parameter, bracket, point: dict, kwargs: dict) -> tuple:
    """One chart point (module level: pickles for process pools). Never raises."""
    try:
        res = contact_onset(_replace(base, point), parameter, bracket, **kwargs)
    except Exception as exc:  # noqa: BLE001 - a bad point is recorded, not raised
        return math.nan, -2, f"{type(exc).__name__}: {exc}", 0
    return res.value, res.status, res.message, res.direction


def _replace(base, point: dict):
    for k, v in point.items():
        base = with_parameter(base, k, v)
    return base


def onset_chart(base, parameter: str, bracket, grid: dict, *, executor=None, progress: bool = True, **kwargs):
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
    executor : concurrent.futures.Executor, "serial" or None
        None: a local process pool (spawn).
    progress : bool
        tqdm progress bar.
    **kwargs
        Passed to :func:`contact_onset` (``tol``, ``scan``, ``transient_periods``, ...).

    Returns
    -------
    xarray.Dataset
        ``critical`` (the two grid dimensions; units of ``parameter``), ``direction``,
        ``status`` and ``message`` per point.
    """
    import xarray as xr
    from tqdm.auto import tqdm

    check_base(base)
    check_parameter(base, parameter)
    if not isinstance(grid, dict) or len(grid) != 2:
        raise ValueError(f"grid must be a dict of exactly two parameters -> values, got {grid!r}")
    axes = {}
    for key, values in grid.items():
        check_parameter(base, key)
        if key == parameter:
            raise ValueError(f"grid may not contain the charted parameter {parameter!r}")
        axes[key] = check_values(f"grid[{key!r}]", values)
    (k1, a1), (k2, a2) = axes.items()
    # Validate the first point (bad options fail here, once, not at every point).
    first = _replace(base, {k1: float(a1[0]), k2: float(a2[0])})
    oscillator_of(with_parameter(first, parameter, float(bracket[0])))
    points = [(i, j, {k1: float(a1[i]), k2: float(a2[j])}) for i in range(a1.size) for j in range(a2.size)]
    crit = np.full((a1.size, a2.size), math.nan)
    direc = np.zeros((a1.size, a2.size), dtype=np.int8)
    status = np.full((a1.size, a2.size), -4, dtype=np.int32)
    message = np.full((a1.size, a2.size), "not computed", dtype=object)
    bar = tqdm(total=len(points), disable=not progress, desc=f"onset of {parameter}", unit="point")
    owned = executor is None
    if executor == "serial":
        results = ((i, j, _chart_point(base, parameter, bracket, p, kwargs)) for i, j, p in points)
    else:
        if owned:
            executor = cf.ProcessPoolExecutor(max_workers=max(1, min(os.cpu_count() or 1, len(points))),
                                              mp_context=multiprocessing.get_context("spawn"))
        futs = {executor.submit(_chart_point, base, parameter, bracket, p, kwargs): (i, j) for i, j, p in points}

        def gather():
            for fut in cf.as_completed(futs):
                i, j = futs[fut]
                try:
                    yield i, j, fut.result()
                except Exception as exc:  # noqa: BLE001 - a lost task costs its point only
                    yield i, j, (math.nan, -3, f"task lost ({type(exc).__name__}: {exc})", 0)

        results = gather()
    try:
        for i, j, (value, st, msg, d) in results:
            crit[i, j], status[i, j], message[i, j], direc[i, j] = value, st, msg, d
            bar.update(1)
    finally:
        bar.close()
        if owned and executor != "serial":
            executor.shutdown(wait=True, cancel_futures=True)
    attrs = parameter_attrs(base, parameter)
    return xr.Dataset(
        {"critical": ((k1, k2), crit, {**attrs, "long_name": f"critical {attrs['long_name']} (contact onset)"}),
         "direction": ((k1, k2), direc, {"long_name": f"+1: contact above the critical {parameter}; -1: below"}),
         "status": ((k1, k2), status, {"long_name": "0 found; 1 no onset in the bracket; -1 run failed; "
                                                    "-2 exception; -3 task lost"}),
         "message": ((k1, k2), message.astype(str))},
        coords={k1: (k1, a1, parameter_attrs(base, k1)), k2: (k2, a2, parameter_attrs(base, k2))},
        attrs={"parameter": parameter, "bracket": list(map(float, bracket)), "base": repr(base),
               "base_value": parameter_value(base, parameter)})


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
