"""Differential fuzzing of the model family: scipy against exact, and scipy alone.

A seeded, bounded random scan. Two groups of cases:

``diff``
    Members both backends support (rigid flanges with restitution, static friction, linear
    spring flanges), drawn with a bias towards the hard regimes: a push ``F - 1`` close to
    ``beta`` or ``beta_s``, ``e`` near 0 and near 1 (and exactly 0 and 1), ``Omega = 0`` and
    small, starts exactly on a wall, tiny and huge ``beta``. scipy and exact must agree on
    the status, the event sequence (kinds and sides), the event times, the final state, the
    mean flange force per flange and the energy identity.
``scipy``
    Damped, power-law and multi-harmonic members (rigid or spring) that only scipy runs:
    the energy identity, ``|X| <= 1`` with rigid flanges (at every event and at exact sample
    times), no status -1, event counts within the limit, and ``sample_at`` time events that
    leave the event sequence unchanged.

Every case gets one outcome class (the first failed check, in the order of the table);
the table gives the count per class and a reproducer for each failure class.

Usage::

    python benchmarks/fuzz_family.py --n 200 --seed 1            # both groups, ~3 min on 2 busy cores
    python benchmarks/fuzz_family.py --n 100 --seed 7 --group diff
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
import traceback
from dataclasses import dataclass, field

import numpy as np

from impactosc import Oscillator, simulate

#: Event times of the two backends must agree to this (times ``max(1, t)``).
TIME_TOL = 1e-8
#: Final states (status 0) agree to this.
STATE_TOL = 1e-7
#: Mean flange forces agree to this, relative (plus an absolute floor).
FORCE_RTOL, FORCE_ATOL = 1e-7, 1e-10
#: The energy identity's residual, relative to ``max(1, scale)``.
ENERGY_TOL = 1e-9
SCIPY = {"rtol": 1e-13, "atol": 1e-15}


class Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise Timeout


@dataclass
class Case:
    group: str
    kw: dict
    t_end: float
    x0: float
    v0: float
    tags: list = field(default_factory=list)

    def __post_init__(self):
        self.kw = {k: float(v) if isinstance(v, np.floating) else v for k, v in self.kw.items()}

    def oscillator(self) -> Oscillator:
        return Oscillator(**self.kw)

    def repro(self, backend: str, max_events: int) -> str:
        kw = dict(self.kw)
        head = ", ".join(repr(kw.pop(k)) for k in ("F", "Omega", "beta", "K"))
        rest = "".join(f", {k}={v!r}" for k, v in kw.items())
        opts = ", rtol=1e-13, atol=1e-15" if backend == "scipy" else ""
        return (f"simulate(Oscillator({head}{rest}), {self.t_end!r}, {self.x0!r}, {self.v0!r}, "
                f"backend={backend!r}, max_events={max_events}{opts})")


# -- drawing members ---------------------------------------------------------------------
def _pick(rng, table):
    """One of ``table``'s ``(weight, tag, draw)`` entries; returns ``(tag, value)``."""
    w = np.array([t[0] for t in table], dtype=float)
    k = int(rng.choice(len(table), p=w / w.sum()))
    return table[k][1], table[k][2]()


def _friction(rng, tags):
    tag, beta = _pick(rng, [
        (0.15, "beta=0", lambda: 0.0),
        (0.1, "beta tiny", lambda: 10 ** rng.uniform(-14, -6)),
        (0.55, "", lambda: rng.uniform(0.0, 0.5)),
        (0.2, "beta huge", lambda: rng.uniform(1.0, 20.0)),
    ])
    tags.append(tag)
    tag, extra = _pick(rng, [
        (0.45, "", lambda: None),
        (0.35, "beta_s>beta", lambda: rng.uniform(0.0, 0.5)),
        (0.2, "beta_s=beta+tiny", lambda: 10 ** rng.uniform(-12, -4)),
    ])
    tags.append(tag)
    return beta, None if extra is None else beta + extra


def _forcing(rng, tags, beta, beta_s):
    tag, Om = _pick(rng, [
        (0.3, "Omega=0", lambda: 0.0),
        (0.2, "Omega small", lambda: 10 ** rng.uniform(-4, -1)),
        (0.5, "", lambda: rng.uniform(0.1, 3.0)),
    ])
    tags.append(tag)
    bs = beta if beta_s is None else beta_s
    # The push at the upper wall is F cos - 1: put its peak near beta or beta_s sometimes.
    near = 0.0 if rng.random() < 0.2 else rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-12, -3)
    tag, F = _pick(rng, [
        (0.45, "", lambda: rng.uniform(0.0, 3.0)),
        (0.1, "F~beta_s (narrow releases)", lambda: bs * (1.0 + 10 ** rng.uniform(-6, -2))),
        (0.2, "F-1~beta", lambda: max(0.0, 1.0 + beta * (1.0 + near) + near)),
        (0.15, "F-1~beta_s", lambda: max(0.0, 1.0 + bs * (1.0 + near) + near)),
        (0.1, "F=0", lambda: 0.0),
    ])
    tags.append(tag)
    return F, Om, float(rng.uniform(0.0, 2 * math.pi))


def _start(rng, tags, rigid):
    tag, x0 = _pick(rng, [
        (0.2, "x0 on wall", lambda: float(rng.choice([-1.0, 1.0]))),
        (0.8, "", lambda: rng.uniform(-1.0, 1.0) if rigid else rng.uniform(-1.1, 1.1)),
    ])
    tags.append(tag)
    tag, v0 = _pick(rng, [
        (0.35, "v0=0", lambda: 0.0),
        (0.05, "v0 tiny", lambda: float(rng.choice([-1, 1])) * 10 ** rng.uniform(-15, -8)),
        (0.6, "", lambda: rng.uniform(-3.0, 3.0)),
    ])
    tags.append(tag)
    return float(x0), float(v0)


def _restitution(rng, tags):
    tag, e = _pick(rng, [
        (0.1, "e=0", lambda: 0.0),
        (0.1, "e~0", lambda: 10 ** rng.uniform(-6, -2)),
        (0.4, "", lambda: rng.uniform(0.0, 1.0)),
        (0.2, "e~1", lambda: 1.0 - 10 ** rng.uniform(-6, -2)),
        (0.2, "e=1", lambda: 1.0),
    ])
    tags.append(tag)
    return e


def draw_diff(rng) -> Case:
    """A member that exact and scipy both run."""
    tags = []
    beta, beta_s = _friction(rng, tags)
    F, Om, phase = _forcing(rng, tags, beta, beta_s)
    rigid = rng.random() < 0.7
    kw = {"F": F, "Omega": Om, "beta": beta, "K": 1.0, "phase": phase}
    if beta_s is not None:
        kw["beta_static"] = beta_s
    if rigid:
        kw["flange"] = "rigid"
        kw["restitution"] = _restitution(rng, tags)
    else:
        kw["K"] = float(rng.choice([1.0, 100.0, 1e4]))
        tags.append("spring")
    x0, v0 = _start(rng, tags, rigid)
    return Case("diff", kw, float(rng.uniform(5.0, 40.0)), x0, v0, [t for t in tags if t])


def draw_scipy(rng) -> Case:
    """A member only scipy runs: damping, a power-law spring, extra harmonics (at least one)."""
    tags = []
    beta, beta_s = _friction(rng, tags)
    F, Om, phase = _forcing(rng, tags, beta, beta_s)
    kw = {"F": F, "Omega": Om, "beta": beta, "K": 1.0, "phase": phase}
    if beta_s is not None:
        kw["beta_static"] = beta_s
    features = set()
    while not features:
        features = {f for f in ("zeta", "power", "harmonics") if rng.random() < 0.5}
    rigid = rng.random() < 0.5
    if "zeta" in features:
        kw["zeta"] = float(10 ** rng.uniform(-3, 0.5))
        tags.append("damped")
    if rigid:
        kw["flange"] = "rigid"
        kw["restitution"] = _restitution(rng, tags)
    else:
        kw["K"] = float(rng.choice([1.0, 100.0, 1e4]))
        if "power" in features:
            kw["exponent"] = float(rng.choice([1.5, 2.0, 3.0]))
            tags.append(f"p={kw['exponent']}")
    if "harmonics" in features or (rigid and features == {"power"}):
        n = int(rng.integers(1, 3))
        kw["harmonics"] = tuple((float(rng.uniform(0.0, 1.0)), float(rng.uniform(0.0, 4.0)),
                                 float(rng.uniform(0.0, 2 * math.pi))) for _ in range(n))
        tags.append(f"{n} harmonics")
        if rng.random() < 0.2:
            # Static friction a hair below the largest |forcing|: rare, narrow release windows.
            top = sum(F for F, _, _ in Oscillator(**kw).terms)
            kw["beta_static"] = max(kw["beta"], top * (1.0 - 10 ** rng.uniform(-4, -1)))
            tags.append("beta_s~sum F (narrow releases)")
    x0, v0 = _start(rng, tags, rigid)
    return Case("scipy", kw, float(rng.uniform(5.0, 30.0)), x0, v0, [t for t in tags if t])


# -- running and judging -----------------------------------------------------------------
def _run(case: Case, backend: str, max_events: int, timeout: float, **kw):
    opts = SCIPY if backend == "scipy" else {}
    signal.setitimer(signal.ITIMER_REAL, timeout)
    t0 = time.perf_counter()
    try:
        return simulate(case.oscillator(), case.t_end, case.x0, case.v0, backend=backend, record="events",
                        max_events=max_events, **opts, **kw), time.perf_counter() - t0
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)


def _residual(sol) -> float:
    bal = sol.energy_balance()
    return abs(bal["residual"]) / max(1.0, bal["scale"])


def _sequence(sol):
    ev = sol.events
    return list(zip(ev.kind.tolist(), ev.side.tolist(), strict=True))


def _compare_events(a, b):
    """``(first index where kinds/sides differ or None, max time difference on the common prefix)``."""
    sa, sb = _sequence(a), _sequence(b)
    n = min(len(sa), len(sb))
    first = next((i for i in range(n) if sa[i] != sb[i]), None)
    if first is None and len(sa) != len(sb) and a.status == b.status == 0:
        first = n
    m = n if first is None else first
    if m == 0:
        return first, 0.0
    ta, tb = a.events.t[:m], b.events.t[:m]
    dt = np.abs(ta - tb) / np.maximum(1.0, np.abs(ta))
    return first, float(dt.max())


#: An impact (or a spring contact) slower than this is near-grazing: its time and speed are ill-conditioned (an
#: error dX in the position moves it by dX / V and its speed by dX / V), so the backends may
#: part there without either being wrong.
GRAZING_SPEED = 1e-5


#: Final states further apart than this after a near-grazing impact: not explained by the graze.
DIVERGED = 1e-5


def _grazing(*sols) -> bool:
    for sol in sols:
        ev = sol.events
        entry = "impact" if sol.oscillator.rigid else "contact_start"  # a rigid rest starts at V = 0
        if np.any((ev.kind == entry) & (np.abs(ev.v) < GRAZING_SPEED)):
            return True
    return False


def judge_diff(case: Case, max_events: int, timeout: float):
    """Outcome class and a detail string for a ``diff`` case (a mismatch after a near-grazing
    impact gets its own class)."""
    cls, detail, be, sols = _judge_diff(case, max_events, timeout)
    if sols is not None and not cls.startswith(("agree", "energy", "status -1", "exception", "timeout")) \
            and "near-grazing" not in cls and _grazing(*sols):
        cls = f"{cls} after a near-grazing impact"
    if "near-grazing" in cls and sols is not None:
        # A graze moves later events by ~ dX / V; a trajectory that has really parted is a
        # finding (a spring flange entered at a turning point once shifted every later event by 4.4).
        a, b = sols
        d = max(abs(a.x_final - b.x_final), abs(a.v_final - b.v_final)) if a.status == b.status == 0 else math.inf
        if d > DIVERGED:
            cls, detail = f"{cls}, diverged", f"{detail}; final states differ by {d:.1e}"
    return cls, detail, be


def _judge_diff(case: Case, max_events: int, timeout: float):
    runs = {}
    for be in ("exact", "scipy"):
        try:
            runs[be] = _run(case, be, max_events, timeout)
        except Timeout:
            return f"timeout ({be})", f"> {timeout} s", be, None
        except Exception as exc:  # noqa: BLE001 - every exception is a finding
            return f"exception ({be}): {type(exc).__name__}", traceback.format_exc(limit=3)[-400:], be, None
    ex, sc = runs["exact"][0], runs["scipy"][0]
    for be, sol in (("exact", ex), ("scipy", sc)):
        if sol.status == -1:
            return f"status -1 ({be})", sol.message[:200], be, (ex, sc)
    if ex.status != sc.status:
        return ("status differs", f"exact {ex.status} ({ex.t_final:.6g}) / scipy {sc.status} ({sc.t_final:.6g})",
                "scipy", (ex, sc))
    first, dt = _compare_events(ex, sc)
    if first is not None:
        sa, sb = _sequence(ex), _sequence(sc)
        t_at = ex.events.t[first] if first < len(sa) else sc.events.t[first]
        return ("event sequence differs",
                f"at #{first} t={t_at:.9g}: exact {sa[first:first + 3]} / scipy {sb[first:first + 3]} "
                f"(counts {len(sa)}/{len(sb)})", "scipy", (ex, sc))
    if dt > TIME_TOL:
        return "event times differ", f"max |dt|/max(1,t) = {dt:.2e}", "scipy", (ex, sc)
    for be, sol in (("exact", ex), ("scipy", sc)):
        r = _residual(sol)
        if r > ENERGY_TOL:
            return f"energy identity ({be})", f"residual/scale = {r:.2e}", be, (ex, sc)
    if ex.status == 0:
        d = max(abs(ex.x_final - sc.x_final), abs(ex.v_final - sc.v_final))
        if d > STATE_TOL:
            return "final state differs", f"max(|dx|,|dv|) = {d:.2e}", "scipy", (ex, sc)
        for side in (1, -1):
            fa, fb = ex.mean_flange_force(side), sc.mean_flange_force(side)
            if abs(fa - fb) > FORCE_RTOL * abs(fa) + FORCE_ATOL:
                return "mean flange force differs", f"side {side}: {fa!r} / {fb!r}", "scipy", (ex, sc)
    extra = _tail_and_samples(case, ex, sc, max_events, timeout)
    if extra is not None:
        return (*extra, (ex, sc))
    if ex.status == 1:
        return ("agree (both at the event limit)", f"{len(ex.events)} events to t={ex.t_final:.4g}", "exact",
                (ex, sc))
    return "agree", f"{len(ex.events)} events, max dt {dt:.1e}", "exact", (ex, sc)


def _tail_and_samples(case: Case, ex, sc, max_events: int, timeout: float):
    """Two more checks of a ``diff`` case: a run ending inside a chatter tail, and exact time events.

    * If the run has a chatter, both backends rerun to the middle of its tail (between the
      last impact followed and the accumulation time) must end in the same state, with the
      energy identity holding.
    * exact with 50 sample times must give the same events as exact without them.
    """
    ev = ex.events
    chatter = np.flatnonzero(ev.kind == "chatter")
    if len(chatter):
        k = int(chatter[0])
        last = ev.t[:k][ev.kind[:k] == "impact"][-1]
        mid = Case(case.group, case.kw, float(0.5 * (last + ev.t[k])), case.x0, case.v0)
        if mid.t_end > 0.0:
            try:
                a, _ = _run(mid, "exact", max_events, timeout)
                b, _ = _run(mid, "scipy", max_events, timeout)
            except Timeout:
                return "timeout (chatter tail)", f"> {timeout} s", "scipy"
            d = max(abs(a.x_final - b.x_final), abs(a.v_final - b.v_final))
            r = max(_residual(a), _residual(b))
            if a.status != 0 or b.status != 0 or d > STATE_TOL or r > ENERGY_TOL:
                return ("run ending inside a chatter tail",
                        f"t_end={mid.t_end!r}: status {a.status}/{b.status}, |state diff| {d:.1e}, "
                        f"residual {r:.1e}", "scipy")
    if ex.status == 0:
        try:
            sampled, _ = _run(case, "exact", max_events, timeout, sample_at=np.linspace(0.0, case.t_end, 50))
        except Timeout:
            return "timeout (exact with sample_at)", f"> {timeout} s", "exact"
        first, dt = _compare_events(ex, sampled)
        if sampled.status != 0 or first is not None or dt > 1e-10:
            cls = "sample_at changes the exact run" + (" after a near-grazing impact" if _grazing(ex, sampled) else "")
            return cls, f"status {sampled.status}, first differing event {first}, max dt {dt:.1e}", "exact"
    return None


def judge_scipy(case: Case, max_events: int, timeout: float):
    """Outcome class and a detail string for a ``scipy`` case."""
    osc = case.oscillator()
    try:
        sol, _ = _run(case, "scipy", max_events, timeout)
        grid = np.linspace(0.0, case.t_end, 101)
        sampled, _ = _run(case, "scipy", max_events, timeout, sample_at=grid)
    except Timeout:
        return "timeout (scipy)", f"> {timeout} s", "scipy"
    except Exception as exc:  # noqa: BLE001
        return f"exception (scipy): {type(exc).__name__}", traceback.format_exc(limit=3)[-400:], "scipy"
    if sol.status == -1:
        return "status -1 (scipy)", sol.message[:200], "scipy"
    if osc.rigid:
        xs = np.concatenate([sol.events.x, [sol.x_final], sampled.samples.x])
        if np.abs(xs).max() > 1.0:
            return "|X| > 1 with a rigid flange", f"max |X| - 1 = {np.abs(xs).max() - 1.0:.2e}", "scipy"
    r = _residual(sol)
    if r > ENERGY_TOL:
        return "energy identity (scipy)", f"residual/scale = {r:.2e}", "scipy"
    if sampled.status != sol.status:
        return "sample_at changes the run", f"status {sol.status} -> {sampled.status}", "scipy"
    first, dt = _compare_events(sol, sampled)
    if first is not None or dt > 1e3 * TIME_TOL:
        cls = "sample_at changes the run"
        if _grazing(sol, sampled):
            d = max(abs(sol.x_final - sampled.x_final), abs(sol.v_final - sampled.v_final))
            cls += " after a near-grazing impact" + (", diverged" if d > DIVERGED else "")
        return cls, f"first differing event {first}, max dt {dt:.1e}", "scipy"
    if sol.status == 0 and len(sampled.samples) != len(grid):
        return "sample_at lost samples", f"{len(sampled.samples)} of {len(grid)}", "scipy"
    if sol.status == 1:
        return "event limit (scipy)", f"{len(sol.events)} events to t={sol.t_final:.4g}", "scipy"
    return "agree", f"{len(sol.events)} events", "scipy"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=200, help="cases per group (default 200)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--group", choices=("diff", "scipy", "all"), default="all")
    ap.add_argument("--max-events", type=int, default=1500, help="event limit per run (default 1500)")
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds per run before it counts as a hang")
    ap.add_argument("--verbose", action="store_true", help="one line per case")
    args = ap.parse_args(argv)
    old = signal.signal(signal.SIGALRM, _alarm)
    groups = ("diff", "scipy") if args.group == "all" else (args.group,)
    t_start = time.perf_counter()
    try:
        for group in groups:
            rng = np.random.default_rng([args.seed, groups.index(group) if args.group == "all" else
                                         ("diff", "scipy").index(group)])
            draw, judge = (draw_diff, judge_diff) if group == "diff" else (draw_scipy, judge_scipy)
            outcomes: dict[str, list] = {}
            for i in range(args.n):
                case = draw(rng)
                cls, detail, be = judge(case, args.max_events, args.timeout)
                outcomes.setdefault(cls, []).append((i, case, detail, be))
                if args.verbose:
                    print(f"{group} #{i:4d} {cls:<34} {detail[:90]}  [{', '.join(case.tags)}]", flush=True)
            _report(group, args, outcomes)
    finally:
        signal.signal(signal.SIGALRM, old)
    print(f"\ntotal wall time {time.perf_counter() - t_start:.0f} s")
    return 0


def _report(group, args, outcomes) -> None:
    print(f"\n## group {group}: n={args.n}, seed={args.seed}, max_events={args.max_events}\n")
    print(f"| {'outcome':<40} | count |")
    print(f"| {'-' * 40} | ----- |")
    for cls in sorted(outcomes, key=lambda c: (c.startswith("agree"), c)):
        print(f"| {cls:<40} | {len(outcomes[cls]):5d} |")
    for cls in sorted(outcomes):
        if cls.startswith("agree"):
            continue
        cases = outcomes[cls]
        i, case, detail, be = min(cases, key=lambda c: c[1].t_end)
        print(f"\n{cls} ({len(cases)} cases; e.g. #{i}, tags: {', '.join(case.tags) or '-'}):\n  {detail}\n"
              f"  {case.repro(be, args.max_events)}")


if __name__ == "__main__":
    sys.exit(main())
