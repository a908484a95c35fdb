# %% [markdown]
# # 06 · Dynamics: sections, periodic orbits, bifurcations, contact onset
#
# A single trajectory says what one tape does from one start. The questions an impact
# oscillator is studied for are about its **dynamics**: which steady states exist, whether
# they are stable, where the motion starts touching a flange, where it becomes period-n or
# irregular as a parameter changes (the literature the paper cites, Shaw & Holmes 1983,
# asks exactly that). `impactosc.dynamics` answers them on the exact event-driven engine:
#
# 1. Poincaré sections, stroboscopic and at events, sampled exactly;
# 2. periodic orbits by Newton shooting, with their Floquet multipliers from saltation
#    matrices, checked against the closed form of Den Hartog's forced Coulomb oscillator;
# 3. a bifurcation diagram over the forcing amplitude with forward and backward
#    continuation (hysteresis), the contact onset marked on it;
# 4. the largest Lyapunov exponent of the nonsmooth flow;
# 5. the tape engineer's design chart: the critical flange clearance against tape speed
#    and tension, in SI units.

# %%
import os

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full-size versions.
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"

import math
import time
from pathlib import Path
from tempfile import mkdtemp

import matplotlib.pyplot as plt
import numpy as np

import impactosc as io
from impactosc import dynamics as dy

print("impactosc", io.__version__, "| quick mode" if QUICK else "| full mode")

# %% [markdown]
# ## 1. Poincaré sections
#
# The **stroboscopic section** records the state once per forcing period `T = 2 pi/Omega`,
# at a chosen forcing phase. It is one run with a *time event* at every section time: the
# engine ends a smooth piece exactly there, so every point is a state of the run, not an
# interpolation. An **event section** records the state at every event of one kind, here
# every contact start on the upper flange.
#
# The paper's contact case (`F = 0.5, Omega = 1.1, beta = 0.01, K = 1e4`) settles on a
# period-3 motion: three points that repeat.

# %%
contact = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
n_points = 60 if QUICK else 300
strobe = dy.stroboscopic_section(contact, n_points, transient_periods=200)
hits = dy.event_section(contact, n_points, "contact_start", side=1, transient_periods=200)
print(f"{len(strobe)} stroboscopic points, {len(hits)} upper-flange contacts over {n_points} periods")
print("period of the stroboscopic sequence:", dy.detect_period(strobe.x, strobe.v, tol=1e-2))

fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
strobe.plot(ax=axes[0])
axes[1].scatter(hits.phase, hits.v, s=6)
axes[1].set_xlabel("forcing phase at contact [rad]")
axes[1].set_ylabel("entry velocity V")
axes[1].set_title("event section: contact starts on the upper flange", fontsize=10)
plt.tight_layout()
plt.show()

# %% [markdown]
# Both sections are also `xarray` Datasets (`period` or `event` dimension, `t`, `x`, `v`
# and the forcing phase):

# %%
strobe.to_xarray()

# %% [markdown]
# ## 2. A periodic orbit and its Floquet multipliers
#
# A period-`n` orbit is a fixed point of the `n`-th iterate of the stroboscopic map.
# Newton's method needs the map's Jacobian, the **monodromy matrix**. For this hybrid
# flow it is a product: the 2x2 matrix exponential of every smooth piece (closed form for
# the linear modes) and a **saltation matrix** at every event,
# `S = R + (f+ - R f-) n^T / (n.f- + h_t)`, built from the model's own vector fields `f`,
# its guard normals `n` and the impact reset `R`. A friction reversal contributes
# `diag(1, a+/a-)`, a contact entry into the spring flange the identity, a stick a zero
# row: the multiplier 0.
#
# Its eigenvalues, the Floquet multipliers, decide stability.

# %%
t0 = time.perf_counter()
orbit3 = dy.periodic_orbit(contact, 3, transient_periods=200)
print(f"({(time.perf_counter() - t0) * 1e3:.0f} ms, transient included)")
print(orbit3.summary())

# %% [markdown]
# **A closed form to check against.** Den Hartog (1931) solved the forced oscillator with
# Coulomb friction: its non-stop steady state has two stops per period at `X = +-A` with
# `A = sqrt((F/(1 - Omega^2))^2 - (beta tan(pi/(2 Omega))/Omega)^2)`. At each stop the
# friction force flips, the saltation matrix is `diag(1, rho)` with
# `rho = (A Omega^2 - beta)/(A Omega^2 + beta)`, and between stops the flow is a rotation,
# so the multipliers are the squares of the eigenvalues of `diag(1, rho) R(pi/Omega)`.
# Shooting reproduces both to rounding:

# %% tags=["gallery-orbit"]
F_dh, Om_dh, beta_dh = 0.3, 0.8, 0.05
den_hartog = io.Oscillator(F_dh, Om_dh, beta_dh, K=1e4)
orbit = dy.periodic_orbit(den_hartog, 1, transient_periods=200)
A = dy.den_hartog_amplitude(F_dh, Om_dh, beta_dh)
mu = dy.den_hartog_multipliers(F_dh, Om_dh, beta_dh)
print(orbit.summary())
print(f"amplitude: closed form {A:.15f}, shooting {np.abs(orbit.events.x).max():.15f}")
print(f"multipliers: closed form {np.round(mu, 12)}\n             shooting    {np.round(orbit.multipliers, 12)}")

fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
orbit.plot(ax=axes[0])
orbit3.plot(ax=axes[1])
plt.tight_layout()
plt.show()

# %% [markdown]
# ## 3. A bifurcation diagram with the contact onset marked
#
# For each forcing amplitude `F` the motion runs a transient (discarded), then the
# stroboscopic points are recorded. The **forward** pass raises `F` step by step, each
# value starting from the last state of the previous one, as a slowly changing run-out
# would; the **backward** pass lowers it. The two passes run concurrently on a process
# pool (every finished value is written to a small file in a store directory, so an
# interrupted diagram resumes).
#
# The Den Hartog branch grows linearly with `F` until it reaches the flange at
# `F_c = |1 - Omega^2| sqrt(1 + (beta tan(pi/(2 Omega))/Omega)^2)`: the **grazing
# bifurcation**. `contact_onset` finds it numerically by following the contact-free
# periodic orbit with Newton shooting and bracketing the sign change of its contact margin.
# Above `F_c` the forward pass jumps to a contact motion; the backward pass stays on
# contact motions below `F_c`: the two coexist, and the diagram shows the hysteresis.

# %% tags=["gallery"]
Fc = dy.den_hartog_onset(Om_dh, beta_dh)
# continuation of the orbit found above (at F = 0.3) up to the value where it grazes the flange
onset = dy.contact_onset(den_hartog, "F", (F_dh, 1.1 * Fc), guess=(orbit.x, orbit.v))
print(f"contact onset: closed form F_c = {Fc:.12f}, numerical {onset.value:.12f} "
      f"(error {abs(onset.value - Fc):.1e}, status {onset.status})")
print(f"followed: {onset.followed}; just before the onset it is {'stable' if onset.stable else 'not stable'}")

values = np.linspace(0.05, 1.5, 30 if QUICK else 300)
t0 = time.perf_counter()
bif = dy.bifurcation_diagram(den_hartog, "F", values, transient_periods=40 if QUICK else 200,
                             record_periods=8 if QUICK else 50, continuation="both", x0=0.0,
                             progress=False)  # the time is printed below; a progress bar would stay on the page
print(f"{bif.sizes['F']} values x 2 passes in {time.perf_counter() - t0:.1f} s")

ax = dy.plot_bifurcation(bif, onset=onset.value, onset_label=f"contact onset F = {onset.value:.4f}")
ax.set_title(f"Omega = {Om_dh}, beta = {beta_dh}, K = 1e4: stroboscopic X against F", fontsize=10)
plt.show()

# %% [markdown]
# ## 4. Largest Lyapunov exponent
#
# A tangent vector rides along the run through the same piece matrices and saltation
# matrices and is renormalised every forcing period. On a stable periodic orbit the
# exponent is `log|mu_max| / period`; positive values flag sensitive (chaotic) motion. The
# convergence history shows how far to trust the last digit.

# %%
lyap_dh = dy.lyapunov_exponent(den_hartog, 300 if QUICK else 3000, transient_periods=0, x0=orbit.x, v0=orbit.v)
print(f"Den Hartog orbit: lambda = {lyap_dh.exponent:.8f}, log|mu|/T = "
      f"{math.log(orbit.spectral_radius) / orbit.period:.8f}")
lyap_c = dy.lyapunov_exponent(contact, 300 if QUICK else 3000, transient_periods=100)
print(f"contact case: lambda = {lyap_c.exponent:.6f} (period-3 orbit: log|mu|/(3T) = "
      f"{math.log(orbit3.spectral_radius) / orbit3.period:.6f})")

fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(lyap_dh.t, lyap_dh.history, label="Den Hartog orbit")
ax.plot(lyap_c.t, lyap_c.history, label="contact case")
ax.axhline(0.0, color="0.6", lw=0.8)
ax.set_xlabel("time (Lambda)")
ax.set_ylabel("running estimate of lambda")
ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# ## 5. The tape engineer's design chart
#
# With the paper's parameters (1 mm clearance) the tape never touches a flange (notebook
# 03, `reports/paper_reproduction.md`). The useful question is then: **at which clearance
# does contact start**, and how does that depend on tape speed and tension? For every
# grid point `onset_chart` brackets the clearance at which the steady state first
# touches a flange. Here by the search from transients (`method="transient"`: each run
# stops at its first contact, so contact-side runs are cheap); the default follows the
# branch of one orbit by continuation instead, and notebook 08 traces the same boundary
# as one continued curve.
#
# At these speeds the reel turns four orders of magnitude slower than the tape span
# resonates (`Omega ~ 2e-4`): the response is quasi-static. The tape creeps after the
# run-out and lags it by the friction deflection `mu N / k`, so contact starts when
# `clearance < run-out - mu N / k` — in the chart a function of tension only, and within
# a micrometre of the run-out (120 um at mid pack), because the in-plane bending stiffness
# `k = 5.2e5 N/m` makes the friction deflection tiny.

# %% tags=["gallery-chart"]
drive = io.TapeDrive()
print(drive.describe())
speeds = np.array([4.0, 8.0] if QUICK else [1.0, 2.0, 4.0, 6.0, 8.0, 12.0])          # m/s
tensions = np.array([0.5, 2.0] if QUICK else [0.25, 0.5, 1.0, 1.5, 2.0, 3.0])        # N
t0 = time.perf_counter()
chart = dy.onset_chart(drive, "clearance", (110e-6, 125e-6), {"speed": speeds, "tension": tensions},
                       method="transient", tol=1e-7 if QUICK else 2e-9, transient_periods=0.25, record_periods=1, stop_at_contact=True,
                       progress=False)
print(f"{chart['critical'].size} chart points in {time.perf_counter() - t0:.1f} s")

quasi = np.array([[dy.quasi_static_critical_clearance(drive.replace(speed=s, tension=t)) for t in tensions]
                  for s in speeds])
print("critical clearance [um] (rows: speed, columns: tension):")
print(np.round(chart["critical"].values * 1e6, 4))
print(f"largest difference from run-out - mu N/k: {np.nanmax(np.abs(chart['critical'].values - quasi)) * 1e9:.2f} nm")

ax = dy.plot_onset_chart(chart, scale=1e6, units="um")
ax.set_title("critical flange clearance: contact below it (paper's drive, mid pack)", fontsize=10)
plt.show()

# %% [markdown]
# **Reading the chart.** Below the critical clearance the tape edge touches a flange once
# per reel turn; above it, never. With the paper's 1 mm clearance the margin is large
# (the critical clearance is ~120 um), which is why the paper's parameters give no contact
# force at all. The same tools chart any other pair (`pack_diameter` moves the run-out,
# `friction` the lag), and `contact_onset(drive, "runout_full", ...)` gives the critical
# run-out for a fixed clearance.

# %% [markdown]
# ## 6. The same from the command line
#
# Each tool has a subcommand that writes its result to a file and its figure to a PNG:
# `impactosc bifurcation`, `orbit`, `onset` and `chart` (`impactosc <subcommand> --help`
# lists the options). The diagram of section 3 over a narrower range of `F`, run here
# through the command line's own entry point (in a shell: `impactosc bifurcation --F 0.3
# ...`), and the figure it wrote:

# %% tags=["gallery-cli"]
from IPython.display import Image, display

from impactosc.cli import main as impactosc_cli

out = Path(mkdtemp(prefix="impactosc-cli-"))
argv = ["bifurcation", "--F", "0.3", "--Omega", str(Om_dh), "--beta", str(beta_dh), "--K", "1e4",
        "--param", "F", "--range", "0.2", "0.6", "--n", "25" if QUICK else "50", "--x0", "0",
        "--transient-periods", "40" if QUICK else "200", "--record-periods", "8",
        "--out", str(out / "bif.nc"), "--plot", str(out / "bif.png"), "--no-progress"]
print("impactosc " + " ".join(argv[:-5]) + " --out bif.nc --plot bif.png")
status = impactosc_cli(argv)
print("exit status", status, "| wrote", sorted(p.name for p in out.iterdir()))
display(Image(filename=str(out / "bif.png"), width=640))
