"""The paper's Fig. 6, 7 and 8, recomputed: event-driven solver, the paper's RK4 baseline, alternatives.

What the paper shows (section 5): Fig. 6 the reel run-out versus pack diameter, Fig. 7 the
average flange force (over 1 s) versus pack diameter for V = 4, 8, 12 m/s and T = 1, 2 N,
Fig. 8 the same for ``T sin(theta/2) = 0.1 ... 0.7`` N at each speed (theta = 60 deg).

What this module computes:

* :func:`fig6`: the run-out law of :class:`~impactosc.TapeDrive` as a table and a figure;
* :func:`fig7_grid`, :func:`fig8_grid`: the paper's grids, run with the event-driven solver
  through :func:`impactosc.sweep` (heyoka), and with the paper's fixed-step RK4 with a naive
  ``sign()`` through :func:`rk4_grid` (both the consistent two-sided flange and
  ``flange="paper"``, eq. 2 as printed);
* :data:`ALTERNATIVES`: parameter sets in which the tape does touch the flanges, and
  :func:`trends`, which checks the paper's qualitative claims on a Fig. 8 grid;
* :func:`reproduce`: all of it, written as PNG figures, CSV tables and a markdown report;
* :func:`study`: the four trends of the measured Fig. 4 against candidate models and
  observables of contact as the AE sensor saw them, with a search of the parameter space
  (``fig4_study.md``); its criteria are :data:`STUDY_CRITERIA`, fixed before the search.

Inside: ``_grids`` (the paper's grids, drives and alternative sets), ``_compute`` (the
computations of the figures), ``_figures`` (their drawing), ``_reproduce`` (the whole run)
and ``_report`` (the markdown report, from the summary alone).

The finding (see the report): with the paper's stated parameters the tape never touches a
flange after the initial condition. ``F = runout/L <= 0.18 < 1`` and ``Omega ~ 1e-4``: the
reel forces the tape quasi-statically (no dynamic amplification), so ``|X| <= F + beta``
once the free oscillation started by ``X(0) = 0.95`` has died out (~6 ms), and that free
oscillation itself stays inside the flanges. The mean flange force is 0 N everywhere.
"""

from ._compute import fig6, figure_dt, quasi_static_mean_force, rk4_default_step_cost, rk4_grid, trends
from ._grids import (
    ALTERNATIVES,
    FIGURE_STEPS_PER_PERIOD,
    FULL_DURATION,
    FULL_N_DIAMETERS,
    PAPER_SPEEDS,
    PAPER_T_SIN_HALF_THETA,
    PAPER_TENSIONS,
    QUICK_DURATION,
    QUICK_N_DIAMETERS,
    Alternative,
    fig7_grid,
    fig8_grid,
    pack_diameters,
    resolve_drive,
)
from ._grids import grid_points as _points  # noqa: F401 - benchmarks/speed.py walks the paper's grids with it
from ._report import write_report
from ._reproduce import reproduce
from ._study import CANDIDATES as STUDY_CANDIDATES
from ._study import CRITERIA as STUDY_CRITERIA
from ._study import (
    lead_ae_proxy,
    lead_peak_runout,
    quasi_static_impact_speed,
    trend_checks,
)
from ._study_run import study

__all__ = [
    "PAPER_SPEEDS", "PAPER_TENSIONS", "PAPER_T_SIN_HALF_THETA", "ALTERNATIVES", "FIGURE_STEPS_PER_PERIOD",
    "pack_diameters", "fig6", "fig7_grid", "fig8_grid", "resolve_drive", "figure_dt", "rk4_grid",
    "rk4_default_step_cost", "quasi_static_mean_force", "trends", "reproduce", "write_report",
    "FULL_DURATION", "QUICK_DURATION", "FULL_N_DIAMETERS", "QUICK_N_DIAMETERS", "Alternative",
    "study", "STUDY_CRITERIA", "STUDY_CANDIDATES", "trend_checks", "quasi_static_impact_speed", "lead_ae_proxy",
    "lead_peak_runout",
]
