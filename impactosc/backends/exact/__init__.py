"""exact backend: closed-form pieces and rigorously bracketed guard roots.

Every mode of the hybrid system is linear with harmonic forcing, so a smooth piece has a
closed form and needs no time stepping at all. This is the ground truth the other
backends are tested against, and the fast path for long stick and creep phases: a stuck
mass is released where ``F cos(Omega t + phase) = restoring(x) +- beta``, an arccos.

Slipping piece
--------------
In region ``r`` with motion ``s`` the position is written relative to ``ref`` (``r`` in a
flange, 0 when free), ``Y = X - ref``, so the flange penetration ``r Y`` is computed
without cancelling against 1::

    Y'' + w^2 Y = cY + F cos(Omega t + phase),   w^2 = 1 + K r^2,
    cY = -r - beta s (flange) or -beta s (free).

With ``tau = t - t0`` and ``theta0 = Omega t0 + phase``::

    Y(tau) = Yp + Ah cos(w tau) + Bh sin(w tau) + F (cos(theta0) Cc(tau) - sin(theta0) Ss(tau)),
    Cc = (cos(Omega tau) - cos(w tau)) / (w^2 - Omega^2),
    Ss = (sin(Omega tau) - (Omega/w) sin(w tau)) / (w^2 - Omega^2).

where ``Yp = cY / w^2``, ``Ah = y0 - Yp``, ``Bh = v0 / w``. Where ``|Yp| > |y0|`` (huge
``beta``: ``Yp ~ -beta s / w^2``) the same motion is evaluated about the start point,
``Y = y0 - 2 Ah sin^2(w tau / 2) + ...``, so ``Yp`` never cancels against ``Ah`` (see
``_SlipPiece``); the velocity is ``v0 cos(w tau) - w Ah sin(w tau) + ...`` in both forms.

``Cc`` and ``Ss`` (the response to the forcing from rest) are evaluated through
``sin((w - Omega) tau / 2) / (w - Omega)``, which tends to ``tau / 2``: there is no
cancellation near resonance and the exact resonance ``w == Omega`` (``Omega = 1`` free,
``Omega = sqrt(1 + K)`` in contact) is the same formula. The homogeneous part uses ``tau``,
never the absolute time, so nothing degrades at large ``t``.

Damping and harmonic sums (the linear members of the model family) use the closed-form
pieces of ``impactosc.backends.exact._family`` (under-, critically and over-damped, the
steady response of each harmonic); a stuck piece with a harmonic sum uses
``impactosc.engine._stuck``.
A power-law flange, or a harmonic within ``1e-6`` of an (almost) undamped resonance, is
refused with a ``ValueError``.

Guards
------
The armed guards and their directions come from :func:`impactosc.engine.guard_gates` and
:data:`impactosc.engine.GUARD_DIRECTIONS`. A guard ``g`` with direction ``d`` fires at the
first ``tau > 0`` where ``h = d g`` passes from negative to non-negative; a root exactly at
the piece start therefore fires only if ``h`` was negative before it, which is never the
case at ``tau = 0`` (the engine snaps the state onto the guard surface it came from).

The piece first locates its "end" guard (``SLIP_END`` when armed, else ``ACCEL_ZERO``):
``h`` is a sum of sinusoids at ``w`` and ``Omega`` (times ``tau`` at resonance), bracketed by
recursive bisection with rigorous derivative bounds: on ``[a, b]`` a function with
``|h''| <= M2`` stays within ``M2 (b - a)^2 / 8`` of its chord, which excludes intervals of
one sign, and ``|h'''| <= M3`` applied to ``h'`` proves monotonicity, so a bracket holds a
single crossing. Near a double root (a tangency) the bisection goes on until the extremum
separates the two crossings; only below a few ulps of ``t``, or where the guard provably
stays within the rounding of its own evaluation (a bound of it, local to the piece start:
``_piece.rounding``), do the end values decide. The latter is a start at rest on
``f_net = 0`` with a forcing so slow that the motion stays below rounding: its guard
computes as rounding only, and bisecting it down to ulps would never end.
Up to that end guard ``X`` is monotonic (``s V >= 0``), so the flange guards are simple
sign tests at the two ends and one bracketed root, and a grazing contact (a flange
crossing just before a turning point) is found whenever the turning point lies beyond the
flange. Brackets are refined by safeguarded Newton (bisection whenever a Newton step
leaves the bracket or converges slowly) to one ulp of ``t``.

Integrals
---------
Over a flange piece, ``int K (r X - 1) dt = K r int Y dt`` in closed form about the start
point (``y0 tau - Ah (w tau - sin(w tau)) / w + ...``, see ``_SlipPiece.int_y``); ``int (K (r X - 1))^2 dt`` by 16-node
Gauss-Legendre quadrature on sub-intervals no longer than half the period of the fastest
frequency ``max(w, Omega)`` (error below 1e-19 relative, see ``_GL_NODES``); the forcing
work ``int V F cos(Omega t + phase) dt`` from the energy balance
``dE/dt = V (F cos(Omega t + phase) - beta s)``, i.e. ``Delta E + beta s Delta X``.
"""

from __future__ import annotations

import sys

from ..._util.jit import HAVE_NUMBA, INSTALL_HINT, warn_no_numba
from ...engine._driver import drive
from ...model._oscillator import Oscillator
from ...results._solution import Solution, _Recorder
from ._family import near_resonance
from ._stepper import _Stepper  # the stepper engine.drive steps (the Python path)

__all__ = ["run"]


def run(osc: Oscillator, t_end: float, x0: float, v0: float, *, record: str, max_events: int,
        sample_at=(), compiled: bool | None = None) -> Solution:
    """Run ``osc`` from ``(x0, v0)`` to ``t_end`` with closed-form pieces.

    Parameters
    ----------
    osc : Oscillator
        The model.
    t_end : float
        End time (> 0).
    x0, v0 : float
        Initial state at ``t = 0``.
    record : {"full", "events", "stats"}
        What the :class:`~impactosc.Solution` keeps.
    max_events : int
        Stop after this many recorded events.
    sample_at : tuple of float
        Sorted sample times (time events).
    compiled : bool or None
        ``None`` (default): run the whole event loop compiled (``impactosc.backends._exact_loop``) when numba
        is installed, else the Python driver :func:`impactosc.engine.drive` with a one-line
        hint. ``False`` forces the Python driver (same transition rule, same pieces, same
        results); ``True`` requires the compiled loop (a ``ValueError`` without numba).

    Returns
    -------
    Solution
        ``n_steps`` counts pieces: each is one closed-form evaluation.
    """
    missing = [f for f in osc.unsupported() if f.startswith("a power-law")]
    if osc.zeta or osc.harmonics:
        resonant = near_resonance(osc)
        if resonant:
            missing.append(resonant)
    subnormal = [F for F, _, _ in osc.terms if 0.0 < abs(F) < sys.float_info.min]
    if subnormal:
        # its closed form's guard search scales by the amplitude and loses every digit below the
        # smallest normal double (the search did not converge: status -1 for F = 5e-324)
        missing.append(f"a subnormal forcing amplitude ({subnormal[0]!r} < {sys.float_info.min!r}; 0 is exact)")
    if missing:
        raise ValueError(f"the exact backend does not support {', '.join(missing)} yet; "
                         "use backend='heyoka' or backend='scipy'")
    if compiled not in (None, True, False):
        raise TypeError(f"compiled must be None, True or False, got {compiled!r}")
    if compiled is not False:
        if HAVE_NUMBA:
            from . import _loop as _exact_loop

            return _exact_loop.run(osc, t_end, x0, v0, record=record, max_events=max_events, sample_at=sample_at)
        if compiled:
            raise ValueError(f"compiled=True needs numba: {INSTALL_HINT}")
        warn_no_numba("the exact backend's event loop")
    stepper = _Stepper(osc)
    rec = _Recorder(record, "exact", stepper.evaluate)
    drive(stepper, osc, t_end, x0, v0, rec, max_events, sample_at)
    return Solution(rec, t_end)
