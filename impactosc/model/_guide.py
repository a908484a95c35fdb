"""One guide or roller of a :class:`~impactosc.model.TapePath`: its position, flanges, wrap and friction."""

from __future__ import annotations

from dataclasses import dataclass

from .._util import validation as _v

__all__ = ["Guide", "GUIDE_FIELDS", "guide_tuple"]

#: The :class:`TapeDrive` fields a :class:`Guide` may set for itself (``None``: the path's drive's value).
GUIDE_FIELDS = ("clearance", "guide_offset", "flange_sides", "flange", "stiffness_ratio", "flange_stiffness",
                "restitution", "wrap_angle", "friction", "static_friction")


@dataclass(frozen=True, slots=True)
class Guide:
    """One guide or roller of a :class:`~impactosc.model.TapePath`: where it is, its flanges, wrap and friction.

    Every field but ``position`` and the roller run-out defaults to ``None``, meaning the value
    of the path's :class:`TapeDrive` (same name, same units, same rules: the guide's fields are
    validated by building a :class:`TapeDrive` with them).

    Parameters
    ----------
    position : float
        Distance in m along the tape from where it leaves the supply pack (> 0; the guides of a
        path are in increasing order).
    clearance, guide_offset, flange_sides, flange, stiffness_ratio, flange_stiffness, restitution, wrap_angle, \
friction, static_friction
        As in :class:`TapeDrive` (clearance in m, offset in m towards the upper flange, ``"both"``,
        ``"upper"`` or ``"lower"``, ``"spring"`` or ``"rigid"``, ``k0`` in N/m, wrap angle in degrees,
        friction coefficients); ``None``: the drive's. The spring flange's ``k0`` defaults to
        ``stiffness_ratio`` times the guide's own lateral stiffness (the diagonal entry of the
        chain's stiffness matrix, ``k`` of eq. 4 for a single guide).
    roller_runout : float
        Axial run-out amplitude in m of a rotating roller's flanges (>= 0; default 0: a fixed guide).
    roller_diameter : float or None
        Roller diameter in m (> 0), required with a run-out: the roller turns at ``2 V / d``
        (eq. 1's relation for a surface moving at the tape speed).
    roller_phase : float
        The roller's angle at ``t = 0`` in radians.

    Examples
    --------
    >>> from impactosc.model import Guide
    >>> Guide(0.03, clearance=50e-6, wrap_angle=90.0).clearance
    5e-05
    """

    position: float
    clearance: float | None = None
    guide_offset: float | None = None
    flange_sides: str | None = None
    flange: str | None = None
    stiffness_ratio: float | None = None
    flange_stiffness: float | None = None
    restitution: float | None = None
    wrap_angle: float | None = None
    friction: float | None = None
    static_friction: float | None = None
    roller_runout: float = 0.0
    roller_diameter: float | None = None
    roller_phase: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _v.positive("Guide.position", self.position))
        object.__setattr__(self, "roller_runout", _v.nonnegative("Guide.roller_runout", self.roller_runout))
        object.__setattr__(self, "roller_phase", _v.real("Guide.roller_phase", self.roller_phase))
        if self.roller_diameter is not None:
            object.__setattr__(self, "roller_diameter", _v.positive("Guide.roller_diameter", self.roller_diameter))
        elif self.roller_runout > 0.0:
            raise ValueError(f"Guide.roller_diameter is required with Guide.roller_runout > 0 (the roller turns at "
                             f"2 V / d), got roller_runout={self.roller_runout!r} and roller_diameter=None")

    def overrides(self) -> dict:
        """The :class:`TapeDrive` fields this guide sets (those not ``None``)."""
        return {name: getattr(self, name) for name in GUIDE_FIELDS if getattr(self, name) is not None}


def guide_tuple(guides) -> tuple[Guide, ...]:
    if isinstance(guides, Guide):
        guides = (guides,)
    if isinstance(guides, str | bytes) or not hasattr(guides, "__iter__"):
        raise TypeError(f"guides must be a sequence of Guide, got {guides!r}")
    out = tuple(guides)
    if not out:
        raise ValueError("guides must hold at least one Guide, got an empty sequence")
    for i, g in enumerate(out):
        if not isinstance(g, Guide):
            raise TypeError(f"guides[{i}] must be a Guide, got {g!r} of type {type(g).__name__}")
        if i and not g.position > out[i - 1].position:
            raise ValueError(f"guides[{i}].position must be > guides[{i - 1}].position = {out[i - 1].position!r} m "
                             f"(guides in order along the path), got {g.position!r}")
    return out
