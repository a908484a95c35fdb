"""Contact observables as a flange sensor sees them: per contact, per second, per flange, in SI units.

The paper's flange is an acoustic-emission (AE) sensor calibrated by ball drops (section 3,
Fig. 1): each impact's peak voltage is read as a peak force. Its Fig. 3(c) is an rms force
over a moving window, its Fig. 4 that force averaged over one second ("the magnitude as well
as the frequency of the impacts is taken into account"). The model's answer to those
readings is computed here from a :class:`~impactosc.results.Solution`: from its
:attr:`~impactosc.results.Solution.impacts` per contact, and from the sums over the contacts
that every run streams (:meth:`~impactosc.results.Solution.contact_sums`, also with
``record="stats"``, as sweeps run) per second:

* per contact (:func:`contact_table`): duration, entry speed, peak force, impulse, the
  elastic impact force of the entry speed, the kinetic energy brought in and the energy
  dissipated during the contact;
* per flange and per second (:func:`contact_observables`): impact rate, mean peak force,
  impulse and dissipated energy per impact, the mean and rms contact force, and the AE
  proxies (sums of peak or impact forces over one second, kinetic-energy and dissipation
  rates);
* over time (:func:`moving_rms_force`): the rms contact force over a moving window.

Units: with a drive (anything with the scales of :class:`~impactosc.TapeDrive`:
``force_scale = k L``, ``time_scale = 1/omega_n``, ``length_scale = L`` and ``stiffness = k``)
everything is in SI (N, s, m/s, J, W); without one, in the units of eq. 3 (force ``k L``,
time ``1/omega_n``, speed ``L omega_n``, energy ``k L^2``).
"""

from __future__ import annotations

import math

import numpy as np

from .._util import validation as _v

__all__ = ["CONTACT_DTYPE", "OBSERVABLES", "contact_table", "contact_observables", "moving_rms_force",
           "elastic_impact_force", "impact_force_law"]

CONTACT_DTYPE = np.dtype([
    ("start", "f8"), ("duration", "f8"), ("side", "i1"), ("entry_speed", "f8"), ("exit_speed", "f8"),
    ("peak_force", "f8"), ("impulse", "f8"), ("impact_force", "f8"), ("entry_energy", "f8"),
    ("dissipated", "f8"), ("complete", "?"),
])

#: name -> (SI units, meaning) of the entries of :func:`contact_observables` (per flange).
OBSERVABLES = {
    "impacts": ("1", "flange contacts that started in the run"),
    "impact_rate": ("1/s", "flange contacts per second"),
    "mean_peak_force": ("N", "mean peak force per contact"),
    "mean_impulse": ("N s", "mean impulse per contact"),
    "mean_dissipated": ("J", "mean energy dissipated per contact"),
    "mean_force": ("N", "time-averaged contact force (the paper's Fig. 7-8 quantity)"),
    "rms_force": ("N", "rms contact force over the run"),
    "ae_peak_sum": ("N/s", "AE proxy: the contacts' peak forces summed per second"),
    "ae_impact_sum": ("N/s", "AE proxy: the elastic impact forces of the entry speeds summed per second"),
    "impact_energy_rate": ("W", "AE proxy, energy variant: kinetic energy brought into contacts per second"),
    "dissipation_rate": ("W", "energy dissipated in contacts per second"),
}

_SIDES = {"upper": (1,), "lower": (-1,), "both": (1, -1)}


def impact_force_law(K: float, exponent: float) -> tuple[float, float]:
    """``(c, q)`` of the elastic impact force ``c |V|^q`` of a flange ``K d^p`` (see :func:`elastic_impact_force`).

    ``q = 2p / (p + 1)`` and ``c = K^(1/(p+1)) ((p + 1)/2)^(p/(p+1))``; the linear flange
    (eq. 2-3, ``p = 1``) gives ``(sqrt(K), 1)``.
    """
    p = float(exponent)
    return float(K) ** (1.0 / (p + 1.0)) * (0.5 * (p + 1.0)) ** (p / (p + 1.0)), 2.0 * p / (p + 1.0)


def elastic_impact_force(K: float, exponent: float, v):
    """The peak force of an entry speed ``v`` alone on a flange ``K d^p`` (units of eq. 3; arrays too).

    A mass arriving at ``|v|`` on the flange spring with nothing else acting stops where
    ``v^2/2 = K d^(p+1)/(p+1)``; the force there is ``K d^p = c |v|^q`` (:func:`impact_force_law`),
    ``sqrt(K) |v|`` for the linear flange of eq. 2-3 (``sqrt(k0 m) v`` in SI).

    Examples
    --------
    >>> from impactosc.results import elastic_impact_force
    >>> float(elastic_impact_force(1e4, 1.0, -2.0))           # sqrt(K) |V|
    200.0
    """
    c, q = impact_force_law(K, exponent)
    return c * abs(v) ** q


def _scales(sol, drive) -> dict[str, float]:
    """Factors from eq. 3's units to SI: force, time, speed, energy (all 1 without a drive)."""
    if drive is None:
        return {"force": 1.0, "time": 1.0, "speed": 1.0, "energy": 1.0}
    for name in ("force_scale", "time_scale", "length_scale"):
        if not hasattr(drive, name):
            raise TypeError(f"drive must have the scales of a TapeDrive (force_scale, time_scale, length_scale); "
                            f"got {type(drive).__name__} without {name}")
    fs, ts, ls = float(drive.force_scale), float(drive.time_scale), float(drive.length_scale)
    return {"force": fs, "time": ts, "speed": ls / ts, "energy": fs * ls}


def contact_table(sol, drive=None) -> np.recarray:
    """One row per flange contact, as a sensor in the flange sees it.

    Parameters
    ----------
    sol : Solution
        A run recorded with ``record="events"`` or ``"full"``. The energy dissipated in the
        contacts of a spring flange with friction (``beta > 0``) or damping (``zeta > 0``) is
        summed over the pieces inside each contact as the run streams them; the ``rk4``
        backend streams none, and gives NaN there.
    drive : TapeDrive, optional
        Gives SI units (see the module); without it the units are those of eq. 3.

    Returns
    -------
    numpy.recarray
        Fields (SI units with a drive):

        ``start`` (s), ``duration`` (s, 0 for a rigid impact), ``side`` (+1 upper, -1 lower),
        ``entry_speed`` and ``exit_speed`` (m/s, magnitudes; NaN exit for a contact open at
        the end), ``peak_force`` (N; ``k L K d_max^p``, the flange law at the deepest
        penetration, eq. 2-3; inf for a rigid impact), ``impulse`` (N s, ``int f dt`` over
        the contact; ``(1 + e) m v`` for a rigid impact), ``impact_force`` (N, below),
        ``entry_energy`` (J, ``m v_in^2 / 2``), ``dissipated`` (J, below), ``complete``.

    Notes
    -----
    **Impact force.** The peak force of the entry speed alone: a mass ``m`` arriving at
    ``v`` on the flange spring ``k0 d^p`` with nothing else acting stops at
    ``m v^2 / 2 = k0 d^(p+1) / (p+1)``, so ``f = k0 d^p``; for the linear flange (eq. 2)
    ``f = v sqrt(k0 m)`` (nondimensional ``sqrt(K) V``). It is the impact a ball-drop
    calibration measures (section 3): the part of the contact force that rings the sensor,
    without the slow push of the run-out that follows (which ``peak_force`` includes).
    Infinite for a rigid flange.

    **Dissipated energy.** A rigid flange: the restitution loss ``(1 - e^2) m v^2 / 2``.
    A spring flange stores and returns energy; during the contact the tape loses
    ``mu N`` times its slip path (friction, eq. 2) plus ``2 zeta m omega_n int v^2 dt``
    (damping): the friction and damping terms of the energy balance
    (:meth:`Solution.energy_balance`) restricted to the contact's pieces. The slip path is
    exact (smooth pieces are monotonic); ``int v^2 dt`` is the backend's own integral
    (closed form on ``exact``, an extra state of the Taylor integrator on ``heyoka``, of
    ``solve_ivp`` at its tolerance on ``scipy``).

    Examples
    --------
    >>> import impactosc
    >>> from impactosc.results import contact_table
    >>> osc = impactosc.Oscillator(F=0.0, Omega=1.0, beta=0.0, K=1e4)
    >>> sol = impactosc.simulate(osc, 3.0, 0.0, 2.0, backend="exact")
    >>> row = contact_table(sol)[0]
    >>> round(float(row.entry_speed), 6), round(float(row.impact_force), 3)  # sqrt(2^2 - 1), sqrt(K) v
    (1.732051, 173.205)
    """
    sc = _scales(sol, drive)
    osc = sol.oscillator
    imp = sol.impacts
    v_in = np.abs(np.asarray(imp.entry_velocity, dtype=float))
    v_out = np.abs(np.asarray(imp.exit_velocity, dtype=float))
    rigid_hit = np.isinf(np.asarray(imp.peak_force, dtype=float)) & bool(osc.rigid)  # an impact, not a rest
    out = np.recarray((len(imp),), dtype=CONTACT_DTYPE)
    out.start = imp.start * sc["time"]
    out.duration = (imp.end - imp.start) * sc["time"]
    out.side = imp.side
    out.entry_speed = v_in * sc["speed"]
    out.exit_speed = v_out * sc["speed"]
    out.peak_force = imp.peak_force * sc["force"]
    out.impulse = imp.impulse * sc["force"] * sc["time"]
    out.entry_energy = 0.5 * v_in**2 * sc["energy"]
    out.complete = imp.complete
    if osc.rigid:
        out.impact_force = np.where(rigid_hit, math.inf, 0.0)
    else:
        out.impact_force = elastic_impact_force(osc.K, osc.exponent, v_in) * sc["force"]
    out.dissipated = _dissipated(sol, imp, rigid_hit) * sc["energy"]
    return out


def _dissipated(sol, imp, rigid_hit: np.ndarray) -> np.ndarray:
    """The energy each contact took (units of ``k L^2``): the recorder's, else what the table alone gives."""
    if sol._dissipated is not None:
        return sol._dissipated
    osc = sol.oscillator
    if osc.rigid:
        e = osc.restitution
        v_in = np.asarray(imp.entry_velocity, dtype=float)
        return np.where(rigid_hit, 0.5 * (1.0 - e * e) * v_in**2, 0.0)
    if osc.beta == 0.0 and osc.zeta == 0.0:
        return np.zeros(len(imp))
    return np.full(len(imp), math.nan)  # a backend that streamed no pieces (rk4): documented, not silent


def contact_observables(sol, drive=None) -> dict[str, dict[str, float]]:
    """What a flange sensor reads over the run, per flange: rates, per-impact means, AE proxies.

    Parameters
    ----------
    sol : Solution
        The run, in any recording mode: the sums over its contacts are streamed
        (:meth:`Solution.contact_sums`), so a ``record="stats"`` run (a sweep's) gives the
        same numbers as a ``"full"`` one. The ``rk4`` backend streams none: it needs
        ``record="events"`` (its rows), and its ``mean_dissipated`` and ``dissipation_rate``
        of a dissipative spring flange are NaN (see :func:`contact_table`). Its whole
        duration is the averaging window (the paper averages over 1 s, Fig. 4, 7, 8); run a
        transient first and start the measured run from its end to average a steady state.
    drive : TapeDrive, optional
        Gives SI units; without it the units are those of eq. 3 (and "per second" means per
        unit of nondimensional time).

    Returns
    -------
    dict
        ``{"upper": {...}, "lower": {...}, "both": {...}}``, each with the entries of
        :data:`OBSERVABLES` (SI units listed there). With ``T`` the run's duration and the
        sums over the contacts that started in it (rows of :func:`contact_table`):

        * ``impact_rate = n / T``;
        * ``mean_peak_force``, ``mean_impulse``, ``mean_dissipated``: means over the
          contacts (NaN without contacts);
        * ``mean_force = (1/T) int f dt`` and ``rms_force = sqrt((1/T) int f^2 dt)``, the
          exact integrals of the flange force (eq. 2's ``k0 H(x^2 - L^2)(|x| - L)`` and its
          family; the paper's Fig. 7-8 average is ``mean_force``);
        * ``ae_peak_sum = (1/T) sum f_peak`` (N/s; numerically the sum over one second):
          the ball-drop-calibrated peak reading summed over one second (section 3,
          Fig. 4: "the magnitude as well as the frequency of the impacts");
        * ``ae_impact_sum = (1/T) sum f_impact``: the same with the elastic impact force
          of the entry speed (:func:`contact_table`), the part of a contact that rings a
          sensor blind to the reel frequency;
        * ``impact_energy_rate = (1/T) sum m v_in^2 / 2``: the energy variant (an AE
          sensor's rms voltage squared measures an energy rate, section 4 and [11]);
        * ``dissipation_rate = (1/T) sum (energy dissipated per contact)``.

        A rigid flange's impacts have infinite peak and impact forces (inf in the sums);
        its ``rms_force`` leaves the impulses out (see :meth:`Solution.rms_flange_force`).

    Examples
    --------
    >>> import impactosc
    >>> osc = impactosc.Oscillator(F=0.0, Omega=1.0, beta=0.0, K=1e4)
    >>> sol = impactosc.simulate(osc, 3.0, 0.0, 2.0, backend="exact")
    >>> obs = sol.contact_observables()    # units of eq. 3; pass a TapeDrive for SI
    >>> obs["both"]["impacts"], obs["upper"]["impacts"], round(obs["both"]["impact_rate"], 6)
    (3.0, 2.0, 1.0)
    """
    sc = _scales(sol, drive)
    duration = (sol.t_final - sol.t0) * sc["time"]
    per_second = 1.0 / duration if duration > 0 else math.nan
    table = None if sol._contact_sums is not None else contact_table(sol)  # rk4: its own rows
    out: dict[str, dict[str, float]] = {}
    for name, sides in _SIDES.items():
        side: int | None = None if len(sides) == 2 else sides[0]
        sums = sol.contact_sums(side) if table is None else _table_sums(table[np.isin(table.side, sides)])
        n = sums["contacts"]

        def mean(total, n=n):
            return total / n if n else math.nan

        force, impulse, energy = sc["force"], sc["force"] * sc["time"], sc["energy"]
        out[name] = {
            "impacts": n,
            "impact_rate": n * per_second,
            "mean_peak_force": mean(sums["peak_force"]) * force,
            "mean_impulse": mean(sums["impulse"]) * impulse,
            "mean_dissipated": mean(sums["dissipated"]) * energy,
            "mean_force": sol.mean_flange_force(side) * force,
            "rms_force": sol.rms_flange_force(side) * force,
            "ae_peak_sum": sums["peak_force"] * force * per_second,
            "ae_impact_sum": sums["impact_force"] * force * per_second,
            "impact_energy_rate": 0.5 * sums["entry_speed_sq"] * energy * per_second,
            "dissipation_rate": sums["dissipated"] * energy * per_second,
        }
    return out


def _table_sums(rows) -> dict[str, float]:
    """The sums of :meth:`Solution.contact_sums` over rows of :func:`contact_table` (units of eq. 3)."""
    return {"contacts": float(len(rows)), "entry_speed": float(np.sum(rows.entry_speed)),
            "entry_speed_sq": float(np.sum(rows.entry_speed**2)), "peak_force": float(np.sum(rows.peak_force)),
            "impulse": float(np.sum(rows.impulse)), "impact_force": float(np.sum(rows.impact_force)),
            "dissipated": float(np.sum(rows.dissipated))}


def moving_rms_force(sol, window: float, *, drive=None, step: float | None = None, side: int | None = None,
                     max_samples: int = 20_000_000) -> tuple[np.ndarray, np.ndarray]:
    """The rms contact force over a moving window, as the paper's Fig. 3(c) shows it.

    ``f_rms(t) = sqrt((1/w) int_{t-w}^{t} f(s)^2 ds)`` of the flange force ``f`` (eq. 2's
    spring ``k0 (|x| - L)`` on contact, its family's law; a rigid flange's wall push, its
    impacts left out), computed like a digital rms meter: ``f`` sampled every ``step`` with the
    exact dense output of the run, the integral a running sum of the samples. The first
    output time is ``t0 + w``.

    Parameters
    ----------
    sol : Solution
        A run recorded with ``record="full"``.
    window : float
        Window ``w`` in seconds with a ``drive``, else in nondimensional time (> 0, at most
        the run's duration).
    drive : TapeDrive, optional
        SI units (seconds in, newtons out).
    step : float, optional
        Sample interval, in the units of ``window``. Default: 1/16 of the period of the
        oscillation on a compressed linear flange (``2 pi / sqrt(1 + K)``), so that every
        contact is resolved; a rigid flange: ``window / 100``. Must not exceed ``window``.
    side : {1, -1, None}
        Upper, lower or both flanges (default both).
    max_samples : int
        Refuse (``ValueError``) a request needing more samples than this, instead of running
        for hours: raise ``step`` or shorten the run.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Output times (end of each window, s or nondimensional) and the rms force there (N, or
        units of ``k L``).

    Examples
    --------
    >>> import impactosc
    >>> from impactosc.results import moving_rms_force
    >>> osc = impactosc.Oscillator(F=2.0, Omega=1e-3, beta=0.0, K=1e2)
    >>> sol = impactosc.simulate(osc, 2 * 6283.185307179586, 1.0, 0.0, backend="exact")
    >>> t, rms = moving_rms_force(sol, 6283.185307179586, step=1.0)
    >>> bool(rms.max() > 0)
    True
    """
    sol._need("full", "moving_rms_force")
    sc = _scales(sol, drive)
    osc = sol.oscillator
    w = _v.positive("window", window) / sc["time"]
    duration = sol.t_final - sol.t0
    if not w <= duration:
        raise ValueError(f"window must be at most the run's duration {duration * sc['time']!r}, got {window!r}")
    if step is None:
        dt = w / 100.0 if osc.rigid else 2.0 * math.pi / osc.contact_frequency / 16.0
    else:
        dt = _v.positive("step", step) / sc["time"]
    if not dt <= w:
        raise ValueError(f"step must be at most window={window!r}, got {dt * sc['time']!r}")
    n = int(math.floor(duration / dt)) + 1
    if n > max_samples:
        raise ValueError(f"moving_rms_force needs {n} samples (run of {duration * sc['time']!r} at step "
                         f"{dt * sc['time']!r}), more than max_samples={max_samples}: raise step or shorten the run")
    sides = (1, -1) if side is None else sol._sides(side)
    t = sol.t0 + dt * np.arange(n)
    sq = np.empty(n)
    chunk = 1_000_000
    for a in range(0, n, chunk):
        tt = t[a:a + chunk]
        x, _, _, k = sol._evaluate(tt)
        f = sol._force_at(tt, x, k)
        if len(sides) == 1 and not osc.rigid:
            f = np.where(np.sign(x) == sides[0], f, 0.0)
        elif len(sides) == 1:
            region = sol._segments["region"][k]
            f = np.where(region == sides[0], f, 0.0)
        sq[a:a + chunk] = f * f
    cum = np.concatenate(([0.0], np.cumsum(sq) * dt))
    m = max(1, int(round(w / dt)))
    rms = np.sqrt(np.maximum(cum[m:] - cum[:-m], 0.0) / (m * dt))
    times = t[m - 1:] + dt
    return times * sc["time"], rms * sc["force"]

