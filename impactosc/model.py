"""The nondimensional impact oscillator of the paper (eq. 3), defined once for every backend.

Equation of motion, with ``X = x/L``, ``Lambda = omega_n t`` and primes for ``d/dLambda``::

    X'' + X + beta sgn(X') = F cos(Omega Lambda + phase) - K (X - sgn X) [|X| > 1]

The paper prints the flange term as ``K H(X^2 - 1)(X - 1)`` for both flanges. At the lower
flange (``X < -1``) that expression is ``K (1 + |X|) >= 2K``: the force jumps from 0 to ``2K``
at ``X = -1``, a wall rather than a spring (``backend="rk4", flange="paper"`` shows what it
does to a fixed-step integration). We use the consistent two-sided spring ``K (X - sgn X)``,
which is continuous and vanishes at both contact boundaries ``|X| = 1``.

The hybrid state is a *mode* ``(region, motion)``: ``region`` is -1 (lower flange spring
compressed), 0 (free) or +1 (upper flange); ``motion`` is -1 (slipping down), 0 (stuck)
or +1 (slipping up). In each mode the vector field is linear with harmonic forcing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _validation as _v

__all__ = ["Oscillator"]


@dataclass(frozen=True, slots=True)
class Oscillator:
    """Harmonically forced oscillator with Coulomb friction between two stiff flanges.

    Nondimensional form of the paper's eq. 2, i.e. its eq. 3 with a consistent two-sided
    flange spring (see the module docstring).

    Parameters
    ----------
    F : float
        Forcing amplitude ``F_a / (k L)`` (>= 0). In the tape drive it is the reel run-out
        divided by the flange clearance.
    Omega : float
        Forcing frequency ``omega_r / omega_n`` (>= 0). ``Omega = 0`` is a constant force.
    beta : float
        Coulomb friction level ``mu N / (k L)`` (>= 0), eq. 3 and eq. 5.
    K : float
        Flange-to-tape stiffness ratio ``k0 / k`` (> 0). The paper uses ``1e4``.
    phase : float, optional
        Forcing phase in radians; the forcing is ``F cos(Omega Lambda + phase)``.

    Raises
    ------
    TypeError
        If a parameter is not a real number.
    ValueError
        If a parameter is not finite or breaks its sign rule.
    """

    F: float
    Omega: float
    beta: float
    K: float
    phase: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "F", _v.nonnegative("F", self.F))
        object.__setattr__(self, "Omega", _v.nonnegative("Omega", self.Omega))
        object.__setattr__(self, "beta", _v.nonnegative("beta", self.beta))
        object.__setattr__(self, "K", _v.positive("K", self.K))
        object.__setattr__(self, "phase", _v.real("phase", self.phase))

    # -- forces, in units of k L -------------------------------------------------------
    def forcing(self, t):
        """External force ``F cos(Omega t + phase)`` (the run-out, right side of eq. 3)."""
        return self.F * np.cos(self.Omega * np.asarray(t, dtype=float) + self.phase)

    def forcing_rate(self, t):
        """Time derivative of :meth:`forcing`."""
        return -self.F * self.Omega * np.sin(self.Omega * np.asarray(t, dtype=float) + self.phase)

    def flange_force(self, x):
        """Magnitude of the flange spring force ``K (|X| - 1)+``, in units of ``k L``."""
        return self.K * np.maximum(np.abs(np.asarray(x, dtype=float)) - 1.0, 0.0)

    def restoring_force(self, x):
        """Tape spring plus flange spring: ``X + K (X - sgn X) [|X| > 1]``."""
        x = np.asarray(x, dtype=float)
        return x + self.K * np.sign(x) * np.maximum(np.abs(x) - 1.0, 0.0)

    def net_force(self, t, x):
        """Net non-friction force ``f_net = F cos(Omega t + phase) - X - K (X - sgn X)[|X|>1]``.

        It decides the Filippov stick test at ``X' = 0``: the mass sticks when
        ``|f_net| <= beta`` and otherwise slips towards ``f_net``. It includes the flange
        spring, so a mass at rest inside a flange is tested against the spring's push.
        """
        return self.forcing(t) - self.restoring_force(x)

    def energy(self, x, v):
        """Mechanical energy ``V^2/2 + X^2/2 + (K/2)(|X| - 1)+^2``."""
        x = np.asarray(x, dtype=float)
        v = np.asarray(v, dtype=float)
        pen = np.maximum(np.abs(x) - 1.0, 0.0)
        return 0.5 * v * v + 0.5 * x * x + 0.5 * self.K * pen * pen

    # -- scalar helpers used by the engine's hot loop ------------------------------------
    def _net_force_scalar(self, t: float, x: float) -> float:
        pen = abs(x) - 1.0
        spring = x + (math.copysign(self.K * pen, x) if pen > 0.0 else 0.0)
        return self.F * math.cos(self.Omega * t + self.phase) - spring

    @property
    def contact_frequency(self) -> float:
        """Angular frequency ``sqrt(1 + K)`` of the oscillation while a flange is compressed."""
        return math.sqrt(1.0 + self.K)

    def mirrored(self) -> Oscillator:
        """The same oscillator with the forcing shifted by pi: ``X -> -X`` maps solutions."""
        return Oscillator(self.F, self.Omega, self.beta, self.K, self.phase + math.pi)
