"""One sweep point, as a worker process runs it: the result variables, status codes and the task.

Module level functions of plain arguments, so that they pickle by reference under any
executor (a process pool, dask) and a worker never needs the caller's ``__main__``.
"""

from __future__ import annotations

import math
from typing import Any

from ..backends._simulate import simulate
from ..model._tape import TapeDrive

STATUS_EXCEPTION = -2
STATUS_LOST = -3
STATUS_NOT_COMPUTED = -4

# The result variables: name -> (units, long name). Counts are float64 so that a failed
# point can hold NaN; ``status`` (int32) and ``message`` (str) are added separately.
RESULTS = {
    "mean_flange_force": ("N", "mean flange force, both flanges"),
    "mean_flange_force_upper": ("N", "mean flange force, upper flange"),
    "mean_flange_force_lower": ("N", "mean flange force, lower flange"),
    "rms_flange_force": ("N", "rms flange force, both flanges"),
    "rms_flange_force_upper": ("N", "rms flange force, upper flange"),
    "rms_flange_force_lower": ("N", "rms flange force, lower flange"),
    "impacts": ("1", "number of flange contacts, both flanges"),
    "impacts_upper": ("1", "number of flange contacts, upper flange"),
    "impacts_lower": ("1", "number of flange contacts, lower flange"),
    "impact_rate": ("1/s", "flange contacts per second, both flanges"),
    "sticks": ("1", "number of stick events"),
    "releases": ("1", "number of release events"),
    "reversals": ("1", "number of friction reversals (slip direction changes)"),
    "max_penetration": ("um", "deepest penetration into a flange"),
    "peak_flange_force": ("N", "peak flange force"),
    "contact_fraction": ("1", "fraction of the time in flange contact"),
    # What a flange sensor reads (impactosc.results.contact_observables, streamed in "stats").
    "mean_peak_force": ("N", "mean peak force per contact, both flanges"),
    "ae_peak_sum": ("N/s", "AE proxy: peak forces of the contacts summed per second, both flanges"),
    "ae_impact_sum": ("N/s", "AE proxy: elastic impact forces sqrt(k0 m) v of the entry speeds summed per second, "
                             "both flanges"),
    "ae_impact_sum_upper": ("N/s", "AE proxy (elastic impact forces per second), upper flange"),
    "ae_impact_sum_lower": ("N/s", "AE proxy (elastic impact forces per second), lower flange"),
    "impact_energy_rate": ("W", "kinetic energy m v^2/2 brought into contacts per second, both flanges"),
    "dissipation_rate": ("W", "energy dissipated in contacts per second, both flanges"),
}
#: The sweep variables read from contact_observables(drive): variable -> (flange, observable).
OBSERVED = {
    "mean_peak_force": ("both", "mean_peak_force"),
    "ae_peak_sum": ("both", "ae_peak_sum"),
    "ae_impact_sum": ("both", "ae_impact_sum"),
    "ae_impact_sum_upper": ("upper", "ae_impact_sum"),
    "ae_impact_sum_lower": ("lower", "ae_impact_sum"),
    "impact_energy_rate": ("both", "impact_energy_rate"),
    "dissipation_rate": ("both", "dissipation_rate"),
}
# Inputs of the point, defined whenever the drive is: kept even when the run failed.
PARAMETERS = {
    "F": ("1", "nondimensional forcing amplitude F = F_a/(kL) (eq. 3)"),
    "Omega": ("1", "nondimensional forcing frequency omega_r/omega_n (eq. 3)"),
    "beta": ("1", "nondimensional friction level mu N/(kL) (eq. 3)"),
    "K": ("1", "flange to tape stiffness ratio (eq. 3)"),
    "simulated_time": ("s", "time actually simulated"),
}
FLOAT_VARS = {**RESULTS, **PARAMETERS}


def run_point(fields: dict, duration: float, backend: str, x0: float, v0: float, options: dict) -> dict:
    """The result dict of one drive (``FLOAT_VARS``, ``status``, ``message``); never raises."""
    out: dict[str, Any] = dict.fromkeys(FLOAT_VARS, math.nan)
    try:
        drive = TapeDrive(**fields)
        out.update(F=drive.F, Omega=drive.Omega, beta=drive.beta, K=drive.K)
        sol = simulate(drive.oscillator(), drive.seconds_to_lambda(duration), x0, v0,
                       backend=backend, record="stats", **options)
    except Exception as exc:  # noqa: BLE001 - any failure of one point is recorded, not raised
        out.update(status=STATUS_EXCEPTION, message=f"{type(exc).__name__}: {exc}")
        return out
    out.update(status=int(sol.status), message=str(sol.message))
    dur = sol.t_final - sol.t0
    out["simulated_time"] = drive.lambda_to_seconds(dur)
    if sol.status != 0:
        # A partial run's averages are over a different window than the other points': not comparable.
        return out
    fs = drive.force_scale
    impacts = {s: sol.contact_entries(s) for s in (None, 1, -1)}
    out.update(
        mean_flange_force=sol.mean_flange_force() * fs,
        mean_flange_force_upper=sol.mean_flange_force(1) * fs,
        mean_flange_force_lower=sol.mean_flange_force(-1) * fs,
        rms_flange_force=sol.rms_flange_force() * fs,
        rms_flange_force_upper=sol.rms_flange_force(1) * fs,
        rms_flange_force_lower=sol.rms_flange_force(-1) * fs,
        impacts=float(impacts[None]),
        impacts_upper=float(impacts[1]),
        impacts_lower=float(impacts[-1]),
        impact_rate=impacts[None] / out["simulated_time"],
        sticks=float(sol.counts["stick"]),
        releases=float(sol.counts["release"]),
        reversals=float(sol.counts["reversal"]),
        max_penetration=sol.max_penetration() * drive.clearance * 1e6,
        peak_flange_force=sol.max_flange_force() * fs,
        contact_fraction=sol.contact_time() / dur if dur > 0 else math.nan,
    )
    observed = sol.contact_observables(drive)
    out.update({name: observed[flange][key] for name, (flange, key) in OBSERVED.items()})
    return out


def failure(status: int, message: str) -> dict:
    """The result dict of a point that has no results."""
    out: dict[str, Any] = dict.fromkeys(FLOAT_VARS, math.nan)
    out.update(status=status, message=message)
    return out
