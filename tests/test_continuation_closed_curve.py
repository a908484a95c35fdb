"""A closed curve ends where it comes round to its start (it ran to max_points before).

Closed forms first: ``x' = x^2 + a^2 + b^2 - 1`` (period 1) has the equilibria
``x = +-sqrt(1 - a^2 - b^2)``: in ``a`` at ``b = 0`` its fixed points form the circle
``x^2 + a^2 = 1`` (an isola, with folds at ``a = +-1``), and its fold curve in ``(a, b)`` is the
circle ``a^2 + b^2 = 1``. Then the built-in family: the fold curve of a spring flange with
``K = 1``, closed between its two cusps.
"""

from __future__ import annotations

import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc import HybridMode, HybridSystem, symbols
from impactosc.dynamics import HybridMap, periodic_orbit_of


@pytest.fixture(scope="module")
def isola():
    x, a, b = symbols("x a b")
    system = HybridSystem("x", {"a": 0.5, "b": 0.0}, [HybridMode("flow", {x: x * x + a * a + b * b - 1.0})], [],
                          period=1.0, name="circle")
    hmap = HybridMap(system)
    start = periodic_orbit_of(hmap, [-0.8])
    assert start.status == 0
    return dy.continuation(start, "a", (-2.0, 2.0), base=hmap, progress=False)


def _closed(branch) -> None:
    assert branch.status == 0 and branch.message.startswith("the curve is closed"), branch.message
    assert len(branch.ends) == 1  # the other direction is not run round again
    assert len(branch.points) < 200


def test_an_isola_stops_where_it_returns(isola):
    _closed(isola)
    for p in isola.points:
        assert abs(p.state[0] ** 2 + p.parameters["a"] ** 2 - 1.0) < 1e-9
    a = np.array([p.parameters["a"] for p in isola.points])
    x = np.array([p.state[0] for p in isola.points])
    assert a.min() > -1.0 - 1e-12 and a.max() < 1.0 + 1e-12 and x.min() < -0.99 and x.max() > 0.99  # all round
    assert sorted(round(f.parameter, 8) for f in isola.find("fold")) == [-1.0, 1.0]


def test_a_closed_fold_curve_stops_where_it_returns(isola):
    fold = isola.find("fold")[0]
    curve = dy.continuation(fold, ("a", "b"), {"a": (-2.0, 2.0), "b": (-2.0, 2.0)}, progress=False)
    _closed(curve)
    angles = []
    for p in curve.points:
        a, b = p.parameters["a"], p.parameters["b"]
        assert abs(np.hypot(a, b) - 1.0) < 1e-9
        angles.append(np.arctan2(b, a))
    assert np.ptp(np.unwrap(angles)) > 2 * np.pi - 0.2  # once round, not twice


def test_an_open_branch_is_not_taken_for_closed():
    branch = dy.continuation(dy.periodic_orbit(io.Oscillator(0.3, 0.5, beta=0.0, K=1.0, zeta=0.05)), "Omega",
                             (0.4, 0.6), progress=False)
    assert branch.status == 0 and "closed" not in branch.message and len(branch.ends) == 2


@pytest.mark.slow  # ~15 s: a fold curve of 134 points
def test_the_fold_curve_of_a_unit_spring_flange_closes_between_its_cusps():
    osc = io.Oscillator(0.5, 0.8, beta=0.0, K=1.0, zeta=0.05)
    branch = dy.continuation(dy.periodic_orbit(osc, backend="exact", transient_periods=300), "Omega", (0.5, 2.5),
                             progress=False, locate=("fold",))
    curve = dy.continuation(branch.find("fold")[0], ("Omega", "F"), {"F": (0.01, 20.0)}, progress=False,
                            max_points=300)
    _closed(curve)
    assert len(curve.find("cusp")) == 2
