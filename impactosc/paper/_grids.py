"""The paper's grids and drives: its speeds, tensions, pack diameters, and the alternative parameter sets."""

from __future__ import annotations

from typing import TypedDict

import numpy as np

from ..model._tape import TapeDrive

#: Tape speeds of Fig. 7 and 8 (m/s).
PAPER_SPEEDS = (4.0, 8.0, 12.0)
#: Nominal tensions of Fig. 7 (N): solid and dashed lines.
PAPER_TENSIONS = (1.0, 2.0)
#: ``T sin(theta/2)`` values of Fig. 8 (N), at theta = 60 deg.
PAPER_T_SIN_HALF_THETA = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)
#: Pack diameters of the full and the quick grids (hub .. full pack, evenly spaced).
FULL_N_DIAMETERS = 15
QUICK_N_DIAMETERS = 5
#: Averaging time of the paper (s), and the shorter one of ``quick=True``.
FULL_DURATION = 1.0
QUICK_DURATION = 0.01
#: RK4 steps per *free* period ``2 pi`` (nondimensional) used for the RK4 figures.
FIGURE_STEPS_PER_PERIOD = 100


class Alternative(TypedDict):
    """One entry of :data:`ALTERNATIVES`."""

    fields: dict[str, float | str]  # TapeDrive fields changed from the paper's
    title: str
    why: str
    event_grid: str  # "fig8" or "coarse"


#: Alternative parameter sets (TapeDrive fields changed from the paper's), in which contacts occur.
#: ``event_grid``: how the event-driven solver is run on them (``"fig8"``: the full Fig. 8 grid;
#: ``"coarse"``: a coarse grid over a shorter window, because that set is expensive).
ALTERNATIVES: dict[str, Alternative] = {
    "tight_guide": {
        "fields": {"clearance": 50e-6},
        "title": "A: tight guide, L = 50 um (in-plane bending, paper's friction)",
        "why": ("Real tape-guide and roller-flange clearances are tens of micrometres, not 1 mm: a guide must "
                "hold the tape laterally to a fraction of a track. With L = 50 um the run-out (60-180 um) exceeds "
                "the clearance at every pack diameter, so the tape is pushed into a flange once per reel turn. "
                "Everything else is the paper's (in-plane bending k = 5.2e5 N/m, mu = 0.2)."),
        "event_grid": "coarse",
    },
    "plate_bending_air_film": {
        "fields": {"bending": "out-of-plane", "friction": 1e-5, "clearance": 100e-6},
        "title": "B: plate bending (I = w h^3/12), air-lubricated roller mu = 1e-5, L = 100 um",
        "why": ("Eq. 4 with the plate reading I = w h^3/12 (probably what a reader of 'moment of inertia of the "
                "tape' computes) gives k = 0.26 N/m and f_n = 65 Hz, the range of the reel's rotation "
                "(14-87 Hz): Omega = 0.2-1.3, so the dynamic trade-off of amplitude against frequency the paper "
                "invokes can exist. But then, with mu = 0.2 and L = 1 mm, beta = 1540 T sin(theta/2)/N (771 at "
                "T = 1 N): the tape sticks for the whole second (F_a = k * runout ~ 3e-5 N against mu N ~ 0.2 N). "
                "A tape running at 4-12 m/s "
                "over a roller rides on a self-acting air film, and lateral slip on a rotating roller meets little "
                "resistance, so a much smaller effective Coulomb coefficient mu = 1e-5 is assumed (beta = "
                "0.08-0.54 at L = 100 um, mostly below F = 0.6-1.8); L = 100 um as in A's argument (with L = 1 mm "
                "contacts occur "
                "only at 12 m/s near the hub, close to resonance)."),
        "event_grid": "fig8",
    },
}


# ---------------------------------------------------------------------------------------
# Grids and drives
# ---------------------------------------------------------------------------------------
def pack_diameters(drive: TapeDrive | None = None, n: int = FULL_N_DIAMETERS) -> np.ndarray:
    """``n`` evenly spaced pack diameters (m) from the hub to the full pack of ``drive``."""
    drive = TapeDrive() if drive is None else drive
    if int(n) < 2:
        raise ValueError(f"n must be >= 2 diameters, got {n!r}")
    return np.linspace(drive.hub_diameter, drive.full_pack_diameter, int(n))


def fig7_grid(drive: TapeDrive | None = None, quick: bool = False) -> dict:
    """The Fig. 7 grid for :func:`impactosc.sweep`: pack diameter x speed x tension."""
    n = QUICK_N_DIAMETERS if quick else FULL_N_DIAMETERS
    return {"pack_diameter": pack_diameters(drive, n), "speed": list(PAPER_SPEEDS), "tension": list(PAPER_TENSIONS)}


def fig8_grid(drive: TapeDrive | None = None, quick: bool = False) -> dict:
    """The Fig. 8 grid for :func:`impactosc.sweep`: pack diameter x speed x ``t_sin_half_theta``."""
    n = QUICK_N_DIAMETERS if quick else FULL_N_DIAMETERS
    return {"pack_diameter": pack_diameters(drive, n), "speed": list(PAPER_SPEEDS),
            "t_sin_half_theta": list(PAPER_T_SIN_HALF_THETA)}


def resolve_drive(base: TapeDrive, point: dict) -> TapeDrive:
    """The drive of one grid point, as :func:`impactosc.sweep` builds it (``t_sin_half_theta`` sets T)."""
    point = dict(point)
    if "t_sin_half_theta" in point:
        value = point.pop("t_sin_half_theta")
        fields = {f: getattr(base, f) for f in base.__dataclass_fields__ if f != "tension"}
        fields.update(point)
        return TapeDrive.from_t_sin_half_theta(value, **fields)
    return base.replace(**point)


def grid_points(grid: dict):
    """``(index, point)`` for every point of the outer product of ``grid``, in C order."""
    names = list(grid)
    arrays = [np.asarray(grid[k], dtype=float) for k in names]
    shape = tuple(a.size for a in arrays)
    for idx in np.ndindex(*shape):
        yield idx, {k: float(a[i]) for k, a, i in zip(names, arrays, idx, strict=True)}
