"""Issue 11, item 4 (dense part): the Morison added-mass generalised force against sympy.

MODEL.md, "Round 2 terms": per unit length the fluid resists the acceleration a(s) of a point of
link i with -A_i a(s), A_i = m_an n_i n_i^T + m_at e_i e_i^T (n_i = (cos th_i, sin th_i),
e_i = (sin th_i, -cos th_i)), m_an = C_an rho_w pi d^2/4, m_at = C_at rho_w pi d^2/4. Here the
point r(s) = p_{i-1} + s e_i is written symbolically, its velocity and acceleration are taken by
the chain rule, and Q_k = int_0^l (dr/dq_k) . (-A a) ds is integrated exactly by sympy, for n = 2,
3, 4 with unequal links, diameters and coefficients. The dense reference's added-mass terms must
give the same generalised force, -(M_a qdd + b_a), at random states (1e-9 of the force scale), and
M_a must be symmetric positive definite on its own when both coefficients are positive.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

RHO_W = 1025.0


def _sympy_force(n: int, lengths, man, mat):
    """Lambdified Q_a(q, qd, qdd) for an n-link line, from MODEL.md's definition."""
    q = sp.symbols(f"q0:{n + 1}", real=True)
    qd = sp.symbols(f"qd0:{n + 1}", real=True)
    qdd = sp.symbols(f"qdd0:{n + 1}", real=True)
    s = sp.symbols("s", real=True)
    Q = [sp.Integer(0)] * (n + 1)
    px, pz = sp.Integer(0), q[0]
    for i in range(n):
        th = q[i + 1]
        e = sp.Matrix([sp.sin(th), -sp.cos(th)])
        nv = sp.Matrix([sp.cos(th), sp.sin(th)])
        r = sp.Matrix([px, pz]) + s * e
        v = sum((r.diff(q[k]) * qd[k] for k in range(n + 1)), sp.zeros(2, 1))
        a = sum((v.diff(q[k]) * qd[k] + v.diff(qd[k]) * qdd[k] for k in range(n + 1)), sp.zeros(2, 1))
        A = sp.nsimplify(man[i]) * nv * nv.T + sp.nsimplify(mat[i]) * e * e.T
        f = -A * a
        for k in range(n + 1):
            Q[k] += sp.integrate(sp.expand((r.diff(q[k]).T * f)[0]), (s, 0, sp.nsimplify(lengths[i])))
        px += sp.nsimplify(lengths[i]) * sp.sin(th)
        pz -= sp.nsimplify(lengths[i]) * sp.cos(th)
    return sp.lambdify((q, qd, qdd), Q, "numpy")


@pytest.mark.parametrize("n", [2, 3, 4])
def test_dense_added_mass_matches_sympy(n: int) -> None:
    rng = np.random.default_rng(100 + n)
    lengths = rng.uniform(0.5, 2.0, n).round(3)
    diam = rng.uniform(0.05, 0.2, n).round(3)
    cn, ct = 1.3, 0.4
    p = CableParams(n_links=n, link_lengths=tuple(lengths), diameter=tuple(diam), water_density=RHO_W,
                    added_mass=True, added_mass_cn=cn, added_mass_ct=ct, drag_model="none")
    model = CableModel.from_params(p)
    area = np.pi * diam**2 / 4
    man, mat = cn * RHO_W * area, ct * RHO_W * area
    Qf = _sympy_force(n, lengths, man, mat)
    worst = 0.0
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, n + 1)
        qd = rng.normal(0, 1.0, n + 1)
        qdd = rng.normal(0, 2.0, n + 1)
        ref = np.array(Qf(q, qd, qdd), dtype=float)
        Ma, ba = dynamics.added_mass_terms(model, q, qd)
        got = -(Ma @ qdd + ba)
        scale = np.max(np.abs(ref))
        worst = max(worst, np.max(np.abs(got - ref)) / scale)
        assert np.allclose(Ma, Ma.T, rtol=0, atol=1e-12 * np.abs(Ma).max())
        assert np.linalg.eigvalsh(Ma).min() > 0
    print(f"n = {n}: max |Q_dense - Q_sympy| / scale = {worst:.2e}")
    assert worst < 1e-9


def test_added_mass_off_is_zero_and_changes_nothing() -> None:
    """Switched off, the added-mass terms vanish and forward dynamics is bit-identical."""
    base = CableParams(n_links=5, drag_model="morison")
    on = base.replace(added_mass=True)
    rng = np.random.default_rng(3)
    q, qd = rng.normal(size=6), rng.normal(size=6)
    Ma, ba = dynamics.added_mass_terms(CableModel.from_params(base), q, qd)
    assert not Ma.any() and not ba.any()
    a0, _ = dynamics.forward_dynamics(CableModel.from_params(base), q, qd)
    a1, _ = dynamics.forward_dynamics(CableModel.from_params(on), q, qd)
    assert np.max(np.abs(a1 - a0)) > 1e-3 * np.max(np.abs(a0))  # the term does act when on
