"""Issue #2: the closed-form dynamics against an independent sympy Euler-Lagrange derivation.

Nothing here reuses the package's formulas. For n = 2..5 links the test writes down the
positions of the platform, of each link centre and of the load from MODEL.md's geometry
(q = [z_m, theta_1..theta_n], theta from the downward vertical, z up), builds

    T = 1/2 M zdot^2 + sum_i (1/2 m_i |c_i'|^2 + 1/2 (m_i l_i^2/12) theta_i'^2) + 1/2 m_c |p_n'|^2
    V = g (sum_i m~_i z(c_i) + m~_c z(p_n))            (reduced masses m~ = m - rho_w * volume)

and obtains by symbolic differentiation M = d2T/dqd2, b = d/dt(dT/dqd) - M qdd - dT/dq,
g = dV/dq. Masses, reduced masses and Morison coefficients are computed here from the raw
parameters (rho_c, d, l_i, rho_w, C_dn, C_dt), not read from the model. Per-link lengths,
diameters and densities differ from link to link so that index mistakes cannot cancel.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from cable_sim.core import dynamics
from cable_sim.core.dynamics import Inputs
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

RTOL = 1e-9
G = 9.81
RHO_W = 1025.0


def _params(n: int, rng: np.random.Generator, **kw) -> CableParams:
    base = dict(
        n_links=n,
        link_lengths=tuple(rng.uniform(0.5, 3.0, n)),
        diameter=tuple(rng.uniform(0.01, 0.1, n)),
        line_density=tuple(rng.uniform(2000.0, 9000.0, n)),
        platform_mass=float(rng.uniform(50.0, 500.0)),
        load_mass=float(rng.uniform(1.0, 30.0)),
        load_volume=float(rng.uniform(0.0, 0.005)),
        water_density=RHO_W,
        gravity=G,
        stiffness_mode="per_joint",
        joint_stiffness=float(rng.uniform(5.0, 50.0)),
        joint_damping=float(rng.uniform(0.5, 5.0)),
        pin_stiffness=float(rng.uniform(5.0, 50.0)),
        pin_damping=float(rng.uniform(0.5, 5.0)),
        heave_stiffness=float(rng.uniform(100.0, 2000.0)),
        heave_damping=float(rng.uniform(10.0, 300.0)),
        drag_model="morison",
        drag_cn=1.3,
        drag_ct=0.05,
        current_speed=0.4,
    )
    base.update(kw)
    return CableParams(**base)


class _Reference:
    """Symbolic Euler-Lagrange model of an n-link cable with numeric parameters."""

    def __init__(self, p: CableParams) -> None:
        n = p.n_links
        self.n = n
        l = [float(x) for x in p.link_lengths]
        d = [float(x) for x in p.diameter]
        rho_c = [float(x) for x in p.line_density]
        area = [np.pi * di**2 / 4.0 for di in d]
        m = [rho_c[i] * area[i] * l[i] for i in range(n)]
        mw = [m[i] - p.water_density * area[i] * l[i] for i in range(n)]
        mc = p.load_mass
        mcw = p.load_mass - p.water_density * p.load_volume
        g = p.gravity

        q = sp.Matrix(sp.symbols(f"q0:{n + 1}", real=True))
        qd = sp.Matrix(sp.symbols(f"qd0:{n + 1}", real=True))
        z, th = q[0], list(q[1:])
        # joint positions p_0..p_n and link centres c_1..c_n
        P = [sp.Matrix([0, z])]
        for i in range(n):
            P.append(P[-1] + sp.Matrix([l[i] * sp.sin(th[i]), -l[i] * sp.cos(th[i])]))
        C = [(P[i] + P[i + 1]) / 2 for i in range(n)]
        vel = lambda r: r.jacobian(q) * qd  # noqa: E731

        T = sp.Rational(1, 2) * p.platform_mass * qd[0] ** 2
        for i in range(n):
            vc = vel(C[i])
            T += sp.Rational(1, 2) * m[i] * (vc.T * vc)[0]
            T += sp.Rational(1, 2) * (m[i] * l[i] ** 2 / 12) * qd[i + 1] ** 2
        vn = vel(P[n])
        T += sp.Rational(1, 2) * mc * (vn.T * vn)[0]
        V = g * (sum(mw[i] * C[i][1] for i in range(n)) + mcw * P[n][1])

        Mmat = sp.hessian(T, qd)
        dTdq = sp.Matrix([sp.diff(T, qi) for qi in q])
        # d/dt (M qd) - M qdd = (d(M qd)/dq) qd
        bvec = (Mmat * qd).jacobian(q) * qd - dTdq
        gvec = sp.Matrix([sp.diff(V, qi) for qi in q])

        # joint springs (theta_0 = 0: joint 1 is the pin against the vertical) and Rayleigh
        k = [p.pin_stiffness] + [p.joint_stiffness] * (n - 1)
        c = [p.pin_damping] + [p.joint_damping] * (n - 1)
        rel = [th[0]] + [th[i] - th[i - 1] for i in range(1, n)]
        relv = [qd[1]] + [qd[i + 1] - qd[i] for i in range(1, n)]
        Vs = sp.Rational(1, 2) * p.heave_stiffness * z**2 + sum(
            sp.Rational(1, 2) * k[i] * rel[i] ** 2 for i in range(n))
        Ray = sp.Rational(1, 2) * p.heave_damping * qd[0] ** 2 + sum(
            sp.Rational(1, 2) * c[i] * relv[i] ** 2 for i in range(n))
        kvec = sp.Matrix([sp.diff(Vs, qi) for qi in q])
        cvec = sp.Matrix([sp.diff(Ray, qi) for qi in qd])

        # Morison drag: centre velocity relative to the current, split along the link axis;
        # the generalised force is the virtual power sum_i F_i . dc_i/dq.
        cn = [0.5 * p.water_density * d[i] * l[i] * p.drag_cn for i in range(n)]
        ct = [0.5 * p.water_density * d[i] * l[i] * np.pi * p.drag_ct for i in range(n)]
        Fs = sp.Matrix(sp.symbols(f"F0:{2 * n}", real=True))  # placeholders for the forces
        Jc = [C[i].jacobian(q) for i in range(n)]
        Qd = sp.zeros(n + 1, 1)
        for i in range(n):
            Qd += Jc[i].T * sp.Matrix([Fs[2 * i], Fs[2 * i + 1]])
        vcs = sp.Matrix.vstack(*[vel(C[i]) for i in range(n)])

        args = (list(q), list(qd))
        self.M = sp.lambdify(args, Mmat, "numpy")
        self.b = sp.lambdify(args, bvec, "numpy")
        self.g = sp.lambdify(args, gvec, "numpy")
        self.k = sp.lambdify(args, kvec, "numpy")
        self.c = sp.lambdify(args, cvec, "numpy")
        self.T = sp.lambdify(args, T, "numpy")
        self.vc = sp.lambdify(args, vcs, "numpy")
        self.Qd = sp.lambdify((list(q), list(Fs)), Qd, "numpy")
        self.cn, self.ct, self.current = cn, ct, p.current_speed

    def morison(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        v = np.asarray(self.vc(q, qd), dtype=float).reshape(self.n, 2)
        F = np.zeros(2 * self.n)
        for i in range(self.n):
            vi = v[i] - np.array([self.current, 0.0])
            e = np.array([np.sin(q[i + 1]), -np.cos(q[i + 1])])
            vt = (vi @ e) * e
            vn = vi - vt
            Fi = -self.cn[i] * np.linalg.norm(vn) * vn - self.ct[i] * np.linalg.norm(vt) * vt
            F[2 * i:2 * i + 2] = Fi
        return np.asarray(self.Qd(q, F), dtype=float).ravel()


def _vec(f, q, qd):
    return np.asarray(f(q, qd), dtype=float).ravel()


def _close(a, b, rtol=RTOL):
    """Relative agreement, scaled by the largest entry (entries can vanish)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(np.max(np.abs(b)), 1e-300)
    err = np.max(np.abs(a - b)) / scale
    assert err <= rtol, f"relative error {err:.3e} > {rtol:g}"
    return err


def _states(n, rng, k=4):
    for _ in range(k):
        q = np.concatenate([[rng.uniform(-3, 3)], rng.uniform(-np.pi, np.pi, n)])
        qd = rng.uniform(-2.0, 2.0, n + 1)
        yield q, qd


@pytest.fixture(scope="module", params=[2, 3, 4, 5])
def case(request):
    n = request.param
    rng = np.random.default_rng(1000 + n)
    p = _params(n, rng)
    return n, p, CableModel.from_params(p), _Reference(p), rng


def test_mass_matrix(case):
    n, _, model, ref, rng = case
    for q, qd in _states(n, rng):
        Mr = np.asarray(ref.M(q, qd), dtype=float)
        _close(dynamics.mass_matrix(model, q), Mr)
        # and the kinetic energy 1/2 qd^T M qd
        assert abs(dynamics.kinetic_energy(model, q, qd) - ref.T(q, qd)) <= RTOL * abs(ref.T(q, qd))


def test_velocity_product(case):
    n, _, model, ref, rng = case
    for q, qd in _states(n, rng):
        _close(dynamics.velocity_product(model, q, qd), _vec(ref.b, q, qd))


def test_gravity_vector(case):
    n, _, model, ref, rng = case
    for q, qd in _states(n, rng):
        _close(dynamics.gravity_vector(model, q), _vec(ref.g, q, qd))


def test_joint_springs_and_dampers(case):
    n, _, model, ref, rng = case
    for q, qd in _states(n, rng):
        _close(dynamics.elastic_force(model, q), _vec(ref.k, q, qd))
        _close(dynamics.damping_force(model, qd), _vec(ref.c, q, qd))


def test_morison_generalised_force(case):
    n, _, model, ref, rng = case
    for q, qd in _states(n, rng):
        _close(dynamics.drag_force(model, q, qd), ref.morison(q, qd))


def test_forward_dynamics_dense_and_fast(case):
    """Both kernels' accelerations solve the sympy equations of motion (free end, every term on,
    a heave force and a wave elevation)."""
    from cable_sim.core import kernel as fast

    n, p, model, ref, rng = case
    inp = Inputs(heave_force=123.0, wave_elevation=0.37)
    for q, qd in _states(n, rng, k=3):
        Q = -_vec(ref.b, q, qd) - _vec(ref.g, q, qd) - _vec(ref.k, q, qd) - _vec(ref.c, q, qd)
        Q += ref.morison(q, qd)
        Q[0] += 123.0 + p.heave_stiffness * 0.37
        qdd_ref = np.linalg.solve(np.asarray(ref.M(q, qd), dtype=float), Q)
        for fwd in (dynamics.forward_dynamics, fast.forward_dynamics):
            qdd, _ = fwd(model, q, qd, inp)
            _close(qdd, qdd_ref, 1e-8)
