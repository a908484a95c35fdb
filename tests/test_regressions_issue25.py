"""Regressions of issue 25: energy of chatter tails, hostile gaps, the CLI, plots and defaults."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import impactosc as io

BACKENDS = ("heyoka", "scipy", "exact")


# -- the energy identity over a chatter tail on a wall that is not at |X| = 1 ----------------

def _balance(osc, t_end, backend, x0=0.0, v0=0.0):
    sol = io.simulate(osc, t_end, x0, v0, backend=backend)
    return sol, sol.energy_balance()


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_chatter_tail_books_the_forcing_work_against_the_wall_where_it_is(backend):
    # A constant push F = 2 drives the mass from rest at 0 onto the upper wall at X = 0.5,
    # where it chatters to rest: the forcing does the work F * 0.5 = 1 in total (the mass
    # ends at the wall, at rest), whatever the backend and however the tail is resolved.
    osc = io.Oscillator(2.0, 0.0, 0.1, flange="rigid", restitution=0.5, gap_upper=0.5)
    sol, bal = _balance(osc, 15.0, backend)
    assert sol.status == 0 and sol.counts["chatter"] == 1
    assert bal["forcing_work"] == pytest.approx(1.0, rel=1e-12)
    assert abs(bal["residual"]) <= 1e-12 * bal["scale"]


gaps = st.one_of(st.just(1.0), st.floats(0.2, 3.0))


@given(push=st.floats(1.1, 4.0), beta=st.floats(0.0, 0.2), e=st.floats(0.1, 0.9),
       gap_lower=st.one_of(st.none(), gaps), gap_upper=gaps, side=st.sampled_from([1, -1]))
def test_the_energy_identity_holds_on_rigid_walls_at_any_gap(push, beta, e, gap_lower, gap_upper, side):
    # A constant force (Omega = 0) of `push` times the wall's gap drives the mass from rest
    # onto one wall, where it chatters to rest or rebounds. heyoka's and scipy's forcing work
    # must match the exact backend's closed form to their event-time tolerance (rtol 1e-10;
    # the work is the force times a displacement of order the gap), and the identity must close.
    if gap_lower is None:
        side = 1
    osc = io.Oscillator(push * (gap_upper if side == 1 else gap_lower), 0.0, beta, phase=0.0 if side == 1 else math.pi,
                        flange="rigid", restitution=e, gap_lower=gap_lower, gap_upper=gap_upper)
    reference = io.simulate(osc, 15.0, 0.0, 0.0, backend="exact").energy_balance()
    for backend in ("heyoka", "scipy"):
        sol, bal = _balance(osc, 15.0, backend)
        assert sol.status == 0, sol.message
        assert abs(bal["residual"]) <= 1e-8 * bal["scale"], (backend, bal)
        assert bal["forcing_work"] == pytest.approx(reference["forcing_work"], rel=1e-8, abs=1e-9), backend


# -- flange gaps the backends cannot resolve ----------------------------------------------------

@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", ["gap_lower", "gap_upper"])
@pytest.mark.parametrize("flange", ["spring", "rigid"])
def test_a_gap_below_what_the_backends_resolve_is_refused_by_name(backend, name, flange):
    # heyoka failed (status -1, "This is a bug: please report it") and scipy missed the impact
    # of a rigid wall at a gap of 1e-100; both run from rest at X = 0.
    osc = io.Oscillator(0.5, 1.1, 0.01, 1e4, flange=flange, **{name: 1e-100})
    with pytest.raises(ValueError, match=rf"{name}=1e-100 is below 1e-12"):
        io.simulate(osc, 5.0, 0.0, 0.0, backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_smallest_gap_allowed_runs_alike_on_every_backend(backend):
    # A rigid wall at 1e-12 from rest, pushed by F cos(1.1 t): the impacts the three backends
    # find agree (53 in five time units).
    osc = io.Oscillator(0.5, 1.1, 0.01, flange="rigid", gap_upper=1e-12)
    sol = io.simulate(osc, 5.0, 0.0, 0.0, backend=backend)
    reference = io.simulate(osc, 5.0, 0.0, 0.0, backend="exact")
    assert sol.status == 0 and sol.counts == reference.counts and sol.counts["impact"] > 10


# -- the command line ---------------------------------------------------------------------------

def _cli(argv, capsys):
    from impactosc.__main__ import main

    try:
        status = main(argv)
    except SystemExit as exc:  # argparse's own errors (a bad value of a typed option)
        status = exc.code
    out, err = capsys.readouterr()
    return status, out, err


def _no_run(monkeypatch):
    """Make every simulation fail loudly: a check that comes after the work would hit it."""
    def boom(*args, **kwargs):
        raise AssertionError("the run started before the output was checked")

    monkeypatch.setattr(io, "simulate", boom)


OSC = ["--F", "0.5", "--Omega", "1.1", "--beta", "0.1", "--K", "1e4"]


@pytest.mark.parametrize("plot, why", [("fig.txt", "the extension .txt"), ("fig", "no extension")])
def test_the_cli_checks_the_figure_format_before_the_run(capsys, monkeypatch, tmp_path, plot, why):
    _no_run(monkeypatch)
    status, _, err = _cli(["simulate", *OSC, "--plot", str(tmp_path / plot)], capsys)
    assert status == 2 and why in err and ".png" in err and "\n" not in err.strip()


def test_the_cli_refuses_a_dataset_name_it_would_not_write_as_named(capsys, tmp_path):
    status, _, err = _cli(["sweep", "--grid", "speed=4,8", "--out", str(tmp_path / "sweep.txt")], capsys)
    assert status == 2 and "write netCDF (.nc) or CSV (.csv)" in err


def test_the_cli_writes_csv_under_a_csv_name(capsys, tmp_path):
    # Before, --out x.csv wrote netCDF (binary) under the .csv name.
    import pandas as pd

    path = tmp_path / "diagram.csv"
    status, out, _ = _cli(["bifurcation", *OSC, "--param", "F", "--range", "0.2", "0.3", "--n", "2",
                           "--transient-periods", "2", "--record-periods", "3", "--serial", "--no-progress",
                           "--out", str(path)], capsys)
    assert status == 0 and f"dataset written to {path} (CSV)" in out
    assert path.read_text().startswith("# parameter: F")
    table = pd.read_csv(path, comment="#")
    assert len(table) == 2 * 3 and {"F", "x", "v", "status"} <= set(table.columns)
    assert sorted(set(table["F"])) == [0.2, 0.3] and (table["status"] == 0).all()


def test_a_rigid_flange_needs_no_stiffness_on_the_command_line(capsys):
    status, out, err = _cli(["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.1", "--flange", "rigid",
                             "--restitution", "0.8", "--t-end", "10", "--events", "1"], capsys)
    assert status == 0, err
    assert "flange='rigid'" in out and "status=0" in out


def test_a_spring_flange_still_needs_its_stiffness(capsys):
    status, _, err = _cli(["simulate", "--F", "0.5", "--Omega", "1.1", "--beta", "0.1"], capsys)
    assert status == 2 and "missing: K" in err and "spring flange" in err


def test_the_cli_places_the_flanges_of_an_oscillator(capsys):
    # The chatter of the energy regression, from the command line: a constant push onto a rigid
    # wall at X = 0.5, no lower flange; it comes to rest on the wall.
    status, out, err = _cli(["simulate", "--F", "2", "--Omega", "0", "--beta", "0.1", "--flange", "rigid",
                             "--restitution", "0.5", "--gap-upper", "0.5", "--gap-lower", "none", "--x0", "0",
                             "--t-end", "15", "--events", "30"], capsys)
    assert status == 0, err
    assert "gap_lower=inf, gap_upper=0.5" in out and "chatter" in out


def test_the_cli_places_the_flanges_of_a_tape_drive(capsys):
    status, out, err = _cli(["simulate", "--guide-offset", "10e-6", "--flange-sides", "upper",
                             "--duration", "1e-4", "--record", "stats"], capsys)
    assert status == 0, err
    assert "flanges at gap_lower=inf, gap_upper=0.99" in out  # 1 - 10 um / 1 mm clearance


@pytest.mark.parametrize("argv, message", [
    (["simulate", "--gap-upper", "0.5"], "flange distances of an oscillator"),
    (["simulate", "--speed", "4", "--gap-lower", "2"], "not both"),
    (["simulate", *OSC, "--gap-upper", "abc"], "expected a number or 'none'"),
    (["simulate", "--flange-sides", "middle"], "invalid choice: 'middle'"),
    (["bifurcation", *OSC, "--param", "flange", "--range", "0", "1"],
     "'flange' is not a number but chooses a member of the family: set it with --flange"),
    (["bifurcation", "--param", "flange_sides", "--range", "0", "1"], "set it with --flange-sides"),
    (["bifurcation", "--param", "runout_harmonics", "--range", "0", "1"], "set it with --runout-harmonic"),
    (["chart", "--param", "clearance", "--bracket", "1e-4", "2e-4", "--grid", "flange_sides=1,2",
      "--grid", "speed=2,4"], "set it with --flange-sides"),
    (["onset", *OSC, "--param", "flange", "--bracket", "0", "1"], "set it with --flange"),
    (["continue", *OSC, "--param", "harmonics", "--limits", "0", "1", "--guess", "0.8", "0"],
     "set it with --harmonic"),
])
def test_the_cli_refuses_flange_options_it_cannot_use(capsys, monkeypatch, argv, message):
    _no_run(monkeypatch)
    status, _, err = _cli(argv, capsys)
    assert status == 2 and message in err, err


# -- figures: the flanges where they are, a rigid wall's impacts ----------------------------------

@pytest.fixture()
def plt():
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot

    yield pyplot
    pyplot.close("all")


#: A rigid wall at X = 0.5 and no lower flange, driven into the wall: five impacts in 30 units.
WALL = io.Oscillator(0.5, 1.1, 0.1, flange="rigid", restitution=0.5, gap_upper=0.5, gap_lower=None)


def _flange_lines(ax):
    """{label or '': positions} of the dashed flange lines of ``ax`` (horizontal or vertical)."""
    from impactosc.results._frames import FLANGE_STYLE

    out = {}
    for line in ax.get_lines():
        if line.get_linestyle() == FLANGE_STYLE["ls"] and line.get_color() == FLANGE_STYLE["color"]:
            xs, ys = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
            out.setdefault(line.get_label() if not line.get_label().startswith("_") else "", []).append(
                (xs, ys))
    return out


def test_a_rigid_run_plots_with_its_impacts_and_its_wall(plt):
    # Solution.plot raised KeyError: 'impact' on every rigid-flange run, and drew flanges at +-1.
    sol = io.simulate(WALL, 30.0, 0.0, 0.0)
    assert sol.counts["impact"] == 5
    fig = sol.plot()
    ax_t, ax_p = fig.axes
    labels = [t.get_text() for t in ax_t.get_legend().get_texts()]
    assert "impact (5)" in labels and "upper rigid wall (X = 0.5)" in labels
    lines = _flange_lines(ax_t)
    assert list(lines) == ["upper rigid wall (X = 0.5)"]  # no line where the absent lower flange would be
    ((_, ys),) = lines["upper rigid wall (X = 0.5)"]
    assert np.all(ys == 0.5)
    ((xs, _),) = _flange_lines(ax_p)[""]
    assert np.all(xs == 0.5)


def test_the_solution_figure_shows_a_rigid_walls_impulses_not_a_flat_force(plt):
    from impactosc.results import plot_solution

    sol = io.simulate(WALL, 30.0, 0.0, 0.0)
    fig = plot_solution(sol)
    ax_x, ax_f, ax_p, twin = fig.axes
    ((_, ys),) = _flange_lines(ax_x)["upper rigid wall (X = 0.5)"]
    assert np.all(ys == 0.5) and len(_flange_lines(ax_x)) == 1
    # One stem per impact, as high as its impulse (1 + e)|V|.
    (stems,) = twin.collections
    heights = sorted(seg[1, 1] for seg in stems.get_segments())
    assert heights == pytest.approx(sorted(sol.impacts.impulse), rel=1e-12)
    assert heights == pytest.approx(sorted(1.5 * np.abs(sol.impacts.entry_velocity)), rel=1e-12)


def test_a_spring_run_draws_its_flanges_at_their_gaps(plt):
    osc = io.Oscillator(0.5, 1.1, 0.01, 1e4, gap_lower=1.5, gap_upper=0.5)
    sol = io.simulate(osc, 20.0, 0.0, 0.0)
    lines = _flange_lines(sol.plot().axes[0])
    assert sorted(lines) == ["lower flange (X = -1.5)", "upper flange (X = 0.5)"]


def test_a_section_and_a_diagram_draw_the_walls_where_they_are(plt):
    from impactosc.dynamics import bifurcation_diagram, plot_bifurcation, stroboscopic_section

    section = stroboscopic_section(WALL, 10, transient_periods=5, x0=0.0)
    ax = section.plot()
    assert [np.unique(xs).tolist() for xs, _ in _flange_lines(ax)[""]] == [[0.5]]
    ds = bifurcation_diagram(WALL, "F", [0.3, 0.5], transient_periods=5, record_periods=3, x0=0.0,
                             executor="serial", progress=False)
    ax = plot_bifurcation(ds)  # the base read back from the Dataset's attributes
    assert list(_flange_lines(ax)) == ["upper rigid wall (X = 0.5)"]


def test_a_diagram_over_the_guide_offset_moves_the_flanges_with_it(plt):
    # The diagram's Dataset as bifurcation_diagram lays it out (a tape drive's runs take a
    # minute: the points do not matter here, the flanges do).
    xr = pytest.importorskip("xarray")
    from impactosc.dynamics import plot_bifurcation

    offsets = [-400e-6, 0.0, 400e-6]  # clearance 1 mm: upper flange at 1.4, 1, 0.6; lower at -0.6, -1, -1.4
    ds = xr.Dataset({"x": (("direction", "guide_offset", "period"), np.zeros((1, 3, 2))),
                     "v": (("direction", "guide_offset", "period"), np.zeros((1, 3, 2)))},
                    coords={"direction": ["independent"], "guide_offset": offsets, "period": [0, 1]},
                    attrs={"parameter": "guide_offset", "base": repr(io.TapeDrive())})
    lines = _flange_lines(plot_bifurcation(ds))
    ((xs, upper),) = lines["upper flange"]
    ((_, lower),) = lines["lower flange"]
    assert xs.tolist() == offsets
    assert upper == pytest.approx([1.4, 1.0, 0.6], rel=1e-12) and lower == pytest.approx([-0.6, -1.0, -1.4], rel=1e-12)
    # A Dataset whose base cannot be read back (or is not a model) gets no flanges, and no error.
    ds.attrs["base"] = "__import__('os').system('echo never run')"
    assert _flange_lines(plot_bifurcation(ds)) == {}


# -- backend="auto": the fastest backend that runs the member ------------------------------------

def test_auto_picks_exact_for_a_linear_member_and_heyoka_for_the_rest():
    from impactosc._util.jit import HAVE_NUMBA
    from impactosc.backends import resolve_backend

    linear = io.Oscillator(0.5, 1.1, 0.01, 1e4)
    assert resolve_backend("auto", linear) == ("exact" if HAVE_NUMBA else "heyoka")
    assert resolve_backend("auto", io.Oscillator(0.5, 1.1, 0.01, flange="rigid")) == (
        "exact" if HAVE_NUMBA else "heyoka")
    assert resolve_backend("auto", io.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5)) == "heyoka"
    assert resolve_backend("auto", io.Oscillator(0.5, 1.1, 0.01, 1e4, zeta=1e4)) == "heyoka"  # beyond exact's zeta
    many = io.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5, harmonics=[(0.01, 1.0 + k, 0.0) for k in range(45)])
    assert resolve_backend("auto", many) == "scipy"  # heyoka's compile time would dominate
    assert resolve_backend("heyoka", io.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5)) == "heyoka"
    # Options say whose they are.
    assert resolve_backend("auto", linear, ["tol"]) == "heyoka"
    assert resolve_backend("auto", linear, ["rtol", "method"]) == "scipy"
    with pytest.raises(TypeError, match="no single backend takes"):
        resolve_backend("auto", linear, ["tol", "rtol"])


def test_the_option_table_of_auto_is_the_backends_signatures():
    import inspect

    from impactosc.backends import BACKENDS, get_backend
    from impactosc.backends._registry import OPTIONS

    common = {"osc", "t_end", "x0", "v0", "record", "max_events", "sample_at"}
    for name in BACKENDS:
        params = set(inspect.signature(get_backend(name)).parameters) - common
        assert set(OPTIONS[name]) == params, name


@pytest.mark.parametrize("osc", [io.Oscillator(0.5, 1.1, 0.01, 1e4),
                                 io.Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5)], ids=["linear", "hertz"])
def test_simulate_auto_says_which_backend_ran_and_runs_it(osc):
    from impactosc.backends import resolve_backend

    auto = io.simulate(osc, 50.0, backend="auto")
    chosen = resolve_backend("auto", osc)
    assert auto.backend == chosen and f"[{chosen}]" in auto.summary()
    same = io.simulate(osc, 50.0, backend=chosen)
    np.testing.assert_array_equal(auto.events.t, same.events.t)  # one machine, one backend: the same run


def test_sweep_defaults_to_auto_and_says_which_backend_ran():
    # The README's sweep took 13 minutes on heyoka, 1.5 on exact with the same forces.
    from impactosc._util.jit import HAVE_NUMBA

    base = io.TapeDrive(clearance=50e-6)
    grid = {"pack_diameter": [0.05, 0.09], "speed": [4.0]}
    auto = io.sweep(base, grid, duration=0.002, executor="serial", progress=False)
    assert auto.attrs["backend"] == "auto"
    assert auto.attrs["backend_used"] == ("exact" if HAVE_NUMBA else "heyoka")
    heyoka = io.sweep(base, grid, duration=0.002, backend="heyoka", executor="serial", progress=False)
    assert heyoka.attrs["backend_used"] == "heyoka"
    assert (auto["impacts"] > 0).all()
    np.testing.assert_array_equal(auto["impacts"], heyoka["impacts"])
    # Two machine-precision event locators: the forces agree far below any physical meaning.
    np.testing.assert_allclose(auto["mean_flange_force"], heyoka["mean_flange_force"], rtol=1e-9)
    # Backend options choose their backend: tol is heyoka's.
    tol = io.sweep(base, grid, duration=0.002, executor="serial", progress=False, tol=1e-14)
    assert tol.attrs["backend_used"] == "heyoka"


@pytest.mark.slow  # about 15 s: a transient at each end of the bracket, then one grid point
def test_a_chart_with_the_default_options_finishes_and_prints_micrometres(tmp_path):
    # Before: one point of this chart ran for over 5 minutes (the orbit followed from the
    # narrow clearance, in contact, after 100 forcing periods) and printed 0.0001198.
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, "-m", "impactosc", "chart", "--param", "clearance", "--bracket", "100e-6",
                           "140e-6", "--grid", "speed=8", "--grid", "tension=0.5", "--serial", "--no-progress"],
                          capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "followed from the hi end of the bracket, after 1 forcing periods" in proc.stdout
    assert "critical clearance [um]" in proc.stdout
    row = proc.stdout.strip().splitlines()[-1].split()
    assert float(row[2]) == pytest.approx(119.8, abs=0.1) and row[3] == "0"  # micrometres, status 0
