"""A plain Newton solve of a square system, for the changes of unknowns at nonsmooth points."""

from __future__ import annotations

import numpy as np

__all__ = ["newton", "NEWTON_STEPS", "along", "halving"]

#: Newton iterations at most.
NEWTON_STEPS = 12


def newton(fun, u0, tol: float):
    """Newton on ``fun(u) -> (F, J, payload)`` (square); returns ``(u, payload, error estimate)`` or a reason."""
    u = np.array(u0, dtype=float)
    for it in range(NEWTON_STEPS + 1):
        out = fun(u)
        if isinstance(out, str):
            return f"{out} (iteration {it})"
        F, J, payload = out
        try:
            du = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            return "a singular Jacobian"
        if not np.all(np.isfinite(du)):
            return "a Newton step that is not finite"
        if float(np.linalg.norm(F)) <= tol * max(1.0, float(np.linalg.norm(u[:2]))):
            return u, payload, du  # the step not taken: the error estimate of the converged point
        if it == NEWTON_STEPS:
            break
        u = u + du
    return f"Newton did not converge (residual {np.linalg.norm(F):.3g})"


def along(residual, w_g, direction, step: float, tol: float):
    """The point of the curve ``R(w) = 0`` a pseudo-arclength ``step`` from ``w_g`` along ``direction``.

    ``residual(w) -> (R, dR/dw, payload)`` (one equation fewer than unknowns) or a reason; Newton
    from ``w_g + step * direction`` with the condition ``direction . (w - w_pred) = 0``. Returns
    ``(w, (payload, dR/dw), error estimate)`` or a reason: how every change of unknowns at a
    grazing steps off it onto the family beyond.
    """
    w_pred = w_g + step * direction

    def fun(w):
        res = residual(w)
        if isinstance(res, str):
            return res
        R, J, payload = res
        return np.concatenate([R, [float(direction @ (w - w_pred))]]), np.vstack([J, direction[None, :]]), (payload, J)

    return newton(fun, w_pred, tol)


def halving(first: float, smallest: float):
    """``first, first / 2, ...`` while the step before is above ``smallest``: the steps tried off a nonsmooth point."""
    step = 2.0 * first
    while step > smallest:
        step *= 0.5
        yield step

