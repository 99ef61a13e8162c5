"""The O(n) operator ``M~ = M + hg D + hg^2 K`` of the linearly implicit schemes: factor, solve,
product.

``M~`` is the mass matrix of a modified chain (see :mod:`cable_sim.integrate.implicit`): joint
armature ``beta_i = hg c_i + hg^2 k_i``, extra platform mass, extra link rotational inertia and
anisotropic extra centre masses. With Morison added mass (MODEL.md "Round 2 terms") ``M`` includes
it: the link mass seen along the normal is m + m_an l (rotation and normal motion) and along the
axis m + m_at l (packed rows 12 and 13; both m without added mass).

Seabed contact: where the bed pushes on link i (the interval ``[a, b]`` of s from its upper
joint where the penetration and the force ``k_b delta - c_b zdot`` are both positive,
:func:`cable_sim.core.kernel.contact.touching_interval`, the interval the kernel integrates the
force over), the force's Jacobian is ``-int_a^b c_b J_z^T J_z ds`` (velocities) and
``-int_a^b k_b J_z^T J_z ds`` (positions, with ``J_z(s) = dz(s)/dq``). So ``hg D + hg^2 K``
gains ``int_a^b kap J_z^T J_z ds``, ``kap = hg c_b + hg^2 k_b``: a mass of density kap that
resists only vertical acceleration, on part of the link. Per link that is a generalised inertia
about the pin (mass ``kap (b - a)``, first and second moments of ``[a, b]``, z direction only,
not centred), added to the link's own in :func:`~.op_factor._op_inward`. Left out (the operator of a
W-method need not be the exact Jacobian): the part of ``-dQ_b/dq`` from turning ``J^T``
(diagonal in absolute angles, like gravity's; the bed's reaction lowers the tension and with it
the tension stiffness), the damper's ``d zdot/dq`` (velocity times curvature), the jump of the
damper's force where a link moving down enters the bed, and friction (off by default).
That is the operator at ``horizon = 0`` (:func:`operator_solve`, :func:`operator_product`).
The schemes pass their step as the horizon: then ``[a, b]`` is the smallest interval holding
the part of the link in the bed now and at ``q + h qd``, the damper's cut ignored, so that a
link touching down or rising out of the bed during the step is already stiff in W (without
it the mooring line's implicit runs were limited to about the RK4 step, see
:func:`~.op_terms._contact_terms`).

The articulated inertia seen at a pin is then 3x3 instead of
the 2x2 of the forward dynamics; the inward recursion (:func:`~.op_factor._op_inward`) is specific to it,
everything else -- link kinematics, drag velocities, the link-frame transforms, the outward
acceleration sweep, the Woodbury choice, the 2x2 end correction -- is the shared implementation
of :mod:`cable_sim.core.kernel.links`, :mod:`cable_sim.core.kernel.frames` and
:mod:`cable_sim.core.kernel.sweeps`.

Factorisation workspace: ``W`` (``_NW`` rows of n per-link values), ``S`` (``_NS`` scalars),
``X`` (the two unit end-force solutions ``M~^-1 J^T``, anchored end or heavy load); the solve
and the product also use W's scratch rows, so nothing is allocated per call.

Modules, one per part: ``op_layout`` (the workspace's rows), ``op_terms`` (per-link terms: armature,
drag, contact, tension stiffness), ``op_factor`` (the inward 3x3 sweep and the unit end forces),
``op_solve`` (the solve's two sweeps), ``op_product`` (``hg D rd + hg K rk``). This module keeps
the theory above, the Python-level API (:func:`operator_solve`, :func:`operator_solve_pair`,
:func:`operator_product`, :func:`geometric_stiffness`) and re-exports the compiled pieces the schemes use.

Integrate layer: imports numpy, :mod:`cable_sim.core.kernel.packing`, :mod:`cable_sim.core.model`
and the sibling ``op_*`` modules.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core.kernel.packing import pack_arrays
from cable_sim.core.model import CableModel
from cable_sim.integrate.implicit.op_factor import _op_factor, _op_factor_trig
from cable_sim.integrate.implicit.op_layout import _NS, _NW, _W_COS, _W_SIN
from cable_sim.integrate.implicit.op_product import _dk_product
from cable_sim.integrate.implicit.op_solve import _op_solve, _op_solve_pair
from cable_sim.integrate.implicit.op_terms import _kgeo_from_forces

__all__ = ["geometric_stiffness", "operator_solve", "operator_solve_pair", "operator_product",
           "_op_factor", "_op_factor_trig", "_op_solve", "_op_solve_pair", "_dk_product",
           "_kgeo_from_forces", "_NS", "_NW", "_W_COS", "_W_SIN"]


# --------------------------------------------------------------------------------------------
# Python-level helpers (tests, dense fallback, diagnostics)
# --------------------------------------------------------------------------------------------


def geometric_stiffness(model: CableModel, q: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Tension stiffness ``kappa_i = max(0, l_i T_i)`` [N m/rad] from joint forces ``F``.

    Parameters
    ----------
    model : CableModel
    q : ndarray (n+1,)
    F : ndarray (n+1, 2)
        Joint forces (:func:`cable_sim.core.dynamics.joint_forces`).
    """
    th = q[1:]
    e = np.stack([np.sin(th), -np.cos(th)], axis=1)
    t_mean = -0.5 * np.sum((F[:-1] + F[1:]) * e, axis=1)
    return np.maximum(0.0, model.length * t_mean)


def _factor_fast(model: CableModel, q: np.ndarray, qd: np.ndarray, hg: float | complex,
                 kgeo: np.ndarray | None, horizon: float = 0.0):
    """Factor at (q, qd): ``arr, par, G, W, S, X, ok`` (``G``: the real geometry rows; for a
    complex ``hg`` those of a real factorisation at the same state, W, S, X complex)."""
    arr, par = pack_arrays(model)
    n = model.n
    q = np.ascontiguousarray(q, dtype=float)
    qd = np.ascontiguousarray(qd, dtype=float)
    kg = np.zeros(n) if kgeo is None else np.ascontiguousarray(kgeo, dtype=float)
    W = np.zeros((_NW, n))
    S = np.zeros(_NS)
    X = np.zeros((2, n + 1))
    cplx = isinstance(hg, complex | np.complexfloating)
    ok = _op_factor(arr, par, q, qd, float(abs(hg)) if cplx else float(hg), kg, W, S, X,
                    float(horizon))
    if not cplx:
        return arr, par, W, W, S, X, ok
    Wc = np.zeros((_NW, n), dtype=complex)
    Sc = np.zeros(_NS, dtype=complex)
    Xc = np.zeros((2, n + 1), dtype=complex)
    ok = _op_factor_trig(arr, par, q, qd, complex(hg), kg, W, Wc, Sc, Xc, float(horizon))
    return arr, par, W, Wc, Sc, Xc, ok


def operator_solve(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    hg: float,
    rhs: np.ndarray,
    kgeo: np.ndarray | None = None,
    horizon: float = 0.0,
) -> np.ndarray:
    """Solve ``(M + hg D + hg^2 K) x = rhs`` in O(n) (anchored end: subject to ``J x = 0``).

    Parameters
    ----------
    model : CableModel
    q, qd : ndarray (n+1,)
        State at which ``M``, ``D`` (drag linearisation) are evaluated.
    hg : float or complex
        ``gamma h`` [s]; 0 gives the plain mass matrix. Complex (Radau IIA's
        ``h / lambda`` for a complex eigenvalue ``lambda`` of ``A^-1``): ``x`` is complex.
    rhs : ndarray (n+1,)
        Generalised force.
    kgeo : ndarray (n,), optional
        Tension stiffness per link (see :func:`geometric_stiffness`); zero if omitted.
    horizon : float, optional
        Seabed contact [s]: 0 (default): the contact force's Jacobian at (q, qd); > 0 (the
        schemes pass their step): over the part of each link in the bed now or at
        ``q + horizon qd``, the damper's cut ignored.

    Returns
    -------
    x : ndarray (n+1,)

    Raises
    ------
    numpy.linalg.LinAlgError
        If the anchored end's 2x2 Schur matrix is singular.
    """
    arr, par, G, W, S, X, ok = _factor_fast(model, q, qd, hg, kgeo, horizon)
    if not ok:
        raise np.linalg.LinAlgError("singular anchor constraint matrix J M~^-1 J^T")
    x = np.empty(model.ndof, dtype=W.dtype)
    _op_solve(arr, par, G, W, S, X, np.ascontiguousarray(rhs, dtype=W.dtype), x)
    return x


def operator_solve_pair(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    hg: float,
    hgc: complex,
    rhs: np.ndarray,
    rhsc: np.ndarray,
    kgeo: np.ndarray | None = None,
    horizon: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Two solves of :func:`operator_solve` at once, as Radau IIA's Newton iteration does them:
    ``(M + hg D + hg^2 K) x = rhs`` with a real ``hg`` and the same with a complex ``hgc`` and
    right-hand side ``rhsc``, the complex factorisation reading its geometry from the real one
    and the two systems' sweeps side by side
    (:func:`cable_sim.integrate.implicit.op_solve._op_solve_pair`).

    Parameters
    ----------
    model, q, qd, kgeo, horizon
        See :func:`operator_solve`.
    hg : float
        The real system's ``gamma h`` [s].
    hgc : complex
        The complex system's ``h / lambda`` [s].
    rhs, rhsc : ndarray (n+1,)
        The real and the complex generalised force.

    Returns
    -------
    x, xc : ndarray (n+1,)
        The real and the complex solution.

    Raises
    ------
    numpy.linalg.LinAlgError
        If an anchored end's 2x2 Schur matrix is singular.
    """
    arr, par, _, W, S, X, ok = _factor_fast(model, q, qd, float(hg), kgeo, horizon)
    Wc = np.zeros((_NW, model.n), dtype=complex)
    Sc = np.zeros(_NS, dtype=complex)
    Xc = np.zeros((2, model.ndof), dtype=complex)
    okc = _op_factor_trig(arr, par, np.ascontiguousarray(q, dtype=float),
                          np.ascontiguousarray(qd, dtype=float), complex(hgc),
                          np.zeros(model.n) if kgeo is None else np.ascontiguousarray(kgeo, dtype=float),
                          W, Wc, Sc, Xc, float(horizon))
    if not (ok and okc):
        raise np.linalg.LinAlgError("singular anchor constraint matrix J M~^-1 J^T")
    x = np.empty(model.ndof)
    xc = np.empty(model.ndof, dtype=complex)
    _op_solve_pair(arr, par, W, W, S, X, np.ascontiguousarray(rhs, dtype=float), x, Wc, Sc, Xc,
                   np.ascontiguousarray(rhsc, dtype=complex), xc)
    return x, xc


def operator_product(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    hg: float,
    rd: np.ndarray,
    rk: np.ndarray,
    kgeo: np.ndarray | None = None,
    horizon: float = 0.0,
) -> np.ndarray:
    """``hg D rd + hg K rk`` in O(n) (the local damping and stiffness of the operator;
    parameters as :func:`operator_solve`)."""
    arr, par, G, W, S, X, _ = _factor_fast(model, q, qd, hg, kgeo, horizon)
    out = np.empty(model.ndof, dtype=W.dtype)
    hgv = complex(hg) if W.dtype.kind == "c" else float(hg)
    _dk_product(arr, par, hgv, G, W, np.ascontiguousarray(rd, dtype=W.dtype),
                np.ascontiguousarray(rk, dtype=W.dtype), out)
    return out
