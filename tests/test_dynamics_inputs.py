"""The dynamics tools refuse bad input as simulate does, and name the argument and the rule (issue 20, items 6, 8).

Every entry point that runs the model from a user's state (monodromy, periodic_orbit,
lyapunov_exponent, contact_margin, contact_onset, the sections) checks that state with
``simulate``'s own checks, so the same input gets the same clear error everywhere.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactosc import Oscillator, simulate
from impactosc.dynamics import (
    contact_margin,
    contact_onset,
    den_hartog_amplitude,
    den_hartog_multipliers,
    den_hartog_onset,
    detect_period,
    lyapunov_exponent,
    monodromy,
    periodic_orbit,
)

RIGID = Oscillator(0.8, 0.7, 0.02, 1e4, flange="rigid", restitution=0.7)
SPRING = Oscillator(0.5, 1.1, 0.01, 1e4)
BACKENDS = ["heyoka", "exact", "scipy"]
BEYOND_WALL = r"x0 must satisfy -1 <= x0 <= 1 with a rigid flange"


# -- item 6: simulate's checks at every entry point ----------------------------------------
@pytest.mark.parametrize("backend", BACKENDS)
def test_monodromy_refuses_a_start_beyond_a_rigid_wall_like_simulate(backend):
    with pytest.raises(ValueError, match=BEYOND_WALL):
        simulate(RIGID, 1.0, 1.5, 0.0, backend=backend)
    with pytest.raises(ValueError, match=BEYOND_WALL):
        monodromy(RIGID, 1.5, 0.0, backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("x0, v0, message", [
    (math.nan, 0.0, "x0 must be finite, got nan"),
    (0.0, math.inf, "v0 must be finite, got inf"),
    (0.0, 1e200, r"v0=1e\+200 is too large for double precision"),
])
def test_monodromy_refuses_a_state_simulate_refuses(backend, x0, v0, message):
    with pytest.raises(ValueError, match=message):
        monodromy(SPRING, x0, v0, backend=backend)


def test_monodromy_refuses_a_non_number():
    with pytest.raises(TypeError, match="x0 must be a real number"):
        monodromy(SPRING, "0.5", 0.0)
    with pytest.raises(ValueError, match="t0 must be finite"):
        monodromy(SPRING, 0.5, 0.0, t0=math.nan)


def test_every_dynamics_entry_point_checks_its_start():
    with pytest.raises(ValueError, match=r"guess\[0\].*" + BEYOND_WALL):
        periodic_orbit(RIGID, guess=(1.5, 0.0), backend="exact")
    with pytest.raises(ValueError, match=BEYOND_WALL):
        periodic_orbit(RIGID, x0=1.5, transient_periods=0, backend="exact")
    with pytest.raises(ValueError, match=BEYOND_WALL):
        lyapunov_exponent(RIGID, 5, x0=1.5, transient_periods=0, backend="exact")
    with pytest.raises(ValueError, match=BEYOND_WALL):
        contact_margin(RIGID, x0=1.5, stop_at_contact=True, backend="exact")
    with pytest.raises(ValueError, match=r"v0=1e\+200 is too large"):
        contact_margin(SPRING, v0=1e200, stop_at_contact=True, backend="exact")
    with pytest.raises(ValueError, match=BEYOND_WALL):
        contact_onset(RIGID, "F", (0.5, 0.9), x0=1.5, backend="exact")
    with pytest.raises(ValueError, match=r"guess\[0\].*" + BEYOND_WALL):
        contact_onset(RIGID, "F", (0.5, 0.9), guess=(1.5, 0.0))
    with pytest.raises(ValueError, match=BEYOND_WALL):
        contact_onset(RIGID, "F", (0.5, 0.9), method="transient", x0=1.5, backend="exact")


def test_monodromy_returns_a_named_result_that_still_unpacks():
    m = monodromy(SPRING, 0.5, 0.1, backend="exact")
    x, v, jac, rec = m  # the old 4-tuple
    assert (x, v) == (m.x, m.v) and jac is m.jacobian and rec is m.recorder
    assert m[:2] == (m.x, m.v)
    sol = simulate(SPRING, 2 * math.pi / 1.1, 0.5, 0.1, backend="exact")
    assert (m.x, m.v) == pytest.approx((sol.x_final, sol.v_final), abs=1e-14)
    assert m.differentiable and m.reason == "" and not m.collapsed
    mus = np.linalg.eigvals(jac)
    np.testing.assert_allclose(np.sort_complex(m.multipliers), np.sort_complex(mus), rtol=1e-12)
    assert list(m.events.kind) == list(sol.events.kind)
    with pytest.raises(AttributeError):
        m.x = 0.0  # frozen


# -- item 8: unclear errors -----------------------------------------------------------------
def test_detect_period_checks_its_arguments():
    with pytest.raises(ValueError, match="x and v must have the same length.*got 6 and 2"):
        detect_period([1, 2, 3, 1, 2, 3], [0, 0])
    with pytest.raises(ValueError, match="tol must be >= 0, got -1"):
        detect_period([1.0] * 4, [0.0] * 4, tol=-1.0)
    with pytest.raises(ValueError, match="x must be one-dimensional"):
        detect_period([[1.0, 1.0]] * 2, [[0.0, 0.0]] * 2)
    with pytest.raises(ValueError, match="max_period must be >= 1"):
        detect_period([1.0] * 4, [0.0] * 4, max_period=0)
    assert detect_period([1, 2, 1, 2], [0, 0, 0, 0]) == 2


def test_den_hartog_closed_forms_at_and_near_their_singular_points():
    for f in (lambda: den_hartog_amplitude(0.5, 0.0, 0.01), lambda: den_hartog_onset(0.0, 0.01),
              lambda: den_hartog_multipliers(0.5, 0.0, 0.01)):
        with pytest.raises(ValueError, match="Omega must be > 0, got 0.0"):
            f()
    with pytest.raises(ValueError, match="beta must be >= 0"):
        den_hartog_amplitude(0.5, 0.5, -0.01)
    with pytest.raises(ValueError, match="F must be finite"):
        den_hartog_amplitude(math.nan, 0.5, 0.01)
    # At the resonance the onset is the limit 4 beta / pi (Den Hartog: unbounded above it), and
    # the formula is continuous through it.
    assert den_hartog_onset(1.0, 0.01) == pytest.approx(0.04 / math.pi, rel=1e-14)
    assert den_hartog_onset(1.0 + 1e-6, 0.01) == pytest.approx(0.04 / math.pi, rel=1e-5)
    assert den_hartog_amplitude(0.5, 1.0, 0.01) == math.inf  # F > 4 beta / pi: unbounded
    assert math.isnan(den_hartog_amplitude(0.01, 1.0, 0.01))  # F < 4 beta / pi: no non-stop motion
    assert np.all(np.isnan(den_hartog_multipliers(0.5, 1.0, 0.01)))
    # Where the amplitude is NaN (documented), so are the multipliers (not a LinAlgError).
    assert math.isnan(den_hartog_amplitude(0.1, 0.5, 0.3))
    assert np.all(np.isnan(den_hartog_multipliers(0.1, 0.5, 0.3)))
    # Unchanged away from the singular points (the textbook form).
    G, q = 0.5 / (1 - 0.25), 0.01 * math.tan(math.pi / 1.0) / 0.5
    assert den_hartog_amplitude(0.5, 0.5, 0.01) == pytest.approx(math.sqrt(G * G - q * q), rel=1e-14)


def test_lyapunov_runs_the_periods_asked_for():
    with pytest.raises(ValueError, match="renormalise_every must be <= periods.*periods=3.*renormalise_every=10"):
        lyapunov_exponent(SPRING, 3, renormalise_every=10, transient_periods=0, backend="exact")
    res = lyapunov_exponent(SPRING, 25, renormalise_every=10, transient_periods=0, backend="exact")
    T = 2 * math.pi / 1.1
    np.testing.assert_allclose(res.t, [10 * T, 20 * T, 25 * T], rtol=1e-14)


def test_dynamics_tools_refuse_runs_that_would_take_minutes():
    # simulate's cost rules (issue 20 item 7) hold for the tangent runs of the dynamics tools too
    with pytest.raises(ValueError, match="zeta"):
        monodromy(Oscillator(0.5, 1.1, 0.01, 1e4, zeta=1e5), 0.1, 0.0, backend="exact")
