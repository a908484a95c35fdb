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

__all__ = ["den_hartog_amplitude", "den_hartog_onset", "den_hartog_multipliers", "quasi_static_critical_clearance"]


def den_hartog_amplitude(F: float, Omega: float, beta: float) -> float:
    """Amplitude of the non-stop steady state of ``X'' + X + beta sgn X' = F cos(Omega t)`` (Den Hartog 1931).

    Two stops per period at ``+-A``. Valid where that motion exists (it does not stick at
    its stops: ``A Omega^2 > beta``, and the radicand is positive); NaN elsewhere.
    """
    G = F / (1.0 - Omega * Omega)
    q = beta * math.tan(math.pi / (2.0 * Omega)) / Omega
    rad = G * G - q * q
    if not rad > 0.0:
        return math.nan
    A = math.sqrt(rad)
    return A if A * Omega * Omega > beta else math.nan


def den_hartog_onset(Omega: float, beta: float) -> float:
    """Forcing amplitude at which the Den Hartog steady state reaches the flange ``|X| = 1``."""
    q = beta * math.tan(math.pi / (2.0 * Omega)) / Omega
    return abs(1.0 - Omega * Omega) * math.sqrt(1.0 + q * q)


def den_hartog_multipliers(F: float, Omega: float, beta: float) -> np.ndarray:
    """Floquet multipliers of the Den Hartog orbit, in closed form.

    Over each half period ``tau = pi/Omega`` the free flow is a rotation ``R(tau)``; at each
    stop the friction force jumps and the saltation matrix is ``diag(1, rho)`` with
    ``rho = (A Omega^2 - beta) / (A Omega^2 + beta)`` (at the stop ``f_net = A Omega^2``). The
    monodromy matrix is ``(S R)^2``, so the multipliers are the squares of the eigenvalues
    of ``S R``: ``det = rho^2`` per period, ``|mu| = rho`` when they are complex.
    """
    A = den_hartog_amplitude(F, Omega, beta)
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
