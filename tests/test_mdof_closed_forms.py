"""Closed forms for the exact n-DOF backend: forced modal response, free decay, a periodic impact orbit.

Each reference is derived here from the equations of motion (modal analysis, or the matrix
exponential of scipy for the orbit), independently of the backend's eigen-decomposition.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh, expm

from impactosc import MechanicalSystem, simulate_mechanical
from impactosc.model import Contact


def _two_mass(m1=1.0, m2=0.5, k1=2.0, k2=1.0):
    M = np.diag([m1, m2])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    return M, K


def test_two_mass_forced_response_is_the_sum_of_modal_amplitudes():
    """Undamped, forced at omega off resonance, started on the steady state: q(t) = X cos(omega t + phi).

    Modal analysis with mass-normalised modes ``phi_r`` (``K phi = w_r^2 M phi``):
    ``X = sum_r phi_r (phi_r . f) / (w_r^2 - omega^2)``.
    """
    M, K = _two_mass()
    f = np.array([0.7, -0.2])
    omega, phase = 1.3, 0.4
    w2, Phi = eigh(K, M)  # Phi^T M Phi = I
    X = sum(Phi[:, r] * (Phi[:, r] @ f) / (w2[r] - omega**2) for r in range(2))
    system = MechanicalSystem(M=M, K=K, harmonics=[(f, omega, phase)])
    q0, v0 = X * np.cos(phase), -omega * X * np.sin(phase)
    sol = simulate_mechanical(system, 30.0, q0, v0)
    assert sol.status == 0 and len(sol.events) == 0
    t = np.linspace(0.0, 30.0, 301)
    q, v = sol.sample(t)
    np.testing.assert_allclose(q, np.outer(np.cos(omega * t + phase), X), rtol=0, atol=1e-12 * np.abs(X).max())
    np.testing.assert_allclose(v, -omega * np.outer(np.sin(omega * t + phase), X), rtol=0,
                               atol=1e-12 * omega * np.abs(X).max())


def test_two_mass_forced_response_with_gyroscopic_damping_is_the_complex_amplitude():
    """With damping and a skew (gyroscopic) part the steady state is ``Re(X e^{i omega t})``,
    ``(K - w^2 M + i w C) X = f``."""
    M, K = _two_mass()
    C = np.array([[0.05, 0.3], [-0.3, 0.02]])
    f = np.array([0.3, 1.0])
    omega = 0.8
    X = np.linalg.solve(K - omega**2 * M + 1j * omega * C, f)
    system = MechanicalSystem(M=M, C=C, K=K, harmonics=[(f, omega, 0.0)])
    sol = simulate_mechanical(system, 20.0, X.real, (1j * omega * X).real)
    t = np.linspace(0.0, 20.0, 81)
    q, _ = sol.sample(t)
    np.testing.assert_allclose(q, (np.exp(1j * omega * t)[:, None] * X).real, rtol=0, atol=1e-12 * np.abs(X).max())


@pytest.mark.parametrize("n", [2, 3, 6])
def test_free_decay_of_a_damped_n_dof_system(n):
    """Rayleigh damping ``C = a M + b K``: every mode decays on its own,
    ``eta_r = e^{-z w t} (eta0 cos(wd t) + (deta0 + z w eta0) / wd sin(wd t))``."""
    rng = np.random.default_rng(n)
    A = rng.normal(size=(n, n))
    M = A @ A.T / n + np.eye(n)
    B = rng.normal(size=(n, n))
    K = B @ B.T + np.eye(n)
    a, b = 0.05, 0.01
    C = a * M + b * K
    w2, Phi = eigh(K, M)
    w = np.sqrt(w2)
    zeta = (a / w + b * w) / 2.0
    assert np.all(zeta < 1.0)
    wd = w * np.sqrt(1.0 - zeta**2)
    q0, v0 = rng.normal(size=n), rng.normal(size=n)
    eta0, deta0 = Phi.T @ M @ q0, Phi.T @ M @ v0
    t = np.linspace(0.0, 15.0, 61)[:, None]
    eta = np.exp(-zeta * w * t) * (eta0 * np.cos(wd * t) + (deta0 + zeta * w * eta0) / wd * np.sin(wd * t))
    sol = simulate_mechanical(MechanicalSystem(M=M, C=C, K=K), 15.0, q0, v0)
    q, _ = sol.sample(t[:, 0])
    scale = np.abs(q0).max() + np.abs(v0).max()
    np.testing.assert_allclose(q, eta @ Phi.T, rtol=0, atol=1e-12 * scale)
    energy = sol.energy_balance()
    assert energy["work"] == 0.0
    assert energy["relative"] < 1e-9
    assert energy["damping"] > 0.0


def _periodic_impact_orbit(M, C, K, f, omega, nrm, gap, e):
    """The orbit with one impact per forcing period ``T`` on the stop ``n . q = gap``, at ``t = 0``.

    Between impacts the flow is linear: ``y(T) = e^{AT} y+ + (I - e^{AT}) y_p(0)``, with the
    periodic particular solution ``y_p(t) = Re(Y e^{i(omega t + phi)})``,
    ``Y = (i omega - A)^-1 (0, M^-1 f)``. The impact is the linear reset ``J`` (``q`` kept,
    ``v -> v - (1 + e) (n.v) M^-1 n / (n.M^-1 n)``). Periodicity ``y+ = J y(T)`` gives
    ``y+ = (I - J e^{AT})^-1 J (I - e^{AT}) Re(Y e^{i phi})``, linear in ``(cos phi, sin phi)``;
    the impact condition ``n . q+ = gap`` is then ``alpha cos phi + beta sin phi = gap``.
    """
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    T = 2 * np.pi / omega
    E = expm(A * T)
    Y = np.linalg.solve(1j * omega * np.eye(2 * n) - A, np.concatenate([np.zeros(n), Minv @ f]))
    mn = Minv @ nrm
    J = np.eye(2 * n)
    J[n:, n:] -= (1 + e) * np.outer(mn, nrm) / (nrm @ mn)
    G = np.linalg.solve(np.eye(2 * n) - J @ E, J @ (np.eye(2 * n) - E))
    yc, ys = G @ Y.real, G @ (-Y.imag)  # y+ = yc cos(phi) + ys sin(phi)
    alpha, beta = nrm @ yc[:n], nrm @ ys[:n]
    amp = np.hypot(alpha, beta)
    assert amp > gap
    phi = np.arctan2(beta, alpha) - np.arccos(gap / amp)  # one of the two roots
    return yc * np.cos(phi) + ys * np.sin(phi), phi, T


def test_single_impact_periodic_orbit_of_a_two_mass_system():
    M, K = _two_mass()
    C = 0.1 * K
    f = np.array([0.0, 1.0])
    omega, e, gap = 1.2, 0.5, 0.5
    nrm = np.array([0.0, 1.0])
    y_plus, phi, T = _periodic_impact_orbit(M, C, K, f, omega, nrm, gap, e)
    # Admissible: the orbit stays off the stop between the impacts (sampled on the matrix exponential).
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ C]])
    Y = np.linalg.solve(1j * omega * np.eye(4) - A, np.concatenate([np.zeros(2), Minv @ f]))
    y_p = [(Y * np.exp(1j * (omega * t + phi))).real for t in np.linspace(0.0, T, 201)]
    between = [nrm @ (expm(A * t) @ (y_plus - y_p[0]) + y_p[i])[:2] - gap
               for i, t in enumerate(np.linspace(0.0, T, 201))][1:-1]
    assert max(between) < -1e-3
    system = MechanicalSystem(M=M, C=C, K=K, harmonics=[(f, omega, phi)],
                              contacts=[Contact(nrm, gap, law="rigid", restitution=e)])
    # The orbit leaves the stop after the impact (n . v+ < 0) and meets it at T with n . v- > 0.
    assert nrm @ y_plus[2:] < 0
    periods = 6
    sol = simulate_mechanical(system, periods * T - 1e-9, y_plus[:2], y_plus[2:])
    ev = sol.events
    assert list(ev.kind) == ["impact"] * (periods - 1)
    np.testing.assert_allclose(ev.t, T * np.arange(1, periods), rtol=0, atol=1e-9)
    for row in ev:
        np.testing.assert_allclose(np.concatenate([row.q, row.v]), y_plus, rtol=0, atol=1e-8)
    assert sol.energy_balance()["relative"] < 1e-9
