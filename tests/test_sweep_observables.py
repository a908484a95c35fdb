"""A sweep reports what a flange sensor reads (issue 29, item 1): contact observables in SI units.

Sweeps run ``record="stats"``; their ``mean_peak_force``, AE proxies, entry-energy and
dissipation rates come from the contact sums the recorder streams, and must equal
``simulate(..., record="full").contact_observables(drive)`` point by point. A store written
before these variables existed (format 1) is refused by name, never reused.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import impactosc
from impactosc.model import TapeDrive
from impactosc.sweeps import sweep
from impactosc.sweeps._point import OBSERVED
from impactosc.sweeps._store import STORE_FORMAT

DURATION = 2e-3
BASE = TapeDrive(clearance=40e-6, friction=0.1)
GRID = {"pack_diameter": [0.05, 0.09], "speed": [4.0, 10.0]}
UNITS = {"mean_peak_force": "N", "ae_peak_sum": "N/s", "ae_impact_sum": "N/s", "ae_impact_sum_upper": "N/s",
         "ae_impact_sum_lower": "N/s", "impact_energy_rate": "W", "dissipation_rate": "W"}


@pytest.mark.parametrize("backend", ["auto", "heyoka"])
def test_sweep_observables_equal_full_runs_point_by_point(backend):
    ds = sweep(BASE, GRID, duration=DURATION, executor="serial", progress=False, backend=backend)
    assert set(OBSERVED) == set(UNITS)
    for name, units in UNITS.items():
        assert ds[name].attrs["units"] == units and ds[name].attrs["long_name"]
    for d in GRID["pack_diameter"]:
        for v in GRID["speed"]:
            drive = BASE.replace(pack_diameter=d, speed=v)
            full = impactosc.simulate(drive.oscillator(), drive.seconds_to_lambda(DURATION), 0.95, 0.0,
                                      backend=backend, record="full")
            obs = full.contact_observables(drive)
            pt = ds.sel(pack_diameter=d, speed=v)
            assert int(pt["status"]) == 0
            for name, (flange, key) in OBSERVED.items():
                assert float(pt[name]) == pytest.approx(obs[flange][key], rel=1e-12), (d, v, name)
    # the case means something: contacts (2 ms is a fraction of a reel turn: the upper flange
    # only), energy brought in and dissipated by friction
    assert (ds["ae_impact_sum_upper"] > 0).all() and (ds["mean_peak_force"] > 0).all()
    assert (ds["impact_energy_rate"] > 0).all() and (ds["dissipation_rate"] > 0).all()
    np.testing.assert_allclose(ds["ae_impact_sum"], ds["ae_impact_sum_upper"] + ds["ae_impact_sum_lower"],
                               rtol=1e-12)


def test_a_store_of_the_format_before_the_observables_is_refused(tmp_path):
    store = tmp_path / "old"
    sweep(BASE, {"speed": [4.0]}, duration=2e-4, executor="serial", progress=False, store=store)
    manifest = store / "manifest.json"
    doc = json.loads(manifest.read_text())
    assert doc["format"] == STORE_FORMAT == 2
    doc["format"] = 1
    manifest.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="format 1, expected 2"):
        sweep(BASE, {"speed": [4.0]}, duration=2e-4, executor="serial", progress=False, store=store)


def test_cli_sweep_prints_and_keeps_the_observables(capsys, tmp_path):
    import xarray as xr

    from impactosc.cli import main

    toml = tmp_path / "grid.toml"
    toml.write_text('[grid]\npack_diameter = [0.05, 0.09]\n\n[drive]\nspeed = 8.0\nclearance = 40e-6\n')
    nc = tmp_path / "s.nc"
    assert main(["sweep", "--toml", str(toml), "--duration", "0.002", "--serial", "--no-progress",
                 "--out", str(nc)]) == 0
    header = next(line for line in capsys.readouterr().out.splitlines() if "mean_flange_force" in line)
    assert "impact_rate" in header and "ae_impact_sum" in header
    with xr.open_dataset(nc, engine="scipy") as ds:
        for name, units in UNITS.items():
            assert ds[name].attrs["units"] == units
        assert (ds["ae_impact_sum"].values > 0).all()
