"""Speed of the exact n-DOF backend: a chain of 4 masses between two rigid stops, events per second.

Run: ``.venv/bin/python benchmarks/mdof_speed.py [--quick]``. Prints a markdown table: per
system the events, the closed-form pieces, the wall time (median of repeats after a warm-up
that loads or compiles the numba code) and the events per second, with and without the
energy terms (the forcing work and viscous dissipation are integrated by quadrature on every
piece). Single process, one core. The target of the n = 4 case with two rigid stops is
2e5 events per second. The chains are chaotic (a start moved by 1e-14 changes the event
count after ~100 events), so the counts move with the rounding of the machine. A second
table runs the paper's contact case (eq. 3) on the 1-DOF exact backend and as the n = 1
mechanical system, side by side.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from _timing import load_average, timed  # noqa: E402

import impactosc  # noqa: E402
from impactosc import MechanicalSystem, Oscillator, simulate_mechanical  # noqa: E402
from impactosc.model import Contact, Friction  # noqa: E402


def chain(n: int = 4, *, friction: bool = False, springs: bool = False) -> MechanicalSystem:
    """``n`` unit masses in a chain of unit springs, lightly damped, the first one forced; the last
    one between two stops (rigid, ``e = 0.9``, or springs of stiffness 100) at +-0.5."""
    K = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    K[-1, -1] = 1.0
    C = 0.02 * K + 0.01 * np.eye(n)
    f = np.zeros(n)
    f[0] = 1.0
    e_last = np.eye(n)[-1]
    law = {"law": "spring", "stiffness": 100.0} if springs else {"law": "rigid", "restitution": 0.9}
    contacts = [Contact(e_last, 0.5, **law), Contact(-e_last, 0.5, **law)]
    fr = [Friction(0, 0.05, 0.07)] if friction else []
    return MechanicalSystem(M=np.eye(n), C=C, K=K, harmonics=[(f, 0.8, 0.0)], contacts=contacts, friction=fr)


CASES = [
    ("n=4, two rigid stops", chain(4)),
    ("n=4, two rigid stops, friction on q0", chain(4, friction=True)),
    ("n=4, two spring stops", chain(4, springs=True)),
    ("n=8, two rigid stops", chain(8)),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs, fewer repeats")
    args = parser.parse_args()
    t_end = 200.0 if args.quick else 1000.0
    repeats = 2 if args.quick else 3
    print(f"load average before: {load_average()}")
    print("| system | events | pieces | energy | wall time (s) | events/s |")
    print("| --- | ---: | ---: | --- | ---: | ---: |")
    for name, system in CASES:
        zeros = np.zeros(system.n)
        simulate_mechanical(system, 1.0, zeros, zeros)  # warm-up: numba cache or compile
        for energy in (False, True):
            median, _, sol = timed(lambda s=system, z=zeros, e=energy: simulate_mechanical(s, t_end, z, z, energy=e),
                                   repeats, budget=20.0, timeout=60.0)
            rate = len(sol.events) / median
            print(f"| {name} | {len(sol.events)} | {sol.n_pieces} | {'yes' if energy else 'no'} | {median:.3f} | "
                  f"{rate:,.0f} |")
    # The n = 1 case beside the 1-DOF exact backend: the paper's contact case (eq. 3).
    osc = Oscillator(0.5, 1.1, 0.01, 1e4)
    one = MechanicalSystem.from_oscillator(osc)
    impactosc.simulate(osc, 10.0, 0.95, 0.0, backend="exact")
    simulate_mechanical(one, 10.0, [0.95], [0.0])
    print()
    print("| eq. 3 contact case to t = 400 | events | wall time (ms) | events/s |")
    print("| --- | ---: | ---: | ---: |")
    for name, fn in (("1-DOF exact backend", lambda: impactosc.simulate(osc, 400.0, 0.95, 0.0, backend="exact")),
                     ("n-DOF exact backend, n = 1", lambda: simulate_mechanical(one, 400.0, [0.95], [0.0],
                                                                                 energy=False))):
        median, _, sol = timed(fn, 5 * repeats, budget=10.0, timeout=60.0)
        print(f"| {name} | {len(sol.events)} | {1e3 * median:.2f} | {len(sol.events) / median:,.0f} |")
    print(f"load average after: {load_average()}")


if __name__ == "__main__":
    main()


# -- the exact loop against the heyoka loop of the same system written as a user hybrid system --------


def versus_heyoka(quick: bool) -> None:
    """The n = 4 chain between two rigid stops: ``simulate_mechanical`` (energy terms off) against
    ``impactosc.simulate`` on :func:`~impactosc.model.hybrid.mechanical_system` of it (its energy
    integrals off too), side by side in one process; both warmed up (numba cache, heyoka compile),
    the same events (checked). Issue target: exact at least 10x heyoka."""
    import impactosc
    from impactosc.model.hybrid import mechanical_system

    t_end = 200.0 if quick else 1000.0
    repeats = 2 if quick else 3
    system = chain(4)
    hybrid = mechanical_system(system, energy=False)
    zeros = np.zeros(system.n)
    simulate_mechanical(system, 1.0, zeros, zeros)
    impactosc.simulate(hybrid, 1.0, [0.0] * 8)
    exact_time, _, exact = timed(lambda: simulate_mechanical(system, t_end, zeros, zeros, energy=False), repeats,
                                 budget=20.0, timeout=60.0)
    hy_time, _, sol = timed(lambda: impactosc.simulate(hybrid, t_end, [0.0] * 8), repeats, budget=40.0,
                            timeout=120.0)
    times = sol.event_times()
    # a chaotic chain: the runs part after ~100 events; count the leading events that agree to 1e-9
    same = int(np.argmin(np.append(np.abs(times[:len(exact.events)] - exact.events["t"][:len(times)]) <= 1e-9,
                                   False)))
    print()
    print(f"n=4, two rigid stops, t_end={t_end:g}: exact n-DOF loop against heyoka on mechanical_system(...)")
    print("| backend | events | wall time (s) | events/s | exact speed-up |")
    print("| --- | ---: | ---: | ---: | ---: |")
    print(f"| exact | {len(exact.events)} | {exact_time:.4f} | {len(exact.events) / exact_time:,.0f} | 1 |")
    print(f"| heyoka (user system) | {len(times)} | {hy_time:.4f} | {len(times) / hy_time:,.0f} | "
          f"{(hy_time / len(times)) / (exact_time / len(exact.events)):.1f}x per event |")
    print(f"leading events that agree to 1e-9: {same}")


if __name__ == "__main__":
    versus_heyoka("--quick" in sys.argv)
