"""A MechanicalSystem written as a user hybrid system: exact against heyoka against scipy.

The exact closed-form backend (``simulate_mechanical``) and the two loops of user hybrid
systems (heyoka's Taylor integrator, scipy's ``solve_ivp``) run the same physics from two
definitions (the compiled closed forms, and :func:`mechanical_system`'s expressions): their
events must agree one by one, within 1e-10 (exact vs heyoka, both at machine precision) and
1e-8 (scipy at ``rtol = atol = 1e-12``). The systems are chaotic over long runs (an impact
amplifies a difference by a few times), so the runs are short enough (a few dozen events)
that the rounding of either side stays far below the tolerances.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

import impactosc
from impactosc.model import Contact, Friction, MechanicalSystem
from impactosc.model.hybrid import mechanical_system, oscillator_system
from impactosc.model.hybrid._mechanical_system import MAX_MODES, event_of

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mdof_systems import initial_state, random_system  # noqa: E402

EXACT_HEYOKA = 1e-10
EXACT_SCIPY = 1e-8
#: hypothesis examples: each one compiles a heyoka integrator (seconds), so fewer than the profile's
EXAMPLES = 4 if settings().max_examples <= 40 else 20


def chain(n: int = 4, *, friction: bool = False, springs: bool = False, restitution: float = 0.9):
    """``n`` unit masses in a chain of unit springs, the first forced, the last between two stops at +-0.5."""
    K = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    K[-1, -1] = 1.0
    f = np.zeros(n)
    f[0] = 1.0
    last = np.eye(n)[-1]
    law = {"law": "spring", "stiffness": 100.0} if springs else {"law": "rigid", "restitution": restitution}
    return MechanicalSystem(M=np.eye(n), C=0.02 * K + 0.01 * np.eye(n), K=K, harmonics=[(f, 0.8, 0.0)],
                            contacts=[Contact(last, 0.5, **law), Contact(-last, 0.5, **law)],
                            friction=[Friction(0, 0.05, 0.07)] if friction else [])


def hybrid_events(ms: MechanicalSystem, sol) -> list[tuple[float, str, int]]:
    """The crossings of a hybrid run as ``(t, kind, index)`` in the exact backend's vocabulary."""
    return [(e.t, *event_of(ms, e.guard, e.mode_after)) for e in sol.events if e.kind == "crossing"]


def exact_events(sol) -> list[tuple[float, str, int]]:
    ev = sol.events
    return [(float(t), str(k), int(i)) for t, k, i in zip(ev["t"], ev["kind"], ev["index"], strict=True)]


#: Rounding of a position of order one (a gap, a coordinate at an impact) that the backends may differ by.
POSITION_ROUNDING = 1e-15


def impact_tolerances(ms: MechanicalSystem, sol, tol: float) -> list[float]:
    """Per event of the exact run ``sol``: ``tol``, or for an impact at approach speed ``u`` at least
    ``POSITION_ROUNDING / u``, the time in which the rounding of the gap is crossed at that speed. A
    chatter's last impacts come at speeds of 1e-6 and below, where the backends' last-bit differences
    of the state move the impact times by ~1e-10 (seen: 1.6e-10 at an approach speed of 2.3e-6)."""
    out = []
    for e in sol.events:
        if e["kind"] == "impact":
            contact = ms.contacts[int(e["index"])]
            u = abs(float(contact.normal @ e["v"])) / max(contact.restitution, 1e-300)
            out.append(max(tol, POSITION_ROUNDING * max(1.0, contact.gap) / u) if u > 0.0 else tol)
        else:
            out.append(tol)
    return out


def assert_agree(reference, other, tol, *, label: str):
    """``other``'s events are ``reference``'s, one by one, times within ``tol`` (a float, or one per event)."""
    assert len(other) == len(reference), f"{label}: {len(other)} events against {len(reference)}"
    tols = [tol] * len(reference) if isinstance(tol, float) else tol
    for k, (a, b) in enumerate(zip(reference, other, strict=True)):
        assert a[1:] == b[1:], f"{label}: event {k} is {b} against {a}"
        assert abs(a[0] - b[0]) <= tols[k], f"{label}: event {k} ({a[1]}) at {b[0]!r} against {a[0]!r}"


def three_way(ms: MechanicalSystem, t_end: float, q0, v0, *, min_events: int = 1,
              backends=(("heyoka", EXACT_HEYOKA), ("scipy", EXACT_SCIPY))):
    """Run the three backends on ``ms`` and check that their events agree; the heyoka run.

    Where the exact backend lets the system come to rest on a stop (its chatter rule: the
    rebounds are summed once they are below the rounding of the gap), the hybrid loops go
    on bouncing until they declare the accumulation (status 2): up to the rest the events
    agree, after it the hybrid runs may only add impacts on that stop, and their estimate of
    the accumulation time is the rest's time within the flights the rule summed (1e-5 here).
    """
    system = mechanical_system(ms)
    exact = impactosc.simulate_mechanical(ms, t_end, q0, v0)
    assert exact.status == 0, exact.message
    reference = exact_events(exact)
    rest = next((k for k, e in enumerate(reference) if e[1] == "rest"), None)
    if rest is not None:
        reference = reference[:rest]
    assert len(reference) >= min_events
    runs = {}
    for backend, tol in backends:
        sol = impactosc.simulate(system, t_end, [*q0, *v0], backend=backend)
        events = hybrid_events(ms, sol)
        if rest is None:
            assert sol.status == 0, f"{backend}: {sol.message}"
        else:
            assert sol.status == 2, f"{backend} does not accumulate where the exact run rests: {sol.message}"
            t_rest, _, stop = exact_events(exact)[rest]
            assert abs(sol.accumulation_time - t_rest) <= 1e-5, backend
            tail = events[len(reference):]
            assert all(e[1:] == ("impact", stop) and t_rest - tol <= e[0] <= sol.accumulation_time for e in tail), \
                f"{backend}: after the rest at {t_rest!r} on stop {stop}: {tail}"
            events = events[:len(reference)]
        assert_agree(reference, events, impact_tolerances(ms, exact, tol)[:len(reference)], label=backend)
        runs[backend] = sol
    return runs


# -- the definition -----------------------------------------------------------------------------


def test_modes_and_states_of_a_chain_with_friction_and_springs():
    system = mechanical_system(chain(3, friction=True, springs=True))
    assert system.states == ("q0", "q1", "q2", "v0", "v1", "v2")
    assert len(system.modes) == 2**2 * 3
    assert "c0in/c1out/q0-" in system.mode_names
    assert system.integrals == ("work", "damping", "friction")
    assert system.period_value() == pytest.approx(2.0 * math.pi / 0.8, rel=1e-15)
    assert mechanical_system(chain(2), energy=False).integrals == ()


def test_refuses_a_nonlinear_spring_naming_it():
    ms = MechanicalSystem(M=np.eye(2), K=np.eye(2), contacts=[Contact([1.0, 0.0], 0.5, law="rigid"),
                                                             Contact([0.0, 1.0], 0.5, stiffness=10.0, exponent=1.5)])
    with pytest.raises(ValueError, match=r"contacts\[1\]\.exponent = 1\.5"):
        mechanical_system(ms)


def test_refuses_friction_coordinates_coupled_by_the_mass_matrix_naming_them():
    M = [[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]]
    coupled = MechanicalSystem(M=M, K=np.eye(3), friction=[Friction(0, 0.1), Friction(1, 0.1)])
    with pytest.raises(ValueError, match=r"friction\[0\] \(coordinate 0\) and friction\[1\] \(coordinate 1\)"):
        mechanical_system(coupled)
    # uncoupled by M^-1: each stick test on its own, 3 x 3 modes
    uncoupled = MechanicalSystem(M=M, K=np.eye(3), friction=[Friction(0, 0.1), Friction(2, 0.1)])
    assert len(mechanical_system(uncoupled).modes) == 9


def test_refuses_more_modes_than_the_bound():
    n = 4
    springs = [Contact(np.eye(n)[i % n] * (1 if i < n else -1), 0.5, stiffness=10.0) for i in range(2 * n)]
    ms = MechanicalSystem(M=np.eye(n), K=np.eye(n), contacts=springs[:6])
    assert 2**6 > MAX_MODES
    with pytest.raises(ValueError, match=r"2\^6 \* 3\^0 = 64 modes, above the bound MAX_MODES"):
        mechanical_system(ms)


def test_refuses_expressions_too_long_for_heyoka_to_print_in_full():
    """heyoka abbreviates a long expression's text, by which the hybrid backends know it."""
    assert len(mechanical_system(random_system(0, 10, laws=("rigid",), friction=0, contacts=1)).modes) == 1
    with pytest.raises(ValueError, match=r"mode 'free': the rate of v\d+ prints over heyoka's limit"):
        mechanical_system(random_system(0, 20, laws=("rigid",), friction=0, contacts=1))


def test_refuses_what_is_not_a_mechanical_system():
    with pytest.raises(TypeError, match="ms must be an impactosc.MechanicalSystem"):
        mechanical_system(impactosc.Oscillator(0.5, 1.1, 0.0, 1e4))


# -- one degree of freedom: the oscillator family's own user system -------------------------------


@pytest.mark.parametrize("osc", [
    impactosc.Oscillator(0.5, 1.1, 0.05, 50.0, zeta=0.02),
    impactosc.Oscillator(0.9, 0.8, 0.0, flange="rigid", restitution=1.0, zeta=0.01),
], ids=["spring flanges, friction", "rigid flanges"])
def test_one_degree_of_freedom_agrees_with_oscillator_system(osc):
    ms = MechanicalSystem.from_oscillator(osc)
    mine = impactosc.simulate(mechanical_system(ms), 40.0, [0.0, 0.3])
    theirs = impactosc.simulate(oscillator_system(osc), 40.0, [0.0, 0.3])
    assert mine.status == theirs.status == 0
    a = [e for e in mine.events if e.kind == "crossing"]
    # without friction (beta = 0) oscillator_system still switches its slip modes where V changes sign
    b = [e for e in theirs.events if e.kind == "crossing" and (osc.beta > 0.0 or e.guard.startswith("impact"))]
    assert len(a) == len(b) >= 6
    for x, y in zip(a, b, strict=True):
        assert abs(x.t - y.t) <= 1e-12 * (1.0 + abs(y.t))
        assert np.allclose(x.state_after[:2], y.state_after[:2], rtol=0.0, atol=1e-11)


# -- exact against heyoka against scipy ------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("ms, t_end, min_events", [
    (chain(4), 25.0, 14),
    (chain(4, friction=True), 25.0, 20),
    (chain(4, springs=True), 25.0, 20),
], ids=["n=4 rigid", "n=4 rigid + friction", "n=4 springs"])
def test_fixed_systems_three_way(ms, t_end, min_events):
    three_way(ms, t_end, np.zeros(ms.n), np.zeros(ms.n), min_events=min_events)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_chatter_on_a_stop_ends_where_the_exact_run_rests(backend):
    ms = chain(3, restitution=0.3)
    tol = EXACT_HEYOKA if backend == "heyoka" else EXACT_SCIPY
    three_way(ms, 40.0, np.zeros(3), np.zeros(3), min_events=5, backends=[(backend, tol)])


@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 6),
       laws=st.sampled_from([("spring",), ("rigid",), ("spring", "rigid")]), friction=st.integers(0, 1),
       contacts=st.integers(1, 3), elastic=st.booleans())
# releases from sticking with mu_s = mu_k (a tangency of the slip-end guard) that the loops once took for a
# stop lost to rounding: a spurious stick and release at the same instant, then a failed root search
@example(seed=0, n=2, laws=("spring",), friction=1, contacts=2, elastic=False)
@example(seed=135, n=2, laws=("spring",), friction=1, contacts=2, elastic=False)
def test_random_systems_three_way(seed, n, laws, friction, contacts, elastic):
    try:
        ms = random_system(seed, n, laws=laws, friction=friction, contacts=contacts, orthogonal=True,
                           restitution=(1.0, 1.0) if elastic else (0.6, 1.0))
    except ValueError as exc:  # n = 2: a stop made orthogonal to the friction coordinate lies along it
        assume("act along the same line" not in str(exc))
        raise
    q0, v0 = initial_state(seed, n)
    three_way(ms, 15.0, q0, v0, min_events=0)


# -- the energy identity on the heyoka run ----------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("ms", [chain(4, friction=True), chain(4, springs=True),
                                random_system(7, 3, friction=1, orthogonal=True)],
                         ids=["rigid + friction", "springs", "random n=3"])
def test_energy_identity_on_the_heyoka_run(ms):
    """``work = Delta E + damping + friction + impact losses`` from the run's integrals and events."""
    q0, v0 = initial_state(7, ms.n)
    sol = impactosc.simulate(mechanical_system(ms), 30.0, [*q0, *v0])
    assert sol.status == 0, sol.message
    n = ms.n
    end = sol.state_final
    delta = float(ms.energy(end[:n], end[n:2 * n]) - ms.energy(q0, v0))
    losses = 0.0
    for e in sol.events:
        if e.kind == "crossing" and e.guard.startswith("impact"):
            before, after = np.array(e.state_before[n:2 * n]), np.array(e.state_after[n:2 * n])
            losses += 0.5 * float(before @ ms.M @ before - after @ ms.M @ after)
    work, damping, friction = (sol.integrals[k] for k in ("work", "damping", "friction"))
    assert damping > 0.0
    residual = work - delta - damping - friction - losses
    scale = max(abs(work), abs(delta), damping, friction, losses)
    assert abs(residual) <= 1e-9 * scale, (work, delta, damping, friction, losses)


# -- grazing: an extreme of a gap within 1e-12 of the contact ---------------------------------------


def _grazing_setup():
    """A 3-DOF system, a direction ``n`` and the maximum of ``n . q(t)`` of its free motion (closed form)."""
    from scipy.optimize import minimize_scalar

    rng = np.random.default_rng(3)
    n = 3
    A = rng.normal(size=(n, n))
    B = rng.normal(size=(n, n))
    data = {"M": A @ A.T / n + np.eye(n), "K": B @ B.T / n + 0.5 * np.eye(n), "C": 0.05 * np.eye(n),
            "harmonics": [(rng.normal(size=n), 0.9, 0.3)]}
    normal = rng.normal(size=n)
    normal /= np.linalg.norm(normal)
    q0, v0 = np.zeros(n), rng.normal(size=n)
    free = impactosc.simulate_mechanical(MechanicalSystem(**data), 10.0, q0, v0)
    ts = np.linspace(0.0, 10.0, 2001)
    height = free.sample(ts)[0] @ normal
    i = int(np.argmax(height[1:-1])) + 1
    found = minimize_scalar(lambda t: -float(free.sample([t])[0][0] @ normal), bracket=(ts[i - 1], ts[i], ts[i + 1]),
                            tol=1e-14)
    return data, normal, q0, v0, float(found.x), -float(found.fun)


@pytest.fixture(scope="module")
def grazing():
    return _grazing_setup()


@pytest.mark.slow
@pytest.mark.parametrize("delta", [-1e-12, -3e-13, 3e-13, 1e-12])
def test_grazing_a_rigid_stop_no_backend_misses_the_contact(grazing, delta):
    """The stop sits ``delta`` above the free motion's maximum of ``n . q``: an impact iff ``delta < 0``."""
    data, normal, q0, v0, t_top, top = grazing
    assert top > 0.1
    ms = MechanicalSystem(**data, contacts=[Contact(normal, top + delta, law="rigid", restitution=0.8)])
    t_end = t_top + 0.5
    exact = impactosc.simulate_mechanical(ms, t_end, q0, v0)
    assert list(exact.events["kind"]) == (["impact"] if delta < 0 else [])
    system = mechanical_system(ms)
    for backend in ("heyoka", "scipy"):
        sol = impactosc.simulate(system, t_end, [*q0, *v0], backend=backend)
        assert sol.status == 0, sol.message
        crossings = [e.t for e in sol.events if e.kind == "crossing"]
        if delta < 0:
            assert len(crossings) == 1, backend
            assert abs(crossings[0] - exact.events["t"][0]) <= 1e-5, backend  # sqrt(|delta| / |n.q''|)
        else:
            assert crossings == [], backend


@pytest.mark.slow
@pytest.mark.parametrize("delta", [-1e-12, -1e-10, -1e-6, 1e-12])
def test_grazing_a_spring_contact_closes_and_opens(grazing, delta):
    """A spring contact ``delta`` above the free maximum: it closes and opens again iff ``delta < 0``
    (the opening is the first root of a guard that starts on zero: see ``_fires``)."""
    data, normal, q0, v0, t_top, top = grazing
    ms = MechanicalSystem(**data, contacts=[Contact(normal, top + delta, law="spring", stiffness=100.0)])
    t_end = t_top + 0.5
    exact = exact_events(impactosc.simulate_mechanical(ms, t_end, q0, v0))
    assert [k for _, k, _ in exact] == (["contact_start", "contact_end"] if delta < 0 else [])
    system = mechanical_system(ms)
    for backend in ("heyoka", "scipy"):
        sol = impactosc.simulate(system, t_end, [*q0, *v0], backend=backend)
        assert sol.status == 0, sol.message
        events = hybrid_events(ms, sol)
        assert [e[1:] for e in events] == [e[1:] for e in exact], backend
        for a, b in zip(exact, events, strict=True):
            assert abs(a[0] - b[0]) <= 1e-5, backend  # sqrt(|delta| / |n.q''|) at a grazing


# -- the analyses of user systems on a mechanical system ----------------------------------------------


def test_periodic_orbit_of_a_forced_two_mass_system_is_its_closed_form():
    """No contact: the steady response ``q = Re(X e^{i w t})``, ``(K - w^2 M + i w C) X = f e^{i phi}``, and
    the Floquet multipliers ``exp(lambda T)`` of the first-order matrix ``A = [[0, I], [-M^-1 K, -M^-1 C]]``."""
    from scipy.linalg import expm

    from impactosc.dynamics.hybrid_map import HybridMap, periodic_orbit_of

    M = np.array([[2.0, 0.3], [0.3, 1.0]])
    K = np.array([[3.0, -1.0], [-1.0, 1.5]])
    C = np.array([[0.1, 0.2], [-0.2, 0.05]])  # with a gyroscopic (skew) part
    f, om, ph = np.array([1.0, -0.5]), 1.3, 0.4
    ms = MechanicalSystem(M=M, C=C, K=K, harmonics=[(f, om, ph)])
    X = np.linalg.solve(K - om**2 * M + 1j * om * C, f * np.exp(1j * ph))
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    orbit = periodic_orbit_of(HybridMap(mechanical_system(ms, energy=False)), np.zeros(4))
    assert orbit.status == 0, orbit.message
    assert np.allclose(orbit.z, np.r_[X.real, -om * X.imag], rtol=0.0, atol=1e-12)
    expected = np.linalg.eigvals(expm(A * 2.0 * np.pi / om))
    assert np.allclose(np.sort_complex(orbit.multipliers), np.sort_complex(expected), rtol=0.0, atol=1e-12)


@pytest.mark.slow
def test_impacting_periodic_orbit_of_a_chain_returns_under_the_exact_backend():
    """The fixed point of the stroboscopic map (heyoka, saltation matrices) is one of the exact backend too,
    and its monodromy obeys Liouville's rule: each impact multiplies the determinant by ``e^2`` (its
    reset ``-e`` along ``M^-1 n``, its crossing speeds ``n.v+ / n.v- = -e``), the flow by
    ``exp(-trace(M^-1 C) T)``."""
    from impactosc.dynamics.hybrid_map import HybridMap, periodic_orbit_of

    ms = chain(2, restitution=0.8)
    period = 2.0 * math.pi / 0.8
    settled = impactosc.simulate_mechanical(ms, 300 * period, np.zeros(2), np.zeros(2), energy=False)
    orbit = periodic_orbit_of(HybridMap(mechanical_system(ms, energy=False)), np.r_[settled.q, settled.v])
    assert orbit.status == 0, orbit.message
    impacts = [g for g, _, _ in orbit.signature if g.startswith("impact")]
    assert len(impacts) >= 2
    back = impactosc.simulate_mechanical(ms, period, orbit.z[:2], orbit.z[2:])
    assert len(back.events) == len(impacts)
    assert np.allclose(np.r_[back.q, back.v], orbit.z, rtol=0.0, atol=1e-9)
    liouville = 0.8 ** (2 * len(impacts)) * math.exp(-np.trace(ms.minv @ ms.C) * period)
    assert np.linalg.det(orbit.monodromy) == pytest.approx(liouville, rel=1e-8)


def test_simulate_runs_a_mechanical_system_on_every_event_locating_backend():
    # one entry point: the exact n-DOF backend by default ("auto" too), heyoka and scipy through the
    # system's form as a user system; the same impacts at the same times
    import numpy as np

    import impactosc as io

    system = io.MechanicalSystem(M=np.eye(2), K=[[2.0, -1.0], [-1.0, 1.0]], harmonics=[([1.0, 0.0], 0.9, 0.0)],
                                 contacts=[io.Contact([0.0, 1.0], 1.0, law="rigid", restitution=0.7)])
    exact = io.simulate(system, 30.0, [0.0, 0.0], [0.0, 0.0], backend="exact")
    assert exact.status == 0
    t_exact = exact.events["t"][exact.events["kind"] == "impact"]
    assert t_exact.size > 0
    for backend, tol in (("heyoka", 1e-10), ("scipy", 1e-7)):
        sol = io.simulate(system, 30.0, [0.0, 0.0], [0.0, 0.0], backend=backend)
        assert isinstance(sol, io.MechanicalSolution) and sol.status == 0, sol.message
        t = sol.events["t"][sol.events["kind"] == "impact"]
        assert t.shape == t_exact.shape and np.max(np.abs(t - t_exact)) < tol, (backend, t, t_exact)
