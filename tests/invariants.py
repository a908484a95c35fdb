"""Physical invariants every Solution must satisfy; shared by the property and hostile-input tests."""

import numpy as np

from impactosc.engine import initial_mode


def energy_scale(sol):
    osc = sol.oscillator
    return max(1.0, osc.energy(sol.x0, sol.v0), abs(sol.forcing_work), sol.friction_work,
               osc.energy(sol.x_final, sol.v_final))


def assert_energy_identity(sol, rel=1e-9):
    """E(end) - E(0) = work of the forcing - beta * (path length while slipping)."""
    osc = sol.oscillator
    lhs = osc.energy(sol.x_final, sol.v_final) - osc.energy(sol.x0, sol.v0)
    rhs = sol.forcing_work - sol.friction_work
    assert abs(lhs - rhs) <= rel * energy_scale(sol), (lhs, rhs)


def assert_contact_alternation(sol):
    """Contact events alternate start/end per flange; starts are snapped onto the flange."""
    ev = sol.events
    open_side = initial_mode(sol.oscillator, 0.0, sol.x0, sol.v0).region or None
    for e in ev[np.char.startswith(ev.kind, "contact")]:
        if e.kind == "contact_start":
            assert open_side is None
            open_side = int(e.side)
            assert e.x == e.side * sol.oscillator.gap(int(e.side))  # on the flange's surface, at its gap
        else:
            assert open_side == e.side
            open_side = None


def assert_friction_invariants(sol):
    """Sticks only where |f_net| <= beta, releases exactly at beta, no motion while stuck."""
    osc = sol.oscillator
    ev = sol.events
    tol = 1e-9 * max(1.0, osc.K * sol.max_penetration(), osc.F)
    for i, e in enumerate(ev):
        f = osc.net_force(e.t, e.x)
        if e.kind == "stick":
            assert abs(f) <= osc.beta + tol and e.v == 0.0
            if i + 1 < len(ev):
                assert ev.kind[i + 1] == "release" and ev.x[i + 1] == e.x
        elif e.kind == "release":
            assert abs(abs(f) - osc.beta) <= tol
        elif e.kind == "reversal":
            assert abs(f) >= osc.beta - tol and e.v == 0.0


def assert_sound(sol, t_end):
    """Finished where asked, finite, and all invariants hold."""
    assert sol.status == 0, sol.message
    assert sol.t_final == t_end
    assert np.isfinite([sol.x_final, sol.v_final, sol.forcing_work, sol.mean_flange_force()]).all()
    assert_energy_identity(sol)
    if sol.record != "stats":
        assert_contact_alternation(sol)
        assert_friction_invariants(sol)


def is_degenerate(osc, t, x, v, tol=1e-6):
    """A graze, a rest point on a flange boundary, or a rest point at the friction threshold:
    the events where rounding alone may legitimately decide what happens next."""
    f = osc.net_force(t, x)
    return abs(abs(x) - 1.0) < tol or abs(abs(f) - osc.beta) < tol or abs(v) < tol


def assert_same_events(a, b, *, t_tol, x_sign=1, side_sign=1, osc_b=None):
    """Same event sequence in ``a`` and ``b`` (times within ``t_tol``) up to the first
    degenerate event, where rounding may send them different ways; then stop comparing.

    ``x_sign``/``side_sign`` = -1 compares ``b`` as the mirror image of ``a``.
    """
    ea, eb = a.events, b.events
    osc_b = osc_b or b.oscillator
    for i in range(max(len(ea), len(eb))):
        if i < len(ea) and i < len(eb):
            same = (ea.kind[i] == eb.kind[i] and ea.side[i] == side_sign * eb.side[i]
                    and abs(ea.t[i] - eb.t[i]) <= t_tol and abs(ea.x[i] - x_sign * eb.x[i]) <= t_tol)
            if same:
                continue
        e, osc = (ea[i], a.oscillator) if i < len(ea) else (eb[i], osc_b)
        assert is_degenerate(osc, e.t, e.x, e.v), f"event #{i} differs: {ea[i:i + 1]} vs {eb[i:i + 1]}"
        return i
    return None
