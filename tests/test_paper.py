"""The paper's Fig. 6-8 reproduction: the run-out law, the no-contact finding, the alternatives, the report."""

import math

import numpy as np
import pytest
import xarray as xr

from impactosc import TapeDrive, simulate, sweep
from impactosc.__main__ import main
from impactosc.paper import (
    ALTERNATIVES,
    QUICK_DURATION,
    fig6,
    fig7_grid,
    fig8_grid,
    figure_dt,
    quasi_static_mean_force,
    resolve_drive,
    rk4_grid,
    trends,
)


def test_fig6_runout_table_endpoints(tmp_path):
    table, fig = fig6(path=tmp_path / "fig6.png")
    assert len(table) == 15
    assert table.pack_diameter_mm.iloc[0] == pytest.approx(44.0)
    assert table.pack_diameter_mm.iloc[-1] == pytest.approx(97.0)
    assert table.runout_um.iloc[0] == pytest.approx(60.0)
    assert table.runout_um.iloc[-1] == pytest.approx(180.0)
    assert table.F_nondim.iloc[0] == pytest.approx(0.06) and table.F_nondim.iloc[-1] == pytest.approx(0.18)
    assert np.all(np.diff(table.runout_um) > 0)
    assert (tmp_path / "fig6.png").stat().st_size > 10_000
    # Another reel: the law follows its hub and full-pack diameters.
    table2, _ = fig6(TapeDrive(hub_diameter=0.03, full_pack_diameter=0.08), n=3)
    assert table2.pack_diameter_mm.tolist() == pytest.approx([30.0, 55.0, 80.0])
    assert table2.runout_um.tolist() == pytest.approx([60.0, 120.0, 180.0])


def test_grids_match_the_paper():
    g7, g8 = fig7_grid(), fig8_grid(quick=True)
    assert list(g7) == ["pack_diameter", "speed", "tension"] and len(g7["pack_diameter"]) >= 15
    assert g7["speed"] == [4.0, 8.0, 12.0] and g7["tension"] == [1.0, 2.0]
    assert g8["t_sin_half_theta"] == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])
    assert len(g8["pack_diameter"]) == 5
    d = resolve_drive(TapeDrive(), {"t_sin_half_theta": 0.3, "speed": 8.0})
    assert d.wrap_angle == 60.0 and d.t_sin_half_theta == pytest.approx(0.3) and d.tension == pytest.approx(0.6)


def test_paper_parameters_never_touch_a_flange():
    """The finding, pinned: with the paper's stated parameters there is no contact and the mean force is 0 N."""
    base = TapeDrive()
    grid = {"pack_diameter": [base.hub_diameter, base.full_pack_diameter], "speed": [4.0, 12.0],
            "t_sin_half_theta": [0.1, 0.7]}
    ds = sweep(base, grid, duration=QUICK_DURATION, executor="serial", progress=False)
    assert (ds.status == 0).all()
    assert float(ds.impacts.sum()) == 0
    assert float(np.abs(ds.mean_flange_force).max()) == 0.0
    assert float(ds.F.max()) == pytest.approx(0.18) and float(ds.Omega.max()) < 1e-3
    assert float(ds.reversals.min()) > 0  # the free oscillation of X(0) = 0.95 rings down inside the flanges


@pytest.mark.parametrize("flange", ["consistent", "paper"])
def test_rk4_with_sign_also_gives_zero_on_the_paper_parameters(flange):
    base = TapeDrive()
    g = {"pack_diameter": [base.hub_diameter, base.full_pack_diameter], "speed": [4.0, 12.0], "tension": [1.0]}
    ds = rk4_grid(base, g, duration=QUICK_DURATION, dt="figure", flange=flange)
    assert ds.attrs["dt"] == pytest.approx(2 * math.pi / 100) == figure_dt()
    assert (ds.status == 0).all() and int(ds.impacts.sum()) == 0
    assert float(ds.mean_flange_force.max()) == 0.0
    assert ds.mean_flange_force.dims == ("pack_diameter", "speed", "tension")


@pytest.mark.parametrize("name", list(ALTERNATIVES))
def test_alternative_sets_touch_the_flanges(name):
    drive = resolve_drive(TapeDrive(**ALTERNATIVES[name]["fields"]),
                          {"pack_diameter": 0.097, "speed": 12.0, "t_sin_half_theta": 0.1})
    duration = 0.002 if name == "tight_guide" else 0.2
    sol = simulate(drive.oscillator(), drive.seconds_to_lambda(duration), 0.95, 0.0, record="stats")
    assert sol.status == 0
    assert sol.contact_entries() > 0
    assert sol.mean_flange_force() * drive.force_scale > 0


def test_quasi_static_formula():
    base = TapeDrive(clearance=50e-6)
    hub = base.replace(pack_diameter=base.hub_diameter)
    a, c = 60e-6, 50e-6 + hub.friction_force / hub.stiffness
    expected = 2 * hub.stiffness / math.pi * (math.sqrt(a * a - c * c) - c * math.acos(c / a))
    assert quasi_static_mean_force(hub) == pytest.approx(expected)
    assert quasi_static_mean_force(TapeDrive()) == 0.0  # run-out < L: no contact
    # Speed-independent, and friction lowers it a little.
    assert quasi_static_mean_force(hub.replace(speed=12.0)) == quasi_static_mean_force(hub)
    assert quasi_static_mean_force(hub.replace(tension=2.0)) < quasi_static_mean_force(hub)


def test_trends_on_a_synthetic_grid():
    d = np.linspace(0.044, 0.097, 5)
    v = np.array([4.0, 8.0, 12.0])
    ts = np.array([0.1, 0.4, 0.7])
    bump = np.array([1.0, 2.0, 3.0, 2.0, 1.0])
    f = bump[:, None, None] * v[None, :, None] / ts[None, None, :] ** 0.356
    ds = xr.Dataset({"mean_flange_force": (("pack_diameter", "speed", "t_sin_half_theta"), f)},
                    coords={"pack_diameter": d, "speed": v, "t_sin_half_theta": ts})
    t = trends(ds)
    assert t["nonzero"] and t["mid_pack_max"] == 1.0 and t["up_with_speed"] and t["down_with_t_sin"]
    assert t["ratio_01_07"] == pytest.approx(7**0.356, rel=1e-12)
    zero = trends(ds * 0)
    assert not zero["nonzero"] and zero["n_curves"] == 0 and not zero["up_with_speed"]


@pytest.mark.slow  # the paper's figures, quick mode
def test_quick_reproduction_writes_the_report(tmp_path, capsys):
    out = tmp_path / "rep"
    assert main(["paper", "--quick", "--out", str(out), "--serial", "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "0 flange contacts" in printed
    for name in ("paper_reproduction.md", "paper_summary.json", "fig6_runout.csv", "fig7_paper_parameters.csv",
                 "fig8_paper_parameters.csv", *(f"alt_{n}.csv" for n in ALTERNATIVES)):
        assert (out / name).stat().st_size > 100, name
    for name in ("fig6_runout", "fig7_paper_parameters", "fig8_paper_parameters", *(f"alt_{n}" for n in ALTERNATIVES)):
        assert (out / "figures" / f"{name}.png").stat().st_size > 20_000, name
    report = (out / "paper_reproduction.md").read_text()
    assert "no flange contact at all" in report and "quick run" in report
    assert "Extrapolated wall time at the default step" in report
    import pandas as pd

    t7 = pd.read_csv(out / "fig7_paper_parameters.csv")
    assert len(t7) == 5 * 3 * 2 and (t7.event_driven_N == 0).all() and (t7.rk4_sign_N == 0).all()
    assert (t7.rk4_eq2_N == 0).all() and (t7.event_driven_impacts == 0).all()
    alt = pd.read_csv(out / "alt_tight_guide.csv")
    assert (alt.impacts > 0).all()
