"""The Dataset of a :class:`~._branch.Branch` (``Branch.to_xarray``) and how its event signatures read."""

from __future__ import annotations

import numpy as np

__all__ = ["dataset", "signature_text", "touched_flanges"]


def dataset(branch):
    """``Branch.to_xarray()``: one row per point, the labelled points on the dimension ``label``."""
    import xarray as xr

    idx = np.arange(len(branch.points))
    width = len(branch.points[0].multipliers) if branch.points else 2
    mus = np.array([p.multipliers for p in branch.points], dtype=complex).reshape(len(idx), width)
    data = {name: ("point", branch.values(name)) for name in branch.names}
    data.update({
        "x": ("point", branch.x), "v": ("point", branch.v),
        "period": ("point", np.array([p.period for p in branch.points], dtype=float)),
        "multiplier_real": (("point", "k"), mus.real), "multiplier_imag": (("point", "k"), mus.imag),
        "multiplier_abs": (("point", "k"), np.abs(mus)),
        "stability": ("point", np.array([p.stability for p in branch.points], dtype=str)),
        "stable": ("point", branch.stable),
        "signature": ("point", np.array([p.signature_text() for p in branch.points], dtype=str)),
        "norm": ("point", np.array([p.norm for p in branch.points], dtype=float)),
        "flange": ("point", np.array([touched_flanges(p.signature) or "none" for p in branch.points], dtype=str)),
        "upper_margin": ("point", np.array([p.upper_margin for p in branch.points], dtype=float)),
        "lower_margin": ("point", np.array([p.lower_margin for p in branch.points], dtype=float)),
        "stick_margin": ("point", np.array([p.stick_margin for p in branch.points], dtype=float)),
        "arclength": ("point", np.array([p.arclength for p in branch.points], dtype=float)),
    })
    if branch.is_system:
        data["state"] = (("point", "component"), np.array([p.z for p in branch.points], dtype=float).reshape(
            len(idx), branch.base.dimension))
    rows = branch.table()
    data["type"] = ("label", np.array([r["type"] for r in rows], dtype=str))
    data["label_point"] = ("label", np.array([r["point"] for r in rows], dtype=int))
    for key in (*branch.names, "norm"):
        data[f"label_{key}"] = ("label", np.array([r[key] for r in rows], dtype=float))
    for key in ("stability", "flange"):
        data[f"label_{key}"] = ("label", np.array([r[key] for r in rows], dtype=str))
    coords = {"point": idx, "label": np.array([r["label"] for r in rows], dtype=str)}
    if branch.is_system:
        coords["component"] = np.array(branch.base.states, dtype=str)
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({"parameters": ", ".join(branch.names), "n": branch.n, "status": branch.status,
                     "message": branch.message, "backend": branch.backend,
                     "special": "; ".join(f"{s.label} {s.kind} at "
                                          + ", ".join(f"{k}={val:.12g}" for k, val in s.parameters.items())
                                          for s in branch.special),
                     "model": repr(branch.base)})
    return ds


def signature_text(signature) -> str:
    """An event signature in words: ``"2 upper impact"`` (built-in family), ``"1 enter (free+->upper+)"`` (a guard)."""
    side = {1: "upper ", -1: "lower ", 0: ""}
    return ", ".join(f"{count} {side[s]}{kind}" if s in side else f"{count} {kind} ({s})"
                     for (kind, s), count in signature) or "no events"


def touched_flanges(signature) -> str:
    """``"upper"``, ``"lower"``, ``"both"`` or ``""``: the flanges an event signature's contacts touch."""
    sides = {side for (kind, side), count in signature
             if count and kind in ("impact", "contact_start", "chatter") and side}
    return "both" if sides == {1, -1} else "upper" if sides == {1} else "lower" if sides == {-1} else ""
