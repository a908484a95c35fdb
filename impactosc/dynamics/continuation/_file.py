"""A :class:`~._branch.Branch` as one netCDF file with its model, and back (``Branch.save`` / ``Branch.load``).

The file is the branch's :meth:`~._branch.Branch.to_xarray` Dataset plus what rebuilding
it needs: the model's class and fields (JSON), the backend and its options, the section
phase, the ends, each point's event signature and test functions, and the special points
on a dimension ``special``. Attributes that are not numbers or strings are JSON text, so
the file is netCDF3 (xarray's ``scipy`` engine, no further dependency).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

__all__ = ["FORMAT", "to_dataset", "from_dataset"]

#: The ``format`` attribute of a saved branch (bumped when the layout changes).
FORMAT = "impactosc.Branch/1"


def _plain(value):
    """A NumPy scalar or array as the Python number or list JSON writes (``json.dumps(default=...)``)."""
    if isinstance(value, np.generic | np.ndarray):
        return value.tolist()
    raise TypeError(f"{value!r} of type {type(value).__name__} cannot be saved in a branch file")


def _dumps(value) -> str:
    return json.dumps(value, default=_plain)


def _model_json(model) -> str:
    fields = {f.name: getattr(model, f.name) for f in dataclasses.fields(model) if f.init}
    return _dumps({"class": type(model).__name__, "fields": fields})


def _model_from_json(text: str):
    from ...model._oscillator import Oscillator
    from ...model._tape import TapeDrive

    spec = json.loads(text)
    cls = {"Oscillator": Oscillator, "TapeDrive": TapeDrive}.get(spec.get("class"))
    if cls is None:
        raise ValueError(f"the saved model's class {spec.get('class')!r} is neither Oscillator nor TapeDrive")
    fields = dict(spec["fields"])
    for key in ("harmonics", "runout_harmonics"):
        if key in fields:
            fields[key] = tuple(tuple(t) for t in fields[key])
    return cls(**fields)


def _signature_json(sig) -> str:
    return json.dumps([[kind, side, count] for (kind, side), count in sig])


def _signature_from_json(text: str) -> tuple:
    return tuple(((kind, int(side)), int(count)) for kind, side, count in json.loads(text))


def _complex(values) -> list:
    return [[float(np.real(m)), float(np.imag(m))] for m in np.asarray(values, dtype=complex)]


def to_dataset(branch):
    """The Dataset :meth:`Branch.save` writes (see the module docstring)."""
    ds = branch.to_xarray()
    points = branch.points
    ds["signature_json"] = ("point", np.array([_signature_json(p.signature) for p in points], dtype=str))
    ds["tests_json"] = ("point", np.array([_dumps(p.tests) for p in points], dtype=str))
    ds["collapsed"] = ("point", np.array([p.collapsed for p in points], dtype=np.int8))
    special = [{"kind": s.kind, "label": s.label, "parameters": s.parameters, "x": s.x, "v": s.v,
                "multipliers": _complex(s.multipliers), "before": _signature_json(s.before),
                "after": _signature_json(s.after), "index": s.index, "accuracy": s.accuracy, "message": s.message,
                "flange": s.flange}
               for s in branch.special]
    ds.attrs.update({
        "format": FORMAT, "names": json.dumps(list(branch.names)), "model_json": _model_json(branch.base),
        "options_json": _dumps(branch.options), "section_phase": float(branch.section_phase),
        "ends_json": json.dumps([[int(s), str(m)] for s, m in branch.ends]),
        "special_json": _dumps(special),
    })
    return ds


def from_dataset(ds, classes):
    """The Branch of a Dataset :func:`to_dataset` made; ``classes`` are ``(Branch, BranchPoint, SpecialPoint)``."""
    branch_cls, point_cls, special_cls = classes
    if ds.attrs.get("format") != FORMAT:
        raise ValueError(f"not a saved continuation branch of this format: the file's format attribute is "
                         f"{ds.attrs.get('format')!r}, expected {FORMAT!r}")
    names = tuple(json.loads(ds.attrs["names"]))
    base = _model_from_json(ds.attrs["model_json"])
    mus = np.asarray(ds["multiplier_real"].values) + 1j * np.asarray(ds["multiplier_imag"].values)
    points = []
    for i in range(ds.sizes["point"]):
        points.append(point_cls(
            {name: float(ds[name].values[i]) for name in names}, float(ds["x"].values[i]), float(ds["v"].values[i]),
            float(ds["period"].values[i]), mus[i].copy(), str(ds["stability"].values[i]),
            _signature_from_json(str(ds["signature_json"].values[i])), float(ds["upper_margin"].values[i]),
            float(ds["lower_margin"].values[i]), float(ds["stick_margin"].values[i]), float(ds["arclength"].values[i]),
            {k: (math.nan if v is None else float(v)) for k, v in json.loads(str(ds["tests_json"].values[i])).items()},
            bool(ds["collapsed"].values[i])))
    special = []
    for s in json.loads(ds.attrs["special_json"]):
        special.append(special_cls(s["kind"], s["label"], {k: float(v) for k, v in s["parameters"].items()},
                                   float(s["x"]), float(s["v"]),
                                   np.array([complex(re, im) for re, im in s["multipliers"]]),
                                   _signature_from_json(s["before"]), _signature_from_json(s["after"]),
                                   int(s["index"]), float(s["accuracy"]), s["message"],
                                   saved_flange=s.get("flange", "")))
    ends = tuple((int(st), str(m)) for st, m in json.loads(ds.attrs["ends_json"]))
    return branch_cls(names, int(ds.attrs["n"]), points, special, int(ds.attrs["status"]), str(ds.attrs["message"]),
                      ends, base, str(ds.attrs["backend"]), float(ds.attrs["section_phase"]),
                      json.loads(ds.attrs["options_json"]))
