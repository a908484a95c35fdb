"""Examples of user hybrid systems, each against a closed form.

Every example is linear (affine, with harmonic forcing) between events, so each piece has the
closed form ``Y(t0 + s) = expm(A s) Y(t0)`` on the state augmented with ``1`` and with
``cos``/``sin`` of the forcing phase; the reference locates each guard's root on it (a scan, then
Brent's method on the closed form) and applies the resets. The paper's eq. 3 written as a user
system is checked against the built-in closed-form engine (``backend="exact"``).
"""

import math

import heyoka as hy
import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

import impactosc
from impactosc import Guard, HybridMode, HybridSystem, stick_slip, symbols
from impactosc.model.hybrid import oscillator_system


def linear_reference(modes, guards, mode0, y0, t_end, omega=1.0, scan=0.01):
    """Event times and modes of a piecewise-affine system with forcing at frequency ``omega``, in closed form.

    ``modes[m]`` is the matrix of the augmented state ``Y = (y, 1, cos(omega t), sin(omega t))``
    (the last three rows are filled here); ``guards`` is a list of ``(row vector c, direction,
    armed mode, next mode, reset matrix of y or None)`` on ``c . Y``.
    """
    n = len(y0)
    N = n + 3

    def full(A):
        M = np.zeros((N, N))
        M[:n, :] = A
        M[n + 1, n + 2] = -omega
        M[n + 2, n + 1] = omega
        return M

    mats = {m: full(np.asarray(A, dtype=float)) for m, A in modes.items()}
    t, mode = 0.0, mode0
    Y = np.concatenate([y0, [1.0, 1.0, 0.0]])
    out = []
    while t < t_end:
        M = mats[mode]
        step = expm(M * scan)
        armed = [(i, g) for i, g in enumerate(guards) if g[2] == mode]
        found = None
        Yk, s = Y.copy(), 0.0
        while found is None and t + s < t_end:
            Yn = step @ Yk
            for i, (c, d, _, _, _) in armed:
                a, b = float(np.dot(c, Yk)), float(np.dot(c, Yn))
                if (d > 0 and a < 0.0 <= b) or (d < 0 and a > 0.0 >= b):
                    root = brentq(lambda u, c=c, M=M, Y=Y: float(np.dot(c, expm(M * u) @ Y)), s, s + scan, xtol=1e-15,
                                  rtol=4 * np.finfo(float).eps, maxiter=200)
                    if found is None or root < found[0]:
                        found = (root, i)
            Yk, s = Yn, s + scan
        if found is None:
            break
        root, i = found
        Y = expm(M * root) @ Y
        t += root
        _, _, _, to, R = guards[i]
        if R is not None:
            Y[:n] = np.asarray(R, dtype=float) @ Y[:n]
        out.append((t, i, mode, to))
        mode = to
    return out


x, v, x1, v1, x2, v2 = symbols("x v x1 v1 x2 v2")


def test_damped_one_sided_impact_oscillator():
    """x'' + 2 zeta x' + x = A cos(w t); at x = d moving up, v -> -e v (the form of COCO's impact demo)."""
    zeta, A, w, d, e = symbols("zeta A w d e")
    values = {"zeta": 0.05, "A": 1.2, "w": 0.8, "d": 0.6, "e": 0.7}
    system = HybridSystem("x v", values, [HybridMode("free", {x: v, v: A * hy.cos(w * hy.time) - x - 2 * zeta * v})],
                          [Guard("impact", x - d, 1, armed="free", to="free", reset={v: -e * v})], name="impact")
    z, amp = values["zeta"], values["A"]
    mode = [[0, 1, 0, 0, 0], [-1, -2 * z, 0, amp, 0]]
    guard = (np.array([1, 0, -values["d"], 0, 0]), 1, "free", "free", [[1, 0], [0, -values["e"]]])
    ref = linear_reference({"free": mode}, [guard], "free", [0.0, 0.0], 60.0, omega=values["w"])
    assert len(ref) > 10
    for backend, tol in (("heyoka", 1e-12), ("scipy", 1e-8)):
        sol = impactosc.simulate(system, 60.0, [0.0, 0.0], backend=backend)
        assert sol.status == 0
        np.testing.assert_allclose(sol.event_times(), [r[0] for r in ref], rtol=0, atol=tol)


def test_two_mass_impact_oscillator_with_one_stop():
    """Two masses coupled by a spring, the first forced and stopped by a rigid wall at x1 = d."""
    k, c, A, w, d, e = symbols("k c A w d e")
    values = {"k": 2.0, "c": 0.02, "A": 1.5, "w": 0.9, "d": 0.5, "e": 0.8}
    field = {x1: v1, v1: A * hy.cos(w * hy.time) - x1 - k * (x1 - x2) - c * v1, x2: v2, v2: -k * (x2 - x1) - c * v2}
    system = HybridSystem("x1 v1 x2 v2", values, [HybridMode("free", field)],
                          [Guard("stop", x1 - d, 1, armed="free", to="free", reset={v1: -e * v1})], name="two masses")
    kk, cc = values["k"], values["c"]
    mode = [[0, 1, 0, 0, 0, 0, 0], [-1 - kk, -cc, kk, 0, 0, values["A"], 0],
            [0, 0, 0, 1, 0, 0, 0], [kk, 0, -kk, -cc, 0, 0, 0]]
    R = np.diag([1.0, -values["e"], 1.0, 1.0])
    guard = (np.array([1, 0, 0, 0, -values["d"], 0, 0]), 1, "free", "free", R)
    ref = linear_reference({"free": mode}, [guard], "free", [0.0, 0.0, 0.0, 0.0], 80.0, omega=values["w"])
    assert len(ref) > 10
    sol = impactosc.simulate(system, 80.0, [0.0, 0.0, 0.0, 0.0])
    assert sol.status == 0
    np.testing.assert_allclose(sol.event_times(), [r[0] for r in ref], rtol=0, atol=1e-11)


def test_relay_feedback_system():
    """x'' + 2 zeta x' + x = -u, u = sign(x + a v) switched by a relay: two affine modes."""
    zeta, a = symbols("zeta a")
    values = {"zeta": -0.1, "a": 0.05}  # unstable linear part: the relay makes a limit cycle
    s = x + a * v
    modes = [HybridMode("on", {x: v, v: -x - 2 * zeta * v - 1.0}),
             HybridMode("off", {x: v, v: -x - 2 * zeta * v + 1.0})]
    guards = [Guard("switch off", s, -1, armed="on", to="off"), Guard("switch on", s, 1, armed="off", to="on")]
    system = HybridSystem("x v", values, modes, guards, name="relay")
    z, aa = values["zeta"], values["a"]
    mats = {"on": [[0, 1, 0, 0, 0], [-1, -2 * z, -1, 0, 0]], "off": [[0, 1, 0, 0, 0], [-1, -2 * z, 1, 0, 0]]}
    c = np.array([1, aa, 0, 0, 0])
    ref = linear_reference(mats, [(c, -1, "on", "off", None), (c, 1, "off", "on", None)], "on", [0.5, 0.0], 40.0)
    assert len(ref) > 10
    sol = impactosc.simulate(system, 40.0, [0.5, 0.0], mode="on")
    np.testing.assert_allclose(sol.event_times(), [r[0] for r in ref], rtol=0, atol=1e-12)
    assert [e.mode_after for e in sol.events] == [r[3] for r in ref]


@pytest.mark.parametrize("backend, tol", [("heyoka", 1e-12), ("scipy", 1e-9)])
def test_dry_friction_oscillator_sticks_as_the_closed_form_does(backend, tol):
    """x'' + x = A cos(w t) - mu sgn(x') with stick phases (stick_slip), against the exact backend."""
    A, w, mu = symbols("A w mu")
    modes, guards = stick_slip("m", v, A * hy.cos(w * hy.time) - x, mu, rates={x: v})
    system = HybridSystem("x v", {"A": 0.4, "w": 0.3, "mu": 0.3}, modes, guards, name="dry friction")
    osc = impactosc.Oscillator(F=0.4, Omega=0.3, beta=0.3, gap_upper=None, gap_lower=None)
    ref = impactosc.simulate(osc, 100.0, 0.2, 0.0, backend="exact")
    sol = impactosc.simulate(system, 100.0, [0.2, 0.0], backend=backend)
    kinds = {"m+ stop", "m- stop", "m release+", "m release-"}
    assert {e.guard for e in sol.events} == kinds  # it sticks and releases both ways
    assert sum(e.mode_after == "m0" for e in sol.events) == int(ref.counts["stick"]) > 3
    np.testing.assert_allclose(sol.event_times(), ref.events["t"], rtol=0, atol=tol)


CASES = {
    "contact": dict(F=0.5, Omega=1.1, beta=0.01, K=1e4),
    "damped, static friction": dict(F=0.3, Omega=0.7, beta=0.05, K=100.0, zeta=0.02, beta_static=0.08),
    "rigid": dict(F=0.5, Omega=1.1, beta=0.01, flange="rigid", restitution=0.8),
}


@pytest.mark.parametrize("case", list(CASES))
def test_eq3_as_a_user_system_agrees_with_the_builtin_engine(case):
    osc = impactosc.Oscillator(**CASES[case])
    t_end = 400.0 if case == "contact" else 200.0
    ref = impactosc.simulate(osc, t_end, backend="exact")
    sol = impactosc.simulate(oscillator_system(osc), t_end, [0.95, 0.0])
    assert sol.status == 0
    if case == "contact":
        assert len(sol.events) == 328
    # event by event: the same times (double-precision rounding accumulated over t_end)
    np.testing.assert_allclose(sol.event_times(), ref.events["t"], rtol=0, atol=1e-12)
    if not osc.rigid:
        assert sol.integrals["Q"] == pytest.approx(ref.flange_impulse(), rel=1e-12)


def test_eq3_with_a_harmonic_and_one_flange():
    osc = impactosc.Oscillator(F=0.4, Omega=0.9, beta=0.02, K=1e3, harmonics=[(0.1, 2.2, 0.3)], gap_upper=1.2,
                               gap_lower=None)
    ref = impactosc.simulate(osc, 200.0, backend="exact")
    sol = impactosc.simulate(oscillator_system(osc), 200.0, [0.95, 0.0])
    np.testing.assert_allclose(sol.event_times(), ref.events["t"], rtol=0, atol=1e-10)
    assert sol.integrals["Q"] == pytest.approx(ref.flange_impulse(), rel=1e-10)


def test_power_law_flange_is_written_with_its_boundary_layers():
    """``d^p`` is not analytic at ``d = 0``: each flange has a layer mode left at the layer's edge
    (the runs are checked in tests/test_one_loop_power.py)."""
    system = oscillator_system(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4, exponent=1.5))
    assert system.mode_names[-2:] == ("upper_layer+", "lower_layer-")
    assert dict(system.parameters)["exponent"] == 1.5 and 0.0 < dict(system.parameters)["layer"] < 1e-13


@pytest.mark.parametrize("backend, above", [("heyoka", 1e-12), ("scipy", 1e-9)])
@pytest.mark.parametrize("side, kind", [(-1, "grazing"), (0, None), (1, "crossing")])
def test_grazing_is_never_missed(backend, above, side, kind):
    """x'' = -x from (0, a): the guard x - 1 has its maximum a - 1 at t = pi/2.

    Just below zero it is a grazing (recorded, no transition); just above, a crossing whose two
    roots are close (2e-6 apart for 1e-12 above); exactly on zero, rounding decides between the
    two. Never nothing. Above: beyond each backend's error (scipy: rtol = 1e-12); below: within
    the grazing tolerance (graze_tol (1 + max |y|) = 2e-10).
    """
    amplitude = 1.0 + (above if side > 0 else 1e-11 * side)
    system = HybridSystem("x v", {}, [HybridMode("free", {x: v, v: -x})],
                          [Guard("wall", x - 1.0, 1, armed="free", to="free", reset={v: -v})], name="graze")
    sol = impactosc.simulate(system, 3.0, [0.0, amplitude], backend=backend)
    assert len(sol.events) == 1 and sol.events[0].guard == "wall"
    assert kind is None or sol.events[0].kind == kind
    assert sol.events[0].t == pytest.approx(math.pi / 2, abs=1e-4)
