"""Small oscillations of a hanging chain against the continuous-chain Bessel limit: the one home
of this reference (merged from test_hanging_chain and test_verify_chain_modes, issue 10).

Reference: a uniform heavy chain of length L hanging from a fixed point has the linearised
frequencies omega_k = (j_{0,k} / 2) sqrt(g' / L), j_{0,k} the zeros of J_0 (scipy.special) and
g' = g (1 - rho_w / rho_c) the buoyancy-reduced gravity. The discrete model (no joint stiffness,
no load, heave locked) is linearised about the vertical rest state: stiffness = Hessian of the
potential by central differences of ``gravity_vector + elastic_force``, mass = ``mass_matrix``
(itself checked against sympy in test_sympy_lagrange), frequencies from the generalised
eigenproblem K v = omega^2 M v. The frequencies for n = 10..80 are computed once per module.
Buoyancy must enter the weight, not the inertia: the same chain without buoyancy follows g.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RefLine
from scipy.integrate import solve_ivp
from scipy.linalg import eigh
from scipy.optimize import brentq
from scipy.special import jn_zeros

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

L, G, RHO_W, RHO_C = 240.0, 9.81, 1025.0, 7850.0
NS = (10, 20, 40, 80)


def discrete_frequencies(n: int, n_modes: int = 3) -> np.ndarray:
    """Lowest linearised frequencies [rad/s] of the n-link chain about the vertical."""
    p = CableParams(n_links=n, total_length=L, gravity=G, water_density=RHO_W, line_density=RHO_C,
                    joint_springs=False, pin_stiffness=0.0, load_mass=0.0, heave_locked=True,
                    drag_model="none")
    model = CableModel.from_params(p)
    q0 = np.zeros(n + 1)

    def force(q: np.ndarray) -> np.ndarray:
        return dynamics.gravity_vector(model, q) + dynamics.elastic_force(model, q)

    assert np.max(np.abs(force(q0)[1:])) < 1e-12  # the vertical line is at rest
    h = 1e-6
    K = np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n + 1)
        e[1 + j] = h
        K[:, j] = (force(q0 + e) - force(q0 - e))[1:] / (2 * h)
    M = dynamics.mass_matrix(model, q0)[1:, 1:]
    w2 = eigh(0.5 * (K + K.T), M, eigvals_only=True)
    assert np.all(w2 > 0)
    return np.sqrt(w2[:n_modes])


def bessel_limit(n_modes: int = 3) -> np.ndarray:
    """omega_k = j_{0,k}/2 sqrt(g'/L) of the continuous submerged chain."""
    g_red = G * (1.0 - RHO_W / RHO_C)
    return jn_zeros(0, n_modes) / 2.0 * np.sqrt(g_red / L)


@pytest.fixture(scope="module")
def errors() -> dict[int, np.ndarray]:
    """Relative errors of the lowest three discrete frequencies against the Bessel limit."""
    ref = bessel_limit()
    errs = {n: np.abs(discrete_frequencies(n) - ref) / ref for n in NS}
    for n in NS:
        print(f"n = {n:3d}: relative errors of modes 1-3 = " + ", ".join(f"{x:.3g}" for x in errs[n]))
    print("Bessel omega_1..3 [rad/s] =", ", ".join(f"{w:.6f}" for w in ref))
    return errs


def test_lowest_three_within_one_percent_at_n80(errors: dict[int, np.ndarray]) -> None:
    """Lowest three frequencies within 1 % of the Bessel limit at n = 80."""
    assert np.all(errors[80] < 0.01), errors[80]


def test_error_decreases_monotonically_with_n(errors: dict[int, np.ndarray]) -> None:
    """Each mode's error shrinks monotonically over n = 10, 20, 40, 80."""
    errs = np.array([errors[n] for n in NS])
    assert np.all(np.diff(errs, axis=0) < 0), "errors do not decrease monotonically with n"


def test_error_is_second_order_in_link_length(errors: dict[int, np.ndarray]) -> None:
    """Halving l divides the error by 3.5..4.5 (rigid-link discretisation of a string is O(l^2));
    so the observed order log2 of that ratio is within 1.5..2.5 as well."""
    for k in range(3):
        for a, b in zip(NS[:-1], NS[1:], strict=True):
            ratio = errors[a][k] / errors[b][k]
            assert 3.5 < ratio < 4.5, (k + 1, a, b, ratio)
            assert 1.5 < np.log2(ratio) < 2.5


def test_buoyancy_enters_weight_not_inertia() -> None:
    """Without buoyancy the same chain must follow g, not g' (n = 80, stiffness from the gravity
    vector at a small angle): within 1 % of the dry Bessel values, > 5 % from the submerged ones."""
    n = 80
    p = CableParams(n_links=n, total_length=L, joint_springs=False, pin_stiffness=0.0,
                    load_mass=0.0, heave_locked=True, drag_model="none", buoyancy=False)
    model = CableModel.from_params(p)
    K = np.diag(dynamics.gravity_vector(model, np.full(n + 1, 1e-7))[1:] / 1e-7)
    M = dynamics.mass_matrix(model, np.zeros(n + 1))[1:, 1:]
    w = np.sqrt(np.sort(eigh(K, M, eigvals_only=True))[:3])
    ref = jn_zeros(0, 3) / 2.0 * np.sqrt(G / L)
    assert np.all(np.abs(w - ref) / ref < 0.01)
    assert np.all(np.abs(w - bessel_limit()) / bessel_limit() > 0.05)


def test_time_domain_period_matches_linearisation() -> None:
    """The integrated motion (forward_dynamics + DOP853) started in the first mode at 1 mrad
    oscillates at the linearised first frequency (to 1e-4; the amplitude's nonlinear shift is
    ~1e-7) and within 1 % of the Bessel limit, at n = 20. The mode shape comes from the analytic
    stiffness diag(g mu~_i l_i) with mu~_i from the parameters (conftest.RefLine)."""
    n = 20
    p = CableParams(n_links=n, total_length=L, gravity=G, water_density=RHO_W, line_density=RHO_C,
                    joint_springs=False, load_mass=0.0, heave_locked=True, drag_model="none")
    model = CableModel.from_params(p)
    ref = RefLine(p)
    mu_w = ref.mw / 2 + (np.cumsum(ref.mw[::-1])[::-1] - ref.mw) + ref.mcw
    q0 = np.zeros(n + 1)
    w2, V = eigh(np.diag(G * mu_w * ref.l), dynamics.mass_matrix(model, q0)[1:, 1:])
    w1 = np.sqrt(w2[0])
    assert abs(w1 / discrete_frequencies(n, 1)[0] - 1) < 1e-8  # analytic vs finite-difference K

    def f(t: float, y: np.ndarray) -> np.ndarray:
        qdd, _ = dynamics.forward_dynamics(model, y[: n + 1], y[n + 1:])
        return np.concatenate([y[n + 1:], qdd])

    y0 = np.concatenate([[0.0], V[:, 0] / np.max(np.abs(V[:, 0])) * 1e-3, np.zeros(n + 1)])
    period = 2 * np.pi / w1
    sol = solve_ivp(f, (0, 2.2 * period), y0, method="DOP853", rtol=1e-11, atol=1e-14,
                    dense_output=True)

    def tip(t: float) -> float:
        return sol.sol(t)[n]

    # the tip angle crosses zero at T/4, 3T/4, 5T/4, 7T/4
    cross = [brentq(tip, (k / 4 - 0.1) * period, (k / 4 + 0.1) * period, xtol=1e-12)
             for k in (1, 3, 5, 7)]
    w_meas = 2 * np.pi / ((cross[-1] - cross[0]) / 1.5)
    print(f"n = {n}: time-domain omega_1 = {w_meas:.8f}, linearised {w1:.8f}, "
          f"Bessel {bessel_limit(1)[0]:.8f}")
    assert abs(w_meas / w1 - 1) < 1e-4
    assert abs(w_meas / bessel_limit(1)[0] - 1) < 0.01
