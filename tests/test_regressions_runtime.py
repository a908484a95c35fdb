"""Regressions of issue 14 (items 4, 5, 6, 10, 12, 13 and the small ones of 14): runtime behaviour.

Pickling, repeated sample times, stuck masses and long event-free runs (Ctrl-C, wall-time
limit), tolerance ranges, huge inputs, heyoka's log on stdout, table limits.
"""

import _thread
import math
import os
import pickle
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import impactosc as io
from impactosc.engine import drive
from impactosc.results._solution import RECORD_OPTIONS, Solution, _Recorder

CONTACT = io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4)
STICK_SLIP = io.Oscillator(F=0.5, Omega=0.3, beta=0.3, K=1e4)
#: Forcing at Omega = 1e8: ~3e8 heyoka steps per unit time, no event for a long time.
FAST_FORCING = io.Oscillator(F=1.0, Omega=1e8, beta=0.1, K=10.0)
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# -- item 4: a Solution pickles in every record mode, and samples after unpickling -------
@pytest.mark.parametrize("backend", ["heyoka", "scipy", "exact", "rk4"])
def test_solution_pickles_in_every_record_mode(backend):
    times = np.linspace(0.0, 30.0, 7)
    for record in RECORD_OPTIONS:
        sol = io.simulate(STICK_SLIP, 30.0, backend=backend, record=record)
        back = pickle.loads(pickle.dumps(sol))
        assert (back.status, back.t_final, back.counts) == (sol.status, sol.t_final, sol.counts)
        assert back.mean_flange_force() == sol.mean_flange_force()
        if record != "stats":
            np.testing.assert_array_equal(back.events.t, sol.events.t)
        if record == "full":
            x, v = sol.sample(times)
            xb, vb = back.sample(times)
            np.testing.assert_array_equal(xb, x)
            np.testing.assert_array_equal(vb, v)


def test_unpickled_heyoka_solution_samples_where_no_integrator_is_cached():
    # A new thread has an empty integrator cache, as a fresh worker process has.
    sol = io.simulate(CONTACT, 20.0)
    blob = pickle.dumps(sol)
    out = {}
    thread = threading.Thread(target=lambda: out.update(xv=pickle.loads(blob).sample([3.0, 7.5])))
    thread.start()
    thread.join()
    np.testing.assert_array_equal(out["xv"][0], sol.sample([3.0, 7.5])[0])


# -- item 5: repeated sample times ---------------------------------------------------------
@pytest.mark.parametrize("backend", ["heyoka", "scipy", "exact", "rk4"])
def test_repeated_sample_times(backend):
    sol = io.simulate(STICK_SLIP, 30.0, backend=backend)
    tf = sol.t_final
    for t in (1.0, tf, 0.0, sol.events.t[3]):
        x, v = sol.sample([t, t])
        x1, v1 = sol.sample(t)
        assert x[0] == x[1] == x1 and v[0] == v[1] == v1
        f = sol.flange_force([t, t, t])
        assert f[0] == f[1] == f[2]
    assert sol.sample([tf, tf])[0][0] == sol.x_final
    # Unsorted with repeats: each value is that of its time (scipy's dense output depends
    # on the grid's last time at the rounding level).
    t = np.array([7.0, 2.0, 7.0, tf, 2.0, 0.0, tf])
    x, _ = sol.sample(t)
    assert x[0] == x[2] and x[1] == x[4] and x[3] == x[6] == sol.x_final and x[5] == sol.x0
    for ti, xi in zip(t, x, strict=True):
        assert xi == pytest.approx(sol.sample(ti)[0], abs=1e-13)


# -- item 6: stuck masses in closed form; Ctrl-C and a wall-time limit for long runs ------
@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_mass_stuck_for_ever_costs_one_piece(backend):
    # F = 0.1 < beta = 0.5: the mass never moves. Before, heyoka stepped through 1e12
    # time units (days) and scipy through every half period of the forcing.
    osc = io.Oscillator(0.1, 0.5, 0.5, 10)
    sol = io.simulate(osc, 1e12, 0.0, 0.0, backend=backend, record="stats")
    assert sol.status == 0 and sol.t_final == 1e12
    assert sum(sol.counts.values()) == 0 and sol.x_final == 0.0 and sol.v_final == 0.0
    assert sol.n_pieces == 1


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_stuck_inside_a_flange_releases_as_the_exact_backend(backend):
    # Stuck in the upper flange (spring force K * 0.01 = 1 < ...) with releases by the forcing.
    osc = io.Oscillator(F=1.5, Omega=0.2, beta=1.2, K=100.0)
    ref = io.simulate(osc, 200.0, 1.01, 0.0, backend="exact")
    sol = io.simulate(osc, 200.0, 1.01, 0.0, backend=backend)
    assert ref.counts["stick"] > 3 and ref.counts["release"] > 3
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, atol=1e-8)
    assert sol.flange_impulse(1) == pytest.approx(ref.flange_impulse(1), rel=1e-8)


def test_long_pieces_are_integrated_in_chunks_without_changing_the_answer():
    # |f_net| > beta throughout and Omega = 1e4: ~1.2e4 heyoka steps in each of the four
    # half-period pieces, so every piece spans several propagate_until chunks.
    osc = io.Oscillator(F=0.05, Omega=1e4, beta=0.01, K=10.0)
    ref = io.simulate(osc, 10.0, 0.9, 0.0, backend="exact")
    sol = io.simulate(osc, 10.0, 0.9, 0.0)
    assert sol.n_pieces == ref.n_pieces == 4 and sol.n_steps > 4 * 10_000
    assert sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, atol=1e-12)
    assert sol.x_final == pytest.approx(ref.x_final, abs=1e-12)
    assert sol.forcing_work == pytest.approx(ref.forcing_work, abs=1e-12)


def test_wall_time_limit_ends_with_status_1_and_keeps_the_results():
    # This run takes ~25 minutes to t_end = 10.
    sol = io.simulate(FAST_FORCING, 10.0, 0.0, 0.0, max_wall_time=0.3)
    assert sol.status == 1 and not sol.success
    assert "max_wall_time=0.3" in sol.message and "kept" in sol.message
    assert 0.0 < sol.t_final < 10.0 and sol.n_steps > 1000
    x, v = sol.sample([0.0, 0.5 * sol.t_final, sol.t_final])
    assert x[-1] == sol.x_final and np.all(np.isfinite(x)) and np.all(np.isfinite(v))


def test_wall_time_limit_does_not_change_a_run_that_finishes():
    a = io.simulate(CONTACT, 50.0)
    b = io.simulate(CONTACT, 50.0, max_wall_time=1e6)
    assert b.status == 0 and b.t_final == a.t_final
    np.testing.assert_array_equal(b.events.t, a.events.t)


@pytest.mark.parametrize("bad, exc", [(0.0, ValueError), (-1.0, ValueError), (math.inf, ValueError), ("1", TypeError)])
def test_wall_time_limit_is_validated(bad, exc):
    with pytest.raises(exc, match="max_wall_time"):
        io.simulate(CONTACT, 1.0, max_wall_time=bad)


@pytest.mark.usefixtures("sigint_raises")  # Ctrl-C must raise, however pytest was started
def test_ctrl_c_in_process_raises_and_leaves_the_backend_usable():
    before = io.simulate(CONTACT, 50.0)
    timer = threading.Timer(0.3, _thread.interrupt_main)  # what a SIGINT does to the main thread
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            io.simulate(FAST_FORCING, 10.0, 0.0, 0.0, record="stats")
    finally:
        timer.cancel()
    after = io.simulate(CONTACT, 50.0)
    np.testing.assert_array_equal(after.events.t, before.events.t)
    assert after.mean_flange_force() == before.mean_flange_force()


@pytest.mark.slow  # a subprocess
@pytest.mark.usefixtures("sigint_raises")  # Ctrl-C must raise, however pytest was started
def test_sigint_stops_a_long_event_free_run_in_a_subprocess():
    code = ("import impactosc as io\n"
            "io.simulate(io.Oscillator(1, 1e8, 0.1, 10), 10.0, 0.0, 0.0, record='stats', max_wall_time=0.01)\n"
            "print('running', flush=True)\n"
            "io.simulate(io.Oscillator(1, 1e8, 0.1, 10), 10.0, 0.0, 0.0, record='stats')\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, "PYTHONPATH": REPO})
    try:
        assert proc.stdout.readline().strip() == "running"
        time.sleep(0.3)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)  # a hang guard: it returns in milliseconds
    finally:
        proc.kill()
    assert proc.returncode != 0 and "KeyboardInterrupt" in err


# -- item 10: usable tolerance ranges --------------------------------------------------------
@pytest.mark.parametrize("tol", [1e-200, 1e-19, 0.05, 0.5])
def test_heyoka_tolerance_outside_its_range_is_refused_at_once(tol):
    with pytest.raises(ValueError, match=r"tol must be in \[1e-18, 0.01\].*got " + repr(tol)):
        io.simulate(CONTACT, 10.0, tol=tol)


@pytest.mark.parametrize("tol", [1e-18, 1e-2])
def test_heyoka_tolerance_range_ends_work(tol):
    ref = io.simulate(CONTACT, 50.0, backend="exact")
    sol = io.simulate(CONTACT, 50.0, tol=tol)
    assert sol.status == 0 and sol.counts == ref.counts
    np.testing.assert_allclose(sol.events.t, ref.events.t, atol=1e-2 if tol == 1e-2 else 1e-10)


@pytest.mark.parametrize("opts, name", [
    ({"rtol": 0.5, "atol": 0.5}, "rtol"),
    ({"rtol": 1e-2}, "rtol"),
    ({"rtol": 1e-15}, "rtol"),
    ({"atol": 0.5}, "atol"),
    ({"atol": 1e-300}, "atol"),
])
def test_scipy_tolerances_outside_their_range_are_refused(opts, name):
    with pytest.raises(ValueError, match=rf"{name} must be in \[.*\] for the scipy backend, got {opts[name]!r}"):
        io.simulate(CONTACT, 10.0, backend="scipy", **opts)


def test_scipy_tolerance_range_ends_work():
    ref = io.simulate(CONTACT, 30.0, backend="exact")
    for rtol, atol in ((1e-3, 1e-3), (1e-13, 1e-18)):
        sol = io.simulate(CONTACT, 30.0, backend="scipy", rtol=rtol, atol=atol)
        assert sol.status == 0 and sol.counts == ref.counts


# -- item 12: empty runs, huge numbers ---------------------------------------------------------
class _FailingStepper:
    def advance(self, *args):
        raise FloatingPointError("no step possible")


def _failed_at_start(record):
    rec = _Recorder(record, "test", None)
    drive(_FailingStepper(), CONTACT, 10.0, 0.95, 0.0, rec, 100)
    return Solution(rec, 10.0)


@pytest.mark.parametrize("record", RECORD_OPTIONS)
def test_a_run_that_failed_at_t0_reports_without_raising(record):
    sol = _failed_at_start(record)
    assert sol.status == -1 and sol.t_final == 0.0
    assert math.isnan(sol.mean_flange_force()) and math.isnan(sol.mean_flange_force(1))
    assert math.isnan(sol.rms_flange_force())
    assert sol.flange_impulse() == 0.0 and sol.max_flange_force() == 0.0
    text = sol.summary()
    assert "status=-1" in text and "no step possible" in text
    with pytest.raises(ValueError, match="side must be"):
        sol.mean_flange_force(side=2)


@pytest.mark.parametrize("backend", ["heyoka", "scipy", "exact", "rk4"])
@pytest.mark.parametrize("field, x0, v0", [("x0", 1e160, 0.0), ("x0", 1e300, 0.0), ("v0", 0.0, -1e160)])
def test_huge_initial_state_is_refused_naming_it(backend, field, x0, v0):
    with pytest.raises(ValueError, match=rf"^{field}=.* is too large for double precision"):
        io.simulate(CONTACT, 10.0, x0, v0, backend=backend)


def test_huge_stiffness_or_time_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"^K=1e\+300 is too large"):
        io.simulate(io.Oscillator(0.5, 1.1, 0.01, 1e300), 10.0)
    with pytest.raises(ValueError, match=r"^F \* t_end \(F=0.5, t_end=1e\+200\) is too large"):
        io.simulate(CONTACT, 1e200, backend="exact")


def test_large_but_safe_initial_state_runs_with_finite_statistics_and_narrow_tables():
    sol = io.simulate(CONTACT, 10.0, 1e100, 0.0, backend="exact")
    assert sol.status == 0
    for value in (sol.mean_flange_force(), sol.rms_flange_force(), sol.max_flange_force(), sol.forcing_work):
        assert math.isfinite(value)
    for table in (sol.impact_table(), sol.event_table()):
        lines = table.splitlines()
        assert len(lines) > 5 and max(map(len, lines[:-1])) == len(lines[0])
    assert "e+104" in sol.impact_table()  # the peak force ~1e104 in scientific notation


@pytest.mark.parametrize("fields, name", [
    ({"thickness": 1e300}, "thickness"),
    ({"thickness": 1e300, "bending": "out-of-plane"}, "thickness"),
    ({"width": 1e200}, "width"),
    ({"density": 1e-300}, "density"),
    ({"free_length": 1e-120}, "free_length"),
])
def test_tape_drive_fields_beyond_double_precision_are_refused_naming_them(fields, name):
    with pytest.raises(ValueError, match=rf"TapeDrive: {name}=.* out of the range double precision"):
        io.TapeDrive(**fields)


def test_tape_drive_without_friction_is_still_fine():
    assert io.TapeDrive(friction=0.0).beta == 0.0


# -- item 13: heyoka's log goes to stderr --------------------------------------------------------
# A non-finite velocity makes heyoka warn "event detection skipped ..." from C++: the warning must
# reach stderr, never the tables on stdout between the two markers.
_WARNS_BETWEEN_MARKERS = ("print('table start', flush=True)\n"
                          "ta = compiled_integrator(Oscillator(0.5, 0.3, 0.1, 1e4)).ta\n"
                          "ta.time = 0.0\n"
                          "ta.state[:] = [0.5, math.inf] + [0.0] * (ta.dim - 2)\n"
                          "ta.propagate_until(1.0)\n"
                          "print('table end', flush=True)\n")


def _assert_warning_on_stderr_only(code: str) -> None:
    out = subprocess.run([sys.executable, "-c", code + _WARNS_BETWEEN_MARKERS], capture_output=True, text=True,
                         timeout=120, env={**os.environ, "PYTHONPATH": REPO})
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["table start", "table end"]
    assert "[warning] event detection skipped" in out.stderr, out.stderr


@pytest.mark.slow  # a subprocess
def test_heyoka_warnings_do_not_reach_stdout():
    """The backend's integrator (the hybrid loop's) is the first heyoka builds in the process."""
    _assert_warning_on_stderr_only("import math\n"
                                   "from impactosc import Oscillator\n"
                                   "from impactosc.backends.heyoka import compiled_integrator\n")


@pytest.mark.slow  # a subprocess
def test_heyoka_warnings_do_not_reach_stdout_when_a_user_system_comes_first():
    """The process's first heyoka compile is a user system's compiled functions (its scipy run):
    heyoka's logger was created there on stdout, so the warnings of every later integrator went to stdout."""
    _assert_warning_on_stderr_only(
        "import math\n"
        "import impactosc\n"
        "from impactosc import Guard, HybridMode, HybridSystem, Oscillator, symbols\n"
        "from impactosc.backends.heyoka import compiled_integrator\n"
        "x, v = symbols('x v')\n"
        "ball = HybridSystem('x v', {}, [HybridMode('flight', {x: v, v: -1.0})],\n"
        "                    [Guard('impact', x, -1, armed='flight', to='flight', reset={v: -0.5 * v})])\n"
        "impactosc.simulate(ball, 1.0, [1.0, 0.0], backend='scipy')\n")


# -- item 14 (part): table limits, rk4's max_events ---------------------------------------------
def test_table_limits():
    sol = io.simulate(CONTACT, 30.0, backend="exact")
    n_ev, n_im = len(sol.events), len(sol.impacts)
    for table, n, what in ((sol.event_table, n_ev, "events"), (sol.impact_table, n_im, "impacts")):
        with pytest.raises(ValueError, match="limit must be >= 0, got -1"):
            table(limit=-1)
        with pytest.raises(TypeError, match="limit must be an integer"):
            table(limit=2.5)
        assert table(limit=0).splitlines()[1:] == [f"... {n} more {what}"]
        assert len(table(limit=3).splitlines()) == 1 + 3 + 1
        assert len(table(limit=None).splitlines()) == 1 + n


def test_rk4_accepts_an_unreachable_event_limit():
    sol = io.simulate(CONTACT, 20.0, backend="rk4", max_events=2**64)
    assert sol.status == 0 and sum(sol.counts.values()) > 0


@pytest.mark.slow  # a subprocess
def test_the_demo_tape_drive_creep_prints_no_heyoka_warning():
    """The tape drive's creep (1 s of tape, as `impactosc demo` runs it): heyoka's root finder gave up on
    45 steps of slips that start at a release (the stop guard's double root at the start) and warned on
    stderr each time; the lost-crossing check handles those steps, so the loop mutes them. The run still
    agrees with exact event for event."""
    code = ("import impactosc as io\n"
            "import numpy as np\n"
            "drive = io.TapeDrive()\n"
            "osc, lam = drive.oscillator(), drive.seconds_to_lambda(1.0)\n"
            "sol = io.simulate(osc, lam, record='events')\n"
            "ref = io.simulate(osc, lam, record='events', backend='exact')\n"
            "assert sol.counts == ref.counts, (sol.counts, ref.counts)\n"
            "print(np.max(np.abs(sol.events.t - ref.events.t)))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": REPO})
    assert out.returncode == 0, out.stderr
    assert "warning" not in out.stderr, out.stderr
    assert float(out.stdout) < 1e-4  # slow releases over 5.7e5 time units: 2.8e-6 measured
