"""Hypothesis strategies shared by the property-based tests."""

import math

from hypothesis import strategies as st

import impactosc as io


def _with_exact(values, inner):
    """Mix exact special values (0, 1, ...) into a float strategy: degeneracies live there."""
    return st.one_of(st.sampled_from(values), inner)


oscillators = st.builds(
    io.Oscillator,
    F=_with_exact([0.0, 0.5, 1.0], st.floats(0.0, 2.5, allow_subnormal=False)),  # exact refuses subnormal F
    Omega=_with_exact([0.0, 1.0], st.floats(0.0, 3.0)),
    beta=_with_exact([0.0, 0.1], st.floats(0.0, 0.6)),
    K=_with_exact([1.0, 24.0, 1e4], st.floats(0.0, 6.0).map(lambda e: 10.0**e)),
    phase=_with_exact([0.0, math.pi], st.floats(0.0, 2 * math.pi)),
)
positions = _with_exact([0.0, 1.0, -1.0, 0.95], st.floats(-1.3, 1.3))
velocities = _with_exact([0.0, 1.0, -1.0], st.floats(-2.5, 2.5))
end_times = st.floats(0.5, 40.0)
