"""What the sensor saw: which model and which observable give the four trends of the paper's Fig. 4.

The criteria are fixed here, before any number is computed (:data:`~impactosc.paper.STUDY_CRITERIA`,
:func:`trend_checks`); the candidates (:data:`CANDIDATES`) are the paper's eq. 3 with its
parameters and readings of it whose ranges have a source; the search
(:func:`search_region`) walks the span length and clearance of the in-plane reading over
their defensible ranges. Every point is a steady state of the exact backend: a transient of
``TRANSIENT_TURNS`` reel turns, then ``MEASURED_TURNS`` turns over which the observables of
:func:`impactosc.results.contact_observables` are taken (a whole number of turns, so the
one-second averages of the paper are those of a periodic state).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..backends._simulate import simulate
from ..model._tape import TapeDrive
from ..runner import run_points
from ._grids import resolve_drive
from ._study_path import observe_path, path_of

#: The four trends of Fig. 4 and 8, and what counts as holding (fixed before the search).
CRITERIA = {
    "mid_pack": ("largest at mid pack (Fig. 4, section 4)",
                 "on every curve (speed, T sin(theta/2)) the maximum over the pack diameters lies strictly "
                 "inside, in the middle third of [hub, full pack], and exceeds both end values by >= 10 %"),
    "speed": ("grows with tape speed (Fig. 4, 8)",
              "the pack-averaged observable rises by >= 10 % from each speed to the next (4, 8, 12 m/s), "
              "at every T sin(theta/2)"),
    "tension": ("falls with tension (Fig. 4, 8)",
                "the pack-averaged observable at the highest T sin(theta/2) is >= 10 % below the lowest, "
                "at every speed"),
    "double": ("0.1 N almost double 0.7 N (Fig. 8, 'regardless of the tape speed')",
               "the ratio of the pack-averaged observable at T sin(theta/2) = 0.1 N to 0.7 N lies in "
               "[1.5, 2.5] at every speed"),
}

#: The observables judged (name in contact_observables -> label, units).
STUDY_OBSERVABLES = {
    "mean_force": ("time-averaged contact force", "N"),
    "ae_impact_sum": ("AE proxy: impact forces summed per second", "N/s"),
    "impact_energy_rate": ("AE proxy, energy rate", "W"),
    "impact_rate": ("impact rate", "1/s"),
    "rms_force": ("rms contact force", "N"),
}

TRANSIENT_TURNS = 2
MEASURED_TURNS = 4
SPEEDS = (4.0, 8.0, 12.0)
T_SIN = (0.1, 0.4, 0.7)
QUICK_T_SIN = (0.1, 0.7)


#: Candidate models (fields changed from the paper's section 5 values) and where their numbers come from.
CANDIDATES: dict[str, dict[str, Any]] = {
    "paper": {"fields": {}, "title": "eq. 3 with the paper's parameters (L = 1 mm, l = 10 mm, in-plane)",
              "source": "section 5"},
    "short_clearance": {"fields": {"clearance": 50e-6},
                        "title": "paper's parameters, L = 50 um",
                        "source": "clearance: tens of um (assumption: a guide holds the tape to a fraction of a "
                                  "track; impactosc.paper.ALTERNATIVES['tight_guide'])"},
    "long_span": {"fields": {"free_length": 50e-3, "clearance": 30e-6},
                  "title": "in-plane bending of a 50 mm span (f_n 3.7 kHz), L = 30 um",
                  "source": "span 10-100 mm (assumption: reel-to-roller distance of a cartridge drive); the "
                            "1-2 kHz contact LTM of Fig. 3(d) points to a kHz-range lateral mode"},
    "air_film": {"fields": {"bending": "out-of-plane", "friction": 1e-5, "clearance": 100e-6},
                 "title": "plate bending I = w h^3/12, air-film friction mu = 1e-5, L = 100 um",
                 "source": "impactosc.paper.ALTERNATIVES['plate_bending_air_film'] (mu an assumption)"},
}

#: Ranges of the search (in-plane bending, mu = 0.2 of section 5): span and clearance.
SEARCH_SPANS = (30e-3, 40e-3, 50e-3, 70e-3, 100e-3)
SEARCH_CLEARANCES = (10e-6, 30e-6, 50e-6, 70e-6, 100e-6)
QUICK_SEARCH_SPANS = (40e-3,)
QUICK_SEARCH_CLEARANCES = (50e-6,)


# ---------------------------------------------------------------------------------------
# The lead of the issue, derived
# ---------------------------------------------------------------------------------------
def quasi_static_impact_speed(drive: TapeDrive) -> float:
    """Speed (m/s) at which a tape that follows the reel reaches a flange: ``omega_r sqrt(A^2 - c^2)``.

    The quasi-static tape (``Omega << 1``) sits at ``x = A cos(omega_r t)`` shifted by the
    friction dead band; it reaches the flange at ``x = c = L + mu N / k`` with speed
    ``|dx/dt| = A omega_r sin(phi_c)``, ``cos(phi_c) = c / A``: ``omega_r sqrt(A^2 - c^2)``
    (eq. 1 for ``omega_r``, Fig. 6 for ``A``). Zero when ``A <= c`` (no contact).

    Examples
    --------
    >>> from impactosc import TapeDrive
    >>> from impactosc.paper import quasi_static_impact_speed
    >>> drive = TapeDrive(clearance=60e-6, friction=0.0)          # mid pack: A = 120 um
    >>> round(quasi_static_impact_speed(drive) / (drive.omega_r * (120e-6**2 - 60e-6**2) ** 0.5), 9)
    1.0
    """
    a, c = drive.runout, drive.clearance + drive.friction_force / drive.stiffness
    return drive.omega_r * math.sqrt(a * a - c * c) if a > c else 0.0


def lead_ae_proxy(drive: TapeDrive) -> float:
    """The lead: one elastic impact per turn and flange, summed per second, ``2 (omega_r / 2 pi) sqrt(k0 m) v`` (N/s).

    Each impact at the quasi-static entry speed ``v = omega_r sqrt(A^2 - c^2)``
    (:func:`quasi_static_impact_speed`) has the elastic peak ``sqrt(k0 m) v`` of
    :func:`impactosc.results.contact_table`; two flanges, ``omega_r / 2 pi`` turns per
    second. With ``omega_r = 2 V / D`` it is ``∝ V^2 sqrt(A^2 - c^2) / D^2``: it grows like
    ``V^2`` and peaks over ``D`` where :func:`lead_peak_runout` says.

    Examples
    --------
    >>> from impactosc import TapeDrive
    >>> from impactosc.paper import lead_ae_proxy
    >>> drive = TapeDrive(clearance=50e-6, free_length=40e-3)
    >>> round(lead_ae_proxy(drive.replace(speed=8.0)) / lead_ae_proxy(drive), 9)   # V^2
    4.0
    """
    k0 = drive.K * drive.stiffness
    return 2.0 * drive.omega_r / (2.0 * math.pi) * math.sqrt(k0 * drive.mass) * quasi_static_impact_speed(drive)


def lead_peak_runout(clearance: float, runout_at_zero: float = 0.0) -> float:
    """Run-out ``A`` at which ``omega_r^2 sqrt(A^2 - c^2)`` peaks over the pack diameter.

    ``A(D) = A0 + s D``, ``omega_r ∝ 1/D``: ``d/dD [sqrt(A^2 - c^2) / D^2] = 0`` gives
    ``s A D = 2 (A^2 - c^2)``. For ``A0 = 0`` (run-out proportional to ``D``, the issue's
    assumption) ``s D = A`` and ``A = sqrt(2) c``; for Fig. 6's affine law ``s D = A - A0``
    and the positive root of ``A^2 + A0 A - 2 c^2 = 0`` (``A0 = -39.6 um`` for the straight
    line through 60 um at 44 mm and 180 um at 97 mm).

    Parameters
    ----------
    clearance : float
        ``c = L + mu N / k`` in m (the clearance plus the friction dead band).
    runout_at_zero : float
        ``A0``, the run-out law extrapolated to ``D = 0`` (m).

    Examples
    --------
    >>> from impactosc.paper import lead_peak_runout
    >>> round(lead_peak_runout(50e-6) / 50e-6, 6)                 # A = sqrt(2) c
    1.414214
    >>> round(lead_peak_runout(60e-6, runout_at_zero=-39.6e-6) * 1e6, 2)   # Fig. 6's affine law, um
    106.93
    """
    if runout_at_zero == 0.0:
        return math.sqrt(2.0) * clearance
    a0 = runout_at_zero
    return 0.5 * (-a0 + math.sqrt(a0 * a0 + 8.0 * clearance**2))


# ---------------------------------------------------------------------------------------
# Criteria
# ---------------------------------------------------------------------------------------
def trend_checks(values: np.ndarray, diameters, speeds, t_sin) -> dict[str, bool]:
    """The four criteria of :data:`~impactosc.paper.STUDY_CRITERIA` on an observable of shape (diameter, speed, T sin).

    A curve that is zero everywhere holds no trend; NaN (a failed point) holds none either.

    Parameters
    ----------
    values : array_like
        The observable, shape ``(len(diameters), len(speeds), len(t_sin))``.
    diameters, speeds, t_sin : sequence of float
        The grid (pack diameters in m, speeds in m/s, T sin(theta/2) in N), each increasing.

    Returns
    -------
    dict
        ``{"mid_pack": bool, "speed": bool, "tension": bool, "double": bool}``.

    Examples
    --------
    >>> import numpy as np
    >>> from impactosc.paper import trend_checks
    >>> d = np.linspace(44e-3, 97e-3, 5)
    >>> curve = np.array([0.3, 0.8, 1.0, 0.8, 0.5])               # peaks mid pack
    >>> y = np.einsum("i,j,k->ijk", curve, [1.0, 1.5, 2.0], [2.0, 1.0])
    >>> trend_checks(y, d, [4, 8, 12], [0.1, 0.7])
    {'mid_pack': True, 'speed': True, 'tension': True, 'double': True}
    """
    y = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(y)) or not np.any(y > 0):
        return dict.fromkeys(CRITERIA, False)
    mid = mid_pack_fraction(y, diameters) == 1.0
    avg = y.mean(axis=0)  # (speed, t_sin)
    speed = bool(np.all(avg[1:, :] >= 1.1 * avg[:-1, :])) if len(speeds) > 1 else False
    ts = np.asarray(t_sin, dtype=float)
    i01, i07 = int(np.argmin(ts)), int(np.argmax(ts))
    tension = bool(np.all(avg[:, i07] <= 0.9 * avg[:, i01]))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = avg[:, i01] / avg[:, i07]
    double = bool(np.all((ratio >= 1.5) & (ratio <= 2.5)))
    return {"mid_pack": mid, "speed": speed, "tension": tension, "double": double}


def mid_pack_fraction(values: np.ndarray, diameters) -> float:
    """Fraction of the curves (speed, T sin) that peak mid pack by the study's criteria (``trend_checks`` wants 1)."""
    y = np.asarray(values, dtype=float)
    d = np.asarray(diameters, dtype=float)
    lo, hi = d[0] + (d[-1] - d[0]) / 3.0, d[0] + 2.0 * (d[-1] - d[0]) / 3.0
    hits = 0
    for j in range(y.shape[1]):
        for k in range(y.shape[2]):
            c = y[:, j, k]
            i = int(np.argmax(c))
            hits += bool(0 < i < len(c) - 1 and lo <= d[i] <= hi and c[i] >= 1.1 * max(c[0], c[-1]) and c[i] > 0)
    return hits / (y.shape[1] * y.shape[2])


# ---------------------------------------------------------------------------------------
# One point: a steady state's observables
# ---------------------------------------------------------------------------------------
def observe(drive: TapeDrive, *, transient_turns: int = TRANSIENT_TURNS, measured_turns: int = MEASURED_TURNS,
            backend: str = "exact") -> dict[str, float]:
    """The observables (both flanges, SI) of ``drive`` over ``measured_turns`` reel turns after a transient.

    The run starts at the paper's ``X = 0.95, X' = 0`` (eq. 6-7); the measured run restarts
    from the end of the transient with the forcing phase carried on.
    """
    osc = drive.oscillator()
    period = 2.0 * math.pi / osc.Omega
    first = simulate(osc, transient_turns * period, 0.95, 0.0, backend=backend, record="stats")
    if first.status != 0:
        raise RuntimeError(f"transient failed: {first.message}")
    phase = math.fmod(osc.Omega * first.t_final, 2.0 * math.pi)
    sol = simulate(drive.oscillator(phase=phase), measured_turns * period, first.x_final, first.v_final,
                   backend=backend, record="stats")  # the contact sums are streamed: no table needed
    if sol.status != 0:
        raise RuntimeError(f"measured run failed: {sol.message}")
    return sol.contact_observables(drive)["both"]


def _point(payload: tuple) -> dict:
    """One study point (module level: pickles for a process pool). Never raises."""
    fields, point, turns = payload
    try:
        if "guides" in fields:  # a tape path (impactosc.paper._study_path)
            out = observe_path(path_of(fields, point), transient_turns=turns[0], measured_turns=turns[1])
        else:
            out = observe(resolve_drive(TapeDrive(**fields), point), transient_turns=turns[0],
                          measured_turns=turns[1])
        return {name: out[name] for name in STUDY_OBSERVABLES} | {"error": ""}
    except Exception as exc:  # noqa: BLE001 - a failed point is recorded as NaN with its reason
        return dict.fromkeys(STUDY_OBSERVABLES, math.nan) | {"error": f"{type(exc).__name__}: {exc}"}


def study_grid(quick: bool) -> dict:
    """The grid every model is judged on: pack diameters (m), speeds (m/s), T sin(theta/2) (N)."""
    base = TapeDrive()
    n = 5 if quick else 7
    return {"diameters": np.linspace(base.hub_diameter, base.full_pack_diameter, n), "speeds": SPEEDS,
            "t_sin": QUICK_T_SIN if quick else T_SIN}


def evaluate_models(models: dict[str, dict], *, quick: bool = False, executor=None, progress: bool = False,
                    turns: dict[str, tuple[int, int]] | None = None) -> dict[str, dict]:
    """Every study observable of each model on :func:`study_grid`, all points in one parallel run.

    Parameters
    ----------
    models : dict
        name -> TapeDrive fields changed from the paper's; a tape path's also hold ``guides``
        (a list of :class:`~impactosc.model.Guide` fields) and ``end_span``
        (``PATH_CANDIDATES`` of ``impactosc.paper._study_path``).
    quick : bool
        The coarse grid (5 diameters, T sin(theta/2) = 0.1 and 0.7 N).
    executor, progress
        As :func:`impactosc.runner.run_points` (None: the local process pool).
    turns : dict, optional
        name -> (transient, measured) reel turns (default ``TRANSIENT_TURNS, MEASURED_TURNS``).

    Returns
    -------
    dict
        name -> ``fields``, ``values`` (observable -> array (diameter, speed, T sin)),
        ``trends`` (observable -> :func:`trend_checks`), ``errors``; and the grid under each.
    """
    grid = study_grid(quick)
    shape = (len(grid["diameters"]), len(grid["speeds"]), len(grid["t_sin"]))
    turns = turns or {}
    todo, index = [], {}
    out: dict[str, dict] = {}
    for name, fields in models.items():
        out[name] = {"fields": dict(fields), **grid, "errors": [],
                     "values": {obs: np.full(shape, np.nan) for obs in STUDY_OBSERVABLES}}
        nt = turns.get(name, (TRANSIENT_TURNS, MEASURED_TURNS))
        for idx in np.ndindex(*shape):
            key = f"{name}|{'-'.join(map(str, idx))}"
            index[key] = (name, idx)
            point = {"pack_diameter": float(grid["diameters"][idx[0]]), "speed": float(grid["speeds"][idx[1]]),
                     "t_sin_half_theta": float(grid["t_sin"][idx[2]])}
            todo.append((key, (dict(fields), point, nt)))

    def on_result(key, result):
        name, idx = index[key]
        for obs in STUDY_OBSERVABLES:
            out[name]["values"][obs][idx] = result[obs]
        if result["error"]:
            out[name]["errors"].append(f"{idx}: {result['error']}")

    def on_lost(key, message):
        name, idx = index[key]
        out[name]["errors"].append(f"{idx}: lost ({message})")

    run_points(_point, todo, (), executor=executor, on_result=on_result, on_lost=on_lost, progress=progress,
               desc="study", what="study")
    for res in out.values():
        res["trends"] = {obs: trend_checks(res["values"][obs], grid["diameters"], grid["speeds"], grid["t_sin"])
                         for obs in STUDY_OBSERVABLES}
    return out


def search_models(quick: bool = False) -> dict[str, dict]:
    """The search's models: the in-plane reading (mu = 0.2) over span length x clearance."""
    spans = QUICK_SEARCH_SPANS if quick else SEARCH_SPANS
    clearances = QUICK_SEARCH_CLEARANCES if quick else SEARCH_CLEARANCES
    return {f"l{span * 1e3:g}mm_L{c * 1e6:g}um": {"free_length": span, "clearance": c}
            for span in spans for c in clearances}


# ---------------------------------------------------------------------------------------
# The lead's model over a dense grid (closed form, no simulation)
# ---------------------------------------------------------------------------------------
def lead_scan(spans, clearances, frictions=(0.2,), n_diameters: int = 15) -> list[dict]:
    """The four criteria for :func:`lead_ae_proxy` at every (span, clearance, friction), on the Fig. 8 grid.

    Cheap (closed form): a dense map of where the quasi-static one-impact-per-turn lead could
    give the trends, to aim the simulated search and to test the lead itself.
    """
    rows = []
    for mu in frictions:
        for span in spans:
            for c in clearances:
                base = TapeDrive(free_length=float(span), clearance=float(c), friction=float(mu))
                d = np.linspace(base.hub_diameter, base.full_pack_diameter, n_diameters)
                y = np.array([[[lead_ae_proxy(resolve_drive(base, {"pack_diameter": float(x), "speed": v,
                                                                   "t_sin_half_theta": ts}))
                                for ts in T_SIN] for v in SPEEDS] for x in d])
                rows.append({"free_length": float(span), "clearance": float(c), "friction": float(mu),
                             "stiffness": base.stiffness, **trend_checks(y, d, SPEEDS, T_SIN)})
    return rows


def lead_ratio_bound(band=None) -> dict:
    """The largest 0.1/0.7 N ratio the lead allows while every curve peaks in the middle third.

    In the lead the tension enters only through ``c = L + mu N / k``, and the peak of
    ``sqrt(A^2 - c^2) / D^2`` lies in the middle third of the pack only for ``c`` in a band
    ``[c_lo, c_hi]`` (Fig. 6's affine run-out law). Both tensions' ``c`` must lie in it, so the
    pack-averaged ratio is at most its value for ``c_1 = c_lo, c_2 = c_hi``. Returns the band
    (m) and that ratio.
    """
    base = TapeDrive()
    d = np.linspace(base.hub_diameter, base.full_pack_diameter, 401)
    a = np.array([base.runout_at(x) for x in d])
    lo, hi = d[0] + (d[-1] - d[0]) / 3.0, d[0] + 2.0 * (d[-1] - d[0]) / 3.0

    def g(c):
        return np.sqrt(np.maximum(a * a - c * c, 0.0)) / d**2

    cs = np.linspace(1e-6, base.runout_full, 2000)
    peaks = np.array([d[int(np.argmax(g(c)))] for c in cs])
    inside = (peaks >= lo) & (peaks <= hi)
    c_lo, c_hi = (float(cs[inside].min()), float(cs[inside].max())) if band is None else band
    return {"c_lo": c_lo, "c_hi": c_hi, "ratio": float(np.mean(g(c_lo)) / np.mean(g(c_hi)))}
