"""Issue 11, item 4 (contact part): the compiled per-link seabed force and its O(n) generalised
force equal the dense reference at random states (1e-9 of the force scale), with the bed's
damping and friction on; and the dense reference's contact integral is exact: it equals a fine
midpoint quadrature of the per-length law written here from MODEL.md (f_z = max(0, k delta - c
zdot) where delta > 0; friction -mu f_z sat(v / v_c) on the horizontal axial and transverse slip).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cable_sim.core import dynamics
from cable_sim.core.kernel.contact import generalised_from_links_nb, seabed_energy, seabed_links_nb
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

ZB = -20.0


def _model(n: int) -> CableModel:
    return CableModel.from_params(CableParams(
        n_links=n, total_length=40.0, diameter=0.1, mass_per_length=50.0, heave_locked=False,
        seabed=True, seabed_depth=ZB, seabed_stiffness=3.0e4, seabed_damping=2.0e3,
        seabed_friction_axial=0.4, seabed_friction_transverse=0.9, seabed_friction_speed=0.05))


def _state(m: CableModel, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A V-shaped line (down at ~69 degrees from the vertical, then up) whose dip (~7 m below the
    fairlead) reaches the bed in most states, with random angle noise and velocities."""
    th = np.where(np.arange(m.n) < m.n // 2, 1.2, 1.9) + rng.normal(0.0, 0.15, m.n)
    q = np.concatenate([[ZB + rng.uniform(4.0, 9.0)], th])
    qd = rng.normal(0.0, 0.3, m.ndof)
    return q, qd


def _quadrature(m: CableModel, q: np.ndarray, qd: np.ndarray, N: int = 40000) -> np.ndarray:
    """Q = sum_i int J(s)^T f(s) ds by the midpoint rule on N points per link."""
    Q = np.zeros(m.ndof)
    px, pz, vx, vz = 0.0, q[0], 0.0, qd[0]
    Jx, Jz = np.zeros(m.ndof), np.zeros(m.ndof)  # d p_{i-1} / d q
    Jz[0] = 1.0
    for i in range(m.n):
        th, w, l = q[i + 1], qd[i + 1], m.length[i]
        c, s = math.cos(th), math.sin(th)
        ss = (np.arange(N) + 0.5) * l / N
        z = pz - ss * c
        zd = vz + ss * w * s
        xd = vx + ss * w * c
        delta = ZB - z
        fz = np.where(delta > 0, np.maximum(0.0, m.seabed_k[i] * delta - m.seabed_c[i] * zd), 0.0)
        ua = vx * s - vz * c  # axial slip (uniform along the link); horizontal parts:
        va = ua * s
        vt = xd - va
        vc = m.friction_speed
        fx = -fz * (m.friction_axial[i] * np.clip(va / vc, -1, 1)
                    + m.friction_transverse[i] * np.clip(vt / vc, -1, 1))
        ds = l / N
        # J(s) = J_p + s t_i in column i
        Q += Jx * np.sum(fx) * ds + Jz * np.sum(fz) * ds
        Q[i + 1] += (c * np.sum(ss * fx) + s * np.sum(ss * fz)) * ds
        Jx[i + 1] += l * c
        Jz[i + 1] += l * s
        px += l * s
        pz -= l * c
        vx += l * c * w
        vz += l * s * w
    return Q


@pytest.mark.parametrize("n", [4, 8, 30])
def test_compiled_contact_equals_dense(n: int) -> None:
    rng = np.random.default_rng(n)
    m = _model(n)
    worst, touched = 0.0, 0
    for _ in range(20):
        q, qd = _state(m, rng)
        F, S, pot, sp = dynamics.seabed_link_forces(m, q, qd)
        Fc, Sc = np.zeros((n, 2)), np.zeros((n, 2))
        cth, sth = np.cos(q[1:]), np.sin(q[1:])
        pot_c, sp_c = seabed_links_nb(m.length, m.seabed_z, m.seabed_k, m.seabed_c, m.friction_axial,
                                      m.friction_transverse, m.friction_speed, q, qd, cth, sth, Fc, Sc)
        # the energy alone (the energy check's pass, no forces) against the dense potential
        pot_e = seabed_energy(m.length, m.seabed_z, m.seabed_k, q[0], cth, sth)
        Qc = np.zeros(n + 1)
        generalised_from_links_nb(m.length, q, Fc, Sc, Qc)
        Q = dynamics.seabed_force(m, q, qd)
        scale = max(np.abs(Q).max(), 1.0)
        touched += bool(np.abs(F).max() > 0)
        worst = max(worst, np.abs(Qc - Q).max() / scale, np.abs(Fc - F).max() / max(np.abs(F).max(), 1),
                    abs(pot_c - pot) / max(abs(pot), 1.0), abs(sp_c - sp) / max(abs(sp), 1.0),
                    abs(pot_e - pot) / max(abs(pot), 1.0))
    print(f"n = {n}: {touched}/20 states touch the bed, max relative difference {worst:.2e}")
    assert touched >= 10
    assert worst < 1e-9


def test_dense_contact_integral_is_exact() -> None:
    """Exact piecewise integration = a fine quadrature (O(1/N^2) error plus kinks: 1e-6)."""
    rng = np.random.default_rng(7)
    m = _model(4)
    for _ in range(5):
        q, qd = _state(m, rng)
        Q = dynamics.seabed_force(m, q, qd)
        ref = _quadrature(m, q, qd)
        err = np.abs(Q - ref).max() / max(np.abs(ref).max(), 1.0)
        print(f"|Q_exact - Q_quadrature| / scale = {err:.2e} (scale {np.abs(ref).max():.3g})")
        assert err < 1e-6
