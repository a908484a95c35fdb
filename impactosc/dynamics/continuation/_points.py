"""What continuation reads off one periodic orbit: stability, event signature, margins, test functions.

Smooth bifurcations are zeros of test functions of the monodromy matrix ``M`` (Kuznetsov,
*Elements of Applied Bifurcation Theory*, sec. 10.2): ``det(M - I)`` (a multiplier through
+1: a fold), ``det(M + I)`` (through -1: a period doubling) and ``det(M) - 1`` while the
multipliers are a complex pair (through the unit circle together: Neimark-Sacker).
Nonsmooth ones are zeros of signed margins that are continuous along the branch though
their derivative is not (di Bernardo et al. 2008, ch. 7-8):

* **grazing** of each flange: ``1 - max X`` (``1 + min X`` for the lower one) while the
  orbit does not reach the flange, the penetration ``-(max X - 1)`` of a spring flange it
  enters, ``-(slowest impact speed)`` on a rigid flange it hits;
* **stick onset**: the largest ``beta_s - |f_net|`` over the reversals (negative: every
  reversal slides on) while the orbit does not stick, the shortest stick duration once it
  does.

Any other change of the event signature between two neighbouring points is a *border*.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...results._solution import Solution
from .._newton import floquet_multipliers
from ._problem import MARGIN_TESTS, MapEvaluation, MapProblem
from ._sensitivity import flange_gap

__all__ = ["GUARD", "PointInfo", "point_info", "smooth_tests", "stability", "SMOOTH_TESTS", "MARGIN_TESTS"]

#: Test functions of smooth bifurcations, by special-point kind.
SMOOTH_TESTS = ("fold", "period_doubling", "neimark_sacker")

#: The prefix of a user system's grazing margins, one per guard (``"guard:<name>"``, :mod:`._hybrid_problem`).
GUARD = "guard:"

#: Distance of the largest multiplier modulus from 1 within which a point is "marginal".
MARGINAL = 1e-8


@dataclass(frozen=True, eq=False)
class PointInfo:
    """One converged orbit of a branch, as continuation sees it."""

    multipliers: np.ndarray
    stability: str
    collapsed: bool
    signature: tuple  #: ((kind, side), count) pairs of one map period, sorted
    upper_margin: float
    lower_margin: float
    stick_margin: float
    tests: dict  #: fold / period_doubling / neimark_sacker test values (NaN when not defined)
    events: object  #: the events of one map period (numpy recarray)
    singular: str  #: why the map has no Jacobian here ("" when it has one)
    #: Per side (+1, -1): the smallest distance from that flange of a turning point that does not
    #: reach it, and the slowest entry (impact or contact start) into it; inf when there is none.
    #: Either near zero means a grazing is near (a contact about to appear or vanish).
    approach: dict = field(default_factory=dict)
    slowest_entry: dict = field(default_factory=dict)
    #: The grazing margins by test name (:attr:`MapProblem.margin_tests`): ``upper_margin`` and
    #: ``lower_margin`` of the built-in family, one per guard (``"guard:<name>"``) of a user system.
    margins: dict = field(default_factory=dict)

    def nearest_grazing(self) -> float:
        """The smallest of the margins, approaches and entry speeds: how far the orbit is from a grazing."""
        values = [abs(self.upper_margin), abs(self.lower_margin)] + [abs(m) for m in self.margins.values()]
        values += list(self.approach.values()) + list(self.slowest_entry.values())
        return min((v for v in values if not math.isnan(v)), default=math.inf)

    def test_value(self, name: str) -> float:
        """The value of the test function or margin ``name`` at this point (NaN where it is not defined)."""
        if name in SMOOTH_TESTS:
            return float(self.tests[name])
        if name in self.margins:
            return float(self.margins[name])
        return float(getattr(self, name))


def _stability(mus) -> str:
    m = float(np.max(np.abs(mus)))
    if not math.isfinite(m):
        return "undefined"
    if m < 1.0 - MARGINAL:
        return "stable"
    if m > 1.0 + MARGINAL:
        return "unstable"
    return "marginal"


def point_info(problem, ev) -> PointInfo:
    """The :class:`PointInfo` of a converged evaluation.

    The built-in family's is read off its run here; another problem (a user system's,
    :mod:`._hybrid_problem`) gives its own (``problem.point_info(ev)``).
    """
    if not isinstance(problem, MapProblem):
        return problem.point_info(ev)
    return _family_point_info(ev)


def smooth_tests(monodromy) -> tuple[np.ndarray, dict]:
    """``(multipliers, tests)`` of a monodromy matrix of any size (module docstring).

    ``det(M - I)`` and ``det(M + I)`` change sign where a real multiplier passes +1 or -1. The
    Neimark-Sacker test is ``det M - 1`` while a 2 x 2 matrix has a complex pair (NaN without
    one, as for the built-in family); for a larger matrix it is the bialternate product
    ``prod_{i<j} (mu_i mu_j - 1)`` (Kuznetsov 2004, sec. 10.2), continuous where a pair turns
    real, which vanishes where a complex pair crosses the unit circle and at a neutral saddle
    (two real multipliers with product 1), which the locator leaves out.
    """
    M = np.asarray(monodromy, dtype=float)
    mus = np.linalg.eigvals(M)
    mus = mus[np.argsort(-np.abs(mus), kind="stable")]
    n = M.shape[0]
    eye = np.eye(n)
    if n == 2:
        ns = float(np.linalg.det(M)) - 1.0 if abs(mus[0].imag) > 0.0 else math.nan
    else:
        ns = float(np.real(np.prod([mus[i] * mus[j] - 1.0 for i in range(n) for j in range(i + 1, n)])))
    tests = {"fold": float(np.linalg.det(M - eye)), "period_doubling": float(np.linalg.det(M + eye)),
             "neimark_sacker": ns}
    return mus, tests


def stability(mus) -> str:
    """``"stable"``, ``"unstable"``, ``"marginal"`` or ``"undefined"`` from the multipliers' largest modulus."""
    return _stability(mus)


def _family_point_info(ev: MapEvaluation) -> PointInfo:
    rec = ev.recorder
    osc = rec.osc
    events = Solution(rec, rec.t_final).events
    mus = (floquet_multipliers(ev.monodromy, rec.collapsed) if not ev.singular
           else np.full(2, math.nan, dtype=complex))
    M = ev.monodromy
    det = float(np.linalg.det(M)) if not ev.singular else math.nan
    tr = float(np.trace(M)) if not ev.singular else math.nan
    complex_pair = bool(abs(mus[0].imag) > 0.0) if not ev.singular else False
    tests = {"fold": det - tr + 1.0, "period_doubling": det + tr + 1.0,
             "neimark_sacker": det - 1.0 if complex_pair else math.nan}
    approach, slowest = _approaches(osc, events)
    upper, lower = _flange_margin(osc, rec, 1), _flange_margin(osc, rec, -1)
    return PointInfo(mus, _stability(mus), bool(rec.collapsed), signature(osc, events), upper, lower,
                     _stick_margin(osc, events, rec), tests, events, ev.singular, approach, slowest,
                     {"upper_margin": upper, "lower_margin": lower})


def _approaches(osc, events):
    """``(approach, slowest_entry)`` of :class:`PointInfo`."""
    approach = {1: math.inf, -1: math.inf}
    slowest = {1: math.inf, -1: math.inf}
    gaps = {1: flange_gap(osc, 1), -1: flange_gap(osc, -1)}
    for e in events:
        kind, x = str(e.kind), float(e.x)
        side = 1 if x > 0.0 else -1
        if kind == "reversal" and abs(x) < gaps[side]:
            approach[side] = min(approach[side], gaps[side] - abs(x))
        elif kind in ("impact", "contact_start"):
            slowest[side] = min(slowest[side], abs(float(e.v)))
    return approach, slowest


def contact_counts(sig) -> dict:
    """Contacts and impacts per side in a signature."""
    return {key: count for key, count in sig if key[0] in ("impact", "contact_start", "chatter")}


def stick_counts(sig) -> int:
    return sum(count for (kind, _), count in sig if kind == "stick")


def signature(osc, events) -> tuple:
    """How many events of each kind (and flange side) one map period has.

    Without friction (``beta_s == 0``) a velocity zero is no switching at all, so reversals
    are left out: their number may change without any bifurcation.
    """
    counts: dict = {}
    for e in events:
        kind = str(e.kind)
        if kind == "reversal" and osc.beta_s == 0.0:
            continue
        side = int(np.sign(e.x)) if kind in ("contact_start", "contact_end", "impact", "chatter") else 0
        counts[(kind, side)] = counts.get((kind, side), 0) + 1
    return tuple(sorted(counts.items()))


def _flange_margin(osc, rec, side: int) -> float:
    """Signed distance of the orbit from the flange on ``side`` (module docstring)."""
    extreme = rec.x_max if side > 0 else -rec.x_min
    if osc.rigid and math.isfinite(rec.impact_speed[side]):
        return -rec.impact_speed[side]
    return flange_gap(osc, side) - extreme


def _stick_margin(osc, events, rec) -> float:
    """Largest ``beta_s - |f_net|`` at a reversal, or the shortest stick once the orbit sticks."""
    if osc.beta_s == 0.0:
        return math.nan
    sticks = [i for i, e in enumerate(events) if str(e.kind) == "stick"]
    if sticks:
        shortest = math.inf
        for i in sticks:
            t_end = events[i + 1].t if i + 1 < len(events) else rec.t_final
            shortest = min(shortest, float(t_end - events[i].t))
        return shortest
    margin = -math.inf
    for e in events:
        if str(e.kind) == "reversal":
            margin = max(margin, osc.beta_s - abs(osc._net_force_scalar(float(e.t), float(e.x))))
    return margin if math.isfinite(margin) else math.nan
