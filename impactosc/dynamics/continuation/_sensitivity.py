"""The parameter derivative ``dP/dp`` of the stroboscopic map, carried through pieces and events.

Continuation needs the full Jacobian ``[dP/dz, dP/dp]`` of ``G(z, p) = P^n(z; p) - z``. The
first block is the monodromy matrix of :mod:`..tangent` (state-transition matrices and
saltation matrices). The second is the same construction for the parameter taken as a
state with zero derivative (Bernardo et al. 2008, sec. 2.5; Dankowicz & Schilder 2013, the
``hspo`` toolbox of COCO): its sensitivity ``sigma = dz/dp`` obeys

* over a smooth piece ``sigma' = A(t) sigma + df/dp``, so
  ``sigma(t1) = Phi(t1, t0) sigma(t0) + int_t0^t1 Phi(t1, s) df/dp(s) ds`` (Duhamel). On the
  linear modes ``Phi(t1, s)`` is closed form (:func:`..flow.linear_transition`) and the
  integral is done by Gauss-Legendre quadrature on the piece's own dense output (the
  backend's evaluator), composite on sub-intervals of at most :data:`PANEL` time units, so
  its error is at the rounding level; on a power-law flange the piece and its sensitivity are
  integrated together (scipy DOP853 at 1e-12);
* at an event on the guard ``h(z, t; p) = 0`` with reset ``R`` the augmented saltation
  matrix adds the column ``(f+ - R_z f-) h_p / (n.f- + h_t) + R_p`` (the time shift of the
  event caused by the parameter, and the reset's own dependence on it: the restitution);
* at the end of the map ``P`` is taken at ``t = n T(p)``: ``+ f(t_end) dT/dp``.

``df/dp``, ``h_p``, ``R_p`` and ``dT/dp`` are derivatives of algebraic expressions of the
model (the transition rule's vector field, guard functions and reset, :mod:`impactosc.model`),
taken by a fourth-order central difference of those expressions in ``p`` (one-sided near
a bound of the parameter's domain): the physics is written once, in the rule, and an
asymmetric flange or a new member needs nothing here. Their error is ~1e-11 relative;
the state's propagation is exact. (Finite differences of the *map* are the tests' oracle.)
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from ...engine._driver import AT_WALL, IMPACT, N_GUARDS, REVERSAL, STICK, guard_gradient, guard_value
from ..flow import transition_matrix, variational_transition
from ..saltation import vector_field
from ..tangent import TangentRecorder

__all__ = ["SensitivityRecorder", "Stencil", "PANEL", "flange_gap", "piece_constants", "particular"]

#: Longest sub-interval (time units) of the composite Gauss-Legendre rule on a piece.
PANEL = 1.0
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(12)

#: Rel. tolerances of the DOP853 integration of a power-law piece with its sensitivities.
_RTOL, _ATOL = 1e-12, 1e-14


class Stencil:
    """Derivatives in ``p`` of algebraic functions of the model, by a central difference.

    ``family(p)`` builds the model at ``p``. The stencil ``p + k h`` (``k = -2..2``, or
    one-sided ``0..4`` when a point beyond a bound of the domain fails to build) is made
    once per point; :meth:`derivative` applies the weights to the values of a function of
    each member.
    """

    _CENTRAL = ((-2, 1.0 / 12.0), (-1, -8.0 / 12.0), (1, 8.0 / 12.0), (2, -1.0 / 12.0))
    _FORWARD = ((0, -25.0 / 12.0), (1, 4.0), (2, -3.0), (3, 4.0 / 3.0), (4, -0.25))

    def __init__(self, family, p: float, scale: float):
        self.h = 2e-4 * max(abs(p), scale)
        self.members = []
        for rule in (self._CENTRAL, self._FORWARD, tuple((-k, -w) for k, w in self._FORWARD)):
            try:
                self.members = [(family(p + k * self.h) if k else None, w) for k, w in rule]
                break
            except ValueError:
                continue
        if not self.members:
            raise ValueError(f"the model cannot be built within {4 * self.h:.3g} of the parameter value {p!r} "
                             "on either side: no derivative in the parameter exists there")
        self.center = family(p)

    def derivative(self, fn):
        """``d fn(model) / dp`` (``fn`` may return arrays)."""
        total = 0.0
        for m, w in self.members:
            total = total + w * fn(self.center if m is None else m)
        return total / self.h


def _duhamel_column(w2: float, zeta: float, tau: np.ndarray):
    """Second column ``(Phi12, Phi22)`` of ``exp(A tau)`` (:func:`..flow.linear_transition`), vectorised."""
    q = zeta * zeta - w2
    if q < 0.0:
        mu = math.sqrt(-q)
        decay = np.exp(-zeta * tau)
        C, S = decay * np.cos(mu * tau), decay * np.sin(mu * tau) / mu
    elif q > 0.0:
        kappa = math.sqrt(q)
        up, down = np.exp((kappa - zeta) * tau), np.exp(-(kappa + zeta) * tau)
        C, S = 0.5 * (up + down), 0.5 * (up - down) / kappa
    else:
        decay = np.exp(-zeta * tau)
        C, S = decay, decay * tau
    return S, C - zeta * S


class SensitivityRecorder(TangentRecorder):
    """A :class:`..tangent.TangentRecorder` that also carries ``sigma = dz/dp`` (module docstring).

    Also keeps what continuation reads off one period: the extremes of ``X`` (pieces are
    monotonic in ``X`` between velocity zeros), the impact speeds per flange and the
    stick margin at every reversal.
    """

    def __init__(self, record, backend, evaluator, stencils):
        super().__init__(record, backend, evaluator, keep_saltations=True)
        self.stencils = tuple(stencils)
        self.sigma = np.zeros((2, len(self.stencils)))  # column j: dz/dp_j
        #: ``(x, dx/dz0 row, dx/dp row)`` at the largest and the smallest X met (a velocity zero
        #: or a piece end): the exact gradient of the distance to each flange.
        self.top = None
        self.bottom = None
        #: Times of ``top`` and ``bottom`` from the start of the run (where a grazing orbit touches).
        self.top_t = self.bottom_t = math.nan
        self.x_max = -math.inf
        self.x_min = math.inf
        self.impact_speed = {1: math.inf, -1: math.inf}
        self.final_mode = None
        #: Every velocity zero of a sliding mass (a reversal, or a stick): ``(t, x, mode before, state Jacobian,
        #: sigma)`` just before it, where the stick test ``beta_s - |f_net|`` is decided (its exact gradient).
        self.turns: list = []

    def begin(self, osc, t, x, v, mode):
        super().begin(osc, t, x, v, mode)
        self.x_max = self.x_min = x
        self._extremes(x, t)

    def piece(self, mode, t0, x0, t1, x1, q, q2, w, vv, steps):
        v0 = self._state[2] if self._state is not None else math.nan
        super().piece(mode, t0, x0, t1, x1, q, q2, w, vv, steps)
        self.x_max = max(self.x_max, x0, x1)
        self.x_min = min(self.x_min, x0, x1)
        r, s = mode.region, mode.motion
        if s == 0 or not t1 > t0:
            return
        osc = self.osc
        if r == 0 or osc.rigid or osc.exponent == 1.0:
            w2 = piece_constants(osc, r, s)[0]
            Phi = np.reshape(transition_matrix(osc, mode, t0, x0, v0, t1), (2, 2))  # the tangent's own matrix
            sigma = Phi @ self.sigma
            quadrature = []
            for j, stencil in enumerate(self.stencils):
                forced = _particular_column(stencil, r, s, t0, t1, Phi)
                if forced is None:
                    quadrature.append(j)
                else:
                    sigma[:, j] += forced
            if quadrature:
                sigma[:, quadrature] += self._duhamel(mode, t0, x0, v0, t1, w2, [self.stencils[j] for j in quadrature])
            self.sigma = sigma
        else:
            self.sigma = _power_law_sensitivity(self, mode, t0, x0, v0, t1)
        self._extremes(x1, t1)

    def _duhamel(self, mode, t0, x0, v0, t1, w2, stencils):
        """``int Phi(t1, s) df/dp(s) ds`` over a linear piece by composite Gauss-Legendre quadrature."""
        r, s = mode.region, mode.motion
        n_panels = max(1, math.ceil((t1 - t0) / PANEL))
        edges = np.linspace(t0, t1, n_panels + 1)
        half = 0.5 * np.diff(edges)
        nodes = (0.5 * (edges[:-1] + edges[1:])[:, None] + half[:, None] * _NODES[None, :]).ravel()
        weights = (half[:, None] * _WEIGHTS[None, :]).ravel()
        xs, vs = self.evaluator(mode, t0, x0, v0, nodes)[:2]
        c12, c22 = _duhamel_column(w2, self.osc.zeta, t1 - nodes)
        out = np.zeros((2, len(stencils)))
        for j, stencil in enumerate(stencils):
            dadp = stencil.derivative(lambda m: m.acceleration(nodes, xs, vs, r, s))
            out[0, j] = float(np.sum(weights * c12 * dadp))
            out[1, j] = float(np.sum(weights * c22 * dadp))
        return out

    def _extremes(self, x, t):
        """Keep the state's derivatives where ``X`` is largest / smallest so far (an end of a monotonic piece)."""
        if self.singular is not None:
            return
        row = (self.jacobian[0], self.jacobian[1])
        if self.top is None or x >= self.top[0]:
            self.top, self.top_t = (x, row, self.sigma[0].copy()), t
        if self.bottom is None or x <= self.bottom[0]:
            self.bottom, self.bottom_t = (x, row, self.sigma[0].copy()), t

    def on_transition(self, t, mode_before, guard, mode_after, x_before, v_before, x_after, v_after, kind):
        if kind in (REVERSAL, STICK) and mode_before.motion != 0 and self.singular is None:
            self.turns.append((t, x_before, mode_before, self.jacobian, self.sigma.copy()))
        n_sal = len(self.saltations)
        super().on_transition(t, mode_before, guard, mode_after, x_before, v_before, x_after, v_after, kind)
        if kind == IMPACT:
            side = 1 if x_after > 0.0 else -1
            self.impact_speed[side] = min(self.impact_speed[side], abs(v_before))
        if guard is None or len(self.saltations) == n_sal:
            return
        sal = self.saltations[-1]
        if sal.singular:
            self.sigma = np.full(self.sigma.shape, math.nan)
            return
        a, b, c, d = sal.matrix
        sigma = np.array([[a, b], [c, d]]) @ self.sigma
        if guard != AT_WALL and 0 <= guard < N_GUARDS:
            sigma += self._event_columns(t, mode_before, guard, mode_after, x_before, v_before, x_after, v_after,
                                         kind)
        if mode_after.motion == 0:
            sigma[1] = 0.0  # stuck after the event: V = 0 for every parameter
        self.sigma = sigma

    def _event_columns(self, t, mode_before, guard, mode_after, x_before, v_before, x_after, v_after, kind):
        """``(f+ - R f-) h_p / (n.f- + h_t) + R_p`` for every parameter (module docstring)."""
        osc = self.osc
        fx0, fv0 = vector_field(osc, t, x_before, v_before, mode_before)
        fx1, fv1 = vector_field(osc, t, x_after, v_after, mode_after)
        r22 = -osc.restitution if kind == IMPACT else 1.0
        (nx, nv), ht = guard_gradient(osc, mode_before, guard, t, x_before, v_before)
        denom = nx * fx0 + nv * fv0 + ht
        columns = np.zeros((2, len(self.stencils)))
        for j, stencil in enumerate(self.stencils):
            hp = stencil.derivative(lambda m: guard_value(m, mode_before, guard, t, x_before, v_before))
            if hp != 0.0 and denom != 0.0:
                columns[:, j] += np.array([fx1 - fx0, fv1 - r22 * fv0]) * (hp / denom)
            if kind == IMPACT:
                columns[1, j] -= v_before * stencil.derivative(lambda m: m.restitution)
        return columns

    def chatter(self, jump, t):
        state = super().chatter(jump, t)
        # The sequence ends at rest on the wall, X = +-1 and V = 0 whatever p: a zero sensitivity.
        self.sigma = np.zeros(self.sigma.shape)
        return state

    def finish(self, t, x, v, mode, status, message):
        super().finish(t, x, v, mode, status, message)
        self.final_mode = mode
        self.x_max = max(self.x_max, x)
        self.x_min = min(self.x_min, x)
        self._extremes(x, t)


def flange_gap(osc, side: int) -> float:
    """Distance of the flange on ``side`` (+1 upper, -1 lower) from ``X = 0`` (inf: no flange there).

    1 for the paper's symmetric guide; a model with flanges at their own distances says so
    through its ``gap(side)``.
    """
    gap = getattr(osc, "gap", None)
    return float(gap(side)) if callable(gap) else 1.0


def piece_constants(osc, region: int, motion: int) -> tuple[float, float, float]:
    """``(w2, zeta, c0)`` of a linear piece ``X'' + 2 zeta X' + w2 X = forcing(t) + c0`` (eq. 3 and its family).

    Read off :meth:`Oscillator.acceleration`: a linear spring flange at ``X = region gap``
    adds ``K`` to the stiffness and ``region K gap`` to the constant, friction ``-beta motion``.
    """
    if region != 0 and not osc.rigid:
        gap = flange_gap(osc, region)
        return 1.0 + osc.K, osc.zeta, region * osc.K * gap - osc.beta * motion
    return 1.0, osc.zeta, -osc.beta * motion


#: Relative distance from resonance (``|w2 - Omega^2| + 2 zeta Omega`` against ``w2``) below which the
#: particular solution is not used (it grows without bound there); the quadrature takes over.
RESONANCE = 1e-6


def particular(osc, region: int, motion: int, t: float):
    """``(X_p, V_p)`` at ``t``: the periodic particular solution of the linear piece, or None near resonance."""
    w2, zeta, c0 = piece_constants(osc, region, motion)
    x, v = c0 / w2, 0.0
    for F, Om, ph in osc.terms:
        if F == 0.0:
            continue
        if Om == 0.0:
            x += F * math.cos(ph) / w2
            continue
        den = complex(w2 - Om * Om, 2.0 * zeta * Om)
        if abs(den) < RESONANCE * w2:
            return None
        z = F * cmath.exp(1j * (Om * t + ph)) / den
        x += z.real
        v += (1j * Om * z).real
    return np.array([x, v])


def _particular_column(stencil: Stencil, r: int, s: int, t0: float, t1: float, Phi: np.ndarray):
    """``d/dp [x_p(t1) - Phi x_p(t0)]``: the forced part of the sensitivity over a linear piece.

    Over the piece ``x(t) = x_p(t) + Phi(t - t0) (x(t0) - x_p(t0))``; when the parameter leaves
    the piece's matrix ``A`` alone (its ``w2`` and ``zeta``), ``Phi`` does not depend on it and
    the forced part is exactly this derivative of an algebraic expression. None when ``A``
    depends on the parameter (a flange stiffness in a contact piece, the damping) or near
    resonance: the quadrature does those.
    """
    members = [stencil.center] + [m for m, _ in stencil.members if m is not None]
    if any(piece_constants(m, r, s)[:2] != piece_constants(stencil.center, r, s)[:2] for m in members):
        return None
    ends = []
    for t in (t0, t1):
        values = [particular(m, r, s, t) for m in members]
        if any(v is None for v in values):
            return None
        ends.append(stencil.derivative(lambda m, t=t: particular(m, r, s, t)))
    return ends[1] - Phi @ ends[0]


def _power_law_sensitivity(rec: SensitivityRecorder, mode, t0, x0, v0, t1):
    """``sigma(t1)`` over a power-law flange piece: the piece, its Jacobian and ``sigma`` integrated together."""
    from scipy.integrate import solve_ivp

    osc, r, s = rec.osc, mode.region, mode.motion
    k = len(rec.stencils)

    def rhs(t, y):
        x, v = y[0], y[1]
        A = osc.jacobian(t, x, v, r, s)
        out = [v, osc._accel_scalar(t, x, v, r, s)]
        for j, stencil in enumerate(rec.stencils):
            fp = stencil.derivative(lambda m: m._accel_scalar(t, x, v, r, s))
            out += [y[3 + 2 * j], A[1, 0] * y[2 + 2 * j] + A[1, 1] * y[3 + 2 * j] + fp]
        return out

    sol = solve_ivp(rhs, (t0, t1), [x0, v0] + [0.0] * (2 * k), method="DOP853", rtol=_RTOL, atol=_ATOL)
    if sol.status != 0:
        raise FloatingPointError(f"the parameter sensitivity of the power-law piece [{t0!r}, {t1!r}] could not be "
                                 f"integrated: {sol.message}")
    # the homogeneous part: the piece's transition matrix (integrated again: the tangent recorder keeps
    # only the product; a power-law piece is the one place this costs a second integration)
    a, b, c, d = variational_transition(osc, mode, t0, x0, v0, t1)
    forced = sol.y[2:, -1].reshape(k, 2).T
    return np.array([[a, b], [c, d]]) @ rec.sigma + forced
