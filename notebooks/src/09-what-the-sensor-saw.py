# %% [markdown]
# # 09 · What the sensor saw: contact observables and the four trends of Fig. 4
#
# The paper's Fig. 4 is a measurement: an acoustic-emission (AE) sensor used as the flange,
# calibrated by ball drops (impact peaks), its rms reading averaged over one second. It
# shows four trends: the average impact force is (1) largest at mid pack, (2) grows with
# tape speed, (3) falls with tension, and (4) at `T sin(theta/2) = 0.1 N` is almost double
# its value at 0.7 N. The paper's model with its printed parameters never touches a flange
# (notebook 03). This notebook
#
# 1. computes what a sensor in the flange sees, in SI units, on one tape drive that does
#    touch: per contact (peak force, impulse, entry speed, elastic impact force, energy),
#    per second (impact rate, AE proxies) and over a moving window (the rms force of
#    Fig. 3(c));
# 2. derives the lead that an impact-counting sensor could see a mid-pack maximum, and tests it;
# 3. runs the study of `impactosc.paper.study` (quick mode): the criteria fixed first, then
#    candidate models and a search, each judged per observable.

# %%
import math
import os
import tempfile

import matplotlib.pyplot as plt
import numpy as np

import impactosc
from impactosc.paper import STUDY_CRITERIA, lead_ae_proxy, lead_peak_runout, quasi_static_impact_speed, study
from impactosc.results import contact_table, moving_rms_force
from impactosc.sweeps import sweep

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full study (minutes).
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"
print("impactosc", impactosc.__version__, "| quick mode" if QUICK else "| full mode")

# %% [markdown]
# ## 1. Observables of one drive
#
# In-plane bending of a 40 mm span (lateral mode 2.3 kHz), a 50 um clearance, the paper's
# friction `mu = 0.2`, 8 m/s at mid pack with `T sin(theta/2) = 0.2 N`. Two reel turns of
# transient, then two measured turns, recorded in full for the moving rms.

# %%
drive = impactosc.TapeDrive.from_t_sin_half_theta(0.2, free_length=40e-3, clearance=50e-6, speed=8.0)
osc = drive.oscillator()
turn = 2 * math.pi / osc.Omega
first = impactosc.simulate(osc, 2 * turn, 0.95, 0.0, backend="exact", record="stats")
phase = math.fmod(osc.Omega * first.t_final, 2 * math.pi)
sol = impactosc.simulate(drive.oscillator(phase=phase), 2 * turn, first.x_final, first.v_final, backend="exact")
print(drive.describe())
table = contact_table(sol, drive)
print(f"{len(table)} contacts in two turns; first rows (SI):")
for row in table[:4]:
    print(f"  t = {row.start * 1e3:8.3f} ms, side {row.side:+d}, {row.duration * 1e6:7.1f} us, "
          f"v_in = {row.entry_speed * 1e3:6.2f} mm/s, peak {row.peak_force:7.4f} N, "
          f"impact {row.impact_force:7.4f} N, impulse {row.impulse * 1e6:8.3f} uN s")
obs = sol.contact_observables(drive)
for k, v in obs["both"].items():
    print(f"  {k:20s} {v:.4g}")

# %% [markdown]
# The rms contact force over a moving 2 ms window, the model's version of Fig. 3(c): each
# push of the run-out into a flange is a burst.

# %%
t, rms = moving_rms_force(sol, 2e-3, drive=drive, step=2e-6)
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot((t - t[0]) * 1e3, rms, lw=0.8)
ax.set_xlabel("time [ms]")
ax.set_ylabel("rms contact force (2 ms) [N]")
ax.set_title("Fig. 3(c) analogue: rms flange force over a moving window")
ax.grid(alpha=0.3)

# %% [markdown]
# ### The same observables over a sweep
#
# `impactosc.sweep` runs every point with `record="stats"`, which keeps no impact table; the
# recorder streams the sums over the contacts (their number, entry speeds and squares, peak
# and elastic impact forces, impulses, dissipated energy), so the sweep's Dataset carries
# the sensor's observables in SI units: `mean_peak_force` (N), the AE proxies `ae_peak_sum`
# and `ae_impact_sum` (N/s), `impact_energy_rate` and `dissipation_rate` (W). Here 20 ms per
# point, less than a reel turn: a demonstration, not a steady state (the study below
# measures whole turns after a transient).

# %%
ds = sweep(drive, {"pack_diameter": [0.05, 0.07, 0.09], "speed": [4.0, 8.0, 12.0]}, duration=20e-3,
           executor="serial", progress=False)
columns = ["impact_rate", "mean_peak_force", "ae_impact_sum", "impact_energy_rate", "mean_flange_force"]
print(", ".join(f"{c} [{ds[c].attrs['units']}]" for c in columns))
print(ds[columns].to_dataframe().to_string(float_format=lambda v: f"{v:.4g}"))

# %% [markdown]
# ## 2. The lead, derived
#
# A quasi-static tape follows the reel, `x = A cos(omega_r t)`, shifted by the friction dead
# band `mu N / k`: it reaches the flange at `c = L + mu N / k` with speed
# `omega_r sqrt(A^2 - c^2)`. One elastic impact `sqrt(k0 m) v` per turn and flange, summed per
# second, goes like `V^2 sqrt(A^2 - c^2) / D^2`. With `A` proportional to `D` its maximum over
# the pack is at `A = sqrt(2) c`; Fig. 6's law is affine (`A0 = -39.6 um` at `D = 0`), and then
# `A^2 + A0 A - 2 c^2 = 0`.

# %%
c = drive.clearance + drive.friction_force / drive.stiffness
print(f"quasi-static impact speed at mid pack: {quasi_static_impact_speed(drive) * 1e3:.2f} mm/s; "
      f"simulated mean entry speed: {np.mean(table.entry_speed) * 1e3:.2f} mm/s")
d = np.linspace(drive.hub_diameter, drive.full_pack_diameter, 400)
lead = np.array([lead_ae_proxy(drive.replace(pack_diameter=float(x))) for x in d])
a_star = lead_peak_runout(c, -39.6e-6)
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(d * 1e3, lead)
ax.axvline(44 + (a_star - 60e-6) / 120e-6 * 53, color="k", ls=":", label=f"A* = {a_star * 1e6:.0f} um")
ax.set_xlabel("pack diameter [mm]")
ax.set_ylabel("lead AE proxy [N/s]")
ax.legend()
ax.grid(alpha=0.3)

# %% [markdown]
# ## 3. The study
#
# The criteria, fixed before anything is computed:

# %%
for key, (what, rule) in STUDY_CRITERIA.items():
    print(f"{key}: {what}\n    {rule}")

# %%
out = tempfile.mkdtemp()
summary = study(out, quick=QUICK, executor="serial", progress=False)
for name, res in summary["candidates"].items():
    for obs_name, trends in res["trends"].items():
        held = [k for k, v in trends.items() if v]
        print(f"{name:16s} {obs_name:20s} {', '.join(held) or '-'}")
print("best:", summary["best"]["model"], summary["best"]["observable"], summary["best"]["trends"])

# %% tags=["gallery"]
img = plt.imread(os.path.join(out, "figures", "fig4_study_best.png"))
fig, ax = plt.subplots(figsize=(9, 2.4))
ax.imshow(img)
ax.axis("off")

# %% [markdown]
# The report `fig4_study.md` (written by `impactosc paper --study`) has the whole argument:
# the lead allows at most a ratio of about 1.57 between 0.1 and 0.7 N while keeping the
# maximum in the middle third of the pack, so an impact-counting sensor on a quasi-static
# tape cannot show all four trends with margin; the simulated candidates and the search
# say which trends each observable does give. Two of the candidates are tape paths of two
# guides (`impactosc.TapePath`, the flanged guide nearest the pack as the sensor): without
# friction a path does not see the tension at all; with friction on a post the tension acts
# through it, and the path's impact rate falls with tension, but no curve peaks mid pack.
