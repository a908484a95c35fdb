"""The nondimensional impact oscillator of the paper (eq. 3) and its family, defined once.

Equation of motion, with ``X = x/L``, ``Lambda = omega_n t`` and primes for ``d/dLambda``::

    X'' + 2 zeta X' + X + beta sgn(X') = sum_i F_i cos(Omega_i Lambda + phase_i) - flange(X)

The paper's eq. 3 is the member with ``zeta = 0``, one harmonic ``F cos(Omega Lambda)``,
equal static and kinetic friction and the linear flange spring ``K (X - sgn X) [|X| > 1]``.
The paper prints the flange term as ``K H(X^2 - 1)(X - 1)`` for both flanges. At the lower
flange (``X < -1``) that expression is ``K (1 + |X|) >= 2K``: the force jumps from 0 to ``2K``
at ``X = -1``, a wall that pushes out rather than a spring (``backend="rk4", flange="paper"``
shows what it does to a fixed-step integration). We use the consistent two-sided spring,
which is continuous and vanishes at both contact boundaries ``|X| = 1``.

The family (every member runs on the one engine of :mod:`impactosc.engine`):

* viscous damping ``2 zeta X'`` (``zeta >= 0``);
* Coulomb friction ``beta`` while slipping, ``beta_static >= beta`` for the stick test and the
  breakaway (default: equal);
* flange laws: a spring ``K d^p`` on the penetration ``d = |X| - 1`` (``p = 1`` linear, the
  default; ``p = 1.5`` Hertz), or a rigid flange with Newton restitution ``0 <= e <= 1``
  (instantaneous impact ``V -> -e V`` at ``|X| = 1``);
* forcing: any finite sum of harmonics (the reel run-out and its higher harmonics);
* flange positions: the lower flange at ``X = -gap_lower``, the upper at ``X = +gap_upper``
  (1 and 1: the paper's symmetric guide), either one absent (a one-sided stop). The
  penetration into the flange of side ``r`` is ``d = r X - gap``; the formulas below are
  written for the default ``|X| = 1``.

The hybrid state is a *mode* ``(region, motion)``: ``region`` is -1 (lower flange), 0 (free)
or +1 (upper flange); ``motion`` is -1 (slipping down), 0 (stuck) or +1 (slipping up). With a
spring flange, ``region != 0`` means the spring is compressed; with a rigid flange it means
the mass rests against that flange (``X = region``, ``V = 0``), which is only possible with
``motion == 0``. :meth:`Oscillator.acceleration` is the vector field of every mode.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import KW_ONLY, dataclass, field
from typing import cast

import numpy as np

from .._util import validation as _v
from . import _layout

__all__ = ["Oscillator", "FLANGE_LAWS", "PARAMETERS"]

#: The flange laws of the family: an elastic spring ``K d^p`` or a rigid stop with restitution.
FLANGE_LAWS = ("spring", "rigid")
#: The numeric fields of :class:`Oscillator`: what a study (sweep, continuation, onset) may vary.
#: ``flange`` (a string) and ``harmonics`` (a tuple) are the member's structure.
PARAMETERS = ("F", "Omega", "beta", "K", "phase", "zeta", "beta_static", "exponent", "restitution", "gap_lower",
              "gap_upper")


def _harmonic_terms(value) -> tuple[tuple[float, float, float], ...]:
    """Validate ``harmonics``: a sequence of ``(F_i, Omega_i, phase_i)`` triples."""
    if isinstance(value, str | bytes) or not hasattr(value, "__iter__"):
        raise TypeError(f"harmonics must be a sequence of (F_i, Omega_i, phase_i) triples, got {value!r}")
    out = []
    for i, term in enumerate(value):
        try:
            items = tuple(term)
        except TypeError:
            raise TypeError(f"harmonics[{i}] must be a triple (F_i, Omega_i, phase_i), got {term!r}") from None
        if len(items) == 2:
            items = (*items, 0.0)
        if len(items) != 3:
            raise ValueError(f"harmonics[{i}] must be a triple (F_i, Omega_i, phase_i), got {term!r}")
        out.append((_v.nonnegative(f"harmonics[{i}] amplitude F_i", items[0]),
                    _v.nonnegative(f"harmonics[{i}] frequency Omega_i", items[1]),
                    _v.real(f"harmonics[{i}] phase_i", items[2])))
    return tuple(out)


def _gap(name: str, value, side: str, where: str) -> float:
    """Validate a flange distance: > 0, or ``None``/``inf`` for an absent flange (stored as inf)."""
    if value is None:
        return math.inf
    if isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isinf(value):
        x = float(value)  # +inf: absent; -inf is refused below
    else:
        x = _v.real(name, value)
    if not x > 0.0:
        raise ValueError(f"{name} must be > 0 (the distance from the rest position X = 0 to the {side} flange, "
                         f"at X = {where}), or None or inf for no {side} flange; got {x!r}")
    return x


@dataclass(frozen=True, slots=True)
class Oscillator:
    """Forced oscillator with Coulomb friction between two flanges: the paper's eq. 3 and its family.

    Nondimensional form of the paper's eq. 2, i.e. its eq. 3 with a consistent two-sided
    flange spring (see the module docstring). ``Oscillator(F, Omega, beta, K)`` is the
    paper's model; the keyword-only fields select another member of the family.

    Parameters
    ----------
    F : float
        Forcing amplitude ``F_a / (k L)`` (>= 0). In the tape drive it is the reel run-out
        divided by the flange clearance.
    Omega : float
        Forcing frequency ``omega_r / omega_n`` (>= 0). ``Omega = 0`` is a constant force.
    beta : float
        Coulomb friction level ``mu N / (k L)`` (>= 0), eq. 3 and eq. 5; the kinetic level
        while slipping.
    K : float or None, optional
        Flange stiffness ratio ``k0 / k`` (> 0) of a spring flange; the paper uses ``1e4``.
        Required with ``flange="spring"``. A rigid flange has no stiffness: there ``K`` may be
        omitted (stored as ``0.0``) and a value given is accepted (``>= 0``) and unused, so a
        spring member turns rigid with :func:`dataclasses.replace` alone.
    phase : float, optional
        Forcing phase in radians; the forcing is ``F cos(Omega Lambda + phase)``.
    zeta : float, keyword-only
        Viscous damping ratio (>= 0): the term ``2 zeta X'``.
    beta_static : float or None, keyword-only
        Static friction level (>= ``beta``) for the stick test and the breakaway; ``None``
        (default) means equal to ``beta``.
    flange : {"spring", "rigid"}, keyword-only
        ``"spring"`` (default): the flange pushes back with ``K d^p``, ``d = |X| - 1``.
        ``"rigid"``: an instantaneous impact ``V -> -e V`` at ``|X| = 1``.
    exponent : float, keyword-only
        ``p >= 1`` of the spring law (1: linear, the default; 1.5: Hertz contact).
    restitution : float, keyword-only
        Newton's coefficient of restitution ``0 <= e <= 1`` of a rigid flange (default 1).
    harmonics : sequence of tuple, keyword-only
        Further harmonics ``(F_i, Omega_i, phase_i)`` added to the forcing, e.g. higher
        harmonics of the run-out.
    gap_lower, gap_upper : float or None, keyword-only
        Distances from the rest position ``X = 0`` to the lower flange (at ``X = -gap_lower``)
        and to the upper one (at ``X = +gap_upper``), in units of the clearance ``L``
        (default 1 and 1: the paper's symmetric guide). Each must be > 0; ``None`` or
        ``math.inf`` means that flange is absent (a one-sided stop), stored as ``math.inf``.
        The flange of side ``r`` (+1 upper, -1 lower) is at ``X = r * gap`` and the
        penetration into it is ``d = r X - gap`` (:meth:`Oscillator.gap`,
        :attr:`Oscillator.flanges`). With both absent there is no flange law: ``K``,
        ``exponent`` and ``restitution`` must be left out.

    Raises
    ------
    TypeError
        If a parameter is not a real number (or ``harmonics`` not a sequence of triples).
    ValueError
        If a parameter is not finite, breaks its sign or range rule, or does not apply to
        the chosen flange law.

    Examples
    --------
    >>> Oscillator(0.5, 1.1, 0.01, 1e4)                       # the paper's eq. 3
    >>> Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.02, exponent=1.5)   # damped, Hertz flange
    >>> Oscillator(0.5, 0.0, 0.1, flange="rigid", restitution=0.8)   # no K: a wall has no stiffness
    >>> Oscillator(0.5, 1.1, 0.01, 1e4, gap_lower=1.5, gap_upper=0.5)  # running off-centre
    >>> Oscillator(0.5, 1.1, 0.01, 1e4, gap_lower=None)               # only the upper flange
    """

    F: float
    Omega: float
    beta: float
    # ``None`` is accepted (a rigid flange, or no flange) and stored as 0.0: a float after __post_init__.
    K: float = None  # type: ignore[assignment]
    phase: float = 0.0
    _: KW_ONLY
    zeta: float = 0.0
    beta_static: float | None = None
    flange: str = "spring"
    exponent: float = 1.0
    restitution: float = 1.0
    harmonics: Sequence[Sequence[float]] = ()
    # ``None`` is accepted for an absent flange and stored as ``math.inf``.
    gap_lower: float = 1.0
    gap_upper: float = 1.0
    #: The member as the transition rule's parameter vector (:func:`impactosc.model._layout.params`).
    _p: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "F", _v.nonnegative("F", self.F))
        put(self, "Omega", _v.nonnegative("Omega", self.Omega))
        put(self, "beta", _v.nonnegative("beta", self.beta))
        put(self, "phase", _v.real("phase", self.phase))
        put(self, "zeta", _v.nonnegative("zeta", self.zeta))
        if self.beta_static is not None:
            bs = _v.real("beta_static", self.beta_static)
            if not bs >= self.beta:
                raise ValueError(f"beta_static must be >= beta={self.beta!r} (static friction is at least the "
                                 f"kinetic level), got {bs!r}")
            put(self, "beta_static", bs)
        _v.choice("flange", self.flange, FLANGE_LAWS)
        put(self, "gap_lower", _gap("gap_lower", self.gap_lower, "lower", "-gap_lower"))
        put(self, "gap_upper", _gap("gap_upper", self.gap_upper, "upper", "+gap_upper"))
        if math.isinf(self.gap_lower) and math.isinf(self.gap_upper):
            given = [f"{n}={getattr(self, n)!r}" for n, default in (("K", None), ("flange", "spring"),
                                                                    ("exponent", 1.0), ("restitution", 1.0))
                     if getattr(self, n) != default and not (n == "K" and getattr(self, n) == 0.0)]
            if given:
                raise ValueError(f"{', '.join(given)} describe a flange, but both flanges are absent "
                                 "(gap_lower and gap_upper are None or inf): leave them out, or give a flange a gap")
            put(self, "K", 0.0)
        if self.flange == "rigid" or math.isinf(self.gap_lower) and math.isinf(self.gap_upper):
            put(self, "K", 0.0 if self.K is None else _v.nonnegative("K", self.K))
        elif self.K is None:
            raise TypeError("K must be a real number (the flange stiffness k0/k > 0) with flange='spring', "
                            "got None; only a rigid flange (flange='rigid') goes without it")
        else:
            put(self, "K", _v.positive("K", self.K))
        put(self, "exponent", _v.real("exponent", self.exponent))
        if not self.exponent >= 1.0:
            raise ValueError(f"exponent must be >= 1 (flange force K d^p with p >= 1), got {self.exponent!r}")
        put(self, "restitution", _v.real("restitution", self.restitution))
        if not 0.0 <= self.restitution <= 1.0:
            raise ValueError(f"restitution must satisfy 0 <= e <= 1, got {self.restitution!r}")
        if self.flange == "rigid" and self.exponent != 1.0:
            raise ValueError(f"exponent applies to flange='spring' only, got exponent={self.exponent!r} "
                             "with flange='rigid'")
        if self.flange == "spring" and self.restitution != 1.0:
            raise ValueError(f"restitution applies to flange='rigid' only, got restitution={self.restitution!r} "
                             "with flange='spring'")
        put(self, "harmonics", _harmonic_terms(self.harmonics))
        put(self, "_p", _layout.params(self))

    def replace(self, **fields) -> Oscillator:
        """A copy with some fields changed, validated again (:func:`dataclasses.replace`).

        Parameters
        ----------
        **fields
            Any field of the class (``F``, ``Omega``, ..., ``gap_upper``).

        Raises
        ------
        TypeError
            If a name is not a field of :class:`Oscillator`.
        ValueError
            If the new member breaks a rule (the message names the field).

        Examples
        --------
        >>> osc = Oscillator(0.5, 1.1, 0.01, 1e4)
        >>> osc.replace(F=0.6, zeta=0.02).F
        0.6
        >>> osc.replace(gap_lower=None).flanges                 # a one-sided stop
        (-inf, 1.0)
        """
        from dataclasses import fields as _fields
        from dataclasses import replace

        known = {f.name for f in _fields(self) if f.init}
        unknown = sorted(set(fields) - known)
        if unknown:
            raise TypeError(f"replace() got fields that Oscillator does not have: {', '.join(unknown)}; its fields "
                            f"are {', '.join(sorted(known))}")
        return replace(self, **fields)

    @classmethod
    def from_harmonics(cls, harmonics, beta: float, K: float | None = None, **family) -> Oscillator:
        """An oscillator forced by ``sum_i F_i cos(Omega_i Lambda + phase_i)``.

        The first triple becomes ``(F, Omega, phase)``, the rest ``harmonics``.

        Raises
        ------
        ValueError
            If ``harmonics`` is empty.
        """
        terms = _harmonic_terms(harmonics)
        if not terms:
            raise ValueError("harmonics must hold at least one (F_i, Omega_i, phase_i) triple, got an empty sequence")
        (F, Om, ph), rest = terms[0], terms[1:]
        return cls(F, Om, beta, K, ph, harmonics=rest, **family)  # type: ignore[arg-type]

    # -- the member's structure ----------------------------------------------------------
    @property
    def terms(self) -> tuple[tuple[float, float, float], ...]:
        """Every harmonic of the forcing as ``(F_i, Omega_i, phase_i)``, the fundamental first."""
        # __post_init__ stored ``harmonics`` as a tuple of float triples.
        return ((self.F, self.Omega, self.phase), *cast(tuple, self.harmonics))

    @property
    def beta_s(self) -> float:
        """Static friction level: the stick test and the breakaway threshold (``beta_static`` or ``beta``)."""
        return self.beta if self.beta_static is None else self.beta_static

    @property
    def rigid(self) -> bool:
        """True for a rigid flange with restitution (impacts instead of a compressed spring)."""
        return self.flange == "rigid"

    @property
    def linear(self) -> bool:
        """True when every mode is a linear ODE (no power-law spring): the exact backend's subset."""
        return self.rigid or self.exponent == 1.0

    def gap(self, side: int) -> float:
        """Distance from the rest position to the flange of ``side`` (+1 upper, -1 lower); inf if absent."""
        if side == 1:
            return self.gap_upper
        if side == -1:
            return self.gap_lower
        raise ValueError(f"side must be +1 (upper flange) or -1 (lower flange), got {side!r}")

    @property
    def flanges(self) -> tuple[float, float]:
        """Positions ``(-gap_lower, +gap_upper)`` of the lower and the upper flange (``-inf``/``inf``: absent)."""
        return -self.gap_lower, self.gap_upper

    @property
    def symmetric(self) -> bool:
        """True for the paper's guide: both flanges at distance 1 (``gap_lower == gap_upper == 1``)."""
        return self.gap_lower == 1.0 and self.gap_upper == 1.0

    @property
    def constant_forcing(self) -> bool:
        """True when the forcing does not depend on time (every term has zero amplitude or frequency)."""
        return all(F == 0.0 or Om == 0.0 for F, Om, _ in self.terms)

    def unsupported(self) -> list[str]:
        """Names of the features of this member that lie outside eq. 3 (used in error messages)."""
        out = []
        if self.zeta:
            out.append(f"damping zeta={self.zeta!r}")
        if self.beta_static is not None and self.beta_static != self.beta:
            out.append(f"static friction beta_static={self.beta_static!r} > beta")
        if self.rigid:
            out.append(f"a rigid flange (restitution={self.restitution!r})")
        elif self.exponent != 1.0:
            out.append(f"a power-law flange (exponent={self.exponent!r})")
        if self.harmonics:
            out.append(f"{len(self.harmonics)} extra forcing harmonics")
        if not self.symmetric:
            out.append(f"flanges at gap_lower={self.gap_lower!r}, gap_upper={self.gap_upper!r} (not both 1)")
        return out

    # -- forces, in units of k L -------------------------------------------------------
    def forcing(self, t):
        """External force ``sum_i F_i cos(Omega_i t + phase_i)`` (the run-out, right side of eq. 3)."""
        t = np.asarray(t, dtype=float)
        out = self.F * np.cos(self.Omega * t + self.phase)
        for F, Om, ph in self.harmonics:
            out = out + F * np.cos(Om * t + ph)
        return out

    def forcing_rate(self, t):
        """Time derivative of :meth:`forcing`."""
        t = np.asarray(t, dtype=float)
        out = -self.F * self.Omega * np.sin(self.Omega * t + self.phase)
        for F, Om, ph in self.harmonics:
            out = out - F * Om * np.sin(Om * t + ph)
        return out

    # The scalar forces are those of the transition rule (impactosc._rule): one copy, compiled.
    def _forcing_scalar(self, t: float) -> float:
        from . import _rule  # compiled on first use, not at import

        return _rule.forcing(self._p, t)

    def forcing_rounding(self, t: float) -> float:
        """A bound on the rounding error of the forcing evaluated at ``t`` in double precision.

        ``cos(Omega t + phase)`` inherits the rounding of its argument, which grows with
        ``|Omega t + phase|``; the stick test's tie tolerance must not be smaller than that.
        """
        return sum(4.0 * _EPS * F * (2.0 + abs(Om * t) + abs(ph)) for F, Om, ph in self.terms)

    def flange_penetration(self, x):
        """Penetration ``d = (r X - gap_r)+`` into the flange on the side ``r = sgn X`` (``(|X| - 1)+`` by default)."""
        x = np.asarray(x, dtype=float)
        if self.symmetric:
            return np.maximum(np.abs(x) - 1.0, 0.0)
        return np.maximum(np.where(x > 0.0, x - self.gap_upper, -x - self.gap_lower), 0.0)

    def flange_force(self, x):
        """Magnitude of the spring flange force ``K d^p`` at ``x``, in units of ``k L``.

        Zero for a rigid flange, whose force is impulsive (see :meth:`Solution.flange_impulse`).
        """
        d = self.flange_penetration(x)
        if self.rigid:
            return np.zeros_like(d)
        return self.K * (d if self.exponent == 1.0 else d**self.exponent)

    def restoring_force(self, x):
        """Tape spring plus flange spring: ``X + sgn(X) K d^p`` (no flange term for a rigid stop)."""
        x = np.asarray(x, dtype=float)
        return x + np.sign(x) * self.flange_force(x)

    def net_force(self, t, x):
        """Net non-friction force at rest ``f_net = forcing(t) - X - sgn(X) K d^p``.

        It decides the Filippov stick test at ``X' = 0`` (where the damping term vanishes):
        the mass sticks when ``|f_net| <= beta_s`` and otherwise slips towards ``f_net``.
        It includes the flange spring, so a mass at rest inside a flange is tested against
        the spring's push.
        """
        return self.forcing(t) - self.restoring_force(x)

    def _spring_scalar(self, x: float) -> float:
        """Restoring force ``X + sgn(X) K d^p`` at a scalar ``x`` (the engine's hot path)."""
        from . import _rule  # compiled on first use, not at import

        return _rule.spring(self._p, x)

    def _net_force_scalar(self, t: float, x: float) -> float:
        from . import _rule  # compiled on first use, not at import

        return _rule.net_force(self._p, t, x)

    def _region_force_scalar(self, x: float, region: int) -> float:
        """Flange force magnitude ``K d^p`` of the spring of ``region`` (0 free or rigid).

        Unlike :meth:`flange_force` it is not clipped at ``d = 0``: inside a piece of a flange
        region the penetration is ``region * x - 1`` as integrated (a power of a negative
        rounding residue is taken as 0).
        """
        from . import _rule  # compiled on first use, not at import

        return _rule.region_force(self._p, x, region)

    def _accel_scalar(self, t: float, x: float, v: float, region: int, motion: int) -> float:
        """:meth:`acceleration` at scalars: the vector field of a slipping mode."""
        from . import _rule  # compiled on first use, not at import

        return _rule.accel(self._p, t, x, v, region, motion)

    # -- the vector field of every mode (one definition for backends and dynamics) -------
    def acceleration(self, t, x, v, region: int, motion: int):
        """``V'`` in mode ``(region, motion)``: zero when stuck, else eq. 3 with its family terms.

        ``f_net - 2 zeta V - beta motion`` with the flange spring of ``region`` (the spring
        law acts only in a flange region; a rigid flange has no smooth force).
        """
        if motion == 0:
            return np.zeros(np.broadcast(np.asarray(t), np.asarray(x), np.asarray(v)).shape)[()]
        x = np.asarray(x, dtype=float)
        f = self.forcing(t) - x
        if region and not self.rigid:
            d = region * x - self.gap(region)
            f = f - region * self.K * (d if self.exponent == 1.0 else np.abs(d) ** self.exponent * np.sign(d))
        return f - 2.0 * self.zeta * np.asarray(v, dtype=float) - self.beta * motion

    def vector_field(self, t, x, v, region: int, motion: int):
        """``(X', V')`` in mode ``(region, motion)``."""
        if motion == 0:
            zero = self.acceleration(t, x, v, region, motion)
            return zero, zero
        return np.asarray(v, dtype=float)[()], self.acceleration(t, x, v, region, motion)

    def jacobian(self, t: float, x: float, v: float, region: int, motion: int) -> np.ndarray:
        """``d(X', V') / d(X, V)`` in mode ``(region, motion)`` (2x2; zero when stuck)."""
        if motion == 0:
            return np.zeros((2, 2))
        dadx = -1.0
        if region and not self.rigid:
            d = max(region * x - self.gap(region), 0.0)
            dadx -= self.K * (1.0 if self.exponent == 1.0 else self.exponent * d ** (self.exponent - 1.0))
        return np.array([[0.0, 1.0], [dadx, -2.0 * self.zeta]])

    def wall_force_integrals(self, side: int, t0: float, t1: float) -> tuple[float, float, float]:
        """Force of a rigid flange on a mass resting against it over ``[t0, t1]``.

        The wall takes the push ``P(t) = max(side * f_net(t, side), 0)``; a pull away that
        friction holds leaves it unloaded. Returns ``(int P dt, int P^2 dt, max P)``. The
        roots of ``side * f_net`` are bracketed on a grid finer than a quarter period of the
        fastest harmonic and refined to an ulp, so each integral is over a smooth stretch
        (composite 16-node Gauss-Legendre, error far below rounding). The maximum is taken
        at the ends and at the maxima of the push inside (roots of the forcing rate, refined
        the same way), not at the quadrature nodes. Compiled, with the exact backend's
        compiled loop (``impactosc.model._wall.wall_force_integrals``).
        """
        from ._wall import wall_force_integrals

        return wall_force_integrals(self._p, int(side), float(t0), float(t1))

    # -- energy -------------------------------------------------------------------------
    def flange_potential(self, x):
        """Potential energy of the flange spring ``K d^(p+1) / (p+1)`` (0 for a rigid flange)."""
        d = self.flange_penetration(x)
        if self.rigid:
            return np.zeros_like(d)
        p = self.exponent
        return self.K * d ** (p + 1.0) / (p + 1.0)

    def energy(self, x, v):
        """Mechanical energy ``V^2/2 + X^2/2 + K d^(p+1)/(p+1)``.

        Its balance over a run (:meth:`Solution.energy_balance`) is
        ``E(b) - E(a) = W_forcing - beta path - 2 zeta int V^2 - sum (1 - e^2) V_impact^2 / 2``.
        """
        x = np.asarray(x, dtype=float)
        v = np.asarray(v, dtype=float)
        return 0.5 * v * v + 0.5 * x * x + self.flange_potential(x)

    @property
    def contact_frequency(self) -> float:
        """Angular frequency ``sqrt(1 + K)`` of the oscillation while a linear flange is compressed."""
        return math.sqrt(1.0 + self.K)

    def mirrored(self) -> Oscillator:
        """The same oscillator with every forcing term shifted by pi: ``X -> -X`` maps solutions."""
        from dataclasses import replace

        return replace(self, phase=self.phase + math.pi,
                       harmonics=tuple((F, Om, ph + math.pi) for F, Om, ph in self.harmonics),
                       gap_lower=self.gap_upper, gap_upper=self.gap_lower)


_EPS = 2.0**-52
