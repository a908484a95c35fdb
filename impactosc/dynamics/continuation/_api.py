"""``continuation``: the one entry point (a branch in one parameter, a boundary in two, a branch switch)."""

from __future__ import annotations

import numpy as np

from ..._util import validation as _v
from ...model._oscillator import Oscillator
from .._common import advanced, check_base, check_parameter, oscillator_of
from ..shooting import PeriodicOrbit
from ._arclength import Corrected, Settings, correct, scaled, unscaled
from ._assembly import assemble, check_limits, reindex
from ._branch import SPECIAL_KINDS, Branch, SpecialPoint
from ._follow import follow, make_node
from ._problem import MapProblem

__all__ = ["continuation"]

_DIRECTIONS = ("both", "forward", "backward")


def continuation(start, parameter, limits, *, base=None, backend: str | None = None, direction: str = "both",
                 step: float = 0.02, min_step: float = 1e-7, max_step: float = 0.1, max_points: int = 500,
                 tol: float = 1e-10, max_iter: int = 8, locate=True, locate_tol: float = 1e-12,
                 stop_at=(), **options) -> Branch:
    """Follow a family of periodic orbits as parameters change (pseudo-arclength continuation).

    The orbits are fixed points of the stroboscopic map ``P^n`` (:func:`periodic_orbit`),
    followed by a pseudo-arclength predictor-corrector on ``G(z, p) = P^n(z; p) - z = 0``
    with the exact Jacobian ``[dP/dz, dP/dp]`` (saltation products for the state, the
    parameter carried as a state with zero derivative for ``dP/dp``). Along the branch every
    point gets its Floquet multipliers, stability, event signature and margins, and the
    special points between points are located: folds, period doublings, Neimark-Sacker
    points (smooth test functions of the monodromy matrix), grazings of either flange and
    stick onsets (zeros of signed margins), and any other change of the event signature
    ("border"). At a nonsmooth point the map is not differentiable; the continuation labels
    it and goes on in the new signature, or ends there and says so (``status`` 2).

    Parameters
    ----------
    start : PeriodicOrbit, SpecialPoint or (float, float)
        * a converged :class:`PeriodicOrbit` (from :func:`periodic_orbit`): the branch through it;
        * a ``(X, V)`` guess on the section (``base`` required): Newton at the base's
          parameter value first;
        * a :class:`SpecialPoint` of a branch with ``parameter`` a pair of names: the
          boundary of that point in two parameters (grazing, stick onset, fold, period
          doubling); with ``parameter`` one name and the point a period doubling: the
          period-``2n`` branch that bifurcates there (branch switching).
    parameter : str or (str, str)
        The free parameter: a field of the model (:func:`parameter_names`); two for a boundary.
    limits : (float, float) or dict
        ``(lo, hi)`` of the (first) parameter; for a boundary, a dict of ``name: (lo, hi)``
        (either parameter; at least one). The branch ends on a limit.
    base : Oscillator or TapeDrive, optional
        The model whose fields are the parameters. Default: the orbit's oscillator. Give a
        :class:`TapeDrive` to continue in its SI fields (its :meth:`~TapeDrive.oscillator` must be the orbit's).
    backend : {"exact", "heyoka", "scipy"}, optional
        Default ``"exact"`` where it runs the member, else ``"heyoka"``.
    direction : {"both", "forward", "backward"}
        Forward is the direction of increasing parameter at the start.
    step, min_step, max_step : float
        Arclength steps in scaled units (state nondimensional; each parameter divided by its
        value at the start, or by 1e-3 if smaller).
    max_points : int
        Points per direction.
    tol : float
        Newton tolerance on ``|G|`` (relative to ``max(1, |z|)``).
    max_iter : int
        Newton iterations per point.
    locate : bool or sequence of str
        Locate special points: True (default) every kind of :data:`SPECIAL_KINDS`, False none,
        or the kinds to locate (e.g. ``("grazing",)``: where a drive's orbit creeps in
        stick-slip, the number of sticks per period changes often, and each change is a
        border point worth locating only when asked).
    locate_tol : float
        Width of the final bracket (scaled arclength) of a located point.
    stop_at : sequence of str
        Kinds of special point whose first located point ends the run in that direction
        (status 0, the message says so), e.g. ``("grazing",)`` for a contact onset.
    **options
        The backend's options (``tol`` of heyoka, ``rtol`` of scipy, ...).

    Returns
    -------
    Branch
        ``points``, ``special``, ``status``/``message`` (the points computed so far are kept
        whatever happens), ``to_xarray()``, ``plot()``.

    Raises
    ------
    TypeError, ValueError
        For a bad argument: an unknown parameter, limits not ``lo < hi`` or not finite, a start
        outside the limits, a start that is not a converged orbit.

    References
    ----------
    Keller (1977); Kuznetsov, *Elements of Applied Bifurcation Theory* (2004), ch. 10;
    di Bernardo, Budd, Champneys & Kowalczyk, *Piecewise-smooth Dynamical Systems* (2008);
    Dankowicz & Schilder, *Recipes for Continuation* (2013) (COCO's ``hspo``).
    """
    settings = _settings(step, min_step, max_step, max_points, tol, max_iter, locate, locate_tol, stop_at)
    if direction not in _DIRECTIONS:
        raise ValueError(f"direction must be one of {', '.join(_DIRECTIONS)}, got {direction!r}")
    if isinstance(start, SpecialPoint):
        if isinstance(parameter, tuple | list):
            from ._boundary import boundary

            return boundary(start, tuple(parameter), limits, settings, backend, options)
        if start.kind != "period_doubling":
            raise ValueError(f"a branch switch starts at a period_doubling point, got a {start.kind!r} point; give "
                             "two parameters to follow this point as a boundary")
        return _switch(start, parameter, limits, settings, max_points)
    if isinstance(parameter, tuple | list):
        raise TypeError("two parameters need a SpecialPoint start (a located point to follow as a boundary), got "
                        f"{type(start).__name__}")
    problem, z0 = _problem_from(start, parameter, base, backend, options)
    lo, hi = check_limits(parameter, limits, problem.values()[0])
    return _run(problem, z0, (lo, hi), direction, settings, max_points)


def _settings(step, min_step, max_step, max_points, tol, max_iter, locate, locate_tol, stop_at) -> Settings:
    step, min_step, max_step = (_v.positive(n, x) for n, x in (("step", step), ("min_step", min_step),
                                                               ("max_step", max_step)))
    if not min_step <= step <= max_step:
        raise ValueError(f"the steps must satisfy min_step <= step <= max_step, got {min_step!r}, {step!r}, "
                         f"{max_step!r}")
    kinds = _kinds("locate", SPECIAL_KINDS if locate is True else () if locate is False else locate)
    stops = _kinds("stop_at", stop_at)
    if not stops <= kinds:
        raise ValueError(f"stop_at kinds must also be located: {sorted(stops - kinds)} are not in locate")
    return Settings(step, min_step, max_step, _v.integer("max_points", max_points, minimum=1),
                    _v.positive("tol", tol), _v.integer("max_iter", max_iter, minimum=1), kinds,
                    _v.positive("locate_tol", locate_tol), stops)


def _kinds(name: str, kinds) -> frozenset:
    if isinstance(kinds, str):
        kinds = (kinds,)
    try:
        out = frozenset(kinds)
    except TypeError:
        raise TypeError(f"{name} must be a bool or a sequence of special-point kinds, got {kinds!r}") from None
    unknown = out - set(SPECIAL_KINDS)
    if unknown:
        raise ValueError(f"{name} names unknown kinds {sorted(unknown)}; the kinds are {', '.join(SPECIAL_KINDS)}")
    return out


def default_backend(osc: Oscillator, backend, options) -> str:
    if backend is not None:
        return backend
    from ..tangent import check_backend

    try:
        check_backend(osc, "exact", options)
        return "exact"
    except ValueError:
        return "heyoka"


def _problem_from(start, parameter, base, backend, options):
    """``(MapProblem, z0)`` of a PeriodicOrbit or a guess."""
    if isinstance(start, PeriodicOrbit):
        if start.status != 0:
            raise ValueError(f"start must be a converged PeriodicOrbit (status 0), got status {start.status}: "
                             f"{start.message}")
        osc, n, z0 = start.oscillator, start.n, (start.x, start.v)
        theta = advanced(osc, start.t0).phase
        if base is None:
            base = osc
        else:
            check_base(base)
            if oscillator_of(base) != osc:
                raise ValueError("base must be the model of the orbit: base's oscillator() differs from the "
                                 "orbit's oscillator")
    else:
        if base is None:
            raise TypeError(f"start must be a PeriodicOrbit or a SpecialPoint, or a guess (X, V) with base=..., got "
                            f"{type(start).__name__}")
        check_base(base)
        try:
            gx, gv = start
        except (TypeError, ValueError):
            raise TypeError(f"start must be a PeriodicOrbit, a SpecialPoint or a pair (X, V), got {start!r}") from None
        z0 = (_v.real("start[0]", gx), _v.real("start[1]", gv))
        osc, n = oscillator_of(base), 1
        theta = osc.phase
    check_parameter(base, parameter)
    backend = default_backend(osc, backend, options)
    problem = MapProblem(base, (parameter,), n, theta, backend, options)
    return problem, np.array(z0, dtype=float)


def _start_node(problem: MapProblem, z0, settings: Settings):
    """The start corrected at its parameter value: a Node, or a string saying why not."""
    u0 = scaled(problem, z0, problem.values())
    constraint = np.zeros_like(u0)
    constraint[2] = 1.0
    result = correct(problem, u0, constraint, settings)
    if not isinstance(result, Corrected):
        return f"no periodic orbit was found from the start ({z0[0]!r}, {z0[1]!r}): {result}"
    node = make_node(problem, result, None, 0.0)
    problem.limit_events(result.ev.recorder.n_events)
    if node.t[2] < 0.0:
        node.t = -node.t
    return node


def _run(problem: MapProblem, z0, limits, direction: str, settings: Settings, max_points: int) -> Branch:
    start = _start_node(problem, z0, settings)
    if isinstance(start, str):
        return assemble(problem, [], [], [(-1, start)], 0)
    sides = {"forward": (1,), "backward": (-1,), "both": (-1, 1)}[direction]
    results = {d: follow(problem, start, d, limits, settings, max_points) for d in sides}
    back_nodes, back_found, *back_end = results.get(-1, ([], [], None, None))
    fwd_nodes, fwd_found, *fwd_end = results.get(1, ([], [], None, None))
    nodes = list(reversed(back_nodes)) + [start] + fwd_nodes
    nb = len(back_nodes)
    found = [reindex(f, nb - 2 - f.index) for f in reversed(back_found)]
    found += [reindex(f, nb + 1 + f.index) for f in fwd_found]
    ends = [tuple(e) for e in (back_end, fwd_end) if e[0] is not None]
    return assemble(problem, nodes, found, ends, nb)


def _switch(pd: SpecialPoint, parameter, limits, settings: Settings, max_points: int) -> Branch:
    """The period-2n branch born at a period doubling (a pitchfork of ``P^2``)."""
    problem, node, _ = pd.context
    if parameter != problem.names[0]:
        raise ValueError(f"the period doubling was located in {problem.names[0]!r}; switch branches in that "
                         f"parameter, got {parameter!r}")
    lo, hi = check_limits(parameter, limits, pd.parameter)
    double = MapProblem(problem.base, problem.names, 2 * problem.n, problem.section_phase, problem.backend,
                        problem.options, problem.scales)
    if problem.orbit_events:
        double.limit_events(2 * problem.orbit_events)
    M = node.corrected.ev.monodromy
    w, vecs = np.linalg.eig(M)
    e = np.real(vecs[:, int(np.argmin(np.abs(w + 1.0)))])
    t0 = np.concatenate([e / np.linalg.norm(e), [0.0]])
    for h in (settings.step, 0.5 * settings.step, 0.25 * settings.step, 0.1 * settings.step):
        result = correct(double, node.u + h * t0, t0, settings, max_distance=2.0 * h)
        if isinstance(result, Corrected):
            z, params = unscaled(double, result.u)
            once = problem.evaluate(z, params)
            if once.ok and np.linalg.norm(once.residual) > 10.0 * settings.tol:  # a genuine period-2 orbit
                start = make_node(double, result, t0, h)
                nodes, found, status, message = follow(double, start, 1, (lo, hi), settings, max_points)
                found = [reindex(f, 1 + f.index) for f in found]
                return assemble(double, [start] + nodes, found, [(status, message)], 0)
    return assemble(double, [], [], [(-1, "no period-2 orbit was found next to the period doubling (the corrector "
                                         "from the critical eigenvector converged back onto the period-1 orbit or "
                                         "failed)")], 0)
