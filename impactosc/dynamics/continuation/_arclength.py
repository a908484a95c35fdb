"""Pseudo-arclength predictor-corrector (Keller 1977; Allgower & Georg 1990, ch. 2-3).

The unknowns are ``u = (X, V, s_1 .. s_k)`` with each parameter scaled, ``s_j = p_j / scale_j``
(so a step is measured in comparable units whether the parameter is a nondimensional
amplitude or a clearance in metres). The equations are ``G(u) = P^n(z; p) - z = 0``, any
``extra`` equations (a test function, for a boundary in two parameters) and one linear
constraint ``c . (u - u_pred) = 0``: the pseudo-arclength hyperplane through the predicted
point, or ``s_j = limit`` at the end of a branch. Newton's method with the exact Jacobian
corrects the prediction; its steps are bounded (:data:`MAX_CORRECTION`), so a corrector
that is drawn towards another branch fails instead of jumping there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._problem import MapEvaluation, MapProblem
from ._sensitivity import flange_gap

__all__ = ["Settings", "Corrected", "correct", "tangent", "scaled", "unscaled", "parameter", "illinois"]

#: Largest Newton correction (scaled units) and largest distance of the corrected point from the
#: prediction, as multiples of the step length: beyond them the corrector is leaving the branch.
MAX_CORRECTION = 1.0
#: A converged Newton step (below ``tol``) is accepted with a residual up to this many times ``tol``.
ROUNDING_FLOOR = 1e3


@dataclass(frozen=True)
class Settings:
    """The step control and tolerances of a continuation run (see :func:`..continuation`)."""

    step: float
    min_step: float
    max_step: float
    max_points: int
    tol: float
    max_iter: int
    locate: frozenset  #: the kinds of special point to locate (empty: none)
    locate_tol: float
    stop_at: frozenset = frozenset()  #: kinds whose first located point ends a direction
    #: Called with every accepted point (a progress bar); None: nothing.
    on_point: Any = field(default=None, compare=False)


@dataclass(frozen=True, eq=False)
class Corrected:
    """A converged point: the unknowns, the evaluation there and the Newton iterations taken."""

    u: np.ndarray
    ev: MapEvaluation
    iterations: int


def scaled(problem: MapProblem, z, params) -> np.ndarray:
    return np.concatenate([np.asarray(z, float), np.asarray(params, float) / np.asarray(problem.scales)])


def unscaled(problem: MapProblem, u) -> tuple[np.ndarray, tuple]:
    k, d = len(problem.names), problem.dimension
    return u[:d].copy(), tuple(float(s * c) for s, c in zip(u[d:d + k], problem.scales, strict=True))


def parameter(problem: MapProblem, u) -> float:
    """The first free parameter's value at the unknowns ``u``."""
    return float(u[problem.dimension] * problem.scales[0])


def jacobian_rows(problem: MapProblem, ev: MapEvaluation) -> np.ndarray:
    """``dG/du`` (d x (d + k)) in scaled unknowns."""
    return np.hstack([ev.monodromy - np.eye(problem.dimension), ev.dp * np.asarray(problem.scales)[None, :]])


def tangent(rows: np.ndarray, previous=None) -> np.ndarray:
    """The unit null vector of ``rows`` (the branch direction), oriented along ``previous``."""
    _, _, vt = np.linalg.svd(rows)
    t = vt[-1]
    if previous is not None and float(np.dot(t, previous)) < 0.0:
        t = -t
    return t / np.linalg.norm(t)


def _walls(problem: MapProblem, u) -> tuple[float, float]:
    """Distances of the rigid walls at the iterate's parameters (a gap or offset may be free)."""
    _, params = unscaled(problem, u)
    try:
        osc = problem.section(params)
    except ValueError:
        lower, upper = problem.walls
        return lower, upper
    return flange_gap(osc, -1), flange_gap(osc, 1)


def correct(problem: MapProblem, u_pred: np.ndarray, constraint: np.ndarray, settings: Settings,
            extra=None, max_distance: float = math.inf) -> Corrected | str:
    """Newton on ``[G; extra; constraint . (u - u_pred)] = 0`` from ``u_pred``.

    ``extra(ev, u) -> (values, rows)`` adds equations and their gradient rows. Returns the
    :class:`Corrected` point, or a string saying why the corrector failed.
    """
    u = u_pred.copy()
    why = "no iteration"
    last_step = math.inf
    rigid = problem.rigid
    for it in range(settings.max_iter + 1):
        lower, upper = _walls(problem, u) if rigid else (math.inf, math.inf)
        if rigid and not -lower <= u[0] <= upper:
            u = u.copy()  # no state lies beyond a rigid wall: the iterate rests on it
            u[0] = min(max(u[0], -lower), upper)
        z, params = unscaled(problem, u)
        ev = problem.evaluate(z, params)
        if not ev.ok:
            return f"the run failed at iteration {it}: {ev.failure}"
        if ev.singular:
            return f"the map is not differentiable at iteration {it}: {ev.singular}"
        G = ev.residual
        rows = jacobian_rows(problem, ev)
        values = [G]
        if extra is not None:
            ex_values, ex_rows = extra(ev, u)
            values.append(np.atleast_1d(ex_values))
            rows = np.vstack([rows, ex_rows])
        F = np.concatenate(values + [[float(np.dot(constraint, u - u_pred))]])
        residual = float(np.linalg.norm(F))
        if residual <= settings.tol * max(1.0, float(np.linalg.norm(z))):
            return Corrected(u, ev, it)
        settled = last_step <= settings.tol * max(1.0, float(np.linalg.norm(u)))
        if it and settled and residual <= ROUNDING_FLOOR * settings.tol:
            # Newton has stopped moving: the residual is at the rounding floor of a map whose
            # derivative is large (near a grazing it grows like 1/V)
            return Corrected(u, ev, it)
        if it == settings.max_iter:
            why = f"Newton did not converge in {settings.max_iter} iterations (residual {np.linalg.norm(F):.3g})"
            break
        J = np.vstack([rows, constraint[None, :]])
        try:
            du = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            return f"the Jacobian of the corrector is singular at iteration {it}"
        if not np.all(np.isfinite(du)):
            return f"the Newton step is not finite at iteration {it}"
        size = last_step = float(np.linalg.norm(du))
        if size > MAX_CORRECTION:
            return f"a Newton correction of {size:.3g} (scaled) at iteration {it}: the corrector is leaving the branch"
        u = u + du
        if float(np.linalg.norm(u - u_pred)) > max_distance:
            return f"the corrector moved {np.linalg.norm(u - u_pred):.3g} from the prediction: leaving the branch"
    return why


def illinois(lo: float, flo: float, hi: float, fhi: float, s: float, fs: float, side: int):
    """One bracket update of the Illinois variant of regula falsi.

    The new point ``(s, fs)`` replaces the end whose sign it shares. When the same end
    (``lo``) is kept twice in a row its value is halved, so the bracket shrinks from both
    sides instead of creeping from one. Returns ``lo, flo, hi, fhi, side``.
    """
    if fs * fhi < 0.0:
        return hi, fhi, s, fs, 0
    if side == -1:
        flo *= 0.5
    return lo, flo, s, fs, -1


def step_past(problem, u_g, direction, step: float, settings, refusal):
    """The point corrected from ``u_g + s direction`` (``s = step, step/2, ...``) that ``refusal`` accepts, or why not.

    ``refusal(result) -> str | None`` says why a corrected point is not the one sought (None: it is);
    the halving stops at ``settings.min_step``, and the last reason is returned.
    """
    why = "no step tried"
    step *= 2.0
    while step > settings.min_step:
        step *= 0.5
        result = correct(problem, u_g + step * direction, direction, settings, max_distance=2.0 * step + 1e-9)
        if not isinstance(result, Corrected):
            why = result
            continue
        why = refusal(result)
        if why is None:
            return result
    return why
