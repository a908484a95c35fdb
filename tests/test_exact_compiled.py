"""The exact backend's compiled event loop against its Python driver (issue #12 item 2).

Both drivers run the one transition rule (impactosc.model._rule) and the one compiled closed
form (impactosc.backends.exact._piece); the compiled loop also records in compiled code.
So the two must give the same Solution, bit for bit, in every recording mode: any
difference is a recording or driving bug in the compiled copy of the loop.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from impactosc import Oscillator, simulate
from impactosc.backends import exact
from impactosc.backends.exact._family import near_resonance

pytestmark = pytest.mark.skipif(not exact.HAVE_NUMBA, reason="the compiled loop needs numba")

CONTACT = Oscillator(0.5, 1.1, 0.01, 1e4)
RIGID = Oscillator(2.0, 0.0, 0.1, 1.0, flange="rigid", restitution=0.8)

CASES = [
    (CONTACT, 400.0, 0.95, 0.0, {}),
    (Oscillator(2.0, 0.01, 0.01, 1e4), 700.0, 0.95, 0.0, {}),  # stick-slip creep into the flanges
    (Oscillator(0.3, 0.7, 0.1, 50.0, beta_static=0.25), 300.0, 0.0, 0.0, {}),  # static > kinetic
    (Oscillator(1.0, 2.0, 1.0, 1e6), 60.0, 0.2, 0.0, {}),  # F == beta: ties at every release
    (Oscillator(0.5, 1.1, 0.01, 1e4), 50.0, 1.01, -0.3, {}),  # starts inside the upper flange
    (Oscillator(0.5, 1.1, 0.01, 1e4), 50.0, -1.0, -0.5, {}),  # starts on the lower boundary, moving in
    (Oscillator(0.2, 0.0, 0.1, 5.0), 20.0, 0.5, 0.0, {}),  # constant force: stuck for ever
    (Oscillator(0.5, 1.0, 0.0, 1e4), 200.0, 0.0, 0.3, {}),  # frictionless, free resonance
    (Oscillator(3.0, 0.5, 1e8, 1e4), 30.0, 0.0, 2.0, {}),  # huge beta: stuck at once
    (CONTACT, 400.0, 0.95, 0.0, {"max_events": 57}),  # stops at the event limit
    # Stroboscopic samples (every forcing period, with repeats, 0 and t_end): time events.
    (CONTACT, 200.0, 0.95, 0.0, {"sample_at": [0.0, *np.arange(1, 35) * 2 * math.pi / 1.1, 100.0, 100.0, 200.0]}),
    (Oscillator(2.0, 0.01, 0.01, 1e4), 700.0, 0.95, 0.0, {"sample_at": np.linspace(0.0, 700.0, 71)}),
    # The damped and harmonic-sum members (impactosc.backends.exact._family).
    (Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.02), 300.0, 0.95, 0.0, {}),  # damped contacts
    (Oscillator(0.0, 0.0, 0.1, 1e4, zeta=0.05), 40.0, 0.95, 0.0, {}),  # damped Coulomb decay to a stick
    (Oscillator(0.3, 0.7, 0.05, 50.0, zeta=3.0, harmonics=[(0.2, 2.2, 0.3)]), 100.0, 0.2, 0.5, {}),  # overdamped
    (Oscillator(0.3, 0.7, 0.05, 50.0, zeta=math.sqrt(51.0)), 60.0, 1.01, 0.0, {}),  # critically damped in contact
    (Oscillator.from_harmonics([(0.6, 0.05, 0.0), (0.3, 0.1, 1.0), (0.1, 0.15, 0.2)], beta=0.2, K=1e3,
                               beta_static=0.3), 800.0, 0.0, 0.0, {"sample_at": np.linspace(0.0, 800.0, 17)}),
    # Rigid flanges: impacts, chatter (a jump to the accumulation point), rest on the wall and release.
    (RIGID, 30.0, 0.0, 0.0, {"sample_at": np.linspace(0.0, 30.0, 301)}),  # samples inside the tails too
    (Oscillator(2.0, 0.3, 0.1, 1.0, flange="rigid", restitution=0.8), 60.0, 0.0, 0.0, {}),  # rest, pulled off
    (Oscillator(2.0, 0.3, 0.1, 1.0, flange="rigid", restitution=0.0), 60.0, 0.0, 1.0, {}),  # plastic impacts
    (Oscillator(0.9, 1.3, 0.02, 1.0, flange="rigid", restitution=1.0, zeta=0.01), 80.0, 0.3, 0.0, {}),
    (Oscillator(2.0, 0.0, 0.1, 1.0, flange="rigid", restitution=0.95), 2.0, 0.0, 0.0, {}),  # ends inside a tail
]


def _pair(osc, t_end, x0, v0, record, max_events=10_000_000, sample_at=None):
    kw = dict(record=record, max_events=max_events, sample_at=sample_at)
    fast = simulate(osc, t_end, x0, v0, backend="exact", compiled=True, **kw)
    slow = simulate(osc, t_end, x0, v0, backend="exact", compiled=False, **kw)
    return fast, slow


def _assert_same(fast, slow):
    for name in ("status", "message", "t_final", "x_final", "v_final", "final_mode", "counts", "n_steps",
                 "n_pieces", "forcing_work", "friction_work", "damping_work", "impact_loss", "record"):
        assert getattr(fast, name) == getattr(slow, name), name
    for side in (1, -1):
        assert fast.contact_entries(side) == slow.contact_entries(side)
        for stat in ("flange_impulse", "mean_flange_force", "rms_flange_force", "contact_time", "max_penetration",
                     "max_flange_force"):
            a, b = getattr(fast, stat)(side), getattr(slow, stat)(side)
            assert a == b or (math.isnan(a) and math.isnan(b)), (stat, side, a, b)
    assert fast.samples.dtype == slow.samples.dtype and len(fast.samples) == len(slow.samples)
    for name in fast.samples.dtype.names:
        np.testing.assert_array_equal(fast.samples[name], slow.samples[name], err_msg=f"samples.{name}")
    if fast.record != "stats":
        for table in ("events", "impacts"):
            a, b = getattr(fast, table), getattr(slow, table)
            assert a.dtype == b.dtype and len(a) == len(b), table
            for name in a.dtype.names:
                np.testing.assert_array_equal(a[name], b[name], err_msg=f"{table}.{name}")
    if fast.record == "full":
        a, b = fast._segments, slow._segments
        assert len(a) == len(b)
        for name in a.dtype.names:
            np.testing.assert_array_equal(a[name], b[name], err_msg=f"segments.{name}")
        times = np.linspace(0.0, fast.t_final, 997)
        for got, want in zip(fast.sample(times), slow.sample(times), strict=True):
            np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("record", ["stats", "events", "full"])
@pytest.mark.parametrize("osc, t_end, x0, v0, kw", CASES)
def test_compiled_loop_equals_python_driver(osc, t_end, x0, v0, kw, record):
    fast, slow = _pair(osc, t_end, x0, v0, record, **kw)
    _assert_same(fast, slow)


def test_compiled_contact_case_keeps_the_reference_mean_force():
    # The paper's contact case: 47 contacts a flange, mean force of the closed-form reference.
    sol = simulate(CONTACT, 400.0, backend="exact", record="stats")
    assert sol.contact_entries(1) == 47 and sol.contact_entries(-1) == 47
    assert abs(sol.mean_flange_force(1) - 0.180165173509774) < 1e-12


def test_event_limit_and_status_are_those_of_the_driver():
    fast, slow = _pair(CONTACT, 400.0, 0.95, 0.0, "events", max_events=57)
    assert fast.status == 1 and sum(fast.counts.values()) == 57
    assert fast.message == slow.message and "max_events=57" in fast.message


def test_compiled_option_is_checked():
    with pytest.raises(TypeError, match="compiled must be None, True or False, got 'yes'"):
        simulate(CONTACT, 10.0, backend="exact", compiled="yes")
    with pytest.raises(ValueError, match="the exact backend does not support a power-law flange"):
        simulate(Oscillator(0.5, 1.1, 0.01, 1e4, exponent=1.5), 10.0, backend="exact", compiled=True)


def test_chatter_is_resolved_in_the_compiled_loop():
    # Impacts accumulate on the upper wall (push 2 - 1 > beta): the jump, then a resting contact.
    fast, slow = _pair(RIGID, 30.0, 0.0, 0.0, "events")
    _assert_same(fast, slow)
    assert fast.counts["chatter"] >= 1 and fast.counts["impact"] > 10
    chatter = fast.events[fast.events.kind == "chatter"][0]
    assert chatter.count > 1 and chatter.x == 1.0


def test_without_numba_the_python_driver_runs_with_a_one_line_hint(monkeypatch):
    monkeypatch.setattr(exact, "HAVE_NUMBA", False)
    with pytest.raises(ValueError, match=r"compiled=True needs numba: pip install 'impactosc\[fast\]'"):
        simulate(CONTACT, 10.0, backend="exact", compiled=True)
    monkeypatch.setattr("impactosc._util.jit._warned", False)
    with pytest.warns(RuntimeWarning, match=r"numba is not installed: .*pip install 'impactosc\[fast\]'"):
        sol = simulate(CONTACT, 100.0, backend="exact", record="stats")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per process, not once per run
        again = simulate(CONTACT, 100.0, backend="exact", record="stats")
    assert sol.counts == again.counts == simulate(CONTACT, 100.0, backend="exact", record="stats").counts


@settings(deadline=None)
@given(F=st.floats(0.0, 3.0, allow_subnormal=False), Omega=st.floats(0.0, 3.0), beta=st.floats(0.0, 1.0),
       K=st.sampled_from([1.0, 50.0, 1e4]), static=st.floats(0.0, 0.5), zeta=st.sampled_from([0.0, 0.0, 0.05, 2.0]),
       extra=st.sampled_from([(), ((0.3, 2.5, 0.4),)]), rigid=st.sampled_from([None, None, 0.0, 0.7, 1.0]),
       x0=st.floats(-1.2, 1.2), v0=st.floats(-2.0, 2.0), record=st.sampled_from(["stats", "events", "full"]),
       samples=st.lists(st.floats(0.0, 40.0), max_size=5))
def test_compiled_loop_equals_python_driver_property(F, Omega, beta, K, static, zeta, extra, rigid, x0, v0, record,
                                                     samples):
    law = {} if rigid is None else {"flange": "rigid", "restitution": rigid}
    if rigid is not None:
        x0 = max(-1.0, min(1.0, x0))
    osc = Oscillator(F, Omega, beta, K, beta_static=beta + static, zeta=zeta, harmonics=extra, **law)
    if near_resonance(osc):
        return  # refused by the exact backend (tests/test_family.py)
    fast, slow = _pair(osc, 40.0, x0, v0, record, max_events=20_000, sample_at=samples)
    _assert_same(fast, slow)


def test_closed_form_of_int_y_squared_matches_gauss_legendre():
    # int Y^2 (the flange force's square) in closed form where it is well conditioned,
    # against the 16-node rule on the stable form, over random pieces of every mode.
    from impactosc.backends.exact import _piece as piece

    rng = np.random.default_rng(12)
    used = 0
    for _ in range(600):
        osc = Oscillator(rng.uniform(0, 3), float(rng.choice([0.0, rng.uniform(0, 3), 1.0, 100.0])),
                         10 ** rng.uniform(-4, 1), 10 ** rng.uniform(0, 6), rng.uniform(-3, 3))
        r, s = int(rng.choice([-1, 0, 1])), int(rng.choice([-1, 1]))
        mc = piece.mode_constants(osc._p, r, s)
        x0 = r + rng.uniform(0, 0.01) * r if r else rng.uniform(-1, 1)
        ps = piece.piece_state(mc, rng.uniform(0, 1e3), x0, rng.uniform(-2, 2))
        tau = 10 ** rng.uniform(-6, 1)
        rule = piece.int_y_squared_rule(mc, ps, tau)
        closed = piece.int_y_squared(mc, ps, tau)
        used += closed != rule
        assert abs(closed - rule) <= 1e-12 * rule
    assert used > 200  # the closed form is taken on most pieces, not only the fallback


def test_without_numba_everything_runs_as_plain_python(tmp_path):
    # The rule, the closed forms and the root finder are written once in compilable Python:
    # with numba absent (import blocked) they must run as plain Python and give the same
    # solution as the compiled code, through the Python driver, with the one-line hint.
    script = tmp_path / "no_numba.py"
    script.write_text(
        "import sys, warnings\n"
        "sys.modules['numba'] = None  # import numba -> ImportError\n"
        "import impactosc as io\n"
        "from impactosc._util import jit as _jit\n"
        "assert not _jit.HAVE_NUMBA\n"
        "with warnings.catch_warnings(record=True) as seen:\n"
        "    warnings.simplefilter('always')\n"
        "    runs = [io.simulate(io.Oscillator(0.5, 1.1, 0.01, 1e4), 60.0, backend='exact', record='events'),\n"
        "            io.simulate(io.Oscillator(2.0, 0.0, 0.1, 1.0, flange='rigid', restitution=0.8), 10.0, 0.0, 0.0,\n"
        "                        backend='exact', record='events'),\n"
        "            io.simulate(io.Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.02, harmonics=[(0.1, 2.3)]), 60.0,\n"
        "                        backend='exact', record='events')]\n"
        "hints = [str(w.message) for w in seen if 'numba is not installed' in str(w.message)]\n"
        "assert len(hints) == 1, hints\n"
        "for sol in runs:\n"
        "    print(sol.status, repr(sol.t_final), repr(sol.x_final), repr(sol.v_final), sol.counts)\n")
    import subprocess
    import sys

    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.strip().splitlines()
    runs = [simulate(CONTACT, 60.0, backend="exact", record="events"),
            simulate(RIGID, 10.0, 0.0, 0.0, backend="exact", record="events"),
            simulate(Oscillator(0.5, 1.1, 0.01, 1e4, zeta=0.02, harmonics=[(0.1, 2.3)]), 60.0, backend="exact",
                     record="events")]
    for line, sol in zip(lines, runs, strict=True):
        assert line == f"{sol.status} {sol.t_final!r} {sol.x_final!r} {sol.v_final!r} {sol.counts}"
