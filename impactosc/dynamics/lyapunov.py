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
from ..model._oscillator import Oscillator
from ..model._tape import TapeDrive
from ._common import advanced, check_base, forcing_period, oscillator_of, section_offset
from ._map import PoincareMap
from .flow import IDENTITY
from .tangent import check_backend, check_start, tangent_run

__all__ = ["LyapunovResult", "lyapunov_exponent", "map_lyapunov_exponent"]


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
                      state0=None, **options) -> LyapunovResult:
    """Largest Lyapunov exponent of the hybrid flow from ``(x0, v0)`` (or ``state0``).

    Parameters
    ----------
    osc : Oscillator, TapeDrive, HybridSystem or PoincareMap
        The built-in family's member; or a user system with a forcing period (its
        stroboscopic :class:`~impactosc.dynamics.HybridMap`); or any map with the map
        interface (:class:`~._map.PoincareMap`, e.g. a ``HybridMap`` of several periods), whose
        evaluations are then the "periods". For the last two the tangent products are the
        maps' ``dP/dz`` (:func:`map_lyapunov_exponent`).
    periods : int
        Forcing periods over which the exponent is averaged (its error falls like ``1/periods``).
    transient_periods : int
        Forcing periods run first (without the tangent dynamics) to reach the attractor.
    renormalise_every : int
        Forcing periods between renormalisations of the tangent vector (<= ``periods``; the
        last interval is shorter when ``periods`` is not a multiple of it).
    x0, v0 : float
        Initial state of the built-in family; ``phase`` the forcing phase of the start
        (default: as at t = 0).
    state0 : sequence of float, optional
        Initial state of a user system or a map (one value per state; default zeros).
    backend : {"heyoka", "scipy", "exact"}
        ``**options`` are its options (for a user system, :class:`HybridMap`'s).

    Returns
    -------
    LyapunovResult

    Examples
    --------
    A damped linear oscillator, ``x'' + 2 zeta x' + x = cos(w t)``: the exponent is ``-zeta``.

    >>> import math
    >>> import heyoka as hy
    >>> from impactosc import HybridMode, HybridSystem, symbols
    >>> from impactosc.dynamics import lyapunov_exponent
    >>> x, v, zeta, w = symbols("x v zeta w")
    >>> linear = HybridSystem("x v", {"zeta": 0.1, "w": math.sqrt(1 - 0.1**2)},
    ...                       [HybridMode("only", {x: v, v: hy.cos(w * hy.time) - x - 2 * zeta * v})], [],
    ...                       period=2 * math.pi / w)
    >>> result = lyapunov_exponent(linear, 20, transient_periods=0)
    >>> round(result.exponent, 9)
    -0.1
    """
    if not isinstance(osc, Oscillator | TapeDrive):
        if x0 != 0.95 or v0 != 0.0 or phase is not None or backend != "heyoka":
            raise TypeError("x0, v0, phase and backend are the built-in family's arguments: a user system or a map "
                            "takes its start as state0 (and a HybridMap's options)")
        return map_lyapunov_exponent(osc, periods, state0=state0, transient_periods=transient_periods,
                                     renormalise_every=renormalise_every, **options)
    if state0 is not None:
        raise TypeError(f"state0 is a user system's start; the built-in family takes x0, v0 (got state0={state0!r})")
    check_base(osc)
    osc = oscillator_of(osc)
    periods, transient_periods, renormalise_every = _counts(periods, transient_periods, renormalise_every)
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
    status, message = 0, ""
    # A start at rest held by static friction alone (rec.held_start) does not count: the exponent
    # is a rate along the trajectory, which reached that rest (after the transient) by a stick
    # whose neighbours stick too, and one instant at the start does not change a mean rate.
    if rec.tangential is not None:
        status, message = 2, f"{rec.tangential.reason}: the tangent dynamics are undefined there (grazing); no exponent"
    elif hook.dead_at is not None:
        status, message = 3, (f"the tangent vector was annihilated before t={hook.dead_at:.12g} (a chatter, or a "
                              "stick along it): every perturbation dies in finite time, the exponent is -inf")
    elif sol.status != 0:
        status, message = -1, f"the run stopped early ({sol.message}); the estimate so far is kept"
    return _result(hook.times, hook.growth, status, message, renormalise_every)


def _result(times: list, growth: list, status: int, message: str, every: int) -> LyapunovResult:
    """The exponent, its running estimate and the status of either driver (a flow's or a map's tangent products).

    ``status`` 0 (done: the message is made here), -1 (stopped early: the estimate so far),
    2 (a grazing: no exponent), 3 (the tangent vector annihilated: ``-inf``).
    """
    t, g = np.array(times, dtype=float), np.array(growth, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        history = np.cumsum(g) / t if t.size else np.array([])
    exponent = float(history[-1]) if history.size else math.nan
    if status == 0:
        message = f"{t.size} renormalisations over {t[-1] if t.size else 0:.6g} time units"
    elif status == 2:
        exponent = math.nan
    elif status == 3:
        exponent = -math.inf
    return LyapunovResult(exponent, t, history, g, status, message, every)


def _counts(periods, transient_periods, renormalise_every) -> tuple[int, int, int]:
    periods = _v.integer("periods", periods)
    transient_periods = _v.integer("transient_periods", transient_periods, minimum=0)
    renormalise_every = _v.integer("renormalise_every", renormalise_every)
    if renormalise_every > periods:
        raise ValueError(f"renormalise_every must be <= periods (the run lasts periods={periods} forcing periods, "
                         f"so an interval of {renormalise_every} would never end inside it), got "
                         f"renormalise_every={renormalise_every}")
    return periods, transient_periods, renormalise_every


def map_lyapunov_exponent(pmap, periods: int = 1000, *, state0=None, transient_periods: int = 100,
                          renormalise_every: int = 1, **options) -> LyapunovResult:
    """Largest Lyapunov exponent from the tangent products of a map's evaluations.

    The map's ``dP/dz`` (state-transition matrices and saltation matrices of one map, the
    same evaluations as shooting's) carry a tangent vector ``u`` along the orbit ``z_{k+1} =
    P(z_k)``; every ``renormalise_every`` maps its growth is logged and it is scaled back to
    unit length (Benettin et al. 1980): ``lambda = sum_k log |J_k u_k| / t`` with ``t`` the
    time of the maps so far (``pmap.period()`` each).

    Parameters
    ----------
    pmap : HybridSystem or PoincareMap
        A user system with a forcing period (its stroboscopic :class:`HybridMap` of one
        period, built with ``**options``) or any map with the map interface.
    periods : int
        Map evaluations averaged over (forcing periods for a user system).
    state0 : sequence of float, optional
        The start (default zeros).
    transient_periods : int
        Maps run first: a user system is simulated over them (no tangent dynamics), a map
        is iterated.
    renormalise_every : int
        Maps between renormalisations.

    Returns
    -------
    LyapunovResult
        ``status``: 0 done; 2 the map is not differentiable at an iterate (a grazing: no
        exponent); 3 the tangent vector was annihilated (``-inf``); -1 a run failed (the
        estimate so far is kept).
    """
    from ..backends._hybrid import simulate_system
    from ..model.hybrid._definition import HybridSystem
    from .hybrid_map import HybridMap

    system = pmap if isinstance(pmap, HybridSystem) else None
    hmap = None
    if system is not None:
        pmap = hmap = HybridMap(system, names=(), **options)
    elif options:
        raise TypeError(f"options {sorted(options)} are a user system's map options; this map is built already")
    if not isinstance(pmap, PoincareMap):
        raise TypeError(f"lyapunov_exponent needs an Oscillator, a TapeDrive, a HybridSystem or a map with the map "
                        f"interface (impactosc.dynamics PoincareMap), got {type(pmap).__name__}")
    periods, transient_periods, renormalise_every = _counts(periods, transient_periods, renormalise_every)
    T = pmap.period()
    if not (math.isfinite(T) and T > 0.0):
        raise ValueError(f"the map's period is {T!r}: a Lyapunov exponent per unit time needs a map of a fixed "
                         "time (a forced system's stroboscopic map), not a section map of an autonomous system")
    d = len(pmap.state_names)
    z = np.zeros(d) if state0 is None else np.asarray(state0, dtype=float).ravel()
    if z.size != d or not np.all(np.isfinite(z)):
        raise ValueError(f"state0 must be {d} finite numbers (one per state {pmap.state_names}), got {state0!r}")
    empty = np.array([])
    if transient_periods:
        if hmap is not None:
            sol = simulate_system(hmap.system, hmap.t0 + transient_periods * T, z, t0=hmap.t0, tol=hmap.tol)
            ok, z, why = sol.status == 0, sol.state_final[:d].copy(), sol.message
        else:
            ok, why = True, ""
            for _ in range(transient_periods):
                value = pmap.evaluate(z)
                if not value.ok:
                    ok, why = False, value.failure
                    break
                z = np.asarray(value.image)
        if not ok:
            return LyapunovResult(math.nan, empty, empty, empty, -1, f"the transient failed: {why}", renormalise_every)
    return _result(*_tangent_products(pmap, z, periods, renormalise_every, T), renormalise_every)


def _tangent_products(pmap, z, periods: int, every: int, T: float) -> tuple[list, list, int, str]:
    """``(times, growth, status, message)``: the renormalised tangent products along ``z_{k+1} = P(z_k)``."""
    d = z.size
    u = np.full(d, 1.0 / math.sqrt(d))
    J = np.eye(d)
    times: list[float] = []
    growth: list[float] = []
    status, message = 0, ""
    for k in range(1, periods + 1):
        value = pmap.evaluate(z)
        if not value.ok:
            status, message = -1, f"the run stopped early ({value.failure}); the estimate so far is kept"
            break
        if value.singular:
            status, message = 2, f"{value.singular}: the tangent dynamics are undefined there (grazing); no exponent"
            break
        J = value.monodromy @ J
        z = np.asarray(value.image)
        if k % every and k != periods:
            continue
        w = J @ u
        norm = float(np.linalg.norm(w))
        times.append(k * T)
        J = np.eye(d)
        if not norm > 0.0 or not math.isfinite(norm):
            growth.append(-math.inf if norm == 0.0 else math.nan)
            status, message = 3, (f"the tangent vector was annihilated before t={k * T:.12g} (a stick along it, "
                                  "or a chatter): every perturbation dies in finite time, the exponent is -inf")
            break
        growth.append(math.log(norm))
        u = w / norm
    return times, growth, status, message
