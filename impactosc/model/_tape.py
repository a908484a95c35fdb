"""The paper's tape drive in SI units, and its reduction to the nondimensional model.

:class:`TapeDrive` holds the physical parameters of section 5 of the paper (tape, roller,
reel run-out, operating point) and derives from them, with the paper's equations,

* the effective lateral stiffness ``k = 48 E I / l^3`` of the free span (eq. 4),
* the belt-wrap normal force ``N = 2 T sin(theta/2)`` on the roller (eq. 5),
* the reel's rotational frequency ``omega_r = 2 V / D`` (eq. 1),
* the forcing amplitude ``F_a = runout(D) * k`` (Fig. 6 and the text below it),

and finally the four numbers of eq. 3: ``F = F_a/(k L)``, ``Omega = omega_r/omega_n``,
``beta = mu N/(k L)`` and ``K = k0/k`` (:meth:`TapeDrive.oscillator`).

Scales used to go back to SI units: time ``Lambda = omega_n t``, length ``x = L X``,
force ``f = k L * (nondimensional force)``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass

import numpy as np

from .._util import validation as _v
from ._oscillator import Oscillator

__all__ = ["TapeDrive", "BENDING_OPTIONS", "FIELD_UNITS", "NUMERIC_FIELDS"]

#: The flanges a guide can have (:attr:`TapeDrive.flange_sides`).
FLANGE_SIDES = ("both", "upper", "lower")

#: The two readings of "moment of inertia of the cross section" in eq. 4.
BENDING_OPTIONS = ("in-plane", "out-of-plane")

#: ``(units, long name)`` of every TapeDrive field, and of ``t_sin_half_theta`` (eq. 5, Fig. 8):
#: the coordinates of sweeps, bifurcation diagrams and design charts.
FIELD_UNITS = {
    "speed": ("m/s", "tape speed V"),
    "tension": ("N", "tape tension T"),
    "pack_diameter": ("m", "supply pack diameter D"),
    "wrap_angle": ("deg", "wrap angle theta"),
    "width": ("m", "tape width w"),
    "thickness": ("m", "tape thickness h"),
    "free_length": ("m", "free span length l"),
    "youngs_modulus": ("Pa", "Young's modulus E of the tape"),
    "density": ("kg/m^3", "tape density rho"),
    "clearance": ("m", "tape edge to flange clearance L"),
    "stiffness_ratio": ("1", "flange to tape stiffness ratio k0/k"),
    "friction": ("1", "Coulomb friction coefficient mu"),
    "bending": ("", "second moment of area reading of eq. 4"),
    "hub_diameter": ("m", "hub diameter"),
    "full_pack_diameter": ("m", "full pack diameter"),
    "runout_hub": ("m", "reel run-out at the hub"),
    "runout_full": ("m", "reel run-out at full pack"),
    "damping_ratio": ("1", "viscous damping ratio zeta"),
    "static_friction": ("1", "static (breakaway) friction coefficient mu_s"),
    "flange": ("", "flange law (spring or rigid)"),
    "flange_exponent": ("1", "exponent p of the flange spring law k0 d^p"),
    "flange_stiffness": ("N/m^p", "flange stiffness k0 of the spring law"),
    "restitution": ("1", "coefficient of restitution of a rigid flange"),
    "guide_offset": ("m", "offset of the tape's rest position from the guide centre, towards the upper flange"),
    "flange_sides": ("", "flanges of the guide (both, upper or lower)"),
    "runout_harmonics": ("", "run-out harmonics (n, fraction, phase)"),
    "t_sin_half_theta": ("N", "T sin(theta/2), half the roller normal force (eq. 5)"),
}

#: The numeric fields of :class:`TapeDrive`: what a study may vary (``bending``, ``flange``, ``flange_sides`` and
#: ``runout_harmonics`` are the drive's structure, not numbers).
NUMERIC_FIELDS = ("speed", "tension", "pack_diameter", "wrap_angle", "width", "thickness", "free_length",
                  "youngs_modulus", "density", "clearance", "stiffness_ratio", "friction", "hub_diameter",
                  "full_pack_diameter", "runout_hub", "runout_full", "damping_ratio", "static_friction",
                  "flange_exponent", "flange_stiffness", "restitution", "guide_offset")

_HUB_DIAMETER = 44e-3
_FULL_PACK_DIAMETER = 97e-3


@dataclass(frozen=True, slots=True)
class TapeDrive:
    """A tape path of the paper (section 5) in SI units: tape, roller flange, reel, operating point.

    Frozen and validated at construction; :meth:`replace` returns a revalidated copy.
    The defaults are the paper's parameters (section 5, text below Fig. 6) at 4 m/s,
    1 N and mid pack.

    Parameters
    ----------
    speed : float
        Linear tape speed ``V`` in m/s (> 0). Default 4.0.
    tension : float
        Tape tension ``T`` in N (> 0). Default 1.0.
    pack_diameter : float or None
        Diameter ``D`` of the supply tape pack in m. ``None`` (default) means mid pack,
        ``(hub_diameter + full_pack_diameter) / 2``, and is stored as that number. Must
        lie in ``[hub_diameter, full_pack_diameter]``, where the run-out law is defined
        (no extrapolation: outside it a ``ValueError`` is raised).
    wrap_angle : float
        Wrap angle ``theta`` of the tape around the roller in degrees, in (0, 360).
        Default 60 (the paper).
    width : float
        Tape width ``w`` in m (> 0). Default 12.7e-3 (half-inch tape).
    thickness : float
        Tape thickness ``h`` in m (> 0). Default 9e-6.
    free_length : float
        Length ``l`` of the free tape span treated as a centrally loaded beam in m (> 0).
        Default 10e-3.
    youngs_modulus : float
        Young's modulus ``E`` of the tape in Pa (> 0). Default 7e9 (PET substrate).
    density : float
        Tape density ``rho`` in kg/m^3 (> 0). Default 1370.
    clearance : float
        Clearance ``L`` between tape edge and flange in m (> 0), the length scale of
        eq. 3. Default 1e-3.
    stiffness_ratio : float
        Flange-to-tape stiffness ratio ``K = k0/k`` (dimensionless, > 0). Default 1e4.
    friction : float
        Coulomb friction coefficient ``mu`` between tape and roller (dimensionless, >= 0).
        Default 0.2.
    bending : {"in-plane", "out-of-plane"}
        Which second moment of area enters eq. 4. ``"in-plane"`` (default):
        ``I = h w^3 / 12``, lateral bending of the tape in its own plane, about the axis
        through its thickness -- the deflection the lateral tape motion actually is.
        ``"out-of-plane"``: ``I = w h^3 / 12``, bending about the width axis (the usual
        "plate" reading); it makes ``k`` (w/h)^2 ~ 2e6 times smaller.
    hub_diameter : float
        Pack diameter of an empty reel (the hub) in m (> 0). Default 44e-3.
    full_pack_diameter : float
        Pack diameter of a full reel in m (> ``hub_diameter``). Default 97e-3.
    runout_hub : float
        Axial run-out of the reel at the hub in m (> 0). Default 60e-6 (paper, Fig. 6:
        "about 60 um at the inner diameter").
    runout_full : float
        Axial run-out of the reel at full pack in m (> 0). Default 180e-6 (paper, Fig. 6:
        "almost 180 um at the outer diameter").
    damping_ratio : float
        Viscous damping ratio ``zeta`` of the lateral tape motion (dimensionless, >= 0).
        Default 0 (the paper's model). A member of the model family, like every field below.
    static_friction : float or None
        Static (breakaway) friction coefficient ``mu_s >= friction``; ``None`` (default)
        means equal to ``friction``. It sets ``beta_static = mu_s N / (k L)``.
    flange : {"spring", "rigid"}
        The flange law: ``"spring"`` (default) pushes back with ``k0 d^p``; ``"rigid"`` is
        an instantaneous impact with restitution.
    flange_exponent : float
        ``p >= 1`` of the spring law (1: linear, the paper; 1.5: Hertz contact).
    flange_stiffness : float or None
        ``k0`` of the spring law in N/m^p (e.g. a Hertz stiffness in N/m^1.5). ``None``
        (default): ``k0 = stiffness_ratio * k * L^(1 - p)``, i.e. ``K = stiffness_ratio``.
    restitution : float
        Newton's coefficient of restitution ``0 <= e <= 1`` of a rigid flange. Default 1.
    runout_harmonics : sequence of tuple
        Higher harmonics of the run-out, ``(n, fraction, phase)``: harmonic number ``n`` (a positive integer, a
        multiple of the reel frequency), amplitude as a fraction of the Fig. 6 run-out
        (>= 0), phase in radians. Default: none (a pure cosine).
    guide_offset : float
        Offset in m of the tape's rest position (its edge with the tape unloaded) from the
        centre of the guide, positive towards the upper flange (default 0: centred). The
        edge then clears the upper flange by ``clearance - guide_offset`` and the lower one
        by ``clearance + guide_offset``: ``gap_upper = 1 - guide_offset / clearance`` and
        ``gap_lower = 1 + guide_offset / clearance`` of :class:`Oscillator`. It must keep
        the tape clear of every flange the guide has (``|guide_offset| < clearance``).
    flange_sides : {"both", "upper", "lower"}
        The flanges of the guide (default ``"both"``); ``"upper"`` or ``"lower"`` is a guide
        with a single reference flange on that side, the other side open
        (``gap_lower`` or ``gap_upper`` of :class:`Oscillator` is ``inf``).

    Notes
    -----
    **Run-out law.** The run-out rises linearly with pack diameter from ``runout_hub`` at
    ``hub_diameter`` to ``runout_full`` at ``full_pack_diameter`` -- a straight-line reading
    of the paper's Fig. 6.

    **Assumed reel geometry (not in the paper).** The paper gives the run-out only at "the
    inner" and "the outer diameter". The default 44 mm hub and 97 mm full pack are
    assumptions typical of a single-reel half-inch (LTO-class) cartridge: the cartridge is
    about 102 mm x 105 mm, so a full pack must stay just under ~100 mm, and the annulus
    between 44 mm and 97 mm holds ``pi/4 (0.097^2 - 0.044^2) / 9e-6`` ~ 650 m of 9 um tape,
    the order of the 609 m of 8.9 um tape of a first-generation LTO cartridge. Change
    ``hub_diameter``/``full_pack_diameter`` for another reel; the run-out law follows.

    **Fig. 8 axis.** Tension and wrap angle enter the model only through
    ``T sin(theta/2)`` (eq. 5); see :attr:`t_sin_half_theta` and
    :meth:`from_t_sin_half_theta`.

    Raises
    ------
    TypeError
        If a numeric field is not a real number, or ``bending`` is not a string.
    ValueError
        If a field is not finite or breaks its rule (sign, range, choice); the message
        names the field, the rule and the value.

    Examples
    --------
    >>> drive = TapeDrive(speed=8.0, tension=2.0)
    >>> osc = drive.oscillator()                      # nondimensional eq. 3
    >>> t_end = drive.seconds_to_lambda(1.0)          # one second of tape motion
    """

    speed: float = 4.0
    tension: float = 1.0
    pack_diameter: float | None = None
    wrap_angle: float = 60.0
    width: float = 12.7e-3
    thickness: float = 9e-6
    free_length: float = 10e-3
    youngs_modulus: float = 7e9
    density: float = 1370.0
    clearance: float = 1e-3
    stiffness_ratio: float = 1e4
    friction: float = 0.2
    bending: str = "in-plane"
    hub_diameter: float = _HUB_DIAMETER
    full_pack_diameter: float = _FULL_PACK_DIAMETER
    runout_hub: float = 60e-6
    runout_full: float = 180e-6
    damping_ratio: float = 0.0
    static_friction: float | None = None
    flange: str = "spring"
    flange_exponent: float = 1.0
    flange_stiffness: float | None = None
    restitution: float = 1.0
    runout_harmonics: tuple = ()
    guide_offset: float = 0.0
    flange_sides: str = "both"

    def __post_init__(self) -> None:
        def put(name: str, value) -> None:
            object.__setattr__(self, name, value)

        for name in ("speed", "tension", "width", "thickness", "free_length", "youngs_modulus", "density",
                     "clearance", "stiffness_ratio", "hub_diameter", "full_pack_diameter", "runout_hub",
                     "runout_full"):
            put(name, _v.positive(name, getattr(self, name)))
        put("friction", _v.nonnegative("friction", self.friction))

        theta = _v.real("wrap_angle", self.wrap_angle)
        if not 0.0 < theta < 360.0:
            raise ValueError(f"wrap_angle must be in (0, 360) degrees, got {theta!r}")
        put("wrap_angle", theta)

        if not isinstance(self.bending, str):
            raise TypeError(f"bending must be a string, one of {', '.join(map(repr, BENDING_OPTIONS))}; "
                            f"got {self.bending!r} of type {type(self.bending).__name__}")
        _v.choice("bending", self.bending, BENDING_OPTIONS)

        if not self.full_pack_diameter > self.hub_diameter:
            raise ValueError(f"full_pack_diameter must be > hub_diameter ({self.hub_diameter!r} m), "
                             f"got {self.full_pack_diameter!r}")
        if self.pack_diameter is None:
            put("pack_diameter", 0.5 * (self.hub_diameter + self.full_pack_diameter))
        else:
            put("pack_diameter", self._check_diameter("pack_diameter", self.pack_diameter))
        self._check_family(put)
        self._check_representable()

    def _check_family(self, put) -> None:
        """Validate the model-family fields (damping, static friction, flange, run-out harmonics) by their names."""
        put("damping_ratio", _v.nonnegative("damping_ratio", self.damping_ratio))
        if self.static_friction is not None:
            mu_s = _v.real("static_friction", self.static_friction)
            if not mu_s >= self.friction:
                raise ValueError(f"static_friction must be >= friction={self.friction!r}, got {mu_s!r}")
            put("static_friction", mu_s)
        if not isinstance(self.flange, str):
            raise TypeError(f"flange must be a string, 'spring' or 'rigid'; got {self.flange!r}")
        _v.choice("flange", self.flange, ("spring", "rigid"))
        p = _v.real("flange_exponent", self.flange_exponent)
        if not p >= 1.0:
            raise ValueError(f"flange_exponent must be >= 1 (flange force k0 d^p with p >= 1), got {p!r}")
        put("flange_exponent", p)
        if self.flange_stiffness is not None:
            put("flange_stiffness", _v.positive("flange_stiffness", self.flange_stiffness))
        e = _v.real("restitution", self.restitution)
        if not 0.0 <= e <= 1.0:
            raise ValueError(f"restitution must satisfy 0 <= e <= 1, got {e!r}")
        put("restitution", e)
        if self.flange == "rigid" and (p != 1.0 or self.flange_stiffness is not None):
            raise ValueError("flange_exponent and flange_stiffness apply to flange='spring' only, got "
                             f"flange_exponent={p!r}, flange_stiffness={self.flange_stiffness!r} with flange='rigid'")
        if self.flange == "spring" and e != 1.0:
            raise ValueError(f"restitution applies to flange='rigid' only, got restitution={e!r} with flange='spring'")
        harmonics = []
        if isinstance(self.runout_harmonics, str | bytes) or not hasattr(self.runout_harmonics, "__iter__"):
            raise TypeError("runout_harmonics must be a sequence of (n, fraction, phase), "
                            f"got {self.runout_harmonics!r}")
        for i, term in enumerate(self.runout_harmonics):
            try:
                n, frac, ph = term
            except (TypeError, ValueError):
                raise ValueError(f"runout_harmonics[{i}] must be a triple (n, fraction, phase), got {term!r}") from None
            if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
                raise ValueError(f"runout_harmonics[{i}] harmonic number n must be an integer >= 1, got {n!r}")
            harmonics.append((int(n), _v.nonnegative(f"runout_harmonics[{i}] fraction", frac),
                              _v.real(f"runout_harmonics[{i}] phase", ph)))
        put("runout_harmonics", tuple(harmonics))
        self._check_guide(put)

    def _check_guide(self, put) -> None:
        """Validate ``guide_offset`` and ``flange_sides`` (the flanges' positions about the tape path)."""
        if not isinstance(self.flange_sides, str):
            raise TypeError(f"flange_sides must be a string, 'both', 'upper' or 'lower'; got {self.flange_sides!r}")
        _v.choice("flange_sides", self.flange_sides, FLANGE_SIDES)
        offset = _v.real("guide_offset", self.guide_offset)
        L = self.clearance
        if self.flange_sides in ("both", "upper") and not offset < L:
            raise ValueError(f"guide_offset must be < clearance={L!r} m (the tape edge at rest would touch or cross "
                             f"the upper flange), got {offset!r}")
        if self.flange_sides in ("both", "lower") and not -offset < L:
            raise ValueError(f"guide_offset must be > -clearance={-L!r} m (the tape edge at rest would touch or cross "
                             f"the lower flange), got {offset!r}")
        put("guide_offset", offset)

    # Fields that enter the derived numbers, and the derived numbers that must be
    # representable: finite, and nonzero where the physics cannot make them zero.
    _NUMERIC_FIELDS = ("speed", "tension", "pack_diameter", "wrap_angle", "width", "thickness", "free_length",
                       "youngs_modulus", "density", "clearance", "stiffness_ratio", "friction", "hub_diameter",
                       "full_pack_diameter", "runout_hub", "runout_full")

    def _derived_problem(self) -> str | None:
        """What goes wrong in double precision on the way to eq. 3, or None."""
        try:
            derived = {"stiffness k (eq. 4)": self.stiffness, "mass m": self.mass, "omega_n": self.omega_n,
                       "force scale k L": self.force_scale, "F": self.F, "Omega": self.Omega,
                       "beta": self.beta}
        except (OverflowError, ZeroDivisionError):
            return "the stiffness k of eq. 4 overflows"
        for name, value in derived.items():
            if not math.isfinite(value):
                return f"{name} = {value!r}"
            if value == 0.0 and not (name == "beta" and self.friction == 0.0):
                return f"{name} underflows to 0"
        return None

    def _check_representable(self) -> None:
        """Refuse fields so extreme that eq. 3's numbers overflow or underflow, naming them.

        A field is named if putting it back to its default cures the problem.
        """
        problem = self._derived_problem()
        if problem is None:
            return
        culprits = []
        for name in self._NUMERIC_FIELDS:
            default = TapeDrive.__dataclass_fields__[name].default
            if default is None:  # pack_diameter: mid pack
                default = 0.5 * (self.hub_diameter + self.full_pack_diameter)
            if getattr(self, name) == default:
                continue
            trial = object.__new__(TapeDrive)
            for f in dataclasses.fields(TapeDrive):
                object.__setattr__(trial, f.name, default if f.name == name else getattr(self, f.name))
            if trial._derived_problem() is None:
                culprits.append(f"{name}={getattr(self, name)!r}")
        which = " or ".join(culprits) if culprits else "the combination of the fields set"
        raise ValueError(f"TapeDrive: {which} is out of the range double precision can carry to the model "
                         f"of eq. 3: {problem}")

    def _check_diameter(self, name: str, value) -> float:
        d = _v.positive(name, value)
        if not self.hub_diameter <= d <= self.full_pack_diameter:
            raise ValueError(f"{name} must be in [hub_diameter, full_pack_diameter] = "
                             f"[{self.hub_diameter!r}, {self.full_pack_diameter!r}] m where the run-out law "
                             f"is defined, got {d!r}")
        return d

    @property
    def _diameter(self) -> float:
        """``pack_diameter`` as the number it always is once constructed.

        The field is typed ``float | None`` because ``None`` is the constructor's "mid pack";
        ``__post_init__`` replaces it with that number, so ``None`` here is a broken invariant.
        """
        d = self.pack_diameter
        if d is None:
            raise RuntimeError("TapeDrive.pack_diameter is None after construction; __post_init__ sets it "
                               "to mid pack, so this instance was built without it")
        return d

    # -- construction helpers ----------------------------------------------------------
    def replace(self, **changes) -> TapeDrive:
        """A copy with some fields changed, validated again (``dataclasses.replace``).

        Note that ``pack_diameter`` is kept as a number: changing the hub or full-pack
        diameter does not move it back to mid pack (pass ``pack_diameter=None`` for that).
        """
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_t_sin_half_theta(cls, value: float, **fields) -> TapeDrive:
        """A drive with ``T sin(theta/2) = value`` (N), keeping the wrap angle and solving for ``T``.

        The paper's Fig. 8 is parametrised by ``T sin(theta/2)``, the only way tension and
        wrap angle enter the model (eq. 5: ``N = 2 T sin(theta/2)``).

        Parameters
        ----------
        value : float
            ``T sin(theta/2)`` in N (> 0).
        **fields
            Any other field; ``wrap_angle`` (degrees) defaults to 60. ``tension`` is not
            allowed (it is the unknown).
        """
        if "tension" in fields:
            raise TypeError("from_t_sin_half_theta() solves for tension; do not pass tension")
        value = _v.positive("t_sin_half_theta", value)
        theta = fields.get("wrap_angle", cls.__dataclass_fields__["wrap_angle"].default)
        theta = _v.real("wrap_angle", theta)
        if not 0.0 < theta < 360.0:
            raise ValueError(f"wrap_angle must be in (0, 360) degrees, got {theta!r}")
        return cls(tension=value / math.sin(math.radians(theta) / 2.0), **fields)

    # -- tape and roller (eq. 4, eq. 5) --------------------------------------------------
    @property
    def second_moment(self) -> float:
        """Second moment of area ``I`` of the tape cross section in m^4 (eq. 4).

        ``h w^3 / 12`` for ``bending="in-plane"``, ``w h^3 / 12`` for ``"out-of-plane"``.
        """
        w, h = self.width, self.thickness
        return h * w**3 / 12.0 if self.bending == "in-plane" else w * h**3 / 12.0

    @property
    def stiffness(self) -> float:
        """Effective lateral tape stiffness ``k = 48 E I / l^3`` in N/m (eq. 4, centrally loaded beam)."""
        return 48.0 * self.youngs_modulus * self.second_moment / self.free_length**3

    @property
    def mass(self) -> float:
        """Mass of the free tape span ``m = rho w h l`` in kg (the point mass of eq. 2)."""
        return self.density * self.width * self.thickness * self.free_length

    @property
    def omega_n(self) -> float:
        """Natural angular frequency ``omega_n = sqrt(k/m)`` in rad/s (eq. 2-3)."""
        return math.sqrt(self.stiffness / self.mass)

    @property
    def natural_frequency_hz(self) -> float:
        """Natural frequency ``omega_n / (2 pi)`` in Hz."""
        return self.omega_n / (2.0 * math.pi)

    @property
    def t_sin_half_theta(self) -> float:
        """``T sin(theta/2)`` in N, the abscissa parameter of the paper's Fig. 8 (= N/2, eq. 5)."""
        return self.tension * math.sin(math.radians(self.wrap_angle) / 2.0)

    @property
    def normal_force(self) -> float:
        """Belt-wrap normal force of the tape on the roller ``N = 2 T sin(theta/2)`` in N (eq. 5)."""
        return 2.0 * self.t_sin_half_theta

    @property
    def friction_force(self) -> float:
        """Coulomb friction force ``mu N`` in N (eq. 2)."""
        return self.friction * self.normal_force

    # -- reel (eq. 1, Fig. 6) ----------------------------------------------------------
    @property
    def omega_r(self) -> float:
        """Rotational frequency of the supply reel ``omega_r = 2 V / D`` in rad/s (eq. 1).

        It is the forcing frequency of eq. 2: the run-out repeats once per reel turn.
        """
        return 2.0 * self.speed / self._diameter

    def runout_at(self, diameter: float) -> float:
        """Axial reel run-out in m at pack diameter ``diameter`` (m), from the linear law (Fig. 6)."""
        d = self._check_diameter("diameter", diameter)
        frac = (d - self.hub_diameter) / (self.full_pack_diameter - self.hub_diameter)
        return self.runout_hub + frac * (self.runout_full - self.runout_hub)

    @property
    def runout(self) -> float:
        """Axial reel run-out at the current pack diameter in m (linear law, Fig. 6)."""
        return self.runout_at(self._diameter)

    @property
    def forcing_amplitude(self) -> float:
        """Forcing amplitude ``F_a = runout * k`` in N (paper, below Fig. 6; eq. 2)."""
        return self.runout * self.stiffness

    # -- nondimensional numbers of eq. 3 -------------------------------------------------
    @property
    def F(self) -> float:
        """Nondimensional forcing ``F = F_a / (k L)`` (eq. 3), which equals ``runout / L``."""
        return self.forcing_amplitude / self.force_scale

    @property
    def Omega(self) -> float:
        """Nondimensional forcing frequency ``Omega = omega_r / omega_n = 2 V / (D omega_n)`` (eq. 1, 3)."""
        return self.omega_r / self.omega_n

    @property
    def beta(self) -> float:
        """Nondimensional friction level ``beta = mu N / (k L)`` (eq. 3 with eq. 5)."""
        return self.friction_force / self.force_scale

    @property
    def K(self) -> float:
        """Flange stiffness ratio ``K = k0 L^(p-1) / k`` (eq. 3; ``k0 / k`` for the linear spring)."""
        if self.flange_stiffness is None:
            return self.stiffness_ratio
        return self.flange_stiffness * self.clearance ** (self.flange_exponent - 1.0) / self.stiffness

    @property
    def beta_static(self) -> float | None:
        """Nondimensional static friction level ``mu_s N / (k L)`` (``None`` when equal to :attr:`beta`)."""
        if self.static_friction is None:
            return None
        return self.static_friction * self.normal_force / self.force_scale

    def oscillator(self, phase: float = 0.0) -> Oscillator:
        """The nondimensional model of this drive (eq. 3 and its family, :class:`Oscillator`).

        Parameters
        ----------
        phase : float
            Forcing phase in radians (the reel's angle at ``t = 0``); the ``n``-th run-out
            harmonic gets ``n * phase`` plus its own phase.
        """
        harmonics = [(frac * self.F, n * self.Omega, n * phase + ph) for n, frac, ph in self.runout_harmonics]
        shift = self.guide_offset / self.clearance
        return Oscillator(self.F, self.Omega, self.beta, self.K, phase, zeta=self.damping_ratio,
                          beta_static=self.beta_static, flange=self.flange, exponent=self.flange_exponent,
                          restitution=self.restitution, harmonics=harmonics,
                          gap_lower=1.0 + shift if self.flange_sides != "upper" else math.inf,
                          gap_upper=1.0 - shift if self.flange_sides != "lower" else math.inf)

    # -- scales ------------------------------------------------------------------------
    @property
    def force_scale(self) -> float:
        """Force scale ``k L`` in N: a nondimensional force times this is newtons."""
        return self.stiffness * self.clearance

    @property
    def length_scale(self) -> float:
        """Length scale ``L`` in m: ``x = L X``."""
        return self.clearance

    @property
    def time_scale(self) -> float:
        """Time scale ``1 / omega_n`` in s: ``t = Lambda / omega_n``."""
        return 1.0 / self.omega_n

    def seconds_to_lambda(self, t_s):
        """Nondimensional time ``Lambda = omega_n t`` for ``t_s`` seconds (float or array)."""
        if isinstance(t_s, numbers.Real) and not isinstance(t_s, bool):
            return self.omega_n * _v.real("t_s", t_s)
        return self.omega_n * np.asarray(t_s, dtype=float)

    def lambda_to_seconds(self, lam):
        """Time in seconds ``t = Lambda / omega_n`` for nondimensional time ``lam`` (float or array)."""
        if isinstance(lam, numbers.Real) and not isinstance(lam, bool):
            return _v.real("lam", lam) / self.omega_n
        return np.asarray(lam, dtype=float) / self.omega_n

    # -- report ------------------------------------------------------------------------
    def describe(self) -> str:
        """A short multi-line summary of the operating point and the derived numbers, with units."""
        lines = [
            f"TapeDrive: V = {self.speed:g} m/s, T = {self.tension:g} N, theta = {self.wrap_angle:g} deg, "
            f"D = {self._diameter * 1e3:.4g} mm (hub {self.hub_diameter * 1e3:.4g}, "
            f"full {self.full_pack_diameter * 1e3:.4g} mm)",
            f"  tape: w = {self.width * 1e3:.4g} mm, h = {self.thickness * 1e6:.4g} um, "
            f"l = {self.free_length * 1e3:.4g} mm, E = {self.youngs_modulus:.4g} Pa, "
            f"rho = {self.density:.4g} kg/m^3, bending {self.bending}",
            f"  I = {self.second_moment:.4g} m^4, k = {self.stiffness:.4g} N/m (eq. 4), m = {self.mass:.4g} kg",
            f"  omega_n = {self.omega_n:.4g} rad/s (f_n = {self.natural_frequency_hz:.4g} Hz), "
            f"1 s = {self.omega_n:.4g} Lambda",
            f"  N = {self.normal_force:.4g} N (eq. 5), T sin(theta/2) = {self.t_sin_half_theta:.4g} N, "
            f"mu N = {self.friction_force:.4g} N",
            f"  omega_r = {self.omega_r:.4g} rad/s (eq. 1), run-out = {self.runout * 1e6:.4g} um, "
            f"F_a = {self.forcing_amplitude:.4g} N",
            f"  scales: L = {self.clearance:.4g} m, k L = {self.force_scale:.4g} N",
            f"  eq. 3: F = {self.F:.4g}, Omega = {self.Omega:.4g}, beta = {self.beta:.4g}, K = {self.K:.4g}",
        ]
        extra = self.oscillator().unsupported()
        if extra:
            lines.append(f"  model family: {', '.join(extra)}")
        return "\n".join(lines)
