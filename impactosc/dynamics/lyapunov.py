"""The largest Lyapunov exponent of the nonsmooth flow, from its exact tangent dynamics.

A tangent vector ``u`` is carried along the run by the same products as the monodromy
matrix (:mod:`.tangent`): the state-transition matrix of every smooth piece and the
saltation matrix of every event (friction jumps, contacts, impacts, sticks). Every
``renormalise_every`` forcing periods (a time event of the run) its growth is logged and it
is scaled back to unit length (Benettin et al. 1980). The exponent is the mean logarithmic
growth rate::

    lambda = (1 / t) sum_k log |J_k u_k|.

Lyapunov exponents of nonsmooth systems need the saltation matrices: without them the
friction jumps and impacts are invisible to the tangent dynamics (Müller 1995; Leine & van
Campen 2000). On a stable periodic orbit ``lambda = log |mu_max| / period`` (``mu_max`` its
largest Floquet multiplier); a stick collapses the ``V`` direction (the multiplier 0), so
the exponent of an orbit that sticks is ``log |trace M| / period``. A chatter annihilates
the tangent vector altogether: the exponent is then ``-inf``, and the result says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._util import validation as _v
from ..backends._simulate import simulate
from ._common import advanced, check_base, forcing_period, oscillator_of, section_offset
from .flow import IDENTITY
from .tangent import check_backend, check_start, tangent_run

__all__ = ["LyapunovResult", "lyapunov_exponent"]


@dataclass(eq=False)
class LyapunovResult:
    """The largest Lyapunov exponent and its convergence history.

    Attributes
    ----------
    exponent : float
        Per unit of nondimensional time ``Lambda`` (divide by the drive's time scale for 1/s).
    t : ndarray
        Times of the renormalisations (from the end of the transient).
    history : ndarray
        The running estimate after each renormalisation (its last value is ``exponent``).
    growth : ndarray
        ``log |J_k u_k|`` of each renormalisation interval.
    status : int
        0 the run reached its end; -1 a run failed (the estimate so far is kept);
        2 a guard was crossed tangentially (the tangent dynamics are undefined there);
        3 the tangent vector was annihilated (a chatter or a stick along it): ``-inf``.
    message : str
    """

    exponent: float
    t: np.ndarray
    history: np.ndarray
    growth: np.ndarray
    status: int
    message: str
    renormalise_every: int

    def to_xarray(self):
        """The convergence history as an :class:`xarray.Dataset` (dimension ``renormalisation``)."""
        import xarray as xr

        return xr.Dataset({"t": ("renormalisation", self.t), "estimate": ("renormalisation", self.history),
                           "growth": ("renormalisation", self.growth)},
                          attrs={"exponent": self.exponent, "status": self.status, "message": self.message})

    def plot(self, ax=None):
        """The running estimate against time."""
        from .._util.optional import require_matplotlib

        plt = require_matplotlib()

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 3.5))
        ax.plot(self.t, self.history)
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_xlabel("time since the transient (Lambda)")
        ax.set_ylabel("largest Lyapunov exponent estimate")
        return ax


class _Renormaliser:
    """The ``on_sample`` hook: apply the accumulated Jacobian to ``u``, log, rescale, restart."""

    def __init__(self):
        self.u = (math.sqrt(0.5), math.sqrt(0.5))
        self.times: list[float] = []
        self.growth: list[float] = []
        self.dead_at = None

    def __call__(self, rec, t, x, v, jac):
        if self.dead_at is not None:
            return IDENTITY
        a, b, c, d = jac
        u0, u1 = self.u
        w0, w1 = a * u0 + b * u1, c * u0 + d * u1
        norm = math.hypot(w0, w1)
        self.times.append(t)
        if not norm > 0.0 or not math.isfinite(norm):
            self.growth.append(-math.inf if norm == 0.0 else math.nan)
            self.dead_at = t
            return IDENTITY
        self.growth.append(math.log(norm))
        self.u = (w0 / norm, w1 / norm)
        return IDENTITY


def lyapunov_exponent(osc, periods: int = 1000, *, transient_periods: int = 100, renormalise_every: int = 1,
                      x0: float = 0.95, v0: float = 0.0, phase: float | None = None, backend: str = "heyoka",
                      **options) -> LyapunovResult:
    """Largest Lyapunov exponent of the hybrid flow from ``(x0, v0)``.

    Parameters
    ----------
    osc : Oscillator or TapeDrive
    periods : int
        Forcing periods over which the exponent is averaged (its error falls like ``1/periods``).
    transient_periods : int
        Forcing periods run first (without the tangent dynamics) to reach the attractor.
    renormalise_every : int
        Forcing periods between renormalisations of the tangent vector (<= ``periods``; the
        last interval is shorter when ``periods`` is not a multiple of it).
    x0, v0 : float
        Initial state; ``phase`` the forcing phase of the start (default: as at t = 0).
    backend : {"heyoka", "scipy", "exact"}
        ``**options`` are its options.

    Returns
    -------
    LyapunovResult
    """
    check_base(osc)
    osc = oscillator_of(osc)
    periods = _v.integer("periods", periods)
    transient_periods = _v.integer("transient_periods", transient_periods, minimum=0)
    renormalise_every = _v.integer("renormalise_every", renormalise_every)
    if renormalise_every > periods:
        raise ValueError(f"renormalise_every must be <= periods (the run lasts periods={periods} forcing periods, "
                         f"so an interval of {renormalise_every} would never end inside it), got "
                         f"renormalise_every={renormalise_every}")
    T = forcing_period(osc)
    sec = advanced(osc, section_offset(osc, phase))
    check_backend(sec, backend, options)
    x0, v0 = check_start(sec, (transient_periods or periods) * T, x0, v0)
    if transient_periods:
        sol = simulate(sec, transient_periods * T, x0, v0, backend=backend, record="stats", **options)
        if sol.status != 0:
            return LyapunovResult(math.nan, np.array([]), np.array([]), np.array([]), -1,
                                  f"the transient failed: {sol.message}", renormalise_every)
        x0, v0 = sol.x_final, sol.v_final
    # Exactly `periods` periods: every renormalise_every periods, and at the end (a shorter
    # last interval when periods is not a multiple of renormalise_every).
    counts = list(range(renormalise_every, periods + 1, renormalise_every))
    if counts[-1] != periods:
        counts.append(periods)
    span = periods * T
    times = T * np.array(counts, dtype=float)
    times[-1] = span
    hook = _Renormaliser()
    sol, rec = tangent_run(sec, span, x0, v0, backend=backend, options=options, sample_at=times, on_sample=hook)
    t = np.array(hook.times)
    growth = np.array(hook.growth)
    with np.errstate(invalid="ignore", divide="ignore"):
        history = np.cumsum(growth) / t if t.size else np.array([])
    exponent = float(history[-1]) if history.size else math.nan
    status, message = 0, f"{t.size} renormalisations over {t[-1] if t.size else 0:.6g} time units"
    # A start at rest held by static friction alone (rec.held_start) does not count: the exponent
    # is a rate along the trajectory, which reached that rest (after the transient) by a stick
    # whose neighbours stick too, and one instant at the start does not change a mean rate.
    if rec.tangential is not None:
        s = rec.tangential
        status, message = 2, f"{s.reason}: the tangent dynamics are undefined there (grazing); no exponent"
        exponent = math.nan
    elif hook.dead_at is not None:
        status, message = 3, (f"the tangent vector was annihilated before t={hook.dead_at:.12g} (a chatter, or a "
                              "stick along it): every perturbation dies in finite time, the exponent is -inf")
        exponent = -math.inf
    elif sol.status != 0:
        status, message = -1, f"the run stopped early ({sol.message}); the estimate so far is kept"
    return LyapunovResult(exponent, t, history, growth, status, message, renormalise_every)
