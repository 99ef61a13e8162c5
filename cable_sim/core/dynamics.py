"""Dense reference dynamics of the n-link cable (MODEL.md, O(n^2) memory, O(n^3) solve).

Pure functions of ``(model, q, qdot, inputs)``. This module is the *reference*: it builds the
mass matrix explicitly and solves with Cholesky. :mod:`cable_sim.core.kernel` has the O(n) kernel
with the same contract. Nothing here imports rclpy.

Coordinates: ``q = [z_m, theta_1 .. theta_n]``; theta_i from the downward vertical, positive
towards +x. The equations of motion are

    M(q) qdd + b(q, qd) + K q + C qd + g(q) = Q_ext + Q_drag + Q_bed + Q_added (+ Phi_q^T lambda),

with ``lambda`` the force the anchor exerts on the cable end (anchored end only). The round-2
terms (MODEL.md) are switchable and computed only when on: the seabed contact Q_bed
(:func:`seabed_force`) and the Morison added mass Q_added = -(M_a qdd + b_a)
(:func:`added_mass_terms`), an external force whose M_a joins the mass matrix in the solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from cable_sim.core.kinematics import joint_positions, joint_velocities
from cable_sim.core.model import CableModel
from cable_sim.core.seabed import link_contact


@dataclass(frozen=True)
class Inputs:
    """External inputs held over a step.

    Attributes
    ----------
    heave_force : float
        Vertical force on the platform u [N], positive up.
    wave_elevation : float
        Water surface elevation eta at the platform [m]; the heave spring acts on (eta - z_m).
    """

    heave_force: float = 0.0
    wave_elevation: float = 0.0


NO_INPUT = Inputs()


def split_state(model: CableModel, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split a state vector ``y = [q, qd]`` into views ``(q, qd)``."""
    k = model.ndof
    return y[:k], y[k:]


def joint_accelerations(
    model: CableModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
) -> np.ndarray:
    """Accelerations of p_0..p_n, shape (n+1, 2) [m/s^2]."""
    th, w, a = q[1:], qd[1:], qdd[1:]
    s, c, l = np.sin(th), np.cos(th), model.length
    acc = np.zeros((model.n + 1, 2))
    acc[1:, 0] = np.cumsum(l * (c * a - s * w * w))
    acc[1:, 1] = np.cumsum(l * (s * a + c * w * w))
    acc[:, 1] += qdd[0]
    return acc


def mass_matrix(model: CableModel, q: np.ndarray) -> np.ndarray:
    """Mass matrix M(q), shape (n+1, n+1), symmetric positive definite."""
    n, l, th = model.n, model.length, q[1:]
    idx = np.arange(n)
    mu_max = model.mu[np.maximum.outer(idx, idx)]
    M = np.empty((n + 1, n + 1))
    M[0, 0] = model.total_mass
    M[0, 1:] = model.mu * l * np.sin(th)
    M[1:, 0] = M[0, 1:]
    M[1:, 1:] = mu_max * np.outer(l, l) * np.cos(th[:, None] - th[None, :])
    M[idx + 1, idx + 1] = (model.mass / 3.0 + model.mass_below) * l**2
    return M


def velocity_product(model: CableModel, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Coriolis-centrifugal vector b(q, qd), shape (n+1,)."""
    n, l, th, w = model.n, model.length, q[1:], qd[1:]
    idx = np.arange(n)
    mu_max = model.mu[np.maximum.outer(idx, idx)]
    b = np.empty(n + 1)
    b[0] = np.sum(model.mu * l * np.cos(th) * w * w)
    S = mu_max * np.outer(l, l) * np.sin(th[:, None] - th[None, :])
    b[1:] = S @ (w * w)
    return b


def gravity_vector(model: CableModel, q: np.ndarray) -> np.ndarray:
    """Gravity-minus-buoyancy vector g(q) = dV_grav/dq, shape (n+1,)."""
    g = np.empty(model.n + 1)
    g[0] = model.gravity * (model.weight_mass.sum() + model.load_weight_mass)
    g[1:] = model.gravity * model.mu_weight * model.length * np.sin(q[1:])
    return g


def relative_angles(x: np.ndarray) -> np.ndarray:
    """Joint-relative values phi_1 = x_1, phi_i = x_i - x_{i-1} (of absolute angles, or of
    their rates), as a URDF chain and the joint springs see them."""
    r = np.empty_like(x)
    r[0] = x[0]
    r[1:] = x[1:] - x[:-1]
    return r


def _joint_to_absolute(tau: np.ndarray) -> np.ndarray:
    """Generalised force on absolute angles from joint torques: Q_i = tau_i - tau_{i+1}."""
    Q = tau.copy()
    Q[:-1] -= tau[1:]
    return Q


def elastic_force(model: CableModel, q: np.ndarray) -> np.ndarray:
    """K q: joint springs (tridiagonal in theta) and the platform's hydrostatic spring."""
    f = np.empty(model.n + 1)
    f[0] = model.heave_k * q[0]
    f[1:] = _joint_to_absolute(model.joint_k * relative_angles(q[1:]))
    return f


def damping_force(model: CableModel, qd: np.ndarray) -> np.ndarray:
    """C qd: joint dampers and the platform heave damper."""
    f = np.empty(model.n + 1)
    f[0] = model.heave_c * qd[0]
    f[1:] = _joint_to_absolute(model.joint_c * relative_angles(qd[1:]))
    return f


def link_drag_forces(model: CableModel, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Morison drag force on each link centre, shape (n, 2) [N] (zeros unless Morison drag)."""
    if model.drag != 2:
        return np.zeros((model.n, 2))
    th, w, l = q[1:], qd[1:], model.length
    s, c = np.sin(th), np.cos(th)
    vj = joint_velocities(model, q, qd)
    vc = vj[:-1].copy()
    vc[:, 0] += 0.5 * l * c * w
    vc[:, 1] += 0.5 * l * s * w
    vc[:, 0] -= model.current
    e = np.stack([s, -c], axis=1)  # link axis, pointing down the line
    vt_mag = np.sum(vc * e, axis=1)
    vt = vt_mag[:, None] * e
    vn = vc - vt
    vn_mag = np.hypot(vn[:, 0], vn[:, 1])
    return -(model.morison_cn * vn_mag)[:, None] * vn - (model.morison_ct * np.abs(vt_mag))[:, None] * vt


def drag_force(model: CableModel, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Generalised hydrodynamic drag force Q_drag(q, qd), shape (n+1,)."""
    Q = np.zeros(model.n + 1)
    if model.drag == 1:
        w = qd[1:]
        Q[1:] = -model.drag_gamma_l2 * w * np.abs(w)
    elif model.drag == 2:
        F = link_drag_forces(model, q, qd)
        th, l = q[1:], model.length
        Q[0] = F[:, 1].sum()
        below = np.cumsum(F[::-1], axis=0)[::-1] - F  # sum_{i>j} F_i
        arm = 0.5 * F + below
        Q[1:] = l * (np.cos(th) * arm[:, 0] + np.sin(th) * arm[:, 1])
    return Q


def external_force(model: CableModel, inputs: Inputs) -> np.ndarray:
    """Q_ext: heave force u plus the wave term k_m eta on the platform, shape (n+1,)."""
    Q = np.zeros(model.n + 1)
    Q[0] = inputs.heave_force
    if model.wave_coupling:
        Q[0] += model.heave_k * inputs.wave_elevation
    return Q


def applied_force(
    model: CableModel, q: np.ndarray, qd: np.ndarray, inputs: Inputs = NO_INPUT
) -> np.ndarray:
    """Right-hand side without constraint: Q_ext + Q_drag + Q_bed - b_a - b - K q - C qd - g
    (the seabed and added-mass parts only when switched on)."""
    rhs = (
        external_force(model, inputs)
        + drag_force(model, q, qd)
        - velocity_product(model, q, qd)
        - elastic_force(model, q)
        - damping_force(model, qd)
        - gravity_vector(model, q)
    )
    if model.seabed:
        rhs += seabed_force(model, q, qd)
    if model.added_mass:
        rhs -= added_mass_terms(model, q, qd)[1]
    return rhs


def constraint_residual(model: CableModel, q: np.ndarray) -> np.ndarray:
    """Phi(q) = p_n(q) - anchor, shape (2,) [m]."""
    th, l = q[1:], model.length
    return np.array([np.sum(l * np.sin(th)), q[0] - np.sum(l * np.cos(th))]) - model.anchor


def constraint_jacobian(model: CableModel, q: np.ndarray) -> np.ndarray:
    """Phi_q = d p_n / d q, shape (2, n+1)."""
    th, l = q[1:], model.length
    J = np.zeros((2, model.n + 1))
    J[0, 1:] = l * np.cos(th)
    J[1, 0] = 1.0
    J[1, 1:] = l * np.sin(th)
    return J


def constraint_bias(model: CableModel, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """(d/dt Phi_q) qd, the velocity-product part of the end acceleration, shape (2,)."""
    th, w, l = q[1:], qd[1:], model.length
    return np.array([-np.sum(l * np.sin(th) * w * w), np.sum(l * np.cos(th) * w * w)])


def forward_dynamics(
    model: CableModel, q: np.ndarray, qd: np.ndarray, inputs: Inputs = NO_INPUT
) -> tuple[np.ndarray, np.ndarray]:
    """Generalised accelerations and anchor reaction.

    Parameters
    ----------
    model : CableModel
    q, qd : ndarray (n+1,)
        Generalised positions and velocities.
    inputs : Inputs
        Heave force and wave elevation.

    Returns
    -------
    qdd : ndarray (n+1,)
        Generalised accelerations.
    anchor_force : ndarray (2,)
        Force (x, z) [N] the anchor exerts on the cable end (zeros unless anchored).
    """
    M = mass_matrix(model, q)
    if model.added_mass:
        M = M + added_mass_terms(model, q, qd)[0]
    rhs = applied_force(model, q, qd, inputs)
    s = 1 if model.heave_locked else 0
    cf = cho_factor(M[s:, s:])
    qdd = np.zeros(model.n + 1)
    qdd[s:] = cho_solve(cf, rhs[s:])
    lam = np.zeros(2)
    if model.constrained:
        J = constraint_jacobian(model, q)[:, s:]
        MinvJt = cho_solve(cf, J.T)
        A = J @ MinvJt
        phi = constraint_residual(model, q)
        phid = constraint_jacobian(model, q) @ qd
        gamma = (
            -constraint_bias(model, q, qd)
            - 2.0 * model.baumgarte_alpha * phid
            - model.baumgarte_beta**2 * phi
        )
        lam = np.linalg.solve(A, gamma - J @ qdd[s:])
        qdd[s:] += MinvJt @ lam
    return qdd, lam


def state_derivative(model: CableModel, y: np.ndarray, inputs: Inputs = NO_INPUT) -> np.ndarray:
    """dy/dt for ``y = [q, qd]`` (dense reference)."""
    q, qd = split_state(model, y)
    qdd, _ = forward_dynamics(model, q, qd, inputs)
    return np.concatenate([qd, qdd])


def kinetic_energy(model: CableModel, q: np.ndarray, qd: np.ndarray) -> float:
    """T = 1/2 qd^T M(q) qd [J] of the structure (the added mass is an external force, not here)."""
    return 0.5 * float(qd @ mass_matrix(model, q) @ qd)


def potential_energy(model: CableModel, q: np.ndarray) -> float:
    """V = gravity-minus-buoyancy of links and load + heave spring + joint springs [J], plus the
    seabed's elastic energy sum int 1/2 k_b delta^2 ds when the seabed is on.

    The platform's own weight is cancelled by its displacement and is not included.
    """
    p = joint_positions(model, q)
    zc = 0.5 * (p[:-1, 1] + p[1:, 1])
    V = model.gravity * (np.sum(model.weight_mass * zc) + model.load_weight_mass * p[-1, 1])
    V += 0.5 * model.heave_k * q[0] ** 2
    V += 0.5 * np.sum(model.joint_k * relative_angles(q[1:]) ** 2)
    if model.seabed:
        V += seabed_link_forces(model, q, np.zeros_like(q))[2]
    return float(V)


def total_energy(model: CableModel, q: np.ndarray, qd: np.ndarray) -> float:
    """E = T + V [J]."""
    return kinetic_energy(model, q, qd) + potential_energy(model, q)


def power(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    inputs: Inputs = NO_INPUT,
    anchor_force: np.ndarray | None = None,
    qdd: np.ndarray | None = None,
) -> dict[str, float]:
    """Power of the non-conservative forces [W]; their sum is dE/dt.

    ``qdd`` is needed only for the added-mass power (default: from :func:`forward_dynamics`).

    Returns
    -------
    dict
        ``external`` (heave force and wave spring term), ``damping`` (joint and heave dampers,
        <= 0), ``drag`` (<= 0 without current), ``constraint`` (anchor reaction; zero when the
        constraint is satisfied exactly); with a seabed ``seabed`` (contact damping and friction:
        the contact force's power minus the rate of the bed's elastic energy, <= 0); with added
        mass ``added_mass`` (-qd . (M_a qdd + b_a)).
    """
    out = {
        "external": float(external_force(model, inputs) @ qd),
        "damping": -float(damping_force(model, qd) @ qd),
        "drag": float(drag_force(model, q, qd) @ qd),
        "constraint": 0.0,
    }
    if anchor_force is not None and model.constrained:
        out["constraint"] = float(anchor_force @ (constraint_jacobian(model, q) @ qd))
    if model.seabed:
        F, S, _, spring_power = seabed_link_forces(model, q, qd)
        out["seabed"] = float(_link_forces_to_generalised(model, q, F, S) @ qd) - spring_power
    if model.added_mass:
        if qdd is None:
            qdd = forward_dynamics(model, q, qd, inputs)[0]
        Ma, ba = added_mass_terms(model, q, qd)
        out["added_mass"] = -float(qd @ (Ma @ qdd + ba))
    return out


def joint_forces(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    anchor_force: np.ndarray | None = None,
) -> np.ndarray:
    """Internal forces at the joints from each link's Newton equation (recursion from the end).

    Returns
    -------
    F : ndarray (n+1, 2)
        ``F[i]`` (i = 0..n-1) is the force [N] that link i (the platform for i = 0) exerts on
        link i+1 at joint i; ``F[0]`` is the fairlead force on the cable. ``F[n]`` is the force
        link n exerts on what is at its end (the load, or the anchor: ``-anchor_force``).
    """
    n, g = model.n, model.gravity
    acc = joint_accelerations(model, q, qd, qdd)
    ac = 0.5 * (acc[:-1] + acc[1:])
    D = link_drag_forces(model, q, qd)
    F = np.zeros((n + 1, 2))
    if model.constrained:
        lam = np.zeros(2) if anchor_force is None else anchor_force
        F[n] = -lam
    else:
        F[n] = model.load_mass * acc[n] + np.array([0.0, model.load_weight_mass * g])
    # F_i = F_{i+1} + m_i a_ci - W~_i - D_i - B_i - F_a,i, with W~_i = (0, -m~_i g), B_i the
    # seabed force and F_a,i = -l_i A_i a_ci the added-mass force on link i
    inc = model.mass[:, None] * ac - D
    inc[:, 1] += model.weight_mass * g
    if model.seabed:
        inc -= seabed_link_forces(model, q, qd)[0]
    if model.added_mass:
        th = q[1:]
        t = np.stack([np.cos(th), np.sin(th)], axis=1)
        e = np.stack([np.sin(th), -np.cos(th)], axis=1)
        an = model.added_mass_normal * model.length * np.sum(t * ac, axis=1)
        at = model.added_mass_axial * model.length * np.sum(e * ac, axis=1)
        inc += an[:, None] * t + at[:, None] * e
    F[:n] = F[n] + np.cumsum(inc[::-1], axis=0)[::-1]
    return F


def axial_tension(model: CableModel, q: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Axial tension at the top of each link, ``T_i = F[i-1] . (-e_i)`` [N], shape (n,)."""
    th = q[1:]
    return -(F[:-1, 0] * np.sin(th) - F[:-1, 1] * np.cos(th))


def mass_matrix_condition(model: CableModel, q: np.ndarray) -> float:
    """2-norm condition number of M(q) (hard-case diagnostic)."""
    return float(np.linalg.cond(mass_matrix(model, q)))


# ---- seabed contact and added mass (MODEL.md "Round 2 terms"; off unless switched on) ---------


def seabed_link_forces(
    model: CableModel, q: np.ndarray, qd: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Seabed force on each link, integrated exactly along its length.

    Returns
    -------
    F : ndarray (n, 2)
        Resultant contact force (x, z) on each link [N].
    S : ndarray (n, 2)
        First moments int s f(s) ds about each link's upper joint [N m].
    potential : float
        Elastic energy of the bed, sum int 1/2 k_b delta^2 ds [J].
    spring_power : float
        sum int k_b delta zdot ds [W]; the bed's elastic energy changes at minus this rate.
    """
    n = model.n
    F = np.zeros((n, 2))
    S = np.zeros((n, 2))
    pot = sp = 0.0
    if not model.seabed:
        return F, S, pot, sp
    p = joint_positions(model, q)
    v = joint_velocities(model, q, qd)
    for i in range(n):
        fx, fz, mx, mz, e, pw = link_contact(
            p[i, 0], p[i, 1], v[i, 0], v[i, 1], q[i + 1], qd[i + 1], model.length[i],
            model.seabed_z, model.seabed_k[i], model.seabed_c[i], model.friction_axial[i],
            model.friction_transverse[i], model.friction_speed,
        )
        F[i] = fx, fz
        S[i] = mx, mz
        pot += e
        sp += pw
    return F, S, pot, sp


def _link_forces_to_generalised(
    model: CableModel, q: np.ndarray, F: np.ndarray, S: np.ndarray
) -> np.ndarray:
    """Q = sum_i J(s)^T f over each link, from resultants F_i and first moments S_i:
    Q_0 = sum F_z, Q_theta_j = l_j t_j . sum_{i>j} F_i + t_j . S_j."""
    th = q[1:]
    Q = np.empty(model.n + 1)
    Q[0] = F[:, 1].sum()
    below = np.cumsum(F[::-1], axis=0)[::-1] - F
    arm = model.length[:, None] * below + S
    Q[1:] = np.cos(th) * arm[:, 0] + np.sin(th) * arm[:, 1]
    return Q


def seabed_force(model: CableModel, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Generalised seabed force Q_b = sum_i int J(s)^T f(s) ds, shape (n+1,) (zeros when off)."""
    if not model.seabed:
        return np.zeros(model.n + 1)
    F, S, _, _ = seabed_link_forces(model, q, qd)
    return _link_forces_to_generalised(model, q, F, S)


def _upper_joint_jacobians(model: CableModel, q: np.ndarray) -> np.ndarray:
    """d p_{i-1} / d q for each link i, shape (n, 2, n+1)."""
    n, l, th = model.n, model.length, q[1:]
    Jp = np.zeros((n, 2, n + 1))
    Jp[:, 1, 0] = 1.0
    cx, cz = l * np.cos(th), l * np.sin(th)
    for i in range(1, n):
        Jp[i, 0, 1:i + 1] = cx[:i]
        Jp[i, 1, 1:i + 1] = cz[:i]
    return Jp


def added_mass_terms(model: CableModel, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Morison added mass as an external force -int J^T A (J qdd + Jdot qd) ds = -(M_a qdd + b_a).

    A_i = m_an n_i n_i^T + m_at e_i e_i^T per unit length (n_i = t_i = (cos, sin), e_i = (sin, -cos)).
    With J(s) = J_p + s T_i (T_i: t_i in column i) and Jdot(s) qd = kappa_p - s w_i^2 e_i:

        M_a = sum_i l J_p^T A J_p + l^2/2 (J_p^T A T + T^T A J_p) + l^3/3 T^T A T
        b_a = sum_i J_p^T A (l kappa_p - l^2/2 w_i^2 e_i) + T^T A (l^2/2 kappa_p)   (A e_i . t_i = 0)

    Returns
    -------
    M_a : ndarray (n+1, n+1)
        Added-mass matrix (symmetric positive semi-definite).
    b_a : ndarray (n+1,)
        Its velocity-product vector.
    """
    n, l, th, w = model.n, model.length, q[1:], qd[1:]
    Ma = np.zeros((n + 1, n + 1))
    ba = np.zeros(n + 1)
    if not model.added_mass:
        return Ma, ba
    Jp = _upper_joint_jacobians(model, q)
    kx = np.concatenate([[0.0], np.cumsum(-l * np.sin(th) * w * w)])  # kappa_p: - sum l w^2 e
    kz = np.concatenate([[0.0], np.cumsum(l * np.cos(th) * w * w)])
    for i in range(n):
        c, s, li = np.cos(th[i]), np.sin(th[i]), l[i]
        t = np.array([c, s])
        e = np.array([s, -c])
        A = model.added_mass_normal[i] * np.outer(t, t) + model.added_mass_axial[i] * np.outer(e, e)
        J = Jp[i]
        AJ = A @ J
        At = A @ t
        Ma += li * (J.T @ AJ)
        cross = 0.5 * li * li * np.outer(J.T @ At, np.eye(n + 1)[i + 1])
        Ma += cross + cross.T
        Ma[i + 1, i + 1] += li**3 / 3.0 * (t @ At)
        kp = np.array([kx[i], kz[i]])
        ba += J.T @ (A @ (li * kp - 0.5 * li * li * w[i] ** 2 * e))
        ba[i + 1] += 0.5 * li * li * (At @ kp)
    return Ma, ba
