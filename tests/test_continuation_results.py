"""What a continuation result offers a COCO/AUTO user (issue 26 items 4 and 5).

Every numeric field a parameter (the flange gaps, a drive's guide offset: derivatives
against central differences of the map, a grazing against Den Hartog's amplitude), a
branch saved and loaded with its model, restarts from a labelled or an indexed point, the
orbit at a label, the AUTO-style table, and the command line's files.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc.dynamics import Branch, continuation
from impactosc.dynamics.continuation._problem import MapProblem

OMEGA, BETA = 1.5, 0.1
FC = dy.den_hartog_onset(OMEGA, BETA)
DH_GUESS = (-0.7891869048001374, 0.16283153617831878)


@pytest.fixture(scope="module")
def den_hartog_branch():
    orb = dy.periodic_orbit(io.Oscillator(0.8 * FC, OMEGA, BETA, 24.0), guess=DH_GUESS, backend="exact")
    return continuation(orb, "F", (0.5 * FC, 1.1 * FC))


# -- every numeric field a parameter -----------------------------------------------------
DRIVE = io.TapeDrive(damping_ratio=0.05, runout_hub=1.5e-3, runout_full=1.5e-3, guide_offset=1e-4, speed=8000.0,
                     friction=0.05)
GAP_CASES = [
    (io.Oscillator(1.0, 1.5, 0.1, 24.0, zeta=0.02, gap_lower=0.7, gap_upper=0.8), "gap_lower", (-0.5, 0.3), "exact"),
    (io.Oscillator(1.0, 1.5, 0.1, 24.0, zeta=0.02, gap_lower=0.7, gap_upper=0.8), "gap_upper", (-0.5, 0.3), "exact"),
    (io.Oscillator(0.5, 0.8, 0.0, flange="rigid", restitution=0.8, zeta=0.05, gap_lower=None, gap_upper=0.5),
     "gap_upper", (0.0, 0.3), "exact"),
    (io.Oscillator(1.0, 1.5, 0.1, 24.0, zeta=0.02, exponent=1.5, gap_upper=0.5), "gap_upper", (-0.5, 0.3), "scipy"),
    (DRIVE, "guide_offset", (0.5, 0.0), "exact"),
]


@pytest.mark.parametrize("base, name, z, backend", GAP_CASES,
                         ids=["spring-lower", "spring-upper", "rigid-upper", "power-law-upper", "drive-offset"])
def test_gap_and_offset_derivatives_match_central_differences_of_the_map(base, name, z, backend):
    # dP/dp of a flange position: the existing sensitivity machinery (the guards and the spring
    # law depend on the gap, their derivatives taken on the model's own expressions)
    options = {"rtol": 1e-12, "atol": 1e-13} if backend == "scipy" else {}
    problem = MapProblem(base, (name,), 1, 0.0, backend, options)
    p = problem.values()[0]
    z = np.array(z)
    ev = problem.evaluate(z, (p,))
    counts = ev.recorder.counts
    assert counts["contact_start"] + counts["impact"] >= 1  # the map meets the flange it moves
    h = 1e-6 * max(abs(p), 1e-3)
    fd = (problem.evaluate(z, (p + h,)).image - problem.evaluate(z, (p - h,)).image) / (2.0 * h)
    scale = max(1.0, float(np.abs(fd).max()))
    assert np.allclose(ev.dp[:, 0], fd, rtol=0.0, atol=(1e-5 if backend == "scipy" else 1e-6) * scale)


def test_a_branch_in_the_upper_gap_grazes_at_den_hartogs_amplitude():
    # the contact-free orbit does not feel the flange: it grazes where gap_upper equals its amplitude
    F = 0.8 * FC
    osc = io.Oscillator(F, OMEGA, BETA, 24.0, gap_upper=1.3)
    orb = dy.periodic_orbit(osc, guess=DH_GUESS, backend="exact")
    br = continuation(orb, "gap_upper", (0.5, 1.3), direction="backward")
    amplitude = dy.den_hartog_amplitude(F, OMEGA, BETA)
    clear = [p for p in br.points if p.upper_margin > 0]
    assert clear and all(abs(p.parameters["gap_upper"] - p.upper_margin - amplitude) < 1e-9 for p in clear)
    gr = [s for s in br.find("grazing") if s.flange == "upper"]
    assert gr and abs(gr[0].parameter - amplitude) < 1e-9, br.summary()
    # the figure's max X is measured from each point's own flange: the amplitude, whatever the gap
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    ax = br.plot(y="max_x")
    drawn = np.fmax(*(line.get_ydata() for line in ax.get_lines()[:2]))
    on_clear = np.array([p.upper_margin > 0 for p in br.points])
    assert np.allclose(drawn[on_clear], amplitude, atol=1e-9)


def test_oscillator_replace_changes_fields_and_names_unknown_ones():
    osc = io.Oscillator(0.5, 1.1, 0.01, 1e4)
    assert osc.replace(gap_lower=None, F=0.7) == io.Oscillator(0.7, 1.1, 0.01, 1e4, gap_lower=None)
    with pytest.raises(TypeError, match="gap_middle"):
        osc.replace(gap_middle=1.0)
    with pytest.raises(ValueError, match="gap_upper"):
        osc.replace(gap_upper=-1.0)


# -- one file, restarts, orbits, the table ----------------------------------------------
def test_a_branch_saved_and_loaded_is_the_same_branch(den_hartog_branch, tmp_path):
    br = den_hartog_branch
    path = tmp_path / "branch.nc"
    br.save(path)
    again = Branch.load(path)
    assert again.base == br.base and again.names == br.names and again.n == br.n
    assert (again.status, again.message, again.ends, again.backend) == (br.status, br.message, br.ends, br.backend)
    assert again.section_phase == br.section_phase and again.options == br.options
    assert len(again) == len(br)
    for p, q in zip(br.points, again.points, strict=True):
        assert p.parameters == q.parameters and (p.x, p.v, p.period) == (q.x, q.v, q.period)
        assert np.array_equal(p.multipliers, q.multipliers, equal_nan=True)
        assert (p.stability, p.signature, p.collapsed) == (q.stability, q.signature, q.collapsed)
        for name in ("upper_margin", "lower_margin", "stick_margin", "arclength"):
            assert getattr(p, name) == getattr(q, name) or math.isnan(getattr(p, name)) and math.isnan(getattr(q, name))
    assert [(s.label, s.kind, s.parameters, s.flange) for s in br.special] == \
        [(s.label, s.kind, s.parameters, s.flange) for s in again.special]
    assert again.summary() == br.summary()


def test_a_saved_branch_of_a_one_sided_stop_with_harmonics(tmp_path):
    osc = io.Oscillator.from_harmonics([(0.3, 0.8, 0.0), (0.05, 1.6, 0.3)], beta=0.0, zeta=0.05, flange="rigid",
                                       restitution=0.8, gap_lower=None)
    orb = dy.periodic_orbit(osc, backend="exact", transient_periods=100)
    br = continuation(orb, "F", (0.25, 0.35), max_points=5)
    br.save(tmp_path / "stop.nc")
    again = Branch.load(tmp_path / "stop.nc")
    assert again.base == osc and math.isinf(again.base.gap_lower)


def test_an_empty_branch_of_a_drive_saves_and_loads(tmp_path):
    drive = io.TapeDrive(runout_harmonics=((2, 0.1, 0.3),), flange_sides="upper", static_friction=0.3)
    empty = Branch(("speed",), 1, [], [], -1, "no start", ((-1, "no start"),), drive, "heyoka",
                   options={"tol": np.float64(1e-15)})
    empty.save(tmp_path / "empty.nc")
    again = Branch.load(tmp_path / "empty.nc")
    assert again.base == drive and len(again) == 0 and again.options == {"tol": 1e-15}
    assert (again.status, again.ends) == (-1, ((-1, "no start"),))


def test_a_file_that_is_no_branch_is_refused(tmp_path):
    import xarray as xr

    path = tmp_path / "other.nc"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(path, engine="scipy")
    with pytest.raises(ValueError, match="not a saved continuation branch"):
        Branch.load(path)


def test_the_orbit_at_a_label_and_at_an_index(den_hartog_branch):
    br = den_hartog_branch
    gr = br.find("grazing")[0]
    orbit = br.orbit(gr.label)
    assert orbit.status == 0 and abs(orbit.x - gr.x) < 1e-8 and abs(orbit.v - gr.v) < 1e-8
    x, _ = orbit.solution.sample(np.linspace(0.0, orbit.period, 400))
    assert abs(x.max() - 1.0) < 1e-3  # it grazes the upper flange
    k = len(br) // 3
    assert br.orbit(k).x == pytest.approx(br.points[k].x, abs=1e-9)
    with pytest.raises(KeyError, match="no special point is labelled 'XX9'"):
        br.orbit("XX9")


def test_restart_from_a_branch_point_and_from_a_loaded_one(den_hartog_branch, tmp_path):
    br = den_hartog_branch
    point = br.points[5]
    other = continuation(point, "Omega", (1.45, 1.55), max_points=40)
    assert other.status == 0, other.message
    # the new branch passes through the point it started from
    hit = [q for q in other.points if abs(q.parameters["Omega"] - OMEGA) < 1e-12]
    assert hit and abs(hit[0].x - point.x) < 1e-9 and abs(hit[0].v - point.v) < 1e-9
    assert other.base == br.model(point)
    br.save(tmp_path / "b.nc")
    loaded = Branch.load(tmp_path / "b.nc")
    again = continuation(loaded.points[5], "Omega", (1.45, 1.55), max_points=40)
    assert len(again) == len(other)
    assert np.allclose(again.values("Omega"), other.values("Omega"), atol=1e-9)


def test_restart_from_a_labelled_point_in_another_parameter(den_hartog_branch):
    gr = den_hartog_branch.point("GR1")
    other = continuation(gr, "Omega", (1.45, 1.55), max_points=30)
    # the orbit grazes (both flanges: it is symmetric) at the start: the new branch locates it again
    again = other.find("grazing")
    assert again and abs(again[0].parameters["Omega"] - OMEGA) < 1e-9, other.summary()
    assert other.base.F == pytest.approx(gr.parameter, rel=1e-15)


def test_the_auto_style_table(den_hartog_branch):
    br = den_hartog_branch
    rows = br.table()
    assert rows[0]["label"] == "EP1" and rows[-1]["label"] == "EP2"
    assert [r["label"] for r in rows[1:-1]] == [s.label for s in br.special]
    gr = next(r for r in rows if r["type"] == "GR")
    assert gr["flange"] in ("upper", "lower") and gr["F"] == pytest.approx(FC, rel=1e-9)
    assert rows[0]["flange"] == "none" and rows[0]["stability"] == "stable"
    assert rows[-1]["flange"] == "both"  # the unstable contacting orbit at the far end
    text = br.summary()
    assert "LAB" in text and "stability" in text and all(r["label"] in text for r in rows)
    ds = br.to_xarray()
    assert list(ds.label.values) == [r["label"] for r in rows]
    assert list(ds.type.values) == [r["type"] for r in rows]
    assert np.allclose(ds.label_F.values, [r["F"] for r in rows])
    assert ds.norm.values[0] == pytest.approx(math.hypot(br.points[0].x, br.points[0].v))


def test_cli_continue_out_is_a_loadable_branch(tmp_path, capsys):
    from impactosc.cli import main

    nc = tmp_path / "branch.nc"
    assert main(["continue", "--F", "0.3", "--Omega", "0.8", "--beta", "0.05", "--K", "1e4", "--param", "F",
                 "--limits", "0.2", "0.36", "--guess", "0.8", "0", "--out", str(nc)]) == 0
    br = Branch.load(nc)
    assert br.names == ("F",) and br.status == 0 and br.values().max() == pytest.approx(0.36)
    assert main(["continue", "--F", "0.3", "--Omega", "0.8", "--beta", "0.05", "--K", "1e4", "--param", "F",
                 "--limits", "0.2", "0.36", "--out", str(tmp_path / "branch.csv")]) == 2
    assert "must end in .nc" in capsys.readouterr().err
