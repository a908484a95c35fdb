"""Linear mechanical systems of many degrees of freedom with contacts and Coulomb friction.

Equation of motion between events, for the coordinates ``q`` (``n`` of them)::

    M q'' + C q' + K q = sum_h f_h cos(omega_h t + phi_h) + sum_c F_c + sum_j R_j e_j

* ``M`` symmetric positive definite; ``C`` any real matrix (its skew part is gyroscopic and
  does no work, its symmetric part dissipates); ``K`` any real symmetric matrix.
* Harmonics: a force vector ``f_h``, a frequency ``omega_h >= 0`` (0: a constant force) and a
  phase ``phi_h``.
* Contacts: a gap ``g_c(q) = n_c . q - gap_c`` that is linear in the coordinates and negative
  while the contact is open (``gap_c > 0``: ``q = 0`` is open). Two laws:

  - ``"spring"``: while ``g_c > 0`` the force ``F_c = -k_c g_c^p n_c`` (``p = 1``: linear,
    the law the exact backend solves in closed form);
  - ``"rigid"``: ``g_c <= 0`` always; at ``g_c = 0`` with ``n_c . q' > 0`` an impact with Newton
    restitution ``e_c`` changes the velocity along ``M^-1 n_c``:
    ``q'+ = q'- - (1 + e_c) (n_c . q'-) M^-1 n_c / (n_c . M^-1 n_c)``, so ``n_c . q'+ = -e_c n_c . q'-``
    and the kinetic energy drops by ``(1 - e_c^2) (n_c . q'-)^2 / (2 n_c . M^-1 n_c)``. When the
    rebounds accumulate (chatter) the coordinates come to rest on the stop: the constraint
    ``g_c = 0`` holds with a contact force ``-lambda_c n_c``, ``lambda_c >= 0``, until
    ``lambda_c`` falls to zero (lift-off), as in the one-degree-of-freedom engine. An elastic
    stop (``e_c = 1``) comes to rest too once its rebounds are below the rounding of the gap
    (damping, or a slow approach under a static push, leaves them that small), unless a
    friction coordinate lies along its normal (:attr:`MechanicalSystem.can_rest`).

* Coulomb friction on a coordinate ``j``: ``R_j = -mu_k sgn(q_j')`` while it slips; it sticks
  (``q_j' = 0`` held) when its velocity reaches zero and the force that holds it,
  ``|R_j| <= mu_s`` (the Filippov stick test), and slips again when that force rises to
  ``mu_s``.

Coupled constraints
-------------------
A stuck coordinate and a resting stop are constraints ``g . q'' = 0`` (``g = e_j`` or ``n_c``),
held by forces along their ``g``. All the active ones are solved together:
``mu = (G M^-1 G^T)^-1 G M^-1 r`` (``r`` the other forces), so stick and lift-off tests that
couple through ``M^-1`` stay consistent; when one constraint sticks or lifts off, the others'
forces are recomputed and any that now breaks its bound switches at the same instant (an
active-set iteration of the small complementarity problem, which gives up with a message if
it does not settle). Constraints that can be active together must be independent:
:class:`MechanicalSystem` refuses a friction coordinate ``j`` together with a rigid stop that
can rest (``e < 1``) and whose normal is parallel to ``e_j``, and two such stops with parallel
normals on the same side, naming them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .._util import validation as _v

__all__ = ["MechanicalSystem", "Contact", "Friction", "CONTACT_LAWS"]

#: The contact laws: an elastic spring ``k d^p`` on the penetration, or a rigid stop with restitution.
CONTACT_LAWS = ("spring", "rigid")


def _vector(name: str, value, n: int | None = None) -> np.ndarray:
    """``value`` as a finite float vector (of length ``n`` when given), or a clear error."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a vector of real numbers, got {value!r}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty vector (1-D), got shape {arr.shape}")
    if n is not None and arr.size != n:
        raise ValueError(f"{name} must have one entry per coordinate ({n}), got {arr.size}: {value!r}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()!r}")
    arr.setflags(write=False)
    return arr


def _matrix(name: str, value, n: int) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a {n}x{n} matrix of real numbers, got {value!r}") from None
    if arr.ndim == 0:
        arr = arr * np.eye(n)
    if arr.shape != (n, n):
        raise ValueError(f"{name} must be {n}x{n} (n = {n} coordinates, from M), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()!r}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class Contact:
    """A contact whose gap ``normal @ q - gap`` is linear in the coordinates.

    Parameters
    ----------
    normal : array_like
        The vector ``n`` (one entry per coordinate, not all zero); the contact closes when
        ``n . q`` rises to ``gap``.
    gap : float
        The clearance at ``q = 0`` (> 0).
    law : {"spring", "rigid"}
        ``"spring"``: the force ``-stiffness d^exponent n`` on the penetration
        ``d = n . q - gap > 0``; ``"rigid"``: an impact with Newton restitution.
    stiffness : float
        Spring constant ``k > 0`` (``"spring"`` only).
    exponent : float
        ``p >= 1`` of the spring law (1: linear, the exact backend's case; 1.5: Hertz).
    restitution : float
        Newton's coefficient ``e`` in ``[0, 1]`` (``"rigid"`` only).

    Examples
    --------
    >>> from impactosc.model import Contact
    >>> Contact([1.0, -1.0], 0.5, law="rigid", restitution=0.8).law
    'rigid'
    """

    normal: np.ndarray
    gap: float
    law: str = "spring"
    stiffness: float = 0.0
    exponent: float = 1.0
    restitution: float = 1.0

    def __post_init__(self) -> None:
        normal = _vector("Contact.normal", self.normal)
        if not np.any(normal != 0.0):
            raise ValueError(f"Contact.normal must not be the zero vector, got {normal.tolist()!r}")
        object.__setattr__(self, "normal", normal)
        object.__setattr__(self, "gap", _v.positive("Contact.gap (clearance at q = 0)", self.gap))
        _v.choice("Contact.law", self.law, CONTACT_LAWS)
        if self.law == "spring":
            object.__setattr__(self, "stiffness", _v.positive("Contact.stiffness of a spring contact",
                                                              self.stiffness))
            p = _v.real("Contact.exponent", self.exponent)
            if not p >= 1.0:
                raise ValueError(f"Contact.exponent must be >= 1 (force k d^p), got {p!r}")
            object.__setattr__(self, "exponent", p)
        else:
            e = _v.real("Contact.restitution", self.restitution)
            if not 0.0 <= e <= 1.0:
                raise ValueError(f"Contact.restitution must be in [0, 1] (Newton's coefficient), got {e!r}")
            object.__setattr__(self, "restitution", e)

    @property
    def rigid(self) -> bool:
        """True for a rigid stop."""
        return self.law == "rigid"


@dataclass(frozen=True)
class Friction:
    """Coulomb friction on one coordinate: ``kinetic`` while it slips, ``static`` for the stick test.

    Parameters
    ----------
    coordinate : int
        Index of the coordinate ``q_j`` it acts on.
    kinetic : float
        Kinetic level ``mu_k > 0`` (a force).
    static : float or None
        Static level ``mu_s >= mu_k``; ``None`` means equal to ``kinetic``.

    Examples
    --------
    >>> from impactosc.model import Friction
    >>> Friction(0, 0.1).static
    0.1
    """

    coordinate: int
    kinetic: float
    # ``None`` (equal to ``kinetic``) is stored as that float after __post_init__.
    static: float = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        object.__setattr__(self, "coordinate", _v.integer("Friction.coordinate", self.coordinate, minimum=0))
        mu = _v.positive("Friction.kinetic (Coulomb level while slipping)", self.kinetic)
        object.__setattr__(self, "kinetic", mu)
        mus = mu if self.static is None else _v.real("Friction.static", self.static)
        if not mus >= mu:
            raise ValueError(f"Friction.static must be >= Friction.kinetic ({mu!r}), got {mus!r}")
        object.__setattr__(self, "static", mus)


def _harmonics(value, n: int) -> tuple[tuple[np.ndarray, float, float], ...]:
    if isinstance(value, str | bytes) or not hasattr(value, "__iter__"):
        raise TypeError(f"harmonics must be a sequence of (force vector, frequency, phase) triples, got {value!r}")
    out = []
    for i, term in enumerate(value):
        items = tuple(term)
        if len(items) == 2:
            items = (*items, 0.0)
        if len(items) != 3:
            raise ValueError(f"harmonics[{i}] must be a triple (force vector, frequency, phase), got {term!r}")
        out.append((_vector(f"harmonics[{i}] force vector", items[0], n),
                    _v.nonnegative(f"harmonics[{i}] frequency", items[1]),
                    _v.real(f"harmonics[{i}] phase", items[2])))
    return tuple(out)


@dataclass(frozen=True)
class MechanicalSystem:
    """``M q'' + C q' + K q = sum of harmonics``, with contacts and Coulomb friction (see the module docstring).

    Parameters
    ----------
    M : array_like, (n, n)
        Mass matrix, symmetric positive definite.
    C : array_like, (n, n), optional
        Damping and gyroscopic matrix (any real matrix; default zero).
    K : array_like, (n, n), optional
        Stiffness matrix, symmetric (default zero).
    harmonics : sequence of tuple
        The forcing ``sum_h f_h cos(omega_h t + phi_h)``, one ``(f_h, omega_h, phi_h)`` per
        harmonic: a force vector of length ``n``, a frequency ``>= 0`` (0: a constant force)
        and a phase.
    contacts : sequence of :class:`Contact`
    friction : sequence of :class:`Friction`
        At most one per coordinate.

    Raises
    ------
    ValueError
        Naming the field, the rule and the value: a wrong shape, ``M`` not symmetric
        positive definite, ``K`` not symmetric, a contact normal of the wrong length, a
        friction coordinate out of range or repeated, or two constraints that can be
        active together and act along the same line (module docstring).

    Examples
    --------
    Two masses joined by a spring, the second one between two rigid stops:

    >>> import numpy as np
    >>> from impactosc.model import Contact, MechanicalSystem
    >>> system = MechanicalSystem(M=np.eye(2), K=[[2.0, -1.0], [-1.0, 1.0]],
    ...                           harmonics=[([1.0, 0.0], 0.9, 0.0)],
    ...                           contacts=[Contact([0.0, 1.0], 1.0, law="rigid", restitution=0.7),
    ...                                     Contact([0.0, -1.0], 1.0, law="rigid", restitution=0.7)])
    >>> system.n, len(system.contacts)
    (2, 2)
    >>> float(system.energy([0.0, 1.0], [0.0, 0.0]))
    0.5
    """

    M: np.ndarray
    # ``None`` is accepted (a zero matrix) and stored as one: an array after __post_init__.
    C: np.ndarray = None  # type: ignore[assignment]
    K: np.ndarray = None  # type: ignore[assignment]
    # Sequences, stored as tuples after __post_init__.
    harmonics: Sequence = ()
    contacts: Sequence[Contact] = ()
    friction: Sequence[Friction] = ()
    _minv: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        try:
            m = np.array(self.M, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"M must be a square matrix of real numbers, got {self.M!r}") from None
        if m.ndim != 2 or m.shape[0] != m.shape[1] or m.shape[0] == 0:
            raise ValueError(f"M must be a square n x n matrix, got shape {m.shape}")
        n = m.shape[0]
        M = _matrix("M", m, n)
        if not np.allclose(M, M.T, rtol=1e-13, atol=0.0):
            raise ValueError(f"M must be symmetric, got {M.tolist()!r}")
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            raise ValueError(f"M must be positive definite (eigenvalues {np.linalg.eigvalsh(M).tolist()!r})") from None
        C = _matrix("C", np.zeros((n, n)) if self.C is None else self.C, n)
        K = _matrix("K", np.zeros((n, n)) if self.K is None else self.K, n)
        if not np.allclose(K, K.T, rtol=1e-13, atol=0.0):
            raise ValueError(f"K must be symmetric (a stiffness has a potential), got {K.tolist()!r}")
        for name, value in (("M", M), ("C", C), ("K", K)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "harmonics", _harmonics(self.harmonics, n))
        contacts = tuple(self.contacts)
        for i, c in enumerate(contacts):
            if not isinstance(c, Contact):
                raise TypeError(f"contacts[{i}] must be a Contact, got {c!r}")
            if c.normal.size != n:
                raise ValueError(f"contacts[{i}].normal must have one entry per coordinate ({n}), "
                                 f"got {c.normal.size}")
        object.__setattr__(self, "contacts", contacts)
        friction = tuple(self.friction)
        seen: set[int] = set()
        for i, f in enumerate(friction):
            if not isinstance(f, Friction):
                raise TypeError(f"friction[{i}] must be a Friction, got {f!r}")
            if f.coordinate >= n:
                raise ValueError(f"friction[{i}].coordinate must be < n = {n}, got {f.coordinate}")
            if f.coordinate in seen:
                raise ValueError(f"friction[{i}].coordinate {f.coordinate} already has friction (one per coordinate)")
            seen.add(f.coordinate)
        object.__setattr__(self, "friction", friction)
        object.__setattr__(self, "_minv", np.linalg.inv(M))
        self._check_coupling()

    def _constraints(self) -> list[tuple[str, np.ndarray]]:
        """The constraint directions that can hold: stuck coordinates and stops that can rest."""
        out = []
        for i, f in enumerate(self.friction):
            e = np.zeros(self.n)
            e[f.coordinate] = 1.0
            out.append((f"friction[{i}] (coordinate {f.coordinate})", e))
        for i, c in enumerate(self.contacts):
            if c.rigid and c.restitution < 1.0:
                out.append((f"contacts[{i}] (a rigid stop that can rest)", c.normal))
        return out

    @property
    def can_rest(self) -> tuple[bool, ...]:
        """Per contact: True for a rigid stop the coordinates can come to rest on.

        Every rigid stop can, once its rebounds fall below the rounding of its gap, except an
        elastic one (``e = 1``) whose normal lies along a friction coordinate: resting, it would
        be a second constraint on that line (the pair this class refuses for ``e < 1``); such a
        stop keeps its rebounds, as they keep the energy.

        Examples
        --------
        >>> from impactosc.model import Contact, Friction, MechanicalSystem
        >>> stop = Contact([1.0, 0.0], 1.0, law="rigid", restitution=1.0)
        >>> MechanicalSystem(M=np.eye(2), contacts=[stop]).can_rest
        (True,)
        >>> MechanicalSystem(M=np.eye(2), contacts=[stop], friction=[Friction(0, 0.1)]).can_rest
        (False,)
        """
        frictional = [f.coordinate for f in self.friction]
        out = []
        for c in self.contacts:
            if not c.rigid:
                out.append(False)
                continue
            along = np.flatnonzero(c.normal)
            parallel = along.size == 1 and int(along[0]) in frictional
            out.append(c.restitution < 1.0 or not parallel)
        return tuple(out)

    def _check_coupling(self) -> None:
        """Refuse pairs of constraints that can hold together and are parallel (their forces are not unique)."""
        cons = self._constraints()
        for a in range(len(cons)):
            for b in range(a + 1, len(cons)):
                (na, ga), (nb, gb) = cons[a], cons[b]
                cos = float(ga @ gb) / (np.linalg.norm(ga) * np.linalg.norm(gb))
                if abs(cos) < 1.0 - 1e-12:
                    continue
                if "contacts" in na and "contacts" in nb and cos < 0.0:
                    continue  # opposite stops on one line: never in contact together
                raise ValueError(
                    f"{na} and {nb} act along the same line (normals {ga.tolist()!r} and {gb.tolist()!r}): held "
                    "together their forces are not unique; give the stop restitution 1 (it never rests) or move "
                    "the friction to another coordinate")

    @classmethod
    def from_oscillator(cls, osc) -> MechanicalSystem:
        """The one-coordinate system of an :class:`~impactosc.model.Oscillator` (eq. 3 and its family).

        ``M = 1``, ``C = 2 zeta``, ``K = 1``, the harmonics, the flanges as contacts with normals
        ``+1`` (upper, gap ``gap_upper``) and ``-1`` (lower, gap ``gap_lower``), and Coulomb
        friction ``beta`` (static ``beta_s``) on the coordinate when ``beta > 0``.

        Raises
        ------
        ValueError
            For a member with a rigid flange that can rest (``restitution < 1``) and friction:
            its stop and its friction act along the same line, which this class refuses
            (module docstring).

        Examples
        --------
        >>> from impactosc.model import MechanicalSystem, Oscillator
        >>> system = MechanicalSystem.from_oscillator(Oscillator(0.5, 1.1, 0.01, 1e4))
        >>> system.n, [c.normal.tolist() for c in system.contacts]
        (1, [[1.0], [-1.0]])
        """
        contacts = []
        for side, gap in ((1.0, osc.gap_upper), (-1.0, osc.gap_lower)):
            if math.isinf(gap):
                continue
            if osc.flange == "rigid":
                contacts.append(Contact(np.array([side]), gap, law="rigid", restitution=osc.restitution))
            else:
                contacts.append(Contact(np.array([side]), gap, law="spring", stiffness=osc.K, exponent=osc.exponent))
        friction = [Friction(0, osc.beta, osc.beta_s)] if osc.beta > 0.0 else []
        return cls(M=np.eye(1), C=np.full((1, 1), 2.0 * osc.zeta), K=np.eye(1),
                   harmonics=[(np.array([F]), Om, ph) for F, Om, ph in osc.terms], contacts=contacts,
                   friction=friction)

    @property
    def n(self) -> int:
        """Number of coordinates (degrees of freedom)."""
        return int(self.M.shape[0])

    @property
    def minv(self) -> np.ndarray:
        """``M^-1`` (read-only copy)."""
        return self._minv.copy()

    @property
    def linear(self) -> bool:
        """True when every spring contact is linear (``p = 1``): the exact backend's class."""
        return all(c.rigid or c.exponent == 1.0 for c in self.contacts)

    def forcing(self, t) -> np.ndarray:
        """The harmonic force ``sum_h f_h cos(omega_h t + phi_h)`` at time(s) ``t``: shape ``(..., n)``."""
        t = np.asarray(t, dtype=float)
        out = np.zeros((*t.shape, self.n))
        for f, om, ph in self.harmonics:
            out += np.cos(om * t + ph)[..., None] * f
        return out

    def gaps(self, q) -> np.ndarray:
        """``n_c @ q - gap_c`` for every contact (negative: open): shape ``(..., contacts)``."""
        q = np.asarray(q, dtype=float)
        if not self.contacts:
            return np.zeros((*q.shape[:-1], 0))
        normals = np.array([c.normal for c in self.contacts])
        return q @ normals.T - np.array([c.gap for c in self.contacts])

    def contact_forces(self, q) -> np.ndarray:
        """The generalised force of the spring contacts at ``q``: shape of ``q``."""
        q = np.asarray(q, dtype=float)
        out = np.zeros_like(q)
        d = self.gaps(q)
        for i, c in enumerate(self.contacts):
            if not c.rigid:
                pen = np.maximum(d[..., i], 0.0)
                out -= (c.stiffness * pen**c.exponent)[..., None] * c.normal
        return out

    def energy(self, q, v) -> np.ndarray:
        """Kinetic + elastic energy ``v.M v / 2 + q.K q / 2 + sum k d^(p+1) / (p+1)`` (spring contacts)."""
        q = np.asarray(q, dtype=float)
        v = np.asarray(v, dtype=float)
        e = 0.5 * np.einsum("...i,ij,...j->...", v, self.M, v) + 0.5 * np.einsum("...i,ij,...j->...", q, self.K, q)
        d = self.gaps(q)
        for i, c in enumerate(self.contacts):
            if not c.rigid:
                pen = np.maximum(d[..., i], 0.0)
                e = e + c.stiffness * pen ** (c.exponent + 1.0) / (c.exponent + 1.0)
        return e
