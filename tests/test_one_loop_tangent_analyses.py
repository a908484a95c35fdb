"""Issue 27 item 4: the analyses that follow a run's Jacobian, on the one heyoka loop, against exact.

Periodic orbits with their Floquet multipliers (shooting on the stroboscopic map), Lyapunov
exponents (the Jacobian renormalised at sample stops), the contact margin that stops at the
first contact (``stop_at_contact``) and a continuation with its special points: on
``backend="heyoka"`` each is the one hybrid loop's run replayed into the engine's recorders
(``dynamics.tangent.drive_recorder``), on ``backend="exact"`` the compiled closed form driven
by the engine. Closed forms where there are (Den Hartog's amplitude and onset), then heyoka
against exact.

Tolerances: the orbits are Newton fixed points to ``tol = 1e-11`` of maps whose event times
both backends locate to ~1e-12, so states agree to ~1e-10 and multipliers (a product of
a few saltation and transition matrices, entries O(1)) to ~1e-10: 1e-8 leaves a margin of 100.
The continuation's special points are located to ``tol = 1e-12`` on both; the issue asks for
the same points within 1e-8.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import impactosc as io
import impactosc.dynamics as dy
from impactosc.dynamics import contact_margin, continuation, lyapunov_exponent, periodic_orbit

OMEGA, BETA = 1.5, 0.1
FC = dy.den_hartog_onset(OMEGA, BETA)
#: the contact-free Den Hartog orbit at 0.8 Fc (tests/test_continuation.py)
DH_GUESS = (-0.7891869048001374, 0.16283153617831878)
DEN_HARTOG = io.Oscillator(0.8 * FC, OMEGA, BETA, 24.0)
#: a rigid one-sided stop with damping and a static push (tests/test_continuation.py): period doubling, grazing
STOP = io.Oscillator.from_harmonics([(0.5, 0.8, 0.0), (0.5, 0.0, 0.0)], beta=0.0, K=1.0, zeta=0.05, flange="rigid",
                                    restitution=0.8)
STICK_ORBIT = io.Oscillator(0.5, 0.5, 0.05, 1e4, beta_static=0.08)  # stick phases: a multiplier exactly 0
SOFT = io.Oscillator(0.8, 1.3, 0.05, 10.0)


def _same_multipliers(a, b, tol):
    """Sum and product of the pair (a complex pair's order is rounding), and the moduli."""
    assert abs(np.sum(a) - np.sum(b)) < tol and abs(np.prod(a) - np.prod(b)) < tol
    np.testing.assert_allclose(np.sort(np.abs(a)), np.sort(np.abs(b)), rtol=0, atol=tol)


@pytest.mark.parametrize("case", ["den hartog", "rigid stop", "stick orbit", "contact case"])
def test_floquet_multipliers_on_heyoka_are_the_exact_backends(case):
    kw = {"den hartog": (DEN_HARTOG, 1, {"guess": DH_GUESS}),
          "rigid stop": (STOP, 1, {"phase": math.pi}),
          "stick orbit": (STICK_ORBIT, 1, {"transient_periods": 60}),
          "contact case": (io.Oscillator(0.5, 1.1, 0.01, 1e4), 3, {"transient_periods": 200})}[case]
    osc, n, start = kw
    ref = periodic_orbit(osc, n, backend="exact", **start)
    section = {k: w for k, w in start.items() if k == "phase"}
    orb = periodic_orbit(osc, n, backend="heyoka", guess=(ref.x, ref.v), **section)
    assert ref.status == orb.status == 0, (ref.message, orb.message)
    assert (orb.x, orb.v) == pytest.approx((ref.x, ref.v), abs=1e-9)
    _same_multipliers(orb.multipliers, ref.multipliers, 1e-8)
    assert orb.stability == ref.stability and orb.collapsed == ref.collapsed
    if case == "den hartog":  # no contact: the closed-form amplitude
        assert max(abs(orb.solution.events.x)) == pytest.approx(dy.den_hartog_amplitude(0.8 * FC, OMEGA, BETA),
                                                                abs=1e-9)
    if case == "stick orbit":
        assert min(abs(orb.multipliers)) == 0.0


@pytest.mark.parametrize("case", ["soft flanges", "stick orbit", "rigid impacts", "chatter"])
def test_lyapunov_exponents_on_heyoka_are_the_exact_backends(case):
    osc, x0, periods = {"soft flanges": (SOFT, 0.5, 30), "stick orbit": (STICK_ORBIT, 0.2, 30),
                        "rigid impacts": (io.Oscillator(0.8, 1.1, 0.05, flange="rigid", restitution=0.8), 0.5, 30),
                        "chatter": (io.Oscillator(2.0, 0.3, 0.05, 1.0, flange="rigid", restitution=0.5), 0.0,
                                    5)}[case]
    ref, res = (lyapunov_exponent(osc, periods, transient_periods=0, x0=x0, v0=0.0, backend=b, renormalise_every=1)
                for b in ("exact", "heyoka"))
    assert res.status == ref.status
    if case == "chatter":  # every perturbation dies at the chatter's end
        assert res.status == 3 and res.exponent == -math.inf
        return
    assert res.status == 0
    # a mean of logs of renormalised growths over ~30 periods, each product of matrices agreeing to ~1e-10
    assert res.exponent == pytest.approx(ref.exponent, abs=1e-10)
    np.testing.assert_allclose(res.history, ref.history, rtol=0, atol=1e-9)


def test_the_contact_margin_that_stops_at_the_first_contact_on_heyoka():
    touching = io.Oscillator(0.5, 1.1, 0.01, 1e4)
    for backend in ("heyoka", "exact"):
        assert contact_margin(touching, transient_periods=50, record_periods=2, stop_at_contact=True,
                              backend=backend) == 0.0
    # no contact: 1 - Den Hartog's amplitude, on either backend, through the watch that did not stop
    clear = io.Oscillator(0.3, 0.8, 0.05, 1e4)
    margins = [contact_margin(clear, transient_periods=100, record_periods=2, stop_at_contact=True, backend=b)
               for b in ("heyoka", "exact")]
    assert margins[0] == pytest.approx(0.819559119886055 - 1.0, abs=1e-9)
    assert margins[0] == pytest.approx(margins[1], abs=1e-10)


def test_the_contact_watch_stops_the_replay_at_the_first_contact_after_its_window_opens():
    from impactosc.dynamics import onset

    events = []
    real = onset._ContactWatch.event

    def spy(self, t, kind, *rest):
        events.append((t, kind))
        return real(self, t, kind, *rest)

    onset._ContactWatch.event = spy
    try:
        osc = io.Oscillator(0.5, 1.1, 0.01, 1e4)
        T = 2.0 * math.pi / 1.1
        assert contact_margin(osc, transient_periods=5, record_periods=5, stop_at_contact=True,
                              backend="heyoka") == 0.0
    finally:
        onset._ContactWatch.event = real
    assert events[-1][1] == "contact_start" and events[-1][0] >= 5 * T
    assert all(t < 5 * T or kind not in ("contact_start", "impact", "chatter") for t, kind in events[:-1])


def test_a_continuation_on_heyoka_finds_the_exact_backends_special_points():
    """Den Hartog's branch in F through its grazing (at the closed-form onset Fc) and the fold past it."""
    orb = periodic_orbit(DEN_HARTOG, guess=DH_GUESS, backend="exact")
    branches = {b: continuation(orb, "F", (0.5 * FC, 1.1 * FC), tol=1e-12, backend=b) for b in ("exact", "heyoka")}
    ref, br = branches["exact"], branches["heyoka"]
    assert br.status == ref.status == 0, br.message
    kinds = [s.kind for s in br.special]
    assert kinds == [s.kind for s in ref.special] and {"grazing", "fold"} <= set(kinds)
    for a, b in zip(br.special, ref.special, strict=True):
        assert abs(a.parameter - b.parameter) < 1e-8, (a.kind, a.parameter, b.parameter)
        assert np.max(np.abs(np.asarray(a.state) - np.asarray(b.state))) < 1e-8
    graze = br.find("grazing")[0]
    assert abs(graze.parameter / FC - 1.0) < 1e-9  # Den Hartog's onset
