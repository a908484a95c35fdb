"""Periodic orbits of the stroboscopic map by Newton shooting, with their Floquet multipliers.

A period-``n`` orbit is a fixed point ``z = P^n(z)`` of the stroboscopic map ``P`` (the state
``z = (X, V)`` one forcing period later, :mod:`.poincare`). Newton's method needs the
Jacobian ``M = dP^n/dz``, the **monodromy matrix**: the product of the smooth pieces'
state-transition matrices (:mod:`.flow`) and the saltation matrix of every event
(:mod:`.saltation`), gathered by one run (:func:`.tangent.tangent_run`). Its eigenvalues are
the orbit's Floquet multipliers: the orbit is stable when they all lie inside the unit circle.

A stick (or a chatter on a rigid flange) zeroes the ``V`` row of a saltation matrix, so the
monodromy matrix of an orbit that sticks has rank one at most: one multiplier is exactly 0
and the other is its trace. The result says so (``collapsed``) rather than reporting the
rounding residue of an eigenvalue solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from .._util import validation as _v
from ..backends._simulate import simulate
from ..model._oscillator import Oscillator
from ..results._solution import Solution
from ._common import advanced, check_base, forcing_period, oscillator_of, periods_in, section_offset
from .tangent import check_backend, check_start, tangent_run

__all__ = ["PeriodicOrbit", "Monodromy", "periodic_orbit", "monodromy", "floquet_multipliers"]

#: Distance of the largest multiplier modulus from 1 below which the verdict is "marginal".
MARGINAL = 1e-8


def floquet_multipliers(matrix, collapsed: bool = False) -> np.ndarray:
    """Eigenvalues of a 2x2 monodromy matrix, largest modulus first (complex array).

    With ``collapsed`` (a stick or chatter in the period) the matrix has rank one at most
    by construction: the multipliers are exactly ``trace`` and ``0``.
    """
    a, b, c, d = (float(z) for z in np.ravel(matrix))
    tr = a + d
    if collapsed:
        mu = np.array([tr, 0.0], dtype=complex)
    else:
        det = a * d - b * c
        disc = complex(0.25 * tr * tr - det)
        root = disc**0.5
        half = 0.5 * tr
        # the root with no cancellation first, the other from the determinant
        big = half + root if half >= 0 else half - root
        small = det / big if big != 0 else 0.0 * big
        mu = np.array([big, small], dtype=complex)
    order = np.argsort(-np.abs(mu), kind="stable")
    mu = mu[order]
    if np.all(mu.imag == 0.0):
        mu = mu.real.astype(complex)
    return mu


def _verdict(multipliers) -> str:
    m = float(np.max(np.abs(multipliers)))
    if m < 1.0 - MARGINAL:
        return "stable"
    if m > 1.0 + MARGINAL:
        return "unstable"
    return "marginal"


@dataclass(eq=False)
class PeriodicOrbit:
    """A periodic orbit of the stroboscopic map (or the last Newton iterate, see ``status``).

    Attributes
    ----------
    oscillator : Oscillator
        The model.
    n : int
        Forcing periods per orbit period.
    period : float
        ``n`` times the forcing period.
    t0 : float
        Time of the section point (the section phase, as a time within the first forcing period).
    x, v : float
        The orbit's point on the section (the last iterate if Newton did not converge).
    monodromy : ndarray (2, 2)
        ``dP^n / d(X, V)`` at that point, from the saltation product.
    multipliers : ndarray of complex
        Floquet multipliers, largest modulus first.
    stability : str
        ``"stable"`` (every ``|mu| < 1``), ``"unstable"`` (some ``|mu| > 1``) or ``"marginal"``
        (largest ``|mu|`` within 1e-8 of 1, e.g. without damping or friction).
    collapsed : bool
        A stick or chatter in the period: one multiplier is exactly 0.
    status : int
        0 converged; 1 Newton did not converge (``x, v`` hold the last iterate); 2 the map
        is not differentiable at ``(x, v)`` (``monodromy`` and ``multipliers`` are NaN, the
        message says why): the orbit crosses a guard tangentially (a grazing impact, a
        turning point on a rigid wall, a release at an extremum of the forcing), or the
        section point is at rest held by static friction alone (``beta < |f_net| <=
        beta_static``: any velocity makes it slide); -1 a run failed.
    message : str
        What happened, in words.
    iterations : int
        Newton iterations taken.
    residual : float
        ``|P^n(z) - z|`` at ``(x, v)``.
    history : list of float
        The residual after each iteration.
    events : numpy.recarray
        The events of one orbit period (``Solution.events`` of a run from the section point).
    solution : Solution
        That run (``record="full"``: :meth:`Solution.sample` gives the orbit).
    """

    oscillator: Oscillator
    n: int
    period: float
    t0: float
    x: float
    v: float
    monodromy: np.ndarray
    multipliers: np.ndarray
    stability: str
    collapsed: bool
    status: int
    message: str
    iterations: int
    residual: float
    history: list = field(default_factory=list)
    events: Any = None
    solution: Any = None

    @property
    def converged(self) -> bool:
        """True when Newton converged (``status == 0``)."""
        return self.status == 0

    @property
    def stable(self) -> bool:
        """True for a converged orbit whose multipliers all lie inside the unit circle."""
        return self.status == 0 and self.stability == "stable"

    @property
    def spectral_radius(self) -> float:
        """Largest multiplier modulus."""
        return float(np.max(np.abs(self.multipliers)))

    def summary(self) -> str:
        """A few lines: the point, the multipliers, the verdict and the events of a period."""
        mus = ", ".join(f"{m.real:.6g}" if m.imag == 0 else f"{m.real:.6g}{m.imag:+.6g}j" for m in self.multipliers)
        counts: dict[str, int] = {}
        if self.events is not None:
            for k in self.events.kind:
                counts[str(k)] = counts.get(str(k), 0) + 1
        lines = [f"period-{self.n} orbit (period {self.period:.6g}), status {self.status}: {self.message}",
                 f"  section point X = {self.x:.12g}, V = {self.v:.12g} at t0 = {self.t0:.6g}",
                 f"  Floquet multipliers: {mus} (|mu|max = {self.spectral_radius:.6g}): {self.stability}"
                 + ("; a stick/chatter collapses a direction (multiplier 0)" if self.collapsed else ""),
                 f"  events per period: {counts}"]
        return "\n".join(lines)

    def plot(self, ax=None, n_points: int = 400):
        """The orbit over one period in the phase plane ``(X, V)``, events marked."""
        from .._util.optional import require_matplotlib

        plt = require_matplotlib()

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 4))
        sol = self.solution
        t = np.linspace(sol.t0, sol.t_final, n_points)
        x, v = sol.sample(t)
        ax.plot(x, v, lw=1.2, label=f"period-{self.n} orbit ({self.stability})")
        ax.plot([self.x], [self.v], "ko", ms=5, label="section point")
        for kind, marker in (("contact_start", "v"), ("reversal", "s"), ("stick", "x"), ("impact", "^")):
            ev = self.events[self.events.kind == kind]
            if len(ev):
                ax.plot(ev.x, ev.v, marker, ls="none", ms=5, label=kind)
        for edge in self.oscillator.flanges:
            if math.isfinite(edge):
                ax.axvline(edge, color="0.6", lw=0.8, ls="--")
        ax.set_xlabel("X = x/L")
        ax.set_ylabel("V = dX/dLambda")
        ax.legend(fontsize=8)
        return ax


class Monodromy(NamedTuple):
    """The stroboscopic map ``P^n`` at a point and its Jacobian (:func:`monodromy`).

    A named tuple ``(x, v, jacobian, recorder)``, so ``x, v, J, rec = monodromy(...)`` and
    ``monodromy(...)[:2]`` work as they did when it was a plain tuple; the other facts of the
    run are properties.

    Attributes
    ----------
    x, v : float
        ``P^n(x0, v0)``.
    jacobian : ndarray (2, 2)
        ``dP^n / d(X, V)`` from the saltation product; NaN where no Jacobian exists
        (``singular``).
    recorder : impactosc.dynamics.tangent.TangentRecorder
        The run's tangent recorder (:mod:`.tangent`).
    """

    x: float
    v: float
    jacobian: np.ndarray
    recorder: Any

    @property
    def collapsed(self) -> bool:
        """A stick, a stuck start, a chatter or a plastic impact annihilated a direction (rank < 2)."""
        return bool(self.recorder.collapsed)

    @property
    def singular(self):
        """The :class:`~.saltation.Saltation` of the first point where the map has no Jacobian, or None."""
        return self.recorder.singular

    @property
    def differentiable(self) -> bool:
        """True when the Jacobian exists (no tangential crossing, no start held by static friction alone)."""
        return self.recorder.singular is None

    @property
    def reason(self) -> str:
        """Why the map is not differentiable here, in words ("" when it is)."""
        return self.recorder.singular.reason if self.recorder.singular is not None else ""

    @property
    def multipliers(self) -> np.ndarray:
        """Eigenvalues of ``jacobian`` (:func:`floquet_multipliers`), NaN when it does not exist."""
        if not self.differentiable:
            return np.full(2, math.nan, dtype=complex)
        return floquet_multipliers(self.jacobian, self.collapsed)

    @property
    def events(self):
        """The events of the run (``Solution.events``)."""
        return Solution(self.recorder, self.recorder.t_final).events


def monodromy(osc: Oscillator, x0: float, v0: float, n: int = 1, *, t0: float = 0.0, backend: str = "heyoka",
              **options) -> Monodromy:
    """The stroboscopic map ``P^n`` at ``(x0, v0)`` and its Jacobian.

    Parameters
    ----------
    osc : Oscillator or TapeDrive
    x0, v0 : float
        The state at time ``t0``, checked as :func:`impactosc.simulate` checks its start.
    n : int
        Forcing periods.
    t0 : float
        Start time (the section).
    backend : {"heyoka", "scipy", "exact"}
    **options
        Backend options.

    Returns
    -------
    Monodromy
        ``(x, v, jacobian, recorder)`` as a named tuple; ``jacobian`` is a 2x2 array, NaN
        where the map is not differentiable (``.differentiable``, ``.reason``: a grazing
        impact, a start at rest held by static friction alone).

    Raises
    ------
    TypeError, ValueError
        For a bad argument, as :func:`impactosc.simulate` raises them (e.g. ``x0`` beyond a
        rigid flange, a non-finite state).
    RuntimeError
        If the run stops early (its message says why).
    """
    check_base(osc)
    osc = oscillator_of(osc)
    n, span = periods_in(osc, None, n)
    t0 = _v.real("t0", t0)
    sec = advanced(osc, t0)
    check_backend(sec, backend, options)
    x0, v0 = check_start(sec, span, x0, v0)
    sol, rec = tangent_run(sec, span, x0, v0, backend=backend, options=options, record="events")
    if sol.status != 0:
        raise RuntimeError(f"the run from ({x0!r}, {v0!r}) failed: {sol.message}")
    return Monodromy(sol.x_final, sol.v_final, _jacobian(rec), rec)


def periodic_orbit(osc, n: int = 1, *, period: float | None = None, guess=None, x0: float = 0.95,
                   v0: float = 0.0, transient_periods: int = 100, phase: float | None = None,
                   tol: float = 1e-11, max_iter: int = 50, backend: str = "heyoka", **options) -> PeriodicOrbit:
    """Find a period-``n`` orbit by Newton shooting on the stroboscopic map.

    Newton's step solves ``(M - I) dz = -(P^n(z) - z)`` with the monodromy matrix ``M`` from
    the saltation product (least squares when ``M - I`` is singular, as for a continuum of
    stuck states), halving the step while the residual grows.

    Parameters
    ----------
    osc : Oscillator or TapeDrive
        The model (a drive is reduced to its :meth:`~impactosc.TapeDrive.oscillator`).
    n : int
        Forcing periods per orbit period (default 1).
    period : float, optional
        The orbit period instead of ``n``; must be a whole multiple of the forcing period.
    guess : (float, float), optional
        ``(X, V)`` on the section to start Newton from. Default: the state after
        ``transient_periods`` forcing periods from ``(x0, v0)``.
    x0, v0 : float
        Initial state of the transient (at the section time).
    transient_periods : int
        Forcing periods of the transient (>= 0), when no ``guess`` is given.
    phase : float, optional
        Forcing phase ``Omega t + phase`` (mod 2 pi) of the section; default: the phase at t = 0.
    tol : float
        Convergence when ``|P^n(z) - z| <= tol * max(1, |z|)``.
    max_iter : int
        Newton iterations before giving up (status 1, the last iterate kept).
    backend : {"heyoka", "scipy", "exact"}
        Backend of the runs; ``**options`` are its options.

    Returns
    -------
    PeriodicOrbit

    Raises
    ------
    ValueError
        If ``period`` is not a multiple of the forcing period, the forcing is constant, or
        an argument breaks its rule.
    """
    check_base(osc)
    osc = oscillator_of(osc)
    n, span = periods_in(osc, period, n)
    tol = _v.positive("tol", tol)
    max_iter = _v.integer("max_iter", max_iter, minimum=0)
    t_s = section_offset(osc, phase)
    sec = advanced(osc, t_s)  # the run from the section point starts at time 0
    check_backend(sec, backend, options)
    if guess is None:
        transient_periods = _v.integer("transient_periods", transient_periods, minimum=0)
        T = forcing_period(osc)
        x0, v0 = check_start(sec, transient_periods * T if transient_periods else span, x0, v0)
        z = np.array([x0, v0])
        if transient_periods:
            sol = simulate(sec, transient_periods * T, x0, v0, backend=backend, record="stats", **options)
            if sol.status != 0:
                return _failed(osc, sec, n, span, t_s, z, -1, f"the transient failed: {sol.message}", backend, options)
            z = np.array([sol.x_final, sol.v_final])
    else:
        try:
            gx, gv = guess
        except (TypeError, ValueError):
            raise TypeError(f"guess must be a pair (X, V), got {guess!r}") from None
        z = np.array(check_start(sec, span, gx, gv, names=("guess[0]", "guess[1]")))

    history: list[float] = []
    status, message = 1, ""
    it = 0
    image, jac, rec = _map(sec, z, span, backend, options)
    if image is None:
        return _failed(osc, sec, n, span, t_s, z, -1, f"the run from the initial guess failed: {rec}", backend, options)
    res = image - z
    rnorm = float(np.linalg.norm(res))
    history.append(rnorm)
    while True:
        converged = rnorm <= tol * max(1.0, float(np.linalg.norm(z)))
        if rec.singular is not None:
            s = rec.singular
            status, message = 2, (f"{s.reason}, so "
                                  + ("the multipliers are undefined" if converged else "Newton cannot proceed; the "
                                     "last iterate is kept"))
            break
        if converged:
            status, message = 0, f"converged in {it} Newton iterations (residual {rnorm:.3g})"
            break
        if it >= max_iter:
            status, message = 1, (f"Newton did not converge in {max_iter} iterations (residual {rnorm:.3g} > "
                                  f"tol {tol:g}); the last iterate is kept in x, v")
            break
        it += 1
        step = np.linalg.lstsq(jac - np.eye(2), -res, rcond=None)[0]
        lam, accepted, why = 1.0, False, ""
        for _ in range(16):
            trial = z + lam * step
            if sec.rigid:
                trial[0] = min(max(trial[0], -sec.gap(-1)), sec.gap(1))  # no state lies beyond a rigid wall
            t_image, t_jac, t_rec = _map(sec, trial, span, backend, options)
            if t_image is not None and np.linalg.norm(t_image - trial) < rnorm:
                accepted = True
                break
            why = t_rec if t_image is None else why
            lam *= 0.5
        if not accepted:
            status = 1
            message = (f"Newton stalled at iteration {it}: no step along the Newton direction reduced the residual "
                       f"{rnorm:.3g}" + (f" (last failure: {why})" if why else "") + "; the last iterate is kept")
            break
        z, image, jac, rec = trial, t_image, t_jac, t_rec
        res = image - z
        rnorm = float(np.linalg.norm(res))
        history.append(rnorm)
    return _result(osc, sec, n, span, t_s, z, jac, rec, status, message, it, rnorm, history, backend, options)


def _map(sec: Oscillator, z, span: float, backend: str, options: dict):
    """``(P^n(z), M, recorder)``, or ``(None, None, message)`` when the run fails."""
    if sec.rigid and not -sec.gap(-1) <= z[0] <= sec.gap(1):
        return None, None, f"X = {z[0]!r} lies beyond a rigid flange (at {-sec.gap(-1)!r} and {sec.gap(1)!r})"
    try:
        sol, rec = tangent_run(sec, span, float(z[0]), float(z[1]), backend=backend, options=options)
    except ValueError as exc:  # a Newton trial that simulate would refuse (e.g. a speed that overflows)
        return None, None, str(exc)
    if sol.status != 0:
        return None, None, sol.message
    return np.array([sol.x_final, sol.v_final]), _jacobian(rec), rec


def _jacobian(rec) -> np.ndarray:
    """The recorder's Jacobian as a 2x2 array; NaN where none exists (``rec.singular``)."""
    if rec.singular is not None:
        return np.full((2, 2), math.nan)
    return np.array(rec.jacobian, dtype=float).reshape(2, 2)


def _result(osc, sec, n, span, t_s, z, jac, rec, status, message, it, rnorm, history, backend, options):
    mus = floquet_multipliers(jac, rec.collapsed)
    sol = simulate(sec, span, float(z[0]), float(z[1]), backend=backend, record="full", **options)
    return PeriodicOrbit(osc, n, span, t_s, float(z[0]), float(z[1]), jac, mus,
                         _verdict(mus) if rec.singular is None else "undefined", rec.collapsed, status, message, it,
                         rnorm, history, sol.events, sol)


def _failed(osc, sec, n, span, t_s, z, status, message, backend, options):
    nan2 = np.full((2, 2), math.nan)
    return PeriodicOrbit(osc, n, span, t_s, float(z[0]), float(z[1]), nan2, np.full(2, math.nan, dtype=complex),
                         "undefined", False, status, message, 0, math.nan, [], None, None)
