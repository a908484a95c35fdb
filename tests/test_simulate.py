"""simulate(): argument checking. Bad input fails loudly, naming the parameter."""

import math

import pytest

import impactosc as io

OSC = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)


@pytest.mark.parametrize(
    "kwargs, exc, pattern",
    [
        ({"t_end": 0.0}, ValueError, "t_end must be > 0"),
        ({"t_end": -5.0}, ValueError, "t_end must be > 0"),
        ({"t_end": math.nan}, ValueError, "t_end must be finite"),
        ({"t_end": math.inf}, ValueError, "t_end must be finite"),
        ({"t_end": "10"}, TypeError, "t_end must be a real number"),
        ({"x0": math.nan}, ValueError, "x0 must be finite"),
        ({"v0": math.inf}, ValueError, "v0 must be finite"),
        ({"backend": "euler"}, ValueError, "backend must be one of"),
        ({"backend": 3}, TypeError, "backend must be a string"),
        ({"record": "everything"}, ValueError, "record must be one of"),
        ({"max_events": 0}, ValueError, "max_events must be >= 1"),
        ({"max_events": 2.5}, TypeError, "max_events must be an integer"),
        ({"tol": 0.0}, ValueError, r"tol must be in \[1e-18, 0.01\]"),
        ({"bogus": 1}, TypeError, "does not accept"),
    ],
)
def test_bad_arguments(kwargs, exc, pattern):
    args = {"t_end": 10.0}
    args.update(kwargs)
    t_end = args.pop("t_end")
    with pytest.raises(exc, match=pattern):
        io.simulate(OSC, t_end, **args)


def test_osc_must_be_an_oscillator():
    with pytest.raises(TypeError, match="osc must be an impactosc.Oscillator"):
        io.simulate({"F": 0.5}, 10.0)


def test_tiny_and_default_runs():
    sol = io.simulate(OSC, 1e-9)
    assert sol.status == 0 and sol.t_final == 1e-9 and sum(sol.counts.values()) == 0
    assert sol.x0 == 0.95 and sol.v0 == 0.0  # the paper's eq. 6-7
