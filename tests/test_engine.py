"""The transition rule on its own: the physics every backend shares."""

import pytest

from impactosc import Oscillator
from impactosc.engine import (
    ACCEL_ZERO,
    ENTER_LOWER,
    ENTER_UPPER,
    LEAVE,
    RELEASE_DOWN,
    RELEASE_UP,
    SLIP_END,
    Mode,
    guard_gates,
    initial_mode,
    motion_at_rest,
    transition,
)

OSC = Oscillator(F=0.0, Omega=0.0, beta=0.1, K=1e4)


def test_stick_test_uses_flange_spring():
    # At X = 1.00005 the tape spring pushes back with 1.00005 and the flange spring with
    # K * 5e-5 = 0.5: the stick test must see |f_net| = 1.50005 > beta.
    osc = Oscillator(F=1.0, Omega=0.0, beta=0.1, K=1e4)
    assert motion_at_rest(osc, 0.0, 1.00005) == (-1, True)
    # Without the flange spring the same point would stick: f = 1 - 1.00005 ~ 0.
    assert motion_at_rest(osc, 0.0, 1.0) == (0, True)


def test_stick_and_slip_directions():
    assert motion_at_rest(OSC, 0.0, 0.05) == (0, True)  # |f| = 0.05 < 0.1
    assert motion_at_rest(OSC, 0.0, 0.5) == (-1, True)  # slips towards f_net = -0.5
    assert motion_at_rest(OSC, 0.0, -0.5) == (1, True)


def test_release_threshold_tie_break_by_rate():
    # f_net = cos(t) - 0 with beta = 1 at t = 0 is on the threshold and falling: stays stuck.
    osc = Oscillator(F=1.0, Omega=1.0, beta=1.0, K=10.0)
    assert motion_at_rest(osc, 0.0, 0.0) == (0, True)
    # phase -0.5: f_net = cos(t - 0.5) rising through... choose x so |f| == beta exactly and rising.
    osc2 = Oscillator(F=2.0, Omega=1.0, beta=1.0, K=10.0, phase=-1.0)
    x = osc2.F * __import__("math").cos(-1.0) - 1.0  # f_net = beta exactly at t = 0
    m, armed = motion_at_rest(osc2, 0.0, x)
    assert (m, armed) == (1, False)  # released with zero acceleration: slip-end disarmed


def test_initial_mode():
    assert initial_mode(OSC, 0.0, 0.95, 0.0) == Mode(0, -1, True)
    assert initial_mode(OSC, 0.0, 0.05, 0.0) == Mode(0, 0, True)
    assert initial_mode(OSC, 0.0, 1.2, 0.0) == Mode(1, -1, True)
    assert initial_mode(OSC, 0.0, 1.0, 0.3) == Mode(1, 1, True)  # on the flange, moving in
    assert initial_mode(OSC, 0.0, 1.0, -0.3) == Mode(0, -1, True)
    assert initial_mode(OSC, 0.0, -1.0, -0.3) == Mode(-1, -1, True)


def test_transitions_snap_and_record():
    m = Mode(0, 1, True)
    assert transition(OSC, m, ENTER_UPPER, 1.0, 1.0 + 2e-16, 0.4) == (Mode(1, 1, True), 1.0, 0.4, "contact_start", 1)
    assert transition(OSC, Mode(0, -1, True), ENTER_LOWER, 1.0, -1.0, -0.4)[3:] == ("contact_start", -1)
    new, x, v, kind, side = transition(OSC, Mode(-1, 1, True), LEAVE, 2.0, -1.0 + 1e-16, 0.4)
    assert (new, x, kind, side) == (Mode(0, 1, True), -1.0, "contact_end", -1)
    # Turning point with |f_net| > beta: reversal; V snapped to zero.
    new, x, v, kind, side = transition(OSC, Mode(0, 1, True), SLIP_END, 3.0, 0.7, 1e-17)
    assert (new, v, kind, side) == (Mode(0, -1, True), 0.0, "reversal", 0)
    # Turning point with |f_net| <= beta: stick.
    assert transition(OSC, Mode(0, 1, True), SLIP_END, 3.0, 0.05, 0.0)[3] == "stick"
    # Release disarms the slip-end guard; the acceleration-zero guard re-arms it silently.
    new, _, _, kind, _ = transition(OSC, Mode(0, 0, True), RELEASE_UP, 4.0, 0.05, 0.0)
    assert (new, kind) == (Mode(0, 1, False), "release")
    assert transition(OSC, Mode(0, 0, True), RELEASE_DOWN, 4.0, 0.05, 0.0)[0] == Mode(0, -1, False)
    assert transition(OSC, Mode(0, 1, False), ACCEL_ZERO, 4.5, 0.3, 0.2) == (Mode(0, 1, True), 0.3, 0.2, None, 0)
    with pytest.raises(ValueError, match="guard"):
        transition(OSC, m, 99, 0.0, 0.0, 0.0)


def test_gates_arm_exactly_the_guards_of_each_mode():
    names = ("enter_upper", "enter_lower", "leave", "slip_end", "accel_zero", "release_up", "release_down")

    def armed(mode):
        return {n for n, g in zip(names, guard_gates(mode), strict=True) if g}

    # Only the flange ahead of the motion (issue 20, item 9).
    assert armed(Mode(0, 1, True)) == {"enter_upper", "slip_end"}
    assert armed(Mode(0, -1, True)) == {"enter_lower", "slip_end"}
    assert armed(Mode(1, 1, True)) == {"slip_end"}
    assert armed(Mode(1, -1, True)) == {"leave", "slip_end"}
    assert armed(Mode(-1, 1, False)) == {"leave", "accel_zero"}
    assert armed(Mode(0, 0, True)) == {"release_up", "release_down"}
    assert armed(Mode(1, 0, True)) == {"release_up", "release_down"}


def test_drive_turns_a_backend_failure_into_status_minus_one():
    from impactosc.engine import NO_GUARD, drive
    from impactosc.results._solution import Solution, _Recorder

    class FlakyStepper:
        """Reaches a slip end at t = 1 and t = 2 (an ideal free oscillator), then gives up."""

        name = "flaky"

        def __init__(self):
            self.calls = 0

        def advance(self, mode, t, x, v, t_end):
            self.calls += 1
            if self.calls == 3:
                raise FloatingPointError("step size underflow")
            return float(self.calls), -x, 1e-17 * mode.motion, SLIP_END, 0.0, 0.0, 0.0, 0.0, 1

    rec = _Recorder("events", "flaky", None)
    drive(FlakyStepper(), OSC, 10.0, 0.95, 0.0, rec, 100)
    sol = Solution(rec, 10.0)
    assert sol.status == -1 and "flaky backend failed after t=2.0" in sol.message
    assert "FloatingPointError: step size underflow" in sol.message
    assert list(sol.events.kind) == ["reversal", "reversal"] and sol.t_final == 2.0
    assert NO_GUARD == -1
