"""A plain Newton solve of a square system, for the changes of unknowns at nonsmooth points."""

from __future__ import annotations

import numpy as np

__all__ = ["newton", "NEWTON_STEPS"]

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
