"""The computations of the figures: the run-out law, the paper's RK4 on a grid, the quasi-static reference, trends."""

from __future__ import annotations

import math
import time

import numpy as np
import xarray as xr

from ..model._tape import TapeDrive
from ._grids import FIGURE_STEPS_PER_PERIOD, FULL_N_DIAMETERS, grid_points, pack_diameters, resolve_drive


# ---------------------------------------------------------------------------------------
# Fig. 6: the run-out law
# ---------------------------------------------------------------------------------------
def fig6(drive: TapeDrive | None = None, *, n: int = FULL_N_DIAMETERS, path=None):
    """The run-out law of the paper's Fig. 6 as a table and a figure.

    Parameters
    ----------
    drive : TapeDrive, optional
        Whose law (hub/full diameters and run-outs); default the paper's drive.
    n : int
        Number of pack diameters, hub to full pack.
    path : str or path-like, optional
        Where to save the figure (PNG).

    Returns
    -------
    (pandas.DataFrame, matplotlib.figure.Figure)
        Columns ``pack_diameter_mm``, ``runout_um``, ``F_nondim`` (``runout/L``); the figure.
    """
    import pandas as pd

    from .._util.optional import require_matplotlib

    drive = TapeDrive() if drive is None else drive
    d = pack_diameters(drive, n)
    runout = np.array([drive.runout_at(x) for x in d])
    table = pd.DataFrame({"pack_diameter_mm": d * 1e3, "runout_um": runout * 1e6,
                          "F_nondim": runout / drive.clearance})
    plt = require_matplotlib()
    fig, ax = plt.subplots(figsize=(6, 4), constrained_layout=True)
    ax.plot(table.pack_diameter_mm, table.runout_um, "o-", color="k", label="linear law (TapeDrive)")
    ax.annotate("hub (assumed 44 mm)\n~60 um (paper)", (d[0] * 1e3, runout[0] * 1e6), textcoords="offset points",
                xytext=(16, -4), va="center", fontsize=8)
    ax.annotate("full pack (assumed 97 mm)\n~180 um (paper)", (d[-1] * 1e3, runout[-1] * 1e6),
                textcoords="offset points", xytext=(-150, -5), fontsize=8)
    ax.set_xlabel("supply pack diameter D [mm]")
    ax.set_ylabel("axial reel run-out [um]")
    ax.set_title("Fig. 6: reel run-out versus pack diameter (straight-line reading)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=120)
    return table, fig


# ---------------------------------------------------------------------------------------
# The paper's RK4 baseline on a grid
# ---------------------------------------------------------------------------------------
def figure_dt() -> float:
    """RK4 step of the figures: ``2 pi / 100``, 100 steps per free period (nondimensional).

    It resolves the free oscillation (and, a fortiori, the forcing, ``Omega ~ 1e-4``) but
    not a flange contact (period ``2 pi / sqrt(1 + K)``, 100 times shorter at ``K = 1e4``):
    it is valid only because no contact occurs with the paper's parameters. A contact would
    be unstable at this step (``omega dt = 6.3 > 2.8``, the RK4 stability limit) and show up
    as ``status = -1`` (non-finite state), which :func:`rk4_grid` reports.
    """
    return 2.0 * math.pi / FIGURE_STEPS_PER_PERIOD


def _require_eq3(drives) -> None:
    """The paper's RK4 grids run eq. 3 only: refuse a drive with a family member's fields."""
    for d in drives:
        extra = d.oscillator().unsupported()
        if extra:
            raise ValueError("the paper's RK4 grid runs eq. 3 only, but the drive has "
                             f"{', '.join(extra)}; use impactosc.sweep (heyoka or scipy) for the model family")


def rk4_grid(base: TapeDrive, grid: dict, *, duration: float = 1.0, dt="figure", flange: str = "consistent",
             x0: float = 0.95, v0: float = 0.0) -> xr.Dataset:
    """Run the paper's fixed-step RK4 (naive ``sign()``) on every point of a grid, as a Dataset in SI units.

    The points are resolved as :func:`impactosc.sweep` resolves them and run together by
    :func:`impactosc.backends.rk4.rk4_batch` (numba, parallel over the points).

    Parameters
    ----------
    base : TapeDrive
        Fields kept where the grid does not set them.
    grid : dict
        ``{field: values}`` (numeric fields and ``t_sin_half_theta``).
    duration : float
        Simulated time per point (s).
    dt : "figure", "default" or float
        Fixed step (nondimensional): ``"figure"`` is :func:`figure_dt`, ``"default"`` the
        backend's contact-resolving default ``2 pi / (100 sqrt(1 + K))``.
    flange : {"consistent", "paper"}
        The two-sided flange spring, or eq. 2 as printed.

    Returns
    -------
    xarray.Dataset
        ``mean_flange_force``, ``mean_flange_force_upper``, ``mean_flange_force_lower`` (N),
        ``impacts``, ``impacts_upper``, ``impacts_lower`` (contacts reconstructed from sign
        changes), ``status`` (0 ok, -1 non-finite state); ``attrs``: ``dt``, ``steps``
        (total), ``wall_time_s``, ``flange``, ``duration``.
    """
    from ..backends.rk4 import default_dt, rk4_batch

    names = list(grid)
    shape = tuple(len(grid[k]) for k in names)
    drives = np.empty(shape, dtype=object)
    for idx, point in grid_points(grid):
        drives[idx] = resolve_drive(base, point)
    flat = drives.ravel()
    _require_eq3(flat)
    F = np.array([d.F for d in flat])
    Om = np.array([d.Omega for d in flat])
    beta = np.array([d.beta for d in flat])
    K = np.array([d.K for d in flat])
    t_end = np.array([d.seconds_to_lambda(duration) for d in flat])
    scale = np.array([d.force_scale for d in flat])
    if isinstance(dt, str):
        if dt not in ("figure", "default"):
            raise ValueError(f"dt must be 'figure', 'default' or a number, got {dt!r}")
        steps = np.array([figure_dt() if dt == "figure" else default_dt(k) for k in K])
    else:
        steps = np.full(F.shape, float(dt))
    t = time.perf_counter()
    r = rk4_batch(F, Om, beta, K, 0.0, t_end, x0, v0, dt=steps, flange=flange)
    wall = time.perf_counter() - t

    def arr(a):
        return np.asarray(a, dtype=float).reshape(shape)

    up, lo = arr(r.mean_force_upper * scale), arr(r.mean_force_lower * scale)
    nu, nl = arr(r.contacts_upper), arr(r.contacts_lower)
    dims = names
    data = {
        "mean_flange_force": (dims, up + lo, {"units": "N", "long_name": "mean flange force, both flanges"}),
        "mean_flange_force_upper": (dims, up, {"units": "N", "long_name": "mean flange force, upper flange"}),
        "mean_flange_force_lower": (dims, lo, {"units": "N", "long_name": "mean flange force, lower flange"}),
        "impacts": (dims, nu + nl, {"units": "1", "long_name": "flange contacts, both flanges"}),
        "impacts_upper": (dims, nu, {"units": "1", "long_name": "flange contacts, upper flange"}),
        "impacts_lower": (dims, nl, {"units": "1", "long_name": "flange contacts, lower flange"}),
        "status": (dims, np.asarray(r.status, dtype=np.int32).reshape(shape),
                   {"long_name": "0 ok, -1 non-finite state"}),
    }
    coords = {k: (k, np.asarray(grid[k], dtype=float)) for k in names}
    n_steps = float(np.sum(np.ceil(t_end / steps)))
    return xr.Dataset(data, coords=coords, attrs={"dt": float(steps.flat[0]), "steps": n_steps, "wall_time_s": wall,
                                                  "flange": flange, "duration": duration, "backend": "rk4"})


def rk4_default_step_cost(base: TapeDrive, points: list[dict], duration: float = 1.0) -> dict:
    """Run a few points at the RK4 default step and measure the cost (for extrapolation).

    The points run in one :func:`impactosc.backends.rk4.rk4_batch` call, i.e. in parallel over the cores.

    Returns
    -------
    dict
        ``wall_time_s``, ``steps`` (total), ``steps_per_s``, ``n_points``, ``duration``,
        ``dt``, ``mean_flange_force`` (N, per point), ``impacts`` (per point).
    """
    from ..backends.rk4 import default_dt, rk4_batch

    drives = [resolve_drive(base, p) for p in points]
    _require_eq3(drives)
    t_end = np.array([d.seconds_to_lambda(duration) for d in drives])
    steps = np.array([default_dt(d.K) for d in drives])
    t = time.perf_counter()
    r = rk4_batch([d.F for d in drives], [d.Omega for d in drives], [d.beta for d in drives],
                  [d.K for d in drives], 0.0, t_end, 0.95, 0.0, dt=steps)
    wall = time.perf_counter() - t
    force = (r.mean_force_upper + r.mean_force_lower) * np.array([d.force_scale for d in drives])
    impacts = r.contacts_upper + r.contacts_lower
    n_steps = float(np.sum(np.ceil(t_end / steps)))
    dt = float(steps[0])
    return {"wall_time_s": wall, "steps": n_steps, "steps_per_s": n_steps / wall, "n_points": len(drives),
            "duration": duration, "dt": dt, "mean_flange_force": [float(x) for x in force],
            "impacts": [int(x) for x in impacts]}


# ---------------------------------------------------------------------------------------
# Quasi-static reference and trends
# ---------------------------------------------------------------------------------------
def quasi_static_mean_force(drive: TapeDrive, duration: float | None = None) -> float:
    """Mean flange force (N, both flanges) of the quasi-static, rigid-flange limit ``Omega -> 0``, ``K -> oo``.

    The tape edge follows the reel, ``k x = F_a cos(phi) -+ mu N``: it presses on a flange
    with ``k (runout cos(phi) - c)`` where ``c = L + mu N / k`` (friction delays the
    contact by the slip it needs, and a stick at the turning point holds the force, to
    first order in ``mu N / (k runout)``). Averaged over a reel turn, both flanges:
    ``(2 k / pi) (sqrt(A^2 - c^2) - c arccos(c / A))`` for ``A = runout > c``, else 0.
    It does not depend on the speed. With ``duration`` (s), the same quasi-static force
    ``k (runout |cos(omega_r t)| - c)+`` is averaged over ``[0, duration]`` instead of a
    whole reel turn (forcing phase 0), for a like-for-like comparison with a finite run.
    """
    a = drive.runout
    c = drive.clearance + drive.friction_force / drive.stiffness
    if a <= c:
        return 0.0
    if duration is not None:
        t = np.linspace(0.0, float(duration), 200_001)
        f = drive.stiffness * np.maximum(a * np.abs(np.cos(drive.omega_r * t)) - c, 0.0)
        return float(np.mean(0.5 * (f[1:] + f[:-1])))
    return 2.0 * drive.stiffness / math.pi * (math.sqrt(a * a - c * c) - c * math.acos(c / a))


def trends(ds: xr.Dataset, var: str = "mean_flange_force") -> dict:
    """Evaluate the paper's qualitative claims on a Fig. 8 grid (pack_diameter x speed x t_sin_half_theta).

    Returns
    -------
    dict
        ``nonzero`` (any point > 0), ``max_force`` (N), ``mid_pack_max`` (fraction of the
        nonzero curves whose maximum lies in the middle third of the pack, strictly inside),
        ``by_speed`` (mean over diameters and ``T sin`` per speed), ``up_with_speed`` (the
        means increase with speed), ``by_t_sin`` (mean per ``T sin(theta/2)``),
        ``down_with_t_sin`` (they decrease), ``ratio_01_07`` (mean at 0.1 over mean at
        0.7; the paper: "almost double"), ``ratio_01_07_by_speed``.
    """
    f = ds[var].transpose("pack_diameter", "speed", "t_sin_half_theta")
    d = f.pack_diameter.values
    lo, hi = d[0] + (d[-1] - d[0]) / 3.0, d[0] + 2.0 * (d[-1] - d[0]) / 3.0
    n_curves = n_mid = 0
    for s in f.speed.values:
        for ts in f.t_sin_half_theta.values:
            y = f.sel(speed=s, t_sin_half_theta=ts).values
            if np.all(np.isfinite(y)) and np.nanmax(y) > 0:
                n_curves += 1
                i = int(np.argmax(y))
                if 0 < i < len(y) - 1 and lo <= d[i] <= hi:
                    n_mid += 1
    by_speed = f.mean(("pack_diameter", "t_sin_half_theta")).values
    by_ts = f.mean(("pack_diameter", "speed")).values
    ts = f.t_sin_half_theta.values

    def ratio(a, b):
        return float(a / b) if b > 0 else (math.inf if a > 0 else math.nan)

    by_speed_ts = f.mean("pack_diameter")
    i01, i07 = int(np.argmin(ts)), int(np.argmax(ts))
    return {
        "nonzero": bool(np.nanmax(f.values) > 0),
        "max_force": float(np.nanmax(f.values)),
        "n_curves": n_curves,
        "mid_pack_max": (n_mid / n_curves) if n_curves else 0.0,
        "speeds": [float(x) for x in f.speed.values],
        "by_speed": [float(x) for x in by_speed],
        "up_with_speed": bool(by_speed.size > 1 and np.all(np.diff(by_speed) > 0)),
        "t_sin": [float(x) for x in ts],
        "by_t_sin": [float(x) for x in by_ts],
        "down_with_t_sin": bool(by_ts.size > 1 and np.all(np.diff(by_ts) < 0)),
        "ratio_01_07": ratio(by_ts[i01], by_ts[i07]),
        "ratio_01_07_by_speed": [ratio(float(by_speed_ts.values[k, i01]), float(by_speed_ts.values[k, i07]))
                                 for k in range(by_speed_ts.shape[0])],
    }
