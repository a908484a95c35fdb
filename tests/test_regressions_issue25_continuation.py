"""Regressions of continuation and contact onset (issue 25 items 5-13 and 18, issue 26 item 6).

Closed forms first (Den Hartog's onset, a branch point's multiplier at +1), then what the
results say about themselves, then bad input refused by name.
"""

from __future__ import annotations

import importlib
import math
import warnings

import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc.dynamics import Branch, SpecialPoint, continuation

#: Issue 25 item 6: a member whose branch in Omega has a symmetry-breaking branch point.
PITCHFORK = dict(F=0.4638374932175059, beta=0.025843977207378025, K=4047.2726687359373, zeta=0.04606147731973585)
#: Where its multiplier passes through +1 (regula falsi in Omega on det(M - I), converged to 1e-11).
PITCHFORK_OMEGA = 0.98135728


def pitchfork_member(Omega: float) -> io.Oscillator:
    p = PITCHFORK
    return io.Oscillator(p["F"], Omega, p["beta"], p["K"], zeta=p["zeta"])


def den_hartog(W, b, F=None):
    fc = dy.den_hartog_onset(W, b)
    return io.Oscillator(0.6 * fc if F is None else F, W, b, 1e5), fc


# -- closed forms ------------------------------------------------------------------------
def test_item6_branch_point_lies_where_a_multiplier_is_one():
    orb = dy.periodic_orbit(pitchfork_member(1.2542522456629002), backend="exact")
    br = continuation(orb, "Omega", (0.9757, 1.7853))
    bps = br.find("branch_point")
    assert len(bps) == 1
    bp = bps[0]
    # located on its test function: a multiplier at +1, the parameter where det(M - I) vanishes
    assert bp.located and np.min(np.abs(bp.multipliers - 1.0)) < 1e-6, (bp.multipliers, bp.message)
    assert abs(bp.parameter - PITCHFORK_OMEGA) < 1e-6 and bp.accuracy < 1e-6


def test_item6_a_branch_point_the_correctors_cannot_reach_says_so():
    # a fuzzed member: its located "branch point" had a complex pair of multipliers (0.23 +- 0.93i)
    F, W, b, K, z, lo, hi = (0.2057224293734115, 1.3304081462985655, 0.03690047492817563, 3311.9521849606685,
                             0.005857519745025499, 0.9216060475500816, 1.8834445153440098)
    orb = dy.periodic_orbit(io.Oscillator(F, W, b, K, zeta=z), backend="exact")
    br = continuation(orb, "Omega", (lo, hi), max_points=200)
    bps = br.find("branch_point")
    assert bps
    for bp in bps:
        miss = float(np.min(np.abs(bp.multipliers - 1.0)))
        assert (bp.located and miss <= 1e-6) or (not bp.located and bp.message.startswith("not located")), bp
        if not bp.located:  # its bracket holds the sign change of det(M - I) between two branch points
            i = bp.index
            lo_p, hi_p = sorted((br.points[i].parameter, br.points[i + 1].parameter))
            assert lo_p - 1e-12 <= bp.parameter <= hi_p + 1e-12 and bp.accuracy <= hi_p - lo_p + 1e-12


def test_issue26_item6_a_crossing_in_the_first_backward_step_keeps_its_kind():
    # the start's tangent points forward; the first backward step must not read as a turn
    orb = dy.periodic_orbit(pitchfork_member(0.99), backend="exact")
    br = continuation(orb, "Omega", (0.9757, 1.0), direction="backward")
    assert [s.kind for s in br.special] == ["branch_point"], br.summary()
    assert abs(br.special[0].parameter - PITCHFORK_OMEGA) < 1e-6


def test_item9_continuation_onset_meets_its_own_tolerance():
    W, b = 0.5058996608708723, 0.138768415460853
    osc = io.Oscillator(0.5415646051157352, W, b, 1e5)
    res = dy.contact_onset(osc, "F", (0.5415646051157352, 1.051418436376201))
    fc = dy.den_hartog_onset(W, b)
    assert res.status == 0, res.message
    assert abs(res.value - fc) <= 1e-11 * fc  # tol is 1e-12 relative; the closed form itself rounds at ~1e-15


def _random_den_hartog(k: int):
    """The k-th Den Hartog member of a fixed draw (Omega in (0.3, 2.5), beta in (0, 0.3)) with a finite onset."""
    rng = np.random.default_rng(1)
    found = []
    while len(found) <= k:
        W, b = rng.uniform(0.3, 2.5), rng.uniform(0.0, 0.3)
        fc = dy.den_hartog_onset(W, b)
        if math.isfinite(fc) and fc <= 5:
            found.append((W, b, fc))
    return found[k]


@pytest.mark.parametrize("k", [0, 1, 2, 6, 7, 8])
def test_item7_transient_onset_is_status_0_only_at_a_grazing(k):
    # 0, 1, 2 and 8 jump between attractors (or their transients have not settled after 200
    # periods: a multiplier of 0.98) 1-3 % below the closed form; 6 and 7 graze
    W, b, fc = _random_den_hartog(k)
    osc, _ = den_hartog(W, b)
    res = dy.contact_onset(osc, "F", (0.6 * fc, 1.5 * fc), method="transient")
    if res.status == 0:
        assert abs(res.value - fc) <= 1e-5 * fc, res.message
    else:
        assert res.status == 2 and "no grazing" in res.message, res.message
    assert (res.status == 0) == (k in (6, 7)), (k, res.status, res.value / fc - 1.0, res.message)


# -- what a result says --------------------------------------------------------------------
def test_item8_a_parameter_starting_at_zero_crosses_its_range():
    osc, _ = den_hartog(1.5, 0.1, F=0.5)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=50)
    br = continuation(orb, "zeta", (0.0, 0.1), max_points=100)
    assert br.status == 0, br.message
    assert br.values().max() == pytest.approx(0.1, abs=1e-12) and len(br) < 100


def test_item5_a_range_beyond_the_exact_members_runs_on_heyoka_and_says_so():
    osc = io.Oscillator(0.3, 0.8, 0.05, 1e2, zeta=0.05)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=50)
    br = continuation(orb, "exponent", (1.0, 1.5), max_points=2, direction="forward")
    assert br.backend == "heyoka" and "exact backend does not run" in br.message
    with pytest.raises(ValueError, match="exponent"):
        continuation(orb, "exponent", (1.0, 1.5), backend="exact")


def test_item5_a_boundary_leaving_the_exact_members_is_refused():
    fc = dy.den_hartog_onset(1.5, 0.1)
    orb = dy.periodic_orbit(io.Oscillator(0.8 * fc, 1.5, 0.1, 24.0), guess=(-0.7891869048001374, 0.16283153617831878),
                            backend="exact")
    br = continuation(orb, "F", (0.8 * fc, 1.1 * fc), direction="forward", stop_at=("grazing",))
    gr = br.find("grazing")[0]
    assert br.backend == "exact"
    with pytest.raises(ValueError, match="does not run every member of the range of exponent"):
        continuation(gr, ("F", "exponent"), {"exponent": (1.0, 1.5)})


def test_issue26_item6_onset_never_says_clear_all_the_way_from_a_branch_that_stopped(monkeypatch):
    package = importlib.import_module("impactosc.dynamics.continuation")
    real = package.continuation

    def stalled(*args, **kwargs):  # a branch that ends at once, status 0, without touching
        br = real(*args, **{**kwargs, "max_points": 1})
        return Branch(br.names, br.n, br.points[:1], [], 0, "ended", ((0, "ended"),), br.base, br.backend)

    monkeypatch.setattr(package, "continuation", stalled)
    fc = dy.den_hartog_onset(1.5, 0.1)
    osc = io.Oscillator(0.8 * fc, 1.5, 0.1, 24.0)
    res = dy.contact_onset(osc, "F", (0.8 * fc, 1.1 * fc), guess=(-0.7891869048001374, 0.16283153617831878))
    assert res.status == -1 and "short of the end of the bracket" in res.message
    assert "all the way" not in res.message


def test_item13_an_empty_branch_exports():
    osc = io.Oscillator(0.3, 0.8, 0.05, 1e4)
    br = Branch(("F",), 1, [], [], -1, "no start", ((-1, "no start"),), osc, "exact")
    ds = br.to_xarray()
    assert ds.sizes["point"] == 0 and ds.attrs["status"] == -1


def test_item18_progress_bar_only_when_asked_and_no_tqdm_warning(capsys):
    osc, fc = den_hartog(1.5, 0.1, F=0.5)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=50)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a TqdmWarning (or any other) would fail here
        quiet = continuation(orb, "F", (0.45, 0.55), progress=False)
    assert "point" not in capsys.readouterr().err
    loud = continuation(orb, "F", (0.45, 0.55), progress=True)
    err = capsys.readouterr().err
    assert "continuation in F" in err and f"{len(loud) - 1}" in err
    assert len(quiet) == len(loud)


# -- bad input, refused by name ---------------------------------------------------------
@pytest.mark.parametrize("value", [math.nan, math.inf])
@pytest.mark.parametrize("method", ["continuation", "transient"])
def test_item10_transient_periods_must_be_finite(value, method):
    osc, fc = den_hartog(1.5, 0.1)
    with pytest.raises(ValueError, match="transient_periods"):
        dy.contact_onset(osc, "F", (0.6 * fc, 1.5 * fc), method=method, transient_periods=value)


@pytest.mark.parametrize("name", ["flange", "flange_sides", "runout_harmonics", "bending"])
def test_item11_structure_fields_are_not_parameters(name):
    drive = io.TapeDrive()
    assert name not in dy.parameter_names(drive)
    orb_base = io.Oscillator(0.3, 0.8, 0.05, 1e4)
    with pytest.raises(ValueError, match=f"{name} of a TapeDrive is not a parameter"):
        continuation((0.1, 0.0), name, (0.0, 1.0), base=drive)
    with pytest.raises(ValueError, match=name):
        dy.contact_onset(drive, name, (0.0, 1.0))
    assert "gap_lower" in dy.parameter_names(orb_base) and "guide_offset" in dy.parameter_names(drive)


def test_item12_parameters_that_do_nothing_or_leave_their_domain_are_refused():
    rigid = io.Oscillator(0.3, 0.8, 0.05, flange="rigid", restitution=0.8, zeta=0.05)
    orb = dy.periodic_orbit(rigid, backend="exact", transient_periods=50)
    with pytest.raises(ValueError, match="K is not a parameter .* rigid"):
        continuation(orb, "K", (1.0, 10.0))
    spring = io.Oscillator(0.3, 0.8, 0.05, 1e4)
    orb = dy.periodic_orbit(spring, backend="exact", transient_periods=50)
    for name, limits in (("beta", (-0.1, 0.2)), ("exponent", (0.5, 1.5)), ("K", (0.0, 2e4))):
        with pytest.raises(ValueError, match=f"limit {name} = .* outside the domain of {name}"):
            continuation(orb, name, limits)
    with pytest.raises(ValueError, match="beta"):
        dy.contact_onset(spring, "beta", (-0.1, 0.2))
    one_sided = io.Oscillator(0.3, 0.8, 0.05, 1e4, gap_lower=None)
    with pytest.raises(ValueError, match="no lower flange"):
        dy.contact_onset(one_sided, "gap_lower", (0.5, 2.0))


def test_item13_bad_starts_and_hand_built_points():
    osc = io.Oscillator(0.3, 0.8, 0.05, 1e4)
    with pytest.raises(ValueError, match=r"start\[0\]"):
        continuation((1e200, 0.0), "F", (0.1, 0.5), base=osc)
    hand = SpecialPoint("grazing", "GR1", {"F": 0.3}, 1.0, 0.0, np.ones(2, complex), (), (), 0, 0.0, "by hand")
    with pytest.raises(ValueError, match="carries no context"):
        continuation(hand, ("F", "Omega"), {"Omega": (0.7, 0.9)})
    free = io.Oscillator(0.3, 0.8, 0.05, gap_lower=None, gap_upper=None)
    with pytest.raises(ValueError, match="no flange") as info:
        dy.contact_onset(free, "F", (0.1, 0.5))
    assert "1e-09" not in str(info.value) and "K=" not in str(info.value)
