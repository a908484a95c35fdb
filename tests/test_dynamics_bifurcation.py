"""Bifurcation diagrams: values in parallel, continuation passes (hysteresis), the resumable store."""

from __future__ import annotations

import concurrent.futures as cf
import json
import math
import os

import numpy as np
import pytest

from impactosc import Oscillator, TapeDrive
from impactosc.dynamics import (
    bifurcation_diagram,
    den_hartog_onset,
    load_bifurcation,
    plot_bifurcation,
    stroboscopic_section,
)

DEN_HARTOG = Oscillator(0.3, 0.8, 0.05, 1e4)


def test_independent_values_match_single_sections():
    values = [0.2, 0.5, 0.35]
    ds = bifurcation_diagram(DEN_HARTOG, "F", values, transient_periods=20, record_periods=4, executor="serial",
                             progress=False)
    assert ds.sizes == {"direction": 1, "F": 3, "period": 4}
    assert list(ds["F"].values) == values and list(ds["period"].values) == [20, 21, 22, 23]
    assert np.all(ds["status"].values == 0)
    sec = stroboscopic_section(Oscillator(0.5, 0.8, 0.05, 1e4), 4, transient_periods=20)
    np.testing.assert_array_equal(ds["x"].sel(F=0.5).values[0], sec.x)


def test_continuation_shows_hysteresis_at_the_grazing_boundary():
    # Near the Den Hartog grazing boundary F_c = 0.36408 a contact orbit coexists with the
    # contact-free one: the forward pass stays off the flange, the backward pass on it.
    values = np.round(np.linspace(0.34, 0.38, 11), 6)
    with cf.ThreadPoolExecutor(2) as pool:
        ds = bifurcation_diagram(DEN_HARTOG, "F", values, transient_periods=60, record_periods=4,
                                 continuation="both", x0=0.0, executor=pool, progress=False)
    assert list(ds["direction"].values) == ["forward", "backward"]
    fw, bw = ds.sel(direction="forward"), ds.sel(direction="backward")
    gap = np.hypot(fw["x"] - bw["x"], fw["v"] - bw["v"]).max("period").values
    unique = (values > 0.341) & (values <= 0.352)  # (0.34: the first value, from x0, still settling)
    coexist = (values > 0.357) & (values < den_hartog_onset(0.8, 0.05))
    print("forward/backward section distance:", dict(zip(values.tolist(), gap.round(6).tolist(), strict=True)))
    assert np.all(gap[unique] < 1e-5)  # one attractor: both passes land on it
    assert np.all(gap[coexist] > 1e-2)  # two attractors: each pass stays on its branch
    # continuation: each value starts from the previous final state
    assert np.all(np.isfinite(ds["x_final"].values))


def test_store_resumes_and_refuses_other_settings(tmp_path):
    store = tmp_path / "bif"
    kw = dict(transient_periods=10, record_periods=3, executor="serial", progress=False, store=store)
    first = bifurcation_diagram(DEN_HARTOG, "F", [0.2, 0.3, 0.4], continuation="forward", **kw)
    files = {_value_of(p): p for p in (store / "points").glob("*.npz")}
    assert sorted(files) == [0.2, 0.3, 0.4]
    os.remove(files[0.4])  # an interrupted pass: the last value is missing
    stamp = os.stat(files[0.2]).st_mtime_ns
    again = bifurcation_diagram(DEN_HARTOG, "F", [0.2, 0.3, 0.4], continuation="forward", **kw)
    assert os.stat(files[0.2]).st_mtime_ns == stamp  # finished values are not recomputed
    np.testing.assert_array_equal(again["x"].values, first["x"].values)
    loaded = load_bifurcation(store)
    np.testing.assert_array_equal(loaded["x"].values, first["x"].values)
    with pytest.raises(ValueError, match="different settings"):
        bifurcation_diagram(DEN_HARTOG, "F", [0.2, 0.3, 0.4], continuation="forward",
                            **{**kw, "record_periods": 5})


def _value_of(path):
    """The parameter value a point file of a bifurcation store holds."""
    with np.load(path) as f:
        return json.loads(str(f["fields"]))["value"]


def test_tape_parameter_and_failures_are_recorded():
    drive = TapeDrive(clearance=200e-6)
    ds = bifurcation_diagram(drive, "speed", [2.0, 6.0], transient_periods=1, record_periods=2,
                             executor="serial", progress=False)
    assert ds["speed"].attrs["units"] == "m/s" and np.all(ds["status"].values == 0)
    # a value the model refuses costs only itself (status -2, NaN points, the reason kept)
    bad = bifurcation_diagram(DEN_HARTOG, "beta", [0.05, -0.1], transient_periods=2, record_periods=2,
                              executor="serial", progress=False)
    assert list(bad["status"].values[0]) == [0, -2]
    assert "beta must be >= 0" in str(bad["message"].values[0, 1])
    assert np.all(np.isnan(bad["x"].values[0, 1]))


def test_bad_input():
    with pytest.raises(ValueError, match="parameter must be one of"):
        bifurcation_diagram(DEN_HARTOG, "speed", [1.0, 2.0])
    with pytest.raises(ValueError, match="NaN"):
        bifurcation_diagram(DEN_HARTOG, "F", [0.1, math.nan])
    with pytest.raises(ValueError, match="duplicate"):
        bifurcation_diagram(DEN_HARTOG, "F", [0.1, 0.1])
    with pytest.raises(ValueError, match="continuation must be one of"):
        bifurcation_diagram(DEN_HARTOG, "F", [0.1], continuation="sideways")
    with pytest.raises(ValueError, match="executor must be"):
        bifurcation_diagram(DEN_HARTOG, "F", [0.1], executor="threads")


def test_plot():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    ds = bifurcation_diagram(DEN_HARTOG, "F", [0.2, 0.3], transient_periods=5, record_periods=2,
                             continuation="both", executor="serial", progress=False)
    ax = plot_bifurcation(ds, onset=0.364)
    assert ax.get_xlabel() == "F" and len(ax.lines) >= 3
