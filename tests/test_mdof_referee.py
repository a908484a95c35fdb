"""The exact n-DOF backend against an independent referee (scipy's solve_ivp, tests/mdof_referee.py).

Random systems, n = 2 to 10: spring contacts, rigid stops with restitution, Coulomb
friction on 0 to 2 coordinates, constraints coupled through the mass matrix or not, damping with a
gyroscopic part, one or two harmonics. Event kinds and indices agree, event times within
1e-8; the energy identity holds to 1e-9 relative.
"""

from __future__ import annotations

import numpy as np
import pytest
from mdof_referee import Referee
from mdof_systems import initial_state, random_system

from impactosc import simulate_mechanical

CASES = [(seed, 2 + seed % 9, laws, friction, seed % 2 == 0)
         for seed, (laws, friction) in enumerate([(("spring",), 0), (("rigid",), 0), (("spring", "rigid"), 0),
                                                  (("spring",), 1), (("rigid",), 1), (("spring", "rigid"), 2),
                                                  (("rigid", "spring"), 2), (("spring",), 2), (("rigid",), 2)] * 2)]


@pytest.mark.parametrize("seed, n, laws, friction, orthogonal", CASES)
def test_random_system_agrees_with_the_referee(seed, n, laws, friction, orthogonal):
    system = random_system(seed, n, laws=laws, friction=friction, contacts=3, orthogonal=orthogonal)
    q0, v0 = initial_state(seed, n)
    t_end = 12.0
    sol = simulate_mechanical(system, t_end, q0, v0)
    ref = Referee(system).run(t_end, q0, v0)
    assert sol.status == 0, sol.message
    assert [(k, i) for _, k, i in ref] == list(zip(sol.events.kind, sol.events.index, strict=True))
    if ref:
        np.testing.assert_allclose(sol.events.t, [t for t, _, _ in ref], rtol=0, atol=1e-8)
    assert sol.energy_balance()["relative"] < 1e-9


def test_the_cases_cover_every_event_kind_but_rest():
    kinds = set()
    for seed, n, laws, friction, orthogonal in CASES:
        system = random_system(seed, n, laws=laws, friction=friction, contacts=3, orthogonal=orthogonal)
        q0, v0 = initial_state(seed, n)
        kinds |= set(simulate_mechanical(system, 12.0, q0, v0, energy=False).events.kind)
    assert {"contact_start", "contact_end", "impact", "stick", "reversal", "release"} <= kinds
