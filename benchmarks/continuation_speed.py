"""Speed of continuation: a branch of the contact case and a two-parameter grazing curve.

Run: ``.venv/bin/python benchmarks/continuation_speed.py [--quick] [--repeats N] [--out DIR]``.
Prints a markdown table and writes it to ``DIR/continuation_speed.md`` (default
``benchmarks/results``; ``--quick`` writes ``benchmarks/results/quick``).

Targets of the continuation, on the exact backend, one core, after compile:

* a 200-point branch of the contact case with stability and special points located in
  under 1 s;
* a 100-point two-parameter grazing curve in under 5 s.

Targets of the grazing location:

* the whole grazing curve of the rigid one-sided stop (COCO's impact demo) over Omega in
  0.5-1.5 in under 2 s;
* a branch that crosses a grazing of a spring flange at K = 1e4 costs no more than 3 times
  one of the same parameter span that does not (the two measured side by side in one run).

A branch is as long as its family: the time is reported per 200 points (per 100 for the
curve), from the measured time and the number of points, with the points actually computed.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import load_average, timed  # noqa: E402

import impactosc as io  # noqa: E402
from impactosc import dynamics as dy  # noqa: E402

#: The contact case of the speed benchmarks (Omega = 1.1, beta = 0.01, K = 1e4) at F = 0.2, where its
#: period-1 orbit touches both flanges every period (at F = 0.5 the motion is not period-1).
CONTACT = io.Oscillator(F=0.2, Omega=1.1, beta=0.01, K=1e4)
#: The Den Hartog case: the contact-free orbit at 0.8 Fc, from a guess near it.
OMEGA, BETA = 1.5, 0.1
DH_GUESS = (-0.7891869048001374, 0.16283153617831878)


def branch_row(repeats: int, quick: bool):
    orb = dy.periodic_orbit(CONTACT, backend="exact", transient_periods=200)
    step = 0.02 if not quick else 0.1
    run = lambda: dy.continuation(orb, "F", (0.05, 2.0), backend="exact", step=step, max_step=step,  # noqa: E731
                                  max_points=10 if quick else 400)
    run()  # compile and warm up
    med, n, br = timed(run, repeats, budget=60.0, timeout=600.0)
    per = med * 200.0 / max(len(br), 1)
    kinds = ", ".join(f"{s.label}" for s in br.special) or "none"
    return {"what": "branch of the contact case in F (exact)", "points": len(br), "seconds": med,
            "per": per, "target": 1.0, "unit": "s per 200 points", "note": f"status {br.status}; special: {kinds}"}


def curve_row(repeats: int, quick: bool):
    Fc = dy.den_hartog_onset(OMEGA, BETA)
    orb = dy.periodic_orbit(io.Oscillator(0.8 * Fc, OMEGA, BETA, 24.0), guess=DH_GUESS, backend="exact")
    br = dy.continuation(orb, "F", (0.5 * Fc, 1.1 * Fc), direction="forward")
    graze = br.find("grazing")[0]
    step = 0.005 if not quick else 0.1
    run = lambda: dy.continuation(graze, ("F", "Omega"), {"Omega": (1.2, 2.5)}, step=step,  # noqa: E731
                                  max_step=step, max_points=10 if quick else 400)
    run()
    med, n, curve = timed(run, repeats, budget=60.0, timeout=600.0)
    err = max(abs(p.parameters["F"] / dy.den_hartog_onset(p.parameters["Omega"], BETA) - 1.0) for p in curve.points)
    per = med * 100.0 / max(len(curve), 1)
    return {"what": "grazing curve (F, Omega) of the Den Hartog orbit", "points": len(curve), "seconds": med,
            "per": per, "target": 5.0, "unit": "s per 100 points",
            "note": f"status {curve.status}; max |F/F_c(Omega) - 1| = {err:.1e}"}


#: COCO's impact demo: x'' + 0.1 x' + x = F cos(W t), a rigid stop at x = 1 with restitution 0.8.
RIGID_STOP = io.Oscillator(0.05, 1.0, 0.0, None, zeta=0.05, flange="rigid", restitution=0.8, gap_lower=None)


def rigid_curve_row(repeats: int, quick: bool):
    orb = dy.periodic_orbit(RIGID_STOP, backend="exact", transient_periods=300)
    graze = dy.continuation(orb, "F", (0.02, 0.5)).find("grazing")[0]
    lo, hi = (0.9, 1.1) if quick else (0.5, 1.5)
    run = lambda: dy.continuation(graze, ("F", "Omega"), {"Omega": (lo, hi)}, max_points=400)  # noqa: E731
    run()
    med, n, curve = timed(run, repeats, budget=60.0, timeout=600.0)
    err = max(abs(p.parameters["F"] - abs(complex(1.0 - p.parameters["Omega"] ** 2, 0.1 * p.parameters["Omega"])))
              for p in curve.points)
    return {"what": f"rigid stop's grazing curve (F, Omega), Omega {lo}-{hi} (exact)", "points": len(curve),
            "seconds": med, "per": med, "target": 2.0, "unit": "s for the whole curve",
            "note": f"status {curve.status}; max |F - |1 - W^2 + 0.1 i W|| = {err:.1e}"}


def crossing_row(repeats: int, quick: bool):
    """A branch in F through the grazing of a K = 1e4 flange against ones of the same span that do not cross it.

    The grazing is at F = |1 - 0.64 + 0.08 i| = 0.3688; the crossing branch runs from 0.32, the
    others below it (contact-free) and above it (every orbit in contact: a contact piece of a
    stiff flange costs more than a free one, so this is the like-for-like comparison, the
    target's).
    """
    osc = io.Oscillator(0.2, 0.8, 0.0, 1e4, zeta=0.05)
    span = 0.06 if quick else 0.15
    below = dy.periodic_orbit(osc, backend="exact", transient_periods=300)
    near = dy.periodic_orbit(dataclasses.replace(osc, F=0.32), backend="exact", transient_periods=300)
    runs = {"free": lambda: dy.continuation(below, "F", (0.2, 0.2 + span), direction="forward"),
            "cross": lambda: dy.continuation(near, "F", (0.32, 0.32 + span), direction="forward")}
    top = runs["cross"]().points[-1]  # a contacting orbit above the grazing
    above = io.Oscillator(top.parameter, 0.8, 0.0, 1e4, zeta=0.05)
    runs["contact"] = lambda: dy.continuation((top.x, top.v), "F", (top.parameter, top.parameter + span),  # noqa
                                              base=above, direction="forward")
    t, br = {}, {}
    for name, run in runs.items():
        run()
        t[name], _, br[name] = timed(run, repeats, budget=30.0, timeout=300.0)
    kinds = ", ".join(s.label for s in br["cross"].special) or "none"
    return {"what": "branch crossing a grazing at K = 1e4 / one in contact that does not (same span in F)",
            "points": f"{len(br['cross'])} / {len(br['contact'])}", "seconds": t["cross"],
            "per": t["cross"] / t["contact"], "target": 3.0, "unit": "ratio",
            "note": f"{t['cross']:.3f} s against {t['contact']:.3f} s in contact and {t['free']:.3f} s contact-free "
                    f"({len(br['free'])} points; ratio {t['cross'] / t['free']:.2f}); status {br['cross'].status} / "
                    f"{br['contact'].status} / {br['free'].status}; special: {kinds}"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny sizes (the smoke test)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    out = Path(args.out) if args.out else Path(__file__).resolve().parent / "results" / (
        "quick" if args.quick else "")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows = [branch_row(args.repeats, args.quick), curve_row(args.repeats, args.quick),
            rigid_curve_row(args.repeats, args.quick), crossing_row(args.repeats, args.quick)]
    lines = ["# Continuation speed", "",
             f"Load average at the start: {load_average()}; medians of {args.repeats} runs after a warm-up run.", "",
             "| case | points | seconds | measure | unit | target | met |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        met = "yes" if r["per"] < r["target"] else "no"
        lines.append(f"| {r['what']} | {r['points']} | {r['seconds']:.3f} | {r['per']:.3f} | {r['unit']} "
                     f"| {r['target']:.1f} | {met} |")
    lines += [""] + [f"- {r['what']}: {r['note']}" for r in rows]
    lines += ["", f"Total {time.perf_counter() - t0:.1f} s."]
    md = "\n".join(lines) + "\n"
    (out / "continuation_speed.md").write_text(md)
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
