"""Speed of the dynamics toolkit: bifurcation diagram, periodic orbit, Lyapunov, contact onset.

Run: ``.venv/bin/python benchmarks/dynamics_speed.py [--quick] [--workers N] [--out DIR]``.
Prints a markdown table and writes it to ``DIR/dynamics_speed.md`` (default
``benchmarks/results``; ``--quick`` writes ``benchmarks/results/quick``).

Targets:

* a bifurcation diagram of 400 parameter values x (200 transient + 50 recorded forcing
  periods) of the contact case in under 60 s on 2 cores (wall time, process pool start-up
  and heyoka compilation in the workers included);
* a periodic orbit with its multipliers in under 50 ms after compile.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import load_average, timed  # noqa: E402

import impactosc as io  # noqa: E402
from impactosc import dynamics as dy  # noqa: E402

CONTACT = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
DEN_HARTOG = io.Oscillator(F=0.3, Omega=0.8, beta=0.05, K=1e4)


def bifurcation_rows(quick: bool, workers: int):
    n_values, n_tr, n_rec = (12, 10, 3) if quick else (400, 200, 50)
    values = np.linspace(0.05, 1.0, n_values)
    rows = []
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # heyoka, then the exact backend (eq. 3 runs its compiled event loop, samples included).
    for backend, continuation in (("heyoka", "none"), ("heyoka", "both"), ("exact", "none"), ("exact", "both")):
        t = time.perf_counter()
        kw = dict(transient_periods=n_tr, record_periods=n_rec, continuation=continuation, progress=False,
                  backend=backend)
        if quick:  # the smoke test: no process start-up
            ds = dy.bifurcation_diagram(CONTACT, "F", values, executor="serial", **kw)
            where = "serial"
        else:
            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
                ds = dy.bifurcation_diagram(CONTACT, "F", values, executor=pool, **kw)
            where = f"{workers} worker processes (start-up included)"
        wall = time.perf_counter() - t
        ok = int((ds["status"].values == 0).sum())
        runs = ds["status"].size
        rows.append((f"bifurcation diagram ({backend}), contact case over F, {n_values} values x "
                     f"({n_tr} + {n_rec}) periods, continuation={continuation}, {where}",
                     f"{wall:.2f} s", f"{ok}/{runs} runs ok; {wall / runs * workers * 1e3:.0f} ms per run per worker"))
    return rows


def orbit_rows(quick: bool):
    reps = 1 if quick else 21
    dy.periodic_orbit(CONTACT, 3, transient_periods=10)  # compile heyoka, warm the caches
    guess_orbit = dy.periodic_orbit(CONTACT, 3, transient_periods=200)
    dh = dy.periodic_orbit(DEN_HARTOG, 1, transient_periods=200)
    # A guess off the orbit by 1e-3, as from a short transient or a neighbouring parameter.
    guess = (guess_orbit.x + 1e-3, guess_orbit.v - 1e-3)
    rows = []
    med, n, orb = timed(lambda: dy.periodic_orbit(CONTACT, 3, guess=guess), reps, 60.0, 60.0)
    rows.append(("periodic orbit (period 3, contact case) from a guess 1e-3 off: Newton + multipliers + events",
                 f"{med * 1e3:.1f} ms", f"best {timed.best * 1e3:.1f} ms of {n}; {orb.iterations} iterations, "
                 f"|mu| = {orb.spectral_radius:.4f} ({orb.stability})"))
    med, n, orb = timed(lambda: dy.periodic_orbit(DEN_HARTOG, 1, guess=(dh.x + 1e-3, dh.v - 1e-3)), reps, 60.0, 60.0)
    rows.append(("periodic orbit (Den Hartog, period 1) from a guess 1e-3 off", f"{med * 1e3:.1f} ms",
                 f"best {timed.best * 1e3:.1f} ms of {n}; {orb.iterations} iterations"))
    med, n, orb = timed(lambda: dy.periodic_orbit(CONTACT, 3, transient_periods=200), reps, 60.0, 60.0)
    rows.append(("periodic orbit (period 3, contact case) from the end of a 200-period transient",
                 f"{med * 1e3:.1f} ms",
                 f"best {timed.best * 1e3:.1f} ms of {n}; {orb.iterations} iterations"))
    return rows


def other_rows(quick: bool):
    rows = []
    periods = 50 if quick else 1000
    med, n, res = timed(lambda: dy.lyapunov_exponent(CONTACT, periods, transient_periods=100), 1 if quick else 3,
                        120.0, 120.0)
    rows.append((f"Lyapunov exponent, contact case, {periods} periods (+100 transient)", f"{med:.2f} s",
                 f"lambda = {res.exponent:.6f}"))
    Fc = dy.den_hartog_onset(0.8, 0.05)
    med, n, res = timed(lambda: dy.contact_onset(DEN_HARTOG, "F", (0.8 * Fc, 1.1 * Fc), method="transient", tol=1e-10,
                                                 scan=4, orbit=1, x0=0.0, transient_periods=300),
                        1 if quick else 3, 120.0, 120.0)
    rows.append(("contact onset, Den Hartog grazing boundary to 1e-10 (transient search, shooting)", f"{med:.2f} s",
                 f"error {abs(res.value - Fc):.1e}, {res.evaluations} orbits"))
    # the same boundary by continuation of a given orbit (Omega 1.5, beta 0.1, K 24)
    Fc2 = dy.den_hartog_onset(1.5, 0.1)
    med, n, res = timed(lambda: dy.contact_onset(io.Oscillator(Fc2, 1.5, 0.1, 24.0), "F", (0.8 * Fc2, 1.1 * Fc2),
                                                 guess=(-0.7891869048001374, 0.16283153617831878)),
                        1 if quick else 3, 120.0, 120.0)
    rows.append(("contact onset by continuation, Den Hartog (Omega 1.5, beta 0.1) from a given orbit", f"{med:.2f} s",
                 f"value/Fc - 1 = {res.value / Fc2 - 1:.1e}, {'stable' if res.stable else 'not stable'}, "
                 f"{res.evaluations} branch points"))
    exact = abs(1 - 0.8**2 + 2j * 0.05 * 0.8)
    for backend in ("exact", "heyoka"):
        med, n, res = timed(lambda b=backend: dy.contact_onset(io.Oscillator(0.3, 0.8, 0.0, 1e4, zeta=0.05), "F",
                                                               (0.2, 0.6), backend=b), 1 if quick else 3, 120.0, 120.0)
        rows.append((f"contact onset by continuation, damped linear textbook case ({backend})", f"{med:.2f} s",
                     f"error {abs(res.value - exact):.1e}"))
    drive = io.TapeDrive()
    Lc = dy.quasi_static_critical_clearance(drive)
    tol = 1e-7 if quick else 1e-9
    med, n, res = timed(lambda: dy.contact_onset(drive, "clearance", (100e-6, 140e-6), method="transient", tol=tol,
                                                 transient_periods=0.25, record_periods=1, stop_at_contact=True),
                        1 if quick else 3, 120.0, 120.0)
    rows.append((f"contact onset, tape critical clearance to {tol * 1e9:g} nm (transient search)", f"{med:.2f} s",
                 f"{res.value * 1e6:.4f} um vs quasi-static {Lc * 1e6:.4f} um, {res.evaluations} runs"))
    med, n, res = timed(lambda: dy.contact_onset(drive, "clearance", (100e-6, 140e-6), start="hi",
                                                 transient_periods=1), 1 if quick else 3, 120.0, 120.0)
    rows.append(("contact onset by continuation, tape critical clearance from 140 um (one design-chart point)",
                 f"{med:.2f} s", f"{res.value * 1e6:.7f} um, {abs(res.value - Lc):.1e} m from quasi-static, "
                                 f"{res.evaluations} branch points"))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small sizes (smoke test)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes of the bifurcation diagram")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    out = args.out or Path(__file__).resolve().parent / "results" / ("quick" if args.quick else "")
    out.mkdir(parents=True, exist_ok=True)
    load0 = load_average()
    rows = orbit_rows(args.quick) + bifurcation_rows(args.quick, args.workers) + other_rows(args.quick)
    lines = [f"# Dynamics toolkit speed{' (quick)' if args.quick else ''}", "",
             f"Machine: {os.cpu_count()} cores; load average at start {load0}, at end {load_average()}.", "",
             "| case | wall time | notes |", "| --- | ---: | --- |"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    text = "\n".join(lines) + "\n"
    (out / "dynamics_speed.md").write_text(text)
    print(text)
    if any(not math.isfinite(float(b.split()[0])) for _, b, _ in rows):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
