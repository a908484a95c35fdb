# %% [markdown]
# # 02 · Why event location matters: the paper's RK4 against located events
#
# The paper integrates its eq. 3 with the classic fourth-order Runge-Kutta method at a
# fixed step, with friction written as `beta * sign(X')` and the flange switched on by
# `|X| > 1` inside the right-hand side. `impactosc` keeps that method as the baseline
# (`backend="rk4"`: default step 1/100 of the contact period `2 pi / sqrt(1 + K)`; events
# are *reconstructed* afterwards from sign changes between steps) and compares it with
#
# * `backend="exact"`: closed-form pieces (every mode is linear with harmonic forcing),
#   event times refined to one ulp: the ground truth;
# * `backend="heyoka"` (default): Taylor integration, every event located on the step's
#   Taylor polynomial, to machine precision.
#
# Three things go wrong with a fixed step and a naive `sign()`:
#
# 1. **contact entries** are found late or early: the step that crosses `|X| = 1`
#    integrates across the kink of the flange force, and the error accumulates contact
#    after contact;
# 2. **sticks** do not exist: `sign(X')` has no stick logic, so where the true motion stops
#    the RK4 mass creeps (fine steps) or chatters (coarse steps);
# 3. **grazing contacts** between two step ends are missed altogether.
#
# At the end: work-precision (error against wall time) for both methods.

# %%
import os

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full-size versions.
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"

import math
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, Markdown, display

import impactosc as io
from impactosc.backends.rk4 import default_dt

print("impactosc", io.__version__, "| quick mode" if QUICK else "| full mode")

# %% [markdown]
# ## 1. Contact entries
#
# The contact case of the test suite: `Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)`
# from `X = 0.95` at rest, 400 time units, 94 contacts, both flanges.

# %%
osc = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
t_end = 400.0
dt = default_dt(osc.K)
print(f"RK4 default step dt = T_c/100 = {dt:.4e} (contact period T_c = {2 * math.pi / osc.contact_frequency:.4e})")

runs, walls = {}, {}
for name, kw in {"exact": {"backend": "exact"}, "heyoka": {"backend": "heyoka"},
                 "rk4": {"backend": "rk4"}, "rk4 dt/4": {"backend": "rk4", "dt": dt / 4}}.items():
    t0 = time.perf_counter()
    runs[name] = io.simulate(osc, t_end, x0=0.95, **kw)
    walls[name] = time.perf_counter() - t0
    print(f"{name:>9}: {walls[name]:6.3f} s  {runs[name].summary()}")

# %% [markdown]
# All four runs see the same sequence of contacts here, so entries can be matched one to
# one. The errors of the entry times against the exact solution:

# %%
def entries(sol):
    ev = sol.events
    return ev[ev.kind == "contact_start"]


ref = entries(runs["exact"])
err = {}
for name in ("heyoka", "rk4", "rk4 dt/4"):
    e = entries(runs[name])
    assert len(e) == len(ref) and np.all(e.side == ref.side), f"{name}: another sequence of contacts"
    err[name] = e.t - ref.t

rows = ["| contact | side | entry time (exact) | heyoka error | RK4 error | RK4 dt/4 error |",
        "| ---: | ---: | ---: | ---: | ---: | ---: |"]
for i in [*range(6), len(ref) // 2, len(ref) - 1]:
    rows.append(f"| {i} | {ref.side[i]:+d} | {ref.t[i]:.10f} | {err['heyoka'][i]:.1e} | "
                f"{err['rk4'][i]:.1e} | {err['rk4 dt/4'][i]:.1e} |")
rows.append(f"| **max** | | | **{np.abs(err['heyoka']).max():.1e}** | **{np.abs(err['rk4']).max():.1e}** | "
            f"**{np.abs(err['rk4 dt/4']).max():.1e}** |")
display(Markdown("\n".join(rows)))
ratio = np.abs(err["rk4"]).max() / np.abs(err["rk4 dt/4"]).max()
print(f"largest RK4 entry error, dt over dt/4: {ratio:.0f} times (a fourth-order method: 4^4 = 256)")

mf = {k: s.mean_flange_force() for k, s in runs.items()}
print("relative error of the mean flange force:",
      {k: f"{abs(v / mf['exact'] - 1):.1e}" for k, v in mf.items() if k != "exact"})
pf = {k: s.impacts.peak_force for k, s in runs.items()}
print("largest relative error of a peak force: ",
      {k: f"{np.abs(v / pf['exact'] - 1).max():.1e}" for k, v in pf.items() if k != "exact"})

# %% [markdown]
# heyoka agrees with the closed form to ~1e-13. RK4's error is not the interpolation error
# of one entry: it appears at the first crossings and is carried on from contact to
# contact. A step that crosses `|X| = 1` integrates across the kink of the flange force,
# where the method is no longer fourth order: a quarter of the step cuts the largest error
# by a factor of about 25 (printed above), between second and third order, not the 256
# of a fourth-order method.

# %%
fig, ax = plt.subplots(figsize=(9, 4))
n = np.arange(len(ref))
for name, style in (("rk4", "o-"), ("rk4 dt/4", "s-"), ("heyoka", "^-")):
    ax.semilogy(n, np.maximum(np.abs(err[name]), 1e-17), style, ms=3, lw=0.8, label=name)
ax.set_xlabel("contact number [-]")
ax.set_ylabel("|entry time − exact| [nondimensional time Λ]")
ax.set_title("entry-time error, contact by contact (zeros drawn at 1e-17)")
ax.legend()
plt.show()

# %% [markdown]
# Zoom on the contact where RK4 is furthest off. Lines: the exact and heyoka solutions
# (dense output); dots: the RK4 step ends, the only states the method has. The vertical
# lines are each method's entry time.

# %%
k = int(np.argmax(np.abs(err["rk4"])))
side = int(ref.side[k])
te = ref.t[k]
lo, hi = te - 8 * dt, te + 6 * dt
tt = np.linspace(lo, hi, 400)
t_steps = np.arange(math.ceil(lo / dt), math.floor(hi / dt) + 1) * dt

fig, ax = plt.subplots(figsize=(9, 4.5))
ax.plot(tt, side * runs["exact"].sample(tt)[0], color="k", lw=2.5, alpha=0.4, label="exact")
ax.plot(tt, side * runs["heyoka"].sample(tt)[0], color="tab:blue", lw=1, label="heyoka")
ax.plot(t_steps, side * runs["rk4"].sample(t_steps)[0], "o", color="tab:red", label="RK4 step ends")
ax.axhline(1.0, color="tab:gray", ls="--", lw=0.8, label="flange |X| = 1")
for name, color in (("exact", "k"), ("heyoka", "tab:blue"), ("rk4", "tab:red")):
    ax.axvline(entries(runs[name]).t[k], color=color, ls=":", lw=1.2)
ax.set_xlabel("nondimensional time Λ [-]")
ax.set_ylabel("|X| = |x|/L (towards the flange) [-]")
ax.set_title(f"contact {k} ({'upper' if side > 0 else 'lower'} flange): RK4 enters "
             f"{err['rk4'][k]:+.2e} late, heyoka {err['heyoka'][k]:+.1e}")
ax.legend(loc="upper left")
plt.show()

# %% [markdown]
# ## 2. Sticks: the free Coulomb oscillator
#
# Without forcing (`F = 0`) and with `beta = 0.1`, a mass released at `X = 0.95` loses
# `2 beta` of amplitude every half period `pi`: it turns at -0.75, 0.55, -0.35, 0.15 and,
# at `Lambda = 5 pi`, at `X = 0.05`, where the spring force `0.05 < beta` cannot overcome
# friction. It sticks there, exactly, forever.

# %%
coulomb = io.Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4)
t_c = 60.0 if QUICK else 400.0
free = {
    "exact": io.simulate(coulomb, t_c, x0=0.95, backend="exact"),
    "heyoka": io.simulate(coulomb, t_c, x0=0.95),
    f"RK4, dt = {dt:.1e} (default)": io.simulate(coulomb, t_c, x0=0.95, backend="rk4"),
    "RK4, dt = 0.1": io.simulate(coulomb, t_c, x0=0.95, backend="rk4", dt=0.1),
}
for name, s in free.items():
    st = s.events[s.events.kind == "stick"]
    when = f"stick at {st.t[0]:.15f}" if len(st) else f"{'no stick':<27}"
    print(f"{name:>26}: {when}, {s.counts['reversal']:3d} reversals, "
          f"X(end) = {s.x_final:+.6f}, X'(end) = {s.v_final:+.2e}")
print(f"{'5 pi':>26} = {5 * math.pi:.15f}")

# %% [markdown]
# The exact and heyoka runs stop at `5 pi` (to the last digit) and stay at `X = 0.05`.
# RK4 has no stick: with the default step the stages straddle `X' = 0` within each step,
# the step ends keep one sign of `X'` and the mass creeps at a spurious speed ~`beta dt`;
# with a coarse step `X'` changes sign at step ends and the mass chatters, with dozens of
# spurious "reversals", drifting towards `X = 0`.

# %%
fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(9, 3.6), constrained_layout=True)
tt = np.linspace(0.0, t_c, 4000)
tail = tt[tt > 5 * math.pi]
colors = ["k", "tab:blue", "tab:red", "tab:orange"]
for (name, s), color in zip(free.items(), colors, strict=True):
    x, v = s.sample(tt)
    style = {"color": color, "lw": 2.5 if name == "exact" else 1.0, "alpha": 0.5 if name == "exact" else 1.0}
    a1.plot(tt, x, label=name, **style)
    if "0.1" not in name:
        a2.plot(tail, (s.sample(tail)[0] - 0.05) * 1e3, label=name, **style)
    if name in ("exact", "heyoka"):
        a3.plot(tail, s.sample(tail)[1], label=name, **style)
    elif "0.1" in name:   # the step ends, the only states the method has
        steps = np.arange(math.ceil(5 * math.pi / 0.1), math.floor(t_c / 0.1) + 1) * 0.1
        a3.plot(steps, s.sample(steps)[1], ".-", ms=3, label=name + " (step ends)", **style)
a1.axvline(5 * math.pi, color="tab:gray", ls=":", lw=1)
a1.set_xlabel("nondimensional time Λ [-]")
a1.set_ylabel("X = x/L [-]")
a1.set_title("free Coulomb oscillator, β = 0.1 (dotted: 5π)", fontsize=9)
a1.legend(fontsize=8)
a2.set_xlabel("nondimensional time Λ [-]")
a2.set_ylabel("X − 0.05 [1e-3]")
a2.set_title("after 5π, fine step: RK4 creeps", fontsize=9)
a2.legend(fontsize=8)
a3.set_xlabel("nondimensional time Λ [-]")
a3.set_ylabel("velocity X' = dX/dΛ [-]")
a3.set_title("after 5π, coarse step: RK4 chatters", fontsize=9)
a3.legend(fontsize=8)
plt.show()

# %% [markdown]
# ## 3. The grazing contact that step-end checks miss
#
# No friction, no forcing, a soft flange (`K = 24`) and a start at `X = 0` with
# `X' = 1 + 1e-9`: the free motion `X = (1 + 1e-9) sin(Lambda)` reaches `1 + 1e-9`, so it
# touches the flange, 1e-9 deep, at `Lambda = pi/2` (and every `pi` after that). The
# event-driven backends locate the crossings; a method that only checks `|X| > 1` at step
# ends sees a contact only if a step end happens to fall within ~`4e-5` of the touching
# time.

# %%
graze = io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=24.0)
v0 = 1.0 + 1e-9
t_g = 10.0
coarse = 0.1
gr = {
    "exact": io.simulate(graze, t_g, x0=0.0, v0=v0, backend="exact"),
    "heyoka": io.simulate(graze, t_g, x0=0.0, v0=v0),
    f"RK4, dt = {coarse}": io.simulate(graze, t_g, x0=0.0, v0=v0, backend="rk4", dt=coarse),
}
for name, s in gr.items():
    e = entries(s)
    print(f"{name:>14}: {s.contact_entries()} contacts, entries at {np.round(e.t, 9)}, "
          f"max penetration {s.max_penetration():.3e}")

# %% [markdown]
# The default RK4 step, `2 pi / (100 sqrt(25)) = pi/250`, happens to divide `pi/2`
# exactly, so a step end lands on the touching point and that run sees the contact; any
# other step, like the coarse one above, does not. Zoom on the first touch: the exact
# penetration `X - 1` against the RK4 step ends of the coarse step.

# %%
ex = gr["exact"]
t_touch = entries(ex).t[0]
tz = np.linspace(math.pi / 2 - 0.25, math.pi / 2 + 0.25, 2001)
xz, _ = ex.sample(tz)
ts = np.arange(math.ceil(tz[0] / coarse), math.floor(tz[-1] / coarse) + 1) * coarse
xs, _ = gr[f"RK4, dt = {coarse}"].sample(ts)
print("step ends:", ", ".join(f"{t:.1f}" for t in ts))
print("exact X − 1 there:", ", ".join(f"{d:.2e}" for d in ex.sample(ts)[0] - 1.0))

fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.8), constrained_layout=True)
a1.plot(tz, xz - 1.0, color="k", label="exact X − 1")
a1.plot(ts, xs - 1.0, "o", color="tab:red", label=f"RK4 step ends, dt = {coarse}")
a1.axhline(0.0, color="tab:gray", ls="--", lw=0.8, label="flange")
a1.set_xlabel("nondimensional time Λ [-]")
a1.set_ylabel("X − 1 [-]")
a1.set_title("step ends never see X > 1", fontsize=9)
a1.legend(fontsize=8)
half = math.pi / 2 - t_touch                     # half the contact duration
tzz = np.linspace(math.pi / 2 - 1.6 * half, math.pi / 2 + 1.6 * half, 801)
a2.plot(tzz, ex.sample(tzz)[0] - 1.0, color="k", label="exact X − 1")
a2.axhline(0.0, color="tab:gray", ls="--", lw=0.8)
for e in ex.events:
    if e.kind in ("contact_start", "contact_end") and tzz[0] <= e.t <= tzz[-1]:
        a2.axvline(e.t, color="tab:green", ls=":", label=e.kind)
a2.set_xlabel("nondimensional time Λ [-]")
a2.set_ylabel("X − 1 [-]")
a2.set_title(f"the located contact: 1e-9 deep, {2 * half:.1e} long", fontsize=9)
a2.legend(fontsize=8)
plt.show()

# %% [markdown]
# ## 4. Work-precision
#
# How much accuracy does each method buy per second of computing? The benchmark
# `benchmarks/work_precision.py` measures errors against the exact backend versus wall
# time on four cases (see `benchmarks/README.md`; its tables are in
# `benchmarks/results/work_precision.md`). If its figures are in `benchmarks/results/`,
# they are shown first; then a small version of the comparison on the contact case is
# computed here, on this machine.

# %%
results = Path("..") / "benchmarks" / "results"
pngs = sorted(results.glob("work_precision_*.png"))
md = results / "work_precision.md"
# The figures, each under its case's title in the report (the full tables are in the
# report itself: benchmarks/results/work_precision.md, the benchmarks page of the docs).
cases = {}
if md.exists():
    for line in md.read_text().splitlines():
        if line.startswith("### ("):
            cases[line[5]] = line[4:].strip()
if pngs:
    for png in pngs:
        case = png.stem.rsplit("_", 1)[-1]
        display(Markdown(f"**{cases.get(case, png.stem)}**"))
        display(Image(filename=str(png), width=720))
else:
    print(f"no benchmark results in {results.resolve()} (run benchmarks/work_precision.py); "
          "the small comparison below is all there is")

# %% tags=["gallery"]
def timed(fn, repeats=3):
    """Best-of wall time of fn() (the machine is shared: the minimum is the least noisy)."""
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


exact_mean = io.simulate(osc, t_end, backend="exact", record="stats").mean_flange_force()
tols = [1e-3, 1e-6, 1e-9, 1e-12, 1e-15] if not QUICK else [1e-3, 1e-6, 1e-9, 1e-15]
fracs = [10, 25, 50, 100, 200, 400] if not QUICK else [10, 25, 50, 100, 200]
t_contact = 2 * math.pi / osc.contact_frequency
wp = {"heyoka (tol)": [], "RK4 (steps per contact period)": []}
for tol in tols:
    io.simulate(osc, 10.0, tol=tol)  # compile (cached) outside the timing
    w, s = timed(lambda tol=tol: io.simulate(osc, t_end, record="stats", tol=tol))
    wp["heyoka (tol)"].append((tol, w, abs(s.mean_flange_force() / exact_mean - 1)))
for nfr in fracs:
    w, s = timed(lambda nfr=nfr: io.simulate(osc, t_end, record="stats", backend="rk4", dt=t_contact / nfr))
    wp["RK4 (steps per contact period)"].append((nfr, w, abs(s.mean_flange_force() / exact_mean - 1)))

fig, ax = plt.subplots(figsize=(8, 5))
for (name, pts), marker in zip(wp.items(), ["o", "s"], strict=True):
    _, w, e = zip(*pts, strict=True)
    ax.loglog(w, np.maximum(e, 1e-17), marker + "-", label=name)
    for p, wi, ei in pts:
        ax.annotate(f"{p:g}", (wi, max(ei, 1e-17)), textcoords="offset points", xytext=(4, 4), fontsize=8)
ax.set_xlabel("wall time per run [s]")
ax.set_ylabel("relative error of the mean flange force [-]")
ax.set_title(f"work-precision, contact case, t_end = {t_end:g} (zeros drawn at 1e-17)")
ax.legend()
plt.show()

# %% [markdown]
# heyoka reaches round-off level (~1e-14) at every tolerance from 1e-9 down, at a cost
# that hardly depends on the tolerance (the events dominate, not the steps). RK4's error
# falls irregularly with the step (the crossing errors partly cancel in the average) and,
# for the same wall time, stays several orders of magnitude above. (Single runs of a few
# milliseconds on a shared machine: the times are indicative; the benchmark script takes
# medians.) And on the stick and grazing cases above no step makes RK4 right: it has no
# stick, and it checks contacts only at step ends.
