# %% [markdown]
# # 10 · Your own system: piecewise-smooth ODEs of any dimension
#
# `impactosc` simulates the paper's oscillator, but its engine is a solver for any
# piecewise-smooth system: *modes*, each a smooth vector field, and *guards*, each a
# switching surface `h(y, t; p) = 0` with a crossing direction, the modes in which it is
# armed, the next mode and a reset map. You write them once, as expressions (heyoka's
# expression system: `symbols` gives named variables), and every backend and analysis reads
# the same definition:
#
# | you write | `impactosc` |
# | --- | --- |
# | `HybridMode(name, {state: rate, ...}, entry=[...], integrands={...})` | a vector field; entry conditions `c >= 0`; integrals carried as extra states |
# | `Guard(name, h, direction, armed=..., to=..., reset={state: value})` | a switching surface and its transition |
# | `stick_slip(prefix, v, force, kinetic, static, rates=...)` | Coulomb friction: two slip modes and a Filippov stick mode with its release guards |
# | `HybridSystem(states, parameters, modes, guards, integrals=..., period=...)` | the system, checked at construction |
#
# `impactosc.simulate(system, t_end, state0, backend=...)` runs it: `"heyoka"` compiles one
# Taylor integrator per system (once per process, reused for every run and parameter value)
# and locates every guard on each step's Taylor polynomial; `"scipy"` runs one `solve_ivp`
# per smooth piece, the independent cross-check. Each guard's extrema are watched, so a
# guard that touches zero without crossing (a grazing) is recorded rather than missed, and
# an accumulation of events ends with status 2 and the accumulation time.

# %%
import os

# Quick by default (CI); IMPACTOSC_QUICK=0 runs the full-size versions.
QUICK = os.environ.get("IMPACTOSC_QUICK", "1") == "1"

import math
import time

import heyoka as hy
import matplotlib.pyplot as plt
import numpy as np

import impactosc as io
from impactosc import Guard, HybridMode, HybridSystem, stick_slip, symbols
from impactosc.dynamics import HybridMap, periodic_orbit_of
from impactosc.model.hybrid import oscillator_system

print("impactosc", io.__version__, "| quick mode" if QUICK else "| full mode")

# %% [markdown]
# ## 1. The bouncing ball, and its Zeno time
#
# `x'' = -g` in flight; at `x = 0` falling, `v -> -e v`. Dropped from `h`, the ball lands at
# `t_1 = sqrt(2 h / g)`, and each bounce lasts `2 v_k / g` with `v_k = e^k sqrt(2 g h)`: a
# geometric series whose sum, the time at which the bounces accumulate, is
#
# $$T_\infty = \sqrt{2h/g}\,\left(1 + \frac{2e}{1 - e}\right).$$
#
# No integrator can step through infinitely many events: the run stops with status 2 when
# the intervals shrink geometrically and little time is left, and estimates `T_inf`.

# %%
x, v, g, e = symbols("x v g e")
ball = HybridSystem(
    states="x v",
    parameters={"g": 9.81, "e": 0.8},
    modes=[HybridMode("flight", {x: v, v: -g})],
    guards=[Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})],
    name="bouncing ball",
)
sol = io.simulate(ball, 10.0, [1.0, 0.0])
zeno = math.sqrt(2 / 9.81) * (1 + 2 * 0.8 / (1 - 0.8))
print(sol)
print(sol.message)
print(f"accumulation time {sol.accumulation_time:.15f}, closed form {zeno:.15f}")
sol.event_table().head()

# %%
t = np.linspace(0.0, sol.t_final, 2000)
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(t, sol.sample(t)[:, 0])
ax.plot(sol.event_times(), np.zeros(len(sol.events)), "k|", ms=8, label="impacts")
ax.axvline(zeno, color="C3", ls="--", label=r"$T_\infty$ (closed form)")
ax.set(xlabel="t", ylabel="x", title="bouncing ball: events pile up at the Zeno time")
ax.legend()
plt.show()

# %% [markdown]
# ## 2. A dry-friction oscillator that sticks
#
# `x'' + x = A cos(w t) - mu sgn(x')`: between the sticks the mass slips one way or the
# other; at `v = 0` it sticks while `abs(A cos(w t) - x) <= mu`, and is released when the
# force reaches the friction level. `stick_slip` writes those three modes and four guards.

# %%
A, w, mu = symbols("A w mu")
modes, guards = stick_slip("m", v, A * hy.cos(w * hy.time) - x, mu, rates={x: v})
friction = HybridSystem("x v", {"A": 0.4, "w": 0.3, "mu": 0.3}, modes, guards, name="dry friction")
print(friction.mode_names, friction.guard_names)
fr = io.simulate(friction, 60.0, [0.2, 0.0])
# The same equation is a member of the built-in family (no flanges): its closed-form engine agrees.
ref = io.simulate(io.Oscillator(F=0.4, Omega=0.3, beta=0.3, gap_upper=None, gap_lower=None), 60.0, 0.2, 0.0,
                  backend="exact")
print("largest event-time difference from the closed-form engine:",
      np.abs(fr.event_times() - ref.events["t"]).max())

t = np.linspace(0.0, 60.0, 3000)
xs = fr.sample(t)[:, 0]
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(t, xs)
for start, end in zip(fr.event_times()[:-1], fr.event_times()[1:], strict=True):
    mode = [ev.mode_after for ev in fr.events if ev.t == start][-1]
    if mode == "m0":
        ax.axvspan(start, end, color="0.85")
ax.set(xlabel="t", ylabel="x", title="dry friction: stuck phases shaded")
plt.show()

# %% [markdown]
# ## 3. The paper's eq. 3, written as a user system
#
# `oscillator_system(osc)` writes any member of the built-in family with spring or rigid
# flanges as a `HybridSystem`: three regions (free, upper, lower flange), each with the
# `stick_slip` modes, and the guards into and out of the flanges; the flange impulse is an
# integral. On the contact case (`F=0.5, Omega=1.1, beta=0.01, K=1e4`) it meets the built-in
# closed-form engine event by event.

# %% tags=["gallery"]
osc = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
eq3 = oscillator_system(osc)
user = io.simulate(eq3, 400.0, [0.95, 0.0])
exact = io.simulate(osc, 400.0, backend="exact")
print(len(user.events), "events; largest event-time difference:",
      np.abs(user.event_times() - exact.events["t"]).max())
print("flange impulse:", user.integrals["Q"], "built-in:", exact.flange_impulse())

runs = 5 if QUICK else 25
for name, run in (("user system", lambda: io.simulate(eq3, 400.0, [0.95, 0.0])),
                  ("built-in heyoka", lambda: io.simulate(osc, 400.0))):
    run()  # compiled and cached: the timing is of the runs
    t0 = time.perf_counter()
    for _ in range(runs):
        run()
    print(f"{name}: {(time.perf_counter() - t0) / runs * 1e3:.2f} ms per run")

t = np.linspace(0.0, 60.0, 4000)
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(t, user.sample(t)[:, 0], label="user system (heyoka)")
ax.plot(exact.events["t"][exact.events["t"] < 60], exact.events["x"][exact.events["t"] < 60], "k.",
        label="built-in exact engine: events")
ax.axhline(1, color="0.5", lw=0.8)
ax.axhline(-1, color="0.5", lw=0.8)
ax.set(xlabel="t", ylabel="X", title="eq. 3 as a user system, against the closed-form engine")
ax.legend(loc="lower right")
plt.show()

# %% [markdown]
# ## 4. Periodic orbits and Floquet multipliers of a user system
#
# `HybridMap(system)` is the stroboscopic map over the forcing period with its Jacobians:
# on each smooth piece the state-transition matrix from heyoka's variational equations,
# at each event the saltation matrix `S = R + (f+ - R f-) n^T / (n . f- + h_t)` from the
# symbolic derivatives of the definition. `periodic_orbit_of` finds a fixed point by
# Newton's method. On a damped member of the family it finds the built-in shooting's orbit.

# %%
damped = io.Oscillator(F=1.5, Omega=0.8, beta=0.05, K=100.0, zeta=0.1)
builtin = io.dynamics.periodic_orbit(damped)
orbit = periodic_orbit_of(HybridMap(oscillator_system(damped)), [builtin.x + 1e-3, builtin.v])
print("user system:", orbit.z, "multipliers", orbit.multipliers)
print("built-in:   ", [builtin.x, builtin.v], "multipliers", builtin.multipliers)
print("events of one period:", [s[0] for s in orbit.signature])
