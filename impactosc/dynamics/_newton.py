"""One shooting for every map: Newton's method on ``P(z) - z``, the Floquet multipliers, the result.

:func:`shoot` finds a fixed point of any :class:`~._map.PoincareMap` (the built-in family's
stroboscopic map, a user system's map): Newton's step solves ``(M - I) dz = -(P(z) - z)``
with the monodromy matrix ``M = dP/dz`` (least squares when ``M - I`` is singular, as for a
continuum of stuck states), halving the step while the residual does not fall. Its verdicts
are the same for every map: converged, stalled or out of iterations, not differentiable (a
grazing: the map's ``singular``), a failed run. :class:`PeriodicOrbit` is the one result
type; the front ends (:func:`~impactosc.dynamics.periodic_orbit` for the built-in family with
its transient, section phase and period; :func:`~impactosc.dynamics.periodic_orbit_of` for a
user system) fill in the model and the run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from ._map import MapValue, PoincareMap

__all__ = ["PeriodicOrbit", "Shot", "shoot", "floquet_multipliers", "verdict", "MARGINAL"]

#: Distance of the largest multiplier modulus from 1 below which the verdict is "marginal".
MARGINAL = 1e-8
#: Halvings of a Newton step before the iteration counts as stalled.
HALVINGS = 16


def floquet_multipliers(matrix, collapsed: bool = False) -> np.ndarray:
    """Eigenvalues of a monodromy matrix, largest modulus first (complex array).

    A 2x2 matrix takes the closed form (the root without cancellation first, the other from
    the determinant); with ``collapsed`` (a stick or chatter in the period) it has rank one
    at most by construction, and the multipliers are exactly ``trace`` and ``0``. A larger
    matrix takes :func:`numpy.linalg.eigvals`.
    """
    matrix = np.asarray(matrix, dtype=float)
    if matrix.shape != (2, 2):
        mu = np.linalg.eigvals(matrix).astype(complex)
    else:
        a, b, c, d = (float(z) for z in np.ravel(matrix))
        tr = a + d
        if collapsed:
            mu = np.array([tr, 0.0], dtype=complex)
        else:
            det = a * d - b * c
            root = complex(0.25 * tr * tr - det) ** 0.5
            half = 0.5 * tr
            big = half + root if half >= 0 else half - root
            small = det / big if big != 0 else 0.0 * big
            mu = np.array([big, small], dtype=complex)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    if np.all(mu.imag == 0.0):
        mu = mu.real.astype(complex)
    return mu


def verdict(multipliers) -> str:
    """``"stable"``, ``"unstable"`` or ``"marginal"`` (largest ``|mu|`` within :data:`MARGINAL` of 1)."""
    m = float(np.max(np.abs(multipliers)))
    if m < 1.0 - MARGINAL:
        return "stable"
    if m > 1.0 + MARGINAL:
        return "unstable"
    return "marginal"


class Shot(NamedTuple):
    """What :func:`shoot` found: the last iterate, the map's value there and the verdict."""

    z: np.ndarray  #: the fixed point (or the last iterate)
    value: MapValue | None  #: the map at ``z`` (None if the first run failed before any value)
    status: int  #: 0 converged, 1 stalled or out of iterations, 2 not differentiable, -1 the first run failed
    message: str
    iterations: int
    residual: float  #: ``|P(z) - z|``
    history: list  #: the residual after each accepted iterate


def shoot(pmap: PoincareMap, guess, params=None, *, tol: float = 1e-11, max_iter: int = 50,
          project: Callable[[np.ndarray], np.ndarray] | None = None) -> Shot:
    """A fixed point of ``pmap`` at ``params`` by Newton's method from ``guess`` (module docstring).

    Parameters
    ----------
    pmap : PoincareMap
        The map (any object with its members).
    guess : sequence of float
        The first iterate.
    params : sequence of float, optional
        The map's free parameters (default ``pmap.values()``).
    tol : float
        Convergence when ``|P(z) - z| <= tol * max(1, |z|)``.
    max_iter : int
        Newton iterations before giving up (status 1, the last iterate kept).
    project : callable, optional
        ``z -> z`` applied to every trial iterate: keeps it where the model has states (on
        the walls of a rigid flange, say).

    Returns
    -------
    Shot
    """
    z = np.asarray(guess, dtype=float).ravel().copy()
    value = pmap.evaluate(z, params)
    if not value.ok:
        return Shot(z, value, -1, f"the run from the initial guess failed: {value.failure}", 0, math.nan, [])
    d = z.size
    rnorm = float(np.linalg.norm(value.residual))
    history = [rnorm]
    it = 0
    while True:
        converged = rnorm <= tol * max(1.0, float(np.linalg.norm(z)))
        if value.singular:
            return Shot(z, value, 2, f"{value.singular}, so " + (
                "the multipliers are undefined" if converged else
                "Newton cannot proceed; the last iterate is kept"), it, rnorm, history)
        if converged:
            return Shot(z, value, 0, f"converged in {it} Newton iterations (residual {rnorm:.3g})", it, rnorm,
                        history)
        if it >= max_iter:
            return Shot(z, value, 1, f"Newton did not converge in {max_iter} iterations (residual {rnorm:.3g} > "
                        f"tol {tol:g}); the last iterate is kept", it, rnorm, history)
        it += 1
        step = np.linalg.lstsq(value.monodromy - np.eye(d), -value.residual, rcond=None)[0]
        lam, why = 1.0, ""
        for _ in range(HALVINGS):
            trial = z + lam * step
            if project is not None:
                trial = project(trial)
            candidate = pmap.evaluate(trial, params)
            if candidate.ok and np.linalg.norm(candidate.residual) < rnorm:
                break
            why = candidate.failure or why
            lam *= 0.5
        else:
            return Shot(z, value, 1, f"Newton stalled at iteration {it}: no step along the Newton direction reduced "
                        f"the residual {rnorm:.3g}" + (f" (last failure: {why})" if why else "")
                        + "; the last iterate is kept", it, rnorm, history)
        z, value = trial, candidate
        rnorm = float(np.linalg.norm(value.residual))
        history.append(rnorm)


@dataclass(eq=False)
class PeriodicOrbit:
    """A periodic orbit of a map (or the last Newton iterate, see ``status``).

    The one result of :func:`~impactosc.dynamics.periodic_orbit` (the built-in family) and
    :func:`~impactosc.dynamics.periodic_orbit_of` (a user system).

    Attributes
    ----------
    model : Oscillator or HybridSystem
        The model (``oscillator`` is its other name for the built-in family).
    n : int
        Forcing periods (or returns to the section) per orbit period.
    period : float
        ``n`` times the forcing period (NaN for a section map of an autonomous system).
    t0 : float
        Time of the section point (for the built-in family the section phase, as a time within
        the first forcing period).
    z : ndarray
        The orbit's point on the section (the last iterate if Newton did not converge); ``x``
        and ``v`` are its two components for the built-in family.
    state_names : tuple of str
        The names of the components of ``z``.
    monodromy : ndarray
        ``dP^n / dz`` at that point (square, one row per state), from the saltation product.
    multipliers : ndarray of complex
        Floquet multipliers, largest modulus first.
    stability : str
        ``"stable"`` (every ``|mu| < 1``), ``"unstable"`` (some ``|mu| > 1``), ``"marginal"``
        (largest ``|mu|`` within 1e-8 of 1, e.g. without damping or friction) or
        ``"undefined"`` (no monodromy matrix).
    collapsed : bool
        A stick or chatter in the period: one multiplier is exactly 0.
    status : int
        0 converged; 1 Newton did not converge (the last iterate is kept); 2 the map is not
        differentiable at ``z`` (``monodromy`` and ``multipliers`` are NaN, the message says
        why): the orbit crosses a guard tangentially (a grazing impact, a turning point on a
        rigid wall, a release at an extremum of the forcing), or the section point is at rest
        held by static friction alone; -1 a run failed.
    message : str
        What happened, in words.
    iterations : int
        Newton iterations taken.
    residual : float
        ``|P^n(z) - z|`` at ``z``.
    history : list of float
        The residual after each iteration.
    events : numpy.recarray or None
        The built-in family: the events of one orbit period (``Solution.events`` of a run from
        the section point).
    solution : Solution or None
        The built-in family: that run (``record="full"``: :meth:`Solution.sample` gives the orbit).
    signature : tuple
        The events of one period, in order, as the map names them.
    """

    model: Any
    n: int
    period: float
    t0: float
    z: np.ndarray
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
    signature: tuple = ()
    state_names: tuple = ("X", "V")

    @property
    def x(self) -> float:
        """The first component of ``z`` (``X`` for the built-in family)."""
        return float(self.z[0])

    @property
    def v(self) -> float:
        """The second component of ``z`` (``V`` for the built-in family)."""
        return float(self.z[1])

    @property
    def oscillator(self):
        """The model (the built-in family's name for it)."""
        return self.model

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
        else:
            for item in self.signature:
                key = str(item[0]) if isinstance(item, tuple) else str(item)
                counts[key] = counts.get(key, 0) + 1
        point = ", ".join(f"{name} = {q:.12g}" for name, q in zip(self.state_names, self.z, strict=False))
        lines = [f"period-{self.n} orbit (period {self.period:.6g}), status {self.status}: {self.message}",
                 f"  section point {point} at t0 = {self.t0:.6g}",
                 f"  Floquet multipliers: {mus} (|mu|max = {self.spectral_radius:.6g}): {self.stability}"
                 + ("; a stick/chatter collapses a direction (multiplier 0)" if self.collapsed else ""),
                 f"  events per period: {counts}"]
        return "\n".join(lines)

    def plot(self, ax=None, n_points: int = 400):
        """The built-in family's orbit over one period in the phase plane ``(X, V)``, events marked."""
        from .._util.optional import require_matplotlib

        plt = require_matplotlib()  # first: without matplotlib the install hint, whatever the orbit
        if self.solution is None or self.events is None:
            raise ValueError("this orbit keeps no run to plot (a user system's orbit: simulate it from z for one "
                             "period and plot the run)")
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
        for edge in self.model.flanges:
            if math.isfinite(edge):
                ax.axvline(edge, color="0.6", lw=0.8, ls="--")
        ax.set_xlabel("X = x/L")
        ax.set_ylabel("V = dX/dLambda")
        ax.legend(fontsize=8)
        return ax


def orbit_of(shot: Shot, model, n: int, period: float, t0: float, *, state_names: tuple, collapsed: bool = False,
             events=None, solution=None) -> PeriodicOrbit:
    """The :class:`PeriodicOrbit` of a :class:`Shot` (multipliers and verdict from its last value)."""
    d = shot.z.size
    value = shot.value
    M = value.monodromy if value is not None else np.full((d, d), math.nan)
    defined = value is not None and value.ok and not value.singular and shot.status != -1
    mus = floquet_multipliers(M, collapsed) if defined else np.full(d, math.nan, dtype=complex)
    return PeriodicOrbit(model, n, period, t0, shot.z, M, mus, verdict(mus) if defined else "undefined",
                         collapsed, shot.status, shot.message, shot.iterations, shot.residual, shot.history,
                         events, solution, value.signature if value is not None else (), tuple(state_names))
