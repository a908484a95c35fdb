"""Closed forms the dynamics toolkit is checked against (and that a designer can use directly).

* Den Hartog (1931), *Forced vibrations with combined viscous and Coulomb damping*: the
  non-stop steady state of ``X'' + X + beta sgn X' = F cos(Omega t)`` has two stops per
  period at ``X = +-A``; its stability follows from the saltation matrices of the stops.
* The quasi-static limit of the tape drive (``Omega -> 0``): the tape creeps after the
  run-out, lagging it by the friction deflection ``mu N / k``.
"""

from __future__ import annotations

import math

import numpy as np

from .._util import validation as _v

__all__ = ["den_hartog_amplitude", "den_hartog_onset", "den_hartog_multipliers", "quasi_static_critical_clearance"]


def _check(F=None, Omega=None, beta=None) -> None:
    """The rules of the closed forms' arguments (TypeError/ValueError naming the argument)."""
    if F is not None:
        _v.nonnegative("F", F)
    if Omega is not None:
        _v.positive("Omega", Omega)
    if beta is not None:
        _v.nonnegative("beta", beta)


def _friction_lag(Omega: float, beta: float) -> float:
    """``q (1 - Omega^2) = beta (1 - Omega^2) tan(pi / (2 Omega)) / Omega``, finite through ``Omega = 1``.

    Both ``F / (1 - Omega^2)`` and ``q`` diverge at the resonance ``Omega = 1``; their ratio
    does not: ``(1 - Omega^2) tan(pi/(2 Omega)) -> -4/pi``. Den Hartog's formulas are
    evaluated multiplied through by ``1 - Omega^2``.
    """
    if Omega == 1.0:
        return -4.0 * beta / math.pi
    return beta * (1.0 - Omega * Omega) * math.tan(math.pi / (2.0 * Omega)) / Omega


def den_hartog_amplitude(F: float, Omega: float, beta: float) -> float:
    """Amplitude of the non-stop steady state of ``X'' + X + beta sgn X' = F cos(Omega t)`` (Den Hartog 1931).

    Two stops per period at ``+-A``. Valid where that motion exists (it does not stick at
    its stops: ``A Omega^2 > beta``, and the radicand is positive); NaN elsewhere. At the
    resonance ``Omega = 1`` the amplitude grows without bound when ``F > 4 beta / pi``
    (``inf``); below that the non-stop motion does not exist (NaN).

    Raises
    ------
    TypeError, ValueError
        Unless ``F >= 0``, ``Omega > 0`` and ``beta >= 0`` are finite real numbers.
    """
    _check(F, Omega, beta)
    # A^2 (1 - Omega^2)^2 = F^2 - (q (1 - Omega^2))^2
    lag = _friction_lag(Omega, beta)
    rad = F * F - lag * lag
    if not rad > 0.0:
        return math.nan
    if Omega == 1.0:
        return math.inf
    A = math.sqrt(rad) / abs(1.0 - Omega * Omega)
    return A if A * Omega * Omega > beta else math.nan


def den_hartog_onset(Omega: float, beta: float) -> float:
    """Forcing amplitude at which the Den Hartog steady state reaches the flange ``|X| = 1``.

    ``|1 - Omega^2| sqrt(1 + q^2)``, continuous through the resonance: ``4 beta / pi`` at ``Omega = 1``.

    Raises
    ------
    TypeError, ValueError
        Unless ``Omega > 0`` and ``beta >= 0`` are finite real numbers.
    """
    _check(Omega=Omega, beta=beta)
    return math.hypot(1.0 - Omega * Omega, _friction_lag(Omega, beta))


def den_hartog_multipliers(F: float, Omega: float, beta: float) -> np.ndarray:
    """Floquet multipliers of the Den Hartog orbit, in closed form.

    Over each half period ``tau = pi/Omega`` the free flow is a rotation ``R(tau)``; at each
    stop the friction force jumps and the saltation matrix is ``diag(1, rho)`` with
    ``rho = (A Omega^2 - beta) / (A Omega^2 + beta)`` (at the stop ``f_net = A Omega^2``). The
    monodromy matrix is ``(S R)^2``, so the multipliers are the squares of the eigenvalues
    of ``S R``: ``det = rho^2`` per period, ``|mu| = rho`` when they are complex. NaN where
    the orbit does not exist (:func:`den_hartog_amplitude` is NaN or infinite).

    Raises
    ------
    TypeError, ValueError
        Unless ``F >= 0``, ``Omega > 0`` and ``beta >= 0`` are finite real numbers.
    """
    A = den_hartog_amplitude(F, Omega, beta)
    if not math.isfinite(A):
        return np.full(2, math.nan, dtype=complex)
    tau = math.pi / Omega
    rho = (A * Omega**2 - beta) / (A * Omega**2 + beta)
    SR = np.array([[math.cos(tau), math.sin(tau)], [-rho * math.sin(tau), rho * math.cos(tau)]])
    mu = np.linalg.eigvals(SR) ** 2
    return mu[np.argsort(-np.abs(mu))]


def quasi_static_critical_clearance(drive) -> float:
    """Critical clearance ``L_c = run-out - mu N / k`` (m) of a tape drive in the quasi-static limit.

    A slowly forced mass with Coulomb friction lags the forcing by the friction deflection
    ``mu N / k``; the tape edge reaches the flange when the run-out exceeds ``L + mu N/k``.
    """
    return drive.runout - drive.friction_force / drive.stiffness
