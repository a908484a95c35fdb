"""The tape path as a candidate of the Fig. 4 study (paper/_study_path.py; issue 29, item 2).

* the one-guide path is the paper's drive: its sensor observables (exact n-DOF backend) equal
  those of the 1-DOF exact backend from the same state, which checks the path's definitions of
  the entry speed, the elastic impact force ``sqrt(k0 m_0) v`` and the energy rate;
* without friction the tension enters a path nowhere: the observables at two tensions are equal;
* a point whose run fails is recorded (NaN and its reason), never raised.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import impactosc
from impactosc.model import TapeDrive, TapePath
from impactosc.paper._study import _point
from impactosc.paper._study_path import PATH_CANDIDATES, observe_path, path_of

ONE_DOF = ("mean_force", "impact_rate", "ae_impact_sum", "impact_energy_rate")


def test_one_guide_path_sees_what_the_paper_drive_sees():
    drive = TapeDrive(clearance=30e-6, friction=0.0, free_length=50e-3, pack_diameter=0.08, speed=8.0)
    got = observe_path(TapePath.from_drive(drive), transient_turns=1, measured_turns=1)
    # the same protocol on the 1-DOF exact backend, from rest at X = 0
    osc = drive.oscillator()
    turn = 2.0 * math.pi / osc.Omega
    first = impactosc.simulate(osc, turn, 0.0, 0.0, backend="exact", record="stats")
    phase = math.fmod(osc.Omega * first.t_final, 2.0 * math.pi)
    sol = impactosc.simulate(drive.oscillator(phase=phase), turn, first.x_final, first.v_final, backend="exact",
                             record="stats")
    want = sol.contact_observables(drive)["both"]
    assert want["impacts"] > 10  # the case has contacts
    for name in ONE_DOF:
        assert got[name] == pytest.approx(want[name], rel=1e-6), name
    assert math.isnan(got["rms_force"])


def test_without_friction_the_tension_is_not_seen():
    fields = PATH_CANDIDATES["tape_path"]["fields"]
    a, b = (observe_path(path_of(fields, {"pack_diameter": 0.07, "speed": 8.0, "t_sin_half_theta": ts}),
                         transient_turns=1, measured_turns=1) for ts in (0.1, 0.7))
    assert a["impact_rate"] > 0
    for name in ONE_DOF:
        assert a[name] == pytest.approx(b[name], rel=1e-12), name


def test_a_failing_path_point_is_recorded_not_raised(monkeypatch):
    import impactosc.paper._study as study

    def fail(*args, **kwargs):
        raise RuntimeError("transient failed: no consistent mode at t = 1.0")

    monkeypatch.setattr(study, "observe_path", fail)
    out = _point((PATH_CANDIDATES["tape_path_friction"]["fields"], {"pack_diameter": 0.07, "speed": 8.0}, (1, 1)))
    assert "no consistent mode" in out["error"]
    assert all(np.isnan(out[name]) for name in ONE_DOF)


def test_path_candidates_are_valid_paths():
    for name, cand in PATH_CANDIDATES.items():
        path = path_of(cand["fields"], {"pack_diameter": 0.05, "speed": 4.0, "t_sin_half_theta": 0.4})
        assert path.n >= 2, name
        assert path.drive.normal_force == pytest.approx(0.8, rel=1e-12)
