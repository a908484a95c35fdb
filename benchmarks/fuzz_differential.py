"""Differential fuzzing of the reference backends: heyoka against exact (and scipy on a subsample).

Run: ``PYTHONPATH=$PWD .venv/bin/python benchmarks/fuzz_differential.py --regime touch --n 300``.
A bounded, seeded random scan: every case is run by ``heyoka`` and ``exact``,
and classified as

``ok``            both reached ``t_end`` and agree;
``status``        a backend ended with ``status != 0`` (``-1`` is a failure, ``1`` the event limit)
                  or raised;
``timeout``       a backend ran longer than ``--timeout`` (slow, not wrong: reported apart);
``inconsistent``  a backend contradicts itself: a negative impulse or mean flange force, or a
                  piece whose dense output leaves its region (``|X| > 1`` in a free piece,
                  ``r X < 1`` in flange ``r``) or moves against its motion (``s V < 0``);
``disagree``      the two backends differ in the final state, the event sequence, the mean
                  flange force or the sampled trajectory (within the comparison horizon).

Regimes (``--regime``): ``touch`` (turning points or starts exactly on ``|X| = 1``: F = 0 or
Omega = 0, integer-ish K, dyadic states), ``fbeta`` (``F == beta`` exactly, long runs),
``hugebeta`` (beta up to 1e9), ``hugek`` (K up to 1e12), ``random`` (everything moderate),
``long`` (random parameters to t = 1e3..1e4, statistics and status only past the horizon),
``powerfast`` (power-law flanges ``K d^p``, ``p`` from ``1 + 1e-9`` to 2, entered at speeds up
to 50: the exact backend has no closed form for them, so scipy is the
reference and heyoka is compared with it), ``resonant`` (lightly damped members forced within
1e-9..1e-2 of the free or the contact resonance, some with a second harmonic:
exact against heyoka), or ``all``. Prints one table row per regime and
a reproducer line per failing case.

Chaotic cases separate legitimately (rounding grows like exp(lambda t)), so trajectories and
events are compared only up to ``--horizon`` time units; past it only statuses and
self-consistency count.
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from dataclasses import dataclass

import numpy as np

import impactosc as io

EPS = 2.0**-52
REGIMES = ("touch", "fbeta", "hugebeta", "hugek", "random", "long", "powerfast", "resonant")
#: The backends of a regime, the reference first (default: exact, then heyoka).
REGIME_BACKENDS = {"powerfast": ["scipy", "heyoka"]}


@dataclass
class Case:
    osc: io.Oscillator
    t_end: float
    x0: float
    v0: float

    def repro(self) -> str:
        o = self.osc
        family = f", exponent={o.exponent!r}" if o.exponent != 1.0 else ""
        family += f", zeta={o.zeta!r}" if o.zeta else ""
        family += f", harmonics={o.harmonics!r}" if o.harmonics else ""
        return (f"simulate(Oscillator(F={o.F!r}, Omega={o.Omega!r}, beta={o.beta!r}, K={o.K!r}, "
                f"phase={o.phase!r}{family}), {self.t_end!r}, x0={self.x0!r}, v0={self.v0!r})")


# -- case generators ------------------------------------------------------------------------
def _dyadic(rng, lo, hi, bits=4):
    """A random multiple of 2**-bits in [lo, hi]: exactly representable, sums stay exact."""
    k = rng.integers(math.ceil(lo * 2**bits), math.floor(hi * 2**bits) + 1)
    return float(k) / 2**bits


def _integerish_k(rng):
    pick = rng.integers(4)
    if pick == 0:
        return float(rng.integers(1, 101))
    if pick == 1:
        return float(rng.choice([1.0, 3.0, 8.0, 24.0, 48.0, 99.0, 1e4]))
    if pick == 2:
        return round(float(rng.uniform(0.5, 50.0)), 4)
    return float(10.0 ** rng.integers(0, 7))


def gen_touch(rng) -> Case:
    """Starts or turning points exactly (to rounding) on a flange boundary."""
    K = _integerish_k(rng)
    t_end = float(rng.uniform(20.0, 150.0))
    kind = rng.integers(5)
    sgn = float(rng.choice([-1.0, 1.0]))
    if kind == 0:  # frictionless, unforced, amplitude exactly 1: X = x0 cos t + v0 sin t
        x0, v0 = [(0.0, 1.0), (1.0, 0.0), (0.6, 0.8), (0.8, -0.6), (0.0, -1.0), (-1.0, 0.0)][rng.integers(6)]
        return Case(io.Oscillator(0.0, float(rng.choice([0.0, 1.0, 2.5])), 0.0, K), t_end, sgn * x0, v0)
    if kind == 1:  # constant force: X = F + (x0 - F) cos t oscillates between x0 and 2F - x0
        F = _dyadic(rng, 0.0625, 3.0)
        x0 = float(rng.choice([1.0, -1.0, 2.0 * F - 1.0, 2.0 * F + 1.0]))
        v0 = float(rng.choice([0.0, 0.0, -1.0, 1.0]))
        return Case(io.Oscillator(F, 0.0, 0.0, K), t_end, x0, v0)
    if kind == 2:  # Coulomb friction, turning point at 1: X = -beta + sqrt((x0+beta)^2 + v0^2) at the top
        beta = _dyadic(rng, 0.0625, 0.5)
        x0, v0 = float(rng.choice([-beta, 2.0 * beta - 1.0])), 1.0 + beta
        if x0 == 2.0 * beta - 1.0:
            v0 = 0.0  # at rest: slips up to 2 beta - x0 = 1 exactly
        return Case(io.Oscillator(0.0, 0.0, beta, K), t_end, sgn * x0, sgn * v0)
    if kind == 3:  # forced, starting on the boundary
        F = _dyadic(rng, 0.0, 2.0)
        Omega = _dyadic(rng, 0.0, 3.0)
        beta = float(rng.choice([0.0, 0.0, _dyadic(rng, 0.0, 0.5)]))
        v0 = float(rng.choice([0.0, 0.0, _dyadic(rng, -1.0, 1.0)]))
        return Case(io.Oscillator(F, Omega, beta, K), t_end, sgn, v0)
    # kind 4: start inside the flange with an integer state
    F = _dyadic(rng, 0.0, 3.0)
    return Case(io.Oscillator(F, 0.0, 0.0, K), t_end, sgn * _dyadic(rng, 1.0, 2.0, 2), _dyadic(rng, -1.0, 1.0, 2))


def gen_fbeta(rng) -> Case:
    """F == beta exactly: the stick test sits on its threshold at every forcing extremum."""
    # Round values hit the threshold exactly far more often (a stick at X = 0 sits on it):
    # F = beta = 1, Omega = 2 failed in 49 of 60 runs before the stick test's tie tolerance, random floats in none.
    F = _dyadic(rng, 0.125, 2.0, 3) if rng.random() < 0.5 else float(rng.uniform(0.05, 2.0))
    Omega = _dyadic(rng, 0.25, 3.0, 2) if rng.random() < 0.5 else float(rng.uniform(0.1, 3.0))
    osc = io.Oscillator(F, Omega, F, float(10.0 ** rng.integers(0, 7)),
                        float(rng.choice([0.0, 0.0, rng.uniform(-math.pi, math.pi)])))
    return Case(osc, 1000.0, float(rng.uniform(-1.2, 1.2)), float(rng.uniform(-1.5, 1.5)))


def gen_hugebeta(rng) -> Case:
    beta = float(10.0 ** rng.uniform(2.0, 9.0))
    osc = io.Oscillator(float(rng.uniform(0.0, 2.0)), float(rng.uniform(0.1, 3.0)), beta,
                        float(10.0 ** rng.uniform(0.0, 6.0)))
    return Case(osc, 10.0, float(rng.uniform(-1.5, 1.5)), float(rng.uniform(-2.0, 2.0)))


def gen_hugek(rng) -> Case:
    osc = io.Oscillator(float(rng.uniform(0.0, 2.0)), float(rng.uniform(0.1, 3.0)),
                        float(rng.choice([0.0, rng.uniform(0.0, 0.3)])), float(10.0 ** rng.uniform(6.0, 12.0)))
    # Starts outside the flanges: deep inside, K = 1e12 flings the mass at 1e5 (1e6 contacts per unit time).
    return Case(osc, float(rng.uniform(5.0, 30.0)), float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-2.0, 2.0)))


def gen_random(rng) -> Case:
    osc = io.Oscillator(float(rng.uniform(0.0, 3.0)), float(rng.uniform(0.0, 3.0)),
                        float(rng.uniform(0.0, 0.5)), float(10.0 ** rng.uniform(0.0, 6.0)),
                        float(rng.uniform(-math.pi, math.pi)))
    return Case(osc, float(rng.uniform(10.0, 100.0)), float(rng.uniform(-1.5, 1.5)), float(rng.uniform(-2.0, 2.0)))


def gen_long(rng) -> Case:
    c = gen_random(rng)
    c.t_end = float(10.0 ** rng.uniform(3.0, 4.0))
    return c


def gen_powerfast(rng) -> Case:
    """A power-law flange entered fast: at the contact start ``d = 0`` and ``d^p`` is singular in its derivatives."""
    p = float(rng.choice([1.0 + 1e-9, 1.0 + 1e-6, 1.01, 1.1, 1.25, 1.5, 2.0]))
    osc = io.Oscillator(float(rng.uniform(0.0, 1.0)), float(rng.uniform(0.0, 3.0)),
                        float(rng.choice([0.0, rng.uniform(0.0, 0.3)])), float(10.0 ** rng.uniform(2.0, 6.0)),
                        float(rng.uniform(-math.pi, math.pi)), exponent=p)
    v0 = float(rng.choice([-1.0, 1.0]) * rng.uniform(5.0, 50.0))
    return Case(osc, float(rng.uniform(3.0, 15.0)), float(rng.uniform(-0.9, 0.9)), v0)


def gen_resonant(rng) -> Case:
    """A lightly damped member forced next to its free (``w = 1``) or contact (``w = sqrt(1 + K)``) resonance."""
    K = float(10.0 ** rng.uniform(0.0, 4.0))
    w = 1.0 if rng.random() < 0.6 else math.sqrt(1.0 + K)
    Omega = w * (1.0 + float(rng.choice([-1.0, 1.0])) * 10.0 ** rng.uniform(-9.0, -2.0))
    zeta = float(10.0 ** rng.uniform(-6.0, -2.0))
    # The exact backend refuses |w^2 - Omega^2 + 2 i zeta Omega| < 1e-6 w^2: keep above it.
    zeta = max(zeta, 1e-6 * w * w / Omega)
    F = float(rng.uniform(0.01, 0.5))
    harmonics = ()
    if rng.random() < 0.3:
        harmonics = ((float(rng.uniform(0.0, 0.2)), float(rng.uniform(0.1, 3.0)), float(rng.uniform(0.0, 6.0))),)
    osc = io.Oscillator(F, Omega, float(rng.choice([0.0, rng.uniform(0.0, 0.1)])), K,
                        float(rng.uniform(-math.pi, math.pi)), zeta=zeta, harmonics=harmonics)
    return Case(osc, float(rng.uniform(20.0, 100.0)), float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-1.0, 1.0)))


GENERATORS = {"touch": gen_touch, "fbeta": gen_fbeta, "hugebeta": gen_hugebeta, "hugek": gen_hugek,
              "random": gen_random, "long": gen_long, "powerfast": gen_powerfast, "resonant": gen_resonant}


# -- checks ---------------------------------------------------------------------------------
class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout


def run_backend(case: Case, backend: str, timeout: float):
    """``(solution, error text)``: an exception or a timeout is an error, not a crash of the scan."""
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        return io.simulate(case.osc, case.t_end, x0=case.x0, v0=case.v0, backend=backend, record="full"), None
    except _Timeout:
        return None, f"timeout > {timeout:g} s"
    except Exception as exc:  # noqa: BLE001 - the scan reports every failure
        return None, f"{type(exc).__name__}: {exc}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _state_scale(sol) -> tuple[float, float]:
    """Rough scales of |X| and |V| over the run, for relative tolerances."""
    seg = sol._segments
    xs = max(1.0, float(np.max(np.abs(seg["x"]))), abs(sol.x_final))
    vs = max(1e-300, float(np.max(np.abs(seg["v"]))), abs(sol.v_final))
    return xs, vs


def self_check(sol, max_pieces: int = 3000, rtol: float = 1e-7) -> list[str]:
    """What a backend's own result contradicts (see the module docstring)."""
    problems = []
    imp = sol.impacts
    if len(imp) and np.any(imp.impulse < 0.0):
        problems.append(f"negative impulse {float(np.min(imp.impulse)):.3g}")
    if sol.t_final > sol.t0 and sol.mean_flange_force() < 0.0:
        problems.append(f"negative mean flange force {sol.mean_flange_force():.3g}")
    seg = sol._segments
    t_starts = np.append(seg["t"], sol.t_final)
    n = min(len(seg), max_pieces)
    length = t_starts[1:n + 1] - t_starts[:n]
    keep = np.nonzero(length > 1e-9 * (1.0 + np.abs(t_starts[:n])))[0]
    if keep.size == 0:
        return problems
    frac = np.array([0.25, 0.5, 0.75])
    times = (t_starts[keep][:, None] + length[keep][:, None] * frac[None, :]).ravel()
    x, v = sol.sample(times)
    r = np.repeat(seg["region"][keep], frac.size).astype(float)
    s = np.repeat(seg["motion"][keep], frac.size).astype(float)
    xs, vs = _state_scale(sol)
    tol_x, tol_v = rtol * xs, rtol * vs
    bad_region = np.where(r == 0, np.abs(x) > 1.0 + tol_x, r * x < 1.0 - tol_x)
    bad_motion = s * v < -tol_v
    if np.any(bad_region):
        i = int(np.argmax(bad_region))
        problems.append(f"piece in region {int(r[i])} at X={x[i]:.6g} (t={times[i]:.6g})")
    if np.any(bad_motion):
        i = int(np.argmax(bad_motion))
        problems.append(f"piece with motion {int(s[i])} at V={v[i]:.3g} (t={times[i]:.6g})")
    return problems


def _without_touches(sol, t_max, pen_tol=1e-10, gap_tol=1e-6):
    """``(t, kind, side)`` of the events up to ``t_max`` without the contact events of touches.

    A turning point exactly on ``|X| = 1`` may be recorded as a contact of zero (or rounding
    level) penetration by one backend and as a plain reversal by the other, and a mass
    leaving a flange at rest may or may not record a free gap of zero length: both are right.
    Dropped: contacts whose peak penetration is below ``pen_tol``, and a ``contact_end`` /
    ``contact_start`` pair on one side less than ``gap_tol`` apart with only reversals between."""
    touches = {(float(i.start), int(i.side)) for i in sol.impacts if i.peak_penetration < pen_tol}
    ev = [(float(e.t), str(e.kind), int(e.side)) for e in sol.events if e.t <= t_max]
    drop = set()
    open_touch = {}
    for k, (t, kind, side) in enumerate(ev):
        if kind == "contact_start" and (t, side) in touches:
            drop.add(k)
            open_touch[side] = True
        elif kind == "contact_end" and open_touch.pop(side, False):
            drop.add(k)
    for k, (t, kind, side) in enumerate(ev):
        if kind != "contact_end" or k in drop:
            continue
        j = k + 1
        while j < len(ev) and ev[j][1] == "reversal" and ev[j][0] - t < gap_tol:
            j += 1
        if j < len(ev) and ev[j][1] == "contact_start" and ev[j][2] == side and ev[j][0] - t < gap_tol:
            drop.update((k, j))
    return [e for k, e in enumerate(ev) if k not in drop]


def compare(a, b, case: Case, horizon: float, rtol: float) -> list[str]:
    """Where two successful runs of one case differ beyond ``rtol`` (relative to the state scale)."""
    problems = []
    t_cmp = min(a.t_final, b.t_final, horizon)
    xs = max(_state_scale(a)[0], _state_scale(b)[0])
    vs = max(_state_scale(a)[1], _state_scale(b)[1], 1.0)
    if case.t_end <= horizon:
        if abs(a.x_final - b.x_final) > rtol * xs or abs(a.v_final - b.v_final) > rtol * vs:
            problems.append(f"final state {a.x_final:.12g},{a.v_final:.6g} vs {b.x_final:.12g},{b.v_final:.6g}")
    times = np.linspace(0.0, t_cmp, 1001)
    xa, _ = a.sample(times)
    xb, _ = b.sample(times)
    dx = np.abs(xa - xb)
    if np.max(dx) > rtol * xs:
        i = int(np.argmax(dx > rtol * xs))
        problems.append(f"trajectory |dX|={np.max(dx):.3g} (first at t={times[i]:.6g})")
    margin = 1e-6 * (1.0 + t_cmp)
    ea, eb = _without_touches(a, t_cmp - margin), _without_touches(b, t_cmp - margin)
    ka, kb = [e[1:] for e in ea], [e[1:] for e in eb]
    if ka != kb:
        k = next((i for i, (p, q) in enumerate(zip(ka, kb, strict=False)) if p != q), min(len(ka), len(kb)))
        at = ea[k][0] if k < len(ea) else eb[k][0]
        problems.append(f"events differ at #{k} (t={at:.6g}; {len(ka)} vs {len(kb)})")
    elif ea:
        dt = max(abs(p[0] - q[0]) for p, q in zip(ea, eb, strict=True))
        if dt > rtol * (1.0 + t_cmp):
            problems.append(f"event times differ by {dt:.3g}")
    if case.t_end <= horizon:
        # Works are sums of per-piece energy balances: each is rounded like the energy scale.
        osc = case.osc
        e_scale = 0.5 * vs * vs + 0.5 * xs * xs + (osc.F + osc.beta) * xs
        pieces = max(len(a._segments), len(b._segments))
        for what in ("friction_work", "forcing_work"):
            wa, wb = getattr(a, what), getattr(b, what)
            if abs(wa - wb) > rtol * max(abs(wa), abs(wb)) + 64.0 * EPS * e_scale * pieces:
                problems.append(f"{what} {wa:.9g} vs {wb:.9g}")
    if t_cmp > 0.0:
        fa, fb = a.mean_flange_force(None, 0.0, t_cmp), b.mean_flange_force(None, 0.0, t_cmp)
        if abs(fa - fb) > rtol * max(abs(fa), abs(fb)) + 1e-12 * case.osc.K:
            problems.append(f"mean flange force {fa:.9g} vs {fb:.9g}")
    return problems


def classify(case: Case, backends, horizon: float, rtol: float, timeout: float):
    """``(class, {backend: detail}, seconds per backend)`` for one case; the first backend is the reference."""
    sols, details, secs = {}, {}, {}
    for name in backends:
        t0 = time.perf_counter()
        sol, err = run_backend(case, name, timeout)
        secs[name] = time.perf_counter() - t0
        sols[name] = sol
        if err is not None:
            details[name] = err
        elif sol.status != 0:
            details[name] = f"status {sol.status}: {sol.message[:160]}"
    if details:
        slow = all(d.startswith("timeout") for d in details.values())
        return ("timeout" if slow else "status"), details, secs
    for name, sol in sols.items():
        try:
            p = self_check(sol)
        except Exception as exc:  # noqa: BLE001 - dense output that fails is a finding, not a crash of the scan
            p = [f"dense output failed: {type(exc).__name__}: {exc}"]
        if p:
            details[name] = "; ".join(p)
    if details:
        return "inconsistent", details, secs
    ref = backends[0]
    for name in backends[1:]:
        tol = rtol if "scipy" not in (ref, name) else max(rtol, 1e-5)
        p = compare(sols[ref], sols[name], case, horizon, tol)
        if p:
            details[f"{ref}/{name}"] = "; ".join(p)
    return ("disagree" if details else "ok"), details, secs


# -- driver ---------------------------------------------------------------------------------
CLASSES = ("ok", "status", "inconsistent", "disagree", "timeout")


def scan(regime: str, n: int, seed: int, args, log) -> dict:
    rng = np.random.default_rng([seed, REGIMES.index(regime)])
    counts = dict.fromkeys(CLASSES, 0)
    by_backend = {}
    secs_total = {}
    t0 = time.perf_counter()
    failures = []
    for i in range(n):
        case = GENERATORS[regime](rng)
        backends = list(REGIME_BACKENDS.get(regime, ["exact", "heyoka"]))
        if args.scipy_every and i % args.scipy_every == 0 and "scipy" not in backends:
            backends.append("scipy")
        cls, details, secs = classify(case, backends, args.horizon, args.rtol, args.timeout)
        counts[cls] += 1
        for k, v in secs.items():
            secs_total[k] = secs_total.get(k, 0.0) + v
        if cls != "ok":
            for who in details:
                by_backend[(cls, who)] = by_backend.get((cls, who), 0) + 1
            failures.append((i, cls, case, details))
            if args.verbose:
                log(f"[{regime} #{i}] {cls}: {case.repro()}")
                for who, d in details.items():
                    log(f"    {who}: {d}")
    wall = time.perf_counter() - t0
    return {"regime": regime, "n": n, "counts": counts, "by_backend": by_backend, "wall": wall,
            "secs": secs_total, "failures": failures}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--regime", default="all", choices=(*REGIMES, "all"))
    ap.add_argument("--n", type=int, default=100, help="cases per regime")
    ap.add_argument("--seed", type=int, default=14)
    ap.add_argument("--horizon", type=float, default=60.0, help="compare trajectories and events up to this time")
    ap.add_argument("--rtol", type=float, default=1e-6, help="agreement tolerance, relative to the state scale")
    ap.add_argument("--timeout", type=float, default=10.0, help="seconds per backend run")
    ap.add_argument("--scipy-every", type=int, default=0, help="also run scipy on every k-th case (0: never)")
    ap.add_argument("--show", type=int, default=5, help="reproducers printed per regime")
    ap.add_argument("-v", "--verbose", action="store_true", help="print every failure as it happens")
    args = ap.parse_args(argv)
    regimes = REGIMES if args.regime == "all" else (args.regime,)
    import heyoka

    # heyoka logs "polynomial root finding ... failed" warnings at exact touches to stdout;
    # what matters is whether a result goes wrong, which the checks below see.
    heyoka.set_logger_level_error()

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    results = [scan(r, args.n, args.seed, args, log) for r in regimes]
    print(f"fuzz_differential: seed={args.seed} n={args.n} horizon={args.horizon:g} rtol={args.rtol:g}\n")
    print("| regime | runs | ok | status != 0 | inconsistent | disagree | failure rate | timeout | wall [s] |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for res in results:
        c = res["counts"]
        bad = c["status"] + c["inconsistent"] + c["disagree"]
        print(f"| {res['regime']} | {res['n']} | {c['ok']} | {c['status']} | {c['inconsistent']} | "
              f"{c['disagree']} | {bad / max(res['n'] - c['timeout'], 1):.1%} | {c['timeout']} | {res['wall']:.1f} |")
    print("\n(failure rate: status, inconsistent and disagree over the runs that finished in time)")
    print("\nFailures by class and backend:")
    for res in results:
        for (cls, who), k in sorted(res["by_backend"].items()):
            print(f"  {res['regime']:<9} {cls:<13} {who:<13} {k}")
    for res in results:
        if res["failures"] and args.show:
            print(f"\nFirst reproducers, regime {res['regime']}:")
            for i, cls, case, details in res["failures"][:args.show]:
                print(f"  #{i} {cls}: {case.repro()}")
                for who, d in details.items():
                    print(f"      {who}: {d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
