"""Regressions of issue 25: energy of chatter tails, hostile gaps, the CLI, plots and defaults."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

import impactosc as io

BACKENDS = ("heyoka", "scipy", "exact")


# -- the energy identity over a chatter tail on a wall that is not at |X| = 1 ----------------

def _balance(osc, t_end, backend, x0=0.0, v0=0.0):
    sol = io.simulate(osc, t_end, x0, v0, backend=backend)
    return sol, sol.energy_balance()


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_chatter_tail_books_the_forcing_work_against_the_wall_where_it_is(backend):
    # A constant push F = 2 drives the mass from rest at 0 onto the upper wall at X = 0.5,
    # where it chatters to rest: the forcing does the work F * 0.5 = 1 in total (the mass
    # ends at the wall, at rest), whatever the backend and however the tail is resolved.
    osc = io.Oscillator(2.0, 0.0, 0.1, flange="rigid", restitution=0.5, gap_upper=0.5)
    sol, bal = _balance(osc, 15.0, backend)
    assert sol.status == 0 and sol.counts["chatter"] == 1
    assert bal["forcing_work"] == pytest.approx(1.0, rel=1e-12)
    assert abs(bal["residual"]) <= 1e-12 * bal["scale"]


gaps = st.one_of(st.just(1.0), st.floats(0.2, 3.0))


@given(push=st.floats(1.1, 4.0), beta=st.floats(0.0, 0.2), e=st.floats(0.1, 0.9),
       gap_lower=st.one_of(st.none(), gaps), gap_upper=gaps, side=st.sampled_from([1, -1]))
def test_the_energy_identity_holds_on_rigid_walls_at_any_gap(push, beta, e, gap_lower, gap_upper, side):
    # A constant force (Omega = 0) of `push` times the wall's gap drives the mass from rest
    # onto one wall, where it chatters to rest or rebounds. heyoka's and scipy's forcing work
    # must match the exact backend's closed form to their event-time tolerance (rtol 1e-10;
    # the work is the force times a displacement of order the gap), and the identity must close.
    if gap_lower is None:
        side = 1
    osc = io.Oscillator(push * (gap_upper if side == 1 else gap_lower), 0.0, beta, phase=0.0 if side == 1 else math.pi,
                        flange="rigid", restitution=e, gap_lower=gap_lower, gap_upper=gap_upper)
    reference = io.simulate(osc, 15.0, 0.0, 0.0, backend="exact").energy_balance()
    for backend in ("heyoka", "scipy"):
        sol, bal = _balance(osc, 15.0, backend)
        assert sol.status == 0, sol.message
        assert abs(bal["residual"]) <= 1e-8 * bal["scale"], (backend, bal)
        assert bal["forcing_work"] == pytest.approx(reference["forcing_work"], rel=1e-8, abs=1e-9), backend


# -- flange gaps the backends cannot resolve ----------------------------------------------------

@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", ["gap_lower", "gap_upper"])
@pytest.mark.parametrize("flange", ["spring", "rigid"])
def test_a_gap_below_what_the_backends_resolve_is_refused_by_name(backend, name, flange):
    # heyoka failed (status -1, "This is a bug: please report it") and scipy missed the impact
    # of a rigid wall at a gap of 1e-100; both run from rest at X = 0.
    osc = io.Oscillator(0.5, 1.1, 0.01, 1e4, flange=flange, **{name: 1e-100})
    with pytest.raises(ValueError, match=rf"{name}=1e-100 is below 1e-12"):
        io.simulate(osc, 5.0, 0.0, 0.0, backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_smallest_gap_allowed_runs_alike_on_every_backend(backend):
    # A rigid wall at 1e-12 from rest, pushed by F cos(1.1 t): the impacts the three backends
    # find agree (53 in five time units).
    osc = io.Oscillator(0.5, 1.1, 0.01, flange="rigid", gap_upper=1e-12)
    sol = io.simulate(osc, 5.0, 0.0, 0.0, backend=backend)
    reference = io.simulate(osc, 5.0, 0.0, 0.0, backend="exact")
    assert sol.status == 0 and sol.counts == reference.counts and sol.counts["impact"] > 10
