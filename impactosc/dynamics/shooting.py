"""Periodic orbits of the stroboscopic map by Newton shooting, with their Floquet multipliers.

A period-``n`` orbit is a fixed point ``z = P^n(z)`` of the stroboscopic map ``P`` (the state
``z = (X, V)`` one forcing period later, :mod:`.poincare`). Newton's method needs the
Jacobian ``M = dP^n/dz``, the **monodromy matrix**: the product of the smooth pieces'
state-transition matrices (:mod:`.flow`) and the saltation matrix of every event
(:mod:`.saltation`), gathered by one run (:func:`.tangent.tangent_run`). Its eigenvalues are
the orbit's Floquet multipliers: the orbit is stable when they all lie inside the unit circle.

The Newton iteration and the result type are the ones every map shares (``_newton``:
:func:`shoot`, :class:`PeriodicOrbit`); the map is :class:`~.oscillator_map.OscillatorMap`.
What is the built-in family's own here: the transient that gives the first iterate, the
section phase, the period as a multiple of the forcing period, the run of one period kept
with the orbit, and :func:`monodromy`.

A stick (or a chatter on a rigid flange) zeroes the ``V`` row of a saltation matrix, so the
monodromy matrix of an orbit that sticks has rank one at most: one multiplier is exactly 0
and the other is its trace. The result says so (``collapsed``) rather than reporting the
rounding residue of an eigenvalue solver.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from .._util import validation as _v
from ..backends._simulate import simulate
from ..model._oscillator import Oscillator
from ..results._solution import Solution
from ._common import check_base, forcing_period, oscillator_of
from ._newton import MARGINAL, PeriodicOrbit, Shot, floquet_multipliers, orbit_of, shoot
from .oscillator_map import OscillatorMap, OscillatorMapValue
from .saltation import Saltation
from .tangent import TangentRecorder, check_start

__all__ = ["Monodromy", "periodic_orbit", "monodromy", "MARGINAL"]


class Monodromy(NamedTuple):
    """The stroboscopic map ``P^n`` at a point and its Jacobian (:func:`monodromy`).

    A named tuple ``(x, v, jacobian, recorder)``, so ``x, v, J, rec = monodromy(...)`` and
    ``monodromy(...)[:2]`` work as they did when it was a plain tuple; the other facts of the
    run are properties.

    Attributes
    ----------
    x, v : float
        ``P^n(x0, v0)``.
    jacobian : ndarray (2, 2)
        ``dP^n / d(X, V)`` from the saltation product; NaN where no Jacobian exists
        (``singular``).
    recorder : object
        The run's tangent recorder (:mod:`.tangent`) where the built-in engine ran; the map's
        value (:class:`~.oscillator_map.OscillatorMapValue`) where heyoka ran the member as a
        user system (:class:`~.oscillator_map.OscillatorMap`).
    """

    x: float
    v: float
    jacobian: np.ndarray
    recorder: Any

    @property
    def collapsed(self) -> bool:
        """A stick, a stuck start, a chatter or a plastic impact annihilated a direction (rank < 2)."""
        return bool(self.recorder.collapsed)

    @property
    def singular(self) -> Saltation | None:
        """The :class:`~.saltation.Saltation` of the first point where the map has no Jacobian, or None."""
        if isinstance(self.recorder, TangentRecorder):
            return self.recorder.singular
        if not self.recorder.singular:
            return None
        nan = math.nan
        return Saltation(nan, "", None, (nan, nan, nan, nan), nan, True, self.recorder.singular)

    @property
    def differentiable(self) -> bool:
        """True when the Jacobian exists (no tangential crossing, no start held by static friction alone)."""
        return self.singular is None

    @property
    def reason(self) -> str:
        """Why the map is not differentiable here, in words ("" when it is)."""
        singular = self.singular
        return singular.reason if singular is not None else ""

    @property
    def multipliers(self) -> np.ndarray:
        """Eigenvalues of ``jacobian`` (:func:`floquet_multipliers`), NaN when it does not exist."""
        if not self.differentiable:
            return np.full(2, math.nan, dtype=complex)
        return floquet_multipliers(self.jacobian, self.collapsed)

    @property
    def events(self):
        """The events of the run (``Solution.events``; the built-in engine's runs only)."""
        if not isinstance(self.recorder, TangentRecorder):
            raise ValueError("this map was evaluated as a user system (backend='heyoka'): its events are "
                             "recorder.signature; simulate the member for its Solution.events")
        return Solution(self.recorder, self.recorder.t_final).events


def monodromy(osc: Oscillator, x0: float, v0: float, n: int = 1, *, t0: float = 0.0, backend: str = "heyoka",
              user_system: bool = False, **options) -> Monodromy:
    """The stroboscopic map ``P^n`` at ``(x0, v0)`` and its Jacobian.

    Evaluates :class:`~.oscillator_map.OscillatorMap` (with ``backend="heyoka"`` and
    ``user_system=True``: the member written as a user system, through
    :class:`~impactosc.dynamics.HybridMap`, where that expresses it).

    Parameters
    ----------
    osc : Oscillator or TapeDrive
    x0, v0 : float
        The state at time ``t0``, checked as :func:`impactosc.simulate` checks its start.
    n : int
        Forcing periods.
    t0 : float
        Start time (the section).
    backend : {"heyoka", "scipy", "exact"}
    user_system : bool
        With heyoka: the member as a user system (:class:`~.oscillator_map.OscillatorMap`).
    **options
        Backend options.

    Returns
    -------
    Monodromy
        ``(x, v, jacobian, recorder)`` as a named tuple; ``jacobian`` is a 2x2 array, NaN
        where the map is not differentiable (``.differentiable``, ``.reason``: a grazing
        impact, a start at rest held by static friction alone).

    Raises
    ------
    TypeError, ValueError
        For a bad argument, as :func:`impactosc.simulate` raises them (e.g. ``x0`` beyond a
        rigid flange, a non-finite state).
    RuntimeError
        If the run stops early (its message says why).

    Examples
    --------
    >>> import impactosc
    >>> from impactosc.dynamics import monodromy
    >>> m = monodromy(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), 0.95, 0.0, backend="exact")
    >>> m.jacobian.shape, m.differentiable
    ((2, 2), True)
    """
    check_base(osc)
    osc = oscillator_of(osc)
    t0 = _v.real("t0", t0)
    _v.integer("n", n)
    pmap = OscillatorMap(osc, n, t0=t0, backend=backend, user_system=user_system, **options)
    x0, v0 = check_start(pmap.section_model, pmap.span, x0, v0)
    value = pmap.evaluate([x0, v0], record="events")
    if value.image is None:
        raise RuntimeError(f"the run from ({x0!r}, {v0!r}) failed: {value.failure}")
    return Monodromy(float(value.image[0]), float(value.image[1]), value.monodromy,
                     value.recorder if value.recorder is not None else value)


def periodic_orbit(osc, n: int = 1, *, period: float | None = None, guess=None, x0: float = 0.95,
                   v0: float = 0.0, transient_periods: int = 100, phase: float | None = None,
                   tol: float = 1e-11, max_iter: int = 50, backend: str = "heyoka", user_system: bool = False,
                   **options) -> PeriodicOrbit:
    """Find a period-``n`` orbit by Newton shooting on the stroboscopic map.

    The front end of the one shooting (``_newton.shoot``, which user systems share
    through :func:`~impactosc.dynamics.periodic_orbit_of`) for the built-in family: the map is
    :class:`~.oscillator_map.OscillatorMap`, the first iterate the end of a transient (or
    ``guess``). Newton's step solves ``(M - I) dz = -(P^n(z) - z)`` with the monodromy
    matrix ``M`` from the saltation product (least squares when ``M - I`` is singular, as
    for a continuum of stuck states), halving the step while the residual grows.

    Parameters
    ----------
    osc : Oscillator or TapeDrive
        The model (a drive is reduced to its :meth:`~impactosc.TapeDrive.oscillator`).
    n : int
        Forcing periods per orbit period (default 1).
    period : float, optional
        The orbit period instead of ``n``; must be a whole multiple of the forcing period.
    guess : (float, float), optional
        ``(X, V)`` on the section to start Newton from. Default: the state after
        ``transient_periods`` forcing periods from ``(x0, v0)``.
    x0, v0 : float
        Initial state of the transient (at the section time).
    transient_periods : int
        Forcing periods of the transient (>= 0), when no ``guess`` is given.
    phase : float, optional
        Forcing phase ``Omega t + phase`` (mod 2 pi) of the section; default: the phase at t = 0.
    tol : float
        Convergence when ``|P^n(z) - z| <= tol * max(1, |z|)``.
    max_iter : int
        Newton iterations before giving up (status 1, the last iterate kept).
    backend : {"heyoka", "scipy", "exact"}
        Backend of the runs; ``**options`` are its options.
    user_system : bool
        With ``backend="heyoka"``: Newton evaluates the member written as a user system
        (:class:`~.oscillator_map.OscillatorMap`, :class:`~impactosc.dynamics.HybridMap`); the
        transient and the orbit's run stay on the engine.

    Returns
    -------
    PeriodicOrbit
        When Newton stalls or runs out of iterations after a transient whose motion repeats
        every ``m != n`` forcing periods, the message says so (the contact case
        ``Oscillator(0.5, 1.1, 0.01, 1e4)`` settles on a period-3 orbit: ``n=3`` finds it).

    Raises
    ------
    ValueError
        If ``period`` is not a multiple of the forcing period, the forcing is constant, or
        an argument breaks its rule.

    Examples
    --------
    >>> import impactosc
    >>> from impactosc.dynamics import periodic_orbit
    >>> orbit = periodic_orbit(impactosc.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), 3, backend="exact")
    >>> orbit.status, orbit.stability
    (0, 'stable')
    """
    check_base(osc)
    osc = oscillator_of(osc)
    tol = _v.positive("tol", tol)
    max_iter = _v.integer("max_iter", max_iter, minimum=0)
    pmap = OscillatorMap(osc, n, period=period, phase=phase, backend=backend, user_system=user_system, **options)
    sec, span = pmap.section_model, pmap.span
    transient = guess is None and bool(transient_periods)
    if guess is None:
        transient_periods = _v.integer("transient_periods", transient_periods, minimum=0)
        T = forcing_period(osc)
        x0, v0 = check_start(sec, transient_periods * T if transient_periods else span, x0, v0)
        z = np.array([x0, v0])
        if transient_periods:
            sol = simulate(sec, transient_periods * T, x0, v0, backend=backend, record="stats", **options)
            if sol.status != 0:
                return _orbit(pmap, Shot(z, None, -1, f"the transient failed: {sol.message}", 0, math.nan, []),
                              keep_run=False)
            z = np.array([sol.x_final, sol.v_final])
    else:
        try:
            gx, gv = guess
        except (TypeError, ValueError):
            raise TypeError(f"guess must be a pair (X, V), got {guess!r}") from None
        z = np.array(check_start(sec, span, gx, gv, names=("guess[0]", "guess[1]")))
    shot = shoot(pmap, z, tol=tol, max_iter=max_iter, project=pmap.project)
    if shot.status == 1 and transient:
        shot = shot._replace(message=shot.message + _period_hint(pmap, z, backend, options))
    return _orbit(pmap, shot, keep_run=shot.status != -1)


def _orbit(pmap: OscillatorMap, shot: Shot, keep_run: bool) -> PeriodicOrbit:
    """The built-in :class:`PeriodicOrbit` of a shot, with the run of one period from its point."""
    value = shot.value
    collapsed = bool(value.collapsed) if isinstance(value, OscillatorMapValue) else False
    events = sol = None
    if keep_run:
        sol = simulate(pmap.section_model, pmap.span, float(shot.z[0]), float(shot.z[1]), backend=pmap.backend,
                       record="full", **pmap.options)
        events = sol.events
    return orbit_of(shot, pmap.model, pmap.n, pmap.span, pmap.t0, state_names=pmap.state_names, collapsed=collapsed,
                    events=events, solution=sol)


def _period_hint(pmap: OscillatorMap, z, backend: str, options: dict, max_period: int = 12) -> str:
    """Where the transient's motion nearly repeats every ``m != n`` forcing periods, a sentence that says so.

    A loose test, for a message: the transient may still be converging slowly onto that
    orbit (multipliers near the unit circle), so the smallest lag ``m`` whose return distance
    is 20 times below the median over the lags counts ("" if none is).
    """
    T = forcing_period(pmap.model)
    periods = 2 * max_period
    sol = simulate(pmap.section_model, periods * T, float(z[0]), float(z[1]), backend=backend, record="stats",
                   sample_at=T * np.arange(periods + 1), **options)
    if sol.status != 0:
        return ""
    points = np.c_[sol.samples.x, sol.samples.v]
    distance = np.array([np.linalg.norm(points[-m:] - points[-2 * m:-m], axis=1).max()
                         for m in range(1, max_period + 1)])
    close = np.flatnonzero(distance < np.median(distance) / 20.0)
    m = int(close[0]) + 1 if close.size else pmap.n
    if m == pmap.n:
        return ""
    return (f". The motion after the transient nearly repeats every {m} forcing periods (to "
            f"{distance[m - 1]:.2g}): it nears a period-{m} orbit, which n={m} finds from there")
