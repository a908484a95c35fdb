"""Codimension-two points on boundaries (issue 26, item 3), against closed forms.

* the cusp of a fold curve: the one-sided linear spring flange ``X'' + 0.1 X' + X + (X - 1)^+ = F cos(W t)``
  has, between W = 1.04 and 1.13, a region where three period-1 orbits coexist, bounded by two fold curves that
  meet at a cusp at either end. The orbit's amplitude as a function of its contact time is a closed form
  (``impact_closed_form.spring_amplitude``), folds are its extrema and cusps its degenerate extrema.
* fold-grazing and period-doubling-grazing on the rigid stop ``X'' + 0.1 X' + X = F cos(W t)``, wall at ``X = 1``,
  ``e = 0.8``: in the impact formulation (unknowns the impact's phase and speed) the fold test
  ``det dR/d(psi, v)`` and the period-doubling test ``v det(S M + I)`` of the single-impact orbits both reduce, at
  zero impact speed, to ``(1 + e) a M12`` up to a nonzero factor (``a = -W^2`` the acceleration at the grazing,
  ``M12 = exp(-zeta T) sin(w_d T) / w_d`` over the period ``T = 2 pi / W``): the fold and the period-doubling
  curves meet the grazing curve ``F = |1 - W^2 + 2 i zeta W|`` where ``w_d T = k pi``, ``W = 2 w_d / k``. The
  closed form of the fold (``impact_closed_form.fold``, ``F_fold = F_gr |P| / sqrt(P^2 + W^2 Q^2)`` with
  ``Q = (1 + e) M12``) touches the grazing curve exactly there.
"""

from __future__ import annotations

import math

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



RIGID = dict(zeta=ZETA, flange="rigid", restitution=0.8, gap_lower=None)
W_D = math.sqrt(1.0 - ZETA * ZETA)


@pytest.fixture(scope="module")
def rigid_grazing_curve():
    orb = dy.periodic_orbit(io.Oscillator(0.05, 1.0, 0.0, None, **RIGID), backend="exact", transient_periods=300)
    graze = dy.continuation(orb, "F", (0.02, 1.0)).find("grazing")[0]
    return dy.continuation(graze, ("F", "Omega"), {"Omega": (0.5, 1.5)}, max_points=400)


@pytest.mark.parametrize("kind, label", [("fold_grazing", "FG"), ("period_doubling_grazing", "PDG")])
def test_fold_and_period_doubling_curves_meet_the_rigid_grazing_curve_at_the_closed_form(rigid_grazing_curve, kind,
                                                                                         label):
    curve = rigid_grazing_curve
    assert curve.status == 0, curve.message
    points = sorted(curve.find(kind), key=lambda s: s.parameters["Omega"])
    # W = 2 w_d / k in (0.5, 1.5): k = 2 and 3 (k = 4 gives 0.4994)
    expected = [2.0 * W_D / 3.0, W_D]
    assert len(points) == 2, curve.summary()
    for s, W in zip(points, expected, strict=True):
        assert abs(s.parameters["Omega"] - W) < 1e-8
        assert abs(s.parameters["F"] - cf.grazing_amplitude(W, ZETA)) < 1e-8
        assert s.label.startswith(label) and s.accuracy < 1e-8
    assert sum(row["type"] == label for row in curve.table()) == 2
    # the grazing curve goes on past them
    assert all(0 < s.index < len(curve) - 1 for s in points)


def test_the_new_labels_survive_a_file(rigid_grazing_curve, tmp_path):
    rigid_grazing_curve.save(tmp_path / "curve.nc")
    again = dy.Branch.load(tmp_path / "curve.nc")
    for kind in ("fold_grazing", "period_doubling_grazing"):
        before = [s.parameters["Omega"] for s in rigid_grazing_curve.find(kind)]
        assert [s.parameters["Omega"] for s in again.find(kind)] == pytest.approx(before, abs=1e-15)


def test_the_closed_form_fold_touches_the_grazing_curve_where_its_impact_speed_vanishes():
    # the independent side of the fold-grazing test: the closed-form fold reaches the grazing amplitude at 2 w_d / k,
    # and its orbit's impact speed changes sign there (the fold curve of admissible orbits ends on the grazing curve)
    for k in (2, 3):
        W = 2.0 * W_D / k
        assert abs(cf.fold(W, ZETA, 0.8, 0.0) - cf.grazing_amplitude(W, ZETA)) < 1e-12
        speeds = [cf.orbits(cf.fold(W + dW, ZETA, 0.8, 0.0) * (1 + 1e-13), W + dW, ZETA, 0.8, 0.0)[0]["v"]
                  for dW in (-1e-3, 1e-3)]
        assert speeds[0] * speeds[1] < 0.0


@pytest.mark.parametrize("W, case", [(0.6, "nonsmooth_fold"), (0.7, "persistent"), (0.99, "persistent"),
                                     (1.01, "nonsmooth_fold")])
def test_the_grazing_case_changes_across_each_fold_grazing_point(W, case):
    # the fold test at zero impact speed is d F / d v along the impacting family: its sign decides whether that family
    # lies beyond the grazing (persistent) or on the contact-free side (nonsmooth fold), and it changes at the fold-
    # grazing points 2 w_d / 3 = 0.666 and w_d = 0.9987
    F_gr = cf.grazing_amplitude(W, ZETA)
    orb = dy.periodic_orbit(io.Oscillator(0.5 * F_gr, W, 0.0, None, **RIGID), backend="exact", transient_periods=300)
    br = dy.continuation(orb, "F", (0.02, 1.5 * F_gr), tol=1e-12)
    graze = br.find("grazing")
    assert len(graze) == 1 and graze[0].context[2]["case"] == case, br.summary()


def test_a_grazing_curve_without_friction_has_no_grazing_stick(rigid_grazing_curve):
    assert not rigid_grazing_curve.find("grazing_stick")


BETA_GS = 0.49  # the grazing-stick point of Den Hartog's orbit lies at W = sqrt(beta) = 0.7


def test_the_grazing_curve_of_den_hartog_orbits_passes_the_grazing_stick_point_labelled():
    # Den Hartog's undamped Coulomb oscillator between spring flanges at X = +-1 (K = 24): his non-stop orbit has
    # amplitude A(F, W) and turns at X = +-A, where f_net = A W^2 (den_hartog_multipliers). It grazes the flanges
    # at A = 1 (F = den_hartog_onset) and starts to stick at its reversals at A W^2 = beta: on the grazing curve both
    # hold at W = sqrt(beta). Above it the grazing orbit slides through its reversals, below it sticks at them.
    W = 0.8
    Fc = dy.den_hartog_onset(W, BETA_GS)
    orb = dy.periodic_orbit(io.Oscillator(0.9 * Fc, W, BETA_GS, 24.0), backend="exact", transient_periods=300,
                            phase=1.0)
    br = dy.continuation(orb, "F", (0.5 * Fc, 1.1 * Fc), direction="forward")
    graze = br.find("grazing")[0]
    curve = dy.continuation(graze, ("F", "Omega"), {"Omega": (0.6, 0.8)}, max_points=300)
    assert curve.status == 0, curve.message  # no stall at the grazing-stick point: the curve goes on past it
    gs = curve.find("grazing_stick")
    assert len(gs) == 1, curve.summary()
    W_gs = math.sqrt(BETA_GS)
    assert abs(gs[0].parameters["Omega"] - W_gs) < 1e-8
    assert abs(gs[0].parameters["F"] - dy.den_hartog_onset(W_gs, BETA_GS)) < 1e-8
    assert gs[0].label.startswith("GS") and any(row["type"] == "GS" for row in curve.table())
    assert 0 < gs[0].index < len(curve) - 1
    sliding = [p for p in curve.points if p.parameters["Omega"] > W_gs + 1e-6]
    sticking = [p for p in curve.points if p.parameters["Omega"] < W_gs - 1e-6]
    assert sliding and sticking
    for p in sliding:  # the non-stop orbit grazing: Den Hartog's closed form
        assert abs(p.parameters["F"] - dy.den_hartog_onset(p.parameters["Omega"], BETA_GS)) < 1e-9
        assert not any(kind == "stick" for (kind, _), _n in p.signature)
    for p in sticking:  # beyond, the grazing orbits stick at their reversals on the flange
        assert any(kind == "stick" for (kind, _), _n in p.signature)


@pytest.mark.slow
def test_on_a_stiff_spring_flange_the_fold_grazing_unfolds_into_a_cusp_next_to_the_grazing_curve():
    # A spring flange's map is C^1 at the grazing (its correction grows like d^(3/2) over penetrations d below ~1/K),
    # so no fold curve of contacting orbits can end on the grazing curve, as the rigid stop's does at w_d. At K = 1e4
    # the fold curve from W = 1.05 comes down to the rigid fold-grazing point and turns there at a cusp, 3e-4 from
    # w_d, whose other fold curve runs along the grazing curve at penetrations of 1e-7. The closed form of the
    # one-contact orbits of a linear spring flange (impact_closed_form.spring_cusp) places it.
    osc = io.Oscillator(0.3, 1.05, 0.0, 1e4, zeta=ZETA, gap_lower=None)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=300)
    fold = dy.continuation(orb, "F", (0.02, 0.5), tol=1e-12).find("fold")[0]
    curve = dy.continuation(fold, ("F", "Omega"), {"Omega": (0.99, 1.1)}, max_points=30)
    cusps = curve.find("cusp")
    assert len(cusps) == 1, curve.summary()
    W_ref, F_ref = cf.spring_cusp(ZETA, 1e4, 0.008, 0.99904)
    assert abs(cusps[0].parameters["Omega"] - W_ref) < 1e-8 and abs(cusps[0].parameters["F"] - F_ref) < 1e-8
    assert abs(W_ref - W_D) < 1e-3 and 0.0 < F_ref - cf.grazing_amplitude(W_ref, ZETA) < 1e-6
