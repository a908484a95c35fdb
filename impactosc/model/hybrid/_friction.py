"""Coulomb friction as modes: slipping each way and a Filippov stick mode with its release guards."""

from __future__ import annotations

from collections.abc import Mapping

from ._definition import Guard, HybridMode, _expression, _name_of


def stick_slip(prefix: str, velocity, force, kinetic, static=None, *, rates: Mapping | None = None,
               integrands: Mapping | None = None, stick_integrands: Mapping | None = None,
               mass=1.0, entry=(), choose=None) -> tuple[list[HybridMode], list[Guard]]:
    """The three friction modes of one degree of freedom and the four guards between them.

    The degree of freedom has the velocity state ``velocity`` and obeys
    ``m v' = force - kinetic * sign(v)`` while slipping; at ``v = 0`` it sticks while
    ``|force| <= static`` (the Filippov sliding mode on ``v = 0``, here the whole state
    frozen in the velocity) and slips away towards ``force`` otherwise. ``force`` is every
    other force on the mass (an expression in the states, time and parameters), ``kinetic``
    and ``static`` the friction levels (``static`` defaults to ``kinetic``).

    Modes (in this order): ``f"{prefix}0"`` (stuck: ``v' = 0``, the other states' rates
    with ``v = 0``), ``f"{prefix}+"`` (slipping with ``v > 0``), ``f"{prefix}-"``.
    Guards: ``f"{prefix}+ stop"`` (``v`` falls to 0 in ``+``) and ``f"{prefix}- stop"``
    (``v`` rises to 0 in ``-``, reset to exactly 0), each to the stick mode if ``|force| <= static`` there,
    else to slipping the other way; ``f"{prefix} release+"`` (``force - static`` rises
    through 0 while stuck) and ``f"{prefix} release-"`` (``force + static`` falls through 0).

    Parameters
    ----------
    prefix : str
        The modes' and guards' names start with it (e.g. the region: ``"free"``).
    velocity : str or variable
        The velocity state.
    force, kinetic, static : expression or number
        See above.
    rates : mapping, optional
        The rates of the other states while slipping (``x: v`` for the position); in the
        stick mode each is taken with ``v = 0``. Every state but ``velocity`` needs one.
    integrands, stick_integrands : mapping, optional
        Integrands of the system's integrals while slipping and while stuck.
    mass : expression or number
        The mass (default 1).
    entry : sequence of expressions, optional
        Entry conditions ``c >= 0`` added to all three modes (the region they belong to,
        such as ``1 - x`` for a mass between the flanges).
    choose : callable, optional
        The transition rule of the four guards (``Guard.choose``): at rest, where ``|force|``
        equals ``static`` within rounding, the entry conditions decide by the sign of a
        rounding error (a net force that vanishes at a stop and then grows: the run stopped,
        released and stopped again at one instant). ``rule(t, state, parameters)`` returns
        the name of the mode to enter (``f"{prefix}0"``, ``f"{prefix}+"`` or ``f"{prefix}-"``),
        e.g. from the force's trend at the tie, or None to leave it to the entry conditions.
        The oscillator family's (:func:`~impactosc.model.hybrid.oscillator_system`) is the
        engine's stick test.

    Returns
    -------
    (list of HybridMode, list of Guard)
        To add to a :class:`HybridSystem`'s modes and guards (with the guards between
        prefixes, such as a flange contact, written by the user).

    Examples
    --------
    A mass on a spring dragged by a harmonic force over a rough floor:

    >>> import heyoka as hy
    >>> from impactosc import HybridSystem, stick_slip, symbols
    >>> x, v, A, w, mu = symbols("x v A w mu")
    >>> modes, guards = stick_slip("m", v, A * hy.cos(w * hy.time) - x, mu, rates={x: v})
    >>> system = HybridSystem("x v", {"A": 2.0, "w": 0.5, "mu": 0.5}, modes, guards)
    >>> system.mode_names
    ('m0', 'm+', 'm-')

    The same floor with a rule for the ties at rest, ``|force| = mu``: the force's trend decides
    (elsewhere the entry conditions do):

    >>> import math
    >>> def at_rest(t, state, p):
    ...     A, w, mu = p
    ...     f, trend = A * math.cos(w * t) - state[0], -A * w * math.sin(w * t)
    ...     if abs(abs(f) - mu) > 1e-12 * (A + mu + abs(state[0])):
    ...         return None
    ...     return ("m+" if f > 0.0 else "m-") if f * trend > 0.0 else "m0"
    >>> modes, guards = stick_slip("m", v, A * hy.cos(w * hy.time) - x, mu, rates={x: v}, choose=at_rest)
    >>> [g.choose is at_rest for g in guards]
    [True, True, True, True]
    """
    import heyoka as hy

    v_name = _name_of("stick_slip: velocity", velocity)
    v = hy.make_vars(v_name)
    force = _expression("stick_slip: force", force)
    kinetic = _expression("stick_slip: kinetic", kinetic)
    static = kinetic if static is None else _expression("stick_slip: static", static)
    mass = _expression("stick_slip: mass", mass)
    region = tuple(_expression(f"stick_slip: entry[{i}]", c) for i, c in enumerate(entry))
    others = {_name_of("stick_slip: rates", k): _expression(f"stick_slip: rates[{k!r}]", e)
              for k, e in (rates or {}).items()}
    if v_name in others:
        raise ValueError(f"stick_slip: rates gives a rate for the velocity {v_name!r}; its rate is "
                         "(force -/+ kinetic) / mass while slipping and 0 while stuck")
    at_rest = {v_name: hy.expression(0.0)}
    stuck_rates = {k: hy.subs(e, at_rest) for k, e in others.items()}
    zero = hy.expression(0.0)
    stuck, up, down = f"{prefix}0", f"{prefix}+", f"{prefix}-"
    above = hy.select(hy.gt(v, zero), 1.0, hy.select(hy.lt(v, zero), -1.0, force - static))
    below = hy.select(hy.lt(v, zero), 1.0, hy.select(hy.gt(v, zero), -1.0, -force - static))
    still = hy.select(hy.gt(v, zero), -1.0, hy.select(hy.lt(v, zero), -1.0, 1.0))
    modes = [
        HybridMode(stuck, {**stuck_rates, v_name: zero}, entry=(*region, still, static - force, static + force),
             integrands=stick_integrands or {}),
        HybridMode(up, {**others, v_name: (force - kinetic) / mass}, entry=(*region, above),
                   integrands=integrands or {}),
        HybridMode(down, {**others, v_name: (force + kinetic) / mass}, entry=(*region, below),
                   integrands=integrands or {}),
    ]
    guards = [
        # the velocity is snapped onto the switching surface v = 0 (the located root is within
        # rounding of it, and the entry conditions test v against 0 exactly)
        Guard(f"{up} stop", v, -1, armed=up, to=(stuck, down), reset={v_name: zero}, choose=choose),
        Guard(f"{down} stop", v, 1, armed=down, to=(stuck, up), reset={v_name: zero}, choose=choose),
        Guard(f"{prefix} release+", force - static, 1, armed=stuck, to=up, choose=choose),
        Guard(f"{prefix} release-", force + static, -1, armed=stuck, to=down, choose=choose),
    ]
    return modes, guards
