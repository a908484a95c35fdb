"""Random linear mechanical systems for the tests of the exact n-DOF backend."""

from __future__ import annotations

import numpy as np

from impactosc.model import Contact, Friction, MechanicalSystem


def random_system(seed: int, n: int, *, laws=("spring", "rigid"), friction: int = 1, damping: float = 0.05,
                  gyroscopic: float = 0.2, contacts: int = 2, restitution=(0.6, 1.0),
                  orthogonal: bool = False) -> MechanicalSystem:
    """A random system: SPD mass and stiffness, damping with a skew part, 1-2 harmonics, contacts, friction.

    With ``orthogonal``, rigid stops that can rest (``e < 1``) get normals orthogonal in the
    ``M^-1`` metric to the friction coordinates and to one another (Gram-Schmidt): their
    stick and lift-off tests decouple. Otherwise they couple through ``M^-1``.
    """
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    M = A @ A.T / n + np.eye(n)
    B = rng.normal(size=(n, n))
    K = B @ B.T / n + 0.5 * np.eye(n)
    S = rng.normal(size=(n, n))
    C = damping * (S @ S.T / n + 0.2 * np.eye(n)) + gyroscopic * (S - S.T) / 2
    harmonics = [(rng.normal(size=n), rng.uniform(0.3, 2.0), rng.uniform(0, 2 * np.pi))
                 for _ in range(rng.integers(1, 3))]
    Minv = np.linalg.inv(M)
    fr = [Friction(int(j), rng.uniform(0.02, 0.2), None) for j in rng.choice(n, size=friction, replace=False)]
    taken = []
    for f in fr:
        e = np.zeros(n)
        e[f.coordinate] = 1.0
        taken.append(e)
    out = []
    for c in range(contacts):
        law = laws[c % len(laws)]
        u = rng.normal(size=n)
        u /= np.linalg.norm(u)
        gap = rng.uniform(0.3, 0.8)
        if law == "rigid":
            e = float(rng.uniform(*restitution))
            if e < 1.0 and orthogonal:
                for g in taken:
                    u = u - (g @ Minv @ u) / (g @ Minv @ g) * g
                u /= np.linalg.norm(u)
                taken.append(u)
            out.append(Contact(u, gap, law="rigid", restitution=e))
        else:
            out.append(Contact(u, gap, law="spring", stiffness=float(rng.uniform(10, 300))))
    return MechanicalSystem(M=M, C=C, K=K, harmonics=harmonics, contacts=out, friction=fr)


def initial_state(seed: int, n: int):
    rng = np.random.default_rng(seed + 1000)
    return np.zeros(n), rng.normal(size=n)
