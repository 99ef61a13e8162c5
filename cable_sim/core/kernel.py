"""O(n) compiled forward dynamics of the n-link cable (same contract as :mod:`cable_sim.core.dynamics`).

The dense reference builds ``M(q)`` and factors it (O(n^3)). This module solves the same
equations of motion in O(n) per call with an articulated-body recursion specialised to the
planar chain of ``MODEL.md``:

* the base is the platform, a point mass ``M`` on a vertical prismatic joint (``z_m``);
* link i hangs from a pin at joint ``p_{i-1}``; a pin transmits no moment besides the joint
  spring/damper torque, so the articulated inertia seen *at a pin* is a 2x2 matrix ``A_i``
  relating the force the parent exerts on the subtree to the acceleration of the pin:
  ``f_i = A_i a_{i-1} + b_i``;
* the terminal load is a point mass at ``p_n`` (``A_{n+1} = m_c I``; but see "heavy load").

Backward sweep (tip to platform), for link i with centre of mass at mid-length, unit axis
``e_i = (sin theta_i, -cos theta_i)`` and ``t_i = (cos theta_i, sin theta_i)`` (note
``e x u = t . u`` in the x-z plane), from each link's Newton equation and its moment equation
about ``p_{i-1}``::

    D_i = m l^2/3 + l^2 t^T A t          h_i = l A t + (m l / 2) t
    R_i = -tau_i + tau_{i+1} + C_i + (l/2) t.G_i + l^2 w^2 t^T A e - l t.b
    A_i = m I + A - h h^T / D            b_i = b - G_i - w^2 (m l/2 e + l A e) + h R / D

(``A``, ``b`` of link i+1; ``G_i`` the weight-minus-buoyancy plus Morison drag on the centre,
``C_i`` the paper drag couple, ``tau_i = k_i phi_i + c_i phi_dot_i`` the joint torque on the
relative angle). Forward sweep: the platform ``(M + A_1,zz) zdd = Q_0 - b_1,z`` (or ``zdd = 0``
when heave-locked), then ``theta_dd_i = (R_i - h_i . a_{i-1}) / D_i`` and
``a_i = a_{i-1} + l (t theta_dd_i - e w^2)``. The recursion yields the *absolute* angle
accelerations directly.

Anchored end: the exact constraint ``p_n = anchor`` is enforced by the Schur complement. The
articulated inertias do not depend on the applied forces, so the same sweep also propagates two
extra right-hand sides (a unit force at ``p_n`` along x and z with zero velocity and gravity),
giving ``X = M^-1 J^T`` and ``J X`` (the end accelerations) in O(n); then
``lambda = (J X)^-1 (gamma - J qdd_free)`` with the dense solver's Baumgarte ``gamma``.

Heavy load (the paper's 8e8 kg anchor emulation, or any load heavier than the line): putting
``m_c I`` into the recursion makes the articulated inertias m_c-sized while the physics lives in
their differences, costing ~m_c/m_link of the precision. Instead the load's inertia ``m_c J^T J``
is added by Woodbury with the same two unit-force solves:
``qdd = qdd_s + X f``, ``f = -(J X + I/m_c)^-1 a_end,s`` (subscript s: the line with a massless
load that keeps its weight). This is exact algebra and leaves every intermediate quantity of
the line's own scale; measured against a 40-digit solve it is accurate to ~1e-15, whereas the
dense float64 Cholesky of the ill-conditioned M is off by up to ~1e-6 at n = 60.

All kernels take plain arrays and floats (numba cannot take the dataclass) and are compiled
with ``cache=True``; call :func:`warmup` once before real time starts.
"""

from __future__ import annotations

import weakref

import numba as nb
import numpy as np

from cable_sim.core.dynamics import NO_INPUT, Inputs
from cable_sim.core.model import CableModel

__all__ = [
    "Inputs",
    "NO_INPUT",
    "forward_dynamics",
    "state_derivative",
    "joint_forces",
    "energy",
    "warmup",
]


# --------------------------------------------------------------------------------------------
# Compiled kernels
# --------------------------------------------------------------------------------------------


#: Magnitude below which the unit-force right-hand sides are flushed to zero (see _fd_kernel).
_TINY = 1e-150
_EPS = float(np.finfo(np.float64).eps)


@nb.njit(cache=True, inline="always")
def _articulated_inertia(
    mi: float, x: float, y: float, z: float, xp: float, c: float, s: float
) -> tuple[float, float, float]:
    """New articulated inertia A' = m I + A - h h^T / D of a link, world-frame (xx, xz, zz).

    Assembled in the link frame (t, e) to avoid cancellation in the t direction,
    A' = a_tt t t^T + a_te (t e^T + e t^T) + a_ee e e^T, then rotated to the world frame.
    """
    a_tt = mi * (x / 3.0 + mi / 12.0) / xp
    a_te = -y * (mi / 6.0) / xp
    a_ee = mi + z - y * y / xp
    axx = a_tt * c * c + 2.0 * a_te * c * s + a_ee * s * s
    axz = a_tt * c * s + a_te * (s * s - c * c) - a_ee * s * c
    azz = a_tt * s * s - 2.0 * a_te * s * c + a_ee * c * c
    return axx, axz, azz


@nb.njit(cache=True)
def _link_drag(
    c: float,
    s: float,
    vcx: float,
    vcz: float,
    cn: float,
    ct: float,
) -> tuple[float, float]:
    """Morison force on one link centre (same arithmetic as the dense ``link_drag_forces``)."""
    vt_mag = vcx * s - vcz * c  # e = (s, -c)
    vtx = vt_mag * s
    vtz = -vt_mag * c
    vnx = vcx - vtx
    vnz = vcz - vtz
    vn_mag = np.hypot(vnx, vnz)
    fx = -cn * vn_mag * vnx - ct * abs(vt_mag) * vtx
    fz = -cn * vn_mag * vnz - ct * abs(vt_mag) * vtz
    return fx, fz


@nb.njit(cache=True)
def _fd_kernel(
    l: np.ndarray,
    m: np.ndarray,
    mw: np.ndarray,
    jk: np.ndarray,
    jc: np.ndarray,
    gl2: np.ndarray,
    cn: np.ndarray,
    ct: np.ndarray,
    current: float,
    drag: int,
    mc: float,
    mcw: float,
    mp: float,
    hk: float,
    hc: float,
    locked: bool,
    wave: bool,
    g: float,
    constrained: bool,
    ax: float,
    az: float,
    balpha: float,
    bbeta: float,
    u: float,
    eta: float,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    lam: np.ndarray,
) -> bool:
    """Articulated-body forward dynamics; writes ``qdd`` and ``lam``.

    Returns False if the 2x2 constraint matrix is singular to working precision (anchored end).
    """
    n = l.shape[0]
    cth = np.empty(n)
    sth = np.empty(n)
    fgx = np.zeros(n)  # applied force on each link centre (weight - buoyancy + drag)
    fgz = np.empty(n)
    cpl = np.zeros(n)  # applied couple on each link (paper drag)
    tau = np.empty(n + 1)  # joint torques tau_1..tau_n, tau_{n+1} = 0
    for i in range(n):
        cth[i] = np.cos(q[i + 1])
        sth[i] = np.sin(q[i + 1])
        fgz[i] = -mw[i] * g
    # joint-local spring/damper torques on relative angles (joint 1 relative to the vertical)
    th_prev = 0.0
    w_prev = 0.0
    for i in range(n):
        tau[i] = jk[i] * (q[i + 1] - th_prev) + jc[i] * (qd[i + 1] - w_prev)
        th_prev = q[i + 1]
        w_prev = qd[i + 1]
    tau[n] = 0.0
    # hydrodynamic drag
    if drag == 1:
        for i in range(n):
            w = qd[i + 1]
            cpl[i] = -gl2[i] * w * abs(w)
    elif drag == 2:
        vx = 0.0
        vz = qd[0]
        for i in range(n):
            hl = 0.5 * l[i] * qd[i + 1]
            vcx = vx + hl * cth[i] - current
            vcz = vz + hl * sth[i]
            fx, fz = _link_drag(cth[i], sth[i], vcx, vcz, cn[i], ct[i])
            fgx[i] += fx
            fgz[i] += fz
            vx += l[i] * cth[i] * qd[i + 1]
            vz += l[i] * sth[i] * qd[i + 1]

    # ---- backward sweep: articulated inertias (force-independent) and bias forces ----------
    # A heavy load (paper anchor: 8e8 kg) is not put into the recursion as A_{n+1} = m_c I: the
    # articulated inertias would then carry m_c-sized terms whose differences are the physical
    # answer (cancellation).  Instead the load's inertia m_c J^T J is added by Woodbury (below),
    # with the same two unit-force solves as the anchor constraint.  A single link on a locked
    # platform keeps the direct form (J M^-1 J^T is then singular; the recursion is exact there).
    line_mass = 0.0
    for i in range(n):
        line_mass += m[i]
    heavy = (not constrained) and mc > line_mass and not (locked and n == 1)
    nrhs = 3 if (constrained or heavy) else 1
    dd = np.empty(n)
    hx = np.empty(n)
    hz = np.empty(n)
    rr = np.empty((nrhs, n))
    mload = 0.0 if heavy else mc
    axx = mload
    axz = 0.0
    azz = mload
    bx = np.zeros(nrhs)
    bz = np.zeros(nrhs)
    bz[0] = mcw * g
    if nrhs == 3:
        bx[1] = -1.0  # unit external force +x on p_n: the link exerts -F on "the end"
        bz[2] = -1.0
    for i in range(n - 1, -1, -1):
        c = cth[i]
        s = sth[i]
        li = l[i]
        mi = m[i]
        w2 = qd[i + 1] * qd[i + 1]
        # A t and A e, with e = (s, -c)
        atx = axx * c + axz * s
        atz = axz * c + azz * s
        aex = axx * s - axz * c
        aez = axz * s - azz * c
        # quadratic forms written so that an isotropic A (the load, m_c I) gives y = 0 exactly
        cs = c * s
        x = axx * c * c + 2.0 * axz * cs + azz * s * s  # t^T A t
        y = (axx - azz) * cs + axz * (s * s - c * c)  # t^T A e
        z = axx * s * s - 2.0 * axz * cs + azz * c * c  # e^T A e
        xp = x + mi / 3.0
        d = li * li * xp
        h_x = li * atx + 0.5 * mi * li * c
        h_z = li * atz + 0.5 * mi * li * s
        dd[i] = d
        hx[i] = h_x
        hz[i] = h_z
        # applied-force right-hand side (rhs 0 only)
        r0 = (
            -tau[i]
            + tau[i + 1]
            + cpl[i]
            + 0.5 * li * (c * fgx[i] + s * fgz[i])
            + li * li * w2 * y
            - li * (c * bx[0] + s * bz[0])
        )
        rr[0, i] = r0
        bx[0] += -fgx[i] - w2 * (0.5 * mi * li * s + li * aex) + h_x * r0 / d
        bz[0] += -fgz[i] - w2 * (-0.5 * mi * li * c + li * aez) + h_z * r0 / d
        for k in range(1, nrhs):
            rk = -li * (c * bx[k] + s * bz[k])
            rr[k, i] = rk
            bx[k] += h_x * rk / d
            bz[k] += h_z * rk / d
            # A unit end force on a line without tension (zero velocity and gravity in these
            # solves) decays geometrically up the line; flush it to zero long before it turns
            # subnormal (subnormal arithmetic is ~100x slower). 1e-150 of the unit force.
            if abs(bx[k]) + abs(bz[k]) < _TINY:
                bx[k] = 0.0
                bz[k] = 0.0
        # new articulated inertia A' = m I + A - h h^T / D (see _articulated_inertia)
        axx, axz, azz = _articulated_inertia(mi, x, y, z, xp, c, s)

    # ---- forward sweep ---------------------------------------------------------------------
    q0 = u - hk * q[0] - hc * qd[0]
    if wave:
        q0 += hk * eta
    endx = np.zeros(nrhs)
    endz = np.zeros(nrhs)
    sol = np.zeros((nrhs, n + 1))
    for k in range(nrhs):
        if locked:
            zdd = 0.0
        else:
            f0 = q0 if k == 0 else 0.0
            zdd = (f0 - bz[k]) / (mp + azz)
        sol[k, 0] = zdd
        apx = 0.0
        apz = zdd
        for i in range(n):
            li = l[i]
            alpha = (rr[k, i] - hx[i] * apx - hz[i] * apz) / dd[i]
            sol[k, i + 1] = alpha
            w2 = qd[i + 1] * qd[i + 1] if k == 0 else 0.0
            apx += li * (cth[i] * alpha - sth[i] * w2)
            apz += li * (sth[i] * alpha + cth[i] * w2)
        endx[k] = apx
        endz[k] = apz

    for j in range(n + 1):
        qdd[j] = sol[0, j]
    lam[0] = 0.0
    lam[1] = 0.0
    if heavy:
        # (M_s + m_c J^T J) qdd = Q  =>  qdd = qdd_s + X f,  f = -(J X + I/m_c)^-1 a_end,s
        # (f: the load's inertial force on the line end; X = M_s^-1 J^T; a_end,s = J qdd_s + bias)
        eps = 1.0 / mc
        a11 = endx[1] + eps
        a12 = endx[2]
        a21 = endz[1]
        a22 = endz[2] + eps
        det = a11 * a22 - a12 * a21
        f0 = -(a22 * endx[0] - a12 * endz[0]) / det
        f1 = -(a11 * endz[0] - a21 * endx[0]) / det
        for j in range(n + 1):
            qdd[j] += sol[1, j] * f0 + sol[2, j] * f1
        return True
    if not constrained:
        return True

    # ---- anchor constraint: Schur complement ---------------------------------------------
    # J qdd_free, Phi, Phi_dot = J qd, bias = (dJ/dt) qd -- as in the dense solver
    jx = 0.0
    jz = qdd[0]
    px = 0.0
    pz = q[0]
    vx = 0.0
    vz = qd[0]
    biasx = 0.0
    biasz = 0.0
    for i in range(n):
        li = l[i]
        c = cth[i]
        s = sth[i]
        w = qd[i + 1]
        jx += li * c * qdd[i + 1]
        jz += li * s * qdd[i + 1]
        px += li * s
        pz -= li * c
        vx += li * c * w
        vz += li * s * w
        biasx -= li * s * w * w
        biasz += li * c * w * w
    gx = -biasx - 2.0 * balpha * vx - bbeta * bbeta * (px - ax)
    gz = -biasz - 2.0 * balpha * vz - bbeta * bbeta * (pz - az)
    rx = gx - jx
    rz = gz - jz
    # J M^-1 J^T: column k is the end acceleration under unit force k
    a11 = endx[1]
    a12 = endx[2]
    a21 = endz[1]
    a22 = endz[2]
    det = a11 * a22 - a12 * a21
    # numerically singular (e.g. one link on a locked platform: 1 dof, 2 constraints)
    if abs(det) <= 4.0 * _EPS * (abs(a11 * a22) + abs(a12 * a21)):
        return False
    l0 = (a22 * rx - a12 * rz) / det
    l1 = (a11 * rz - a21 * rx) / det
    lam[0] = l0
    lam[1] = l1
    for j in range(n + 1):
        qdd[j] += sol[1, j] * l0 + sol[2, j] * l1
    return True


@nb.njit(cache=True)
def _energy_kernel(
    l: np.ndarray,
    m: np.ndarray,
    mw: np.ndarray,
    jk: np.ndarray,
    mc: float,
    mcw: float,
    mp: float,
    hk: float,
    g: float,
    q: np.ndarray,
    qd: np.ndarray,
) -> tuple[float, float]:
    """Kinetic and potential energy in O(n) from link-centre velocities and heights."""
    n = l.shape[0]
    vx = 0.0
    vz = qd[0]
    pz = q[0]
    t_kin = 0.5 * mp * qd[0] * qd[0]
    v_grav = 0.0
    v_spr = 0.5 * hk * q[0] * q[0]
    th_prev = 0.0
    for i in range(n):
        li = l[i]
        c = np.cos(q[i + 1])
        s = np.sin(q[i + 1])
        w = qd[i + 1]
        vcx = vx + 0.5 * li * c * w
        vcz = vz + 0.5 * li * s * w
        t_kin += 0.5 * m[i] * (vcx * vcx + vcz * vcz) + 0.5 * (m[i] * li * li / 12.0) * w * w
        pz_next = pz - li * c
        v_grav += mw[i] * 0.5 * (pz + pz_next)
        phi = q[i + 1] - th_prev
        v_spr += 0.5 * jk[i] * phi * phi
        th_prev = q[i + 1]
        pz = pz_next
        vx += li * c * w
        vz += li * s * w
    t_kin += 0.5 * mc * (vx * vx + vz * vz)
    v_grav += mcw * pz
    return t_kin, g * v_grav + v_spr


@nb.njit(cache=True)
def _joint_forces_kernel(
    l: np.ndarray,
    m: np.ndarray,
    mw: np.ndarray,
    cn: np.ndarray,
    ct: np.ndarray,
    current: float,
    drag: int,
    mc: float,
    mcw: float,
    g: float,
    constrained: bool,
    lamx: float,
    lamz: float,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
) -> np.ndarray:
    """Joint forces by the Newton recursion from the end (see ``dynamics.joint_forces``)."""
    n = l.shape[0]
    acx = np.empty(n)  # link-centre accelerations
    acz = np.empty(n)
    dfx = np.zeros(n)  # Morison drag on the centres
    dfz = np.zeros(n)
    # joint accelerations summed in the dense order (cumulative sum, platform added last) so
    # that the load force m_c a_n, which is a cancellation for a heavy load, rounds alike
    ax = 0.0
    az = 0.0
    vx = 0.0
    vz = qd[0]
    for i in range(n):
        li = l[i]
        c = np.cos(q[i + 1])
        s = np.sin(q[i + 1])
        w = qd[i + 1]
        a = qdd[i + 1]
        ax_next = ax + li * (c * a - s * w * w)
        az_next = az + li * (s * a + c * w * w)
        acx[i] = 0.5 * (ax + ax_next)
        acz[i] = 0.5 * ((az + qdd[0]) + (az_next + qdd[0]))
        ax = ax_next
        az = az_next
        if drag == 2:
            hl = 0.5 * li * w
            fx, fz = _link_drag(c, s, vx + hl * c - current, vz + hl * s, cn[i], ct[i])
            dfx[i] = fx
            dfz[i] = fz
        vx += li * c * w
        vz += li * s * w
    out = np.zeros((n + 1, 2))
    if constrained:
        out[n, 0] = -lamx
        out[n, 1] = -lamz
    else:
        out[n, 0] = mc * ax
        out[n, 1] = mc * (az + qdd[0]) + mcw * g
    fx = out[n, 0]
    fz = out[n, 1]
    for i in range(n - 1, -1, -1):
        fx += m[i] * acx[i] - dfx[i]
        fz += m[i] * acz[i] - dfz[i] + mw[i] * g
        out[i, 0] = fx
        out[i, 1] = fz
    return out


# --------------------------------------------------------------------------------------------
# Python wrappers
# --------------------------------------------------------------------------------------------

_PACK_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _arr(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _pack(model: CableModel) -> tuple:
    """Plain-typed model data for the kernels (cached per model object)."""
    try:
        return _PACK_CACHE[model]
    except (KeyError, TypeError):
        pass
    fd = (
        _arr(model.length),
        _arr(model.mass),
        _arr(model.weight_mass),
        _arr(model.joint_k),
        _arr(model.joint_c),
        _arr(model.drag_gamma_l2),
        _arr(model.morison_cn),
        _arr(model.morison_ct),
        float(model.current),
        int(model.drag),
        float(model.load_mass),
        float(model.load_weight_mass),
        float(model.platform_mass),
        float(model.heave_k),
        float(model.heave_c),
        bool(model.heave_locked),
        bool(model.wave_coupling),
        float(model.gravity),
        bool(model.constrained),
        float(model.anchor[0]),
        float(model.anchor[1]),
        float(model.baumgarte_alpha),
        float(model.baumgarte_beta),
    )
    try:
        _PACK_CACHE[model] = fd
    except TypeError:
        pass
    return fd


def _vec(x: np.ndarray, size: int, name: str) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.shape != (size,):
        raise ValueError(f"{name} has shape {a.shape}; expected ({size},)")
    return a


def forward_dynamics(
    model: CableModel, q: np.ndarray, qd: np.ndarray, inputs: Inputs = NO_INPUT
) -> tuple[np.ndarray, np.ndarray]:
    """Generalised accelerations and anchor reaction in O(n) (articulated-body recursion).

    Same contract as :func:`cable_sim.core.dynamics.forward_dynamics`.

    Parameters
    ----------
    model : CableModel
        Immutable model.
    q, qd : ndarray (n+1,)
        Generalised positions ``[z_m, theta_1..theta_n]`` and velocities.
    inputs : Inputs, optional
        Heave force and wave elevation (held).

    Returns
    -------
    qdd : ndarray (n+1,)
        Generalised accelerations (``qdd[0] = 0`` when heave-locked).
    anchor_force : ndarray (2,)
        Force (x, z) [N] the anchor exerts on the cable end (zeros unless anchored).

    Raises
    ------
    numpy.linalg.LinAlgError
        If the anchored end's 2x2 matrix ``J M^-1 J^T`` is singular to working precision
        (e.g. one link on a heave-locked platform: one dof against two constraints).
    """
    k = model.n + 1
    qv = _vec(q, k, "q")
    qdv = _vec(qd, k, "qd")
    qdd = np.empty(k)
    lam = np.empty(2)
    ok = _fd_kernel(
        *_pack(model),
        float(inputs.heave_force),
        float(inputs.wave_elevation),
        qv,
        qdv,
        qdd,
        lam,
    )
    if not ok:
        raise np.linalg.LinAlgError("singular anchor constraint matrix J M^-1 J^T")
    return qdd, lam


def state_derivative(model: CableModel, y: np.ndarray, inputs: Inputs = NO_INPUT) -> np.ndarray:
    """Time derivative of the state ``y = [q, qd]`` using the O(n) kernel.

    Parameters
    ----------
    model : CableModel
        Immutable model.
    y : ndarray (2(n+1),)
        State ``[q, qd]``.
    inputs : Inputs, optional
        Heave force and wave elevation (held).

    Returns
    -------
    ydot : ndarray (2(n+1),)
        ``[qd, qdd]``.
    """
    k = model.n + 1
    y = np.asarray(y, dtype=np.float64)
    if y.shape != (2 * k,):
        raise ValueError(f"y has shape {y.shape}; expected ({2 * k},)")
    qdd, _ = forward_dynamics(model, y[:k], y[k:], inputs)
    return np.concatenate([y[k:], qdd])


def joint_forces(
    model: CableModel,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    anchor_force: np.ndarray | None = None,
) -> np.ndarray:
    """Internal joint forces from each link's Newton equation, O(n), compiled.

    Same contract as :func:`cable_sim.core.dynamics.joint_forces`.

    Parameters
    ----------
    model : CableModel
        Immutable model.
    q, qd, qdd : ndarray (n+1,)
        Generalised positions, velocities and accelerations.
    anchor_force : ndarray (2,), optional
        Anchor reaction (anchored end); zeros if omitted.

    Returns
    -------
    F : ndarray (n+1, 2)
        ``F[i]`` (i = 0..n-1) is the force [N] that link i (the platform for i = 0) exerts on
        link i+1 at joint i; ``F[n]`` is the force link n exerts on what is at its end (the
        load, or the anchor: ``-anchor_force``).
    """
    k = model.n + 1
    p = _pack(model)
    lamx, lamz = (0.0, 0.0) if anchor_force is None else (float(anchor_force[0]),
                                                          float(anchor_force[1]))
    return _joint_forces_kernel(
        p[0], p[1], p[2], p[6], p[7], p[8], p[9], p[10], p[11], p[17], p[18], lamx, lamz,
        _vec(q, k, "q"), _vec(qd, k, "qd"), _vec(qdd, k, "qdd"),
    )


def energy(model: CableModel, q: np.ndarray, qd: np.ndarray) -> tuple[float, float]:
    """Kinetic and potential energy in O(n).

    Parameters
    ----------
    model : CableModel
        Immutable model.
    q, qd : ndarray (n+1,)
        Generalised positions and velocities.

    Returns
    -------
    T : float
        Kinetic energy ``1/2 qd^T M(q) qd`` [J], summed from link-centre velocities, link
        spins, the platform and the load.
    V : float
        Potential energy [J], as :func:`cable_sim.core.dynamics.potential_energy`.
    """
    k = model.n + 1
    p = _pack(model)
    t_kin, v_pot = _energy_kernel(
        p[0], p[1], p[2], p[3], p[10], p[11], p[12], p[13], p[17],
        _vec(q, k, "q"), _vec(qd, k, "qd"),
    )
    return float(t_kin), float(v_pot)


def warmup() -> None:
    """Compile (or load from the on-disk cache) every kernel on a tiny model.

    Call once at start-up, before real time starts, so the first real step is not a compile.
    """
    from cable_sim.core.params import CableParams

    for end, drag in (("free", "morison"), ("anchored", "paper")):
        p = CableParams(n_links=2, drag_model=drag, end_condition=end, current_speed=0.1,
                        anchor_x=10.0, anchor_z=-200.0)
        model = CableModel.from_params(p)
        q = np.array([0.0, 0.3, 0.2])
        qd = np.array([0.1, -0.2, 0.05])
        qdd, lam = forward_dynamics(model, q, qd, Inputs(1.0, 0.1))
        joint_forces(model, q, qd, qdd, lam)
        energy(model, q, qd)
        state_derivative(model, np.concatenate([q, qd]))



# --------------------------------------------------------------------------------------------
# Compiled stepping helpers (issue #5: per-step Python overhead). Additive: everything above is
# unchanged. A model is passed to these as two arrays, so that calling a compiled stepper costs
# a handful of argument conversions instead of ~30.
# --------------------------------------------------------------------------------------------

#: Status codes returned by the compiled steppers and checks.
STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_DRIFT = 2
STATUS_TAUT = 3
STATUS_SINGULAR = 4
STATUS_ILL_CONDITIONED = 5
STATUS_UNSTABLE = 6
STATUS_ENERGY_JUMP = 7
STATUS_OSCILLATION = 8

#: Runaway detector of :func:`check_packed`: a step's velocity increment larger than the
#: previous one by this factor, ...
OSC_GROWTH = 1.5
#: ... this many steps in a row, ...
OSC_STEPS = 3
#: ... each above ``OSC_ACCEL g h / l_min`` (an angular acceleration ten times a link's
#: pendulum scale), is a numerically unstable mode growing geometrically (|R(h lambda)| > 1).
OSC_ACCEL = 10.0

#: Rows of the per-link array returned by :func:`pack_arrays`.
_ARR_ROWS = 8


def pack_arrays(model: CableModel) -> tuple[np.ndarray, np.ndarray]:
    """The model as two arrays for the compiled steppers (cached per model object).

    Returns
    -------
    arr : ndarray (8, n)
        Rows: l, m, m~, k, c, gamma l^2/4, Morison c_n, Morison c_t.
    par : ndarray (17,)
        current, drag code, m_c, m~_c, M, k_m, c_m, heave_locked, wave_coupling, g,
        constrained, anchor x, anchor z, Baumgarte alpha, beta, end code, total length.
    """
    try:
        return _ARRAYS_CACHE[model]
    except (KeyError, TypeError):
        pass
    p = _pack(model)
    arr = np.ascontiguousarray(np.stack(p[:8]), dtype=np.float64)
    par = np.array(
        [p[8], p[9], p[10], p[11], p[12], p[13], p[14], float(p[15]), float(p[16]), p[17],
         float(p[18]), p[19], p[20], p[21], p[22], float(model.end), float(np.sum(model.length))],
        dtype=np.float64,
    )
    try:
        _ARRAYS_CACHE[model] = (arr, par)
    except TypeError:
        pass
    return arr, par


_ARRAYS_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@nb.njit(cache=True)
def fd_packed(
    arr: np.ndarray,
    par: np.ndarray,
    u: float,
    eta: float,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    lam: np.ndarray,
) -> bool:
    """:func:`_fd_kernel` on the packed model (same arithmetic, same results)."""
    return _fd_kernel(
        arr[0], arr[1], arr[2], arr[3], arr[4], arr[5], arr[6], arr[7],
        par[0], int(par[1]), par[2], par[3], par[4], par[5], par[6], par[7] != 0.0,
        par[8] != 0.0, par[9], par[10] != 0.0, par[11], par[12], par[13], par[14],
        u, eta, q, qd, qdd, lam,
    )


@nb.njit(cache=True)
def joint_forces_packed(
    arr: np.ndarray,
    par: np.ndarray,
    lamx: float,
    lamz: float,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
) -> np.ndarray:
    """:func:`_joint_forces_kernel` on the packed model."""
    return _joint_forces_kernel(
        arr[0], arr[1], arr[2], arr[6], arr[7], par[0], int(par[1]), par[2], par[3], par[9],
        par[10] != 0.0, lamx, lamz, q, qd, qdd,
    )


@nb.njit(cache=True)
def project_packed(arr: np.ndarray, par: np.ndarray, y: np.ndarray, tol: float) -> None:
    """In-place projection onto Phi(q) = 0 and Phi_q qd = 0.

    The algorithm of :func:`cable_sim.core.system.project_constraint` (at most 5 Gauss-Newton steps
    ``dq = -J^T (J J^T)^-1 Phi`` on the free coordinates, then the least-squares velocity
    projection), O(n).
    """
    n = arr.shape[1]
    l = arr[0]
    n1 = n + 1
    s0 = 1 if par[7] != 0.0 else 0
    ax = par[11]
    az = par[12]
    big = par[16]
    for _ in range(5):
        px = 0.0
        pz = y[0]
        for i in range(n):
            px += l[i] * np.sin(y[i + 1])
            pz -= l[i] * np.cos(y[i + 1])
        fx = px - ax
        fz = pz - az
        if np.hypot(fx, fz) <= tol * big:
            break
        # J J^T over the free coordinates
        a11 = 0.0
        a12 = 0.0
        a22 = 1.0 if s0 == 0 else 0.0
        for i in range(n):
            jx = l[i] * np.cos(y[i + 1])
            jz = l[i] * np.sin(y[i + 1])
            a11 += jx * jx
            a12 += jx * jz
            a22 += jz * jz
        det = a11 * a22 - a12 * a12
        mx = (a22 * fx - a12 * fz) / det
        mz = (a11 * fz - a12 * fx) / det
        if s0 == 0:
            y[0] -= mz
        for i in range(n):
            y[i + 1] -= l[i] * np.cos(y[i + 1]) * mx + l[i] * np.sin(y[i + 1]) * mz
    a11 = 0.0
    a12 = 0.0
    a22 = 1.0 if s0 == 0 else 0.0
    vx = 0.0
    vz = y[n1] if s0 == 0 else 0.0
    for i in range(n):
        jx = l[i] * np.cos(y[i + 1])
        jz = l[i] * np.sin(y[i + 1])
        a11 += jx * jx
        a12 += jx * jz
        a22 += jz * jz
        vx += jx * y[n1 + i + 1]
        vz += jz * y[n1 + i + 1]
    det = a11 * a22 - a12 * a12
    mx = (a22 * vx - a12 * vz) / det
    mz = (a11 * vz - a12 * vx) / det
    if s0 == 0:
        y[n1] -= mz
    for i in range(n):
        y[n1 + i + 1] -= l[i] * np.cos(y[i + 1]) * mx + l[i] * np.sin(y[i + 1]) * mz


@nb.njit(cache=True)
def end_drift_packed(arr: np.ndarray, par: np.ndarray, y: np.ndarray) -> float:
    """|p_n - anchor| [m]."""
    n = arr.shape[1]
    l = arr[0]
    px = 0.0
    pz = y[0]
    for i in range(n):
        px += l[i] * np.sin(y[i + 1])
        pz -= l[i] * np.cos(y[i + 1])
    return np.hypot(px - par[11], pz - par[12])


@nb.njit(cache=True)
def schur_packed(arr: np.ndarray, par: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``J M^-1 J^T`` (2x2, end accelerations per unit end force) in O(n), load excluded.

    The same backward/forward sweep as :func:`_fd_kernel` with its two unit-force right-hand
    sides (zero velocity and gravity); the terminal load is not included (as for the anchored
    end and the heavy-load Woodbury form).
    """
    n = arr.shape[1]
    l = arr[0]
    m = arr[1]
    mp = par[4]
    locked = par[7] != 0.0
    cth = np.empty(n)
    sth = np.empty(n)
    dd = np.empty(n)
    hx = np.empty(n)
    hz = np.empty(n)
    rr = np.empty((2, n))
    axx = 0.0
    axz = 0.0
    azz = 0.0
    bx = np.zeros(2)
    bz = np.zeros(2)
    bx[0] = -1.0
    bz[1] = -1.0
    for i in range(n - 1, -1, -1):
        c = np.cos(q[i + 1])
        s = np.sin(q[i + 1])
        cth[i] = c
        sth[i] = s
        li = l[i]
        mi = m[i]
        atx = axx * c + axz * s
        atz = axz * c + azz * s
        cs = c * s
        x = axx * c * c + 2.0 * axz * cs + azz * s * s
        y = (axx - azz) * cs + axz * (s * s - c * c)
        z = axx * s * s - 2.0 * axz * cs + azz * c * c
        xp = x + mi / 3.0
        d = li * li * xp
        h_x = li * atx + 0.5 * mi * li * c
        h_z = li * atz + 0.5 * mi * li * s
        dd[i] = d
        hx[i] = h_x
        hz[i] = h_z
        for k in range(2):
            rk = -li * (c * bx[k] + s * bz[k])
            rr[k, i] = rk
            bx[k] += h_x * rk / d
            bz[k] += h_z * rk / d
            if abs(bx[k]) + abs(bz[k]) < _TINY:
                bx[k] = 0.0
                bz[k] = 0.0
        axx, axz, azz = _articulated_inertia(mi, x, y, z, xp, c, s)
    out = np.empty((2, 2))
    for k in range(2):
        zdd = 0.0 if locked else -bz[k] / (mp + azz)
        apx = 0.0
        apz = zdd
        for i in range(n):
            alpha = (rr[k, i] - hx[i] * apx - hz[i] * apz) / dd[i]
            apx += l[i] * cth[i] * alpha
            apz += l[i] * sth[i] * alpha
        out[0, k] = apx
        out[1, k] = apz
    return out


@nb.njit(cache=True)
def condition_2x2(a11: float, a12: float, a21: float, a22: float) -> float:
    """2-norm condition number of a 2x2 matrix (inf if singular)."""
    # singular values from the Frobenius norm and the determinant
    fro2 = a11 * a11 + a12 * a12 + a21 * a21 + a22 * a22
    det = abs(a11 * a22 - a12 * a21)
    disc = np.sqrt(max(fro2 * fro2 - 4.0 * det * det, 0.0))
    smax2 = 0.5 * (fro2 + disc)
    if det == 0.0 or smax2 == 0.0:
        return np.inf
    smin2 = det * det / smax2
    return np.sqrt(smax2 / smin2)


def schur_condition(model: CableModel, q: np.ndarray) -> float:
    """Condition number of the anchored end's 2x2 ``J M^-1 J^T`` (load excluded), O(n).

    Grows without bound as the line is pulled straight (kinematic singularity); the
    integrators stop when it exceeds their ``max_condition``.
    """
    arr, par = pack_arrays(model)
    s = schur_packed(arr, par, np.ascontiguousarray(q, dtype=float))
    return float(condition_2x2(s[0, 0], s[0, 1], s[1, 0], s[1, 1]))


@nb.njit(cache=True)
def check_packed(
    arr: np.ndarray, par: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray
) -> int:
    """The integrator's per-step check, compiled: finite, project (anchored), drift, slack,
    Schur conditioning. ``chk = [max_drift, taut_slack, projection tol, max Schur condition,
    slack below which the Schur condition is checked]``. Modifies ``y`` (projection); on failure
    writes the offending value to ``info[2]`` and returns a status code.

    ``chk[5]`` (when present) is a kinetic-energy bound [J]: the lower bound of the kinetic
    energy ``1/2 M zd^2 + sum 1/2 (m_i l_i^2 / 12) thd_i^2`` (platform + link rotation) above it
    returns ``STATUS_UNSTABLE`` (numerical instability), checked last so that a taut anchored
    line still reports its snap load. O(n) multiply-adds.

    ``chk[6]`` (when present and finite) is the mechanical energy of the previous accepted
    state [J] and ``chk[7]`` the largest increase allowed over one step [J]: a larger increase
    returns ``STATUS_ENERGY_JUMP`` (energy increase in ``info[2]``); on success ``chk[6]``
    becomes the new state's energy. One O(n) energy evaluation.

    ``chk[8:]`` (when ``chk`` has ``11 + 2 (n+1)`` entries) is the runaway detector's memory:
    ``[count, valid, floor, previous qd (n+1), previous qd increment (n+1)]``. A velocity
    increment ``d_k`` with ``|d_k| > OSC_GROWTH |d_(k-1)|`` and ``|d_k| > floor`` for
    ``OSC_STEPS`` steps in a row returns ``STATUS_OSCILLATION`` (growth factor in ``info[2]``):
    a mode growing geometrically at every step is the signature of a scheme beyond its
    stability limit (RK4's R(z) > 1 for real z < -2.79, sign-alternating for explicit Euler). O(n)."""
    for v in y:
        if not np.isfinite(v):
            return STATUS_NONFINITE
    if par[10] != 0.0:
        project_packed(arr, par, y, chk[2])
        for v in y:
            if not np.isfinite(v):
                return STATUS_NONFINITE
        drift = end_drift_packed(arr, par, y)
        if drift > chk[0]:
            info[2] = drift
            return STATUS_DRIFT
    if par[15] != 0.0:
        slack = 1.0 - np.hypot(par[11], y[0] - par[12]) / par[16]
        if slack < chk[1]:
            info[2] = slack
            return STATUS_TAUT
        if slack < chk[4]:
            n1 = y.shape[0] // 2
            s = schur_packed(arr, par, y[:n1])
            cond = condition_2x2(s[0, 0], s[0, 1], s[1, 0], s[1, 1])
            if cond > chk[3]:
                info[2] = cond
                return STATUS_ILL_CONDITIONED
    if chk.shape[0] > 5:
        n1 = y.shape[0] // 2
        l = arr[0]
        m = arr[1]
        tlb = 0.5 * par[4] * y[n1] * y[n1]
        for i in range(n1 - 1):
            w = y[n1 + 1 + i]
            tlb += m[i] * l[i] * l[i] * w * w / 24.0
        if tlb > chk[5]:
            info[2] = tlb
            return STATUS_UNSTABLE
    if chk.shape[0] > 7 and np.isfinite(chk[6]):
        n1 = y.shape[0] // 2
        t_kin, v_pot = _energy_kernel(arr[0], arr[1], arr[2], arr[3], par[2], par[3], par[4],
                                      par[5], par[9], y[:n1], y[n1:])
        e_new = t_kin + v_pot
        if e_new - chk[6] > chk[7]:
            info[2] = e_new - chk[6]
            return STATUS_ENERGY_JUMP
        chk[6] = e_new
    return oscillation_packed(y, chk, info)


@nb.njit(cache=True)
def oscillation_packed(y: np.ndarray, chk: np.ndarray, info: np.ndarray) -> int:
    """The oscillation detector of :func:`check_packed` on its memory ``chk[8:]`` (no-op
    unless ``chk`` has ``11 + 2 (n+1)`` entries); updates the memory when the state passes;
    on failure the growth factor is in ``info[2]``."""
    n1 = y.shape[0] // 2
    if chk.shape[0] != 11 + 2 * n1:
        return STATUS_OK
    o = 11
    if chk[9] >= 1.0:
        dd = 0.0
        pp = 0.0
        for j in range(n1):
            d = y[n1 + j] - chk[o + j]
            p = chk[o + n1 + j]
            dd += d * d
            pp += p * p
        if chk[9] >= 2.0 and dd > OSC_GROWTH * OSC_GROWTH * pp and dd > chk[10] * chk[10]:
            if chk[8] + 1.0 >= OSC_STEPS:
                info[2] = np.sqrt(dd / pp)
                return STATUS_OSCILLATION
            chk[8] += 1.0
        else:
            chk[8] = 0.0
        for j in range(n1):
            chk[o + n1 + j] = y[n1 + j] - chk[o + j]
        chk[9] = 2.0
    else:
        chk[9] = 1.0
    for j in range(n1):
        chk[o + j] = y[n1 + j]
    return STATUS_OK


@nb.njit(cache=True)
def rk4_run(
    arr: np.ndarray,
    par: np.ndarray,
    h: float,
    u: np.ndarray,
    eta: np.ndarray,
    y: np.ndarray,
    chk: np.ndarray,
    info: np.ndarray,
) -> int:
    """``u.shape[0]`` classical RK4 steps of size h, each followed by :func:`check_packed`.

    ``u[k] = (u(t_k), u(t_k + h/2), u(t_k + h))`` and likewise ``eta``. On success ``y`` holds
    the final state; on failure the last good state, ``info[1]`` the index of the failed step
    and the status code is returned. The arithmetic is that of ``integrators.RK4._step``.
    """
    n2 = y.shape[0]
    n1 = n2 // 2
    k1 = np.empty(n2)
    k2 = np.empty(n2)
    k3 = np.empty(n2)
    k4 = np.empty(n2)
    ys = np.empty(n2)
    yn = np.empty(n2)
    qdd = np.empty(n1)
    lam = np.empty(2)
    hh = h / 2
    h6 = h / 6
    for k in range(u.shape[0]):
        info[1] = k
        # k1
        if not fd_packed(arr, par, u[k, 0], eta[k, 0], y[:n1], y[n1:], qdd, lam):
            return STATUS_SINGULAR
        k1[:n1] = y[n1:]
        k1[n1:] = qdd
        for j in range(n2):
            ys[j] = y[j] + hh * k1[j]
        if not fd_packed(arr, par, u[k, 1], eta[k, 1], ys[:n1], ys[n1:], qdd, lam):
            return STATUS_SINGULAR
        k2[:n1] = ys[n1:]
        k2[n1:] = qdd
        for j in range(n2):
            ys[j] = y[j] + hh * k2[j]
        if not fd_packed(arr, par, u[k, 1], eta[k, 1], ys[:n1], ys[n1:], qdd, lam):
            return STATUS_SINGULAR
        k3[:n1] = ys[n1:]
        k3[n1:] = qdd
        for j in range(n2):
            ys[j] = y[j] + h * k3[j]
        if not fd_packed(arr, par, u[k, 2], eta[k, 2], ys[:n1], ys[n1:], qdd, lam):
            return STATUS_SINGULAR
        k4[:n1] = ys[n1:]
        k4[n1:] = qdd
        for j in range(n2):
            yn[j] = y[j] + h6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j])
        status = check_packed(arr, par, yn, chk, info)
        if status != STATUS_OK:
            return status
        y[:] = yn
    return STATUS_OK


@nb.njit(cache=True)
def symplectic_euler_run(
    arr: np.ndarray,
    par: np.ndarray,
    h: float,
    u: np.ndarray,
    eta: np.ndarray,
    y: np.ndarray,
    chk: np.ndarray,
    info: np.ndarray,
) -> int:
    """``u.shape[0]`` symplectic Euler steps (``u[k] = u(t_k)``), each checked; as
    :func:`rk4_run`. Arithmetic of ``integrators.SemiImplicitEuler._step``."""
    n2 = y.shape[0]
    n1 = n2 // 2
    qdd = np.empty(n1)
    lam = np.empty(2)
    yn = np.empty(n2)
    for k in range(u.shape[0]):
        info[1] = k
        if not fd_packed(arr, par, u[k], eta[k], y[:n1], y[n1:], qdd, lam):
            return STATUS_SINGULAR
        for j in range(n1):
            yn[n1 + j] = y[n1 + j] + h * qdd[j]
            yn[j] = y[j] + h * yn[n1 + j]
        status = check_packed(arr, par, yn, chk, info)
        if status != STATUS_OK:
            return status
        y[:] = yn
    return STATUS_OK
