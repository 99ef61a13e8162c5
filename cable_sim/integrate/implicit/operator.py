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
not centred), added to the link's own in :func:`_op_inward`. Left out (the operator of a
W-method need not be the exact Jacobian): the part of ``-dQ_b/dq`` from turning ``J^T``
(diagonal in absolute angles, like gravity's; the bed's reaction lowers the tension and with it
the tension stiffness), the damper's ``d zdot/dq`` (velocity times curvature), the jump of the
damper's force where a link moving down enters the bed, and friction (off by default).
That is the operator at ``horizon = 0`` (:func:`operator_solve`, :func:`operator_product`).
The schemes pass their step as the horizon: then ``[a, b]`` is the smallest interval holding
the part of the link in the bed now and at ``q + h qd``, the damper's cut ignored, so that a
link touching down or rising out of the bed during the step is already stiff in W (without
it the mooring line's implicit runs were limited to about the RK4 step, see
:func:`_contact_terms`).

The articulated inertia seen at a pin is then 3x3 instead of
the 2x2 of the forward dynamics; the inward recursion (:func:`_op_inward`) is specific to it,
everything else -- link kinematics, drag velocities, the link-frame transforms, the outward
acceleration sweep, the Woodbury choice, the 2x2 end correction -- is the shared implementation
of :mod:`cable_sim.core.kernel.links`, :mod:`cable_sim.core.kernel.frames` and
:mod:`cable_sim.core.kernel.sweeps`.

Factorisation workspace: ``W`` (``_NW`` rows of n per-link values), ``S`` (``_NS`` scalars),
``X`` (the two unit end-force solutions ``M~^-1 J^T``, anchored end or heavy load); the solve
and the product also use W's scratch rows, so nothing is allocated per call.

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` (contact, packing,
sweeps) and :mod:`cable_sim.core.model`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.contact import touching_interval
from cable_sim.core.kernel.frames import relative_trig, to_parent_frame, to_world
from cable_sim.core.kernel.links import (
    centre_velocity,
    from_link_frame,
    joint_torque,
    link_frame_velocity,
    link_trig,
    next_pin_velocity,
    woodbury_load,
)
from cable_sim.core.kernel.packing import ARR_MK, pack_arrays
from cable_sim.core.kernel.sweeps import _K_IL2, TINY, add_columns, outward_sweep, singular_2x2, solve_2x2
from cable_sim.core.model import CableModel

#: 1/12 (a multiply per link instead of a division: equal to round-off).
_TWELFTH = 1.0 / 12.0

# rows of the per-link workspace W (n columns; _W_D holds 1/D_i); _W_CA, _W_CB: the link's
# seabed contact interval; _W_PX, _W_PZ: scratch of the product (per-link forces of the Morison
# and contact terms)
(_W_COS, _W_SIN, _W_D, _W_UX, _W_UZ, _W_BETA, _W_ROT, _W_GT, _W_GE, _W_BCN, _W_DROT, _W_KGEO,
 _W_CA, _W_CB, _W_PX, _W_PZ) = range(16)
_NW = 16
# entries of the scalar workspace S
_S_BETA0, _S_AZZ, _S_J00, _S_J01, _S_J10, _S_J11, _S_MODE, _S_MC = range(8)
_NS = 8
_MODE_NONE, _MODE_CONSTRAINED, _MODE_HEAVY = 0.0, 1.0, 2.0


# --------------------------------------------------------------------------------------------
# Factorisation: per-link terms, inward 3x3 sweep, unit end forces
# --------------------------------------------------------------------------------------------


@nb.njit(cache=True, inline="always")
def _link_terms(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray, hg: float,
                kgeo: np.ndarray, W: np.ndarray, horizon: float) -> None:
    """Per-link terms of ``M~`` at (q, qd) into W (whose cos/sin rows already hold those of
    q): joint armature ``beta``, extra rotational inertia (paper drag ``drot``, tension
    stiffness ``kg``), extra centre masses ``g_t, g_e`` (the Jacobian of the Morison force:
    ``2 c_n |v.t|``, ``2 c_t |v.e|``)."""
    n = arr.shape[1]
    l = arr[0]
    jk = arr[3]
    jc = arr[4]
    gl2 = arr[5]
    cn = arr[6]
    ct = arr[7]
    current = par[0]
    drag = int(par[1])
    hg2 = hg * hg
    beta = W[_W_BETA]
    kg = W[_W_KGEO]
    drot = W[_W_DROT]
    gt = W[_W_GT]
    ge = W[_W_GE]
    rot = W[_W_ROT]
    # the drag model chosen once (not per link): one short loop each, without branches
    for i in range(n):
        beta[i] = hg * jc[i] + hg2 * jk[i]
        kg[i] = hg * kgeo[i]
    if drag == 1:
        for i in range(n):
            drot[i] = hg * 2.0 * gl2[i] * abs(qd[i + 1])
    else:
        for i in range(n):
            drot[i] = 0.0
    if drag == 2:
        vx = 0.0
        vz = qd[0]
        for i in range(n):
            c = W[_W_COS, i]
            s = W[_W_SIN, i]
            w = qd[i + 1]
            vcx, vcz = centre_velocity(vx, vz, l[i], c, s, w, current)
            vt, ve = link_frame_velocity(vcx, vcz, c, s)  # normal (along t), axial (along e)
            gt[i] = hg * 2.0 * cn[i] * abs(vt)
            ge[i] = hg * 2.0 * ct[i] * abs(ve)
            vx, vz = next_pin_velocity(vx, vz, l[i], c, s, w)
    else:
        for i in range(n):
            gt[i] = 0.0
            ge[i] = 0.0
    for i in range(n):
        rot[i] = drot[i] + hg * kg[i]
    _contact_terms(arr, par, q, qd, W, horizon)


@nb.njit(cache=True, inline="always")
def _contact_terms(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray,
                   W: np.ndarray, horizon: float) -> None:
    """Each link's seabed contact interval ``[a, b]`` into W (``a = b = 0`` without; not
    written without a seabed, where nothing reads them).

    ``horizon`` = 0: where the bed pushes on the link at (q, qd)
    (:func:`cable_sim.core.kernel.contact.touching_interval`), so that the operator is the
    contact force's Jacobian there. ``horizon`` > 0 (the schemes pass their step h): the smallest
    interval holding the part in the bed now and the part in the bed at the extrapolated state
    ``q + horizon qd``, whatever the damper does. A W-method keeps its order for any W; this one
    is stiff wherever the bed can push during the step: a link about to touch down (the damper's
    force jumps to ``c_b |zdot|`` where a link enters the bed) and a link rising out of it (the
    damper cancels the spring while it rises fast, then the spring is back)."""
    n = arr.shape[1]
    l = arr[0]
    if par[17] == 0.0:  # no seabed: the rows are not read (:func:`_op_inward`, :func:`_dk_product`)
        return
    zb = par[18]
    kb = arr[8]
    cb = arr[9]
    pz = q[0]
    vz = qd[0]
    pze = q[0] + horizon * qd[0]  # the joint's z at the extrapolated state q + horizon qd
    for i in range(n):
        c = W[_W_COS, i]
        s = W[_W_SIN, i]
        w = qd[i + 1]
        if horizon > 0.0:
            # in the bed now, and at the extrapolated state (k = 1, c = 0: the force is delta)
            a, b = touching_interval(pz, 0.0, q[i + 1], 0.0, l[i], zb, 1.0, 0.0)
            the = q[i + 1] + horizon * w
            ap, bp = touching_interval(pze, 0.0, the, 0.0, l[i], zb, 1.0, 0.0)
            pze -= l[i] * np.cos(the)
            if b <= a:
                a, b = ap, bp
            elif bp > ap:
                a = min(a, ap)
                b = max(b, bp)
        else:
            a, b = touching_interval(pz, vz, q[i + 1], w, l[i], zb, kb[i], cb[i])
        W[_W_CA, i] = a
        W[_W_CB, i] = b
        pz -= l[i] * c
        vz += l[i] * s * w


@nb.njit(cache=True, inline="always")
def _contact_moments(a: float, b: float) -> tuple[float, float, float]:
    """``int_a^b (1, s, s^2) ds`` written without cancellation."""
    h = b - a
    return h, 0.5 * h * (a + b), h * ((a + b) * (a + b) + a * a + b * b) / 6.0


@nb.njit(cache=True, inline="always")
def _op_inward(arr: np.ndarray, W: np.ndarray, mload: float, hg: float, contact: bool) -> float:
    """The 3x3 articulated inertias ``[[c, w^T], [w, A]]``, tip to platform; fills ``1/D_i`` and
    ``u_i`` (world frame) in W and returns the platform's ``A_zz`` (see :func:`_op_factor`).
    A and w stay in each link's frame; the parent turns them into its own by the relative
    angle (:func:`cable_sim.core.kernel.frames.to_parent_frame`).

    ``contact`` (a constant at each call: the model has a seabed) adds the contact intervals'
    terms; without, they are left out of the arithmetic (not added as zeros). The factors off
    the recursion's chain are formed ahead (``u^2/l^2``, ``beta u/l^2``, ...), so that on the
    chain the new inertia costs the rotation, one division and one product."""
    n = arr.shape[1]
    l = arr[0]
    m = arr[12]  # link mass seen along the normal (m + m_an l with added mass)
    ma = arr[13]  # and along the axis (m + m_at l)
    il2a = arr[ARR_MK + _K_IL2]  # 1/l^2
    kb = arr[8]  # seabed stiffness and damping per length (contact interval in W)
    cb = arr[9]
    hg2 = hg * hg
    cth = W[_W_COS]
    sth = W[_W_SIN]
    beta = W[_W_BETA]
    rot = W[_W_ROT]
    # the child's A and w in the child's frame (the load's A is isotropic: any frame), turned
    # into each link's frame by the relative angle (one rotation on the recursion's chain)
    pa = mload
    ra = 0.0
    ua = mload
    cc = 0.0
    wtc = 0.0
    wec = 0.0
    cp = 1.0
    sp = 0.0
    for i in range(n - 1, -1, -1):
        c = cth[i]
        s = sth[i]
        li = l[i]
        mi = m[i]
        il2 = il2a[i]
        il = li * il2
        if i == n - 1:
            p_tt, r_te, s_ee = pa, ra, ua
            wt, we = wtc, wec
        else:
            cr, sr = relative_trig(c, s, cp, sp)
            p_tt, r_te, s_ee = to_parent_frame(pa, ra, ua, cr, sr)
            wt = cr * wtc + sr * wec
            we = cr * wec - sr * wtc
        cp = c
        sp = s
        mt = mi + W[_W_GT, i]
        me = ma[i] + W[_W_GE, i]
        bi = beta[i]
        bl = bi * il2
        ip0 = mi * _TWELFTH + rot[i] * il2
        ip = ip0 + bl  # rotational inertia about the centre / l^2
        cw = cc * il2
        ww = wt * il  # the reciprocal off the recursion's chain
        e0 = ip0 + 0.25 * mt  # (D - beta) / l^2 without the child: off the chain
        if contact:
            # seabed: a world-z mass of density kap = hg c_b + hg^2 k_b on the contact
            # interval; in the t direction (z.t = s) its mass, moments / l, l^2 and the centred
            # forms
            za, zb_ = W[_W_CA, i], W[_W_CB, i]
            mz = 0.0
            s1 = 0.0
            q0 = 0.0
            q1 = 0.0
            q2 = 0.0
            qc = 0.0
            qv = 0.0
            qm = 0.0
            qq = 0.0
            if zb_ > za:
                kap = hg * cb[i] + hg2 * kb[i]
                h0, h1, h2 = _contact_moments(za, zb_)
                mz = kap * h0
                s1 = kap * h1
                ks = kap * s * s
                q0 = ks * h0
                q1 = ks * h1 * il
                q2 = ks * h2 * il2
                qc = ks * _contact_moments(za - 0.5 * li, zb_ - 0.5 * li)[2] * il2  # about the centre
                qv = ks * ks * h0 * h0 * h0 * h0 * il2 / 12.0  # q0 q2 - q1^2
                qm = q0 * (1.0 - 0.5 * (za + zb_) / li)  # q0 - q1
                qq = ks * _contact_moments(1.0 - zb_ / li, 1.0 - za / li)[2] * li  # q0 + q2 - 2 q1
            en = (e0 + q2) + (cw + 2.0 * ww) + p_tt  # (D - beta) / l^2
            ut = li * (0.5 * mt + q1 + p_tt) + wt
            ue = we + li * r_te - s1 * s * c
            m0 = mt + q0
            num = (m0 * ip + mt * qc + qv + m0 * cw + 2.0 * ww * (0.5 * mt + qm)
                   + p_tt * (ip + 0.25 * mt + qq) + (p_tt * cw - ww * ww))
            rz = r_te - mz * s * c
            uz = me + mz * c * c + s_ee
        else:
            en = e0 + (cw + 2.0 * ww) + p_tt  # (D - beta) / l^2
            ut = li * (0.5 * mt + p_tt) + wt
            ue = we + li * r_te
            num = (mt * ip + mt * cw + ww * mt + p_tt * (ip + 0.25 * mt) + (p_tt * cw - ww * ww))
            rz = r_te
            uz = me + s_ee
        idn = 1.0 / (en + bl)  # l^2 / D: the one division per link
        inv_d = idn * il2
        # the numerators known before 1/D (formed while it is computed): on the chain one
        # product each
        pa = num * idn
        ra = rz - (ut * ue * il2) * idn
        ua = uz - (ue * ue * il2) * idn
        uxw, uzw = from_link_frame(ut, ue, c, s)
        W[_W_D, i] = inv_d
        W[_W_UX, i] = uxw
        W[_W_UZ, i] = uzw
        # rotational coupling passed to the parent (zero without armature), link frame:
        # beta (D - beta) / D (D - beta a sum of non-negative terms), beta u / D
        cc = (bi * en) * idn
        wtc = (bl * ut) * idn
        wec = (bl * ue) * idn
        # cross terms decaying geometrically along a straight stretch: flushed at TINY of the
        # inertia / coupling before they turn subnormal (as in sweeps.inward_sweep: every
        # 16th link)
        if i & 15 == 0:
            if abs(ra) < TINY * (abs(pa) + abs(ua)):
                ra = 0.0
            if abs(wec) < TINY * abs(wtc):
                wec = 0.0
    if n == 0:
        return mload
    return to_world(pa, ra, ua, cp, sp)[2]


@nb.njit(cache=True, inline="always")
def _op_rhs_inward(l: np.ndarray, W: np.ndarray, rhs: np.ndarray, use_rhs: bool, bx: float,
                   bz: float, rr: np.ndarray) -> tuple[float, float]:
    """Inward sweep of one right-hand side through a factorisation: a generalised force ``rhs``
    (``use_rhs``) or a unit end force (``bx, bz`` at the end; flushed at TINY). Stores ``-b_i``
    in ``rr`` (read by the outward sweep) and returns the force on the platform."""
    cth = W[_W_COS]
    sth = W[_W_SIN]
    idd = W[_W_D]
    uxa = W[_W_UX]
    uza = W[_W_UZ]
    beta = W[_W_BETA]
    bn = 0.0
    for i in range(l.shape[0] - 1, -1, -1):
        # the factors known ahead (l t, u/D, beta/D) formed off the recursion's chain: on it
        # b costs a product and two sums, the new end force a product and a sum
        ltx = l[i] * cth[i]
        ltz = l[i] * sth[i]
        inv_d = idd[i]
        if use_rhs:
            b = (bn - rhs[i + 1]) + (ltx * bx + ltz * bz)
        else:
            b = bn + (ltx * bx + ltz * bz)
        rr[i] = -b
        bn = (beta[i] * inv_d) * b
        bx -= (uxa[i] * inv_d) * b
        bz -= (uza[i] * inv_d) * b
        if not use_rhs and abs(bx) + abs(bz) + abs(bn) < TINY:
            bn = 0.0
            bx = 0.0
            bz = 0.0
    return bx, bz


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _op_unit_forces(arr: np.ndarray, par: np.ndarray, W: np.ndarray, S: np.ndarray,
                    X: np.ndarray) -> None:
    """``X = M~^-1 J^T`` (two unit end forces, +x and +z) and ``J X`` into S."""
    l = arr[0]
    locked = par[7] != 0.0
    mp = par[4]
    for k in range(2):
        bx, bz = _op_rhs_inward(l, W, X[k], False, -1.0 if k == 0 else 0.0,
                                0.0 if k == 0 else -1.0, X[k, 1:])
        zdd = 0.0 if locked else -bz / (mp + S[_S_BETA0] + S[_S_AZZ])
        # column k of J X: (J00, J10) for k = 0 -> stored J00, J01 = row 0
        S[_S_J00 + k], S[_S_J10 + k] = outward_sweep(
            l, W[_W_COS], W[_W_SIN], X[k], False, W[_W_BETA], True, X[k, 1:], W[_W_UX],
            W[_W_UZ], W[_W_D], zdd, X[k])


@nb.njit(cache=True)
def _op_factor(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray, hg: float,
               kgeo: np.ndarray, W: np.ndarray, S: np.ndarray, X: np.ndarray,
               horizon: float) -> bool:
    """Articulated inertias of ``M~ = M + hg D + hg^2 K`` at (q, qd); fills W, S, X (the
    links' cos/sin first, then :func:`_op_factor_trig`)."""
    link_trig(q, W[_W_COS], W[_W_SIN])
    return _op_factor_trig(arr, par, q, qd, hg, kgeo, W, S, X, horizon)


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _op_factor_trig(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray, hg: float,
                    kgeo: np.ndarray, W: np.ndarray, S: np.ndarray, X: np.ndarray,
                    horizon: float) -> bool:
    """Articulated inertias of ``M~ = M + hg D + hg^2 K`` at (q, qd); fills W, S, X. W's rows
    ``_W_COS``, ``_W_SIN`` must hold the cos/sin of the links' angles ``q[1:]`` already (the
    compiled runs copy those of the forward dynamics at the same q).

    ``horizon`` (the step h in the schemes; 0: the Jacobian at (q, qd) itself): the seabed
    contact's terms cover the part of each link in the bed now or at ``q + horizon qd``
    (see :func:`_contact_terms`).

    Backward sweep (tip to platform). For the subtree below pin p_{i-1} the 3x3 articulated
    inertia maps the parent's (angular acceleration, pin acceleration) to the (couple, force)
    the parent applies: ``[[c, w^T], [w, A]]``. For link i (axis e, normal t, length l, mass m,
    extra rotational inertia rho, extra centre masses g_t, g_e along t, e, joint armature beta)
    with the child's ``c, w, A`` expressed in the link frame (P = t.A.t, R = t.A.e, ...):

        D   = m l^2/12 + rho + beta + l^2 (m+g_t)/4 + c + 2 l w_t + l^2 P
        u   = (l (m+g_t)/2 + w_t + l P) t + (w_e + l R) e        (couple-force coupling)
        A'  = diag_te(m+g_t, m+g_e) + A - u u^T / D,   w' = beta u / D,  c' = beta (D - beta) / D

    with ``A'_tt`` assembled from non-negative terms (no cancellation; it reduces to the fast
    kernel's ``a_tt`` when beta = rho = g = 0). The seabed contact's vertical mass (density
    kap on ``[a, b]``; in the link frame z = sin(theta) t - cos(theta) e) adds its moments
    ``kap int (1, s, s^2)`` to the link's (rotation: ``sin^2 int s^2``; coupling:
    ``sin int s z``; pin: ``int z z^T``); ``A'_tt`` stays a sum of non-negative terms (centred
    moments of the interval). Forward sweep:
    ``alpha_i = (beta_i alpha_{i-1} - u_i . a_{i-1} - b_i) / D_i``, ``a_i = a_{i-1} + l t alpha_i``.

    The two unit end-force solves ``X = M~^-1 J^T`` and ``J X`` are done here (anchored end, or
    Woodbury for a heavy load). Returns False if the anchored end's ``J X`` is singular.
    """
    constrained = par[10] != 0.0
    mc = par[2]
    _link_terms(arr, par, q, qd, hg, kgeo, W, horizon)
    heavy = woodbury_load(arr[1], mc, constrained, par[7] != 0.0)
    extra = constrained or heavy
    mload = 0.0 if extra else mc
    if par[17] != 0.0:  # seabed: the contact terms (chosen once per factorisation)
        azz = _op_inward(arr, W, mload, hg, True)
    else:
        azz = _op_inward(arr, W, mload, hg, False)
    S[_S_BETA0] = hg * par[6] + (hg * hg) * par[5]
    S[_S_AZZ] = azz
    S[_S_MC] = mc
    if not extra:
        S[_S_MODE] = _MODE_NONE
        return True
    S[_S_MODE] = _MODE_CONSTRAINED if constrained else _MODE_HEAVY
    _op_unit_forces(arr, par, W, S, X)
    return not (constrained and singular_2x2(S[_S_J00], S[_S_J01], S[_S_J10], S[_S_J11]))


# --------------------------------------------------------------------------------------------
# Solve and product
# --------------------------------------------------------------------------------------------


@nb.njit(cache=True, inline="always")
def _solve_inward(l: np.ndarray, W: np.ndarray, rhs: np.ndarray, rr: np.ndarray) -> float:
    """:func:`_op_rhs_inward` of a generalised force (``-b_i`` into ``rr``; returns the
    vertical force on the platform) with the recursion written as an affine map of the state
    ``(b_n, b_x, b_z)``: ``b = (b_n - r) + lt . (b_x, b_z)``, ``b_n' = k b``, ``(b_x, b_z)' =
    (b_x, b_z) - g b`` (``k = beta/D``, ``g = u/D``) expanded into products of the old state
    with factors formed off the recursion's chain (``1 - g_x l t_x``, ...), so that on the chain
    each new entry costs two products and two sums in a tree instead of the chain through b.
    Equal to round-off."""
    cth = W[_W_COS]
    sth = W[_W_SIN]
    idd = W[_W_D]
    uxa = W[_W_UX]
    uza = W[_W_UZ]
    beta = W[_W_BETA]
    bn = 0.0
    bx = 0.0
    bz = 0.0
    for i in range(l.shape[0] - 1, -1, -1):
        ltx = l[i] * cth[i]
        ltz = l[i] * sth[i]
        inv_d = idd[i]
        gx = uxa[i] * inv_d
        gz = uza[i] * inv_d
        k = beta[i] * inv_d
        r = rhs[i + 1]
        rr[i] = -((bn - r) + (ltx * bx + ltz * bz))
        bn_new = (k * ltx * bx + k * ltz * bz) + k * (bn - r)
        bx_new = ((1.0 - gx * ltx) * bx - (gx * ltz) * bz) - gx * (bn - r)
        bz = ((1.0 - gz * ltz) * bz - (gz * ltx) * bx) - gz * (bn - r)
        bx = bx_new
        bn = bn_new
    return bz


@nb.njit(cache=True, inline="always")
def _solve_outward(l: np.ndarray, W: np.ndarray, rr: np.ndarray, zdd: float,
                   x: np.ndarray) -> tuple[float, float]:
    """The outward sweep of :func:`_op_solve` (``x = [zdd, alpha_1..n]``; returns the end's
    acceleration), as :func:`cable_sim.core.kernel.sweeps.outward_sweep` with the armature
    (no velocity terms) but written as an affine map of the state ``(alpha, a_x, a_z)``:
    ``alpha' = R/D + k alpha - g . a``, ``a' = a + l t alpha'`` expanded so that the new pin
    acceleration is formed from the old state directly (factors ``1 - l t_x g_x``, ``l t k``,
    ... off the chain), not through ``alpha'``. Equal to round-off."""
    cth = W[_W_COS]
    sth = W[_W_SIN]
    idd = W[_W_D]
    uxa = W[_W_UX]
    uza = W[_W_UZ]
    beta = W[_W_BETA]
    x[0] = zdd
    ap = 0.0
    apx = 0.0
    apz = zdd
    for i in range(l.shape[0]):
        ltx = l[i] * cth[i]
        ltz = l[i] * sth[i]
        inv_d = idd[i]
        gx = uxa[i] * inv_d
        gz = uza[i] * inv_d
        k = beta[i] * inv_d
        rd = rr[i] * inv_d
        alpha = (rd + k * ap) - (gx * apx + gz * apz)
        x[i + 1] = alpha
        ax_new = (ltx * rd + (ltx * k) * ap) + ((1.0 - ltx * gx) * apx - (ltx * gz) * apz)
        apz = (ltz * rd + (ltz * k) * ap) + ((1.0 - ltz * gz) * apz - (ltz * gx) * apx)
        apx = ax_new
        ap = alpha
    return apx, apz


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _op_solve(arr: np.ndarray, par: np.ndarray, W: np.ndarray, S: np.ndarray, X: np.ndarray,
              rhs: np.ndarray, x: np.ndarray) -> None:
    """Solve ``M~ x = rhs`` (anchored: with ``J x = 0``) using a factorisation from
    :func:`_op_factor`. ``rhs`` is a generalised force: ``rhs[0]`` a vertical force on the
    platform, ``rhs[i]`` a couple on link i. The two sweeps are :func:`_solve_inward` and
    :func:`_solve_outward` (the unit end forces of the factorisation take
    :func:`_op_rhs_inward` and the shared outward sweep)."""
    l = arr[0]
    bcn = W[_W_BCN]
    bz = _solve_inward(l, W, rhs, bcn)
    zdd = 0.0 if par[7] != 0.0 else (rhs[0] - bz) / (par[4] + S[_S_BETA0] + S[_S_AZZ])
    apx, apz = _solve_outward(l, W, bcn, zdd, x)
    mode = S[_S_MODE]
    if mode == _MODE_NONE:
        return
    eps = 1.0 / S[_S_MC] if mode == _MODE_HEAVY else 0.0
    a11 = S[_S_J00] + eps
    a22 = S[_S_J11] + eps
    f0, f1 = solve_2x2(a11, S[_S_J01], S[_S_J10], a22, -apx, -apz)
    add_columns(x, X[0], f0, X[1], f1)


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _dk_product(arr: np.ndarray, par: np.ndarray, hg: float, W: np.ndarray, rd: np.ndarray,
                rk: np.ndarray, out: np.ndarray) -> None:
    """``out = hg D rd + hg K rk`` with the local ``D``, ``K`` of the factorisation in W."""
    n = arr.shape[1]
    l = arr[0]
    drot = W[_W_DROT]
    kg = W[_W_KGEO]
    out[0] = hg * (par[6] * rd[0] + par[5] * rk[0])
    # joint torques tau_i on relative angles (springs on rk, dampers on rd); Q_i = tau_i - tau_{i+1}
    jk = arr[3]
    jc = arr[4]
    # (no branch in the loop: the last link, without a joint below, after it)
    if n > 0:
        t_i = hg * joint_torque(jk[0], jc[0], rk[1], 0.0, rd[1], 0.0)
        for i in range(n - 1):
            t_next = hg * joint_torque(jk[i + 1], jc[i + 1], rk[i + 2], rk[i + 1], rd[i + 2], rd[i + 1])
            out[i + 1] = t_i - t_next + (drot[i] * rd[i + 1] + kg[i] * rk[i + 1])
            t_i = t_next
        out[n] = t_i + (drot[n - 1] * rd[n] + kg[n - 1] * rk[n])
    if int(par[1]) == 2:
        _morison_product(l, W, rd, out)
    if par[17] != 0.0:
        _contact_product(arr, hg, W, rd, rk, out)


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _contact_product(arr: np.ndarray, hg: float, W: np.ndarray, rd: np.ndarray, rk: np.ndarray,
                     out: np.ndarray) -> None:
    """``out += int J_z^T hg (c_b J_z rd + k_b J_z rk) ds`` over each link's contact interval:
    the z "velocities" ``J_z(s) r = r_z,pin + s sin(theta) r_theta`` (linear in s), their
    resultant and first moment per link, generalised by ``J_z^T`` (reverse sums)."""
    n = arr.shape[1]
    l = arr[0]
    kb = arr[8]
    cb = arr[9]
    sth = W[_W_SIN]
    fz = W[_W_PX]  # per-link scratch: resultant and first moment of the z forces
    mzs = W[_W_PZ]
    pd = rd[0]
    pk = rk[0]
    for i in range(n):
        s = sth[i]
        a = W[_W_CA, i]
        b = W[_W_CB, i]
        if b > a:
            h0, h1, h2 = _contact_moments(a, b)
            fd = cb[i] * (h0 * pd + h1 * s * rd[i + 1]) + kb[i] * (h0 * pk + h1 * s * rk[i + 1])
            md = cb[i] * (h1 * pd + h2 * s * rd[i + 1]) + kb[i] * (h1 * pk + h2 * s * rk[i + 1])
            fz[i] = hg * fd
            mzs[i] = hg * md
        else:
            fz[i] = 0.0
            mzs[i] = 0.0
        pd += l[i] * s * rd[i + 1]
        pk += l[i] * s * rk[i + 1]
    sz = 0.0
    for i in range(n - 1, -1, -1):
        out[i + 1] += sth[i] * (l[i] * sz + mzs[i])
        sz += fz[i]
    out[0] += sz


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _morison_product(l: np.ndarray, W: np.ndarray, rd: np.ndarray, out: np.ndarray) -> None:
    """``out += J_c^T (hg G) J_c rd``: centre "velocities" ``J_c rd``, forces ``hg G J_c rd``,
    generalised by ``J_c^T`` (reverse sums)."""
    n = l.shape[0]
    cth = W[_W_COS]
    sth = W[_W_SIN]
    gta = W[_W_GT]
    gea = W[_W_GE]
    fxa = W[_W_PX]  # per-link scratch: the forces hg G J_c rd
    fza = W[_W_PZ]
    vx = 0.0
    vz = rd[0]
    for i in range(n):
        c = cth[i]
        s = sth[i]
        ux, uz = centre_velocity(vx, vz, l[i], c, s, rd[i + 1], 0.0)
        ut, ue = link_frame_velocity(ux, uz, c, s)
        fxa[i], fza[i] = from_link_frame(gta[i] * ut, gea[i] * ue, c, s)
        vx, vz = next_pin_velocity(vx, vz, l[i], c, s, rd[i + 1])
    sx = 0.0
    sz = 0.0
    for i in range(n - 1, -1, -1):
        out[i + 1] += l[i] * (cth[i] * (0.5 * fxa[i] + sx) + sth[i] * (0.5 * fza[i] + sz))
        sx += fxa[i]
        sz += fza[i]
    out[0] += sz


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _kgeo_from_forces(arr: np.ndarray, cth: np.ndarray, sth: np.ndarray, F: np.ndarray,
                      kgeo: np.ndarray) -> None:
    """Tension stiffness ``kappa_i = max(0, l_i T_i)``, T_i the mean axial tension of link i
    (``cth, sth``: cos/sin of the links' angles)."""
    n = arr.shape[1]
    l = arr[0]
    for i in range(n):
        s = sth[i]
        c = cth[i]
        # axial tension at the top (-F_i . e) and bottom (-F_{i+1} . e) of link i, e = (s, -c)
        t = -0.5 * ((F[i, 0] + F[i + 1, 0]) * s - (F[i, 1] + F[i + 1, 1]) * c)
        kgeo[i] = max(0.0, l[i] * t)


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
                 kgeo: np.ndarray | None, horizon: float = 0.0):
    arr, par = pack_arrays(model)
    n = model.n
    W = np.zeros((_NW, n))
    S = np.zeros(_NS)
    X = np.zeros((2, n + 1))
    kg = np.zeros(n) if kgeo is None else np.ascontiguousarray(kgeo, dtype=float)
    ok = _op_factor(arr, par, np.ascontiguousarray(q, dtype=float),
                    np.ascontiguousarray(qd, dtype=float), float(hg), kg, W, S, X,
                    float(horizon))
    return arr, par, W, S, X, ok


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
    hg : float
        ``gamma h`` [s]; 0 gives the plain mass matrix.
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
    arr, par, W, S, X, ok = _factor_fast(model, q, qd, hg, kgeo, horizon)
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
    horizon: float = 0.0,
) -> np.ndarray:
    """``hg D rd + hg K rk`` in O(n) (the local damping and stiffness of the operator;
    parameters as :func:`operator_solve`)."""
    arr, par, W, S, X, _ = _factor_fast(model, q, qd, hg, kgeo, horizon)
    out = np.empty(model.ndof)
    _dk_product(arr, par, float(hg), W, np.ascontiguousarray(rd, dtype=float),
                np.ascontiguousarray(rk, dtype=float), out)
    return out
