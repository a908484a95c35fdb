# %% [markdown]
# # 01 · Getting started with `impactosc`
#
# `impactosc` simulates the tape-edge / roller-flange impact oscillator of section 5 of
# *Characterization of Tape Edge Contact Force With Acoustic Emission* (ASME, DOI
# 10.1115/1.2748775): a tape span, modelled as a mass on a spring, is pushed sideways by
# the run-out of the supply reel, rubs on the roller with Coulomb friction and hits one of
# the two roller flanges when its lateral excursion exceeds the clearance.
#
# Every flange contact entry and exit, every friction reversal, every stick and every
# release is a **located event**, found to machine precision, instead of the paper's
# fixed-step Runge-Kutta integration with a naive `sign()` (notebook 02 shows why that
# matters).
#
# This notebook covers:
#
# 1. installing, and the model (`Oscillator`: `F`, `Omega`, `beta`, `K`);
# 2. `simulate`, the event table and the impact table;
# 3. plots: position with contacts shaded and sticks/releases marked, phase portrait,
#    flange force over time;
# 4. recording levels (`record="full" | "events" | "stats"`);
# 5. the paper's tape drive in SI units (`TapeDrive`).
#
# **Installing.** From a clone of the repository, `make demo` creates `.venv`, installs the
# package and runs a contacting case; `make test` runs the linters and the test suite
# (these notebooks included). By hand: `pip install -e ".[plot]"` (add `fast` for numba,
# which the RK4 baseline uses, and `dask` for clusters).

# %%
import os

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full-size versions.
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"

import time

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import display

import impactosc as io
from impactosc.results import plot_solution

print("impactosc", io.__version__, "| quick mode" if QUICK else "| full mode")

# %% [markdown]
# ## 1. The model
#
# The paper's equation of motion (its eq. 2) for the lateral tape position `x`, made
# nondimensional with the flange clearance `L` and the natural frequency
# `omega_n = sqrt(k/m)` of the tape span, is its **eq. 3**:
#
# $$X'' + X + \beta\,\mathrm{sgn}(X') = F\cos(\Omega\Lambda + \varphi) - K\,(X - \mathrm{sgn}X)\,[|X| > 1]$$
#
# with `X = x/L`, `Lambda = omega_n t` and primes for `d/dLambda`. The four numbers are
#
# | symbol | meaning | in the tape drive |
# | --- | --- | --- |
# | `F = F_a/(k L)` | forcing amplitude | reel run-out / clearance |
# | `Omega = omega_r/omega_n` | forcing frequency | reel turns vs tape-span resonance |
# | `beta = mu N/(k L)` | Coulomb friction level | friction on the roller, `N = 2 T sin(theta/2)` |
# | `K = k0/k` | flange-to-tape stiffness ratio | `1e4` in the paper |
#
# **The two-sided flange.** There is a flange at `X = +1` and one at `X = -1`. While
# `|X| > 1` the flange is a stiff spring pushing the tape back with force `K (|X| - 1)`
# (in units of `k L`). The paper prints the flange term as `K (X - 1)` for *both* flanges;
# at the lower flange that is a force jumping from 0 to `2K` at `X = -1` (a wall, not a
# spring), so `impactosc` uses the consistent, continuous `K (X - sgn X)` (the RK4 baseline
# can reproduce the printed form with `flange="paper"`).
#
# **Friction** is Filippov stick-slip: when the velocity reaches zero the tape *sticks* if
# the net non-friction force (forcing minus tape spring minus flange spring) is at most
# `beta` in magnitude, and is *released* when that force reaches `beta`.

# %%
osc = io.Oscillator(F=0.8, Omega=0.5, beta=0.1, K=1e4)
osc

# %% [markdown]
# An `Oscillator` is a frozen, validated dataclass. It also knows its forces, in units of
# `k L`: the forcing, the flange force `K (|X| - 1)+`, the net force of the stick test, the
# energy, and the contact frequency `sqrt(1 + K)` that sets the time scale of an impact.

# %%
print("forcing at Lambda = 0, 1, 2 :", osc.forcing([0.0, 1.0, 2.0]))
print("flange force at X = 0.9, 1.001, -1.002 :", osc.flange_force([0.9, 1.001, -1.002]))
print("contact frequency sqrt(1+K) =", osc.contact_frequency)
try:
    io.Oscillator(F=-1.0, Omega=1.0, beta=0.1, K=1e4)
except ValueError as exc:
    print("ValueError:", exc)

# %% [markdown]
# ## 2. `simulate`, events and impacts
#
# `simulate(osc, t_end, x0, v0)` integrates from `(X, X') = (x0, v0)` at `Lambda = 0` to
# `Lambda = t_end` (the defaults `x0 = 0.95, v0 = 0` are the paper's eq. 6-7). The default
# backend is heyoka (Taylor integration, events located on each step's polynomial).

# %%
t0 = time.perf_counter()
sol = io.simulate(osc, t_end=60.0, x0=0.95, v0=0.0)
print(f"{time.perf_counter() - t0:.3f} s wall")
print(sol.status, sol.message)
print(sol.counts)
print(sol.summary())

# %% [markdown]
# The **event table**: one row per event, with its time `t`, `kind` (`contact_start`,
# `contact_end`, `reversal`, `stick`, `release`), state `x`, `v` and flange `side` (+1
# upper, -1 lower, 0 for friction events). Contact events sit exactly on `|X| = 1`; sticks
# exactly at `v = 0`.

# %%
print(sol.event_table(limit=15))

# %% [markdown]
# `sol.events` is a NumPy record array, so the usual selections work:

# %%
ev = sol.events
sticks = ev[ev.kind == "stick"]
print("stick times:", np.round(sticks.t, 4))
print("largest |x| error at contact events:",
      np.abs(np.abs(ev.x[np.isin(ev.kind, ["contact_start", "contact_end"])]) - 1).max())

# %% [markdown]
# The **impact table**: one row per contact, with entry and exit velocity, the deepest
# penetration `max(|X| - 1)`, the peak force `K * penetration` and the impulse
# `int K(|X| - 1) dLambda` (forces in units of `k L`).

# %%
print(sol.impact_table(limit=10))
im = sol.impacts
print(f"\n{len(im)} contacts; mean duration {np.mean(im.end - im.start):.4f} "
      f"(half a contact period pi/sqrt(1+K) = {np.pi / osc.contact_frequency:.4f})")

# %% [markdown]
# The **mean flange force** is the quantity the paper averages (its Fig. 7 and 8). It is an
# exact integral of the flange force, per flange or for both, over the whole run or any
# window (a window needs `record="full"`).

# %%
print("mean flange force, both flanges :", sol.mean_flange_force())
print("upper / lower                   :", sol.mean_flange_force(side=1), sol.mean_flange_force(side=-1))
print("window Lambda in [30, 60]       :", sol.mean_flange_force(t0=30.0, t1=60.0))
print("peak force, rms force           :", sol.max_flange_force(), sol.rms_flange_force())

# %% [markdown]
# ## 3. Plots
#
# `impactosc.plotting.plot_solution` draws position, flange force and phase portrait in one
# figure. (It selects matplotlib's non-interactive Agg backend, meant for scripts; in a
# notebook we switch back to the inline backend and display the figure explicitly.)

# %%
fig = plot_solution(sol)
get_ipython().run_line_magic("matplotlib", "inline")
display(fig)
plt.close(fig)

# %% [markdown]
# The same with plain matplotlib, using dense output: `sol.sample(t)` evaluates `(X, X')`
# anywhere in the run (exact at event times). Contacts are shaded, sticks and releases
# marked.

# %%
t = np.union1d(np.linspace(0.0, sol.t_final, 3000), ev.t)
x, v = sol.sample(t)

fig, ax = plt.subplots(figsize=(9, 3.6))
ax.plot(t, x, color="k", lw=0.8, label="X(Λ)")
for side in (-1, 1):
    ax.axhline(side, color="tab:red", ls="--", lw=0.8)
for row in sol.impacts:
    ax.axvspan(row.start, row.end, color="tab:red", alpha=0.25, lw=0)
rel = ev[ev.kind == "release"]
ax.plot(sticks.t, sticks.x, "o", color="tab:blue", ms=5, label="stick")
ax.plot(rel.t, rel.x, "^", color="tab:green", ms=5, label="release")
ax.set_xlabel("nondimensional time Λ = ω_n t [-]")
ax.set_ylabel("lateral position X = x/L [-]")
ax.set_title("Position; red bands: flange contact, dashed: flanges at |X| = 1")
ax.legend(loc="lower right", ncol=3)
plt.show()

# %% [markdown]
# A stick is a flat piece of `X(Λ)` that starts with `X' = 0` and ends when the net force
# reaches `beta`. Zoom on the first one:

# %%
s0, r0 = sticks.t[0], rel.t[rel.t > sticks.t[0]][0]
tz = np.linspace(s0 - 1.0, r0 + 1.0, 800)
xz, vz = sol.sample(tz)
fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.4), constrained_layout=True)
a1.plot(tz, xz, color="k")
a1.axvspan(s0, r0, color="tab:blue", alpha=0.2, label="stuck")
a1.set_xlabel("Λ [-]")
a1.set_ylabel("X [-]")
a1.legend()
fnet = osc.net_force(tz, xz)
a2.plot(tz, fnet, color="tab:purple", label="net force f_net")
a2.axhspan(-osc.beta, osc.beta, color="tab:blue", alpha=0.15, label="|f_net| ≤ β (stick band)")
a2.axvspan(s0, r0, color="tab:blue", alpha=0.2)
a2.set_xlabel("Λ [-]")
a2.set_ylabel("force [units of kL]")
a2.legend(fontsize=8)
fig.suptitle(f"stick at Λ = {s0:.4f}, release at Λ = {r0:.4f}")
plt.show()

# %% [markdown]
# Phase portrait and flange force. The flange force is `K (|X| - 1)+`; during a contact the
# tape compresses the flange spring for about half a period `pi/sqrt(1+K)` of the stiff
# contact oscillation.

# %%
fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.6), constrained_layout=True)
a1.plot(x, v, color="k", lw=0.6)
a1.axvline(1.0, color="tab:red", ls="--", lw=0.8)
a1.axvline(-1.0, color="tab:red", ls="--", lw=0.8)
a1.plot(sticks.x, sticks.v, "o", color="tab:blue", ms=4, label="stick")
a1.set_xlabel("X = x/L [-]")
a1.set_ylabel("X' = dX/dΛ [-]")
a1.set_title("phase portrait")
a1.legend()

first = sol.impacts[0]
tc = np.linspace(first.start - 0.02, first.end + 0.02, 400)
a2.plot(tc, sol.flange_force(tc), color="tab:red")
a2.set_xlabel("Λ [-]")
a2.set_ylabel("flange force K(|X|-1)+ [units of kL]")
a2.set_title(f"first contact (side {first.side:+d}): peak {first.peak_force:.3f} kL")
plt.show()

# %%
tf = np.linspace(0.0, sol.t_final, 20000)
fig, ax = plt.subplots(figsize=(9, 3))
ax.plot(tf, sol.flange_force(tf), color="tab:red", lw=0.7)
ax.axhline(sol.mean_flange_force(), color="k", ls=":", label=f"mean = {sol.mean_flange_force():.4f} kL")
ax.set_xlabel("nondimensional time Λ [-]")
ax.set_ylabel("flange force [units of kL]")
ax.set_title("flange force over the run (upper and lower flange)")
ax.legend()
plt.show()

# %% [markdown]
# ## 4. Recording levels
#
# `record=` chooses what a run keeps:
#
# * `"full"` (default): events, impacts and the start of every smooth piece, so that
#   `sample`, `flange_force(t)` and windowed averages work;
# * `"events"`: events and impacts;
# * `"stats"`: counts and integrals only; memory stays flat however long the run.
#
# Counts, contact statistics and mean/rms forces over the whole run are identical at every
# level; asking for more than was kept raises a `ValueError` that says what to do.

# %%
t_long = 2_000.0 if QUICK else 20_000.0
for record in ("full", "events", "stats"):
    t0 = time.perf_counter()
    s = io.simulate(osc, t_long, record=record)
    wall = time.perf_counter() - t0
    kept = 0 if s.record == "stats" else len(s.events)
    print(f"{record:>6}: {wall:6.3f} s, {s.contact_entries()} contacts, {kept:6d} events kept, "
          f"mean force {s.mean_flange_force():.10f}")
try:
    s.events
except ValueError as exc:
    print("ValueError:", exc)

# %% [markdown]
# ## 5. The paper's tape drive in SI units
#
# `TapeDrive` holds the physical parameters of section 5 (tape, roller, reel run-out,
# operating point), with the paper's values as defaults, and reduces them to the four
# numbers of eq. 3 with the paper's equations: `k = 48 E I / l^3` (eq. 4, with the in-plane
# second moment `I = h w^3 / 12`), `N = 2 T sin(theta/2)` (eq. 5), `omega_r = 2 V / D`
# (eq. 1) and a run-out rising linearly with pack diameter from 60 um at the hub to 180 um
# at full pack (Fig. 6). Scales back to SI: time `t = Lambda / omega_n`, length `x = L X`,
# force `k L` times the nondimensional force.

# %%
drive = io.TapeDrive(speed=4.0, tension=1.0, pack_diameter=0.07)   # m/s, N, m
print(drive.describe())

# %%
osc_drive = drive.oscillator()
print(osc_drive)
print(f"force scale kL = {drive.force_scale:.4g} N, length scale L = {drive.length_scale * 1e6:.4g} um, "
      f"time scale 1/omega_n = {drive.time_scale * 1e6:.4g} us")

# %% [markdown]
# One second of tape motion is `Lambda = omega_n * 1 s`, about 5.7e5 nondimensional time
# units and some 90 000 periods of the tape span. `record="stats"` keeps memory flat.

# %%
duration = 1.0  # s
t0 = time.perf_counter()
sol_drive = io.simulate(osc_drive, drive.seconds_to_lambda(duration), record="stats")
print(f"{time.perf_counter() - t0:.2f} s wall for {duration} s of tape motion")
print(sol_drive.summary())

fs, L_um = drive.force_scale, drive.length_scale * 1e6
print(f"mean flange force  : {sol_drive.mean_flange_force() * fs:.4g} N")
print(f"peak flange force  : {sol_drive.max_flange_force() * fs:.4g} N")
print(f"max penetration    : {sol_drive.max_penetration() * L_um:.4g} um")
print(f"time in contact    : {drive.lambda_to_seconds(sol_drive.contact_time()) * 1e3:.4g} ms")
print(f"final position     : {sol_drive.x_final * L_um:.4g} um from the roller centre line")
print(f"sticks per second  : {sol_drive.counts['stick'] / duration:.0f}")

# %% [markdown]
# With the paper's stated parameters the tape **never touches a flange** after the initial
# condition: the run-out is at most 0.18 of the 1 mm clearance (`F <= 0.18`) and the reel
# turns some 10 000 times slower than the tape span resonates (`Omega ~ 2e-4`), so there is
# no dynamic amplification. The initial 0.95 mm offset rings down in a few milliseconds and
# the tape then creeps after the run-out in thousands of stick/release steps per second.
# Notebook 03 discusses what that means for the paper's Fig. 7 and 8.
#
# The first milliseconds, in SI units (a short `record="full"` run):

# %%
t_ms = 10.0 if QUICK else 50.0
sol_ms = io.simulate(osc_drive, drive.seconds_to_lambda(t_ms * 1e-3))
lam = np.linspace(0.0, sol_ms.t_final, 20000)
x_ms, _ = sol_ms.sample(lam)
fig, ax = plt.subplots(figsize=(9, 3.4))
ax.plot(drive.lambda_to_seconds(lam) * 1e3, x_ms * L_um, color="k", lw=0.4, label="tape edge x(t)")
for side in (-1, 1):
    ax.axhline(side * L_um, color="tab:red", ls="--", lw=0.8, label="flange" if side == 1 else None)
ax.plot(drive.lambda_to_seconds(lam) * 1e3, osc_drive.forcing(lam) * L_um, color="tab:orange",
        label="run-out forcing F_a/k")
ax.set_xlabel("time t [ms]")
ax.set_ylabel("lateral tape position x [um]")
ax.set_title(f"paper's drive, V = {drive.speed:g} m/s, D = {drive.pack_diameter * 1e3:g} mm: "
             "ring-down, then creep (no contact)")
ax.legend(loc="upper right")
plt.show()
