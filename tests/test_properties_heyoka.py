"""Property-based tests of energy, contact and friction invariants (heyoka backend).

The CI profile (tests/conftest.py) keeps these within a few seconds each; run with
HYPOTHESIS_PROFILE=dev to dig deeper.
"""

import math

import numpy as np
from hypothesis import example, given
from invariants import assert_contact_alternation, assert_friction_invariants, assert_same_events, assert_sound
from strategies import end_times, oscillators, positions, velocities

import impactosc as io


@given(osc=oscillators, x0=positions, v0=velocities, t_end=end_times)
@example(osc=io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), x0=0.95, v0=0.0, t_end=40.0)
# Regressions found by hypothesis, each a bug fixed in the engine or the heyoka backend:
# a turning point exactly on the flange boundary (double root of the leave guard);
@example(osc=io.Oscillator(F=0.0, Omega=0.0, beta=0.0, K=1.0), x0=-1.0, v0=-2.643715195751675e-112, t_end=1.0)
# a second turning point inside the first heyoka step after a reversal (root at tau=0 masked it);
@example(osc=io.Oscillator(F=1.28125, Omega=1.0, beta=0.1, K=1e4, phase=math.pi), x0=0.75, v0=0.0, t_end=13.0)
@example(osc=io.Oscillator(F=1.0, Omega=1.0, beta=0.1, K=1.0, phase=5.0), x0=1.0, v0=0.0, t_end=2.0)
# starting exactly on the friction threshold at a stationary point of the forcing;
@example(osc=io.Oscillator(F=0.5, Omega=1.0, beta=0.5, K=1.0, phase=math.pi), x0=0.0, v0=0.0, t_end=1.0)
# a threshold within rounding (beta = 1e-173, f_net = 0): heyoka's root finder gave up;
@example(osc=io.Oscillator(F=1.0, Omega=1.0, beta=1.0856050975323129e-173, K=1.0), x0=1.0, v0=0.0, t_end=1.0)
# heyoka's time landing one ulp past t_end.
@example(osc=io.Oscillator(F=1.0, Omega=0.0, beta=0.1, K=1e4, phase=5.5), x0=0.0, v0=0.0, t_end=27.422468623715833)
def test_robust_energy_identity(osc, x0, v0, t_end):
    sol = io.simulate(osc, t_end, x0, v0, record="stats")
    # Robustness (ends where asked, finite) and the energy identity.
    assert_sound(sol, t_end)


@given(osc=oscillators, x0=positions, v0=velocities, t_end=end_times)
def test_contact_invariants(osc, x0, v0, t_end):
    sol = io.simulate(osc, t_end, x0, v0)
    assert_contact_alternation(sol)
    for im in sol.impacts:
        assert im.end > im.start or not im.complete
        if im.complete:
            # Entering means moving into the flange (at rest only for a contact that starts
            # from a release or an exact graze on the boundary); leaving means moving out.
            assert im.entry_velocity * im.side >= 0
            assert im.exit_velocity * im.side <= 0
        assert im.peak_force == osc.K * im.peak_penetration
        assert im.peak_penetration >= 0 and im.impulse >= -1e-12
    # No sample beyond a flange outside a recorded contact (and the force is zero inside).
    ts = np.linspace(0.0, t_end, 397)
    xs, _ = sol.sample(ts)
    beyond = np.abs(xs) > 1.0 + 1e-12
    im = sol.impacts
    for t in ts[beyond]:
        assert np.any((im.start <= t) & (t <= im.end)), f"|X| > 1 at t={t} outside every contact"
    assert np.all(osc.flange_force(xs[np.abs(xs) <= 1.0]) == 0.0)


@given(osc=oscillators, x0=positions, v0=velocities, t_end=end_times)
def test_friction_invariants(osc, x0, v0, t_end):
    assert_friction_invariants(io.simulate(osc, t_end, x0, v0))


@given(osc=oscillators.filter(lambda o: o.F == 0.0), x0=positions, v0=velocities, t_end=end_times)
def test_unforced_energy_never_increases(osc, x0, v0, t_end):
    sol = io.simulate(osc, t_end, x0, v0)
    ev = sol.events
    energies = np.concatenate(([osc.energy(x0, v0)], osc.energy(ev.x, ev.v), [osc.energy(sol.x_final, sol.v_final)]))
    assert np.all(np.diff(energies) <= 1e-12 * max(1.0, energies[0]))
    assert sol.forcing_work == 0.0


@given(osc=oscillators, x0=positions, v0=velocities, t_end=end_times)
def test_mirror_symmetry(osc, x0, v0, t_end):
    """Mirroring the initial state and shifting the forcing by pi mirrors every event."""
    a = io.simulate(osc, t_end, x0, v0)
    b = io.simulate(osc.mirrored(), t_end, -x0, -v0)
    assert_same_events(a, b, t_tol=1e-8, x_sign=-1, side_sign=-1)
