"""Small oscillations of a hanging chain against the continuous-chain Bessel limit.

Reference: a uniform heavy chain of length L hanging from a fixed point has the linearised
frequencies omega_k = (j_{0,k} / 2) sqrt(g' / L), j_{0,k} the zeros of J_0 (scipy.special) and
g' = g (1 - rho_w / rho_c) the buoyancy-reduced gravity. The discrete model (no joint stiffness,
no load, heave locked) is linearised about the vertical rest state: stiffness = Hessian of the
potential by central differences of ``gravity_vector + elastic_force``, mass = ``mass_matrix``
(itself checked against sympy in test_sympy_dynamics), frequencies from the generalised
eigenproblem K v = omega^2 M v.
"""

from __future__ import annotations

import numpy as np
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
                    joint_springs=False, load_mass=0.0, heave_locked=True, drag_model="none")
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


def test_hanging_chain_frequencies_converge_to_bessel_limit() -> None:
    """Lowest three frequencies: error < 1 % at n = 80, decreasing monotonically over
    n = 10, 20, 40, 80, and at the second-order rate of a consistent discretisation (each
    halving of the link length divides the error by 2^(2 +- 0.5))."""
    ref = bessel_limit()
    errs = np.array([np.abs(discrete_frequencies(n) - ref) / ref for n in NS])
    for n, e in zip(NS, errs, strict=True):
        print(f"n = {n:3d}: relative errors of modes 1-3 = " + ", ".join(f"{x:.3g}" for x in e))
    assert np.all(errs[-1] < 0.01)
    assert np.all(np.diff(errs, axis=0) < 0), "errors do not decrease monotonically with n"
    orders = np.log2(errs[:-1] / errs[1:])
    print("observed orders (per mode, successive n):", np.round(orders, 3).tolist())
    assert np.all((orders > 1.5) & (orders < 2.5))



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
