"""A MechanicalSystem and a tape path on heyoka and scipy give the exact backend's result type and numbers.

``simulate(system, ..., backend="heyoka" | "scipy")`` and ``simulate_path(..., backend=...)``
run the system's form as a user system and read the run as a ``MechanicalSolution``: the
same events (kinds and indices of the exact backend), the same dense output and the energy
terms of the identity ``work = Delta E + damping + friction + impact losses``. The exact
backend is the reference: its closed forms and the Taylor integrator agree to ~1e-12 on a
run of a few dozen events, scipy at ``rtol = atol = 1e-12`` to ~1e-9.
"""

from __future__ import annotations

import numpy as np
import pytest

import impactosc as io
from impactosc.model import Contact, Friction, MechanicalSystem


def chain(n: int = 3, *, springs: bool = False) -> MechanicalSystem:
    """``n`` unit masses in a chain, the first forced, the last between two stops; friction on the first."""
    K = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    K[-1, -1] = 1.0
    f = np.zeros(n)
    f[0] = 1.0
    last = np.eye(n)[-1]
    law = {"law": "spring", "stiffness": 100.0} if springs else {"law": "rigid", "restitution": 0.8}
    return MechanicalSystem(M=np.eye(n), C=0.02 * K + 0.01 * np.eye(n), K=K, harmonics=[(f, 0.8, 0.0)],
                            contacts=[Contact(last, 0.5, **law), Contact(-last, 0.5, **law)],
                            friction=[Friction(0, 0.5, 0.65)])


TOL = {"heyoka": 1e-9, "scipy": 1e-7}


@pytest.mark.parametrize("springs", [False, True], ids=["rigid", "spring"])
@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_events_samples_and_energy_terms_are_the_exact_backends(backend, springs):
    ms = chain(springs=springs)
    q0, v0 = [0.0, 0.0, 0.0], [0.0, 0.0, 0.6]
    exact = io.simulate(ms, 25.0, q0, v0, backend="exact")
    sol = io.simulate(ms, 25.0, q0, v0, backend=backend)
    assert isinstance(sol, io.MechanicalSolution) and sol.status == 0 and exact.status == 0, sol.message
    kinds = set(exact.events["kind"].tolist())
    assert {"impact" if not springs else "contact_start", "stick", "release"} <= kinds
    assert sol.events["kind"].tolist() == exact.events["kind"].tolist()
    assert sol.events["index"].tolist() == exact.events["index"].tolist()
    tol = TOL[backend]
    np.testing.assert_allclose(sol.events["t"], exact.events["t"], rtol=0, atol=tol)
    np.testing.assert_allclose(sol.events["v"], exact.events["v"], rtol=0, atol=100 * tol)
    times = np.linspace(0.0, 25.0, 37)
    for a, b in zip(sol.sample(times), exact.sample(times), strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=100 * tol)
    mine, ref = sol.energy_balance(), exact.energy_balance()
    assert mine["relative"] < 1e-9 if backend == "heyoka" else mine["relative"] < 1e-7
    for key in ("work", "delta_energy", "damping", "friction", "impacts"):
        assert mine[key] == pytest.approx(ref[key], rel=1e3 * tol, abs=1e3 * tol), key


def test_a_tape_path_on_heyoka_reads_as_on_the_exact_backend():
    path = io.TapePath(io.TapeDrive(clearance=40e-6, friction=0.0, damping_ratio=0.01),
                       [io.Guide(0.02, clearance=150e-6), io.Guide(0.05)], end_span=0.03)
    exact = io.simulate_path(path, 2e-3)
    run = io.simulate_path(path, 2e-3, backend="heyoka")
    assert run.status == 0 and exact.status == 0
    assert (exact.impacts_per_second() > 0).all()
    np.testing.assert_array_equal(run.impacts_per_second(), exact.impacts_per_second())
    np.testing.assert_allclose(run.flange_impulse(0), exact.flange_impulse(0), rtol=1e-8)
    np.testing.assert_allclose(run.mean_flange_force(), exact.mean_flange_force(), rtol=1e-8)
    t = np.linspace(0.0, 2e-3, 50)
    np.testing.assert_allclose(run.lateral_motion(t, 0.03), exact.lateral_motion(t, 0.03), rtol=0, atol=1e-12)


def test_a_chatter_the_exact_backend_rests_on_ends_the_hybrid_run_with_status_2():
    # one mass pushed onto a stop by a constant force: the rebounds accumulate; the exact
    # backend sums them into rest, the hybrid loops stop at the accumulation (status 2)
    ms = MechanicalSystem(M=[[1.0]], K=[[0.0]], harmonics=[([1.0], 0.0, 0.0)],
                          contacts=[Contact([1.0], 0.5, law="rigid", restitution=0.5)])
    exact = io.simulate(ms, 10.0, [0.0], [0.0], backend="exact")
    assert exact.status == 0 and "rest" in exact.events["kind"].tolist()
    sol = io.simulate(ms, 10.0, [0.0], [0.0], backend="heyoka")
    assert sol.status == 2 and "accumulat" in sol.message.lower()
    assert sol.t < 10.0 and set(sol.events["kind"].tolist()) == {"impact"}


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_record_and_sample_at_are_refused_as_on_the_exact_backend(backend):
    with pytest.raises(ValueError, match="record and sample_at"):
        io.simulate(chain(), 1.0, [0.0] * 3, [0.0] * 3, backend=backend, record="stats")
    with pytest.raises(ValueError, match="backend"):
        io.simulate_path(io.TapePath(io.TapeDrive(), [io.Guide(0.02)]), 1e-3, backend="rk4")
