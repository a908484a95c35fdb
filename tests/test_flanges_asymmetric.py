"""Asymmetric and one-sided flanges (issue 19, item 6): the flanges at their own distances.

``Oscillator(..., gap_lower=a, gap_upper=b)`` puts the lower flange at ``X = -a`` and the
upper one at ``X = +b`` (default 1 and 1); ``None`` or ``inf`` leaves a flange out. The
switching rule reads them from the parameter vector (``p[P_LOWER]``, ``p[P_UPPER]``), every
backend from there. Checked: the symmetric default keeps its numbers, closed forms
of the free flight to the nearer flange and of a one-sided rigid stop, agreement between
backends, the tape drive's SI fields, and refused input.
"""

import math

import numpy as np
import pytest

import impactosc as io
from impactosc.model import _layout

O = io.Oscillator
SCIPY_TIGHT = {"rtol": 1e-12, "atol": 1e-14}


# -- the symmetric default is unchanged -------------------------------------------------------
# First event times and the final X, computed before the flange positions became parameters
# (commit 97cfdcc): the default member must reproduce them on every backend, to a tolerance the
# numerics justify rather than bit for bit (another CPU's numpy picks other SIMD kernels and
# rounds the forcing's cosines differently: 1-2 ulp on an EPYC with AVX-512).
_BEFORE = {
    ("eq3", "exact"): ([1.9171595882400596, 4.3635750876330235, 4.378979151989707, 4.394387075711999,
                        6.218669337545475, 6.234332096103799], 0.6547943311428854),
    ("eq3", "heyoka"): ([1.9171595882400596, 4.363575087633022, 4.378979151989705, 4.394387075711998,
                         6.218669337545481, 6.234332096103804], 0.6547943311432498),
    ("eq3", "scipy"): ([1.9171595882400605, 4.36357508763304, 4.378979151989725, 4.394387075712018,
                        6.21866933754551, 6.2343320961038335], 0.6547943311412824),
    ("eq3", "rk4"): ([1.9171655776060337, 4.363577947638208, 4.378981869379219, 4.394389609893609,
                      6.218673488241454, 6.234336197991545], 0.6550652991204159),
    ("rigid", "exact"): ([1.2481412050246727, 2.684436590636883, 3.9949774383267034, 6.23341461628904,
                          7.268288659036849, 8.353958705024636], 0.5246929276462592),
    ("rigid", "heyoka"): ([1.248141205024673, 2.6844365906368832, 3.9949774383267025, 6.23341461628904,
                           7.268288659036849, 8.353958705024636], 0.5246929276462593),
    ("rigid", "scipy"): ([1.2481412050246705, 2.684436590636877, 3.9949774383266763, 6.233414616289018,
                          7.268288659036816, 8.35395870502459], 0.5246929276462237),
    ("hertz", "heyoka"): ([3.1499979497090385, 3.1921443269015395, 3.2343340705408448, 5.422616758029625,
                           5.465975878136504, 5.509395129642491], -0.07836163192636712),
    ("hertz", "scipy"): ([3.1499979497090442, 3.192144326901545, 3.23433407054085, 5.422616758029423,
                          5.4659758781363035, 5.509395129642291], -0.078361631925942),
    ("hertz", "rk4"): ([3.1499979930945647, 3.1921443878624887, 3.2343340448741422, 5.422618074461673,
                        5.465977228628527, 5.509396411079547], -0.07835659153628566),
}
_MEMBERS = {
    "eq3": (O(0.5, 1.1, 0.01, 1e4), 0.0),
    "rigid": (O(1.6, 0.4, 0.1, 1.0, flange="rigid", restitution=0.8), 0.0),
    "hertz": (O(0.5, 1.1, 0.01, 1e4, zeta=0.02, exponent=1.5), 0.95),
}


#: How far a machine's rounding may move the stored numbers, relative (times: of max(1, t)).
#: exact, heyoka and rk4 compute to machine precision: exact and heyoka, two independent
#: computations, differ by at most 5.3e-15 in these event times and 3.6e-13 in the final X,
#: so another CPU's rounding moves one backend by less than 1e-11. scipy (DOP853 at its
#: default rtol 1e-10) chooses its steps from error estimates that the rounding moves: a step
#: accepted on one CPU and rejected on another moves the result by up to its tolerance, here
#: grown over a few contacts (it sits 1.6e-12 from exact). A change in the physics (a flange at
#: another place, a mode read wrongly) moves them by 1e-3 or more.
_MACHINE_TOL = {"exact": 1e-11, "heyoka": 1e-11, "rk4": 1e-11, "scipy": 1e-9}


@pytest.mark.parametrize("name, backend", sorted(_BEFORE))
def test_the_symmetric_default_keeps_its_results(name, backend):
    osc, x0 = _MEMBERS[name]
    assert osc.symmetric and (osc.gap_lower, osc.gap_upper) == (1.0, 1.0)
    times, x_final = _BEFORE[name, backend]
    tol = _MACHINE_TOL[backend]
    default = io.simulate(osc, 30.0, x0, 0.0, backend=backend)
    assert default.events.t[:6] == pytest.approx(times, rel=tol, abs=tol)
    assert default.x_final == pytest.approx(x_final, rel=tol, abs=tol)
    # The gaps given explicitly are the same member: on one machine, the same run bit for bit.
    explicit = io.simulate(O(**{**_fields(osc), "gap_lower": 1.0, "gap_upper": 1.0}), 30.0, x0, 0.0,
                           backend=backend)
    np.testing.assert_array_equal(explicit.events.t, default.events.t)
    assert explicit.x_final == default.x_final


def _fields(osc):
    return {f: getattr(osc, f) for f in ("F", "Omega", "beta", "K", "phase", "zeta", "beta_static", "flange",
                                         "exponent", "restitution", "harmonics")}


def test_the_rule_vector_holds_the_gaps_before_the_forcing_terms():
    osc = O(0.5, 1.1, 0.01, 1e4, 0.3, gap_lower=1.5, gap_upper=None)
    p = osc._p
    assert (_layout.P_LOWER, _layout.P_UPPER, _layout.P_TERMS) == (8, 9, 10)
    assert p[_layout.P_LOWER] == 1.5 and p[_layout.P_UPPER] == math.inf
    assert list(p[_layout.P_TERMS:]) == [0.5, 1.1, 0.3]
    assert osc.flanges == (-1.5, math.inf) and osc.gap(1) == math.inf and osc.gap(-1) == 1.5
    assert "gap_lower=1.5" in repr(osc) and "gap_upper=inf" in repr(osc)


# -- closed forms -----------------------------------------------------------------------------
@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
@pytest.mark.parametrize("lo, hi", [(1.5, 0.6), (0.6, 1.5), (None, 0.6), (0.6, None)])
def test_a_free_flight_reaches_the_nearer_flange_first(backend, lo, hi):
    # X = sin(t) from X = 0 at V = 1 (no forcing, friction or damping): the contact starts
    # where sin(t) reaches the nearer flange, at t = asin(0.6), on that side.
    v0 = 1.0
    osc = O(0.0, 0.0, 0.0, 1e4, gap_lower=lo, gap_upper=hi)
    side = 1 if (hi or math.inf) < (lo or math.inf) else -1
    sol = io.simulate(osc, 2.0, 0.0, side * v0, backend=backend)
    ev = sol.events[0]
    assert (ev.kind, ev.side, ev.x) == ("contact_start", side, side * 0.6)
    tol = 1e-14 if backend == "heyoka" else 1e-12  # scipy at its default rtol = 1e-10
    assert ev.t == pytest.approx(math.asin(0.6), abs=tol)
    assert ev.v == pytest.approx(side * math.sqrt(1.0 - 0.36), rel=tol)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_one_sided_rigid_stop_and_the_free_flight_past_the_missing_flange(backend):
    # From X = 0 at V = 2 the mass hits the upper wall at g = 0.7 when 2 sin t = g, leaves at
    # -e times the impact speed, and swings freely down to -A, A^2 = g^2 + e^2 (4 - g^2), far
    # past X = -1, where there is no lower flange.
    g, e, v0 = 0.7, 0.9, 2.0
    osc = O(0.0, 0.0, 0.0, flange="rigid", restitution=e, gap_lower=None, gap_upper=g)
    sol = io.simulate(osc, 4.0, 0.0, v0, backend=backend)
    ev = sol.events
    assert list(ev.kind[:2]) == ["impact", "reversal"]
    t_hit = math.asin(g / v0)
    u = math.sqrt(v0 * v0 - g * g)
    assert ev.t[0] == pytest.approx(t_hit, abs=1e-14) and ev.x[0] == g and ev.v[0] == pytest.approx(u, rel=1e-13)
    amp = math.sqrt(g * g + (e * u) ** 2)
    assert ev.x[1] == pytest.approx(-amp, rel=1e-12) and amp > 1.0
    # The turning point: X = g cos(tau) - e u sin(tau) reaches -A at tau = pi - atan(e u / g).
    assert ev.t[1] == pytest.approx(t_hit + math.pi - math.atan2(e * u, g), abs=1e-12)
    assert sol.impacts[0].impulse == pytest.approx((1 + e) * u, rel=1e-13)


def test_a_rigid_stop_off_centre_rests_and_leaves_at_its_own_position():
    # Pressed on the upper wall at 0.5 by F - 0.5 > 0: it rests there (the initial mode) until
    # the pull F cos(Omega t) - 0.5 falls to -beta_s, an arccos.
    F, Om, bs, g = 1.6, 0.4, 0.1, 0.5
    osc = O(F, Om, bs, flange="rigid", gap_upper=g, gap_lower=2.0)
    for backend in ("heyoka", "scipy"):
        sol = io.simulate(osc, 20.0, g, 0.0, backend=backend)
        ev = sol.events
        assert (ev.kind[0], ev.x[0], ev.side[0]) == ("contact_end", g, 1)
        assert ev.t[0] == pytest.approx(math.acos((g - bs) / F) / Om, abs=1e-12)
        # The wall took the push F cos(Omega t) - g while it was positive.
        t0 = math.acos(g / F) / Om
        assert sol.impacts[0].impulse == pytest.approx(F * math.sin(Om * t0) / Om - g * t0, rel=1e-12)


# -- agreement between backends ----------------------------------------------------------------
_ASYMMETRIC = [
    (O(0.5, 1.1, 0.01, 1e4, gap_lower=1.5, gap_upper=0.6), 60.0, 0.0, 0.0),
    (O(0.5, 1.1, 0.01, 1e4, gap_lower=None, gap_upper=0.8), 60.0, 0.0, 0.0),
    (O(0.8, 1.1, 0.01, 1e4, zeta=0.01, exponent=1.5, gap_upper=None, gap_lower=0.7), 40.0, 0.0, 0.0),
    (O(1.6, 0.4, 0.1, flange="rigid", restitution=0.8, gap_lower=0.5, gap_upper=2.0), 40.0, 0.0, 0.0),
    (O(1.6, 0.4, 0.1, flange="rigid", restitution=0.8, gap_lower=None, gap_upper=0.7), 40.0, 0.0, 0.0),
    (O(0.9, 1.0, 0.1, harmonics=[(0.2, 2.3, 0.1)], gap_lower=None, gap_upper=None), 30.0, 0.0, 0.0),
]


@pytest.mark.parametrize("osc, t_end, x0, v0", _ASYMMETRIC)
def test_heyoka_and_scipy_agree_on_asymmetric_and_one_sided_members(osc, t_end, x0, v0):
    a = io.simulate(osc, t_end, x0, v0)
    b = io.simulate(osc, t_end, x0, v0, backend="scipy", **SCIPY_TIGHT)
    assert a.status == b.status == 0
    assert list(a.events.kind) == list(b.events.kind) and list(a.events.side) == list(b.events.side)
    np.testing.assert_allclose(a.events.t, b.events.t, rtol=0, atol=1e-8)
    # Every flange event is at its own flange; none at an absent one.
    walls = {1: osc.gap_upper, -1: -osc.gap_lower}
    for ev in (a.events[(a.events.side != 0) & (a.events.kind != "chatter")]):
        assert ev.x == walls[ev.side]
    for side in (1, -1):
        assert a.flange_impulse(side) == pytest.approx(b.flange_impulse(side), rel=1e-7, abs=1e-12)
        if osc.gap(side) == math.inf:
            assert a.flange_impulse(side) == 0.0 and not np.any(a.events.side == side)


def test_mirroring_swaps_the_flanges():
    osc = O(0.5, 1.1, 0.01, 1e4, 0.2, gap_lower=1.5, gap_upper=0.6)
    mirror = osc.mirrored()
    assert (mirror.gap_lower, mirror.gap_upper) == (0.6, 1.5)
    a = io.simulate(osc, 30.0, 0.1, 0.2)
    b = io.simulate(mirror, 30.0, -0.1, -0.2)
    assert list(a.events.kind) == list(b.events.kind)
    np.testing.assert_allclose(a.events.t, b.events.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.events.x, -b.events.x, rtol=0, atol=1e-12)


# -- the tape drive ------------------------------------------------------------------------------
def test_a_tape_off_centre_in_its_guide():
    drive = io.TapeDrive(guide_offset=0.3e-3)  # 1 mm clearance: 0.7 mm above, 1.3 mm below
    osc = drive.oscillator()
    assert (osc.gap_lower, osc.gap_upper) == (1.3, 0.7)
    one = io.TapeDrive(guide_offset=-0.2e-3, flange_sides="lower").oscillator()
    assert one.gap_upper == math.inf and one.gap_lower == pytest.approx(0.8, rel=1e-15)
    assert io.TapeDrive().oscillator().symmetric
    assert "gap_upper=0.7" in drive.describe()


@pytest.mark.parametrize("fields, match", [
    ({"guide_offset": 1e-3}, "guide_offset must be < clearance"),
    ({"guide_offset": -1.5e-3}, "guide_offset must be > -clearance"),
    ({"guide_offset": math.nan}, "guide_offset must be finite"),
    ({"flange_sides": "left"}, "flange_sides"),
])
def test_the_tape_drive_refuses_a_tape_on_or_past_a_flange(fields, match):
    with pytest.raises(ValueError, match=match):
        io.TapeDrive(**fields)
    # One-sided: only the flange that is there bounds the offset.
    assert io.TapeDrive(guide_offset=1.5e-3, flange_sides="lower").oscillator().gap_lower == 2.5


# -- refused input ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, error, match", [
    ({"gap_lower": -0.5}, ValueError, "gap_lower must be > 0 .*lower flange, at X = -gap_lower.*got -0.5"),
    ({"gap_upper": 0.0}, ValueError, "gap_upper must be > 0 .*got 0.0"),
    ({"gap_upper": -math.inf}, ValueError, "gap_upper must be > 0"),
    ({"gap_lower": math.nan}, ValueError, "gap_lower must be finite"),
    ({"gap_upper": "1"}, TypeError, "gap_upper must be a real number"),
    ({"gap_lower": None, "gap_upper": None}, ValueError, "K=10000.0 describe a flange, but both flanges are absent"),
])
def test_bad_flange_positions_are_refused(kwargs, error, match):
    with pytest.raises(error, match=match):
        O(0.5, 1.1, 0.01, 1e4, **kwargs)


def test_no_flange_at_all_takes_no_flange_law():
    free = O(0.5, 1.1, 0.01, gap_lower=None, gap_upper=math.inf)
    assert free.K == 0.0 and free.flanges == (-math.inf, math.inf)
    with pytest.raises(ValueError, match="flange='rigid' describe a flange"):
        O(0.5, 1.1, 0.01, flange="rigid", gap_lower=None, gap_upper=None)
    # A rigid start beyond the wall is refused with the wall's own position.
    with pytest.raises(ValueError, match="-gap_lower <= x0 <= gap_upper .* X = 0.7"):
        io.simulate(O(0.5, 1.1, 0.01, flange="rigid", gap_upper=0.7), 1.0, 0.8, 0.0, backend="scipy")


def test_the_paper_flange_law_of_rk4_keeps_its_printed_positions():
    osc = O(0.5, 1.1, 0.01, 1e4, gap_upper=0.6)
    with pytest.raises(ValueError, match="flange='paper' .* has its flanges at |X| = 1, got .*gap_upper=0.6"):
        io.simulate(osc, 1.0, 0.0, 0.0, backend="rk4", flange="paper")


@pytest.mark.parametrize("osc, t_end, x0, v0", [case for case in _ASYMMETRIC if not case[0].rigid and case[0].K])
def test_rk4_follows_heyoka_on_asymmetric_and_one_sided_members(osc, t_end, x0, v0):
    # The paper's fixed step against heyoka over the first contacts (its phase error grows
    # with time, as on the symmetric member): events at the member's own flanges.
    t_end = 15.0
    a = io.simulate(osc, t_end, x0, v0)
    b = io.simulate(osc, t_end, x0, v0, backend="rk4")
    assert b.status == 0 and list(a.events.kind) == list(b.events.kind)
    np.testing.assert_allclose(b.events.t, a.events.t, rtol=0, atol=2e-4)
    walls = {1: osc.gap_upper, -1: -osc.gap_lower}
    for ev in b.events[b.events.side != 0]:
        assert ev.x == walls[ev.side]
    for side in (1, -1):
        assert b.flange_impulse(side) == pytest.approx(a.flange_impulse(side), rel=2e-3, abs=1e-12)


@pytest.mark.parametrize("osc", [O(0.5, 1.1, 0.01, 1e4, gap_lower=None, gap_upper=0.7),
                                 O(0.5, 1.1, 0.01, 1e4, gap_lower=1.2, gap_upper=0.7, zeta=0.05)])
def test_the_saltation_monodromy_of_an_orbit_on_one_flange_matches_finite_differences(osc):
    from impactosc.dynamics import periodic_orbit

    orb = periodic_orbit(osc, 1, transient_periods=100)
    assert orb.status == 0 and "contact_start" in set(orb.events.kind)
    assert np.all(orb.events.x[orb.events.side == 1] == 0.7)

    def strobe(x, v):
        sol = io.simulate(osc, orb.period, x, v, backend="scipy", rtol=1e-13, atol=1e-15)
        return np.array([sol.x_final, sol.v_final])

    h = 1e-6
    fd = np.column_stack([(strobe(orb.x + h, orb.v) - strobe(orb.x - h, orb.v)) / (2 * h),
                          (strobe(orb.x, orb.v + h) - strobe(orb.x, orb.v - h)) / (2 * h)])
    np.testing.assert_allclose(orb.monodromy, fd, rtol=0, atol=1e-6)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("osc, t_end, x0, v0", [case for case in _ASYMMETRIC if case[0].linear and case[0].K]
                         + [(O(1.6, 0.4, 0.1, flange="rigid", gap_upper=0.5, gap_lower=2.0), 20.0, 0.5, 0.0),
                            (O(0.8, 1.1, 0.01, 1e3, zeta=0.01, harmonics=[(0.1, 2.3, 0.2)], gap_upper=None,
                               gap_lower=0.7), 40.0, 0.0, 0.0)])
def test_the_exact_backend_agrees_with_heyoka_on_asymmetric_and_one_sided_members(osc, t_end, x0, v0, compiled):
    a = io.simulate(osc, t_end, x0, v0)
    b = io.simulate(osc, t_end, x0, v0, backend="exact", compiled=compiled)
    assert a.status == b.status == 0
    assert list(a.events.kind) == list(b.events.kind) and list(a.events.side) == list(b.events.side)
    # Chatter on a one-sided wall: its accumulation time is conditioned like the impact speeds.
    np.testing.assert_allclose(b.events.t, a.events.t, rtol=0, atol=1e-8 if osc.rigid else 1e-11)
    for side in (1, -1):
        assert b.flange_impulse(side) == pytest.approx(a.flange_impulse(side), rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("backend", ["heyoka", "scipy", "exact", "rk4"])
def test_penetrations_and_chatter_are_measured_from_the_members_own_flanges(backend):
    osc = O(0.5, 1.1, 0.01, 1e4, gap_lower=1.5, gap_upper=0.6)
    sol = io.simulate(osc, 30.0, 0.0, 0.0, backend=backend)
    rows = sol.impacts[sol.impacts.complete]
    assert len(rows) > 2 and set(rows.side) == {1, -1}
    # the deepest point of each contact is its reversal inside the flange, at 0.6 or -1.5
    ev = sol.events
    rtol = 1e-3 if backend == "rk4" else 1e-12
    for row in rows:
        inside = ev[(ev.kind == "reversal") & (ev.t > row.start) & (ev.t < row.end)]
        assert len(inside) == 1
        assert row.peak_penetration == pytest.approx(row.side * inside.x[0] - osc.gap(row.side), rel=rtol)
    for side in (1, -1):
        deepest = max(rows.peak_penetration[rows.side == side])
        assert sol.max_penetration(side) == pytest.approx(deepest, rel=rtol)
    if backend != "rk4":  # a chatter on a one-sided wall ends at rest on that wall
        wall = O(2.0, 0.0, 0.1, flange="rigid", restitution=0.8, gap_lower=None, gap_upper=0.7)
        ch = io.simulate(wall, 12.0, 0.0, 0.0, backend=backend)
        chatter = ch.events[ch.events.kind == "chatter"]
        assert len(chatter) == 1 and chatter.x[0] == 0.7 and ch.x_final == 0.7
