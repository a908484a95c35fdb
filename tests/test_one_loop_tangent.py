"""Issue 27 item 4: the tangent dynamics on the one heyoka loop (``drive_on_hybrid_loop``).

``tangent_run(..., backend="heyoka")`` runs the member on the one hybrid loop and replays its run
into the ``TangentRecorder`` with the calls the engine's ``drive`` makes for the other backends.
Closed forms of the Jacobian first (a free linear piece, a chatter's zero), then the Jacobian
against ``backend="exact"`` (the compiled closed form, driven by the engine) on spring and rigid
members with contacts, sticks and chatter, and against finite differences of ``simulate``; then
the calls themselves, call by call against the engine's ``drive``; the tolerance option.

Tolerances. Both backends locate events to about machine precision in time (heyoka at
``tol = eps`` on Taylor polynomials, exact on closed forms): event times agree to ~1e-12 over
these runs. A Jacobian entry moves with an event time ``dt`` by at most ``|A| |J| dt`` with
``|A| <= 1 + K`` the stiffest mode's matrix, so ``1e4 * 1e-12`` relative on the stiff contact
case and ~1e-12 on the others: 1e-8 and 1e-10 relative to the largest entry leave a margin of
100 over that bound (measured: 7e-11 and below 1e-12).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import impactosc
from impactosc.dynamics.flow import linear_transition
from impactosc.dynamics.tangent import TangentRecorder, drive_recorder, evaluator_of, tangent_run

CONTACT = impactosc.Oscillator(0.5, 1.1, 0.01, 1e4)  # the paper's eq. 3, the contact case
SOFT = impactosc.Oscillator(0.8, 1.3, 0.05, 10.0)  # soft flanges: long contacts, reversals inside them
STICKY = impactosc.Oscillator(0.3, 0.4, 0.25, 50.0)  # stick and release between the flanges
STATIC = impactosc.Oscillator(0.5, 0.5, 0.05, 1e4, beta_static=0.08)  # stick phases, static friction
RIGID = impactosc.Oscillator(0.8, 1.1, 0.05, flange="rigid", restitution=0.8)  # impacts, reversals
#: chatter on the upper wall, rest, release and stick (the one-loop rigid tests' case)
CHATTER = impactosc.Oscillator(F=2.0, Omega=0.3, beta=0.2, flange="rigid", restitution=0.5)
#: X'' = 2 - X between walls at +-1: impacts at sqrt(3), halving, accumulate at t = 4.150405283
PUSHED = impactosc.Oscillator(F=2.0, Omega=0.0, beta=0.0, flange="rigid", restitution=0.5)

CASES = {
    # name: (osc, t_end, x0, v0, relative tolerance on the Jacobian)
    "spring contacts, stiff": (CONTACT, 30.0, 0.95, 0.0, 1e-8),
    "spring contacts, soft": (SOFT, 30.0, 0.5, 0.0, 1e-10),
    "stick and release": (STICKY, 30.0, 0.2, 0.0, 1e-10),
    "static friction, stick on a flange": (STATIC, 40.0, 0.2, 0.0, 1e-8),
    "rigid impacts": (RIGID, 30.0, 0.5, 0.0, 1e-10),
    "rigid chatter, rest, release": (CHATTER, 40.0, 0.0, 0.0, 1e-10),
}


def _both(osc, t_end, x0, v0, **kw):
    return [tangent_run(osc, t_end, x0, v0, backend=b, record="events", keep_saltations=True, **kw)
            for b in ("exact", "heyoka")]


# -- closed forms -------------------------------------------------------------------------
def test_a_free_piece_without_events_is_the_closed_form_transition_matrix():
    """No friction, no flange reached, no damping: X'' + X = F cos(Omega t), Phi = [[cos t, sin t], [-sin t, cos t]]
    (its turning points are reversals, whose saltation matrix is the identity without friction)."""
    osc = impactosc.Oscillator(0.1, 1.3, 0.0, 1e4)
    sol, rec = tangent_run(osc, 7.5, 0.2, 0.0, backend="heyoka", record="events")
    assert sol.status == 0 and set(sol.events.kind) == {"reversal"}
    np.testing.assert_allclose(rec.jacobian, (math.cos(7.5), math.sin(7.5), -math.sin(7.5), math.cos(7.5)),
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(rec.jacobian, linear_transition(1.0, 0.0, 7.5), rtol=0, atol=1e-15)


def test_a_chatter_annihilates_the_jacobian_at_its_closed_form_time():
    """The impacts accumulate at pi/3 + sum_k 2 atan(sqrt(3) / 2^k) and the mass rests on the wall: the map is
    locally constant, its Jacobian exactly zero, with the chatter and the rest test as the last two transitions."""
    t_inf = math.pi / 3.0 + sum(2.0 * math.atan(math.sqrt(3.0) / 2.0**k) for k in range(1, 200))
    sol, rec = tangent_run(PUSHED, 6.0, 0.0, 0.0, backend="heyoka", record="events", keep_saltations=True)
    assert sol.status == 0 and sol.counts["chatter"] == 1
    assert rec.jacobian == (0.0, 0.0, 0.0, 0.0) and rec.collapsed and rec.singular is None
    assert [(s.guard, s.kind) for s in rec.saltations[-2:]] == [("chatter", "chatter"), ("at_wall", "contact_start")]
    assert rec.saltations[-1].t == pytest.approx(t_inf, abs=1e-11)


# -- against the closed-form backend ------------------------------------------------------
@pytest.mark.parametrize("case", list(CASES))
def test_the_jacobian_on_heyoka_is_the_exact_backends(case):
    osc, t_end, x0, v0, rtol = CASES[case]
    (ref, r_rec), (sol, rec) = _both(osc, t_end, x0, v0)
    assert sol.status == ref.status == 0
    assert sol.counts == ref.counts
    expected = np.array(r_rec.jacobian)
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(rec.jacobian, expected, rtol=0, atol=rtol * scale)
    assert rec.collapsed == r_rec.collapsed
    assert (rec.singular is None) == (r_rec.singular is None)
    assert rec.slip_time == pytest.approx(r_rec.slip_time, abs=1e-9)
    # the same transitions with an event, in order (the engine's internal acceleration-zero re-arming is
    # an identity the hybrid loop has no guard for)
    signature = [(s.guard, s.kind) for s in rec.saltations if s.kind is not None]
    assert signature == [(s.guard, s.kind) for s in r_rec.saltations if s.kind is not None]
    for a, b in zip([s for s in rec.saltations if s.kind is not None],
                    [s for s in r_rec.saltations if s.kind is not None], strict=True):
        assert a.t == pytest.approx(b.t, abs=1e-9)
        # a slow impact's entry (a+ + e a-) / V is ~ m = a / V: its error a dV / V^2 ~ m^2 dV, dV <= 1e-10
        m = max(1.0, float(np.max(np.abs(b.matrix))))
        np.testing.assert_allclose(a.matrix, b.matrix, rtol=0, atol=1e-9 * m + 1e-10 * m * m)


@pytest.mark.parametrize("h", [1e-6])
def test_the_jacobian_on_heyoka_is_the_finite_difference_of_simulate(h):
    """Central differences of ``simulate`` over a stretch with transversal contacts (no grazing, no stick: the
    flow is smooth in the start). Truncation ~h^2 |d2 phi| and rounding ~eps |phi| / h = 2e-10 relative: 1e-6."""
    osc, t_end, x0, v0 = SOFT, 12.0, 0.5, 0.3
    _, rec = tangent_run(osc, t_end, x0, v0, backend="heyoka", record="events")
    J = np.empty((2, 2))
    for j, (dx, dv) in enumerate(((h, 0.0), (0.0, h))):
        up = impactosc.simulate(osc, t_end, x0 + dx, v0 + dv, backend="heyoka", record="stats")
        down = impactosc.simulate(osc, t_end, x0 - dx, v0 - dv, backend="heyoka", record="stats")
        J[:, j] = [(up.x_final - down.x_final) / (2 * h), (up.v_final - down.v_final) / (2 * h)]
    ref = impactosc.simulate(osc, t_end, x0, v0, backend="heyoka", record="events")
    assert ref.counts["contact_start"] >= 2 and ref.counts["stick"] == 0
    np.testing.assert_allclose(np.reshape(rec.jacobian, (2, 2)), J, rtol=0, atol=1e-6 * np.max(np.abs(J)))


# -- the calls of the engine's drive --------------------------------------------------------
class _Log(TangentRecorder):
    """A tangent recorder that logs the name of every call (and the mode/guard of the transitions)."""

    def __init__(self, backend, evaluator):
        super().__init__("full", backend, evaluator, keep_saltations=True)
        self.calls: list = []

    def piece(self, mode, t0, x0, t1, x1, *rest):
        self.calls.append(("piece", round(t0, 6), round(t1, 6), tuple(mode)[:2]))
        super().piece(mode, t0, x0, t1, x1, *rest)

    def event(self, t, kind, *rest):
        self.calls.append(("event", round(t, 6), kind))
        super().event(t, kind, *rest)

    def segment(self, t, x, v, mode):
        self.calls.append(("segment", round(t, 6), tuple(mode)[:2]))
        super().segment(t, x, v, mode)

    def sample(self, t, x, v, mode):
        self.calls.append(("sample", t, tuple(mode)[:2]))
        super().sample(t, x, v, mode)

    def on_transition(self, t, mode_before, guard, mode_after, *rest):
        if rest[-1] is not None or guard is None:  # not the engine's internal acceleration-zero re-arming
            self.calls.append(("on_transition", round(t, 6), guard, tuple(mode_before)[:2], tuple(mode_after)[:2]))
        super().on_transition(t, mode_before, guard, mode_after, *rest)

    def chatter(self, jump, t):
        self.calls.append(("chatter", round(t, 6)))
        return super().chatter(jump, t)

    def finish(self, t, x, v, mode, status, message):
        self.calls.append(("finish", round(t, 6), tuple(mode)[:2], status))
        super().finish(t, x, v, mode, status, message)


@pytest.mark.parametrize("case", ["spring contacts, stiff", "spring contacts, soft", "rigid impacts", "pushed"])
def test_the_replay_makes_the_calls_of_the_engines_drive_with_pieces_cut_at_the_samples(case):
    osc, t_end, x0, v0 = (PUSHED, 6.0, 0.0, 0.0) if case == "pushed" else CASES[case][:4]
    # samples inside pieces, on an event-free stretch, at the start, at the end, and (pushed) inside the
    # chatter's tail, where the engine's local model gives the state
    stops = tuple(sorted({0.0, *np.linspace(0.37, t_end - 0.4, 9).tolist(), 4.1502, 4.1504, t_end}))
    logs = []
    for backend in ("exact", "heyoka"):
        rec = _Log(backend, evaluator_of(backend, osc, {}))
        drive_recorder(backend, osc, t_end, x0, v0, rec, 10**6, stops)
        logs.append(rec)
    ref, rec = logs
    assert rec.calls == ref.calls
    assert sum(c[0] == "sample" for c in rec.calls) == len(stops)
    np.testing.assert_allclose(np.array(rec.samples), np.array(ref.samples), rtol=0, atol=1e-10)  # t, x, v, mode
    np.testing.assert_allclose(rec.jacobian, ref.jacobian, rtol=0, atol=1e-8 * max(1.0, np.max(np.abs(ref.jacobian))))


def test_the_states_at_the_samples_are_the_exact_backends():
    """What the Lyapunov renormalisation sees at each sample: ``(t, x, v, Jacobian so far)``."""
    seen: dict = {"exact": [], "heyoka": []}
    times = np.sort(np.concatenate((np.linspace(0.0, 6.0, 25), [4.1500, 4.1503, 4.15040528])))
    for backend in seen:
        def hook(rec, t, x, v, jac, out=seen[backend]):
            out.append((t, x, v, *jac))
            return jac

        tangent_run(PUSHED, 6.0, 0.0, 0.0, backend=backend, sample_at=times, on_sample=hook)
    ref, got = np.array(seen["exact"]), np.array(seen["heyoka"])
    assert got.shape == ref.shape == (len(times), 7)
    np.testing.assert_allclose(got[:, :3], ref[:, :3], rtol=0, atol=1e-11)
    # the Jacobian went through 14 impacts, the slowest at V = 0.05 (entries ~ 1 / V): 1e-10
    np.testing.assert_allclose(got[:, 3:], ref[:, 3:], rtol=0, atol=1e-10)


# -- options ------------------------------------------------------------------------------
def test_the_heyoka_tolerance_is_checked_and_honoured(monkeypatch):
    from impactosc.backends.heyoka import _replay

    with pytest.raises(ValueError, match="tol must be in"):
        tangent_run(SOFT, 5.0, 0.5, 0.0, backend="heyoka", options={"tol": 1e-30})
    with pytest.raises(TypeError, match="tol"):
        tangent_run(SOFT, 5.0, 0.5, 0.0, backend="heyoka", options={"tol": "fine"})
    seen = []
    real = _replay.run_counted

    def spy(*args, **kw):
        seen.append(kw["tol"])
        return real(*args, **kw)

    monkeypatch.setattr(_replay, "run_counted", spy)
    sol, rec = tangent_run(SOFT, 5.0, 0.5, 0.0, backend="heyoka", options={"tol": 1e-10})
    assert seen == [1e-10] and rec.evaluator.tol == 1e-10 and sol.status == 0


def test_the_heyoka_backend_has_no_piece_stepper_any_more():
    from impactosc.dynamics.tangent import piece_stepper

    with pytest.raises(ValueError, match="no piece stepper"):
        piece_stepper("heyoka", SOFT, {})
    with pytest.raises(ValueError, match="backend must be one of"):
        tangent_run(SOFT, 5.0, 0.5, 0.0, backend="rk4")


def test_the_examples_of_the_tangent_module():
    import doctest

    from impactosc.dynamics import tangent

    result = doctest.testmod(tangent)
    assert result.attempted >= 3 and result.failed == 0


# -- one system per structure -------------------------------------------------------------
def test_members_of_one_structure_share_a_system_with_their_own_values():
    """A continuation or a sweep runs a new member at every point: the replay builds ``oscillator_system`` once
    per structure and hands each member its values. Members that differ in values only share it and each
    runs with its own (events as exact's); members of other structures (damping, a harmonic, one flange,
    rigid) get their own system."""
    from impactosc.backends.heyoka import _replay

    members = [SOFT, SOFT.replace(F=0.9), SOFT.replace(Omega=1.2, beta=0.02, K=30.0, gap_upper=0.8),
               SOFT.replace(zeta=0.05), SOFT.replace(harmonics=((0.2, 2.6, 0.3),)), SOFT.replace(gap_lower=None),
               RIGID, RIGID.replace(restitution=0.6)]
    systems = []
    for osc in members:
        system, *_ = _replay._member_system(osc)
        systems.append(system)
        built = _replay._system(osc)[0]  # what the member's own build gives: the sharing must not change it
        assert system.structure == built.structure and dict(system.parameters) == dict(built.parameters)
        ref = impactosc.simulate(osc, 30.0, 0.5, 0.0, backend="exact", record="events")
        sol = _replay.run_on_hybrid_loop(osc, 30.0, 0.5, 0.0, record="events", max_events=10**6, tol=2.0**-52)
        assert sol.status == ref.status == 0 and sol.counts == ref.counts
        np.testing.assert_allclose(sol.events.t, ref.events.t, rtol=0, atol=1e-9)
    structure = [s.structure for s in systems]
    assert structure[0] == structure[1] == structure[2] and systems[0].modes is systems[2].modes
    assert len({structure[0], structure[3], structure[4], structure[5], structure[6]}) == 5
    assert systems[6].modes is systems[7].modes


@pytest.mark.parametrize("field", ["F", "Omega", "phase", "beta", "beta_static", "K", "zeta", "gap_upper",
                                   "gap_lower", "harmonics", "restitution"])
def test_a_shared_system_is_the_members_own_build_whatever_value_changes(field):
    """The sharing is sound only if every number of the member that ``oscillator_system`` uses is a runtime
    parameter: the shared system (expressions, guards, rules: its ``structure``) and values must be those of
    the member's own build, for a change of any field's value within a structure."""
    from impactosc.backends.heyoka import _replay

    base = RIGID.replace(zeta=0.02, beta_static=0.07, harmonics=((0.2, 2.2, 0.3),)) if field == "restitution" else \
        SOFT.replace(zeta=0.02, beta_static=0.07, harmonics=((0.2, 2.6, 0.3),), gap_upper=0.9)
    values = {"F": 0.7, "Omega": 1.1, "phase": 0.4, "beta": 0.03, "beta_static": 0.09, "K": 55.0, "zeta": 0.07,
              "gap_upper": 1.2, "gap_lower": 0.8, "harmonics": ((0.3, 3.3, -0.2),), "restitution": 0.55}
    _replay._member_system(base)
    other = base.replace(**{field: values[field]})
    shared, *tables = _replay._member_system(other)
    own, *own_tables = _replay._system(other)
    assert shared.structure == own.structure and shared.parameters == own.parameters
    assert tables == own_tables
