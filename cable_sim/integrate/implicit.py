"""Linearly implicit integrators for stiff cables, O(n) per step.

Why: with the paper's drag (and at large n with any drag) the explicit schemes are limited by
*stability*, not accuracy (MODEL.md, "Numerical character"). The stiff forces are local:

* joint springs and dampers act on each joint's relative angle;
* the heave spring and damper act on the platform;
* drag is body-local: the paper's drag depends on link i's own angular velocity, Morison drag
  on the velocity of link i's centre;
* the (static) tension stiffness of a hanging chain is diagonal in absolute angles.

A linearly implicit step solves with the operator ``M~ = M + hg D + hg^2 K`` (MuJoCo's
``M + hD + h^2K``) where ``D = -dQ/dqd`` and ``K = -dQ/dq`` are restricted to those local terms
and ``hg`` is the scheme's ``gamma h``. In mechanical terms ``M~`` is the mass matrix of a
modified chain: every joint gets an "armature" ``beta_i = hg c_i + hg^2 k_i`` on its relative
angle, the platform an extra mass ``hg c_m + hg^2 k_m``, every link an extra rotational inertia
``hg 2 gamma_i l_i^2/4 |theta_dot_i| + hg^2 kappa_i`` (paper drag, tension stiffness) and an
anisotropic extra mass ``hg G_i`` at its centre, ``G_i = 2 c_n |v.t| t t^T + 2 c_t |v.e| e e^T``
(the Jacobian of the Morison force, v the centre velocity relative to the water). Because the
armature couples a link's rotation to its parent's, the articulated inertia seen at a pin is
3x3 (couple + force against parent rotation + pin acceleration) instead of the 2x2 of
:mod:`cable_sim.core.kernel`; the recursion is otherwise the same and stays O(n) (see
:func:`_op_factor`). The anchored end is handled by the same Schur complement with the modified
operator (two unit-force solves), the paper's 8e8 kg load by the same Woodbury form as in
:mod:`cable_sim.core.kernel`; after each step the base class projects onto the constraint.

The geometric (tension) stiffness ``kappa_i = max(0, l_i T_i)`` uses the mean axial tension of
link i at the start of the step (from the Newton recursion of the joint forces). For a hanging
chain at rest it is exactly the gravity stiffness ``g mu~_i l_i cos(theta_i)``; in motion it is
an approximation, which a W-method allows (the schemes keep their order for any ``K``, ``D``).

Schemes (:data:`INTEGRATORS`):

* :class:`LinearlyImplicitEuler` (``implicit_euler``): order 1, one force evaluation and one
  O(n) solve per step. ``v' = v + h a*``, ``q' = q + h v'`` with
  ``M~ a* = f - hK v``: for the local stiff terms it is the implicit Euler step (L-stable,
  strongly damping), for the rest symplectic Euler. Stable at steps far above the explicit
  limit, but first order: its numerical damping of fast physical modes is O(h).
* :class:`Rosenbrock2` (``rosenbrock2``): the two-stage L-stable Rosenbrock W-method ROS2
  (Verwer, Spee, Blom & Hundsdorfer 1999), order 2 for *any* approximation of the Jacobian,
  so order 2 with the local ``K``, ``D`` above; two force evaluations, one operator
  factorisation and two O(n) solves per step. ``gamma = 1 - 1/sqrt(2)`` by default (smaller
  error constant; ``1 + 1/sqrt(2)`` is the original's choice), both L-stable for the part in
  ``W``; the explicit remainder (velocity-product couplings) is integrated like Heun's method.

Both have a compiled fast path (system kernel ``"fast"``: the whole step, its checks and the
projection run in numba; :meth:`advance` runs many steps in one call) and a dense fallback
(kernel ``"dense"``: the same scheme with the dense matrices ``M``, ``D``, ``K``, used as the
reference the O(n) solve is tested against).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core import dynamics
from cable_sim.core import kernel as _fast
from cable_sim.core.model import CableModel
from cable_sim.core.system import CableSystem
from cable_sim.integrate.base import Integrator

__all__ = [
    "INTEGRATORS",
    "LinearlyImplicitEuler",
    "Rosenbrock2",
    "operator_solve",
    "operator_product",
    "dense_operator",
    "geometric_stiffness",
]

_TINY = 1e-150

# rows of the per-link workspace W (n columns)
_W_COS, _W_SIN, _W_D, _W_UX, _W_UZ, _W_BETA, _W_ROT, _W_GT, _W_GE, _W_BCN, _W_DROT, _W_KGEO = range(12)
_NW = 12
# entries of the scalar workspace S
_S_BETA0, _S_AZZ, _S_J00, _S_J01, _S_J10, _S_J11, _S_MODE, _S_MC = range(8)
_NS = 8
_MODE_NONE, _MODE_CONSTRAINED, _MODE_HEAVY = 0.0, 1.0, 2.0


# --------------------------------------------------------------------------------------------
# Compiled O(n) operator
# --------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _op_factor(
    arr: np.ndarray,
    par: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    hg: float,
    kgeo: np.ndarray,
    W: np.ndarray,
    S: np.ndarray,
    X: np.ndarray,
) -> bool:
    """Articulated inertias of ``M~ = M + hg D + hg^2 K`` at (q, qd); fills W, S, X.

    Backward sweep (tip to platform). For the subtree below pin p_{i-1} the 3x3 articulated
    inertia maps the parent's (angular acceleration, pin acceleration) to the (couple, force)
    the parent applies: ``[[c, w^T], [w, A]]``. For link i (axis e, normal t, length l, mass m,
    extra rotational inertia rho, extra centre masses g_t, g_e along t, e, joint armature beta)
    with the child's ``c, w, A`` expressed in the link frame (P = t.A.t, R = t.A.e, ...):

        D   = m l^2/12 + rho + beta + l^2 (m+g_t)/4 + c + 2 l w_t + l^2 P
        u   = (l (m+g_t)/2 + w_t + l P) t + (w_e + l R) e        (couple-force coupling)
        A'  = diag_te(m+g_t, m+g_e) + A - u u^T / D,   w' = beta u / D,  c' = beta (D - beta) / D

    with ``A'_tt`` assembled from non-negative terms (no cancellation; it reduces to the fast
    kernel's ``a_tt`` when beta = rho = g = 0). Forward sweep:
    ``alpha_i = (beta_i alpha_{i-1} - u_i . a_{i-1} - b_i) / D_i``, ``a_i = a_{i-1} + l t alpha_i``.

    The two unit end-force solves ``X = M~^-1 J^T`` and ``J X`` are done here (anchored end, or
    Woodbury for a heavy load). Returns False if the anchored end's ``J X`` is singular.
    """
    n = arr.shape[1]
    l = arr[0]
    m = arr[1]
    jk = arr[3]
    jc = arr[4]
    gl2 = arr[5]
    cn = arr[6]
    ct = arr[7]
    current = par[0]
    drag = int(par[1])
    mc = par[2]
    mp = par[4]
    hk = par[5]
    hc = par[6]
    locked = par[7] != 0.0
    constrained = par[10] != 0.0
    cth = W[_W_COS]
    sth = W[_W_SIN]
    dd = W[_W_D]
    uxa = W[_W_UX]
    uza = W[_W_UZ]
    beta = W[_W_BETA]
    rot = W[_W_ROT]
    gta = W[_W_GT]
    gea = W[_W_GE]
    drot = W[_W_DROT]
    kg = W[_W_KGEO]
    hg2 = hg * hg
    vx = 0.0
    vz = qd[0]
    line_mass = 0.0
    for i in range(n):
        c = np.cos(q[i + 1])
        s = np.sin(q[i + 1])
        cth[i] = c
        sth[i] = s
        line_mass += m[i]
        beta[i] = hg * jc[i] + hg2 * jk[i]
        kg[i] = hg * kgeo[i]
        w = qd[i + 1]
        drot[i] = 0.0
        gta[i] = 0.0
        gea[i] = 0.0
        if drag == 1:
            drot[i] = hg * 2.0 * gl2[i] * abs(w)
        elif drag == 2:
            hl = 0.5 * l[i] * w
            vcx = vx + hl * c - current
            vcz = vz + hl * s
            vt = vcx * c + vcz * s  # normal component (along t)
            ve = vcx * s - vcz * c  # axial component (along e)
            gta[i] = hg * 2.0 * cn[i] * abs(vt)
            gea[i] = hg * 2.0 * ct[i] * abs(ve)
            vx += l[i] * c * w
            vz += l[i] * s * w
        rot[i] = drot[i] + hg * kg[i]
    heavy = (not constrained) and mc > line_mass and not (locked and n == 1)
    extra = constrained or heavy
    mload = 0.0 if extra else mc
    axx = mload
    axz = 0.0
    azz = mload
    cc = 0.0
    wx = 0.0
    wz = 0.0
    b1n = 0.0
    b1x = -1.0  # unit force +x on p_n: "the end" needs -1 from the line
    b1z = 0.0
    b2n = 0.0
    b2x = 0.0
    b2z = -1.0
    for i in range(n - 1, -1, -1):
        c = cth[i]
        s = sth[i]
        li = l[i]
        mi = m[i]
        il2 = 1.0 / (li * li)
        cs = c * s
        p_tt = axx * c * c + 2.0 * axz * cs + azz * s * s
        r_te = (axx - azz) * cs + axz * (s * s - c * c)
        s_ee = axx * s * s - 2.0 * axz * cs + azz * c * c
        wt = wx * c + wz * s
        we = wx * s - wz * c
        mt = mi + gta[i]
        me = mi + gea[i]
        bi = beta[i]
        rp = (rot[i] + bi) * il2
        dn = mi / 12.0 + rp + 0.25 * mt + cc * il2 + 2.0 * wt / li + p_tt  # D / l^2
        d = li * li * dn
        ut = 0.5 * li * mt + wt + li * p_tt
        ue = we + li * r_te
        a_tt = ((mt + p_tt) * (mi / 12.0 + rp) + mt * (cc * il2 + wt / li + 0.25 * p_tt)
                + (p_tt * cc - wt * wt) * il2) / dn
        a_te = r_te - ut * ue / d
        a_ee = me + s_ee - ue * ue / d
        axx = a_tt * c * c + 2.0 * a_te * cs + a_ee * s * s
        axz = a_tt * cs + a_te * (s * s - c * c) - a_ee * cs
        azz = a_tt * s * s - 2.0 * a_te * cs + a_ee * c * c
        uxw = ut * c + ue * s
        uzw = ut * s - ue * c
        dd[i] = d
        uxa[i] = uxw
        uza[i] = uzw
        # rotational coupling passed to the parent (zero without armature)
        dnb = li * li * (mi / 12.0 + rot[i] * il2 + 0.25 * mt + cc * il2 + 2.0 * wt / li + p_tt)
        cc = bi * dnb / d
        wx = bi * uxw / d
        wz = bi * uzw / d
        if extra:
            bc = b1n + li * (c * b1x + s * b1z)
            X[0, i + 1] = bc
            b1n = bi * bc / d
            b1x -= uxw * bc / d
            b1z -= uzw * bc / d
            if abs(b1x) + abs(b1z) + abs(b1n) < _TINY:
                b1n = 0.0
                b1x = 0.0
                b1z = 0.0
            bc = b2n + li * (c * b2x + s * b2z)
            X[1, i + 1] = bc
            b2n = bi * bc / d
            b2x -= uxw * bc / d
            b2z -= uzw * bc / d
            if abs(b2x) + abs(b2z) + abs(b2n) < _TINY:
                b2n = 0.0
                b2x = 0.0
                b2z = 0.0
    beta0 = hg * hc + hg2 * hk
    S[_S_BETA0] = beta0
    S[_S_AZZ] = azz
    S[_S_MC] = mc
    if not extra:
        S[_S_MODE] = _MODE_NONE
        return True
    S[_S_MODE] = _MODE_CONSTRAINED if constrained else _MODE_HEAVY
    for k in range(2):
        bz = b1z if k == 0 else b2z
        zdd = 0.0 if locked else -bz / (mp + beta0 + azz)
        X[k, 0] = zdd
        ap = 0.0
        apx = 0.0
        apz = zdd
        for i in range(n):
            alpha = (beta[i] * ap - uxa[i] * apx - uza[i] * apz - X[k, i + 1]) / dd[i]
            X[k, i + 1] = alpha
            apx += l[i] * cth[i] * alpha
            apz += l[i] * sth[i] * alpha
            ap = alpha
        S[_S_J00 + k] = apx  # column k of J X: (J00, J10) for k = 0 -> stored J00, J01 = row 0
        S[_S_J10 + k] = apz
    if constrained:
        a11 = S[_S_J00]
        a12 = S[_S_J01]
        a21 = S[_S_J10]
        a22 = S[_S_J11]
        det = a11 * a22 - a12 * a21
        if abs(det) <= 4.0 * 2.220446049250313e-16 * (abs(a11 * a22) + abs(a12 * a21)):
            return False
    return True


@nb.njit(cache=True)
def _op_solve(
    arr: np.ndarray,
    par: np.ndarray,
    W: np.ndarray,
    S: np.ndarray,
    X: np.ndarray,
    rhs: np.ndarray,
    x: np.ndarray,
) -> None:
    """Solve ``M~ x = rhs`` (anchored: with ``J x = 0``) using a factorisation from
    :func:`_op_factor`. ``rhs`` is a generalised force: ``rhs[0]`` a vertical force on the
    platform, ``rhs[i]`` a couple on link i."""
    n = arr.shape[1]
    l = arr[0]
    cth = W[_W_COS]
    sth = W[_W_SIN]
    dd = W[_W_D]
    uxa = W[_W_UX]
    uza = W[_W_UZ]
    beta = W[_W_BETA]
    bcn = W[_W_BCN]
    locked = par[7] != 0.0
    mp = par[4]
    bn = 0.0
    bx = 0.0
    bz = 0.0
    for i in range(n - 1, -1, -1):
        b = bn + l[i] * (cth[i] * bx + sth[i] * bz) - rhs[i + 1]
        bcn[i] = b
        r = b / dd[i]
        bn = beta[i] * r
        bx -= uxa[i] * r
        bz -= uza[i] * r
    zdd = 0.0 if locked else (rhs[0] - bz) / (mp + S[_S_BETA0] + S[_S_AZZ])
    x[0] = zdd
    ap = 0.0
    apx = 0.0
    apz = zdd
    for i in range(n):
        alpha = (beta[i] * ap - uxa[i] * apx - uza[i] * apz - bcn[i]) / dd[i]
        x[i + 1] = alpha
        apx += l[i] * cth[i] * alpha
        apz += l[i] * sth[i] * alpha
        ap = alpha
    mode = S[_S_MODE]
    if mode == _MODE_NONE:
        return
    a11 = S[_S_J00]
    a12 = S[_S_J01]
    a21 = S[_S_J10]
    a22 = S[_S_J11]
    if mode == _MODE_HEAVY:
        eps = 1.0 / S[_S_MC]
        a11 += eps
        a22 += eps
    det = a11 * a22 - a12 * a21
    f0 = -(a22 * apx - a12 * apz) / det
    f1 = -(a11 * apz - a21 * apx) / det
    for j in range(n + 1):
        x[j] += X[0, j] * f0 + X[1, j] * f1


@nb.njit(cache=True)
def _dk_product(
    arr: np.ndarray,
    par: np.ndarray,
    hg: float,
    W: np.ndarray,
    rd: np.ndarray,
    rk: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out = hg D rd + hg K rk`` with the local ``D``, ``K`` of the factorisation in W."""
    n = arr.shape[1]
    l = arr[0]
    jk = arr[3]
    jc = arr[4]
    drag = int(par[1])
    hk = par[5]
    hc = par[6]
    cth = W[_W_COS]
    sth = W[_W_SIN]
    gta = W[_W_GT]
    gea = W[_W_GE]
    drot = W[_W_DROT]
    kg = W[_W_KGEO]
    out[0] = hg * (hc * rd[0] + hk * rk[0])
    # joint torques tau_i on relative angles; Q_i = tau_i - tau_{i+1}
    pd = 0.0
    pk = 0.0
    for i in range(n):
        out[i + 1] = hg * (jc[i] * (rd[i + 1] - pd) + jk[i] * (rk[i + 1] - pk))
        pd = rd[i + 1]
        pk = rk[i + 1]
    for i in range(n - 1):
        out[i + 1] -= out[i + 2]
    for i in range(n):
        out[i + 1] += drot[i] * rd[i + 1] + kg[i] * rk[i + 1]
    if drag == 2:
        # centre "velocities" J_c rd, forces hg G J_c rd, generalised by J_c^T (reverse sums)
        fxa = np.empty(n)
        fza = np.empty(n)
        vx = 0.0
        vz = rd[0]
        for i in range(n):
            c = cth[i]
            s = sth[i]
            hl = 0.5 * l[i] * rd[i + 1]
            ux = vx + hl * c
            uz = vz + hl * s
            ft = gta[i] * (ux * c + uz * s)
            fe = gea[i] * (ux * s - uz * c)
            fxa[i] = ft * c + fe * s
            fza[i] = ft * s - fe * c
            vx += l[i] * c * rd[i + 1]
            vz += l[i] * s * rd[i + 1]
        sx = 0.0
        sz = 0.0
        for i in range(n - 1, -1, -1):
            out[i + 1] += l[i] * (cth[i] * (0.5 * fxa[i] + sx) + sth[i] * (0.5 * fza[i] + sz))
            sx += fxa[i]
            sz += fza[i]
        out[0] += sz


@nb.njit(cache=True)
def _kgeo_from_forces(arr: np.ndarray, q: np.ndarray, F: np.ndarray, kgeo: np.ndarray) -> None:
    """Tension stiffness ``kappa_i = max(0, l_i T_i)``, T_i the mean axial tension of link i."""
    n = arr.shape[1]
    l = arr[0]
    for i in range(n):
        s = np.sin(q[i + 1])
        c = np.cos(q[i + 1])
        # axial tension at the top (-F_i . e) and bottom (-F_{i+1} . e) of link i, e = (s, -c)
        t = -0.5 * ((F[i, 0] + F[i + 1, 0]) * s - (F[i, 1] + F[i + 1, 1]) * c)
        kgeo[i] = max(0.0, l[i] * t)


@nb.njit(cache=True)
def _implicit_run(
    arr: np.ndarray,
    par: np.ndarray,
    scheme: int,
    gamma: float,
    geometric: bool,
    h: float,
    u: np.ndarray,
    eta: np.ndarray,
    y: np.ndarray,
    chk: np.ndarray,
    info: np.ndarray,
) -> int:
    """``u.shape[0]`` steps of the linearly implicit Euler (scheme 0) or ROS2 (scheme 1).

    ``u[k] = (u(t_k), u(t_k + h))`` (one column suffices for scheme 0), likewise ``eta``.
    Each step is followed by the compiled check (:func:`cable_sim.core.kernel.check_packed`). On
    failure ``y`` keeps the last good state, ``info[1]`` is the failed step's index and the
    status is returned. ``info[0]`` counts the force evaluations.
    """
    n = arr.shape[1]
    n1 = n + 1
    n2 = 2 * n1
    W = np.zeros((_NW, n))
    S = np.zeros(_NS)
    X = np.zeros((2, n1))
    kgeo = np.zeros(n)
    a1 = np.empty(n1)
    a2 = np.empty(n1)
    lam = np.empty(2)
    rd = np.empty(n1)
    rk = np.empty(n1)
    rhs = np.empty(n1)
    x = np.empty(n1)
    k1q = np.empty(n1)
    k1v = np.empty(n1)
    q2 = np.empty(n1)
    v2 = np.empty(n1)
    rqa = np.empty(n1)
    yn = np.empty(n2)
    hg = gamma * h
    last = u.shape[1] - 1
    for k in range(u.shape[0]):
        info[1] = k
        q = y[:n1]
        v = y[n1:]
        if not _fast.fd_packed(arr, par, u[k, 0], eta[k, 0], q, v, a1, lam):
            return _fast.STATUS_SINGULAR
        info[0] += 1
        if geometric:
            F = _fast.joint_forces_packed(arr, par, lam[0], lam[1], q, v, a1)
            _kgeo_from_forces(arr, q, F, kgeo)
        if not _op_factor(arr, par, q, v, hg, kgeo, W, S, X):
            return _fast.STATUS_SINGULAR
        for j in range(n1):
            rd[j] = a1[j]
            rk[j] = v[j] + hg * a1[j]
        _dk_product(arr, par, hg, W, rd, rk, rhs)
        _op_solve(arr, par, W, S, X, rhs, x)
        for j in range(n1):
            k1v[j] = a1[j] - x[j]
        if scheme == 0:
            for j in range(n1):
                yn[n1 + j] = v[j] + h * k1v[j]
                yn[j] = q[j] + h * yn[n1 + j]
        else:
            for j in range(n1):
                k1q[j] = v[j] + hg * k1v[j]
                q2[j] = q[j] + h * k1q[j]
                v2[j] = v[j] + h * k1v[j]
            if not _fast.fd_packed(arr, par, u[k, last], eta[k, last], q2, v2, a2, lam):
                return _fast.STATUS_SINGULAR
            info[0] += 1
            for j in range(n1):
                rqa[j] = v2[j] - 2.0 * k1q[j]
                rd[j] = a2[j] - 2.0 * k1v[j]
                rk[j] = rqa[j] + hg * rd[j]
            _dk_product(arr, par, hg, W, rd, rk, rhs)
            _op_solve(arr, par, W, S, X, rhs, x)
            for j in range(n1):
                k2v = rd[j] - x[j]
                k2q = rqa[j] + hg * k2v
                yn[j] = q[j] + 1.5 * h * k1q[j] + 0.5 * h * k2q
                yn[n1 + j] = v[j] + 1.5 * h * k1v[j] + 0.5 * h * k2v
        status = _fast.check_packed(arr, par, yn, chk, info)
        if status != _fast.STATUS_OK:
            return status
        y[:] = yn
    return _fast.STATUS_OK


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


def _factor_fast(model: CableModel, q: np.ndarray, qd: np.ndarray, hg: float,
                 kgeo: np.ndarray | None):
    arr, par = _fast.pack_arrays(model)
    n = model.n
    W = np.zeros((_NW, n))
    S = np.zeros(_NS)
    X = np.zeros((2, n + 1))
    kg = np.zeros(n) if kgeo is None else np.ascontiguousarray(kgeo, dtype=float)
    ok = _op_factor(arr, par, np.ascontiguousarray(q, dtype=float),
                    np.ascontiguousarray(qd, dtype=float), float(hg), kg, W, S, X)
    return arr, par, W, S, X, ok


def operator_solve(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    hg: float,
    rhs: np.ndarray,
    kgeo: np.ndarray | None = None,
) -> np.ndarray:
    """Solve ``(M + hg D + hg^2 K) x = rhs`` in O(n) (anchored end: subject to ``J x = 0``).

    Parameters
    ----------
    model : CableModel
    q, qd : ndarray (n+1,)
        State at which ``M``, ``D`` (drag linearisation) are evaluated.
    hg : float
        ``gamma h`` [s]; 0 gives the plain mass matrix.
    rhs : ndarray (n+1,)
        Generalised force.
    kgeo : ndarray (n,), optional
        Tension stiffness per link (see :func:`geometric_stiffness`); zero if omitted.

    Returns
    -------
    x : ndarray (n+1,)

    Raises
    ------
    numpy.linalg.LinAlgError
        If the anchored end's 2x2 Schur matrix is singular.
    """
    arr, par, W, S, X, ok = _factor_fast(model, q, qd, hg, kgeo)
    if not ok:
        raise np.linalg.LinAlgError("singular anchor constraint matrix J M~^-1 J^T")
    x = np.empty(model.ndof)
    _op_solve(arr, par, W, S, X, np.ascontiguousarray(rhs, dtype=float), x)
    return x


def operator_product(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    hg: float,
    rd: np.ndarray,
    rk: np.ndarray,
    kgeo: np.ndarray | None = None,
) -> np.ndarray:
    """``hg D rd + hg K rk`` in O(n) (the local damping and stiffness of the operator)."""
    arr, par, W, S, X, _ = _factor_fast(model, q, qd, hg, kgeo)
    out = np.empty(model.ndof)
    _dk_product(arr, par, float(hg), W, np.ascontiguousarray(rd, dtype=float),
                np.ascontiguousarray(rk, dtype=float), out)
    return out


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
    return M, D, K


def _dense_solve(model: CableModel, q: np.ndarray, Mt: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``Mt x = rhs`` (anchored: with ``J x = 0``) densely, heave lock respected."""
    s = 1 if model.heave_locked else 0
    x = np.zeros(model.ndof)
    A = Mt[s:, s:]
    if model.constrained:
        J = dynamics.constraint_jacobian(model, q)[:, s:]
        k = A.shape[0]
        kkt = np.zeros((k + 2, k + 2))
        kkt[:k, :k] = A
        kkt[:k, k:] = J.T
        kkt[k:, :k] = J
        sol = np.linalg.solve(kkt, np.concatenate([rhs[s:], np.zeros(2)]))
        x[s:] = sol[:k]
    else:
        x[s:] = np.linalg.solve(A, rhs[s:])
    return x


# --------------------------------------------------------------------------------------------
# Integrators
# --------------------------------------------------------------------------------------------


class _LinearlyImplicit(Integrator):
    """Shared machinery: compiled fast path, dense fallback, batched :meth:`advance`."""

    scheme = 0
    stages = 1

    def __init__(
        self,
        system: CableSystem,
        step: float = 1e-2,
        gamma: float = 1.0,
        geometric_stiffness: bool = True,
        **kwargs,
    ) -> None:
        if not (np.isfinite(gamma) and gamma > 0):
            raise ValueError(f"parameter 'gamma' = {gamma!r} is invalid; allowed: finite number > 0")
        self.gamma = float(gamma)
        self.geometric = bool(geometric_stiffness)
        super().__init__(system, step=step, **kwargs)

    # ---- fast path ---------------------------------------------------------------------
    def _fast_kernel(self, arr, par, h, u, eta, y, chk, info) -> int:
        return _implicit_run(arr, par, self.scheme, self.gamma, self.geometric, h, u, eta, y,
                             chk, info)

    # ---- dense fallback ----------------------------------------------------------------
    def _dense_step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        sys_ = self.system
        model = sys_.model
        n1 = model.ndof
        q, v = y[:n1], y[n1:]
        hg = self.gamma * h
        a1, lam = sys_.accelerations(t, y)
        sys_.nfev += 1
        kgeo = None
        if self.geometric:
            F = dynamics.joint_forces(model, q, v, a1, lam)
            kgeo = geometric_stiffness(model, q, F)
        M, D, K = dense_operator(model, q, v, kgeo)
        Mt = M + hg * D + hg * hg * K

        def solve(rd: np.ndarray, rk: np.ndarray) -> np.ndarray:
            return _dense_solve(model, q, Mt, hg * (D @ rd) + hg * (K @ rk))

        k1v = a1 - solve(a1, v + hg * a1)
        if self.stages == 1:
            vn = v + h * k1v
            return np.concatenate([q + h * vn, vn])
        k1q = v + hg * k1v
        y2 = np.concatenate([q + h * k1q, v + h * k1v])
        a2, _ = sys_.accelerations(t + h, y2)
        sys_.nfev += 1
        rq = y2[n1:] - 2.0 * k1q
        rv = a2 - 2.0 * k1v
        k2v = rv - solve(rv, rq + hg * rv)
        k2q = rq + hg * k2v
        return np.concatenate([q + 1.5 * h * k1q + 0.5 * h * k2q, v + 1.5 * h * k1v + 0.5 * h * k2v])

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        return self._dense_step(t, y, h)

class LinearlyImplicitEuler(_LinearlyImplicit):
    """Linearly implicit Euler with the local O(n) operator ``M + hD + h^2K``.

    Order 1. One force evaluation and one O(n) solve per step:
    ``(M + hD + h^2K) a* = f(q, v) - hK v``, ``v' = v + h a*``, ``q' = q + h v'``. For the terms
    in ``D`` and ``K`` (joint springs/dampers, heave spring/damper, paper or Morison drag,
    tension stiffness) it is implicit Euler: L-stable, no step limit from them, but it damps
    fast physical modes by O(h). For the rest it is symplectic Euler (stable for
    ``h omega < 2``). MuJoCo's "implicitfast" is the same idea.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    geometric_stiffness : bool
        Include the tension stiffness in ``K`` (default True).
    max_drift, taut_slack, max_condition : float
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "implicit_euler"
    order = 1
    scheme = 0
    stages = 1
    _fast_offsets = (0.0,)

    def __init__(self, system: CableSystem, step: float = 1e-2, geometric_stiffness: bool = True,
                 **kwargs) -> None:
        super().__init__(system, step=step, gamma=1.0, geometric_stiffness=geometric_stiffness,
                         **kwargs)


class Rosenbrock2(_LinearlyImplicit):
    """Two-stage Rosenbrock W-method ROS2 with the local O(n) operator.

    Order 2 for any approximation ``W`` of the Jacobian (a W-method), hence order 2 with the
    local ``D``, ``K``. With ``hg = gamma h`` and ``S(r) = (M + hg D + hg^2 K)^-1 r``::

        k1v = a(t, q, v) - S(hg D a + hg K (v + hg a)),     k1q = v + hg k1v
        (q2, v2) = (q, v) + h (k1q, k1v)
        rq = v2 - 2 k1q,  rv = a(t + h, q2, v2) - 2 k1v
        k2v = rv - S(hg D rv + hg K (rq + hg rv)),          k2q = rq + hg k2v
        (q', v') = (q, v) + 1.5 h (k1q, k1v) + 0.5 h (k2q, k2v)

    Stability: L-stable for the part in ``W`` (stability function
    ``(1 + (1 - 2 gamma) z) / (1 - gamma z)^2``, A-stable for gamma >= 1/4); the velocity-product
    remainder is treated like Heun's method. Two force evaluations, one O(n) factorisation
    and two O(n) solves per step.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    gamma : float
        ``1 - 1/sqrt(2)`` (default, smaller error constant) or ``1 + 1/sqrt(2)`` (Verwer et al.).
    geometric_stiffness : bool
        Include the tension stiffness in ``K`` (default True).
    max_drift, taut_slack, max_condition : float
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "rosenbrock2"
    order = 2
    scheme = 1
    stages = 2
    _fast_offsets = (0.0, 1.0)

    def __init__(self, system: CableSystem, step: float = 1e-2, gamma: float = 1.0 - 1.0 / np.sqrt(2.0),
                 geometric_stiffness: bool = True, **kwargs) -> None:
        super().__init__(system, step=step, gamma=gamma, geometric_stiffness=geometric_stiffness,
                         **kwargs)


#: Implicit integrators by name (merged into :func:`cable_sim.integrate.registry.make_integrator`).
INTEGRATORS: dict[str, type[Integrator]] = {
    "implicit_euler": LinearlyImplicitEuler,
    "rosenbrock2": Rosenbrock2,
}
