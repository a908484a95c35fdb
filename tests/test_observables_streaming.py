"""The contact sums streamed in every recording mode (``Solution.contact_sums``; issue 29, item 1).

A sweep runs ``record="stats"``, which keeps no impact table; the recorder and the exact
backend's compiled loop stream, per flange, the sums that :func:`contact_observables` needs
(number of contacts, entry speeds and their squares, peak forces, impulses, elastic impact
forces, dissipated energy). Checked here:

* closed forms on ``record="stats"`` runs: a free mass's entry speed ``sqrt(V0^2 - 1)`` and its
  impact force ``sqrt(K) V``; a rigid flange's restitution loss ``(1 - e^2) V^2 / 2`` summed
  over the geometric sequence of impacts; a spring contact without forcing takes the kinetic
  energy lost between entry and exit;
* the streamed sums against the impact table of a ``record="full"`` run, and
  ``contact_observables`` of a ``"stats"`` run against a ``"full"`` one, on heyoka, scipy and
  exact, spring and rigid flanges (1e-12 relative: the same run, summed in another order);
* the compiled exact loop against the Python driver;
* a hypothesis property: any linear member on the exact backend, the streamed sums equal the
  sums of its impact table, per flange;
* a backend that streams no pieces (rk4) is refused in ``"stats"`` by name, and served from
  its table in ``"events"``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import impactosc
from impactosc.backends import exact
from impactosc.backends.exact._family import near_resonance
from impactosc.results import contact_observables, contact_table, elastic_impact_force

SPRING = impactosc.Oscillator(0.5, 1.1, 0.05, 1e4, zeta=0.02)
RIGID = impactosc.Oscillator(0.9, 1.3, 0.02, 1.0, flange="rigid", restitution=0.7)
MEMBERS = {
    "spring": (SPRING, 150.0, 0.95, 0.0),
    "spring_from_inside": (impactosc.Oscillator(0.5, 1.1, 0.01, 1e4), 60.0, 1.01, -0.3),  # a contact open at t=0
    "rigid": (RIGID, 80.0, 0.3, 0.0),
    "rigid_resting": (impactosc.Oscillator(2.0, 0.3, 0.1, 1.0, flange="rigid", restitution=0.8), 60.0, 0.0, 0.0),
}
BACKENDS = ("exact", "heyoka", "scipy")


def _close(a: float, b: float, rel: float) -> bool:
    if math.isinf(a) or math.isinf(b) or math.isnan(a) or math.isnan(b):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == pytest.approx(b, rel=rel, abs=1e-300)


def _table_sums(table) -> dict[str, float]:
    return {"contacts": float(len(table)), "entry_speed": float(np.sum(np.abs(table.entry_speed))),
            "entry_speed_sq": float(np.sum(table.entry_speed**2)), "peak_force": float(np.sum(table.peak_force)),
            "impulse": float(np.sum(table.impulse)), "impact_force": float(np.sum(table.impact_force)),
            "dissipated": float(np.sum(table.dissipated))}


def test_free_impact_closed_form_in_stats():
    """From X = 0 at V0 = 2 with no forcing: V_in = sqrt(3) at each flange, impact force sqrt(K) V_in."""
    osc = impactosc.Oscillator(0.0, 1.0, 0.0, 1e4)
    sol = impactosc.simulate(osc, 3.0, 0.0, 2.0, backend="exact", record="stats")
    sums = sol.contact_sums()
    assert sums["contacts"] == 3.0
    assert sums["entry_speed"] == pytest.approx(3.0 * math.sqrt(3.0), rel=1e-12)
    assert sums["entry_speed_sq"] == pytest.approx(9.0, rel=1e-12)
    assert sums["impact_force"] == pytest.approx(100.0 * 3.0 * math.sqrt(3.0), rel=1e-12)
    assert sums["dissipated"] == 0.0
    assert sol.contact_sums(1)["contacts"] == 2.0 and sol.contact_sums(-1)["contacts"] == 1.0
    assert float(elastic_impact_force(1e4, 1.0, -math.sqrt(3.0))) == pytest.approx(100.0 * math.sqrt(3.0), rel=1e-15)


@pytest.mark.parametrize("backend", BACKENDS)
def test_rigid_restitution_loss_closed_form_in_stats(backend):
    """No forcing, no friction: impacts at sqrt(3) e^n, each losing (1 - e^2) V^2 / 2."""
    e = 0.5
    osc = impactosc.Oscillator(0.0, 1.0, 0.0, 1.0, flange="rigid", restitution=e)
    sol = impactosc.simulate(osc, 8.0, 0.0, 2.0, backend=backend, record="stats")
    sums = sol.contact_sums()
    n = int(sums["contacts"])
    assert n >= 3
    speeds = math.sqrt(3.0) * e ** np.arange(n)
    assert sums["entry_speed"] == pytest.approx(float(np.sum(speeds)), rel=1e-9)
    assert sums["dissipated"] == pytest.approx(float(np.sum(0.5 * (1 - e * e) * speeds**2)), rel=1e-9)
    assert sums["impulse"] == pytest.approx(float(np.sum((1 + e) * speeds)), rel=1e-9)
    assert math.isinf(sums["peak_force"]) and math.isinf(sums["impact_force"])


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize(("beta", "zeta"), [(0.05, 0.0), (0.05, 0.1)])
def test_spring_contact_takes_the_kinetic_energy_lost_in_stats(backend, beta, zeta):
    """No forcing, one contact entered and left at X = 1: dissipated = (V_in^2 - V_out^2) / 2."""
    osc = impactosc.Oscillator(0.0, 1.0, beta, 1e3, zeta=zeta)
    stats = impactosc.simulate(osc, 1.0, 0.0, 3.0, backend=backend, record="stats")
    events = impactosc.simulate(osc, 1.0, 0.0, 3.0, backend=backend, record="events")
    row = contact_table(events)
    assert len(row) == 1 and row[0].complete
    taken = 0.5 * (row[0].entry_speed ** 2 - row[0].exit_speed ** 2)
    assert stats.contact_sums()["dissipated"] == pytest.approx(taken, rel=1e-7)
    assert stats.contact_sums()["dissipated"] > 0.0


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("member", sorted(MEMBERS))
def test_stats_equal_full(member, backend):
    """Streamed sums == the full run's impact table; contact_observables(stats) == (full), at 1e-12."""
    osc, t_end, x0, v0 = MEMBERS[member]
    stats = impactosc.simulate(osc, t_end, x0, v0, backend=backend, record="stats")
    full = impactosc.simulate(osc, t_end, x0, v0, backend=backend, record="full")
    assert stats.counts == full.counts
    table = _table_sums(contact_table(full))
    streamed = stats.contact_sums()
    assert table["contacts"] >= 3, "the case must have contacts"
    for name, value in table.items():
        assert _close(streamed[name], value, 1e-12), (name, streamed[name], value)
    a, b = contact_observables(stats), contact_observables(full)
    for flange in ("upper", "lower", "both"):
        for name in a[flange]:
            assert _close(a[flange][name], b[flange][name], 1e-12), (flange, name, a[flange][name], b[flange][name])


def test_stats_equal_full_in_si_on_a_tape_drive():
    drive = impactosc.TapeDrive(clearance=20e-6, friction=0.05)
    osc = drive.oscillator()
    t_end = drive.seconds_to_lambda(2e-3)
    stats = impactosc.simulate(osc, t_end, 0.95, 0.0, backend="exact", record="stats")
    full = impactosc.simulate(osc, t_end, 0.95, 0.0, backend="exact", record="full")
    a, b = stats.contact_observables(drive), full.contact_observables(drive)
    for name in a["both"]:
        assert _close(a["both"][name], b["both"][name], 1e-12), name


@pytest.mark.skipif(not exact.HAVE_NUMBA, reason="the compiled loop needs numba")
@pytest.mark.parametrize("member", sorted(MEMBERS))
@pytest.mark.parametrize("record", ["stats", "events"])
def test_compiled_loop_streams_what_the_python_driver_streams(member, record):
    osc, t_end, x0, v0 = MEMBERS[member]
    fast = impactosc.simulate(osc, t_end, x0, v0, backend="exact", record=record, compiled=True)
    slow = impactosc.simulate(osc, t_end, x0, v0, backend="exact", record=record, compiled=False)
    for side in (1, -1):
        a, b = fast.contact_sums(side), slow.contact_sums(side)
        for name in a:
            assert _close(a[name], b[name], 1e-14), (side, name)
    if record == "events":
        np.testing.assert_allclose(contact_table(fast).dissipated, contact_table(slow).dissipated, rtol=1e-14)


@settings(max_examples=40, deadline=None)
@given(F=st.floats(0.0, 3.0, allow_subnormal=False), Omega=st.floats(0.05, 3.0), beta=st.floats(0.0, 0.5),
       K=st.sampled_from([1.0, 50.0, 1e4]), zeta=st.sampled_from([0.0, 0.05]), rigid=st.sampled_from([None, 0.0, 0.7]),
       x0=st.floats(-1.0, 1.0), v0=st.floats(-2.0, 2.0))
def test_streamed_sums_equal_the_table_property(F, Omega, beta, K, zeta, rigid, x0, v0):
    """Any linear member on the exact backend: the sums of a "stats" run are those of the "events" run's table."""
    law = {} if rigid is None else {"flange": "rigid", "restitution": rigid}
    osc = impactosc.Oscillator(F, Omega, beta, K, zeta=zeta, **law)
    if near_resonance(osc):
        return  # refused by the exact backend (tests/test_family.py)
    stats = impactosc.simulate(osc, 40.0, x0, v0, backend="exact", record="stats", max_events=20_000)
    events = impactosc.simulate(osc, 40.0, x0, v0, backend="exact", record="events", max_events=20_000)
    table = contact_table(events)
    for side in (1, -1, None):
        rows = _table_sums(table if side is None else table[table.side == side])
        streamed = stats.contact_sums(side)
        for name, value in rows.items():
            assert _close(streamed[name], value, 1e-12), (side, name, streamed[name], value)


def test_rk4_streams_no_contacts():
    """rk4 hands over its own rows and totals: "stats" is refused by name, "events" uses its table."""
    osc = impactosc.Oscillator(0.5, 1.1, 0.0, 1e2)
    stats = impactosc.simulate(osc, 60.0, 0.95, 0.0, backend="rk4", record="stats", dt=1e-3)
    assert stats.contact_entries() > 0
    with pytest.raises(ValueError, match="rk4.*record='events'"):
        stats.contact_sums()
    with pytest.raises(ValueError, match="record"):
        contact_observables(stats)
    events = impactosc.simulate(osc, 60.0, 0.95, 0.0, backend="rk4", record="events", dt=1e-3)
    obs = contact_observables(events)
    assert obs["both"]["impacts"] == len(events.impacts) > 0
    assert obs["both"]["dissipation_rate"] == 0.0  # frictionless, undamped: nothing to dissipate
