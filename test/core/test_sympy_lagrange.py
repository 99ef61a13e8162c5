"""The dynamics against an independent symbolic Euler-Lagrange derivation (sympy): the one home
of this reference (merged from test_sympy_dynamics and test_verify_sympy, issue 10).

Reference: inside this file, the positions of the platform, of every link centre and of the
terminal load are written in sympy, the kinetic energy T (translation + spin m l^2/12 of each
rod) and the potential energy V (wet weights at the centres and the load) are formed, and the
Lagrange equations give M = d^2T/dqd^2, b = (d/dq dT/dqd) qd - dT/dq and g = dV/dq. Spring
forces come from the gradient of the spring energy, damper forces from the gradient of the
Rayleigh function, Morison drag from F_i at each centre mapped by the sympy Jacobian dc_i/dq
(virtual work), never through ``dynamics.drag_force``'s reverse cumulative sums. The numeric
link constants (m_i, m~_i, k_i, ...) come from the parameters via ``conftest.RefLine``, not from
``CableModel``. Agreement is required to 1e-9 relative for n = 2..5 at random states, with
unequal per-link lengths, diameters and densities. The accelerations of both kernels (dense
reference and compiled O(n)) must solve the sympy equations of motion (residual to 1e-9) and
equal their solution M^-1 Q (to 1e-8 of the largest entry).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import sympy as sp
from conftest import RefLine

from cable_sim.core import dynamics
from cable_sim.core.dynamics import Inputs
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

RTOL = 1e-9


@functools.cache
def derive(n: int):
    """Euler-Lagrange derivation for n links; returns lambdified M, b, g, T, V, centre Jacobians."""
    q = sp.symbols(f"q0:{n + 1}")
    qd = sp.symbols(f"qd0:{n + 1}")
    l = sp.symbols(f"l1:{n + 1}", positive=True)
    m = sp.symbols(f"m1:{n + 1}", positive=True)
    mw = sp.symbols(f"mw1:{n + 1}")
    Mp, mc, mcw, g = sp.symbols("Mp mc mcw g")
    z, th = q[0], q[1:]
    # joints p_0..p_n and centres c_i = (p_{i-1} + p_i)/2
    px, pz = [sp.Integer(0)], [z]
    for i in range(n):
        px.append(px[-1] + l[i] * sp.sin(th[i]))
        pz.append(pz[-1] - l[i] * sp.cos(th[i]))
    cx = [(px[i] + px[i + 1]) / 2 for i in range(n)]
    cz = [(pz[i] + pz[i + 1]) / 2 for i in range(n)]
    qv, qdv = sp.Matrix(q), sp.Matrix(qd)

    def vel(expr):
        return (sp.Matrix([expr]).jacobian(qv) * qdv)[0]

    T = Mp * qd[0] ** 2 / 2
    for i in range(n):
        T += m[i] * (vel(cx[i]) ** 2 + vel(cz[i]) ** 2) / 2 + m[i] * l[i] ** 2 / 12 * qd[1 + i] ** 2 / 2
    T += mc * (vel(px[n]) ** 2 + vel(pz[n]) ** 2) / 2
    V = sum(mw[i] * g * cz[i] for i in range(n)) + mcw * g * pz[n]
    p = sp.Matrix([T]).jacobian(qdv).T  # generalised momenta dT/dqd
    Mmat = p.jacobian(qdv)
    bvec = p.jacobian(qv) * qdv - sp.Matrix([T]).jacobian(qv).T
    gvec = sp.Matrix([V]).jacobian(qv).T
    Jc = [sp.Matrix([cx[i], cz[i]]).jacobian(qv) for i in range(n)]
    par = (l, m, mw, Mp, mc, mcw, g)
    lam = functools.partial(sp.lambdify, modules="numpy", cse=True)
    return {
        "M": lam((q, par), Mmat),
        "b": lam((q, qd, par), bvec),
        "g": lam((q, par), gvec),
        "T": lam((q, qd, par), T),
        "V": lam((q, par), V),
        "Jc": lam((q, par), Jc),
    }


def spring_reference(n: int):
    """Joint and heave spring forces dV_s/dq and damper forces dR/dqd (Rayleigh), lambdified."""
    q = sp.symbols(f"q0:{n + 1}")
    qd = sp.symbols(f"qd0:{n + 1}")
    k = sp.symbols(f"k1:{n + 1}")
    c = sp.symbols(f"c1:{n + 1}")
    km, cm = sp.symbols("km cm")
    Vs = km * q[0] ** 2 / 2 + k[0] * q[1] ** 2 / 2
    R = cm * qd[0] ** 2 / 2 + c[0] * qd[1] ** 2 / 2
    for i in range(1, n):
        Vs += k[i] * (q[1 + i] - q[i]) ** 2 / 2
        R += c[i] * (qd[1 + i] - qd[i]) ** 2 / 2
    fK = sp.lambdify((q, k, km), sp.Matrix([Vs]).jacobian(sp.Matrix(q)).T, "numpy")
    fC = sp.lambdify((qd, c, cm), sp.Matrix([R]).jacobian(sp.Matrix(qd)).T, "numpy")
    return fK, fC


def make_params(n: int, rng: np.random.Generator, **kw) -> CableParams:
    """A line with unequal links (lengths, diameters, densities) and a submerged load."""
    base = dict(
        n_links=n,
        link_lengths=tuple(rng.uniform(0.5, 3.0, n)),
        diameter=tuple(rng.uniform(0.01, 0.05, n)),
        line_density=tuple(rng.uniform(2000.0, 8000.0, n)),
        load_mass=37.0,
        load_volume=0.004,
        platform_mass=900.0,
        pin_stiffness=55.0,
        pin_damping=3.5,
        joint_stiffness=104.7,
        joint_damping=2.8,
        current_speed=0.4,
    )
    base.update(kw)
    return CableParams(**base)


def random_state(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = np.concatenate([[rng.uniform(-5, 5)], rng.uniform(-np.pi, np.pi, n)])
    qd = np.concatenate([[rng.normal(0, 1.0)], rng.normal(0, 0.7, n)])
    return q, qd


def par_tuple(ref: RefLine):
    return (tuple(ref.l), tuple(ref.m), tuple(ref.mw), ref.M, ref.mc, ref.mcw, ref.g)


def assert_rel(actual, reference, what: str, rtol: float = RTOL) -> None:
    """Entry-wise rtol, with an absolute floor rtol * 1e-3 * max|reference| for zero entries."""
    reference = np.asarray(reference, dtype=float)
    scale = float(np.max(np.abs(reference)))
    np.testing.assert_allclose(actual, reference, rtol=rtol, atol=rtol * 1e-3 * scale, err_msg=what)


@pytest.mark.parametrize("end", ["free", "paper_anchor", "anchored"])
@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_mass_velocity_gravity_match_euler_lagrange(n: int, end: str) -> None:
    """M(q), b(q, qd), g(q), T and V equal the sympy Euler-Lagrange derivation at random states."""
    rng = np.random.default_rng(100 * n + len(end))
    ref_fns = derive(n)
    params = make_params(n, rng, end_condition=end, anchor_x=0.3, anchor_z=-2.0)
    model = CableModel.from_params(params)
    ref = RefLine(params)
    par = par_tuple(ref)
    q_a, qd_a = random_state(n, rng)
    for _ in range(4):
        q, qd = random_state(n, rng)
        M_ref = np.array(ref_fns["M"](q, par), dtype=float)
        b_ref = np.array(ref_fns["b"](q, qd, par), dtype=float).ravel()
        g_ref = np.array(ref_fns["g"](q, par), dtype=float).ravel()
        assert_rel(dynamics.mass_matrix(model, q), M_ref, f"M, n={n}, {end}")
        assert_rel(dynamics.velocity_product(model, q, qd), b_ref, f"b, n={n}, {end}")
        assert_rel(dynamics.gravity_vector(model, q), g_ref, f"g, n={n}, {end}")
        T_ref = float(ref_fns["T"](q, qd, par))
        assert dynamics.kinetic_energy(model, q, qd) == pytest.approx(T_ref, rel=RTOL)
        # potential energy of the weights: compare differences (independent of the datum);
        # the spring terms are zeroed by comparing with joint springs and heave spring off
        m0 = CableModel.from_params(params.replace(joint_springs=False, platform_spring=False))
        dV = dynamics.potential_energy(m0, q) - dynamics.potential_energy(m0, q_a)
        dV_ref = float(ref_fns["V"](q, par)) - float(ref_fns["V"](q_a, par))
        scale = abs(float(ref_fns["V"](q, par))) + abs(float(ref_fns["V"](q_a, par)))
        assert abs(dV - dV_ref) <= RTOL * scale, (dV, dV_ref)


@pytest.mark.parametrize("mode", ["per_joint", "bending"])
@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_spring_and_damper_forces(n: int, mode: str) -> None:
    """K q and C qd equal the gradients of the spring energy and of the Rayleigh function.

    Reference constants: pin k_1/c_1; joints i >= 2 either per-joint k, c or EI / l_bar_i,
    damping / l_bar_i with l_bar_i the mean of the two link lengths at joint i (MODEL.md).
    """
    rng = np.random.default_rng(7 + n)
    params = make_params(n, rng, stiffness_mode=mode, bending_stiffness=31.0, bending_damping=4.5,
                         heave_stiffness=1234.0, heave_damping=321.0)
    model = CableModel.from_params(params)
    ref = RefLine(params)
    fK, fC = spring_reference(n)
    for _ in range(3):
        q, qd = random_state(n, rng)
        assert_rel(dynamics.elastic_force(model, q), np.ravel(fK(q, ref.k, ref.km)), "K q")
        assert_rel(dynamics.damping_force(model, qd), np.ravel(fC(qd, ref.c, ref.cm)), "C qd")
    # switches: springs / dampers / platform terms off give exactly zero
    off = CableModel.from_params(params.replace(joint_springs=False, joint_dampers=False,
                                                platform_spring=False, platform_damper=False))
    q, qd = random_state(n, rng)
    assert not np.any(dynamics.elastic_force(off, q))
    assert not np.any(dynamics.damping_force(off, qd))


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_morison_drag_by_virtual_work(n: int) -> None:
    """Morison drag: per-centre forces from the relative velocity J_i qd - U (normal/tangential
    split along the link), generalised force Q = sum_i J_i^T F_i with J_i = dc_i/dq from sympy."""
    rng = np.random.default_rng(300 + n)
    params = make_params(n, rng, drag_model="morison", drag_cn=1.3, drag_ct=0.05)
    model = CableModel.from_params(params)
    ref = RefLine(params)
    par = par_tuple(ref)
    Jfn = derive(n)["Jc"]
    for _ in range(4):
        q, qd = random_state(n, rng)
        Jc = [np.array(J, dtype=float) for J in Jfn(q, par)]
        F = np.zeros((n, 2))
        for i in range(n):
            v = Jc[i] @ qd - np.array([ref.U, 0.0])
            e = np.array([np.sin(q[1 + i]), -np.cos(q[1 + i])])
            vt = (v @ e) * e
            vn = v - vt
            F[i] = -0.5 * ref.rho_w * ref.d[i] * ref.l[i] * (
                ref.cn * np.linalg.norm(vn) * vn + np.pi * ref.ct * np.linalg.norm(vt) * vt
            )
        Q = sum(Jc[i].T @ F[i] for i in range(n))
        assert_rel(dynamics.link_drag_forces(model, q, qd), F, "Morison link forces")
        assert_rel(dynamics.drag_force(model, q, qd), Q, "Morison generalised force")
        # virtual work with a random virtual displacement
        dq = rng.normal(size=n + 1)
        assert dynamics.drag_force(model, q, qd) @ dq == pytest.approx(
            sum(F[i] @ (Jc[i] @ dq) for i in range(n)), rel=1e-9, abs=1e-12 * np.abs(F).sum())


@pytest.mark.parametrize("n", [2, 5])
def test_paper_drag_formula(n: int) -> None:
    """Paper drag: alpha_i = -gamma l_i^2/4 thd_i |thd_i| on theta_i only, nothing on the heave."""
    rng = np.random.default_rng(11 * n)
    params = make_params(n, rng, drag_model="paper", paper_drag_gamma=173.0)
    model = CableModel.from_params(params)
    q, qd = random_state(n, rng)
    l = np.asarray(params.link_lengths)
    expect = np.concatenate([[0.0], -173.0 * l**2 / 4 * qd[1:] * np.abs(qd[1:])])
    assert_rel(dynamics.drag_force(model, q, qd), expect, "paper drag")
    none = CableModel.from_params(params.replace(drag_model="none"))
    assert not np.any(dynamics.drag_force(none, q, qd))


@pytest.mark.parametrize("kernel", ["dense", "fast"])
@pytest.mark.parametrize("drag", ["paper", "morison"])
@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_forward_dynamics_solves_reference_equations(n: int, drag: str, kernel: str) -> None:
    """qdd from the kernel's forward dynamics satisfies the reference equation
    M qdd + b + g + dV_s/dq + dR/dqd = Q_ext + Q_drag, with Q_ext,0 = u + k_m eta (wave spring),
    every term from the sympy derivation / independent formulae (residual to 1e-9 of the terms),
    and equals the reference solution qdd_ref = M^-1 (Q - ...) to 1e-8 of max|qdd_ref|."""
    from cable_sim.core import kernel as fast

    forward = {"dense": dynamics.forward_dynamics, "fast": fast.forward_dynamics}[kernel]
    rng = np.random.default_rng(50 + n)
    params = make_params(n, rng, drag_model=drag, drag_cn=1.1, drag_ct=0.02, heave_stiffness=900.0,
                         heave_damping=150.0)
    model = CableModel.from_params(params)
    ref = RefLine(params)
    par = par_tuple(ref)
    fns = derive(n)
    fK, fC = spring_reference(n)
    inp = Inputs(heave_force=1234.5, wave_elevation=0.37)
    for _ in range(3):
        q, qd = random_state(n, rng)
        qdd, lam = forward(model, q, qd, inp)
        assert not np.any(lam)
        M = np.array(fns["M"](q, par), dtype=float)
        forces = (np.ravel(fns["b"](q, qd, par)) + np.ravel(fns["g"](q, par))
                  + np.ravel(fK(q, ref.k, ref.km)) + np.ravel(fC(qd, ref.c, ref.cm)))
        rhs = ref.drag_generalised(q, qd)
        rhs[0] += 1234.5 + ref.km * 0.37
        scale = np.max(np.abs(M @ qdd)) + np.max(np.abs(rhs))
        np.testing.assert_allclose(M @ qdd + forces, rhs, rtol=0, atol=RTOL * scale)
        qdd_ref = np.linalg.solve(M, rhs - forces)
        err = np.max(np.abs(qdd - qdd_ref)) / np.max(np.abs(qdd_ref))
        assert err <= 1e-8, f"{kernel}: relative error of qdd {err:.3e} > 1e-8"


@pytest.mark.parametrize("end", ["free", "anchored"])
@pytest.mark.parametrize("drag", ["paper", "morison"])
def test_joint_forces_satisfy_newton_euler(drag: str, end: str) -> None:
    """The tension recursion (translational Newton equations, from the bottom) is consistent with
    the Lagrangian accelerations through the two equations it does not use: each link's moment
    equation about its centre, (m l^2/12) thdd_i = -(l_i/2) t_i . (F_{i-1} + F_i) + joint
    spring/damper torques + paper-drag torque (t_i = (cos, sin) theta_i; Morison drag and the
    weights act at the centre), and the platform's heave equation
    M zdd = u + k_m (eta - z) - c_m zd - F_0,z."""
    n = 5
    rng = np.random.default_rng(900 + len(drag) + len(end))
    params = make_params(n, rng, drag_model=drag, end_condition=end, anchor_x=1.0, anchor_z=-4.0,
                         heave_stiffness=900.0, heave_damping=150.0)
    model = CableModel.from_params(params)
    ref = RefLine(params)
    fK, fC = spring_reference(n)
    inp = Inputs(heave_force=-321.0, wave_elevation=0.2)
    for _ in range(3):
        q, qd = random_state(n, rng)
        if end == "anchored":  # a state on the constraint: put the anchor where the end is
            model = CableModel.from_params(params.replace(
                anchor_x=float(ref.joints(q)[-1, 0]), anchor_z=float(ref.joints(q)[-1, 1])))
            J = ref.end_jacobian(q)
            qd = qd - J.T @ np.linalg.solve(J @ J.T, J @ qd)
        qdd, lam = dynamics.forward_dynamics(model, q, qd, inp)
        F = dynamics.joint_forces(model, q, qd, qdd, lam)
        th = q[1:]
        t = np.stack([np.cos(th), np.sin(th)], axis=1)
        tau = -np.ravel(fK(q, ref.k, ref.km))[1:] - np.ravel(fC(qd, ref.c, ref.cm))[1:]
        if drag == "paper":
            tau = tau + ref.drag_generalised(q, qd)[1:]
        moment = -(ref.l / 2) * np.sum(t * (F[:-1] + F[1:]), axis=1) + tau
        inertia = ref.m * ref.l**2 / 12 * qdd[1:]
        scale = np.max(np.abs(ref.l / 2 * np.linalg.norm(F[:-1], axis=1))) + np.max(np.abs(tau))
        np.testing.assert_allclose(inertia, moment, rtol=0, atol=RTOL * scale)
        heave = (inp.heave_force + ref.km * (inp.wave_elevation - q[0]) - ref.cm * qd[0] - F[0, 1])
        assert ref.M * qdd[0] == pytest.approx(heave, abs=RTOL * (np.abs(F).max() + ref.km * 5))
        if end == "anchored":
            np.testing.assert_allclose(F[-1], -lam, rtol=1e-9)
