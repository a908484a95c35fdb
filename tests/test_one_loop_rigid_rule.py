"""Issue 27 item 4: a guard's accumulation rule (``Guard.accumulation``) on both hybrid loops.

A rule is asked at every crossing of its guard whether the guard's events accumulate from
there; where it answers, the run jumps to the accumulation time and goes on in the guard's rest
mode with the rule's state and integral increments. Checked on the bouncing ball, whose Zeno
time is a closed form: dropped from height ``h`` it lands after ``sqrt(2 h / g)`` at speed
``u0 = sqrt(2 g h)``, and after an impact at speed ``u`` its flights add up to
``2 e u / (g (1 - e))``.
"""

from __future__ import annotations

import math

import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols
from impactosc.engine._hybrid import RULED_ZENO_SCALE

G, E, H = 9.81, 0.8, 1.0
U0 = math.sqrt(2.0 * G * H)
ZENO = math.sqrt(2.0 * H / G) + 2.0 * E * U0 / (G * (1.0 - E))
BACKENDS = {"heyoka": 1e-13, "scipy": 1e-10}  # scipy's DOP853 at rtol = 1e-12 over ~20 flights


class Zeno:
    """The ball's accumulation in closed form, once an impact is slower than ``threshold`` (hashable, picklable)."""

    def __init__(self, threshold: float, answer=None):
        self.threshold = threshold
        self.answer = answer

    def __eq__(self, other):
        return type(other) is Zeno and (other.threshold, other.answer) == (self.threshold, self.answer)

    def __hash__(self):
        return hash((self.threshold, self.answer))

    def __call__(self, t, before, after, p):
        g, e = p
        u = abs(before[1])
        if u >= self.threshold:
            return None
        if self.answer is not None:
            return self.answer
        left = 2.0 * e * u / (g * (1.0 - e))
        return t + left, (0.0, 0.0), (left,)  # the flights' time goes into the integral T


def ball(rule, rest_reset=()):
    x, v, g, e = symbols("x v g e")
    return HybridSystem("x v", {"g": G, "e": E},
                        [HybridMode("flight", {x: v, v: -g}, integrands={"T": 1.0}),
                         HybridMode("floor", {x: 0.0, v: 0.0})],
                        [Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v}, rest="floor",
                               rest_reset=rest_reset, accumulation=rule)],
                        integrals="T")


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_a_rule_jumps_to_the_closed_form_zeno_time(backend):
    sol = impactosc.simulate(ball(Zeno(0.1)), 20.0, [H, 0.0], backend=backend)
    assert sol.status == 0, sol.message
    # u0 0.8^17 = 0.0998 < 0.1: the 18th impact is the first the rule answers at, then the rest
    kinds = [e.kind for e in sol.events]
    assert kinds == ["crossing"] * 18 + ["rest"]
    rest = sol.events[-1]
    assert rest.t == pytest.approx(ZENO, abs=BACKENDS[backend])
    assert rest.mode_after == "floor" and rest.state_after[:2] == (0.0, 0.0)
    # the integral T (the time in flight) moved on by the rule's increment: the whole time to rest
    assert sol.integrals["T"] == pytest.approx(ZENO, abs=BACKENDS[backend])
    assert (sol.t_final, tuple(sol.state_final[:2])) == (20.0, (0.0, 0.0))


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_the_watch_of_event_times_acts_much_later_on_a_guard_with_a_rule(backend):
    """A rule that never answers: the watch of event times ends the accumulation (no hang, no ball through the
    floor), with a tolerance RULED_ZENO_SCALE times finer: more impacts than without a rule."""
    plain = impactosc.simulate(ball(None), 20.0, [H, 0.0], backend=backend)
    never = impactosc.simulate(ball(Zeno(-1.0), rest_reset={"v": 0.0}), 20.0, [H, 0.0], backend=backend)
    for sol in (plain, never):
        assert sol.status == 0, sol.message
        assert [e.kind for e in sol.events].count("rest") == 1
    # the watch declares it with the time left below zeno_tol (1 + t) (times the scale): e^k ~ that ratio
    extra = math.log(RULED_ZENO_SCALE) / math.log(E)
    assert len(never.events) - len(plain.events) == pytest.approx(extra, abs=3)
    assert never.events[-1].t == pytest.approx(ZENO, abs=1e-7 * (1.0 + ZENO))


@pytest.mark.parametrize("backend", list(BACKENDS))
@pytest.mark.parametrize("answer, words", [((0.0, (0.0, 0.0)), "must be finite and >= t"),
                                           ((5.0, (0.0,)), "2 states"),
                                           ("soon", "must return None or")])
def test_a_wrong_answer_of_a_rule_ends_the_run_naming_its_guard(backend, answer, words):
    sol = impactosc.simulate(ball(Zeno(0.1, answer)), 20.0, [H, 0.0], backend=backend)
    assert sol.status == -1
    assert "guard 'impact'" in sol.message and words in sol.message
    assert [e.kind for e in sol.events] == ["crossing"] * 18  # what was computed is kept


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_a_ball_at_rest_a_hair_above_the_floor_falls_before_it_lands(backend):
    """Released at rest 5e-13 above the floor (within the touch tolerance of the impact guard, its rate 0 and
    its curvature towards it): the guard's crossing is ahead, after sqrt(2 x0 / g) = 3.2e-7, at speed
    sqrt(2 g x0). It was taken for an impact at t = 0 with no speed."""
    x0 = 5e-13
    sol = impactosc.simulate(ball(None), 1e-6, [x0, 0.0], backend=backend)
    assert sol.status == 0, sol.message
    first = sol.events[0]
    assert first.t == pytest.approx(math.sqrt(2.0 * x0 / G), rel=1e-6)
    assert first.state_before[1] == pytest.approx(-math.sqrt(2.0 * G * x0), rel=1e-6)


def test_an_accumulation_rule_is_checked_at_construction():
    x, v = symbols("x v")

    def guard(**kwargs):
        return Guard("impact", x, -1, armed="flight", to="flight", reset={v: -v}, **kwargs)

    with pytest.raises(TypeError, match="guard 'impact': accumulation must be a callable"):
        guard(rest="floor", accumulation=3.0)
    with pytest.raises(ValueError, match="guard 'impact': accumulation=.* without a rest mode"):
        guard(accumulation=Zeno(0.1))

    class Unhashable(Zeno):
        __hash__ = None  # type: ignore[assignment]

    with pytest.raises(TypeError, match="guard 'impact': accumulation must be hashable"):
        guard(rest="floor", accumulation=Unhashable(0.1))


def test_the_rule_is_part_of_the_structure():
    assert ball(Zeno(0.1)).structure == ball(Zeno(0.1)).structure
    assert ball(Zeno(0.1)).structure != ball(Zeno(0.2)).structure
    assert ball(Zeno(0.1)).with_parameters(e=0.5).structure == ball(Zeno(0.1)).structure
