"""Codimension-two points on boundaries (issue 26, item 3), against closed forms.

* the cusp of a fold curve: the one-sided linear spring flange ``X'' + 0.1 X' + X + (X - 1)^+ = F cos(W t)``
  has, between W = 1.04 and 1.13, a region where three period-1 orbits coexist, bounded by two fold curves that
  meet at a cusp at either end. The orbit's amplitude as a function of its contact time is a closed form
  (``impact_closed_form.spring_amplitude``), folds are its extrema and cusps its degenerate extrema.
"""

from __future__ import annotations

import impact_closed_form as cf
import pytest

import impactosc as io
import impactosc.dynamics as dy

ZETA, K = 0.05, 1.0
#: The two cusps of the spring flange's fold curve: (contact time, W) guesses for the closed form.
CUSP_GUESSES = [(1.0, 1.05), (1.35, 1.13)]


@pytest.fixture(scope="module")
def spring_fold_curve():
    osc = io.Oscillator(0.1, 1.1, 0.0, K, zeta=ZETA, gap_lower=None)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=300)
    br = dy.continuation(orb, "F", (0.05, 0.4), tol=1e-12)
    folds = br.find("fold")
    assert len(folds) == 2, br.summary()
    return br, dy.continuation(folds[0], ("F", "Omega"), {"Omega": (1.0, 1.2)}, max_points=25, tol=1e-12)


@pytest.mark.slow
def test_the_folds_of_the_spring_flange_branch_are_the_closed_form(spring_fold_curve):
    br, _ = spring_fold_curve
    ref = sorted(cf.spring_folds(1.1, ZETA, K, 0.3, 2.0))
    assert len(ref) == 2
    for fold, F in zip(sorted(s.parameter for s in br.find("fold")), ref, strict=True):
        assert abs(fold - F) < 1e-9


@pytest.mark.slow
def test_the_fold_curve_passes_both_cusps_labelled_and_goes_on(spring_fold_curve):
    _, curve = spring_fold_curve
    cusps = curve.find("cusp")
    located = sorted((s.parameters["Omega"], s.parameters["F"]) for s in cusps)
    expected = sorted(cf.spring_cusp(ZETA, K, *guess) for guess in CUSP_GUESSES)
    assert len(located) == 2, curve.summary()
    for (W, F), (W_ref, F_ref) in zip(located, expected, strict=True):
        assert abs(W - W_ref) < 1e-8 and abs(F - F_ref) < 1e-8
    assert all(s.label.startswith("CP") for s in cusps)
    assert any(row["type"] == "CP" for row in curve.table())
    # the curve goes on through each cusp (points on both sides of it), along the other fold curve
    for s in cusps:
        assert 0 < s.index < len(curve) - 1
    # every point of the curve is a fold of the closed form at its frequency (a few of them: each is a root search)
    for p in curve.points[:: max(1, len(curve) // 5)]:
        W, F = p.parameters["Omega"], p.parameters["F"]
        folds = cf.spring_folds(W, ZETA, K, 0.3, 2.0)
        assert min(abs(F - f) for f in folds) < 1e-9, (W, F, folds)

