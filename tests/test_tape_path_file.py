"""Tape paths as data (issue 28, item 3): the path file, the dict form, parameters by name."""

from __future__ import annotations

import json
from importlib.resources import files

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from impactosc import Guide, TapeDrive, TapePath

EXAMPLES = files("impactosc.cli") / "paths"


def test_example_files_build_the_paths_they_describe():
    four = TapePath.from_file(EXAMPLES / "four-guides.toml")
    assert four.n == 4 and four.end_span == 0.03
    assert [four.guide_drive(i).clearance for i in range(4)] == [300e-6, 200e-6, 20e-6, 300e-6]
    assert four.guide_drive(1).wrap_angle == 90.0 and four.guide_drive(0).wrap_angle == 60.0
    assert four.guide_drive(3).flange == "rigid" and four.drive.damping_ratio == 0.02
    two = TapePath.from_file(EXAMPLES / "two-guides.toml")
    assert two.n == 2 and two.guide_drive(1).clearance == 40e-6 and two.guide_drive(0).clearance == 150e-6


def test_dict_form_round_trips_through_json_and_toml(tmp_path):
    path = TapePath(TapeDrive(runout_harmonics=((2, 0.3, 0.1),), static_friction=0.3),
                    [Guide(0.02, clearance=30e-6, flange_sides="upper"),
                     Guide(0.05, roller_runout=1e-5, roller_diameter=0.02, roller_phase=0.4)], end_span=0.03)
    assert TapePath.from_dict(path.to_dict()) == path
    f = tmp_path / "p.json"
    f.write_text(json.dumps(path.to_dict()))
    assert TapePath.from_file(f) == path
    # TOML: written by hand (no writer in the standard library), read back by tomllib.
    g = tmp_path / "p.toml"
    g.write_text('end_span = 0.03\n[drive]\nrunout_harmonics = [[2, 0.3, 0.1]]\nstatic_friction = 0.3\n'
                 '[[guides]]\nposition = 0.02\nclearance = 30e-6\nflange_sides = "upper"\n'
                 '[[guides]]\nposition = 0.05\nroller_runout = 1e-5\nroller_diameter = 0.02\nroller_phase = 0.4\n')
    assert TapePath.from_file(g) == path
    np.testing.assert_array_equal(TapePath.from_file(g).stiffness_matrix, path.stiffness_matrix)


@pytest.mark.parametrize("text, match", [
    ("[[guides]]\nposition = 0.02\nclearence = 1e-5\n", r"guides\[0\] has an unknown key 'clearence'; valid keys"),
    ("[drive]\nsped = 4.0\n[[guides]]\nposition = 0.02\n", r"\[drive\] has an unknown key 'sped'"),
    ("[drive]\nspeed = -4.0\n[[guides]]\nposition = 0.02\n", r"\[drive\] speed must be > 0, got -4.0"),
    ("[drive]\nspeed = \"fast\"\n[[guides]]\nposition = 0.02\n", r"\[drive\] speed must be a real number"),
    ("[drive]\n", "guides is missing"),
    ("[[guides]]\nclearance = 1e-5\n", r"guides\[0\]\.position is missing"),
    ("[[guides]]\nposition = 0.05\n[[guides]]\nposition = 0.02\n",
     r"guides\[1\]\.position must be > guides\[0\]\.position"),
    ("[[guides]]\nposition = 0.02\nclearance = 0.0\n", r"guides\[0\]: clearance must be > 0, got 0.0"),
    ("[[guides]]\nposition = 0.02\nflange = \"glue\"\n", r"guides\[0\]: flange must be one of"),
    ("end_span = -1\n[[guides]]\nposition = 0.02\n", "end_span must be > 0, got -1"),
    ("format = 2\n[[guides]]\nposition = 0.02\n", "format must be 1"),
    ("speed = 4.0\n[[guides]]\nposition = 0.02\n", "the top level has an unknown key 'speed'"),
    ("[[guides]\nposition = 0.02\n", "is not valid TOML"),
])
def test_bad_files_name_the_file_the_key_the_rule_and_the_value(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises((TypeError, ValueError), match=match) as info:
        TapePath.from_file(f)
    assert "bad.toml" in str(info.value)


def test_bad_suffix_and_top_level_are_refused(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text("guides: []")
    with pytest.raises(ValueError, match=r"must end in \.toml or \.json"):
        TapePath.from_file(f)
    g = tmp_path / "p.json"
    g.write_text("[1, 2]")
    with pytest.raises(ValueError, match="must hold a table"):
        TapePath.from_file(g)


def test_parameters_by_name():
    path = TapePath(TapeDrive(clearance=50e-6), [Guide(0.02), Guide(0.05, clearance=30e-6)], end_span=0.03)
    assert path.with_parameter("clearance", 60e-6).guide_drive(0).clearance == 60e-6
    assert path.with_parameter("clearance", 60e-6).guide_drive(1).clearance == 30e-6  # its own stays
    assert path.with_parameter("guide1_clearance", 10e-6).guide_drive(1).clearance == 10e-6
    assert path.with_parameter("guide0_position", 0.01).span_lengths[:2] == pytest.approx((0.01, 0.04))
    assert path.with_parameter("end_span", 0.05).end_span == 0.05
    assert path.with_parameter("tension", 2.0).drive.tension == 2.0
    with pytest.raises(ValueError, match="'guide2_clearance' names guide 2, but the path has 2 guides"):
        path.with_parameter("guide2_clearance", 1e-5)
    with pytest.raises(ValueError, match="'colour' is not a path parameter"):
        path.with_parameter("colour", 1.0)
    with pytest.raises(ValueError, match="'guide0_flange' is not a path parameter"):
        path.with_parameter("guide0_flange", "rigid")
    with pytest.raises(ValueError, match=r"guide1_position = 0.01: guides\[1\]\.position must be >"):
        path.with_parameter("guide1_position", 0.01)


def test_leaving_out_a_guides_flanges_keeps_the_rest():
    path = TapePath(TapeDrive(clearance=50e-6), [Guide(0.02), Guide(0.05, flange_sides="upper")], end_span=0.03)
    full = path.mechanical_system()
    assert len(full.contacts) == 3
    without = path.mechanical_system(leave_out_flanges=[0])
    assert len(without.contacts) == 1 and without.contacts[0].normal.tolist() == [0.0, 1.0]
    np.testing.assert_array_equal(without.K, full.K)
    assert len(without.friction) == len(full.friction) == 2
    with pytest.raises(ValueError, match="leave_out_flanges must name guides 0 to 1"):
        path.mechanical_system(leave_out_flanges=[2])


@settings(max_examples=30, deadline=None)
@given(gaps=st.lists(st.floats(2e-3, 0.1), min_size=1, max_size=5),
       clearances=st.lists(st.one_of(st.none(), st.floats(5e-6, 1e-3)), min_size=5, max_size=5),
       end=st.one_of(st.none(), st.floats(2e-3, 0.1)), speed=st.floats(0.5, 12.0))
def test_dict_form_round_trip_property(gaps, clearances, end, speed):
    positions = np.cumsum(gaps)
    path = TapePath(TapeDrive(speed=speed), [Guide(float(p), clearance=c) for p, c in
                                            zip(positions, clearances, strict=False)], end_span=end)
    data = json.loads(json.dumps(path.to_dict()))
    assert TapePath.from_dict(data) == path


@pytest.mark.parametrize("module", ["impactosc.model._tape_path", "impactosc.model._guide"])
def test_examples_in_the_docstrings_run(module):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted > 0 and result.failed == 0
