"""Issue #2: small oscillations of a hanging chain against the continuous (Bessel) limit.

A uniform chain hanging from a fixed point (no joint stiffness, no load, heave locked) swings
in the modes of the classical hanging chain: omega_k = (j_{0,k} / 2) sqrt(g' / L), j_{0,k} the
zeros of J0 and g' = g (1 - rho_w / rho_c) the buoyancy-reduced gravity (buoyancy reduces the
weight, not the inertia).

The discrete model is linearised at theta = 0: the stiffness K is the Hessian of the
potential, taken by central finite differences of the restoring force
``gravity_vector + elastic_force`` (the package's analytic Hessian is not used), M the
theta-block of ``mass_matrix``; K v = omega^2 M v. The three lowest frequencies must be
within 1 % of the Bessel values at n = 80, and the error must shrink monotonically as n
doubles from 10 to 80.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.special import jn_zeros

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

L = 240.0
RHO_C = 7850.0
RHO_W = 1025.0
G = 9.81
NS = (10, 20, 40, 80)


def _frequencies(n: int, k: int = 3) -> np.ndarray:
    p = CableParams(n_links=n, total_length=L, line_density=RHO_C, water_density=RHO_W,
                    gravity=G, joint_springs=False, pin_stiffness=0.0, load_mass=0.0,
                    heave_locked=True, drag_model="none")
    model = CableModel.from_params(p)
    q0 = np.zeros(n + 1)

    def force(q):
        return dynamics.gravity_vector(model, q) + dynamics.elastic_force(model, q)

    h = 1e-6
    K = np.empty((n, n))
    for j in range(n):
        dq = np.zeros(n + 1)
        dq[j + 1] = h
        K[:, j] = (force(q0 + dq)[1:] - force(q0 - dq)[1:]) / (2 * h)
    K = 0.5 * (K + K.T)
    M = dynamics.mass_matrix(model, q0)[1:, 1:]
    w2 = eigh(K, M, eigvals_only=True)
    assert np.all(w2 > 0)
    return np.sqrt(np.sort(w2)[:k])


def _bessel(k: int = 3) -> np.ndarray:
    g_red = G * (1.0 - RHO_W / RHO_C)
    return jn_zeros(0, k) / 2.0 * np.sqrt(g_red / L)


@pytest.fixture(scope="module")
def errors():
    ref = _bessel()
    errs = {n: np.abs(_frequencies(n) - ref) / ref for n in NS}
    for n in NS:
        print(f"n = {n:3d}: relative errors of omega_1..3 = "
              + ", ".join(f"{e:.4%}" for e in errs[n]))
    print("Bessel omega_1..3 [rad/s] =", ", ".join(f"{w:.6f}" for w in ref))
    return errs


def test_lowest_three_within_one_percent_at_n80(errors):
    assert np.all(errors[80] < 0.01), errors[80]


def test_error_decreases_monotonically_with_n(errors):
    for k in range(3):
        seq = [errors[n][k] for n in NS]
        assert all(b < a for a, b in zip(seq[:-1], seq[1:], strict=True)), (k + 1, seq)


def test_buoyancy_enters_weight_not_inertia():
    """Without buoyancy the same chain must follow g, not g'; this distinguishes the two."""
    n = 80
    p = CableParams(n_links=n, total_length=L, joint_springs=False, pin_stiffness=0.0,
                    load_mass=0.0, heave_locked=True, drag_model="none", buoyancy=False)
    model = CableModel.from_params(p)
    K = np.diag(dynamics.gravity_vector(model, np.full(n + 1, 1e-7))[1:] / 1e-7)
    M = dynamics.mass_matrix(model, np.zeros(n + 1))[1:, 1:]
    w = np.sqrt(np.sort(eigh(K, M, eigvals_only=True))[:3])
    ref = jn_zeros(0, 3) / 2.0 * np.sqrt(G / L)
    assert np.all(np.abs(w - ref) / ref < 0.01)
    assert np.all(np.abs(w - _bessel()) / _bessel() > 0.05)


def test_error_is_second_order_in_link_length(errors):
    """Halving l divides the error by ~4 (rigid-link discretisation of a string is O(l^2))."""
    for k in range(3):
        for a, b in zip(NS[:-1], NS[1:], strict=True):
            ratio = errors[a][k] / errors[b][k]
            assert 3.5 < ratio < 4.5, (k + 1, a, b, ratio)
