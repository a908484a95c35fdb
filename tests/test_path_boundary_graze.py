"""A tape path's critical clearance as a continued boundary (issue 28, item 3).

The curve of ``critical_clearance_boundary`` against ``critical_clearance`` (the steady-state
extreme measured by simulation on the exact n-DOF backend) at the same speeds, on two-guide
paths: a centred guide and an offset one whose two flanges have different critical
clearances (the larger, the one the tape touches first, is followed).
"""

from __future__ import annotations

import numpy as np
import pytest

from impactosc import Guide, TapeDrive, TapePath
from impactosc.dynamics.continuation import critical_clearance_boundary
from impactosc.sweeps import critical_clearance, steady_deflection


def _path(offset: float = 0.0) -> TapePath:
    return TapePath(TapeDrive(friction=0.0, damping_ratio=0.05),
                    [Guide(0.02, clearance=300e-6), Guide(0.05, clearance=30e-6, guide_offset=offset)], end_span=0.03)


def _with_runout(path: TapePath, runout: float) -> TapePath:
    """``path`` with the pack's run-out ``runout`` at its diameter: both ends of the linear law (Fig. 6) scaled."""
    k = runout / path.drive.runout
    out = path.with_parameter("runout_hub", k * path.drive.runout_hub)
    out = out.with_parameter("runout_full", k * path.drive.runout_full)
    assert out.drive.runout == pytest.approx(runout, rel=1e-14)
    return out


@pytest.mark.parametrize("offset", [0.0, 4e-6])
def test_the_continued_clearance_is_the_measured_one(offset):
    path = _path(offset)
    ds = critical_clearance_boundary(path, 1, ("clearance", "speed"), {"speed": (2.0, 8.0)})
    assert ds.attrs["status"] == 0, ds.attrs["message"]
    # offset towards the upper flange: the tape reaches it first; without an offset the frictionless
    # linear motion is symmetric, and the two flanges' critical clearances tie to rounding
    assert ds.attrs["flange"] in (("upper",) if offset > 0 else ("upper", "lower"))
    speeds = ds.speed.values
    assert speeds.min() == pytest.approx(2.0, abs=1e-12) and speeds.max() == pytest.approx(8.0, abs=1e-12)
    assert "speed = " in ds.attrs["message"] and "m/s" in ds.attrs["message"]
    for i in (0, len(speeds) // 2, len(speeds) - 1):
        ref = critical_clearance(path.with_parameter("speed", float(speeds[i])), 1)
        # the measurement polishes its extreme to ~1e-10 of a turn: far below 1e-9 of the clearance
        assert abs(float(ds.clearance[i]) - ref) < 1e-9 * ref


def test_the_clearance_against_the_runout_is_the_measured_one():
    path = _path(4e-6)
    r0 = path.drive.runout
    ds = critical_clearance_boundary(path, 1, ("clearance", "runout"), {"runout": (0.5 * r0, 2.0 * r0)})
    assert ds.attrs["status"] == 0, ds.attrs["message"]
    assert ds.runout.attrs["units"] == "m" and "runout = " in ds.attrs["message"]
    runouts = ds.runout.values
    assert runouts.min() == pytest.approx(0.5 * r0, rel=1e-12) and runouts.max() == pytest.approx(2.0 * r0, rel=1e-12)
    for i in (0, len(runouts) - 1):
        ref = critical_clearance(_with_runout(path, float(runouts[i])), 1)
        assert abs(float(ds.clearance[i]) - ref) < 1e-9 * ref
    # without contact anywhere the path is linear: its deflection grows in proportion to the run-out
    slope = np.diff(ds.clearance.values) / np.diff(runouts)
    assert np.ptp(slope) < 1e-6 * np.abs(slope).max()


def test_the_lower_flange_on_request():
    path = _path(4e-6)
    ds = critical_clearance_boundary(path, 1, ("clearance", "speed"), {"speed": (3.0, 5.0)}, flange="lower")
    assert ds.attrs["status"] == 0 and ds.attrs["flange"] == "lower"
    v = float(ds.speed[-1])
    ref = steady_deflection(path.with_parameter("speed", v), 1)["critical_clearance_lower"]
    assert abs(float(ds.clearance[-1]) - ref) < 1e-9 * ref
    assert np.all(ds.clearance.values < critical_clearance(path, 1))  # the offset guide is nearer its upper flange


def test_bad_input_names_it():
    path = _path()
    with pytest.raises(ValueError, match="parameters must be"):
        critical_clearance_boundary(path, 1, ("clearance", "tension"), {"speed": (2.0, 8.0)})
    with pytest.raises(ValueError, match="limits"):
        critical_clearance_boundary(path, 1, limits={"tension": (0.5, 1.0)})
    with pytest.raises(ValueError, match="outside"):
        critical_clearance_boundary(path, 1, limits={"speed": (5.0, 8.0)})
    with pytest.raises(ValueError, match="flange"):
        critical_clearance_boundary(path, 1, limits={"speed": (2.0, 8.0)}, flange="middle")
    with pytest.raises(TypeError, match="TapePath"):
        critical_clearance_boundary("path", 1, limits={"speed": (2.0, 8.0)})
