# %% [markdown]
# # 07 · The model family: damping, static friction, rigid and Hertz flanges, run-out harmonics
#
# The paper's eq. 3 is one member of a family that `impactosc` simulates on the same
# event engine. In nondimensional form, with `X = x/L`, `Lambda = omega_n t`
# and primes for `d/dLambda`:
#
# $$X'' + 2\zeta X' + X + \beta\,\mathrm{sgn}(X') = \sum_i F_i\cos(\Omega_i\Lambda + \varphi_i) - \mathrm{flange}(X)$$
#
# | member | `Oscillator(...)` keyword | what changes |
# | --- | --- | --- |
# | viscous damping | `zeta=` | the term `2 zeta X'` (material and air damping of the tape span) |
# | static friction | `beta_static=` (`>= beta`) | the stick test and the breakaway use `beta_static`; slipping uses `beta` |
# | rigid flange | `flange="rigid", restitution=e` | an instantaneous impact `V -> -e V` at `abs(X) = 1`, rest against the wall |
# | power-law flange | `exponent=p` | the flange spring pushes back with `K d^p`, `d = abs(X) - 1` (`p = 1.5`: Hertz) |
# | run-out harmonics | `harmonics=[(F_i, Omega_i, phase_i), ...]` | the forcing is a sum of harmonics |
#
# `Oscillator(F, Omega, beta, K)` with no keyword is still exactly eq. 3, and the keywords
# combine freely (`exponent` goes with the spring flange, `restitution` with the rigid
# one). `TapeDrive` has the same family in SI units (`damping_ratio`, `static_friction`,
# `flange`, `flange_exponent`, `flange_stiffness`, `restitution`, `runout_harmonics`).
#
# This notebook shows one picture per member and checks one number of each against its
# closed form, derived here so that the notebook stands alone (the test suite holds every
# backend to the same references, `tests/family_reference.py`). The last section checks the
# energy identity, extended to the family, on one run per member.

# %%
import os

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full-size versions.
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"

import math
import time
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import display
from scipy.integrate import quad
from scipy.optimize import brentq

import impactosc as io

# The backend of every run, per member: heyoka (the default) and scipy run every member;
# exact the linear ones (not the Hertz flange); rk4 what needs no event location.
# Change a value here to see another backend give the same numbers.
BACKEND = {
    "damped": "heyoka",
    "static": "heyoka",
    "rigid": "heyoka",
    "hertz": "heyoka",
    "harmonics": "heyoka",
}
WALL = {}  # seconds of simulation per section, printed at the end

print("impactosc", io.__version__, "| quick mode" if QUICK else "| full mode")
print("backends:", BACKEND)

# %% [markdown]
# ## 1. Viscous damping: the damped Coulomb decay
#
# Let a mass go from rest at `X = 0.93`, with no forcing, and friction `beta` and damping
# `zeta` take its energy. Coulomb friction alone shrinks each swing by the same amount,
# `2 beta` (a straight-line envelope); viscous damping alone by the same *factor*,
# `exp(-zeta pi / w_d)` (an exponential envelope). Together, each half cycle between two
# turning points is a damped arc about the centre `c` that friction shifts (`c = +beta`
# while sliding down, `-beta` while sliding up), so the turning points follow
#
# $$X_{k+1} = c_k - (X_k - c_k)\,e^{-\zeta\pi/\omega_d}, \qquad t_{k+1} = t_k + \pi/\omega_d, \qquad \omega_d = \sqrt{1 - \zeta^2},$$
#
# until a turning point lands inside the static band `abs(X) <= beta_static` and the mass
# sticks there for good (the net force at rest is `-X`).

# %%
def damped_coulomb_turns(x0, beta, beta_static, zeta=0.0):
    """Turning points [(t_k, X_k)] of X'' + 2 zeta X' + X + beta sgn X' = 0 from rest at x0."""
    wd = math.sqrt(1.0 - zeta * zeta)
    half, decay = math.pi / wd, math.exp(-zeta * math.pi / wd)
    t, x, turns = 0.0, x0, []
    while abs(x) > beta_static:
        c = math.copysign(beta, x)  # friction pushes back against the slide towards 0
        x = c - (x - c) * decay
        t += half
        turns.append((t, x))
    return turns


# x0 = 0.93: with 0.95, friction alone would end exactly on the static threshold (a tie).
zeta, beta, x0, t_end = 0.05, 0.05, 0.93, 40.0
damped = io.Oscillator(F=0.0, Omega=0.0, beta=beta, K=1e4, zeta=zeta)
members_1 = {"Coulomb friction only": replace(damped, zeta=0.0),
             "viscous damping only": replace(damped, beta=0.0),
             "friction + damping": damped}
start = time.perf_counter()
runs_1 = {name: io.simulate(osc, t_end, x0, 0.0, backend=BACKEND["damped"]) for name, osc in members_1.items()}
WALL["1 damping"] = time.perf_counter() - start

sol_damped = runs_1["friction + damping"]
turns = damped_coulomb_turns(x0, beta, beta, zeta)
ev = sol_damped.events
print(sol_damped.summary())
print("events:", ", ".join(ev.kind))
print(f"closed form: {len(turns)} turning points, stuck at t = {turns[-1][0]:.10f}, X = {turns[-1][1]:+.10f}")
print(f"simulated  : {len(ev)} turning points, stuck at t = {ev.t[-1]:.10f}, X = {ev.x[-1]:+.10f}")
print(f"largest difference: {np.max(np.abs(ev.t - [t for t, _ in turns])):.1e} in t, "
      f"{np.max(np.abs(ev.x - [x for _, x in turns])):.1e} in X")

# %%
t = np.linspace(0.0, t_end, 4000)
fig, ax = plt.subplots(figsize=(9, 4))
colors = {"Coulomb friction only": "tab:blue", "viscous damping only": "tab:green", "friction + damping": "k"}
for name, sol in runs_1.items():
    x, _ = sol.sample(t)
    ax.plot(t, x, color=colors[name], lw=1.6 if name == "friction + damping" else 0.9, label=name)
t_coulomb = t[t <= runs_1["Coulomb friction only"].events.t[-1]]  # up to its stick
ax.plot(t_coulomb, x0 - 2 * beta * t_coulomb / math.pi, color="tab:blue", ls=":", lw=0.8,
        label="envelope x0 - 2 beta t / pi")
ax.plot(t, x0 * np.exp(-zeta * t), color="tab:green", ls=":", lw=0.8, label="envelope x0 exp(-zeta t)")
ax.plot(*zip(*turns, strict=True), "o", mfc="none", mec="tab:red", ms=8, label="closed-form turning points")
ax.axhspan(-beta, beta, color="0.85", zorder=0, label="static band |X| <= beta_static")
ax.set_ylim(-1, 1)
ax.set_xlabel("Lambda")
ax.set_ylabel("X")
ax.set_title(f"damped Coulomb decay (beta = {beta}, zeta = {zeta}): both envelopes at once, stuck after "
             f"{len(turns)} half cycles")
ax.legend(loc="upper right", fontsize=8, ncol=2)
plt.show()

# %% [markdown]
# Friction alone (blue) would keep the mass swinging for 9 half cycles with a linear
# envelope; damping alone (green) never stops it. Together, the swings shrink faster than
# either, and the mass sticks at the 6th turning point, where the closed form says.
#
# ## 2. Static friction above kinetic friction
#
# With `beta_static > beta` the stick test at a turning point compares the net force with
# the larger static level, while a slipping mass still feels only `beta`. The same Coulomb
# decay (now without damping: the recursion of section 1 with `zeta = 0`, turning points
# every `pi`, of sizes 0.75, 0.55, 0.35, 0.15, 0.05 from `X = 0.95` with `beta = 0.1`)
# therefore sticks at an **earlier turn**: at `t = 5 pi` when `beta_static = beta` (the
# classic case), at `t = 4 pi` when `beta_static = 2 beta` (the turning point `X = 0.15`
# is then inside the static band).
#
# The **breakaway** shows the other side. A mass stuck at `X = 0` under
# `F cos(Omega Lambda + phase)` is released when the forcing reaches `-beta_static`, at
# `Lambda = (arccos(-beta_static / F) - phase) / Omega`. At that instant the net force
# is `beta_static` but only `beta` opposes the slide, so the acceleration **jumps** from 0
# to `-(beta_static - beta)` and the mass leaves as `X = -(beta_static - beta) tau^2 / 2`
# (`tau` is the time since the release). With equal levels there is no jump: the
# acceleration grows from 0 with the forcing's slope `f'`, and `X = f' tau^3 / 6`.

# %%
start = time.perf_counter()
decays = {bs: io.simulate(io.Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4, beta_static=bs), 20.0, 0.95, 0.0,
                          backend=BACKEND["static"]) for bs in (0.1, 0.2)}
for bs, sol in decays.items():
    turns = damped_coulomb_turns(0.95, 0.1, bs)
    ev = sol.events
    print(f"beta_static = {bs}: stuck at t = {ev.t[-1] / math.pi:.12f} pi (closed form {turns[-1][0] / math.pi:g} pi), "
          f"X = {ev.x[-1]:+.12f} (closed form {turns[-1][1]:+.2f}); {len(ev)} events, the last {str(ev.kind[-1])!r}; "
          f"turning points off by at most {np.max(np.abs(ev.x - [x for _, x in turns])):.1e}")

F, Omega, phase, b_s = 1.0, 0.5, 1.5, 0.4
breakaway = {"beta_static = 0.4 > beta = 0.1": io.Oscillator(F, Omega, 0.1, 1e4, phase, beta_static=b_s),
             "beta_static = beta = 0.4": io.Oscillator(F, Omega, b_s, 1e4, phase)}
runs_2 = {name: io.simulate(osc, 6.0, 0.0, 0.0, backend=BACKEND["static"]) for name, osc in breakaway.items()}
WALL["2 static friction"] = time.perf_counter() - start

t_release = (math.acos(-b_s / F) - phase) / Omega
slope = -F * Omega * math.sin(Omega * t_release + phase)  # f' at the release
tau = np.logspace(-4, 0, 60)
for name, sol in runs_2.items():
    osc = breakaway[name]
    x_tau, _ = sol.sample(t_release + tau[:1])
    expected = -(b_s - osc.beta) * tau[0] ** 2 / 2 if osc.beta < b_s else slope * tau[0] ** 3 / 6
    print(f"{name}: released at {sol.events.t[0]:.15f} (closed form {t_release:.15f}); "
          f"X({tau[0]:g} after) = {x_tau[0]:.6e} (leading term {expected:.6e})")

# %%
fig, axd = plt.subplot_mosaic("AA;BC", figsize=(9, 7.5))  # fits the page column
axes = [axd["A"], axd["B"], axd["C"]]
ax = axes[0]
t = np.linspace(0.0, 20.0, 3000)
for (bs, sol), color in zip(decays.items(), ("tab:blue", "tab:red"), strict=True):
    x, _ = sol.sample(t)
    ax.plot(t / math.pi, x, color=color, label=f"beta_static = {bs}")
    ax.plot(*zip(*[(tk / math.pi, xk) for tk, xk in damped_coulomb_turns(0.95, 0.1, bs)], strict=True), "o",
            mfc="none", mec=color, ms=7)
    ax.axhline(bs, color=color, ls=":", lw=0.8)
    ax.axhline(-bs, color=color, ls=":", lw=0.8)
ax.set_xlabel("Lambda / pi")
ax.set_ylabel("X")
ax.set_title("decay with beta = 0.1: sticks at 5 pi or 4 pi\n(circles: closed form; dotted: static bands)")
ax.legend(fontsize=8)

ax = axes[1]
t = t_release + np.linspace(-0.4, 0.6, 2001)
for (name, sol), color in zip(runs_2.items(), ("tab:red", "tab:blue"), strict=True):
    osc = breakaway[name]
    x, v = sol.sample(t)
    acc = np.where(t > t_release, osc.acceleration(t, x, v, 0, -1), 0.0)  # stuck (0) before, slipping down after
    ax.plot(t - t_release, acc, color=color, label=name)
ax.axhline(-(b_s - 0.1), color="0.5", ls=":", lw=0.8)
ax.annotate("jump -(beta_static - beta)", (0.0, -(b_s - 0.1)), (0.05, -0.25), fontsize=8)
ax.set_xlabel("Lambda - Lambda_release")
ax.set_ylabel("X''")
ax.set_title("breakaway: the acceleration jumps\nonly when static > kinetic")
ax.legend(fontsize=8, loc="lower left")

ax = axes[2]
for (name, sol), color in zip(runs_2.items(), ("tab:red", "tab:blue"), strict=True):
    x, _ = sol.sample(t_release + tau)
    ax.loglog(tau, np.abs(x), "o", ms=3, color=color, label=name)
ax.loglog(tau, (b_s - 0.1) * tau**2 / 2, color="tab:red", lw=0.8, label="(beta_s - beta) tau^2 / 2")
ax.loglog(tau, abs(slope) * tau**3 / 6, color="tab:blue", lw=0.8, label="|f'| tau^3 / 6")
ax.set_xlabel("tau = Lambda - Lambda_release")
ax.set_ylabel("|X|")
ax.set_title("leaving the stick: tau^2 against tau^3")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()

# %% [markdown]
# ## 3. A rigid flange with restitution: impacts, chatter, rest and release
#
# With `flange="rigid"` the flange is a wall: at `abs(X) = 1` the velocity is reversed and
# scaled, `V -> -e V`, an event `impact` that loses `(1 - e^2) V^2 / 2` of energy. Under a
# constant push `p = F - 1` into the upper wall (`Omega = 0`, `F = 2`), each rebound is
# lower than the last: between impacts the mass flies an arc of the free equation, moving
# out about the centre `F + beta` and back about `F - beta`. Summing those arcs gives the
# impact times in closed form; they **accumulate** at a finite time `t_inf` (a Zeno point,
# infinitely many impacts in finite time). Near the end the flights are short and the
# speeds fall geometrically, by `rho = e sqrt((p - beta) / (p + beta))` per impact.
#
# No event loop can follow infinitely many impacts. The engine follows them until a local
# model predicts the remaining ones to 1e-12 in time, then **jumps** to the accumulation
# point (an event `chatter` whose `count` says how many impacts it followed one by one;
# the impulse, friction path and energy loss of the infinitely many rest are summed in
# closed form) and lets the mass rest on the wall (`contact_start`).

# %%
def rigid_chatter_series(F, beta, e, x0=0.0):
    """Impact times and speeds on the upper rigid wall under X'' + X + beta sgn X' = F, from rest at x0."""
    c_in, c_out = F - beta, F + beta  # arc centres moving towards the wall and away from it
    t = math.acos((1.0 - c_in) / (x0 - c_in))  # first arrival at X = 1
    u = abs(x0 - c_in) * math.sin(t)
    times, speeds = [t], [u]
    while True:
        w = e * u  # rebound speed
        t_up = math.atan2(w, c_out - 1.0)  # wall -> apex, about c_out
        apex_minus_1 = -w * w / ((c_out - 1.0) + math.hypot(c_out - 1.0, w))  # without cancellation
        u = math.sqrt(apex_minus_1 * (apex_minus_1 + 2.0 - 2.0 * c_in))  # apex -> wall, about c_in
        t_down = math.atan2(u, c_in - 1.0)
        if t_up + t_down < 1e-17 * t:
            return times, speeds
        t += t_up + t_down
        times.append(t)
        speeds.append(u)


F, beta, e = 2.0, 0.1, 0.8
chatter = io.Oscillator(F=F, Omega=0.0, beta=beta, K=1.0, flange="rigid", restitution=e)  # K is unused by a wall
start = time.perf_counter()
sol_chatter = io.simulate(chatter, 15.0, 0.0, 0.0, backend=BACKEND["rigid"])
WALL["3 rigid"] = time.perf_counter() - start

times, speeds = rigid_chatter_series(F, beta, e)
ev = sol_chatter.events
jump = ev[ev.kind == "chatter"][0]
imp = sol_chatter.impacts
hits = imp[imp.start == imp.end]  # impacts (zero duration); the last row is the rest on the wall
p = F - 1.0
rho = e * math.sqrt((p - beta) / (p + beta))
print(sol_chatter.summary())
print(f"closed form: t_inf = {times[-1]:.15f} ({len(times)} impacts until the flights vanish in double precision)")
print(f"simulated  : chatter at t = {jump.t:.15f} after {jump.count} impacts followed one by one "
      f"(difference {abs(jump.t - times[-1]):.1e})")
print(f"those {len(hits)} impact times are off the closed form by at most "
      f"{np.max(np.abs(hits.start - times[:len(hits)])):.1e}")
print(f"speed ratio of the last impacts {hits.entry_velocity[-1] / hits.entry_velocity[-2]:.6f}, "
      f"geometric limit rho = {rho:.6f}")
print(f"then at rest on the wall from {imp.start[-1]:.6f} to {imp.end[-1]:g}, wall force {imp.peak_force[-1]:.12f} "
      f"(the push F - 1 = {p:g})")

# %% [markdown]
# Under **harmonic** forcing the push on the wall changes sign. A slow forcing,
# `F cos(Omega Lambda + phase)` with `F = 2, Omega = 0.1, phase = -1` and
# `beta_static = 0.15`: from rest at `X = 0` the mass is pushed into the upper wall,
# chatters to rest on it, and stays while the net force `F cos(Omega Lambda + phase) - 1`
# stays above `-beta_static`. It leaves (`contact_end`) when the forcing falls to
# `1 - beta_static`, flies to the lower wall, chatters to rest there, and leaves it half a
# forcing period later: the releases are at
# `Lambda_k = (arccos((1 - beta_static) / F) + k pi - phase) / Omega`.

# %%
Omega, phase, b_s = 0.1, -1.0, 0.15
rocking = io.Oscillator(F=F, Omega=Omega, beta=beta, K=1.0, phase=phase, flange="rigid", restitution=e,
                        beta_static=b_s)
t_end_3 = (1.0 if QUICK else 3.0) * 2 * math.pi / Omega
start = time.perf_counter()
sol_rocking = io.simulate(rocking, t_end_3, 0.0, 0.0, backend=BACKEND["rigid"])
WALL["3 rigid"] += time.perf_counter() - start

ev = sol_rocking.events
releases = ev.t[ev.kind == "contact_end"]
expected = (math.acos((1.0 - b_s) / F) + math.pi * np.arange(len(releases)) - phase) / Omega
print(sol_rocking.summary())
print("counts:", {k: n for k, n in sol_rocking.counts.items() if n})
print("chatter events (time, side, impacts followed):",
      [(round(float(c.t), 4), int(c.side), int(c.count)) for c in ev[ev.kind == "chatter"]])
print(f"releases at {np.round(releases, 6)}; closed form {np.round(expected, 6)}; "
      f"largest difference {np.max(np.abs(releases - expected)):.1e}")

# %% [markdown]
# **About warnings from heyoka.** If lines such as `[heyoka] [warning] polynomial root
# finding during event detection failed due to too many iterations` appear under the cell
# above, they come from heyoka's C++ core (its own log on the standard error, not Python's
# `warnings`). They are printed while the mass chatters to rest on a wall: the flights
# between impacts shrink geometrically, and on such a short piece the Taylor polynomial of
# a guard has roots so close together that heyoka's root isolation stops at its iteration
# limit and says so. They are shown, not hidden, because they are real; what matters is
# whether the run is still right, and the cell checks it against the closed form: the
# releases printed above agree with `Lambda_k` to the largest difference shown.

# %% tags=["gallery"]
fig, axes = plt.subplots(2, 1, figsize=(9, 8), gridspec_kw={"height_ratios": [1, 1.2]})
ax = axes[0]
ax.semilogy(times, speeds, "-", color="0.6", lw=0.8, label="closed form (arc series)")
ax.semilogy(hits.start, hits.entry_velocity, "o", ms=4, color="tab:blue",
            label=f"simulated impacts ({len(hits)}, followed one by one)")
ax.axvline(jump.t, color="tab:red", lw=1.0, label=f"chatter: jump to t_inf = {jump.t:.6f}")
ax.axvspan(jump.t, 15.0, color="tab:red", alpha=0.08, label="at rest on the wall")
ax.set_xlim(times[0] - 0.3, times[-1] + 0.6)
ax.set_ylim(1e-17, 3)
ax.set_xlabel("Lambda")
ax.set_ylabel("impact speed |V|")
ax.set_title(f"constant push, e = {e}: impacts accumulate at a finite time")
ax.legend(fontsize=8, loc="lower left")
inset = ax.inset_axes([0.12, 0.45, 0.4, 0.4])  # the same impacts against the time left to t_inf
left = times[-1] - np.array(times)
resolved = left > 1e-12 * times[-1]  # closer to t_inf, the difference of times is rounding
inset.loglog(left[resolved], np.array(speeds)[resolved], "-", color="0.6", lw=0.8)
inset.loglog(times[-1] - hits.start, hits.entry_velocity, "o", ms=2.5, color="tab:blue")
inset.set_xlabel("t_inf - Lambda", fontsize=8)
inset.set_ylabel("|V|", fontsize=8)
inset.tick_params(labelsize=7)
inset.set_title("speed ~ time left (geometric)", fontsize=8)

ax = axes[1]
t = np.linspace(0.0, t_end_3, 6000)
x, _ = sol_rocking.sample(t)
ax.plot(t, x, color="k", lw=1.0, label="X")
ax.plot(t, rocking.forcing(t) / F, color="tab:orange", lw=0.8, ls="--", label="forcing / F")
rests = sol_rocking.impacts[sol_rocking.impacts.end > sol_rocking.impacts.start]
for i, r in enumerate(rests):
    ax.axvspan(r.start, r.end, color="tab:red", alpha=0.12, label="at rest on a wall" if i == 0 else None)
chat = ev[ev.kind == "chatter"]
ax.plot(chat.t, chat.x, "v", color="tab:red", ms=8, label="chatter (jump)")
ax.plot(releases, ev.x[ev.kind == "contact_end"], "^", color="tab:green", ms=8, label="release")
ax.plot(expected, ev.x[ev.kind == "contact_end"], "x", color="k", ms=9, label="closed-form release")
ax.set_xlabel("Lambda")
ax.set_ylabel("X")
ax.set_ylim(-1.15, 1.75)
ax.set_yticks([-1, -0.5, 0, 0.5, 1])
ax.set_title(f"harmonic forcing F = {F}, Omega = {Omega}: chatter, rest, release, wall to wall")
ax.legend(fontsize=8, loc="upper center", ncol=4)
fig.tight_layout()
plt.show()

# %% [markdown]
# ## 4. A power-law (Hertz) flange against the linear spring
#
# The paper's flange is a linear spring `K d` on the penetration `d = abs(X) - 1`. A
# rounded tape edge pressed into a flat flange is closer to a Hertz contact, `K d^1.5`
# (`exponent=1.5`; `TapeDrive(flange_exponent=1.5, flange_stiffness=k0)` takes `k0` in
# N/m^1.5). With the same `K`, the Hertz law is softer below `d = 1`, so a contact goes
# deeper, lasts longer and peaks at a lower force. It is also nonlinear: its duration
# shrinks with the impact speed (about as `v^(-1/5)`), while the linear spring's stays
# close to `pi / sqrt(1 + K)` whatever the speed.
#
# The check: a free mass (`F = beta = zeta = 0`) leaves `X = 0` at speed `v0 = 1.5` and
# hits the upper flange at speed `sqrt(v0^2 - 1)`. Energy `v0^2 / 2` is conserved, so
#
# * linear: the contact is an arc of frequency `w = sqrt(1 + K)` about `c = K / (1 + K)`:
#   duration `2 atan2(v_in, w (1 - c)) / w`, peak `d = c - 1 + hypot(1 - c, v_in / w)`;
# * power law: the peak solves `(1 + d)^2 / 2 + K d^(p+1) / (p+1) = v0^2 / 2`, and the
#   duration is `2 int_0^d_max dd / V(d)` with `V` from the energy (a quadrature).

# %%
def linear_contact(v0, K):
    """(duration, peak penetration) of the linear-spring contact of the free oscillator from X = 0."""
    v_in, w, c = math.sqrt(v0 * v0 - 1.0), math.sqrt(1.0 + K), K / (1.0 + K)
    return 2.0 * math.atan2(v_in, w * (1.0 - c)) / w, c - 1.0 + math.hypot(1.0 - c, v_in / w)


def power_law_contact(v0, K, p):
    """(duration, peak penetration) of the K d^p contact, from energy conservation."""
    energy = 0.5 * v0 * v0

    def potential(d):
        return 0.5 * (1.0 + d) ** 2 + K * d ** (p + 1.0) / (p + 1.0)

    d_max = brentq(lambda d: potential(d) - energy, 0.0, v0, xtol=1e-300, rtol=1e-15)
    # d = d_max (1 - s^2) removes the square-root singularity of 1 / V at d_max.
    half, _ = quad(lambda s: 2.0 * d_max * s / math.sqrt(2.0 * (energy - potential(d_max * (1.0 - s * s)))),
                   0.0, 1.0, epsabs=0.0, epsrel=1e-13, limit=200)
    return 2.0 * half, d_max


K, v0 = 1e4, 1.5
laws = {"linear, p = 1": io.Oscillator(0.0, 0.0, 0.0, K),
        "Hertz, p = 1.5": io.Oscillator(0.0, 0.0, 0.0, K, exponent=1.5)}
start = time.perf_counter()
runs_4 = {name: io.simulate(osc, 1.2, 0.0, v0, backend=BACKEND["hertz"]) for name, osc in laws.items()}
WALL["4 Hertz"] = time.perf_counter() - start
contacts = {}
for name, sol in runs_4.items():
    osc, c = laws[name], sol.impacts[0]
    contacts[name] = c
    duration, d_max = linear_contact(v0, K) if osc.exponent == 1.0 else power_law_contact(v0, K, osc.exponent)
    print(f"{name:15s}: duration {c.end - c.start:.12f} (closed form {duration:.12f}), "
          f"peak penetration {c.peak_penetration:.12f} ({d_max:.12f}), peak force {c.peak_force:8.4f} "
          f"(K d_max^p = {K * d_max**osc.exponent:8.4f}), exit speed {c.exit_velocity:+.12f} "
          f"(-{math.sqrt(v0 * v0 - 1):.12f})")

# %%
fig, axes = plt.subplots(2, 1, figsize=(9, 7.5))
d = np.linspace(0.0, 0.034, 300)
for (name, osc), color in zip(laws.items(), ("tab:blue", "tab:red"), strict=True):
    c = contacts[name]
    axes[0].plot(d, K * d**osc.exponent, color=color, lw=1, label=f"{name}: K d^p")
    tc = np.linspace(c.start, c.end, 41)
    x, _ = runs_4[name].sample(tc)
    axes[0].plot(osc.flange_penetration(x), osc.flange_force(x), "o", ms=3, color=color,
                 label="states of the run in contact")
    axes[0].plot(c.peak_penetration, c.peak_force, "*", ms=14, color=color, mec="k")
    tc = np.linspace(c.start, c.end, 400)
    x, _ = runs_4[name].sample(tc)
    axes[1].plot(tc - c.start, osc.flange_penetration(x) * 1e3, color=color,
                 label=f"{name}: {c.end - c.start:.4f} long, peak force {c.peak_force:.1f}")
axes[0].set_xlabel("penetration d = |X| - 1")
axes[0].set_ylabel("flange force (units of k L)")
axes[0].set_title(f"force against penetration, K = {K:g} (stars: peaks of the contact)")
axes[0].legend(fontsize=8)
axes[1].set_xlabel("Lambda - contact start")
axes[1].set_ylabel("penetration d [1e-3 L]")
axes[1].set_title(f"one contact at entry speed {math.sqrt(v0 * v0 - 1):.3f}: Hertz goes deeper, for longer")
axes[1].legend(fontsize=8)
fig.tight_layout()
plt.show()

# %% [markdown]
# ## 5. Run-out harmonics: a tape drive whose third harmonic resonates
#
# A real reel's run-out is not a pure cosine: a warped flange or an eccentric hub adds
# harmonics at 2, 3, ... times the reel frequency. `TapeDrive(runout_harmonics=[(n,
# fraction, phase), ...])` adds them to the Fig. 6 run-out, and the model's forcing becomes
# `sum_i F_i cos(Omega_i Lambda + phase_i)` (`Oscillator.from_harmonics` builds one from
# the triples directly).
#
# The drive: alternative B of notebooks 03 and 05 (plate bending, `f_n = 65 Hz`), with a
# frictionless air film (`friction=0`), 5% damping (`damping_ratio=0.05`), a 1 mm
# clearance, mid pack, and run-out harmonics of 20% at twice and 10% at three times the
# reel frequency. At 4.75 m/s the reel turns at 21.6 Hz, so the **third** harmonic sits
# on the tape-span resonance (`3 Omega = 1.0`) and is amplified about `1 / (2 zeta) = 10`
# times, while the fundamental is barely amplified.
#
# The check: without friction and contact the model is linear, so its steady state is the
# sum of each harmonic's response, `X = sum_i Re[F_i e^{i(Omega_i Lambda + phase_i)} /
# (1 - Omega_i^2 + 2 i zeta Omega_i)]`. Started on it, the run must stay on it. Then the
# same drive with a 200 um clearance: the fundamental alone would stay 66 um clear of the
# flanges, but with the harmonics the tape hits the upper one once per reel turn.

# %%
def steady_state(osc, t):
    """Steady-state (X, V) of X'' + 2 zeta X' + X = sum_i F_i cos(Omega_i t + phase_i) (no friction, no contact)."""
    z = sum(F_i * np.exp(1j * (Om_i * np.asarray(t) + ph_i)) / (1.0 - Om_i**2 + 2j * osc.zeta * Om_i)
            for F_i, Om_i, ph_i in osc.terms)
    dz = sum(1j * Om_i * F_i * np.exp(1j * (Om_i * np.asarray(t) + ph_i)) / (1.0 - Om_i**2 + 2j * osc.zeta * Om_i)
             for F_i, Om_i, ph_i in osc.terms)
    return z.real, dz.real


drive = io.TapeDrive(speed=4.75, pack_diameter=0.07, bending="out-of-plane", friction=0.0, clearance=1e-3,
                     damping_ratio=0.05, runout_harmonics=[(2, 0.2, 0.3), (3, 0.1, 0.0)])
osc = drive.oscillator()
print(f"f_n = {drive.natural_frequency_hz:.2f} Hz, reel {drive.omega_r / (2 * math.pi):.2f} Hz, "
      f"run-out {drive.runout * 1e6:.1f} um")
L = drive.length_scale
for n, (F_i, Om_i, ph_i) in zip((1, 2, 3), osc.terms, strict=True):
    gain = 1.0 / abs(1.0 - Om_i**2 + 2j * osc.zeta * Om_i)
    print(f"harmonic {n}: F_i = {F_i:.4f}, Omega_i = {Om_i:.4f}, phase {ph_i:g}; run-out {F_i * L * 1e6:5.1f} um, "
          f"amplified {gain:5.2f} times: {gain * F_i * L * 1e6:5.1f} um of response")

turns = 3 if QUICK else 12
t_end_5 = turns * 2 * math.pi / osc.Omega
x0, v0 = (float(s) for s in steady_state(osc, 0.0))
tight = drive.replace(clearance=200e-6)
start = time.perf_counter()
sol_wide = io.simulate(osc, t_end_5, x0, v0, backend=BACKEND["harmonics"])
# The same state in SI units, on the tighter guide: X scales with 1 / L.
sol_tight = io.simulate(tight.oscillator(), t_end_5, x0 * L / tight.length_scale, v0 * L / tight.length_scale,
                        backend=BACKEND["harmonics"])
WALL["5 harmonics"] = time.perf_counter() - start

lam = np.linspace(0.0, t_end_5, 6000)
x_sim, _ = sol_wide.sample(lam)
x_ss, _ = steady_state(osc, lam)
fundamental = replace(osc, harmonics=())
x_fund, _ = steady_state(fundamental, lam)
print(f"1 mm clearance: {sol_wide.summary()}")
print(f"  largest |x_sim - x_closed form| = {np.max(np.abs(x_sim - x_ss)) * L * 1e6:.1e} um over {turns} reel turns; "
      f"amplitude {np.max(np.abs(x_ss)) * L * 1e6:.1f} um "
      f"(fundamental alone {np.max(np.abs(x_fund)) * L * 1e6:.1f} um)")
print(f"200 um clearance: {sol_tight.contact_entries(1)} upper / {sol_tight.contact_entries(-1)} lower contacts, "
      f"mean flange force {sol_tight.mean_flange_force() * tight.force_scale * 1e6:.3g} uN, "
      f"peak {sol_tight.max_flange_force() * tight.force_scale * 1e3:.3g} mN")

# %%
t_ms = drive.lambda_to_seconds(lam) * 1e3
fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
axes[0].plot(t_ms, osc.forcing(lam) * L * 1e6, color="tab:orange", label="run-out with harmonics (forcing F_a(t)/k)")
axes[0].plot(t_ms, fundamental.forcing(lam) * L * 1e6, color="0.5", ls=":", label="fundamental only")
axes[0].set_ylabel("run-out [um]")
axes[0].set_title(f"tape drive at {drive.speed} m/s: reel {drive.omega_r / (2 * math.pi):.1f} Hz, "
                  f"tape span f_n = {drive.natural_frequency_hz:.1f} Hz, harmonics 2 (20%) and 3 (10%)")
axes[0].legend(fontsize=8, loc="upper right")
axes[1].plot(t_ms, x_sim * L * 1e6, color="k", label="simulated, 1 mm clearance (no contact)")
axes[1].plot(t_ms[::40], x_ss[::40] * L * 1e6, "o", mfc="none", color="tab:red", ms=4,
             label="closed-form steady state")
axes[1].plot(t_ms, x_fund * L * 1e6, color="0.5", ls=":", label="response to the fundamental alone")
axes[1].set_ylabel("tape position x [um]")
axes[1].legend(fontsize=8, loc="upper right")
x_tight, _ = sol_tight.sample(lam)
Lt = tight.length_scale * 1e6
axes[2].plot(t_ms, x_tight * Lt, color="k", label="simulated, 200 um clearance")
for side in (-1, 1):
    axes[2].axhline(side * Lt, color="tab:red", ls="--", lw=0.8, label="flanges" if side == 1 else None)
axes[2].plot(t_ms, x_fund * L * 1e6, color="0.5", ls=":", label="fundamental alone (closed form)")
starts = sol_tight.impacts.start
axes[2].plot(drive.lambda_to_seconds(starts) * 1e3, sol_tight.impacts.side * Lt, "v", color="tab:red", ms=6,
             label="contact")
axes[2].set_ylabel("tape position x [um]")
axes[2].set_xlabel("time t [ms]")
axes[2].legend(fontsize=8, loc="lower right", ncol=2)
fig.tight_layout()
plt.show()

# %% [markdown]
# The third harmonic carries a tenth of the run-out but almost as much of the response as
# the fundamental: a reel that turns at a third of the tape-span resonance can push the
# tape into a flange that the pure cosine of the paper's model would never reach.
#
# ## 6. The energy identity, for every member
#
# With the mechanical energy `E = V^2/2 + X^2/2 + K d^(p+1)/(p+1)` (tape spring, flange
# spring, kinetic; no flange term for a rigid wall), the family's equation of motion gives,
# integrated over a run,
#
# $$E_\text{end} - E_\text{start} = \underbrace{\int V \sum_i F_i\cos(\Omega_i\Lambda + \varphi_i)\,d\Lambda}_{\text{forcing work}}
#   - \underbrace{\beta \int |V|\,d\Lambda}_{\text{friction}} - \underbrace{2\zeta\int V^2\,d\Lambda}_{\text{damping}}
#   - \underbrace{\sum_\text{impacts} \tfrac{1 - e^2}{2} V^2}_{\text{impact loss}} .$$
#
# Every backend integrates the right-hand terms along with the motion, independently of
# `E` (the engine sums the impact losses, including the closed-form remainder of a
# chatter), and `Solution.energy_balance()` returns them with the residual. One run per
# member: the damped decay of section 1, the breakaway with static friction of section 2,
# the rigid flange under harmonic forcing of section 3, a forced and rubbing Hertz flange
# (`F = 0.5, Omega = 1.1, beta = 0.01`: the free contact of section 4 conserves energy, so
# every term of it is zero), and the tape drive with run-out harmonics on the 200 um guide
# of section 5 (nondimensional, in units of `k L^2`).

# %%
hertz_forced = io.Oscillator(0.5, 1.1, 0.01, K, exponent=1.5)
start = time.perf_counter()
sol_hertz = io.simulate(hertz_forced, 40.0 if QUICK else 400.0, 0.95, 0.0, backend=BACKEND["hertz"])
WALL["6 energy"] = time.perf_counter() - start
energy_runs = {
    "viscous damping\n(section 1)": sol_damped,
    "static friction\n(section 2)": runs_2["beta_static = 0.4 > beta = 0.1"],
    "rigid flange, e = 0.8\n(section 3)": sol_rocking,
    "Hertz flange, forced\n(p = 1.5)": sol_hertz,
    "run-out harmonics\n(section 5, 200 um)": sol_tight,
}
terms = ["forcing work", "- friction", "- damping", "- impact loss", "energy change"]
rows = []
for name, sol in energy_runs.items():
    bal = sol.energy_balance()
    rows.append({"run": name.replace(chr(10), " "), "forcing": bal["forcing_work"], "friction": bal["friction_work"],
                 "damping": bal["damping_work"], "impacts": bal["impact_loss"],
                 "E change": bal["energy_end"] - bal["energy_start"],
                 "residual / scale": f"{bal['residual'] / bal['scale']:.1e}"})
display(pd.DataFrame(rows).set_index("run").round(5))

# %%
fig, axes = plt.subplots(2, 3, figsize=(9, 8))
axes = axes.ravel()
for ax in axes[len(energy_runs):]:
    ax.axis("off")
colors = ["tab:orange", "tab:blue", "tab:green", "tab:red", "k"]
for ax, (name, sol) in zip(axes[:len(energy_runs)], energy_runs.items(), strict=True):
    bal = sol.energy_balance()
    values = [bal["forcing_work"], -bal["friction_work"], -bal["damping_work"], -bal["impact_loss"],
              bal["energy_end"] - bal["energy_start"]]
    ax.bar(range(5), values, color=colors)
    ax.axhline(0.0, color="0.3", lw=0.6)
    ax.set_xticks(range(5), terms, rotation=60, ha="right", fontsize=8)
    ax.set_title(f"{name}\nresidual {bal['residual'] / bal['scale']:.0e} of the largest term", fontsize=9)
axes[0].set_ylabel("energy (units of k L^2)")
axes[3].set_ylabel("energy (units of k L^2)")
fig.suptitle("energy change = forcing work - friction - damping - impact loss, run by run")
fig.tight_layout()
plt.show()

# %% [markdown]
# In every run the four transfers add up to the change of energy, to rounding: the check
# that a new member's terms are all accounted for (the test suite runs it on random
# members, `tests/test_family.py`).

# %%
for section, seconds in WALL.items():
    print(f"section {section:20s}: {seconds:6.2f} s of simulation")
print(f"total: {sum(WALL.values()):.2f} s ({'quick' if QUICK else 'full'} mode)")

# %% [markdown]
# **Where next.** The event engine, the stick test and the guards are the same for every
# member: `docs/theory.md` (the *Theory* page of the documentation) states them, and
# `impactosc/model/_rule.py` (the switching physics, once), `impactosc/engine/_driver.py`
# and `impactosc/engine/_chatter.py` implement them. Notebook 01 introduces
# `simulate` and the tables, notebook 02 compares the backends.
