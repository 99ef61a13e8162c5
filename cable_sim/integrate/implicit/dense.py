"""Dense ``M``, ``D``, ``K`` and the dense solve of the implicit operator: the O(n^3) reference the
O(n) operator is tested against, and the schemes' ``dense`` kernel fallback.

With a seabed, ``K`` includes the contact stiffness (:func:`cable_sim.core.statics.seabed_hessian`);
with added mass, ``M`` includes ``M_a``.

Integrate layer: imports numpy and :mod:`cable_sim.core.dynamics`, :mod:`cable_sim.core.model`
(and :mod:`cable_sim.core.statics` with a seabed).
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel


def dense_operator(
    model: CableModel, q: np.ndarray, qd: np.ndarray, kgeo: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dense ``M``, local damping ``D`` and stiffness ``K`` (reference for the O(n) operator).

    ``D``: joint dampers, heave damper, paper drag ``2 gamma l^2/4 |w|`` or Morison
    ``sum_i J_ci^T G_i J_ci``. ``K``: joint springs, heave spring, ``diag(kgeo)``.
    """
    n1 = model.ndof
    n = model.n
    M = dynamics.mass_matrix(model, q)
    if model.added_mass:
        M = M + dynamics.added_mass_terms(model, q, qd)[0]
    eye = np.eye(n1)
    D = np.column_stack([dynamics.damping_force(model, eye[j]) for j in range(n1)])
    K = np.column_stack([dynamics.elastic_force(model, eye[j]) for j in range(n1)])
    if kgeo is not None:
        K[1:, 1:] += np.diag(kgeo)
    th, w, l = q[1:], qd[1:], model.length
    if model.drag == 1:
        D[1:, 1:] += np.diag(2.0 * model.drag_gamma_l2 * np.abs(w))
    elif model.drag == 2:
        c, s = np.cos(th), np.sin(th)
        vj = dynamics.joint_velocities(model, q, qd)
        vc = vj[:-1].copy()
        vc[:, 0] += 0.5 * l * c * w - model.current
        vc[:, 1] += 0.5 * l * s * w
        for i in range(n):
            t = np.array([c[i], s[i]])
            e = np.array([s[i], -c[i]])
            G = (2.0 * model.morison_cn[i] * abs(vc[i] @ t) * np.outer(t, t)
                 + 2.0 * model.morison_ct[i] * abs(vc[i] @ e) * np.outer(e, e))
            Jc = np.zeros((2, n1))
            Jc[1, 0] = 1.0
            Jc[0, 1:i + 1] = l[:i] * c[:i]
            Jc[1, 1:i + 1] = l[:i] * s[:i]
            Jc[0, i + 1] = 0.5 * l[i] * c[i]
            Jc[1, i + 1] = 0.5 * l[i] * s[i]
            D += Jc.T @ G @ Jc
    if model.seabed:  # the bed's contact stiffness (Hessian of its elastic energy)
        from cable_sim.core.statics import seabed_hessian

        K += seabed_hessian(model, q)
    return M, D, K


def _dense_solve(model: CableModel, q: np.ndarray, Mt: np.ndarray, rhs: np.ndarray,
                 end_motion: np.ndarray | None = None) -> np.ndarray:
    """Solve ``Mt x = rhs`` (anchored: with ``J x = 0``, or ``J x = end_motion`` when given)
    densely, heave lock respected (real or complex ``Mt``, ``rhs``)."""
    s = 1 if model.heave_locked else 0
    dtype = np.result_type(Mt, rhs)  # complex for Radau IIA's complex eigenvalue
    x = np.zeros(model.ndof, dtype=dtype)
    A = Mt[s:, s:]
    if model.constrained:
        J = dynamics.constraint_jacobian(model, q)[:, s:]
        k = A.shape[0]
        kkt = np.zeros((k + 2, k + 2), dtype=dtype)
        kkt[:k, :k] = A
        kkt[:k, k:] = J.T
        kkt[k:, :k] = J
        target = np.zeros(2) if end_motion is None else end_motion
        sol = np.linalg.solve(kkt, np.concatenate([rhs[s:], target]))
        x[s:] = sol[:k]
    else:
        x[s:] = np.linalg.solve(A, rhs[s:])
    return x


def baumgarte_end_motion(model: CableModel, q: np.ndarray, hg: complex, rv: np.ndarray,
                         rk: np.ndarray) -> np.ndarray | None:
    """``J x`` of the shifted system's solve at an anchored end (None otherwise): ``hg (2 alpha
    J rv + beta^2 J rk) / (1 + 2 alpha hg + beta^2 hg^2)``, the linearised Baumgarte
    stabilisation (dense reference of
    :func:`cable_sim.integrate.implicit.op_solve._op_solve_stabilised`)."""
    if not model.constrained:
        return None
    J = dynamics.constraint_jacobian(model, q)
    if model.heave_locked:
        J[:, 0] = 0.0
    alpha, beta2 = model.baumgarte_alpha, model.baumgarte_beta ** 2
    return hg * (J @ (2.0 * alpha * rv + beta2 * rk)) / (1.0 + hg * (2.0 * alpha + beta2 * hg))
