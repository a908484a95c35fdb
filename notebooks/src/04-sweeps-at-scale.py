# %% [markdown]
# # 04 · Sweeps at scale
#
# The paper's Fig. 7 and 8 are grids: average flange force over pack diameter, for several
# speeds, tensions and wrap angles, each point one second of tape motion. `impactosc.sweep`
# runs the outer product of a grid of `TapeDrive` fields in parallel and returns an
# [xarray](https://docs.xarray.dev) `Dataset` in SI units, one dimension per swept field.
#
# This notebook covers:
#
# 1. a sweep with a progress bar, stored point by point on disk;
# 2. rerunning it: finished points are loaded, not recomputed (and an extended grid runs
#    only its new points);
# 3. the same sweep on a local dask cluster;
# 4. reading a store back with `load_sweep`, and plotting slices.
#
# The physics here is incidental (notebook 03 is about the results). To have flange
# contacts at all we use a 100 um flange clearance instead of the paper's 1 mm (see
# notebook 03 for why), and short runs: in quick mode 10 ms per point, which is a small
# part of one reel turn, so the averages depend on where in the turn the run starts.

# %%
import os

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full-size versions.
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"

import tempfile
import time
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

import impactosc as io

# Without ipywidgets, tqdm's notebook bar falls back to text and says so; text is fine here
# (pip install ipywidgets for the widget bar).
warnings.filterwarnings("ignore", message="IProgress not found")

print("impactosc", io.__version__, "| quick mode" if QUICK else "| full mode")

# %% [markdown]
# ## 1. A stored sweep with a progress bar
#
# `sweep(base, grid, duration=...)` runs `base.replace(**point)` for every point of the
# grid, for `duration` seconds each, with `simulate(..., record="stats")`. By default the
# points run on a local pool of one process per CPU (each compiles the heyoka integrator
# once and reuses it, also in the next sweep). With `store=` every finished point is saved
# as a small netCDF file next to a `manifest.json` of the settings, as soon as it arrives:
# interrupting the kernel stops the sweep at once and keeps what is done.
#
# The same call works in a notebook, a script (no `if __name__ == "__main__":` guard
# needed), a REPL or a program fed on standard input: the workers never re-import the
# caller's code.

# %%
base = io.TapeDrive(clearance=100e-6)          # paper's drive, 100 um flange clearance
diameters = np.linspace(base.hub_diameter, base.full_pack_diameter, 4 if QUICK else 8)   # m
grid = {"pack_diameter": diameters, "speed": [4.0, 12.0]}                                # m/s
duration = 0.01 if QUICK else 0.1                                                       # s per point

workdir = Path(tempfile.mkdtemp(prefix="impactosc-sweeps-"))
store = workdir / "pack-speed"
print("store:", store)

t0 = time.perf_counter()
ds = io.sweep(base, grid, duration=duration, store=store)
first_run = time.perf_counter() - t0
print(f"first run: {first_run:.1f} s for {ds['status'].size} points")

# %% [markdown]
# The result is a `Dataset` with one dimension per grid key. Every variable carries its
# `units` and `long_name`; `status` is 0 for a point that reached its end time (failed
# points are kept with NaN results, their status and message, instead of stopping the
# sweep).

# %%
ds

# %%
print(ds["mean_flange_force"].attrs)
print("status of every point:", np.unique(ds["status"].values))
print("store holds", len(list((store / "points").glob("*.nc"))), "point files")

# %% [markdown]
# ## 2. Rerunning resumes instead of recomputing
#
# The same call again finds every point in the store and loads it: no simulation runs. An
# interrupted sweep (a killed kernel, a closed laptop) resumes the same way, and an
# extended grid runs only its new points. A store made with other settings (another base
# drive, duration, backend or option) is refused with a message listing the differences.

# %%
t0 = time.perf_counter()
ds_again = io.sweep(base, grid, duration=duration, store=store)
second_run = time.perf_counter() - t0
print(f"first run {first_run:.2f} s, rerun {second_run:.2f} s (all points loaded from the store)")
xr.testing.assert_identical(ds.drop_vars("message"), ds_again.drop_vars("message"))
print("identical results")

# %%
grid_ext = {"pack_diameter": diameters, "speed": [4.0, 8.0, 12.0]}      # one more speed
t0 = time.perf_counter()
ds_ext = io.sweep(base, grid_ext, duration=duration, store=store)
print(f"extended grid: {ds_ext['status'].size} points, {len(diameters)} of them new, "
      f"{time.perf_counter() - t0:.1f} s")

try:
    io.sweep(base.replace(tension=2.0), grid, duration=duration, store=store, progress=False)
except ValueError as exc:
    print("ValueError:", str(exc)[:300])

# %% [markdown]
# ## 3. The same sweep on a dask cluster
#
# `executor=` takes `"serial"`, any `concurrent.futures.Executor`, `"dask"` (the current
# `dask.distributed` client, or a new local cluster), or a `dask.distributed.Client`. On a
# real cluster the client would connect to a scheduler address instead of a
# `LocalCluster`; the call to `sweep` is the same. Here: two single-threaded worker
# processes on this machine, results in a second store.

# %%
from dask.distributed import Client, LocalCluster

with warnings.catch_warnings():
    warnings.simplefilter("ignore")       # dask's notes about ports and memory limits
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None)
    client = Client(cluster)
try:
    print(client)
    t0 = time.perf_counter()
    ds_dask = io.sweep(base, grid, duration=duration, executor=client, store=workdir / "pack-speed-dask")
    print(f"dask run: {time.perf_counter() - t0:.1f} s")
finally:
    client.close()
    cluster.close()

diff = float(np.nanmax(np.abs(ds_dask["mean_flange_force"] - ds["mean_flange_force"])))
print(f"largest difference to the process-pool sweep: {diff:.3g} N")

# %% [markdown]
# ## 4. Reading a store back, and plotting slices
#
# `load_sweep(store)` reads the latest grid of a store back without simulating anything
# (points not yet computed would have status -4 and NaN results, with a warning). Here it
# returns the extended 3-speed grid.

# %%
loaded = io.load_sweep(store)
print(dict(loaded.sizes))
print("settings:", {k: loaded.attrs[k] for k in ("duration", "backend", "x0", "v0")})
print("base clearance:", loaded.attrs["base_clearance"], "m")

# %% [markdown]
# xarray labels its plots from the `long_name` and `units` attributes. Pack diameter in
# millimetres reads better than in metres, so we add a coordinate for it.

# %%
loaded = loaded.assign_coords(D_mm=("pack_diameter", loaded["pack_diameter"].values * 1e3))
loaded["D_mm"].attrs.update(long_name="supply pack diameter D", units="mm")

fig, axes = plt.subplots(1, 3, figsize=(8.5, 3.4), constrained_layout=True)
loaded["mean_flange_force"].plot.line(x="D_mm", hue="speed", marker="o", ax=axes[0])
loaded["impact_rate"].plot.line(x="D_mm", hue="speed", marker="o", ax=axes[1], add_legend=False)
loaded["F"].sel(speed=4.0).plot.line(x="D_mm", marker="o", ax=axes[2], label="F = run-out / L")
axes[2].axhline(1.0, color="tab:red", ls="--", label="flange reach F = 1")
axes[2].legend()
axes[0].set_title("mean flange force")
axes[1].set_title("flange contacts per second")
axes[2].set_title("nondimensional forcing amplitude")
fig.suptitle(f"clearance {base.clearance * 1e6:g} um, {duration * 1e3:g} ms per point")
plt.show()

# %% [markdown]
# Selections work by label, and any variable can be turned into a table:

# %%
print(loaded["mean_flange_force"].sel(speed=8.0).to_series().rename("mean flange force [N]"))

# %%
fig, ax = plt.subplots(figsize=(6, 4))
loaded["max_penetration"].plot(x="D_mm", y="speed", ax=ax, cmap="viridis")
ax.set_title("deepest penetration into a flange")
plt.show()
table = loaded[["mean_flange_force", "impacts", "sticks", "max_penetration"]].drop_vars("D_mm").to_dataframe()
print(table.round(4))

# %%
import shutil

shutil.rmtree(workdir, ignore_errors=True)   # the stores were only for this demonstration
print("removed", workdir)
