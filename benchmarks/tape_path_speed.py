"""Speed of a four-guide tape path on the exact n-DOF backend: one second of tape motion per speed.

Run: ``.venv/bin/python benchmarks/tape_path_speed.py [--quick]``. Prints a markdown table: per
path variant and tape speed (the paper's 4, 8 and 12 m/s), the events, the wall time of
the simulation and of the SI post-processing (:class:`~impactosc.TapePathRun`: exact flange
impulses per guide), the events per second, the run's status, and the flange contacts per
second and mean flange force of each guide. Single process, one core, one run each after a
warm-up that loads or compiles the numba code. The target is one second of tape motion in
under 10 s.

The path: 20 mm of free tape from the pack to a wide guide (300 um clearance), then a roller
at 50 mm (200 um, 90 degree wrap), a tight guide at 80 mm (20 um) and a rigid-flanged guide
at 110 mm (300 um), then 30 mm to a fixed end; the tape, reel and run-out of the paper (mid
pack), 2 % modal damping; the variants are in :data:`VARIANTS`. ``--seconds``, ``--speeds``
and ``--variants`` choose the rows (the full table, three variants at three speeds over one
second, takes minutes while the spring flanges are slow: run it in parts).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from _timing import load_average  # noqa: E402

from impactosc import Guide, TapeDrive, TapePath, TapePathRun, simulate_mechanical  # noqa: E402

GUIDES = (Guide(0.02, clearance=300e-6), Guide(0.05, clearance=200e-6, wrap_angle=90.0),
          Guide(0.08, clearance=20e-6), Guide(0.11, clearance=300e-6, flange="rigid", restitution=1.0))

#: The variants: every flange a spring (k0 = 1e4 times the guide's stiffness, the paper's K)
#: without friction; every flange rigid with restitution 0.8 (rebounds summed into rest)
#: without friction; the spring flanges with the paper's friction mu = 0.2 on every guide.
VARIANTS = ("spring", "rigid", "friction")


def path(speed: float, variant: str) -> TapePath:
    """The four-guide path at ``speed`` m/s, in one of :data:`VARIANTS`."""
    drive = TapeDrive(speed=speed, friction=0.2 if variant == "friction" else 0.0, damping_ratio=0.02)
    guides = GUIDES
    if variant == "rigid":
        guides = tuple(Guide(g.position, clearance=g.clearance, wrap_angle=g.wrap_angle, flange="rigid",
                             restitution=0.8) for g in GUIDES)
    return TapePath(drive, guides, end_span=0.03)


def run_one(p: TapePath, seconds: float, max_events: int) -> tuple[TapePathRun, float, float]:
    """Simulate ``seconds`` of tape motion from rest; the run and the two wall times."""
    system = p.mechanical_system()
    zeros = np.zeros(p.n)
    t0 = time.perf_counter()
    sol = simulate_mechanical(system, p.seconds_to_time(seconds), zeros, zeros, max_events=max_events)
    t1 = time.perf_counter()
    run = TapePathRun(p, sol)
    t2 = time.perf_counter()
    return run, t1 - t0, t2 - t1


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10 ms of tape motion at 4 m/s")
    parser.add_argument("--seconds", type=float, default=1.0, help="seconds of tape motion per row (default 1)")
    parser.add_argument("--speeds", type=float, nargs="+", default=[4.0, 8.0, 12.0], help="tape speeds in m/s")
    parser.add_argument("--variants", nargs="+", choices=VARIANTS, default=list(VARIANTS))
    args = parser.parse_args(argv)
    seconds = 0.01 if args.quick else args.seconds
    speeds = (4.0,) if args.quick else tuple(args.speeds)
    print(f"load average before: {load_average()}")
    run_one(path(4.0, "spring"), 1e-4, 1000)  # warm-up: numba cache or compile
    print("| variant | speed (m/s) | tape time (s) | events | simulate (s) | SI outputs (s) | events/s | status | "
          "contacts/s per guide | mean flange force per guide (N) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |")
    for variant in args.variants:
        for speed in speeds:
            run, t_sim, t_si = run_one(path(speed, variant), seconds, 5_000_000)
            sol = run.solution
            rate = ", ".join(f"{r:.4g}" for r in run.impacts_per_second())
            force = ", ".join(f"{f:.4g}" for f in run.mean_flange_force())
            print(f"| {variant} | {speed:g} | {run.duration:.4g} | {len(sol.events)} | {t_sim:.3f} | {t_si:.3f} | "
                  f"{len(sol.events) / t_sim:,.0f} | {sol.status} | {rate} | {force} |")
            if sol.status != 0:
                print(f"|  |  |  |  |  |  |  | {sol.message[:150]} |  |  |")
    print(f"load average after: {load_average()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
