"""A tape path as plain data: the tables of a path file (TOML or JSON), and its SI parameters by name.

The same dict is a path file's content, a sweep point's stored inputs and the argument of
:meth:`TapePath.from_dict <impactosc.TapePath.from_dict>`::

    format = 1                 # optional: the version of this layout
    end_span = 0.03            # m, optional: a free span from the last guide to a fixed support

    [drive]                    # TapeDrive fields in SI units (defaults: the paper's drive)
    speed = 4.0                # m/s
    tension = 1.0              # N
    clearance = 50e-6          # m: every guide's, unless the guide sets its own
    friction = 0.0
    damping_ratio = 0.02
    runout_harmonics = [[2, 0.3, 0.0]]

    [[guides]]                 # one table per guide, in order along the path
    position = 0.02            # m from the pack (required)
    clearance = 300e-6         # any Guide field: clearance, guide_offset, flange_sides, flange,
                               # stiffness_ratio, flange_stiffness, restitution, wrap_angle,
                               # friction, static_friction, roller_runout, roller_diameter, roller_phase

A parameter of a path is named by one string, the coordinate of a sweep: a numeric
:class:`~impactosc.TapeDrive` field (``"speed"``, ``"tension"``, ``"pack_diameter"``, ``"clearance"``...:
the drive's, so every guide that does not set its own), ``"end_span"``, or
``"guide<i>_<field>"`` for guide ``i``'s own numeric field (``"guide1_clearance"``,
``"guide0_wrap_angle"``, ``"guide2_position"``, ``"guide3_roller_runout"``...).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
import tomllib
from pathlib import Path

from ._guide import Guide
from ._tape import FIELD_UNITS, NUMERIC_FIELDS, TapeDrive

__all__ = ["FILE_FORMAT", "PATH_KEYS", "path_dict", "parse_path", "read_path_file", "set_parameter",
           "parameter_units", "check_parameter"]

#: The version of the path-file layout this module reads and writes.
FILE_FORMAT = 1
#: The top-level keys of a path (a file may hold more tables if its reader asks for them).
PATH_KEYS = ("format", "drive", "guides", "end_span")

_DRIVE_FIELDS = tuple(f.name for f in dataclasses.fields(TapeDrive))
_GUIDE_KEYS = tuple(f.name for f in dataclasses.fields(Guide))
#: Guide fields that are numbers (what ``guide<i>_<field>`` may name).
_GUIDE_NUMERIC = ("position", "clearance", "guide_offset", "stiffness_ratio", "flange_stiffness", "restitution",
                  "wrap_angle", "friction", "static_friction", "roller_runout", "roller_diameter", "roller_phase")
_GUIDE_UNITS = {"position": ("m", "guide position along the path from the pack"),
                "roller_runout": ("m", "axial run-out amplitude of the roller's flanges"),
                "roller_diameter": ("m", "roller diameter"),
                "roller_phase": ("rad", "roller angle at t = 0")}
_GUIDE_PARAMETER = re.compile(r"guide(\d+)_(\w+)")


def _plain(value):
    """A field value as TOML/JSON data: tuples as lists (run-out harmonics)."""
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def path_dict(drive: TapeDrive, guides, end_span) -> dict:
    """The dict form of a path: every drive field, each guide's own fields, the end span (``None`` left out)."""
    out: dict = {"format": FILE_FORMAT}
    if end_span is not None:
        out["end_span"] = end_span
    out["drive"] = {f: _plain(getattr(drive, f)) for f in _DRIVE_FIELDS if getattr(drive, f) is not None}
    rows = []
    for g in guides:
        row = {"position": g.position, **g.overrides()}
        if g.roller_runout or g.roller_diameter is not None:
            row.update(roller_runout=g.roller_runout, roller_diameter=g.roller_diameter,
                       roller_phase=g.roller_phase)
        rows.append(row)
    out["guides"] = rows
    return out


def _table(data, name: str, source: str) -> dict:
    if not isinstance(data, dict):
        raise TypeError(f"{source}: {name} must be a table (key = value pairs), got {data!r}")
    return data


def _unknown(keys, valid, where: str, source: str) -> None:
    for key in keys:
        if key not in valid:
            raise ValueError(f"{source}: {where} has an unknown key {key!r}; valid keys: {', '.join(valid)}")


def _drive_value(name: str, value):
    if name == "runout_harmonics" and isinstance(value, list):
        return tuple(tuple(h) if isinstance(h, list) else h for h in value)
    return value


def parse_path(data, *, source: str = "path", extra=()) -> tuple[TapeDrive, tuple[Guide, ...], float | None]:
    """The drive, guides and end span of a path's dict form, every error naming its key.

    Parameters
    ----------
    data : dict
        The tables of ``PATH_KEYS`` (and any of ``extra``, which are not read here).
    source : str
        What the data came from, the start of every error message (a file name).
    extra : sequence of str
        Further top-level keys the caller reads itself (a path file's ``run`` and ``output``).

    Raises
    ------
    TypeError, ValueError
        ``"<source>: <key>: <rule>, got <value>"``: an unknown key (with the valid ones),
        a missing ``guides`` or ``position``, a field that :class:`~impactosc.TapeDrive` or :class:`~impactosc.Guide`
        refuses, a ``format`` other than ``FILE_FORMAT``.
    """
    data = _table(data, "the path", source)
    _unknown(data, PATH_KEYS + tuple(extra), "the top level", source)
    fmt = data.get("format", FILE_FORMAT)
    if fmt != FILE_FORMAT or isinstance(fmt, bool):
        raise ValueError(f"{source}: format must be {FILE_FORMAT} (the layout this version reads), got {fmt!r}")
    fields = _table(data.get("drive", {}), "[drive]", source)
    _unknown(fields, _DRIVE_FIELDS, "[drive]", source)
    try:
        drive = TapeDrive(**{k: _drive_value(k, v) for k, v in fields.items()})
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"{source}: [drive] {exc}") from None
    if "guides" not in data:
        raise ValueError(f"{source}: guides is missing: give at least one [[guides]] table with its position")
    rows = data["guides"]
    if not isinstance(rows, list) or not rows:
        raise ValueError(f"{source}: guides must be a non-empty list of tables ([[guides]]), got {rows!r}")
    guides = []
    for i, row in enumerate(rows):
        row = _table(row, f"guides[{i}]", source)
        _unknown(row, _GUIDE_KEYS, f"guides[{i}]", source)
        if "position" not in row:
            raise ValueError(f"{source}: guides[{i}].position is missing: give the guide's distance in m from the "
                             "pack")
        try:
            guides.append(Guide(**row))
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{source}: guides[{i}]: {exc}") from None
    end_span = data.get("end_span")
    return drive, tuple(guides), end_span


def read_path_file(file) -> dict:
    """The tables of a path file: TOML (``.toml``) or JSON (``.json``), by its suffix.

    Raises
    ------
    ValueError
        Another suffix, or a file that does not parse (the parser's message with its line).
    OSError
        The file cannot be read.
    """
    path = Path(file)
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise ValueError(f"path file {str(path)!r} must end in .toml or .json (its format), got {suffix or 'none'!r}")
    text = path.read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text) if suffix == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"path file {str(path)!r} is not valid {suffix[1:].upper()}: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError(f"path file {str(path)!r} must hold a table (JSON object) at the top, got {data!r}")
    return data


def check_parameter(key, n_guides: int) -> tuple[int | None, str]:
    """``(guide index or None, field)`` of a parameter name; ``ValueError`` listing the valid forms."""
    if not isinstance(key, str):
        raise TypeError(f"parameter names must be strings, got {key!r}")
    if key in NUMERIC_FIELDS or key == "end_span":
        return None, key
    m = _GUIDE_PARAMETER.fullmatch(key)
    if m and m.group(2) in _GUIDE_NUMERIC:
        i = int(m.group(1))
        if i >= n_guides:
            raise ValueError(f"parameter {key!r} names guide {i}, but the path has {n_guides} guides (0 to "
                             f"{n_guides - 1})")
        return i, m.group(2)
    raise ValueError(f"parameter {key!r} is not a path parameter: give a numeric TapeDrive field "
                     f"({', '.join(NUMERIC_FIELDS)}), 'end_span', or 'guide<i>_<field>' with <field> one of "
                     f"{', '.join(_GUIDE_NUMERIC)}")


def set_parameter(data: dict, key: str, value) -> dict:
    """A copy of a path's dict form with the parameter ``key`` (see the module docstring) set to ``value``.

    The value is not checked here: building the path (:func:`parse_path`) checks it, by name.
    """
    out = copy.deepcopy(data)
    guide, field = check_parameter(key, len(out.get("guides", ())))
    if guide is None:
        if field == "end_span":
            out["end_span"] = value
        else:
            out.setdefault("drive", {})[field] = value
    else:
        out["guides"][guide][field] = value
    return out


def parameter_units(key: str) -> tuple[str, str]:
    """``(units, long name)`` of a parameter (its coordinate's attributes in a sweep)."""
    m = _GUIDE_PARAMETER.fullmatch(key)
    if m:
        units, name = _GUIDE_UNITS.get(m.group(2)) or FIELD_UNITS[m.group(2)]
        return units, f"guide {m.group(1)}: {name}"
    if key == "end_span":
        return "m", "free span from the last guide to a fixed support"
    return FIELD_UNITS[key]

