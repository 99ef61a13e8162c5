"""Issue 11, item 5: hanging chain with transverse added mass against the Bessel limit.

A uniform chain hanging from a fixed point (no joint stiffness, no load, heave locked) with
Morison added mass m_an = C_an rho_w pi d^2/4 per length (C_at = 0) swings in the modes of the
classical hanging chain with the transverse inertia m + m_an per length and the restoring wet
weight w: omega_k = (j_{0,k}/2) sqrt(g_eff / L), g_eff = w / (m + m_an) (computed here from the
parameters). The discrete model is linearised at theta = 0: K from central differences of the
restoring force (gravity_vector), M the theta-block of mass_matrix + the added-mass matrix.
The lowest three frequencies must be within 0.5 % at n = 80 and differ from the no-added-mass
Bessel values by far more (the term really acts).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh
from scipy.special import jn_zeros

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

L, D, RHO_C, RHO_W, G, CAN = 240.0, 0.05, 7850.0, 1025.0, 9.81, 1.0


def _frequencies(n: int) -> np.ndarray:
    p = CableParams(n_links=n, total_length=L, diameter=D, line_density=RHO_C, water_density=RHO_W,
                    gravity=G, joint_springs=False, pin_stiffness=0.0, load_mass=0.0,
                    heave_locked=True, drag_model="none", added_mass=True, added_mass_cn=CAN,
                    added_mass_ct=0.0)
    model = CableModel.from_params(p)
    q0 = np.zeros(n + 1)
    h = 1e-6
    K = np.empty((n, n))
    for j in range(n):
        dq = np.zeros(n + 1)
        dq[j + 1] = h
        K[:, j] = (dynamics.gravity_vector(model, q0 + dq)[1:]
                   - dynamics.gravity_vector(model, q0 - dq)[1:]) / (2 * h)
    K = 0.5 * (K + K.T)
    M = (dynamics.mass_matrix(model, q0) + dynamics.added_mass_terms(model, q0, q0)[0])[1:, 1:]
    return np.sqrt(np.sort(eigh(K, M, eigvals_only=True))[:3])


def test_hanging_chain_with_added_mass_matches_bessel() -> None:
    area = np.pi * D**2 / 4
    m, ma = RHO_C * area, CAN * RHO_W * area
    w = (RHO_C - RHO_W) * area * G
    ref = jn_zeros(0, 3) / 2 * np.sqrt(w / (m + ma) / L)
    no_am = jn_zeros(0, 3) / 2 * np.sqrt(w / m / L)
    for n in (20, 40, 80):
        err = np.abs(_frequencies(n) - ref) / ref
        print(f"n = {n}: relative errors of omega_1..3 = " + ", ".join(f"{e:.4%}" for e in err))
    assert np.all(err < 0.005), err
    assert np.all(np.abs(no_am - ref) / ref > 0.05)
