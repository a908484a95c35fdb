"""``continuation``: the one entry point (a branch in one parameter, a boundary in two, a branch switch)."""

from __future__ import annotations

import dataclasses
import math
from contextlib import contextmanager

import numpy as np

from ..._util import validation as _v
from ...model._oscillator import Oscillator
from ...model.hybrid._definition import HybridSystem
from .._common import (
    advanced,
    check_base,
    check_study_parameter,
    forcing_period,
    on_a_terminal,
    oscillator_of,
    parameter_value,
    with_parameter,
)
from .._newton import PeriodicOrbit
from ..hybrid_map import HybridMap
from ..tangent import check_backend, check_start
from ._arclength import Corrected, Settings, correct, scaled, unscaled
from ._assembly import assemble, check_limits, reindex
from ._branch import SPECIAL_KINDS, Branch, BranchPoint, SpecialPoint
from ._follow import CLOSED, follow, make_node
from ._hybrid_problem import is_system_orbit, system_problem
from ._problem import MapProblem

__all__ = ["continuation"]

_DIRECTIONS = ("both", "forward", "backward")


def continuation(start, parameter, limits, *, base=None, backend: str | None = None, direction: str = "both",
                 step: float = 0.02, min_step: float = 1e-7, max_step: float = 0.1, max_points: int = 500,
                 tol: float = 1e-10, max_iter: int = 8, locate=True, locate_tol: float = 1e-12,
                 stop_at=(), progress: bool | None = None, **options) -> Branch:
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

    Grazings are crossed, not stepped over. A grazing of a flange is located as a regular
    point of the map with that flange taken away (``gap - max X = 0`` there, to the Newton
    tolerance, not extrapolated), labelled ``GR`` with the flange, and its multipliers are
    NaN (the map has no Jacobian at a grazing: a rigid stop's map has a square-root
    singularity there, the saltation matrix grows like ``1/V``). The branch then goes on in
    the family on the other side: a rigid flange's impacting family is entered with the
    impact's phase and speed as unknowns (smooth through zero impact speed), a stiff spring's
    from the same predictor with ``e = 1``. ``context[2]["case"]`` says which grazing it
    was: ``"persistent"`` (the family continues across) or ``"nonsmooth_fold"`` (the
    contact-free and the contacting family meet at the grazing and turn back together: the
    discontinuous case). Fold and period-doubling curves of single-impact orbits on a rigid
    flange end at the resonant grazing (``RG``), where the square-root term vanishes. Every
    point of a boundary is verified before it is accepted: its defining condition holds to
    ``10 tol`` and its orbit, rerun with every flange, returns.

    Parameters
    ----------
    start : PeriodicOrbit, BranchPoint, SpecialPoint or (float, float)
        * a converged :class:`PeriodicOrbit` (from :func:`periodic_orbit`): the branch through it;
        * a :class:`BranchPoint` of a branch (``branch.points[i]``, also of a loaded one), or a
          :class:`SpecialPoint` other than a period doubling with ``parameter`` one name: the
          branch through that point's orbit, in any parameter (a restart; ``branch.point(key)``
          finds a point by label or index);
        * a ``(X, V)`` guess on the section (``base`` required): Newton at the base's
          parameter value first;
        * a :class:`SpecialPoint` of a branch with ``parameter`` a pair of names: the
          boundary of that point in two parameters (grazing, stick onset, fold, period
          doubling); with ``parameter`` one name and the point a period doubling: the
          period-``2n`` branch that bifurcates there (branch switching);
        * a user system's orbit: a converged :class:`~impactosc.dynamics.PeriodicOrbit` (from
          :func:`~impactosc.dynamics.periodic_orbit_of`) or a guess of its state on the section,
          with ``base`` its :class:`~impactosc.dynamics.HybridMap` (or the
          :class:`~impactosc.HybridSystem`: the map of one forcing period from ``t = 0``); or
          a point of a user system's branch.
    parameter : str or (str, str)
        The free parameter: a field of the model (:func:`parameter_names`), or a parameter of
        the user system; two for a boundary.
    limits : (float, float) or dict
        ``(lo, hi)`` of the (first) parameter; for a boundary, a dict of ``name: (lo, hi)``
        (either parameter; at least one). The branch ends on a limit.
    base : Oscillator, TapeDrive, HybridMap or HybridSystem, optional
        The model whose fields are the parameters. Default: the orbit's oscillator. Give a
        :class:`TapeDrive` to continue in its SI fields (its :meth:`~TapeDrive.oscillator` must be the orbit's).
        For a user system, its map (required with a user system's :class:`PeriodicOrbit`, which does not carry it).
    backend : {"exact", "heyoka", "scipy"}, optional
        Default ``"exact"`` where it runs the member, else ``"heyoka"``.
    direction : {"both", "forward", "backward"}
        Forward is the direction of increasing parameter at the start.
    step, min_step, max_step : float
        Arclength steps in scaled units (state nondimensional; the parameter divided by the
        larger of its value at the start and the span ``hi - lo`` of its limits, so a
        parameter that starts at 0 crosses its range in a few dozen steps).
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
    progress : bool, optional
        A tqdm progress bar over the accepted points. Default: shown when standard error is
        a terminal (not in a notebook, a pipe or a log file); False never imports tqdm.
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
        For a bad argument: an unknown parameter, a field that is not a number (``flange``), a
        parameter that does nothing in this member (``K`` of a rigid flange), limits not
        ``lo < hi``, not finite or outside the parameter's domain (``beta < 0``,
        ``exponent < 1``), a start outside the limits, a start that is not a converged orbit,
        an explicit backend that does not run every member of the range (``backend="exact"``
        with ``exponent`` free: pass no backend and heyoka runs the branch, the message says so).

    Examples
    --------
    The rigid one-sided stop of COCO's impact demo, ``X'' + 0.1 X' + X = F cos(Omega t)``
    with a wall at ``X = 1``: a branch in ``F`` from a contact-free orbit, its grazing, the
    grazing followed in ``(F, Omega)``, and the orbit at a labelled point:

    >>> import impactosc as io, impactosc.dynamics as dy
    >>> stop = io.Oscillator(0.3, 1.0, 0.0, zeta=0.05, flange="rigid", restitution=0.8, gap_lower=None)
    >>> orb = dy.periodic_orbit(stop, backend="exact", transient_periods=200)
    >>> br = dy.continuation(orb, "F", (0.02, 0.5))
    >>> print(br.summary())                                   # doctest: +SKIP
    >>> gr = br.find("grazing")[0]
    >>> curve = dy.continuation(gr, ("F", "Omega"), {"Omega": (0.5, 1.4)})   # doctest: +SKIP
    >>> br.orbit(gr.label).solution.plot()                    # doctest: +SKIP

    A parameter that starts at 0 (the damping), restarted from the last point of a branch:

    >>> tail = dy.continuation(br.points[-1], "zeta", (0.0, 0.2))            # doctest: +SKIP

    A user's own system goes through the same loop: the stop above written as a
    :class:`~impactosc.HybridSystem`, its impacting orbit at ``F = 0.5`` followed in ``F``
    up to its period doubling (``F = 0.5182098666`` in closed form at ``Omega = 0.8``).
    Special points of a user system are the same kinds; a grazing is labelled with its
    guard (:attr:`SpecialPoint.guard`) and crossed as a flange's is (on the system with that
    guard taken away; for a guard with a reset, onto the impacting orbits with the impact's
    time and state as unknowns), or, where that fails, ends the branch with status 2:

    >>> import math, heyoka as hy
    >>> from impactosc import Guard, HybridMode, HybridSystem, symbols
    >>> x, v, F, W = symbols("x v F W")
    >>> wall = HybridSystem("x v", {"F": 0.5, "W": 0.8},
    ...                     [HybridMode("free", {x: v, v: F * hy.cos(W * hy.time) - x - 0.1 * v})],
    ...                     [Guard("impact", x - 1, 1, armed="free", to="free", reset={v: -0.8 * v})],
    ...                     period=2 * math.pi / W)
    >>> hmap = dy.HybridMap(wall)
    >>> orbit = dy.periodic_orbit_of(hmap, [0.96, 0.45])
    >>> up = dy.continuation(orbit, "F", (0.45, 0.6), base=hmap, direction="forward", progress=False)
    >>> [(s.label, round(s.parameter, 9)) for s in up.special]
    [('PD1', 0.518209867)]

    Down in ``F`` the impact speed falls to zero at the grazing, ``F = |1 - W^2 + 0.1 i W|``
    (0.368781778 in closed form), and the branch goes on along the contact-free orbits; the
    grazing is then followed in ``(F, W)``, like a flange's:

    >>> down = dy.continuation(orbit, "F", (0.1, 0.5), base=hmap, direction="backward", progress=False)
    >>> (graze,) = down.find("grazing")
    >>> down.status, graze.guard, round(graze.parameter, 9)
    (0, 'impact', 0.368781778)
    >>> curve = dy.continuation(graze, ("F", "W"), {"W": (0.7, 0.9)}, progress=False)
    >>> curve.status, len(curve.points) > 5
    (0, True)

    References
    ----------
    Keller (1977); Kuznetsov, *Elements of Applied Bifurcation Theory* (2004), ch. 10;
    di Bernardo, Budd, Champneys & Kowalczyk, *Piecewise-smooth Dynamical Systems* (2008);
    Dankowicz & Schilder, *Recipes for Continuation* (2013) (COCO's ``hspo``).
    """
    settings = _settings(step, min_step, max_step, max_points, tol, max_iter, locate, locate_tol, stop_at)
    if direction not in _DIRECTIONS:
        raise ValueError(f"direction must be one of {', '.join(_DIRECTIONS)}, got {direction!r}")
    if isinstance(start, SpecialPoint) and (isinstance(parameter, tuple | list) or start.kind == "period_doubling"):
        return _from_special(start, parameter, limits, settings, backend, options, progress, max_points)
    if isinstance(parameter, tuple | list):
        raise TypeError("two parameters need a SpecialPoint start (a located point to follow as a boundary), got "
                        f"{type(start).__name__}")
    if _of_a_system(start, base):
        return _system_branch(start, parameter, limits, base, direction, settings, progress, max_points, options)
    if isinstance(start, BranchPoint | SpecialPoint):
        start, base, backend, options = _restart(start, base, backend, options)
    problem, z0, note = _problem_from(start, parameter, limits, base, backend, options)
    lo, hi = check_limits(parameter, limits, problem.values()[0])
    with _progress(progress, f"continuation in {parameter}") as on_point:
        settings = dataclasses.replace(settings, on_point=on_point)
        branch = _run(problem, z0, (lo, hi), direction, settings, max_points)
    if note:
        branch = dataclasses.replace(branch, message=f"{branch.message}; {note}")
    return _adopt(branch, problem)


def _from_special(start: SpecialPoint, parameter, limits, settings: Settings, backend, options, progress,
                  max_points: int) -> Branch:
    """A located point followed as a boundary (two parameters), or the branch switch at a period doubling."""
    if not isinstance(start.context, tuple) or len(start.context) != 3 or start.context[0] is None:
        raise ValueError(f"the SpecialPoint {start.label!r} carries no context (it was built by hand or loaded "
                         "from a file): only a point located by continuation() can be followed as a boundary or "
                         "switched at; restart from its orbit instead, continuation(branch.orbit(label), ...)")
    located = start.context[0]
    if isinstance(parameter, tuple | list):
        from ._boundary import boundary

        if not isinstance(located, MapProblem):
            if options or backend is not None:
                raise TypeError(f"a user system's boundary takes no backend or backend options, got backend="
                                f"{backend!r}, options {sorted(options)}: the map's tolerance is its HybridMap's")
        elif isinstance(limits, dict):  # the same up-front refusals as a branch in one parameter
            for name, pair in limits.items():
                pair = _limits_pair(name, pair)
                check_study_parameter(located.base, name, pair)
                _range_backend(located.base, name, pair, backend or located.backend, {**located.options, **options})
        with _progress(progress, f"boundary in {', '.join(map(str, parameter))}") as on_point:
            settings = dataclasses.replace(settings, on_point=on_point)
            return _adopt(boundary(start, tuple(parameter), limits, settings, backend, options), located)
    with _progress(progress, f"period-2 branch in {parameter}") as on_point:
        settings = dataclasses.replace(settings, on_point=on_point)
        return _adopt(_switch(start, parameter, limits, settings, max_points), located)


def _of_a_system(start, base) -> bool:
    """Whether the start is a user system's: its orbit, a point of its branch, or a guess with its map as base."""
    if isinstance(base, HybridMap | HybridSystem) or is_system_orbit(start):
        return True
    branch = getattr(start, "branch", None) if isinstance(start, BranchPoint | SpecialPoint) else None
    return branch is not None and branch.is_system


def _system_branch(start, parameter, limits, base, direction: str, settings: Settings, progress, max_points: int,
                   options) -> Branch:
    """The branch of a user system's periodic orbits (:mod:`._hybrid_problem`), by the same follow loop."""
    if is_system_orbit(start) and base is None:
        raise TypeError("a HybridOrbit does not carry its map: pass it with base=HybridMap(system, ...) (the map "
                        "periodic_orbit_of solved), or the system itself")
    if isinstance(start, BranchPoint | SpecialPoint):
        branch = start.branch
        if base is None:
            base = HybridMap(branch.model(start), branch.n, t0=branch.section_phase)
        start = start.z
    lo, hi = _limits_pair(parameter, limits)
    problem, z0 = system_problem(start, parameter, (lo, hi), base, options)
    lo, hi = check_limits(parameter, limits, problem.values()[0])
    with _progress(progress, f"continuation in {parameter}") as on_point:
        settings = dataclasses.replace(settings, on_point=on_point)
        branch = _run(problem, z0, (lo, hi), direction, settings, max_points)
    return _adopt(branch, problem)


@contextmanager
def _progress(progress, desc: str):
    """A callback for every accepted point that moves a tqdm bar, or None (no bar: off when not a terminal)."""
    show = on_a_terminal() if progress is None else bool(progress)
    if not show:
        yield None
        return
    from tqdm.auto import tqdm

    with tqdm(desc=desc, unit="point") as bar:
        def on_point(node):
            bar.update(1)

        yield on_point


def _adopt(branch: Branch, problem: MapProblem) -> Branch:
    """The branch with its section and options, every point knowing it (a start of its own)."""
    branch = dataclasses.replace(branch, section_phase=problem.section_phase, options=dict(problem.options))
    return branch.adopted()


def _restart(point: BranchPoint | SpecialPoint, base, backend, options):
    """``(PeriodicOrbit, base, backend, options)`` of a branch's point, to start a new branch there."""
    branch = point.branch
    if branch is None:
        raise ValueError(f"this {type(point).__name__} belongs to no branch (built by hand): give a PeriodicOrbit "
                         "start, e.g. periodic_orbit(model, guess=(x, v))")
    here = branch.model(point)
    if base is None:
        base = here
    elif oscillator_of(check_base(base)) != oscillator_of(here):
        raise ValueError("base must be the model at the branch point (branch.model(point)); its oscillator differs")
    options = {**branch.options, **options}
    backend = branch.backend if backend is None else backend
    orbit = branch.orbit(point, **{k: v for k, v in options.items() if k not in branch.options})
    if orbit.status != 0:
        raise ValueError(f"the orbit at the branch point did not converge again (status {orbit.status}): "
                         f"{orbit.message}")
    return orbit, base, backend, options


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
    try:
        check_backend(osc, "exact", options)
        return "exact"
    except ValueError:
        return "heyoka"


def _range_backend(base, parameter: str, limits, backend, options) -> tuple[str, str]:
    """``(backend, note)``: a backend that runs every member of the parameter's range.

    The members at both limits are checked (a parameter such as the flange exponent takes
    the branch out of the exact backend's linear members). A default backend becomes heyoka
    for the whole branch when exact does not run them all (``note`` says so); an explicit
    one that does not is refused.
    """
    chosen = default_backend(oscillator_of(base), backend, options)
    for value in limits:
        member = oscillator_of(with_parameter(base, parameter, float(value)))
        try:
            check_backend(member, chosen, options)
        except ValueError as exc:
            if backend is not None:
                raise ValueError(f"backend={backend!r} does not run every member of the range of {parameter}: at "
                                 f"{parameter} = {value!r} {exc}; leave backend out (heyoka runs every member) or "
                                 "narrow the limits") from None
            return "heyoka", (f"backend heyoka for the whole branch: the exact backend does not run the member at "
                              f"{parameter} = {value!r} ({exc})")
    return chosen, ""


def _problem_from(start, parameter, limits, base, backend, options):
    """``(MapProblem, z0, note)`` of a PeriodicOrbit or a guess."""
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
            raise TypeError(f"start must be a PeriodicOrbit, a BranchPoint or a SpecialPoint, or a guess (X, V) with "
                            f"base=..., got {type(start).__name__}")
        check_base(base)
        try:
            gx, gv = start
        except (TypeError, ValueError):
            raise TypeError(f"start must be a PeriodicOrbit, a SpecialPoint or a pair (X, V), got {start!r}") from None
        osc, n = oscillator_of(base), 1
        # the magnitude check of periodic_orbit: a guess whose run would overflow is no orbit's point
        z0 = check_start(osc, forcing_period(osc), gx, gv, names=("start[0]", "start[1]"))
        theta = osc.phase
    check_study_parameter(base, parameter, _limits_pair(parameter, limits))
    backend, note = _range_backend(base, parameter, _limits_pair(parameter, limits), backend, options)
    value = parameter_value(base, parameter)
    lo, hi = _limits_pair(parameter, limits)
    scale = max(abs(value), hi - lo)
    problem = MapProblem(base, (parameter,), n, theta, backend, options, (scale,))
    return problem, np.array(z0, dtype=float), note


def _limits_pair(name, limits) -> tuple[float, float]:
    """The limits as floats (checked in full by check_limits; only their shape and order here)."""
    try:
        lo, hi = (float(x) for x in limits)
    except (TypeError, ValueError):
        raise TypeError(f"limits must be a pair (lo, hi) of the parameter {name!r}, got {limits!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"limits must be finite with lo < hi, got {limits!r}")
    return lo, hi


def _start_node(problem: MapProblem, z0, settings: Settings):
    """The start corrected at its parameter value: a Node, or a string saying why not."""
    u0 = scaled(problem, z0, problem.values())
    constraint = np.zeros_like(u0)
    constraint[problem.dimension] = 1.0
    result = correct(problem, u0, constraint, settings)
    if not isinstance(result, Corrected):
        return f"no periodic orbit was found from the start ({z0[0]!r}, {z0[1]!r}): {result}"
    node = make_node(problem, result, None, 0.0)
    problem.limit_events(problem.events_in(result.ev))
    if node.t[problem.dimension] < 0.0:
        node.t = -node.t
    return node


def _run(problem: MapProblem, z0, limits, direction: str, settings: Settings, max_points: int) -> Branch:
    start = _start_node(problem, z0, settings)
    if isinstance(start, str):
        return assemble(problem, [], [], [(-1, start)], 0)
    sides = {"forward": (1,), "backward": (-1,), "both": (-1, 1)}[direction]
    results: dict = {}
    for d in sides:
        if any(r[3].startswith(CLOSED) for r in results.values()):
            break  # the other direction came round: this one would go round again
        results[d] = follow(problem, start, d, limits, settings, max_points)
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
    double = problem.doubled()
    M = node.corrected.ev.monodromy
    w, vecs = np.linalg.eig(M)
    e = np.real(vecs[:, int(np.argmin(np.abs(w + 1.0)))])
    t0 = np.concatenate([e / np.linalg.norm(e), np.zeros(len(problem.names))])
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
