"""A linear mechanical system of many degrees of freedom written as a user hybrid system.

The physics is :class:`~impactosc.model.MechanicalSystem`'s (its module docstring); this
module only writes it in the hybrid language, so that the heyoka and scipy loops and the
analyses of user systems run it beside its exact closed-form backend:

* states ``q0 .. q{n-1}, v0 .. v{n-1}``, ``q' = v`` and
  ``v' = M^-1 (sum_h f_h cos(omega_h t + phi_h) - C v - K q + contact and friction forces)``;
* a linear spring contact is a pair of modes (open, engaged) and the guards between them;
* a rigid stop is a guard ``n.q - gap`` rising through 0 in every mode, with Newton's reset
  ``v -> v - (1 + e) (n.v) M^-1 n / (n.M^-1 n)``;
* a friction coordinate ``j`` is three modes (stuck, slipping up, slipping down) as in
  :func:`~impactosc.model.hybrid.stick_slip`, with the effective force
  ``F_j = (M^-1 r)_j / (M^-1)_jj`` (``r`` every force but that friction) and the effective
  mass ``1 / (M^-1)_jj``: it slips with ``v_j' = (M^-1)_jj (F_j -/+ mu_k)``, sticks when
  ``v_j`` reaches 0 with ``|F_j| <= mu_s`` (held by the force ``-F_j e_j``), and slips
  again when ``|F_j|`` rises to ``mu_s``.

A mode is one choice per spring contact (open or engaged) and per friction coordinate
(stuck, up, down): ``2^springs 3^frictions`` of them, refused above ``MAX_MODES``.
"""

from __future__ import annotations

import math

import numpy as np

from .._mechanical import MechanicalSystem
from ._definition import Guard, HybridMode, HybridSystem, symbols

__all__ = ["mechanical_system", "MAX_MODES", "event_of"]

#: The most modes :func:`mechanical_system` writes (``2^springs 3^frictions``): each is a term of
#: the compiled vector field and of every guard's gated event, so the compile time grows with them.
MAX_MODES = 54

#: Friction states of a coordinate, in the order its candidate modes are tried.
_STUCK, _UP, _DOWN = 0, 1, -1
_TAG = {_STUCK: "0", _UP: "+", _DOWN: "-"}
def _linear(coefficients, variables):
    """``sum_i c_i x_i`` as one heyoka sum (zero coefficients left out)."""
    import heyoka as hy

    terms = [float(c) * x for c, x in zip(coefficients, variables, strict=True) if c != 0.0]
    if not terms:
        return hy.expression(0.0)
    return terms[0] if len(terms) == 1 else hy.sum(terms)


def _check(ms: MechanicalSystem) -> None:
    """Refuse what the hybrid definition does not express, naming the contact or coordinate."""
    if not isinstance(ms, MechanicalSystem):
        raise TypeError(f"ms must be an impactosc.MechanicalSystem, got {ms!r}")
    for i, c in enumerate(ms.contacts):
        if not c.rigid and c.exponent != 1.0:
            raise ValueError(f"contacts[{i}].exponent = {c.exponent!r}: a spring law k d^p with p != 1 is not "
                             "analytic at d = 0, where each contact starts and a Taylor integrator expands it; "
                             "mechanical_system writes linear springs (exponent 1) and rigid stops")
    minv = ms._minv
    coords = [f.coordinate for f in ms.friction]
    for a in range(len(coords)):
        for b in range(a + 1, len(coords)):
            j, k = coords[a], coords[b]
            if minv[j, k] != 0.0:
                raise ValueError(
                    f"friction[{a}] (coordinate {j}) and friction[{b}] (coordinate {k}) couple through M^-1 "
                    f"((M^-1)[{j}, {k}] = {minv[j, k]!r}): their stick tests must be solved together, which the "
                    "modes of a hybrid system do not express; use simulate_mechanical (the exact backend), or "
                    "friction on coordinates that M^-1 does not couple")
    springs = sum(1 for c in ms.contacts if not c.rigid)
    count = 2**springs * 3 ** len(coords)
    if count > MAX_MODES:
        raise ValueError(f"{springs} spring contacts and {len(coords)} friction coordinates need 2^{springs} * "
                         f"3^{len(coords)} = {count} modes, above the bound MAX_MODES = {MAX_MODES}; "
                         "use simulate_mechanical (the exact backend), or fewer spring contacts or friction "
                         "coordinates")


def _check_printed_in_full(modes, guards, states) -> None:
    """Refuse expressions that heyoka prints abbreviated (over about 1000 characters, ending in "...").

    The hybrid backends know an expression by its text (the terms that modes share, the cache
    of compiled integrators): two long expressions with the same first 1000 characters would
    be taken for one another. The energy integrands are left out: they are the same in every mode.
    """
    for m in modes:
        for name, rate in zip(states, m.field, strict=False):
            if str(rate).endswith("..."):
                raise ValueError(
                    f"mode {m.name!r}: the rate of {name} prints over heyoka's limit of about 1000 characters "
                    f"({len(states) // 2} coordinates and the harmonics make it long); the hybrid backends know "
                    "expressions by their text and could confuse it with another. Use simulate_mechanical (the "
                    "exact backend), or fewer coordinates or harmonics")
        for i, c in enumerate(m.entry):
            if str(c).endswith("..."):
                raise ValueError(f"mode {m.name!r}: entry condition {i} prints over heyoka's limit of about 1000 "
                                 "characters (see the rates); use simulate_mechanical, or fewer coordinates")
    for g in guards:
        if str(g.expression).endswith("..."):
            raise ValueError(f"guard {g.name!r}: its expression prints over heyoka's limit of about 1000 "
                             "characters (see the rates); use simulate_mechanical, or fewer coordinates")


def _period(ms: MechanicalSystem, omegas):
    """``2 pi / omega`` of the oscillating harmonics when they share one frequency, else None."""
    oscillating = [i for i, (_, om, _) in enumerate(ms.harmonics) if om > 0.0]
    if not oscillating or len({ms.harmonics[i][1] for i in oscillating}) != 1:
        return None
    return 2.0 * math.pi / omegas[oscillating[0]]


def mechanical_system(ms: MechanicalSystem, *, energy: bool = True) -> HybridSystem:
    """The mechanical system ``ms`` as a :class:`HybridSystem` (the physics of the module docstring).

    Parameters
    ----------
    ms : MechanicalSystem
        Its spring contacts must be linear (``exponent == 1``), and its friction coordinates
        uncoupled by ``M^-1`` (their stick tests independent).
    energy : bool
        Declare the integrals ``work`` (``int f(t) . v dt``), ``damping`` (``int v . C v dt``)
        and ``friction`` (``int sum mu_k |v_j| dt`` while slipping), the terms of the energy
        identity ``work = Delta E + damping + friction + impact losses`` (the impact losses are
        the jumps of the kinetic energy at the impact events). Default True.

    Returns
    -------
    HybridSystem
        States ``q0 .. q{n-1}, v0 .. v{n-1}``; parameters ``omega{h}`` and ``phase{h}`` per
        harmonic (the force vectors, matrices and contact data are constants); modes named by
        their parts, ``"c{i}in"`` or ``"c{i}out"`` per spring contact ``i`` and ``"q{j}0"``,
        ``"q{j}+"``, ``"q{j}-"`` per friction coordinate ``j`` (``"free"`` when there are none);
        the forcing period ``2 pi / omega`` when the oscillating harmonics share one frequency.

    Raises
    ------
    TypeError
        When ``ms`` is not a MechanicalSystem.
    ValueError
        Naming the contact or coordinates: a nonlinear spring, two friction coordinates
        coupled by ``M^-1`` (a stick test to solve jointly), or more modes than
        ``MAX_MODES``; naming the mode or guard: an expression too long for heyoka to
        print in full (about 1000 characters: ``2 n`` terms of about 27 characters and about
        50 per harmonic, so ``n`` up to about 15), which the hybrid backends could take for
        another that starts alike.

    Notes
    -----
    Rigid stops: the rebounds of a stop that the forcing holds against it accumulate; the
    hybrid loops end such a run with status 2 and the estimated accumulation time, where the
    exact backend sums the chatter and lets the system rest on the stop (for ``e < 1``, and for
    an elastic stop once its rebounds fall below the gap's rounding: ``MechanicalSystem.can_rest``).
    The resting contact is a constraint the modes here do not write (``Guard.rest`` is the
    building block for it).

    Examples
    --------
    Two masses, the second one between two rigid stops:

    >>> import numpy as np
    >>> import impactosc
    >>> from impactosc.model import Contact, MechanicalSystem
    >>> from impactosc.model.hybrid import mechanical_system
    >>> ms = MechanicalSystem(M=np.eye(2), K=[[2.0, -1.0], [-1.0, 1.0]], harmonics=[([1.0, 0.0], 0.9, 0.0)],
    ...                       contacts=[Contact([0.0, 1.0], 0.5, law="rigid", restitution=1.0),
    ...                                 Contact([0.0, -1.0], 0.5, law="rigid", restitution=1.0)])
    >>> system = mechanical_system(ms)
    >>> system.states, system.mode_names
    (('q0', 'q1', 'v0', 'v1'), ('free',))
    >>> sol = impactosc.simulate(system, 30.0, [0.0, 0.0, 0.0, 0.0])
    >>> exact = impactosc.simulate_mechanical(ms, 30.0, [0.0, 0.0], [0.0, 0.0])
    >>> bool(np.allclose(sol.event_times(), exact.events["t"], rtol=0, atol=1e-10))
    True
    """
    _check(ms)
    n = ms.n
    names = [f"q{i}" for i in range(n)] + [f"v{i}" for i in range(n)]
    variables = symbols(names)
    variables = list(variables) if isinstance(variables, list | tuple) else [variables]
    q, v = list(variables[:n]), list(variables[n:])
    params: dict[str, float] = {}
    omegas = []
    for h, (_, om, ph) in enumerate(ms.harmonics):
        params[f"omega{h}"], params[f"phase{h}"] = float(om), float(ph)
        omegas.append(symbols(f"omega{h}"))
    writer = _Writer(ms, q, v, omegas, energy)
    modes, guards = writer.modes_and_guards()
    _check_printed_in_full(modes, guards, names)
    return HybridSystem(names, params, modes, guards, integrals=("work", "damping", "friction") if energy else (),
                        period=_period(ms, omegas), name=f"mechanical n={n}")


class _Writer:
    """The expressions of one system: forces per mode, the modes, the guards.

    Every force and acceleration is written as one linear form in ``v, q``, the harmonics
    and 1 with its coefficients computed numerically (``M^-1 C``, ``M^-1 K``, ...): each
    expression then has ``2 n + harmonics + 1`` terms, short enough that heyoka prints it in
    full (the hybrid backends key their shared terms and compile caches by that text).
    """

    def __init__(self, ms: MechanicalSystem, q, v, omegas, energy: bool):
        import heyoka as hy

        self.ms, self.q, self.v, self.energy = ms, q, v, energy
        self.minv = ms._minv
        self.springs = [i for i, c in enumerate(ms.contacts) if not c.rigid]
        self.stops = [i for i, c in enumerate(ms.contacts) if c.rigid]
        self.gaps = [_linear(c.normal, q) - c.gap for c in ms.contacts]
        self.waves = [hy.cos(om * hy.time + symbols(f"phase{h}")) for h, om in enumerate(omegas)]
        # the terms of every linear form: v, q, the harmonics, 1
        self.basis = [*v, *q, *self.waves, hy.expression(1.0)]
        self.forces = np.array([f for f, _, _ in ms.harmonics]).reshape(len(ms.harmonics), ms.n)
        if energy:
            self.work = _linear([1.0] * len(self.waves), [w * _linear(f, v) for w, f in
                                                         zip(self.waves, self.forces, strict=True)])
            self.dissipation = _linear([1.0] * ms.n, [v[i] * _linear(ms.C[i], v) for i in range(ms.n)])

    # -- the parts of a mode ---------------------------------------------------------------
    def name(self, engaged: tuple, motion: tuple) -> str:
        parts = [f"c{c}{'in' if on else 'out'}" for c, on in zip(self.springs, engaged, strict=True)]
        parts += [f"q{f.coordinate}{_TAG[s]}" for f, s in zip(self.ms.friction, motion, strict=True)]
        return "/".join(parts) or "free"

    def force_matrix(self, engaged: tuple, motion: tuple, without: int | None = None) -> np.ndarray:
        """The force ``r`` as rows of coefficients on :attr:`basis`: ``f(t) - C v - K q``, the engaged
        springs and the slipping frictions (not friction ``without``, nor stuck ones)."""
        ms, n = self.ms, self.ms.n
        stiffness = ms.K.copy()
        const = np.zeros(n)
        for c, on in zip(self.springs, engaged, strict=True):
            if on:  # -k (n.q - gap) n
                contact = ms.contacts[c]
                stiffness += contact.stiffness * np.outer(contact.normal, contact.normal)
                const += contact.stiffness * contact.gap * contact.normal
        for k, (f, s) in enumerate(zip(ms.friction, motion, strict=True)):
            if k != without and s != _STUCK:
                const[f.coordinate] -= s * f.kinetic
        return np.hstack([-ms.C, -stiffness, self.forces.T, const[:, None]])

    def form(self, row) -> object:
        return _linear(row, self.basis)

    def effective_force(self, engaged: tuple, motion: tuple, k: int):
        """``F_j = (M^-1 r)_j / (M^-1)_jj`` of friction ``k`` (every force but its own)."""
        j = self.ms.friction[k].coordinate
        weights = self.minv[j] / self.minv[j, j]
        return self.form(weights @ self.force_matrix(engaged, motion, without=k))

    def mode(self, engaged: tuple, motion: tuple) -> HybridMode:
        import heyoka as hy

        ms, n = self.ms, self.ms.n
        # M^-1 r, with the stuck coordinates held: their constraint forces -F_j e_j take away
        # F_j M^-1 e_j = (M^-1 r)_j M^-1 e_j / (M^-1)_jj (the friction coordinates are uncoupled by
        # M^-1, so each holds its own coordinate only)
        project = np.eye(n)
        for f, s in zip(ms.friction, motion, strict=True):
            if s == _STUCK:
                j = f.coordinate
                project -= np.outer(self.minv[:, j], np.eye(n)[j]) / self.minv[j, j]
        rows = project @ self.minv @ self.force_matrix(engaged, motion)
        entry = [self.gaps[c] if on else -self.gaps[c] for c, on in zip(self.springs, engaged, strict=True)]
        zero = hy.expression(0.0)
        for k, (f, s) in enumerate(zip(ms.friction, motion, strict=True)):
            vj = self.v[f.coordinate]
            force = self.effective_force(engaged, motion, k)
            if s == _STUCK:
                rows[f.coordinate] = 0.0
                still = hy.select(hy.gt(vj, zero), -1.0, hy.select(hy.lt(vj, zero), -1.0, 1.0))
                entry += [still, f.static - force, f.static + force]
            else:
                ahead = hy.gt(vj, zero) if s == _UP else hy.lt(vj, zero)
                behind = hy.lt(vj, zero) if s == _UP else hy.gt(vj, zero)
                entry.append(hy.select(ahead, 1.0, hy.select(behind, -1.0, s * force - f.static)))
        integrands = {}
        if self.energy:
            slipping = [(f, s) for f, s in zip(ms.friction, motion, strict=True) if s != _STUCK]
            rub = _linear([s * f.kinetic for f, s in slipping], [self.v[f.coordinate] for f, _ in slipping])
            integrands = {"work": self.work, "damping": self.dissipation, "friction": rub}
        return HybridMode(self.name(engaged, motion), [*self.v, *(self.form(r) for r in rows)], entry=tuple(entry),
                          integrands=integrands)

    # -- the whole system -------------------------------------------------------------------
    def modes_and_guards(self) -> tuple[list[HybridMode], list[Guard]]:
        import itertools

        ms = self.ms
        spring_parts = list(itertools.product((False, True), repeat=len(self.springs)))
        motions = list(itertools.product((_STUCK, _UP, _DOWN), repeat=len(ms.friction)))
        modes, guards = [], []
        for engaged in spring_parts:
            for motion in motions:
                modes.append(self.mode(engaged, motion))
                here = self.name(engaged, motion)
                for c, on in zip(self.springs, engaged, strict=True):
                    flipped = tuple((not o) if s == c else o for s, o in zip(self.springs, engaged, strict=True))
                    what = "opens" if on else "closes"
                    d = -1 if on else 1
                    guards.append(Guard(f"{here}: contact {c} {what}", self.gaps[c], d, armed=here,
                                        to=self.name(flipped, motion)))
                guards += self.friction_guards(engaged, motion)
        for c in self.stops:
            contact = ms.contacts[c]
            w = self.minv @ contact.normal
            scale = (1.0 + contact.restitution) / float(contact.normal @ w)
            approach = _linear(contact.normal, self.v)
            reset = {self.v[i]: self.v[i] - float(scale * w[i]) * approach for i in range(ms.n) if w[i] != 0.0}
            for engaged in spring_parts:
                # the impulse may set a stuck coordinate moving or reverse a slip: the entry conditions decide
                targets = [self.name(engaged, m) for m in motions]
                tag = "/".join(f"c{s}{'in' if on else 'out'}" for s, on in zip(self.springs, engaged, strict=True))
                guards.append(Guard(f"impact {c}" + (f" [{tag}]" if tag else ""), self.gaps[c], 1,
                                    armed=targets,
                                    to=targets if len(targets) > 1 else None, reset=reset))
        return modes, guards

    def friction_guards(self, engaged: tuple, motion: tuple) -> list[Guard]:
        import heyoka as hy

        here = self.name(engaged, motion)
        out = []
        for k, (f, s) in enumerate(zip(self.ms.friction, motion, strict=True)):
            j = f.coordinate

            def becomes(state: int, k=k) -> str:
                return self.name(engaged, tuple(state if i == k else m for i, m in enumerate(motion)))

            if s == _STUCK:
                force = self.effective_force(engaged, motion, k)
                out.append(Guard(f"{here}: q{j} released up", force - f.static, 1, armed=here,
                                 to=becomes(_UP)))
                out.append(Guard(f"{here}: q{j} released down", force + f.static, -1, armed=here,
                                 to=becomes(_DOWN)))
            else:
                # the velocity is snapped onto v_j = 0: the stuck mode's entry tests it exactly
                out.append(Guard(f"{here}: q{j} stops", self.v[j], -s, armed=here,
                                 to=(becomes(_STUCK), becomes(-s)), reset={self.v[j]: hy.expression(0.0)}))
        return out


def event_of(ms: MechanicalSystem, guard: str, mode_after: str) -> tuple[str, int]:
    """The exact backend's ``(kind, index)`` of a crossing of ``guard`` (a name :func:`mechanical_system` wrote).

    ``kind`` is one of ``MECHANICAL_EVENT_KINDS``: ``impact`` and ``contact_start``/``contact_end``
    with the contact's index, ``stick``/``reversal`` (a slip stops: ``mode_after`` says which)
    and ``release`` with the index of the friction entry in ``ms.friction``.
    """
    words = guard.split(": ")[-1].split()
    if words[0] == "impact":
        return "impact", int(words[1])
    if words[0] == "contact":
        return ("contact_start" if words[2] == "closes" else "contact_end"), int(words[1])
    entry = next(k for k, f in enumerate(ms.friction) if f"q{f.coordinate}" == words[0])
    if words[1] == "stops":
        part = next(p for p in mode_after.split("/") if p[:-1] == words[0])
        return ("stick" if part[-1] == _TAG[_STUCK] else "reversal"), entry
    return "release", entry

