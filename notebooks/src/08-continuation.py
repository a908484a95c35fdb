# %% [markdown]
# # 08 · Continuation: following branches through impacts, with their bifurcations located
#
# A bifurcation diagram from transients shows the attractors that the transients happened
# to fall into. Impact oscillators almost always have several side by side, and the
# unstable orbits that separate them never show at all. **Continuation** follows one family
# of periodic orbits as a parameter changes, stable or not, and locates where it folds,
# doubles its period, touches a flange or starts to stick. `impactosc.dynamics.continuation`
# does it on the exact event-driven stroboscopic map: the Jacobian comes from saltation
# matrices and the parameter derivative is carried through the same pieces and events, so
# a located point is exact to the solver's tolerance, not to a mesh.
#
# 1. An impact oscillator against a rigid stop: the brute-force diagram with the continued
#    branches drawn over it, the period doubling and the grazings labelled and checked
#    against their closed forms.
# 2. The Den Hartog oscillator: why shooting from transients gave a wrong contact onset,
#    and the grazing boundary continued in two parameters.
# 3. The tape drive: the contact-onset boundary as a continued curve in SI units (critical
#    clearance against the pack diameter on the reel), next to the grid chart it replaces.

# %%
import math
import os
import textwrap
import time

import matplotlib.pyplot as plt
import numpy as np

import impactosc as io
from impactosc import dynamics as dy

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full-size versions.
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"
print("impactosc", io.__version__, "| quick mode" if QUICK else "| full mode")


def show(text, width=64):
    """Print a summary with its sentences wrapped to the width of the page's column (a table
    after its first blank line is printed as it is)."""
    prose, blank, table = text.partition("\n\n")
    for line in prose.splitlines():
        indent = " " * (len(line) - len(line.lstrip()) + 4)
        print(textwrap.fill(line, width, subsequent_indent=indent))
    if blank:
        print("\n" + table)

# %% [markdown]
# ## 1. A one-sided rigid stop: branches over the brute-force diagram
#
# The classic impact oscillator: `X'' + 2 zeta X' + X = F cos(0.8 t)` (`zeta = 0.05`, no
# friction) with a rigid stop at `X = 1` and Newton's impact `V -> -0.8 V` there, and no
# lower flange at all (`gap_lower=None`: a **one-sided stop**). Between impacts the motion
# is linear, so its single-impact orbits, their multipliers, period doubling and grazing
# have closed forms (`tests/impact_closed_form.py`), which the located points are checked
# against in the tests and below.
#
# We start on the period-1 orbit at `F = 1` (the section half a forcing period after
# `t = 0`, away from the impact) and follow it down in `F`.

# %%
W, ZETA, E = 0.8, 0.05, 0.8


def stop(F):
    """The stop at X = 1, and no lower flange."""
    return io.Oscillator(F, W, 0.0, zeta=ZETA, flange="rigid", restitution=E, gap_lower=None)


t0 = time.perf_counter()
orbit = dy.periodic_orbit(stop(1.0), phase=math.pi, backend="exact")
period1 = dy.continuation(orbit, "F", (0.3, 1.0))
show(period1.summary())
pd = period1.find("period_doubling")[0]
period2 = dy.continuation(pd, "F", (0.3, 1.0))  # branch switching onto the period-2 orbits
show(period2.summary())
print(f"both branches in {time.perf_counter() - t0:.2f} s")

# %% [markdown]
# The period-1 branch is stable down to the period doubling `PD1`, where a multiplier passes
# through -1 (its value there is printed below), and unstable below it until its impact speed
# falls to zero at a grazing (`GR`), where the map is not differentiable (its square-root
# singularity, see the theory page) and no single-impact orbit exists beyond: the branch
# crosses there onto the contact-free orbits and goes on to the limit (a persistent grazing). The
# period-2 branch that bifurcates at `PD1` is followed from there by branch switching. The
# closed forms of the single-impact orbits (Shaw and Holmes 1983, with damping) put the period
# doubling at `F = 0.5182098665978725` and the grazing at `F = 0.3687817782917154`.

# %% tags=["gallery"]
print("multipliers at PD1:", np.round(pd.multipliers, 10))
graze1 = period1.find("grazing")[0]
print(f"PD1 at F = {pd.parameter:.13f}, GR1 at F = {graze1.parameter:.13f}")
values = np.linspace(0.32, 0.68, 40 if QUICK else 200)
diagram = dy.bifurcation_diagram(stop(0.6), "F", values, transient_periods=150 if QUICK else 400,
                                 record_periods=16, phase=math.pi, backend="exact", executor="serial",
                                 progress=False)
fig, ax = plt.subplots(figsize=(8, 4.5))
dy.plot_bifurcation(diagram, ax=ax, markersize=1.5)
period1.plot(ax=ax, color="C0")
period2.plot(ax=ax, color="C3")
ax.set_xlim(values[0], values[-1])
ax.set_title("one-sided rigid stop: brute force (dots), period-1 (blue) and period-2 (red)\n"
             "branches; solid stable, dashed unstable")
fig.tight_layout()

# %% [markdown]
# ## 2. Den Hartog's oscillator: which orbit grazes?
#
# The forced Coulomb oscillator `X'' + X + 0.1 sgn(X') = F cos(1.5 t)` with spring flanges
# (`K = 24`) has a contact-free orbit whose amplitude is known in closed form (Den Hartog
# 1931); it reaches the flange at `F_c` (`dy.den_hartog_onset`). Following that orbit from
# `0.8 F_c` shows what shooting from transients could not: at `F_c` it grazes the flange,
# turns back at a fold just above, and returns as an *unstable* contacting orbit, the one
# Newton from a transient used to land on (reporting an onset at `0.98 F_c`).

# %% tags=["gallery-den-hartog"]
OMEGA, BETA = 1.5, 0.1
Fc = dy.den_hartog_onset(OMEGA, BETA)
free = dy.periodic_orbit(io.Oscillator(0.8 * Fc, OMEGA, BETA, 24.0), backend="exact",
                         guess=(-0.7891869048001374, 0.16283153617831878))
branch = dy.continuation(free, "F", (0.5 * Fc, 1.1 * Fc))
show(branch.summary())
graze = [s for s in branch.find("grazing") if s.context[2]["test"] == "upper_margin"][0]
print(f"located grazing F / F_c - 1 = {graze.parameter / Fc - 1:.1e}")
fig, ax = plt.subplots(figsize=(7, 4))
branch.plot(ax=ax, y="max_x")
# the closed form at a few amplitudes: circles on the branch (a line would hide under it)
F = np.linspace(0.55 * Fc, Fc, 8)
ax.plot(F, [dy.den_hartog_amplitude(f, OMEGA, BETA) for f in F], "s", ms=7, mfc="none", mec="C3", mew=1.2,
        label="Den Hartog amplitude (closed form)")
ax.axhline(1.0, color="0.6", lw=0.8)
ax.margins(x=0.1)  # room for the labels of the points at the fold
ax.legend(fontsize=8)
ax.set_title("Den Hartog orbit: grazing at F_c, fold, unstable contacting branch")
fig.tight_layout()

# %% [markdown]
# The grazing point continued in two parameters is the contact-onset boundary `F_c(Omega)`,
# and it is Den Hartog's closed form to the solver's tolerance:

# %%
curve = dy.continuation(graze, ("F", "Omega"), {"Omega": (1.2, 2.5)})
omega = curve.values("Omega")
err = np.max(np.abs(curve.values("F") / [dy.den_hartog_onset(w, BETA) for w in omega] - 1))
show(curve.summary().splitlines()[0])
print(f"max |F / F_c(Omega) - 1| over {len(curve)} points: {err:.1e}")

# %% [markdown]
# ## 3. The tape drive: the contact-onset boundary in SI units
#
# A design chart asks at which clearance the tape starts touching the flange. The lateral
# run-out of the reel grows from the hub to the full pack, so the answer depends on the pack
# diameter. The grid chart (`onset_chart`) answers point by point with one onset search
# each; continuation follows the boundary itself. We follow the drive's steady orbit from a
# wide guide (140 um) down in clearance until it grazes the flange, then that grazing point
# in (clearance, pack diameter).

# %%
drive = io.TapeDrive().replace(clearance=140e-6)
t0 = time.perf_counter()
steady = dy.periodic_orbit(drive, x0=0.0, transient_periods=3, backend="exact")
down = dy.continuation(steady, "clearance", (100e-6, 140e-6), base=drive, direction="backward",
                       locate=("grazing",), stop_at=("grazing",))
onset = down.find("grazing")[0]
show(down.summary())
print(f"contact onset at clearance {onset.parameter * 1e6:.6f} um; quasi-static closed form "
      f"{dy.quasi_static_critical_clearance(drive) * 1e6:.6f} um")
lo, hi = (0.06, 0.08) if QUICK else (0.05, 0.095)
# quick mode: a few points each way (each is a few exact maps of a period with ~370 stick-slip events)
boundary = dy.continuation(onset, ("clearance", "pack_diameter"), {"pack_diameter": (lo, hi)},
                           max_points=6 if QUICK else 500)
show(boundary.summary().splitlines()[0])
print(f"{len(boundary)} points in {time.perf_counter() - t0:.1f} s")

# %% tags=["gallery-boundary"]
covered = boundary.values("pack_diameter")
diameters = np.linspace(covered.min(), covered.max(), 3 if QUICK else 8)  # within the traced part
grid = [dy.quasi_static_critical_clearance(drive.replace(pack_diameter=d)) for d in diameters]
fig, ax = plt.subplots(figsize=(7, 4))
ax.plot(boundary.values("pack_diameter") * 1e3, boundary.values("clearance") * 1e6, "-",
        label="continued boundary (exact map)")
ax.plot(diameters * 1e3, np.array(grid) * 1e6, "o", mfc="none",
        label="quasi-static closed form at grid points")
ax.set_xlabel("pack diameter (mm)")
ax.set_ylabel("critical clearance (um)")
ax.set_title("where the tape starts touching the flange (below the curve: contact)")
ax.legend(fontsize=8)
fig.tight_layout()

# %% [markdown]
# Below the curve the tape touches the flange once per reel revolution; above it, it runs
# free. At these speeds the reel turns so slowly against the tape's lateral resonance that
# the boundary is the quasi-static one (run-out plus friction deflection), which the circles
# check. The paper's drive has a 1 mm clearance, far above this curve, which is why its
# contact force is exactly zero (`reports/paper_reproduction.md`).
