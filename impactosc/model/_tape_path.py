"""A tape path of several guides in SI units, as a linear chain with flanges and friction.

:class:`TapePath` generalises :class:`~impactosc.model.TapeDrive` (one guide, the paper's
section 5) to a path of guides or rollers along the tape, each with its flanges, clearance,
wrap angle and friction, coupled by the free spans of tape between them. It builds a
:class:`~impactosc.model.MechanicalSystem` (one lateral coordinate per guide) from the paper's
equations, taken from :class:`TapeDrive` rather than written again:

* every span's lateral stiffness from eq. 4 (:attr:`TapeDrive.stiffness` of a drive whose
  ``free_length`` is the span), its mass from :attr:`TapeDrive.mass`;
* every guide's normal force and Coulomb friction from eq. 5 (:attr:`TapeDrive.normal_force`,
  :attr:`TapeDrive.friction_force` with the guide's wrap angle and friction);
* the supply reel's frequency and run-out from eq. 1 and Fig. 6 (:attr:`TapeDrive.omega_r`,
  :attr:`TapeDrive.runout`, the run-out harmonics).

The system is nondimensional, with the scales of the first guide (its clearance, the
stiffness of the span from the pack to it, its mass): for a one-guide path these are
exactly :class:`TapeDrive`'s scales and the system is
``MechanicalSystem.from_oscillator(drive.oscillator())``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass

import numpy as np

from .._util import validation as _v
from ._guide import GUIDE_FIELDS, Guide, guide_tuple
from ._mechanical import Contact, Friction, MechanicalSystem
from ._tape import TapeDrive
from ._tape_path_file import parse_path, path_dict, read_path_file, set_parameter

__all__ = ["Guide", "TapePath", "GUIDE_FIELDS"]


@dataclass(frozen=True, slots=True)
class TapePath:
    """The tape's lateral motion along a path of guides, in SI units (a chain; paper eq. 1, 4, 5, Fig. 6).

    The coordinate ``q_i`` is the lateral position of the tape edge at guide ``i`` relative to
    the guide (its rest position unloaded is 0, positive towards the upper flange). Between
    supports -- the point where the tape leaves the pack, the guides in order, and optionally
    a fixed support after the last guide -- each free span of length ``l`` is a lateral spring
    of eq. 4, ``k = 48 E I / l^3`` (:attr:`TapeDrive.stiffness`). The second moment of area
    ``I`` is the drive's ``bending`` reading, by default in-plane ``I = h w^3 / 12``: the tape
    moving sideways bends in its own plane, about the axis through its thickness, the reading
    :class:`TapeDrive` uses and the one under which its single guide is the paper's model. The
    centrally loaded beam of eq. 4 is kept for every span so that one span is exactly the
    paper's spring; a modal model of the tensioned, axially moving tape (a beam over the guides,
    where tension stiffens the spans and gyroscopic terms enter ``C``) is a later refinement.

    Masses: a span whose other end is a prescribed support (the pack, the fixed end) is lumped
    wholly on its guide, as eq. 2 lumps the paper's free span (``m = rho w h l``); a span
    between two guides is shared half and half. Damping: every mode of the chain gets the
    drive's ``damping_ratio`` (modal damping, ``2 zeta sqrt(k m)`` for one guide).

    Forcing: the supply reel's run-out (Fig. 6 at the drive's pack diameter, with its
    harmonics) moves the pack end of the first span sideways by
    ``u_p(t) = runout cos(omega_r t + phase) + ...`` (eq. 1), a force ``k_0 u_p(t)`` on the first
    guide through the first span's stiffness (the paper's ``F_a = runout k``). A roller with
    run-out moves its flanges by ``a cos(2 V t / d + phi)``: the coordinate is then measured from
    the moving flanges (so contacts and friction act on it unchanged), and the roller's motion
    enters as the harmonic forces ``-(M u'' + C u' + K u)``.

    Friction at guide ``i``: ``mu_i N_i`` with ``N_i = 2 T sin(theta_i / 2)`` (eq. 5); the tension
    is the drive's, the same along the path (its rise over the wraps is neglected).

    Parameters
    ----------
    drive : TapeDrive
        The tape (width, thickness, modulus, density, bending reading), the reel and operating
        point (speed, tension, pack diameter, run-out law and harmonics, damping ratio), and
        the default of every guide field. Its ``free_length`` is not used: the spans are the
        distances between the positions.
    guides : sequence of Guide
        At least one, in increasing ``position``.
    end_span : float or None
        Length in m of a free span from the last guide to a fixed lateral support (a take-up
        reel without run-out, a head with no clearance); ``None`` (default): none.

    Raises
    ------
    TypeError, ValueError
        Naming the field (``guides[i].<field>``, ``end_span``), the rule and the value.

    Examples
    --------
    >>> from impactosc.model import Guide, TapeDrive, TapePath
    >>> drive = TapeDrive(clearance=50e-6)
    >>> path = TapePath(drive, [Guide(0.01), Guide(0.03, wrap_angle=90.0), Guide(0.05)], end_span=0.02)
    >>> system = path.mechanical_system()
    >>> system.n, len(system.contacts), len(system.friction)
    (3, 6, 3)
    >>> t_end = path.seconds_to_time(1e-3)   # nondimensional time of 1 ms

    A path from a path file, run for a millisecond, and where contact starts at its second
    guide (the tools of :mod:`impactosc.sweeps`; ``impactosc path FILE`` on the command line):

    >>> from importlib.resources import files
    >>> from impactosc.sweeps import critical_clearance, simulate_path
    >>> two = TapePath.from_file(files("impactosc.cli") / "paths" / "two-guides.toml")
    >>> run = simulate_path(two, 1e-3)
    >>> run.mean_flange_force().shape, run.status        # N per guide
    ((2,), 0)
    >>> round(critical_clearance(two, 1) * 1e6, 1)       # um: its 40 um clearance is touched
    52.3
    """

    drive: TapeDrive
    guides: tuple
    end_span: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.drive, TapeDrive):
            raise TypeError(f"drive must be a TapeDrive, got {self.drive!r} of type {type(self.drive).__name__}")
        object.__setattr__(self, "guides", guide_tuple(self.guides))
        if self.end_span is not None:
            object.__setattr__(self, "end_span", _v.positive("end_span", self.end_span))
        for i in range(len(self.guides)):
            self.guide_drive(i)  # validates the guide's fields as TapeDrive fields
        for j, length in enumerate(self.span_lengths):
            self._span_drive(j, length)

    @classmethod
    def from_drive(cls, drive: TapeDrive) -> TapePath:
        """The paper's single guide as a path: one guide at ``drive.free_length`` from the pack.

        Its :meth:`mechanical_system` is ``MechanicalSystem.from_oscillator(drive.oscillator())``.

        Examples
        --------
        >>> from impactosc.model import TapeDrive, TapePath
        >>> path = TapePath.from_drive(TapeDrive())
        >>> path.guides[0].position
        0.01
        """
        return cls(drive, (Guide(drive.free_length),))

    @classmethod
    def from_dict(cls, data, *, source: str = "path") -> TapePath:
        """A path from its dict form (a path file's tables: ``drive``, ``guides``, ``end_span``).

        The layout is that of a path file (``impactosc path --example two-guides`` prints one): a
        ``drive`` table of :class:`TapeDrive` fields, a list ``guides`` of tables of
        :class:`Guide` fields (``position`` required), an optional ``end_span`` and ``format``.
        Errors start with ``source`` and name the key (``guides[1].clearance``...).

        Examples
        --------
        >>> from impactosc.model import TapePath
        >>> path = TapePath.from_dict({"drive": {"clearance": 50e-6, "friction": 0.0},
        ...                            "guides": [{"position": 0.02}, {"position": 0.05, "clearance": 30e-6}],
        ...                            "end_span": 0.03})
        >>> path.n, path.guide_drive(1).clearance
        (2, 3e-05)
        >>> TapePath.from_dict(path.to_dict()) == path
        True
        """
        drive, guides, end_span = parse_path(data, source=source)
        try:
            return cls(drive, guides, end_span=end_span)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{source}: {exc}") from None

    @classmethod
    def from_file(cls, file) -> TapePath:
        """A path from a path file (``.toml`` or ``.json``; the layout of :meth:`from_dict`).

        A file's ``run`` and ``output`` tables (read by ``impactosc path``) are allowed and not
        read here (:meth:`read_file` returns them). Errors name the file and the key.

        Examples
        --------
        >>> from importlib.resources import files
        >>> from impactosc.model import TapePath
        >>> path = TapePath.from_file(files("impactosc.cli") / "paths" / "four-guides.toml")
        >>> path.n
        4
        """
        return cls.read_file(file)[0]

    @classmethod
    def read_file(cls, file) -> tuple[TapePath, dict]:
        """A path file's path and all its tables (the ``run`` and ``output`` tables included, unchecked)."""
        source = f"path file {str(file)!r}"
        data = read_path_file(file)
        drive, guides, end_span = parse_path(data, source=source, extra=("run", "output"))
        try:
            return cls(drive, guides, end_span=end_span), data
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{source}: {exc}") from None

    def to_dict(self) -> dict:
        """The dict form of :meth:`from_dict` (every drive field; each guide's own fields), TOML/JSON-ready."""
        return path_dict(self.drive, self.guides, self.end_span)

    def with_parameter(self, key: str, value) -> TapePath:
        """A copy with one SI parameter set, by its sweep name.

        ``key``: a numeric :class:`TapeDrive` field (``"speed"``, ``"tension"``,
        ``"pack_diameter"``, ``"clearance"`` -- the drive's, so of every guide that does not set
        its own), ``"end_span"``, or ``"guide<i>_<field>"`` for guide ``i``'s own field
        (``"guide1_clearance"``, ``"guide0_guide_offset"``, ``"guide2_position"``...).

        Examples
        --------
        >>> from impactosc.model import Guide, TapeDrive, TapePath
        >>> path = TapePath(TapeDrive(), [Guide(0.02), Guide(0.05)])
        >>> path.with_parameter("guide1_clearance", 40e-6).guide_drive(1).clearance
        4e-05
        >>> path.with_parameter("speed", 8.0).drive.speed
        8.0
        """
        return TapePath.from_dict(set_parameter(self.to_dict(), key, value), source=f"{key} = {value!r}")

    def replace(self, **changes) -> TapePath:
        """A copy with some fields changed, validated again (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    # -- the pieces of the chain ---------------------------------------------------------
    def guide_drive(self, i: int) -> TapeDrive:
        """The :class:`TapeDrive` of guide ``i``: the path's drive with the guide's own fields."""
        g = self.guides[i]
        try:
            return self.drive.replace(**g.overrides())
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"guides[{i}]: {exc}") from None

    def _span_drive(self, j: int, length: float) -> TapeDrive:
        try:
            return self.drive.replace(free_length=length)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"span {j} ({length!r} m): {exc}") from None

    @property
    def n(self) -> int:
        """Number of guides (coordinates of the chain)."""
        return len(self.guides)

    @property
    def span_lengths(self) -> tuple[float, ...]:
        """Lengths in m of the free spans: pack to guide 0, guide to guide, and the end span if any."""
        pos = [g.position for g in self.guides]
        spans = [pos[0]] + [b - a for a, b in zip(pos[:-1], pos[1:], strict=True)]
        if self.end_span is not None:
            spans.append(self.end_span)
        return tuple(spans)

    @property
    def span_stiffnesses(self) -> np.ndarray:
        """Lateral stiffness of every span in N/m (eq. 4, :attr:`TapeDrive.stiffness`)."""
        return np.array([self._span_drive(j, s).stiffness for j, s in enumerate(self.span_lengths)])

    @property
    def span_masses(self) -> np.ndarray:
        """Mass of every span in kg (:attr:`TapeDrive.mass`, ``rho w h l``)."""
        return np.array([self._span_drive(j, s).mass for j, s in enumerate(self.span_lengths)])

    def _spans(self):
        """``(span index, guide at its start or None, guide at its end or None)`` for every span."""
        n = self.n
        out = [(0, None, 0)] + [(j, j - 1, j) for j in range(1, n)]
        if self.end_span is not None:
            out.append((n, n - 1, None))
        return out

    @property
    def mass_matrix(self) -> np.ndarray:
        """Lumped masses in kg on the diagonal (an end span wholly on its guide, a shared span halved)."""
        m = np.zeros(self.n)
        masses = self.span_masses
        for j, a, b in self._spans():
            if a is None or b is None:
                m[a if b is None else b] += masses[j]
            else:
                m[a] += 0.5 * masses[j]
                m[b] += 0.5 * masses[j]
        return np.diag(m)

    @property
    def stiffness_matrix(self) -> np.ndarray:
        """The chain's stiffness matrix in N/m: each span a spring between its guides (or to ground)."""
        K = np.zeros((self.n, self.n))
        ks = self.span_stiffnesses
        for j, a, b in self._spans():
            for i in (a, b):
                if i is not None:
                    K[i, i] += ks[j]
            if a is not None and b is not None:
                K[a, b] -= ks[j]
                K[b, a] -= ks[j]
        return K

    @property
    def damping_matrix(self) -> np.ndarray:
        """Modal damping in N s/m: every mode of ``(M, K)`` with the drive's ``damping_ratio``."""
        return self._damping(self.mass_matrix / self.mass_scale, self.stiffness_matrix / self.stiffness_scale) \
            * (self.mass_scale * self.omega_scale)

    def _damping(self, M: np.ndarray, K: np.ndarray) -> np.ndarray:
        """``2 zeta M^1/2 (M^-1/2 K M^-1/2)^1/2 M^1/2`` for a diagonal ``M`` (``2 zeta`` for ``M = K = 1``)."""
        zeta = self.drive.damping_ratio
        if zeta == 0.0:
            return np.zeros_like(M)
        sqm = np.sqrt(np.diag(M))
        w2, phi = np.linalg.eigh(K / sqm[:, None] / sqm[None, :])
        root = (phi * (2.0 * zeta * np.sqrt(np.maximum(w2, 0.0)))) @ phi.T
        return sqm[:, None] * root * sqm[None, :]

    def flange_stiffness(self, i: int) -> float:
        """``k0`` in N/m of guide ``i``'s spring flange (its own, or ``stiffness_ratio`` times ``K_ii``)."""
        gd = self.guide_drive(i)
        if gd.flange_stiffness is not None:
            return gd.flange_stiffness
        return gd.stiffness_ratio * float(self.stiffness_matrix[i, i])

    # -- scales --------------------------------------------------------------------------
    @property
    def length_scale(self) -> float:
        """Length scale in m: the first guide's clearance (``q_SI = length_scale * q``)."""
        return self.guide_drive(0).clearance

    @property
    def stiffness_scale(self) -> float:
        """Stiffness scale in N/m: the first span's (eq. 4)."""
        return float(self.span_stiffnesses[0])

    @property
    def mass_scale(self) -> float:
        """Mass scale in kg: the first guide's lumped mass."""
        return float(self.mass_matrix[0, 0])

    @property
    def omega_scale(self) -> float:
        """``sqrt(stiffness_scale / mass_scale)`` in rad/s (the one-guide ``omega_n``)."""
        return math.sqrt(self.stiffness_scale / self.mass_scale)

    @property
    def time_scale(self) -> float:
        """Time scale in s: ``t_SI = time_scale * t``."""
        return 1.0 / self.omega_scale

    @property
    def force_scale(self) -> float:
        """Force scale in N: ``stiffness_scale * length_scale`` (``k L`` of the one-guide path)."""
        return self.stiffness_scale * self.length_scale

    @property
    def impulse_scale(self) -> float:
        """Impulse scale in N s: ``force_scale * time_scale``."""
        return self.force_scale * self.time_scale

    def seconds_to_time(self, t_s):
        """Nondimensional time for ``t_s`` seconds (float or array)."""
        if isinstance(t_s, numbers.Real) and not isinstance(t_s, bool):
            return _v.real("t_s", t_s) / self.time_scale
        return np.asarray(t_s, dtype=float) / self.time_scale

    def time_to_seconds(self, t):
        """Seconds for nondimensional time ``t`` (float or array)."""
        if isinstance(t, numbers.Real) and not isinstance(t, bool):
            return _v.real("t", t) * self.time_scale
        return np.asarray(t, dtype=float) * self.time_scale

    # -- the model -----------------------------------------------------------------------
    def pack_runout(self, t_s, phase: float = 0.0) -> np.ndarray:
        """Lateral displacement in m of the tape where it leaves the pack at ``t_s`` seconds (eq. 1, Fig. 6)."""
        d = self.drive
        t = np.asarray(t_s, dtype=float)
        u = np.cos(d.omega_r * t + phase)
        for n, frac, ph in d.runout_harmonics:
            u = u + frac * np.cos(n * d.omega_r * t + n * phase + ph)
        return d.runout * u

    def roller_runout(self, t_s) -> np.ndarray:
        """Lateral displacement in m of every guide's flanges at ``t_s`` seconds: shape ``(len(t_s), n)``."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        out = np.zeros((t.size, self.n))
        for i, g in enumerate(self.guides):
            if g.roller_runout > 0.0:
                w = 2.0 * self.drive.speed / float(g.roller_diameter)  # type: ignore[arg-type]
                out[:, i] = g.roller_runout * np.cos(w * t + g.roller_phase)
        return out

    def _harmonics(self, M: np.ndarray, C: np.ndarray, K: np.ndarray, phase: float) -> list:
        """The nondimensional harmonic forces: the pack run-out on guide 0, the rollers' on their rows."""
        d = self.drive
        fs, ws = self.force_scale, self.omega_scale
        e0 = np.zeros(self.n)
        e0[0] = 1.0
        pack = self.span_stiffnesses[0] * d.runout / fs  # F_a / (k L) of the paper
        out = [(pack * e0, d.omega_r / ws, phase)]
        out += [(frac * pack * e0, n * d.omega_r / ws, n * phase + ph) for n, frac, ph in d.runout_harmonics]
        for i, g in enumerate(self.guides):
            if g.roller_runout == 0.0:
                continue
            w = 2.0 * d.speed / float(g.roller_diameter)  # type: ignore[arg-type]
            a = g.roller_runout
            # q = r + u, u = a cos(w t + phi) e_i: -(M u'' + K u) in phase, -C u' a quarter turn behind.
            out.append(((M[:, i] * w**2 - K[:, i]) * a / fs, w / ws, g.roller_phase))
            if np.any(C[:, i] != 0.0):
                out.append((C[:, i] * a * w / fs, w / ws, g.roller_phase - 0.5 * math.pi))
        return out

    def _guide_laws(self, i: int, Kii: float) -> tuple[list[Contact], list[Friction]]:
        """Guide ``i``'s flanges as contacts on ``q_i`` and its friction (eq. 5), nondimensional."""
        gd = self.guide_drive(i)
        L, fs = self.length_scale, self.force_scale
        e = np.zeros(self.n)
        e[i] = 1.0
        contacts = []
        for side, gap, present in ((1.0, gd.clearance - gd.guide_offset, gd.flange_sides != "lower"),
                                   (-1.0, gd.clearance + gd.guide_offset, gd.flange_sides != "upper")):
            if not present:
                continue
            if gd.flange == "rigid":
                contacts.append(Contact(side * e, gap / L, law="rigid", restitution=gd.restitution))
            else:
                p = gd.flange_exponent
                k0 = gd.flange_stiffness if gd.flange_stiffness is not None else \
                    gd.stiffness_ratio * Kii * gd.clearance ** (1.0 - p)
                contacts.append(Contact(side * e, gap / L, law="spring", stiffness=k0 * L**p / fs, exponent=p))
        friction = []
        if gd.friction > 0.0:
            mus = gd.static_friction if gd.static_friction is not None else gd.friction
            friction.append(Friction(i, gd.friction_force / fs, mus * gd.normal_force / fs))
        return contacts, friction

    def mechanical_system(self, phase: float = 0.0, *, leave_out_flanges=()) -> MechanicalSystem:
        """The chain as a nondimensional :class:`MechanicalSystem` (scales: :attr:`length_scale`, ...).

        ``M``, ``C``, ``K`` over :attr:`mass_scale`, ``mass_scale * omega_scale`` and
        :attr:`stiffness_scale`; forces over :attr:`force_scale`; frequencies over
        :attr:`omega_scale`. Contacts ``2 i`` and ``2 i + 1`` (when the guide has both flanges)
        are guide ``i``'s upper and lower flanges; see :meth:`contact_guides`.

        Parameters
        ----------
        phase : float
            The supply reel's angle at ``t = 0`` in radians (as :meth:`TapeDrive.oscillator`).
        leave_out_flanges : sequence of int
            Guides whose flanges are taken away (their friction stays): the motion a guide's
            flanges would limit, as where contact starts is found. :meth:`contact_guides`
            lists the contacts of the full path only.

        Raises
        ------
        ValueError
            When a guide has a rigid flange that can rest (``restitution < 1``) and friction:
            :class:`MechanicalSystem` refuses the pair (they act along one line).

        Examples
        --------
        >>> from impactosc import simulate_mechanical
        >>> from impactosc.model import Guide, TapeDrive, TapePath
        >>> path = TapePath(TapeDrive(clearance=30e-6, friction=0.0), [Guide(0.01), Guide(0.03)])
        >>> sol = simulate_mechanical(path.mechanical_system(), path.seconds_to_time(2e-3), [0, 0], [0, 0])
        >>> sol.status
        0
        """
        phase = _v.real("phase", phase)
        ms, ks = self.mass_scale, self.stiffness_scale
        M, K = self.mass_matrix, self.stiffness_matrix
        c_nd = self._damping(M / ms, K / ks)
        C = c_nd * (ms * self.omega_scale)
        contacts: list[Contact] = []
        friction: list[Friction] = []
        left_out = {self.check_guide(i, "leave_out_flanges") for i in leave_out_flanges}
        for i in range(self.n):
            c, f = self._guide_laws(i, float(K[i, i]))
            contacts += [] if i in left_out else c
            friction += f
        try:
            return MechanicalSystem(M=M / ms, C=c_nd, K=K / ks,
                                    harmonics=self._harmonics(M, C, K, phase), contacts=contacts,
                                    friction=friction)
        except ValueError as exc:
            raise ValueError(f"TapePath: {exc} (contacts 2i, 2i+1 and friction on coordinate i belong to "
                             "guides[i])") from None

    def check_guide(self, i, name: str = "guide") -> int:
        """``i`` as the index of one of the path's guides; a ``TypeError``/``ValueError`` naming ``name``."""
        g = _v.integer(name, i, minimum=0)
        if g >= self.n:
            raise ValueError(f"{name} must name guides 0 to {self.n - 1} (the path's guides), got {i!r}")
        return g

    def contact_guides(self) -> list[tuple[int, int]]:
        """``(guide, side)`` of every contact of :meth:`mechanical_system`, in order (side +1 upper, -1 lower)."""
        out = []
        for i in range(self.n):
            sides = self.guide_drive(i).flange_sides
            if sides != "lower":
                out.append((i, 1))
            if sides != "upper":
                out.append((i, -1))
        return out

    def quasi_static_deflection(self) -> np.ndarray:
        """Amplitude in m of each guide's quasi-static response to the pack run-out: ``K^-1 k_0 runout e_0``.

        The flanges and friction left out; the run-out exceeds a guide's clearance where this
        does (a first estimate of where contact starts, exact when the reel turns slowly).
        """
        f = np.zeros(self.n)
        f[0] = self.span_stiffnesses[0] * self.drive.runout
        return np.linalg.solve(self.stiffness_matrix, f)
