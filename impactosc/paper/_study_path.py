"""The multi-guide tape path as a candidate of the Fig. 4 study: what the first guide's flanges see.

A :class:`~impactosc.model.TapePath` couples the paper's guide to the spans and guides after it
(eq. 4 per span, eq. 5 per guide, Fig. 6 at the pack). The sensor is the flanged guide nearest
the pack (guide 0, the paper's single guide); its observables are
:meth:`TapePathRun.contact_observables` (``mean_force``, ``impact_rate``, ``ae_impact_sum``: the
elastic impact forces ``sqrt(k0 m_0) v`` of the entry speeds summed per second with the guide's
flange stiffness and lumped mass, ``impact_energy_rate``: ``m_0 v^2 / 2`` per second), the 1-DOF
definitions of :func:`impactosc.results.contact_observables` with the guide's own mass;
``rms_force`` is NaN (a run of the n-DOF backend streams no integral of the squared force; a
sampled one would need sub-microsecond steps over a second).

Every point is a steady state as in :func:`impactosc.paper.observe`: a transient of whole reel
turns from rest, then the measured turns restarted from its end state with the reel's phase
carried on. Runs are on the exact n-DOF backend (:func:`impactosc.simulate_mechanical`).
"""

from __future__ import annotations

import math

import numpy as np

from ..backends._exact_mdof import simulate_mechanical
from ..model._tape import TapeDrive
from ..model._tape_path import Guide, TapePath
from ..results._tape_path import TapePathRun
from ._grids import resolve_drive

__all__ = ["PATH_CANDIDATES", "path_of", "observe_path", "SENSOR_GUIDE"]

#: The guide whose flanges are the sensor: the one nearest the pack (the paper's single guide).
SENSOR_GUIDE = 0

#: Tape-path candidates: drive fields, guides (``Guide`` fields), end span; sources of the numbers.
PATH_CANDIDATES: dict[str, dict] = {
    "tape_path": {
        "fields": {"clearance": 30e-6, "friction": 0.0,
                   "guides": [{"position": 50e-3}, {"position": 90e-3}], "end_span": 30e-3},
        "title": "tape path: flanged guides at 50 and 90 mm from the pack (L = 30 um), a 30 mm span to a "
                 "fixed head; no friction",
        "source": "spans 10-100 mm as the long-span candidate (assumption: a cartridge drive's reel-to-guide "
                  "and guide-to-guide distances); no friction, to see the chain's own response (tape_path_friction "
                  "adds it on a post)"},
    "tape_path_friction": {
        "fields": {"clearance": 30e-6, "friction": 0.2,
                   "guides": [{"position": 50e-3, "friction": 0.0},
                              {"position": 90e-3, "clearance": 1e-3, "wrap_angle": 90.0}],
                   "end_span": 30e-3},
        "title": "tape path: a flanged roller (no sliding friction, L = 30 um) at 50 mm, a fixed post "
                 "(mu = 0.2, 90 deg wrap, 1 mm clearance: never touched) at 90 mm, 30 mm to the head",
        "source": "mu = 0.2 of section 5 on the post; a roller turns with the tape (no sliding friction); "
                  "tension enters through the post's friction (eq. 5)"},
}


def path_of(fields: dict, point: dict) -> TapePath:
    """The tape path of a candidate's ``fields`` (drive fields, ``guides``, ``end_span``) at a grid ``point``.

    Examples
    --------
    >>> from impactosc.paper._study_path import PATH_CANDIDATES, path_of
    >>> path = path_of(PATH_CANDIDATES["tape_path"]["fields"], {"pack_diameter": 0.07, "speed": 8.0})
    >>> path.n, path.drive.speed
    (2, 8.0)
    """
    drive_fields = {k: v for k, v in fields.items() if k not in ("guides", "end_span")}
    drive = resolve_drive(TapeDrive(**drive_fields), point)
    return TapePath(drive, tuple(Guide(**g) for g in fields["guides"]), end_span=fields.get("end_span"))


def observe_path(path: TapePath, *, transient_turns: int, measured_turns: int) -> dict[str, float]:
    """The study's observables (SI) of the sensor guide over ``measured_turns`` reel turns after a transient.

    Raises ``RuntimeError`` with the backend's message when a run does not reach its end.
    """
    turn = path.seconds_to_time(2.0 * math.pi / path.drive.omega_r)
    zeros = np.zeros(path.n)
    first = simulate_mechanical(path.mechanical_system(), transient_turns * turn, zeros, zeros)
    if first.status != 0:
        raise RuntimeError(f"transient failed: {first.message}")
    phase = math.fmod(path.drive.omega_r * path.time_to_seconds(first.t), 2.0 * math.pi)
    sol = simulate_mechanical(path.mechanical_system(phase), measured_turns * turn, first.q, first.v)
    if sol.status != 0:
        raise RuntimeError(f"measured run failed: {sol.message}")
    run = TapePathRun(path, sol, phase)
    seen = run.contact_observables(SENSOR_GUIDE)
    return {"mean_force": seen["mean_force"], "impact_rate": seen["impact_rate"],
            "ae_impact_sum": seen["ae_impact_sum"], "impact_energy_rate": seen["impact_energy_rate"],
            "rms_force": math.nan}
