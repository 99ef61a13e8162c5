"""Factorisation of the O(n) operator ``M + hg D + hg^2 K`` (see
:mod:`cable_sim.integrate.implicit.operator`): the inward 3x3 articulated-inertia sweep
(:func:`_op_inward`), the inward sweep of one right-hand side through it (:func:`_op_rhs_inward`),
the two unit end-force solutions of the anchored end or heavy load (:func:`_op_unit_forces`) and
the whole factorisation at a state (:func:`_op_factor`, :func:`_op_factor_trig`) with the
factors its solves read (:func:`_solve_factors`).

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` and the siblings
``op_layout``, ``op_terms``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.frames import relative_trig, to_parent_frame, to_world
from cable_sim.core.kernel.jit import HOT_KERNEL
from cable_sim.core.kernel.links import from_link_frame, link_trig, woodbury_load
from cable_sim.core.kernel.packing import ARR_MK
from cable_sim.core.kernel.sweeps import _K_IL2, TINY, outward_sweep, singular_2x2
from cable_sim.integrate.implicit.op_layout import (
    _MODE_CONSTRAINED,
    _MODE_HEAVY,
    _MODE_NONE,
    _S_AZZ,
    _S_BETA0,
    _S_J00,
    _S_J01,
    _S_J10,
    _S_J11,
    _S_MC,
    _S_MODE,
    _TWELFTH,
    _W_AXX,
    _W_AXZ,
    _W_AZX,
    _W_AZZ,
    _W_BETA,
    _W_CA,
    _W_CB,
    _W_COS,
    _W_D,
    _W_GE,
    _W_GT,
    _W_GX,
    _W_GZ,
    _W_K,
    _W_KX,
    _W_KZ,
    _W_ROT,
    _W_SIN,
    _W_UX,
    _W_UZ,
)
from cable_sim.integrate.implicit.op_terms import _contact_moments, _link_terms


@nb.njit(cache=True, inline="always")
def _op_inward(arr: np.ndarray, G: np.ndarray, W: np.ndarray, mload: float, hg: float,
               contact: bool) -> float:
    """The 3x3 articulated inertias ``[[c, w^T], [w, A]]``, tip to platform; fills ``1/D_i`` and
    ``u_i`` (world frame) in W and returns the platform's ``A_zz`` (see :func:`_op_factor`).
    ``G`` holds the real geometry rows (cos/sin, contact interval; ``G is W`` for a real
    ``hg``). A and w stay in each link's frame; the parent turns them into its own by the relative
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
    cth = G[_W_COS]
    sth = G[_W_SIN]
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
            za, zb_ = G[_W_CA, i], G[_W_CB, i]
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
def _solve_factors(l: np.ndarray, G: np.ndarray, W: np.ndarray) -> None:
    """The per-link factors of a solve's two sweeps
    (:func:`cable_sim.integrate.implicit.op_solve._op_solve`) into W's rows ``_W_GX`` ..
    ``_W_AZZ``, once per factorisation: ``g = u / D``, ``k = beta / D``, ``k l t`` and the
    entries of the affine map ``I - (l t) g^T`` that carries an end force inwards (its transpose
    carries a pin acceleration outwards). Every solve with the factorisation reads them instead
    of forming them again (Radau IIA: three or four solves per factorisation, the complex one
    at four real products per complex product). ``G``: the real geometry rows."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
    for i in range(l.shape[0]):
        ltx = l[i] * cth[i]
        ltz = l[i] * sth[i]
        inv_d = W[_W_D, i]
        gx = W[_W_UX, i] * inv_d
        gz = W[_W_UZ, i] * inv_d
        k = W[_W_BETA, i] * inv_d
        W[_W_GX, i] = gx
        W[_W_GZ, i] = gz
        W[_W_K, i] = k
        W[_W_KX, i] = k * ltx
        W[_W_KZ, i] = k * ltz
        W[_W_AXX, i] = 1.0 - gx * ltx
        W[_W_AXZ, i] = gx * ltz
        W[_W_AZX, i] = gz * ltx
        W[_W_AZZ, i] = 1.0 - gz * ltz


@nb.njit(cache=True, inline="always")
def _op_rhs_inward(l: np.ndarray, G: np.ndarray, W: np.ndarray, rhs: np.ndarray, use_rhs: bool,
                   bx: float, bz: float, rr: np.ndarray) -> tuple[float, float]:
    """Inward sweep of one right-hand side through a factorisation: a generalised force ``rhs``
    (``use_rhs``) or a unit end force (``bx, bz`` at the end; flushed at TINY). Stores ``-b_i``
    in ``rr`` (read by the outward sweep) and returns the force on the platform (``G``: the
    real geometry rows)."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
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


@nb.njit(**HOT_KERNEL)
def _op_unit_forces(arr: np.ndarray, par: np.ndarray, G: np.ndarray, W: np.ndarray,
                    S: np.ndarray, X: np.ndarray) -> None:
    """``X = M~^-1 J^T`` (two unit end forces, +x and +z) and ``J X`` into S."""
    l = arr[0]
    locked = par[7] != 0.0
    mp = par[4]
    for k in range(2):
        bx, bz = _op_rhs_inward(l, G, W, X[k], False, -1.0 if k == 0 else 0.0,
                                0.0 if k == 0 else -1.0, X[k, 1:])
        zdd = 0.0 if locked else -bz / (mp + S[_S_BETA0] + S[_S_AZZ])
        # column k of J X: (J00, J10) for k = 0 -> stored J00, J01 = row 0
        S[_S_J00 + k], S[_S_J10 + k] = outward_sweep(
            l, G[_W_COS], G[_W_SIN], X[k], False, W[_W_BETA], True, X[k, 1:], W[_W_UX],
            W[_W_UZ], W[_W_D], zdd, X[k])


@nb.njit(cache=True)
def _op_factor(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray, hg: float,
               kgeo: np.ndarray, W: np.ndarray, S: np.ndarray, X: np.ndarray,
               horizon: float) -> bool:
    """Articulated inertias of ``M~ = M + hg D + hg^2 K`` at (q, qd); fills W, S, X (the
    links' cos/sin first, then :func:`_op_factor_trig`)."""
    link_trig(q, W[_W_COS], W[_W_SIN])
    return _op_factor_trig(arr, par, q, qd, hg, kgeo, W, W, S, X, horizon)


@nb.njit(**HOT_KERNEL)
def _op_factor_trig(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray, hg: float,
                    kgeo: np.ndarray, G: np.ndarray, W: np.ndarray, S: np.ndarray, X: np.ndarray,
                    horizon: float) -> bool:
    """Articulated inertias of ``M~ = M + hg D + hg^2 K`` at (q, qd); fills W, S, X. ``G`` holds
    the real geometry rows: its ``_W_COS``, ``_W_SIN`` must hold the cos/sin of the links' angles
    ``q[1:]`` already (the compiled runs copy those of the forward dynamics at the same q), its
    contact interval is written here. For a real ``hg`` G is W itself; for a complex ``hg``
    (Radau IIA's complex eigenvalue, :mod:`cable_sim.integrate.implicit.radau_step`) W, S, X are
    complex and G is the real factorisation's W at the same state and horizon.

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
    _link_terms(arr, par, q, qd, hg, kgeo, G, W, horizon)
    heavy = woodbury_load(arr[1], mc, constrained, par[7] != 0.0)
    extra = constrained or heavy
    mload = 0.0 if extra else mc
    if par[17] != 0.0:  # seabed: the contact terms (chosen once per factorisation)
        azz = _op_inward(arr, G, W, mload, hg, True)
    else:
        azz = _op_inward(arr, G, W, mload, hg, False)
    _solve_factors(arr[0], G, W)
    S[_S_BETA0] = hg * par[6] + (hg * hg) * par[5]
    S[_S_AZZ] = azz
    S[_S_MC] = mc
    if not extra:
        S[_S_MODE] = _MODE_NONE
        return True
    S[_S_MODE] = _MODE_CONSTRAINED if constrained else _MODE_HEAVY
    _op_unit_forces(arr, par, G, W, S, X)
    return not (constrained and singular_2x2(S[_S_J00], S[_S_J01], S[_S_J10], S[_S_J11]))
