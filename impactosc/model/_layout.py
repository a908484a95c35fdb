"""The layout the transition rule shares with the engine and the backends: guard indices,
event kinds, tolerances and the parameter vector of a member.

Plain Python (no numba): :class:`~impactosc.model.Oscillator` builds its parameter vector
here at construction, and imports the compiled rule (``_rule.py``) only when it first
computes a force.
"""

from __future__ import annotations

import numpy as np

# -- indices and codes shared with the engine and the backends ----------------------------
# Guard indices: the order is the contract between the engine and the backends.
ENTER_UPPER, ENTER_LOWER, LEAVE, SLIP_END, ACCEL_ZERO, RELEASE_UP, RELEASE_DOWN = range(7)
N_GUARDS = 7
#: The state has not reached a guard: the piece ended at the requested end time.
NO_GUARD = -1
#: Internal guard, never located by a backend: a mass at rest exactly against a rigid wall.
AT_WALL = N_GUARDS
#: Direction of each guard: +1 fires on a rising crossing, -1 on a falling one.
GUARD_DIRECTIONS = (1, -1, -1, -1, -1, 1, -1)

EVENT_KINDS = ("contact_start", "contact_end", "reversal", "stick", "release", "impact", "chatter")
CONTACT_START, CONTACT_END, REVERSAL, STICK, RELEASE, IMPACT, CHATTER = range(7)
#: Kind code of a transition that records no event.
NO_KIND = -1

#: Offset of the kinematic guards (see :data:`impactosc.engine.KINEMATIC_GUARD_OFFSET`).
KINEMATIC_GUARD_OFFSET = 1e-300
#: Rounding allowance of :func:`missed_guard`, in ulps of the scale of the quantity checked.
INTEGRITY_ULPS = 64.0
EPS = 2.0**-52

# -- the parameter vector -----------------------------------------------------------------
#: ``p[P_LOWER]``, ``p[P_UPPER]``: the distances ``gap_lower``, ``gap_upper`` from the rest
#: position ``X = 0`` to the lower flange (at ``X = -gap_lower``) and the upper one (at
#: ``X = +gap_upper``), ``inf`` for an absent flange; the flange of side ``r`` (+1 upper, -1
#: lower) is at ``X = r * gap``, and the penetration into it is ``d = r X - gap``.
P_BETA, P_BETA_S, P_K, P_ZETA, P_EXPONENT, P_RESTITUTION, P_RIGID, P_AMPLITUDE, P_LOWER, P_UPPER = range(10)
#: Index of the first forcing term; each term is ``(F_i, Omega_i, phase_i)``.
P_TERMS = 10


def params(osc) -> np.ndarray:
    """The member ``osc`` (an :class:`~impactosc.model.Oscillator`) as the rule's parameter vector.

    ``[beta, beta_s, K, zeta, p, e, rigid, sum F_i, gap_lower, gap_upper, F_0, Omega_0,
    phase_0, F_1, ...]`` (the indices ``P_*`` of this module).
    """
    terms = [v for term in osc.terms for v in term]
    head = [osc.beta, osc.beta_s, osc.K, osc.zeta, osc.exponent, osc.restitution, float(osc.rigid),
            sum(F for F, _, _ in osc.terms), osc.gap_lower, osc.gap_upper]
    out = np.array(head + terms, dtype=float)
    out.setflags(write=False)
    return out
