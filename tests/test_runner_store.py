"""The verified store under bifurcation diagrams: damaged, swapped and old files are named, set aside, recomputed."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from impactosc import Oscillator
from impactosc.dynamics import bifurcation_diagram, load_bifurcation

OSC = Oscillator(0.3, 0.8, 0.05, 1e4)
VALUES = [0.2, 0.3, 0.4]
KW = dict(transient_periods=5, record_periods=3, backend="exact", progress=False, executor="serial")


def _files(store):
    """Point file of each value, by its value."""
    out = {}
    for p in (store / "points").glob("*.npz"):
        with np.load(p) as f:
            out[json.loads(str(f["fields"]))["value"]] = p
    return out


@pytest.fixture(params=["none", "forward"])
def filled(tmp_path, request):
    store = tmp_path / "bif"
    ds = bifurcation_diagram(OSC, "F", VALUES, continuation=request.param, store=store, **KW)
    assert np.all(ds["status"].values == 0)
    return store, ds, request.param


@pytest.mark.parametrize(
    "damage",
    [
        pytest.param(lambda p: p.write_bytes(b""), id="empty"),  # was a raw EOFError
        pytest.param(lambda p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2]), id="truncated"),
        pytest.param(lambda p: p.write_bytes(b"not a zip file\n" * 20), id="garbage"),  # was a raw BadZipFile
    ],
)
def test_a_damaged_value_file_is_named_quarantined_and_recomputed(filled, damage):
    store, ds, continuation = filled
    bad = _files(store)[0.4]
    damage(bad)
    with pytest.warns(RuntimeWarning, match=rf"1 point file\(s\) unusable \(treated as not computed\): {bad.name}"):
        partial = load_bifurcation(store)
    assert int((partial["status"] == -4).sum()) == 1 and bad.exists()
    with pytest.warns(RuntimeWarning, match=rf"unusable \(moved to quarantine/ and computed again\): {bad.name}"):
        again = bifurcation_diagram(OSC, "F", VALUES, continuation=continuation, store=store, **KW)
    np.testing.assert_array_equal(again["x"].values, ds["x"].values)
    assert (store / "quarantine" / bad.name).exists() and bad.exists()
    np.testing.assert_array_equal(load_bifurcation(store)["x"].values, ds["x"].values)


def test_swapped_value_files_are_detected_and_recomputed(filled):
    store, ds, continuation = filled
    files = _files(store)
    a, b = files[0.2], files[0.3]
    tmp = a.with_suffix(".swap")
    shutil.move(a, tmp)
    shutil.move(b, a)
    shutil.move(tmp, b)
    with pytest.warns(RuntimeWarning, match=r"point file\(s\) unusable.*holds point"):
        again = bifurcation_diagram(OSC, "F", VALUES, continuation=continuation, store=store, **KW)
    np.testing.assert_array_equal(again["x"].values, ds["x"].values)  # each value its own, not the other's
    np.testing.assert_array_equal(load_bifurcation(store)["x"].values, ds["x"].values)


def test_an_altered_value_is_caught_by_its_checksum(filled):
    store, ds, continuation = filled
    path = _files(store)[0.3]
    with np.load(path) as f:
        content = {k: f[k] for k in f.files}
    content["x"] = content["x"] + 1e-9  # a file that still reads, with other numbers in it
    with open(path, "wb") as fh:
        np.savez(fh, **content)
    with pytest.warns(RuntimeWarning, match=rf"{path.name} \(its values do not match its checksum"):
        again = bifurcation_diagram(OSC, "F", VALUES, continuation=continuation, store=store, **KW)
    np.testing.assert_array_equal(again["x"].values, ds["x"].values)


@pytest.mark.parametrize("text", ["", "{not json", "[1, 2]"])
def test_a_damaged_manifest_is_named_and_set_aside(filled, text):
    store, ds, continuation = filled
    manifest = store / "manifest.json"
    manifest.write_text(text)
    with pytest.raises(ValueError, match=r"manifest\.json"):  # was a raw JSONDecodeError
        load_bifurcation(store)
    with pytest.warns(RuntimeWarning, match=r"manifest\.json.*moved to .*quarantine"):
        again = bifurcation_diagram(OSC, "F", VALUES, continuation=continuation, store=store, **KW)
    np.testing.assert_array_equal(again["x"].values, ds["x"].values)
    assert json.loads(manifest.read_text())["format"] == 2


def test_a_store_of_the_old_format_is_refused_by_name(tmp_path):
    # The layout before the shared runner: <direction>-<index>.npz beside a format-1 manifest.
    store = tmp_path / "old"
    store.mkdir()
    (store / "manifest.json").write_text(json.dumps({"format": 1, "parameter": "F", "values": VALUES,
                                                     "continuation": "none", "settings": {}}))
    np.savez(store / "independent-000000.npz", value=0.2, x=np.zeros(3))
    for call in (lambda: load_bifurcation(store),
                 lambda: bifurcation_diagram(OSC, "F", VALUES, store=store, **KW)):
        with pytest.raises(ValueError, match=r"has format 1, expected 2 .*manifest\.json"):
            call()
    assert (store / "independent-000000.npz").exists()  # nothing of it was moved or overwritten


def test_a_sweep_store_is_not_taken_for_a_diagram(tmp_path):
    from impactosc import TapeDrive, sweep

    store = tmp_path / "sw"
    sweep(TapeDrive(clearance=50e-6), {"speed": [4.0]}, duration=1e-5, backend="exact", executor="serial",
          progress=False, store=store)
    with pytest.raises(ValueError, match=r"holds a sweep .* not a bifurcation diagram"):
        bifurcation_diagram(OSC, "F", VALUES, store=store, **KW)
    store2 = tmp_path / "bif"
    bifurcation_diagram(OSC, "F", VALUES, store=store2, **KW)
    with pytest.raises(ValueError, match=r"holds a bifurcation diagram .* not a sweep"):
        sweep(TapeDrive(clearance=50e-6), {"speed": [4.0]}, duration=1e-5, backend="exact", executor="serial",
              progress=False, store=store2)


def test_an_interrupted_pass_resumes_from_its_last_value(tmp_path):
    store = tmp_path / "bif"
    first = bifurcation_diagram(OSC, "F", VALUES, continuation="forward", store=store, **KW)
    files = _files(store)
    files[0.4].unlink()
    stamps = {v: files[v].stat().st_mtime_ns for v in (0.2, 0.3)}
    again = bifurcation_diagram(OSC, "F", VALUES, continuation="forward", store=store, **KW)
    assert {v: files[v].stat().st_mtime_ns for v in (0.2, 0.3)} == stamps
    np.testing.assert_array_equal(again["x"].values, first["x"].values)
