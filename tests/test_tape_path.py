"""TapePath (issue 28, item 2): a tape path of several guides in SI units, on the exact n-DOF backend."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import impactosc
from impactosc import Guide, MechanicalSystem, TapeDrive, TapePath, TapePathRun, simulate_mechanical

# One-guide drives that cover the laws: spring flanges with friction, a rigid elastic flange,
# damping with a run-out harmonic and an offset single flange, a rigid flange that can rest.
ONE_GUIDE = [
    TapeDrive(clearance=50e-6, friction=0.2),
    TapeDrive(clearance=60e-6, friction=0.0, flange="rigid", restitution=1.0),
    TapeDrive(clearance=80e-6, friction=0.1, damping_ratio=0.03, runout_harmonics=((2, 0.3, 0.1),),
              guide_offset=10e-6, flange_sides="upper", static_friction=0.15),
    TapeDrive(clearance=60e-6, friction=0.0, flange="rigid", restitution=0.8, damping_ratio=0.02),
]


def _system_arrays(system: MechanicalSystem):
    contacts = [(c.normal.tolist(), c.gap, c.law, c.stiffness, c.exponent, c.restitution) for c in system.contacts]
    return system.M, system.C, system.K, system.harmonics, contacts, system.friction


@pytest.mark.parametrize("drive", ONE_GUIDE, ids=range(len(ONE_GUIDE)))
def test_one_guide_path_is_the_tape_drive_model(drive):
    path = TapePath.from_drive(drive)
    M, C, K, harmonics, contacts, friction = _system_arrays(path.mechanical_system(phase=0.3))
    M0, C0, K0, harmonics0, contacts0, friction0 = _system_arrays(
        MechanicalSystem.from_oscillator(drive.oscillator(phase=0.3)))
    for a, b in ((M, M0), (C, C0), (K, K0)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
    assert len(harmonics) == len(harmonics0)
    for (f, om, ph), (f0, om0, ph0) in zip(harmonics, harmonics0, strict=True):
        np.testing.assert_allclose([*f, om, ph], [*f0, om0, ph0], rtol=1e-12)
    assert len(contacts) == len(contacts0)
    for c, c0 in zip(contacts, contacts0, strict=True):
        assert c[0] == c0[0] and c[2] == c0[2]
        np.testing.assert_allclose([c[1], c[3], c[4], c[5]], [c0[1], c0[3], c0[4], c0[5]], rtol=1e-12)
    assert [(f.coordinate, f.kinetic, f.static) == pytest.approx((f0.coordinate, f0.kinetic, f0.static), rel=1e-12)
            for f, f0 in zip(friction, friction0, strict=True)] == [True] * len(friction0)
    for name, value in (("length_scale", drive.length_scale), ("time_scale", drive.time_scale),
                        ("force_scale", drive.force_scale)):
        assert getattr(path, name) == pytest.approx(value, rel=1e-14), name


@pytest.mark.parametrize("drive, atol", [(ONE_GUIDE[0], 1e-12), (ONE_GUIDE[1], 1e-12), (ONE_GUIDE[2], 1e-10)],
                         ids=range(3))
def test_one_guide_path_reproduces_the_tape_drive_run(drive, atol):
    """Event times and mean flange force of the 1-DOF exact backend, on the n-DOF backend via the path.

    The path and the drive give the same system (test above), so on the n-DOF backend their runs
    are the same to the last bit; against the 1-DOF backend the event times agree to ``atol``
    relative to the time reached. Drive 2's releases after long sticks are roots of a force that
    changes as slowly as the reel turns (Omega ~ 2e-4), which amplifies the backends' last-bit
    differences in the state to ~3e-12 t_end: there the tolerance is that of the n-DOF backend's
    own 1-DOF agreement test.
    """
    path = TapePath.from_drive(drive)
    t_end = 150.0
    osc = drive.oscillator()
    ref = impactosc.simulate(osc, t_end, 0.0, 0.0, backend="exact")
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(), t_end, [0.0], [0.0]))
    same = simulate_mechanical(MechanicalSystem.from_oscillator(osc), t_end, [0.0], [0.0])
    assert ref.status == 0 and run.status == 0
    np.testing.assert_allclose(run.solution.events.t, same.events.t, rtol=0, atol=1e-12 * t_end)
    ev = ref.events if osc.beta > 0.0 else ref.events[ref.events.kind != "reversal"]
    assert len(ev) > 20
    assert list(run.solution.events.kind) == list(ev.kind)
    np.testing.assert_allclose(run.solution.events.t, ev.t, rtol=0, atol=atol * t_end)
    for side in (1, -1):
        expected = ref.mean_flange_force(side) * drive.force_scale  # N
        assert run.mean_flange_force(0, side) == pytest.approx(expected, rel=1e-12, abs=1e-300)
    assert run.duration == pytest.approx(drive.lambda_to_seconds(t_end), rel=1e-14)


def test_one_guide_rigid_flange_that_rests_has_the_tape_drive_mean_force():
    """A rigid flange with restitution < 1: the chatter is summed differently, the impulse is the same."""
    drive = ONE_GUIDE[3]
    path = TapePath.from_drive(drive)
    t_end = 150.0
    ref = impactosc.simulate(drive.oscillator(), t_end, 0.0, 0.0, backend="exact")
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(), t_end, [0.0], [0.0]))
    assert ref.status == 0 and run.status == 0
    assert ref.flange_impulse(1) > 1.0
    assert run.mean_flange_force(0, 1) == pytest.approx(ref.mean_flange_force(1) * drive.force_scale, rel=1e-12)


def _beam_stiffness(drive: TapeDrive, span: float) -> float:
    """Eq. 4 written out for the in-plane reading: 48 E (h w^3 / 12) / l^3."""
    return 48.0 * drive.youngs_modulus * (drive.thickness * drive.width**3 / 12.0) / span**3


def test_two_guide_static_deflection_is_the_linear_chain_closed_form():
    drive = TapeDrive(friction=0.0, speed=1e-3, damping_ratio=0.7, clearance=1e-3)
    path = TapePath(drive, [Guide(0.02), Guide(0.05)], end_span=0.04)
    k0, k1, k2 = (_beam_stiffness(drive, s) for s in (0.02, 0.03, 0.04))
    np.testing.assert_allclose(path.span_stiffnesses, [k0, k1, k2], rtol=1e-13)
    u = drive.runout
    det = (k0 + k1) * (k1 + k2) - k1**2
    closed = np.array([k0 * (k1 + k2) * u / det, k0 * k1 * u / det])
    np.testing.assert_allclose(path.quasi_static_deflection(), closed, rtol=1e-13)
    # The run: the reel turns so slowly (omega_r / omega ~ 1e-8) that the pack offset is constant;
    # the damped chain settles on the static deflection (no flange is reached: 1 mm clearance).
    t_end = 400.0
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(), t_end, [0.0, 0.0], [0.0, 0.0]))
    assert run.status == 0 and len(run.solution.events) == 0
    t_s = path.time_to_seconds(t_end)
    x = [run.lateral_motion([t_s], p)[0] for p in (0.02, 0.05)]
    np.testing.assert_allclose(x, closed * math.cos(drive.omega_r * t_s), rtol=1e-9)


def test_masses_and_spans_follow_the_lumping_rule():
    drive = TapeDrive()
    path = TapePath(drive, [Guide(0.01), Guide(0.03), Guide(0.06)], end_span=0.02)
    m = drive.density * drive.width * drive.thickness
    np.testing.assert_allclose(np.diag(path.mass_matrix), [m * (0.01 + 0.01), m * (0.01 + 0.015),
                                                           m * (0.015 + 0.02)], rtol=1e-13)
    assert path.span_lengths == pytest.approx((0.01, 0.02, 0.03, 0.02))


def test_modal_damping_gives_every_mode_the_ratio():
    path = TapePath(TapeDrive(damping_ratio=0.04), [Guide(0.01), Guide(0.025), Guide(0.05)], end_span=0.01)
    M, C, K = path.mass_matrix, path.damping_matrix, path.stiffness_matrix
    w2, phi = np.linalg.eigh(np.diag(np.diag(M) ** -0.5) @ K @ np.diag(np.diag(M) ** -0.5))
    modes = np.diag(np.diag(M) ** -0.5) @ phi  # mass-normalised
    np.testing.assert_allclose(modes.T @ C @ modes, np.diag(2 * 0.04 * np.sqrt(w2)), rtol=1e-9,
                               atol=1e-9 * np.sqrt(w2.max()))


@pytest.mark.parametrize("kwargs, match", [
    (dict(guides=[Guide(0.03), Guide(0.02)]), r"guides\[1\]\.position must be > guides\[0\]\.position"),
    (dict(guides=[Guide(0.02, clearance=-1e-6)]), r"guides\[0\]: clearance must be > 0"),
    (dict(guides=[Guide(0.02, guide_offset=60e-6, clearance=50e-6)]), r"guides\[0\]: .*guide_offset"),
    (dict(guides=[Guide(0.02, flange="glue")]), r"guides\[0\]: flange"),
    (dict(guides=[]), "at least one Guide"),
    (dict(guides=[Guide(0.02)], end_span=-0.01), "end_span"),
])
def test_bad_paths_name_the_field(kwargs, match):
    with pytest.raises(ValueError, match=match):
        TapePath(TapeDrive(), **kwargs)


def test_bad_guides_and_drives_name_the_field():
    with pytest.raises(ValueError, match="Guide.position"):
        Guide(-0.01)
    with pytest.raises(ValueError, match="Guide.roller_diameter is required"):
        Guide(0.01, roller_runout=5e-6)
    with pytest.raises(ValueError, match="Guide.roller_runout"):
        Guide(0.01, roller_runout=-5e-6, roller_diameter=0.02)
    with pytest.raises(TypeError, match="drive must be a TapeDrive"):
        TapePath("paper", [Guide(0.01)])
    with pytest.raises(TypeError, match=r"guides\[0\] must be a Guide"):
        TapePath(TapeDrive(), [0.01])
    path = TapePath(TapeDrive(), [Guide(0.01, flange="rigid", restitution=0.5)])
    with pytest.raises(ValueError, match="same line.*guides"):
        path.mechanical_system()
    run = TapePathRun(TapePath(TapeDrive(friction=0.0), [Guide(0.01)]),
                      simulate_mechanical(TapePath(TapeDrive(friction=0.0), [Guide(0.01)]).mechanical_system(),
                                          1.0, [0.0], [0.0]))
    with pytest.raises(ValueError, match="position must lie on the path"):
        run.lateral_motion([0.0], 0.02)
    with pytest.raises(ValueError, match="guide must be < 1"):
        run.mean_flange_force(1)


def _gauss_impulse(path: TapePath, run: TapePathRun, guide: int) -> float:
    """Flange impulse by Gauss-Legendre quadrature of the sampled force over each contact (a referee)."""
    sol, system = run.solution, path.mechanical_system(run.phase)
    x, w = np.polynomial.legendre.leggauss(16)
    ev = sol.events
    total = 0.0
    for r in np.flatnonzero(ev.kind == "contact_start"):
        c = int(ev.index[r])
        if path.contact_guides()[c][0] != guide:
            continue
        later = np.flatnonzero((ev.kind == "contact_end") & (ev.index == c) & (np.arange(len(ev)) > r))
        a, b = ev.t[r], (ev.t[later[0]] if later.size else sol.t)
        inner = ev.t[(ev.t > a) & (ev.t < b)]
        cuts = np.unique(np.concatenate([[a], inner, [b]]))
        for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
            edges = np.linspace(lo, hi, max(1, math.ceil((hi - lo) / 0.002)) + 1)
            t = (0.5 * (edges[1:] - edges[:-1])[:, None] * x + 0.5 * (edges[1:] + edges[:-1])[:, None]).ravel()
            q, _ = sol.sample(t)
            f = system.contacts[c].stiffness * np.maximum(system.gaps(q)[:, c], 0.0)
            total += float(((0.5 * (edges[1:] - edges[:-1]))[:, None] * w * f.reshape(-1, x.size)).sum())
    return total * path.impulse_scale


def test_spring_flange_impulse_matches_quadrature_on_two_guides():
    drive = TapeDrive(clearance=40e-6, friction=0.0, damping_ratio=0.01)
    path = TapePath(drive, [Guide(0.02, clearance=150e-6), Guide(0.05)], end_span=0.03)
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(phase=1.2), 60.0, [0.0, 0.0], [0.0, 0.0]),
                      phase=1.2)
    assert run.status == 0
    assert run.flange_impulse(1) > 0.0
    assert run.flange_impulse(1) == pytest.approx(_gauss_impulse(path, run, 1), rel=1e-9)


def test_rigid_flange_impulses_are_the_momentum_jumps():
    drive = TapeDrive(clearance=40e-6, friction=0.0)
    path = TapePath(drive, [Guide(0.02, clearance=150e-6), Guide(0.05, flange="rigid", restitution=1.0)])
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(phase=1.2), 60.0, [0.0, 0.0], [0.0, 0.0]),
                      phase=1.2)
    assert run.status == 0
    t, j = run.impacts(1)
    assert t.size > 3
    rows = run.solution.events[run.solution.events.kind == "impact"]
    m = path.mass_matrix[1, 1] / path.mass_scale
    np.testing.assert_allclose(j, 2.0 * m * np.abs(rows.v[:, 1]) * path.impulse_scale, rtol=1e-12)
    assert run.flange_impulse(1) == pytest.approx(j.sum(), rel=1e-12)
    assert run.impacts_per_second(1) == pytest.approx(t.size / run.duration)


def test_lateral_motion_interpolates_between_the_supports():
    drive = TapeDrive(clearance=40e-6, friction=0.0)
    path = TapePath(drive, [Guide(0.02), Guide(0.05)], end_span=0.03)
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(), 30.0, [0.0, 0.0], [0.0, 0.0]))
    t = np.linspace(0.0, run.duration, 11)
    q, _ = run.solution.sample(path.seconds_to_time(t))
    np.testing.assert_allclose(run.lateral_motion(t, 0.0), path.pack_runout(t), rtol=1e-14)
    np.testing.assert_allclose(run.lateral_motion(t, 0.05), q[:, 1] * path.length_scale, rtol=1e-14)
    np.testing.assert_allclose(run.lateral_motion(t, 0.035),
                               0.5 * (q[:, 0] + q[:, 1]) * path.length_scale, rtol=1e-12, atol=1e-20)
    np.testing.assert_allclose(run.lateral_motion(t, 0.08), 0.0, atol=0.0)


def test_roller_runout_moves_the_flanges_not_the_free_tape():
    """Without friction and contact the tape does not feel its roller: its absolute motion is unchanged."""
    drive = TapeDrive(friction=0.0, clearance=1e-3, damping_ratio=0.05)
    plain = TapePath(drive, [Guide(0.02), Guide(0.05)], end_span=0.03)
    a, d, phi = 30e-6, 0.02, 0.4
    roller = plain.replace(guides=(Guide(0.02), Guide(0.05, roller_runout=a, roller_diameter=d, roller_phase=phi)))
    w = 2.0 * drive.speed / d
    # The same absolute start (at rest, on the axis): the roller's coordinate is measured from its flanges.
    q0 = np.array([0.0, -a * math.cos(phi)]) / roller.length_scale
    v0 = np.array([0.0, a * w * math.sin(phi)]) * roller.time_scale / roller.length_scale
    t_end = 200.0
    ref = TapePathRun(plain, simulate_mechanical(plain.mechanical_system(), t_end, [0.0, 0.0], [0.0, 0.0]))
    run = TapePathRun(roller, simulate_mechanical(roller.mechanical_system(), t_end, q0, v0))
    assert ref.status == 0 and run.status == 0
    t = np.linspace(0.0, ref.duration, 23)
    assert np.abs(roller.roller_runout(t)[:, 1]).max() > 0.5 * a
    for position in (0.02, 0.05, 0.065):
        x = ref.lateral_motion(t, position)
        np.testing.assert_allclose(run.lateral_motion(t, position), x, rtol=0, atol=1e-9 * np.abs(x).max())


def _path(guides, **drive):
    return TapePath(TapeDrive(**drive), guides, end_span=0.03)


TWO = [Guide(0.02, clearance=300e-6), Guide(0.05, clearance=30e-6)]
FOUR = [Guide(0.02, clearance=300e-6), Guide(0.05, clearance=200e-6, wrap_angle=90.0),
        Guide(0.08, clearance=20e-6), Guide(0.11, clearance=300e-6, flange="rigid", restitution=1.0)]


@pytest.mark.parametrize("guides", [TWO, FOUR], ids=["two", "four"])
def test_multi_guide_runs_find_contact_where_the_quasi_static_runout_exceeds_the_clearance(guides):
    path = _path(guides, friction=0.0, damping_ratio=0.02)
    qs = np.abs(path.quasi_static_deflection())
    clear = np.array([path.guide_drive(i).clearance for i in range(path.n)])
    assert np.any(qs > 1.5 * clear) and np.any(qs < 0.7 * clear)
    # A quarter of a reel turn from the pack's extreme: the pack sweeps the whole run-out.
    seconds = 0.5 * math.pi / path.drive.omega_r
    sol = simulate_mechanical(path.mechanical_system(), path.seconds_to_time(seconds), np.zeros(path.n),
                              np.zeros(path.n))
    run = TapePathRun(path, sol)
    assert run.status == 0, sol.message
    rate = run.impacts_per_second()
    force = run.mean_flange_force()
    assert np.all(rate[qs > 1.5 * clear] > 0.0) and np.all(force[qs > 1.5 * clear] > 0.0)
    assert np.all(rate[qs < 0.7 * clear] == 0.0)
    assert sol.energy_balance()["relative"] < 1e-9


def test_two_guide_run_with_friction_reaches_its_end():
    path = TapePath(TapeDrive(clearance=30e-6, friction=0.2), [Guide(0.01), Guide(0.03, friction=0.0)])
    sol = simulate_mechanical(path.mechanical_system(), path.seconds_to_time(2e-3), [0.0, 0.0], [0.0, 0.0])
    assert sol.status == 0, sol.message


def test_speed_benchmark_runs_quick(capsys):
    """benchmarks/tape_path_speed.py end to end on 10 ms (no timing asserted: the machine is shared)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "_bench_tape_path_speed", Path(__file__).resolve().parent.parent / "benchmarks" / "tape_path_speed.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.main(["--quick", "--variants", "spring", "rigid"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| spring") or
            line.startswith("| rigid")]
    assert len(rows) == 2 and all(row.split("|")[8].strip() == "0" for row in rows)


@settings(max_examples=40, deadline=None)
@given(gaps=st.lists(st.floats(2e-3, 0.1), min_size=1, max_size=6), end=st.one_of(st.none(), st.floats(2e-3, 0.1)))
def test_chain_statics_properties(gaps, end):
    """Any chain: M, K symmetric positive definite; a chain held only at the pack follows its offset
    rigidly; with a fixed end the static deflection falls monotonically along the path, between 0 and
    the run-out."""
    positions = np.cumsum(gaps)
    path = TapePath(TapeDrive(), [Guide(float(p)) for p in positions], end_span=end)
    K, M = path.stiffness_matrix, path.mass_matrix
    np.testing.assert_allclose(K, K.T, rtol=0, atol=0)
    assert np.all(np.linalg.eigvalsh(K) > 0) and np.all(np.diag(M) > 0)
    assert np.sum(np.diag(M)) == pytest.approx(path.drive.density * path.drive.width * path.drive.thickness
                                                * (positions[-1] + (end or 0.0)), rel=1e-12)  # all the tape, once
    x = path.quasi_static_deflection()
    u = path.drive.runout
    if end is None:
        np.testing.assert_allclose(x, u, rtol=1e-9)
    else:
        assert np.all(np.diff(x) < 0) and np.all((x > 0) & (x < u))


def test_one_guide_path_reads_what_the_tape_drive_sensor_reads():
    """``TapePathRun.contact_observables`` of the one-guide path is the drive's ``contact_observables``."""
    drive = ONE_GUIDE[0]  # spring flanges, friction
    path = TapePath.from_drive(drive)
    t_end = 150.0
    ref = impactosc.simulate(drive.oscillator(), t_end, 0.0, 0.0, backend="exact").contact_observables(drive)
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(), t_end, [0.0], [0.0]))
    assert ref["upper"]["impacts"] > 10
    for side, name in ((1, "upper"), (-1, "lower"), (None, "both")):
        seen, expected = run.contact_observables(0, side), ref[name]
        for key in ("impact_rate", "mean_force", "mean_impulse", "ae_impact_sum", "impact_energy_rate"):
            assert seen[key] == pytest.approx(expected[key], rel=1e-9, nan_ok=True), (name, key)
        assert math.isnan(seen["dissipation_rate"])  # spring flanges: no per-contact dissipation on this backend


def test_rigid_flange_dissipation_per_impact_is_newtons_loss():
    """``(1 - e^2) m v^2 / 2`` per impact, summed per second, from the path's entry speeds."""
    drive = ONE_GUIDE[3]
    path = TapePath.from_drive(drive)
    run = TapePathRun(path, simulate_mechanical(path.mechanical_system(), 150.0, [0.0], [0.0]))
    seen = run.contact_observables(0)
    e = drive.restitution
    assert seen["impact_energy_rate"] > 0.0
    assert seen["dissipation_rate"] == pytest.approx((1.0 - e**2) * seen["impact_energy_rate"], rel=1e-12)
    with pytest.raises(ValueError, match="guide"):
        run.contact_observables(5)
