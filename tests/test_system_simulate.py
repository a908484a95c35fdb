"""User hybrid systems run by simulate(): closed forms, then heyoka against scipy."""

import math

import numpy as np
import pytest

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, symbols

x, v, g, e = symbols("x v g e")


def ball(restitution=0.8):
    return HybridSystem("x v", {"g": 9.81, "e": restitution}, [HybridMode("flight", {x: v, v: -g})],
                        [Guard("impact", x, -1, armed="flight", to="flight", reset={v: -e * v})], name="ball")


def ball_times(h, gr, r, n):
    """Impact times of a ball dropped from h: t1 = sqrt(2h/g), then 2 v_k / g with v_k = r^k sqrt(2 g h)."""
    t, speed, out = math.sqrt(2 * h / gr), math.sqrt(2 * gr * h), []
    for _ in range(n):
        out.append(t)
        speed *= r
        t += 2 * speed / gr
    return np.array(out)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
@pytest.mark.parametrize("restitution", [0.5, 0.8, 0.9])
def test_bouncing_ball_events_and_zeno_time(backend, restitution):
    sol = impactosc.simulate(ball(restitution), 30.0, [1.0, 0.0], backend=backend)
    times = sol.event_times("impact")
    want = ball_times(1.0, 9.81, restitution, times.size)
    tol = 1e-12 if backend == "heyoka" else 1e-9
    np.testing.assert_allclose(times, want, rtol=0, atol=tol)
    zeno = math.sqrt(2 / 9.81) * (1 + 2 * restitution / (1 - restitution))
    assert sol.status == 2 and "Zeno" in sol.message
    assert sol.accumulation_time == pytest.approx(zeno, abs=tol)
    assert sol.t_final < zeno
    # the velocity after each impact is -e times the one before
    ev = sol.events[3]
    assert ev.state_after[1] == pytest.approx(-restitution * ev.state_before[1], rel=1e-14)
    assert (ev.mode_before, ev.mode_after, ev.kind) == ("flight", "flight", "crossing")


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_dense_output_is_the_parabola(backend):
    sol = impactosc.simulate(ball(), 1.0, [1.0, 0.0], backend=backend)
    t1 = math.sqrt(2 / 9.81)
    s = np.array([0.2, t1 + 0.1])
    got = sol.sample(s)
    v1 = 0.8 * math.sqrt(2 * 9.81)
    want = np.array([[1 - 9.81 * 0.02, -9.81 * 0.2], [v1 * 0.1 - 9.81 * 0.005, v1 - 0.981]])
    np.testing.assert_allclose(got, want, atol=1e-9)
    assert sol.status == 0 and sol.t_final == 1.0
    with pytest.raises(ValueError, match="sample: times"):
        sol.sample([2.0])


def test_event_limit_keeps_results_and_bad_state_is_named():
    sol = impactosc.simulate(ball(), 30.0, [1.0, 0.0], max_events=3)
    assert sol.status == 1 and len(sol.events) == 3 and "max_events=3" in sol.message
    with pytest.raises(ValueError, match="state0 has 3 values"):
        impactosc.simulate(ball(), 1.0, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="backend must be one of"):
        impactosc.simulate(ball(), 1.0, [1.0, 0.0], backend="exact")
    with pytest.raises(TypeError, match="does not accept that option"):
        impactosc.simulate(ball(), 1.0, [1.0, 0.0], backend="heyoka", rtol=1e-9)
    with pytest.raises(ValueError, match="tol must be in"):
        impactosc.simulate(ball(), 1.0, [1.0, 0.0], tol=1e-200)
    # the built-in oscillator's arguments are refused, not silently ignored
    with pytest.raises(TypeError, match="v0=0.5"):
        impactosc.simulate(ball(), 1.0, [1.0, 0.0], 0.5)
    with pytest.raises(ValueError, match="record='stats'"):
        impactosc.simulate(ball(), 1.0, [1.0, 0.0], record="stats")
    with pytest.raises(TypeError, match="sample_at"):
        impactosc.simulate(ball(), 1.0, [1.0, 0.0], sample_at=[0.5])


k = symbols("k")


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_run_that_blows_up_fails_and_keeps_what_it_computed(backend):
    """x' = x^2 from 1 blows up at t = 1: status -1, the event at x = 1.5 (t = 1/3) kept."""
    system = HybridSystem("x", {"k": 1.0}, [HybridMode("a", {x: k * x * x}), HybridMode("b", {x: k * x * x})],
                          [Guard("half", x - 1.5, 1, armed="a", to="b")], name="blow-up")
    sol = impactosc.simulate(system, 2.0, [1.0], backend=backend)
    assert sol.status == -1 and "'b'" in sol.message
    assert [e.guard for e in sol.events] == ["half"] and sol.events[0].t == pytest.approx(1 / 3, abs=1e-12)
    assert 0.99 < sol.t_final <= 1.0 + 1e-9
    assert sol.sample([0.5])[0, 0] == pytest.approx(2.0, rel=1e-9)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_transition_without_an_admissible_mode_is_named(backend):
    system = HybridSystem("x v", {}, [HybridMode("a", {x: v, v: -x}), HybridMode("b", {x: v, v: -x}, entry=[x + 10.0]),
                                      HybridMode("c", {x: v, v: -x}, entry=[x + 10.0])],
                          [Guard("g", x, -1, armed="a", to=("b", "c"), reset={x: x - 20.0})], name="no mode")
    sol = impactosc.simulate(system, 10.0, [1.0, 0.0], backend=backend, mode="a")
    assert sol.status == -1 and "guard 'g'" in sol.message and "['b', 'c']" in sol.message
    assert sol.t_final == pytest.approx(math.pi / 2, abs=1e-9)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_sliding_relay_ends_as_an_accumulation_at_one_instant(backend):
    """A relay whose two fields both point at the switching surface (a Filippov sliding motion that the
    user did not model as a mode): each switch lands on the other guard at once. Status 2, no hang."""
    zeta, a = symbols("zeta a")
    s = x + a * v
    system = HybridSystem("x v", {"zeta": -0.1, "a": 0.3},
                          [HybridMode("on", {x: v, v: -x - 2 * zeta * v - 1.0}),
                           HybridMode("off", {x: v, v: -x - 2 * zeta * v + 1.0})],
                          [Guard("switch off", s, -1, armed="on", to="off"),
                           Guard("switch on", s, 1, armed="off", to="on")], name="sliding relay")
    sol = impactosc.simulate(system, 40.0, [0.5, 0.0], mode="on", backend=backend)
    assert sol.status == 2 and "one instant" in sol.message
    assert sol.accumulation_time == pytest.approx(sol.t_final) and len(sol.events) > 64


def test_a_crossing_lost_inside_a_step_is_applied_at_its_first_root(monkeypatch):
    """Make the heyoka loop lose the crossing of x - 1 (x = 1.5 sin t): the guard's maximum, past zero,
    reveals it, and the event is applied at its first root asin(2/3), not at the maximum pi/2."""
    from impactosc.backends import _hybrid_heyoka

    crossing = _hybrid_heyoka._Run.crossing
    lost = []

    def lose_first(self, ta, g):
        if not lost:
            lost.append(ta.time)
            return True  # as if the root had not been located
        return crossing(self, ta, g)

    monkeypatch.setattr(_hybrid_heyoka._Run, "crossing", lose_first)
    system = HybridSystem("x v", {}, [HybridMode("free", {x: v, v: -x})],
                          [Guard("wall", x - 1.0, 1, armed="free", to="free", reset={v: -v})], name="lost root")
    sol = impactosc.simulate(system, 1.7, [0.0, 1.5])
    assert lost and sol.status == 0
    assert [(e.guard, e.kind) for e in sol.events] == [("wall", "crossing")]
    assert sol.events[0].t == pytest.approx(math.asin(2 / 3), abs=1e-12)
    assert sol.events[0].state_after[1] == pytest.approx(-1.5 * math.cos(math.asin(2 / 3)), rel=1e-12)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_solution_pickles_and_samples_after(backend):
    import pickle

    sol = impactosc.simulate(ball(), 1.0, [1.0, 0.0], backend=backend)
    copy = pickle.loads(pickle.dumps(sol))
    assert copy.event_times() == pytest.approx(sol.event_times(), abs=0)
    np.testing.assert_allclose(copy.sample([0.3, 0.9]), sol.sample([0.3, 0.9]), rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_reset_that_lands_on_a_guard_fires_it_at_once(backend):
    """x' = 1: at x = 1 the guard "jump" moves x to 2, onto the guard "land" (x - 2, rising) of the next mode."""
    modes = [HybridMode(m, {x: 1.0, v: 0.0}) for m in ("A", "B", "C")]
    guards = [Guard("jump", x - 1.0, 1, armed="A", to="B", reset={x: x + 1.0}),
              Guard("land", x - 2.0, 1, armed="B", to="C")]
    system = HybridSystem("x v", {}, modes, guards, name="landing")
    sol = impactosc.simulate(system, 3.0, [0.0, 0.0], mode="A", backend=backend)
    assert [(e.guard, e.mode_before, e.mode_after) for e in sol.events] == [("jump", "A", "B"), ("land", "B", "C")]
    assert sol.events[1].t == sol.events[0].t == pytest.approx(1.0, abs=1e-12)
    assert sol.mode_final == "C" and sol.state_final[0] == pytest.approx(4.0, abs=1e-12)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_two_guards_at_one_instant_both_fire(backend):
    """x' = 1, y' = 1 from (0, 0): x - 1 and y - 1 reach zero together. Whichever fires first, the other
    (armed again in the mode the first leads to) fires at once: mode D after two events at t = 1."""
    y = symbols("y")
    modes = [HybridMode(m, {x: 1.0, y: 1.0}) for m in ("A", "B", "C", "D")]
    guards = [Guard("x first", x - 1.0, 1, armed="A", to="B"), Guard("y first", y - 1.0, 1, armed="A", to="C"),
              Guard("y second", y - 1.0, 1, armed="B", to="D"), Guard("x second", x - 1.0, 1, armed="C", to="D")]
    system = HybridSystem("x y", {}, modes, guards, name="two at once")
    sol = impactosc.simulate(system, 2.0, [0.0, 0.0], mode="A", backend=backend)
    assert sol.mode_final == "D" and len(sol.events) == 2
    assert all(e.t == pytest.approx(1.0, abs=1e-12) for e in sol.events)


@pytest.mark.parametrize("backend", ["heyoka", "scipy"])
def test_a_system_without_guards_and_with_an_unused_parameter(backend):
    """x' = -k x: exp(-k t); the parameter q appears in no expression."""
    system = HybridSystem("x", {"k": 0.5, "q": 3.0}, [HybridMode("decay", {x: -k * x})], name="decay")
    sol = impactosc.simulate(system, 2.0, [1.0], backend=backend)
    assert sol.status == 0 and sol.events == []
    assert sol.state_final[0] == pytest.approx(math.exp(-1.0), rel=1e-11)


def test_long_vector_fields_that_print_alike_stay_apart():
    # heyoka prints an expression cut after about 1000 characters ("... + ..."): two modes whose
    # long rates differ only in their last term must not be merged into one, and two systems
    # that differ only there must not share a compiled integrator
    import heyoka as hy

    from impactosc import simulate
    from impactosc.model.hybrid import Guard, HybridMode, HybridSystem

    names = [f"x{i}" for i in range(40)]
    xs = hy.make_vars(*names)
    terms = [x * (1.0 + 1e-3 * i) for i, x in enumerate(xs[1:-1])]

    def system(last: float) -> HybridSystem:
        # the distinguishing term last: it is where the printed text is cut
        rates = {xs[0]: hy.sum([*terms, last * xs[-1]])}
        rates.update({x: hy.expression(0.0) for x in xs[1:]})
        mode = HybridMode("m", rates)
        return HybridSystem(names, modes=[mode], guards=[Guard("g", xs[0] - 1e9, 1, "m")])

    a, b = system(1.0), system(2.0)
    rate = a.modes[0].field[0]
    assert "..." in str(rate[1] if isinstance(rate, tuple) else rate)  # the text really is cut
    assert a.structure != b.structure
    y0 = [0.0] * 39 + [1.0]
    xa = simulate(a, 1.0, y0).sample([1.0])
    xb = simulate(b, 1.0, y0).sample([1.0])
    # x0' = sum of the constant states x1..x38 (all 0) + last * x39 (= 1): x0(1) = last
    assert abs(float(xa[0][0]) - 1.0) < 1e-12 and abs(float(xb[0][0]) - 2.0) < 1e-12
