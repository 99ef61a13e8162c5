"""The shared O(n) sweeps of the articulated-body recursion on the planar chain (``MODEL.md``).

One implementation of each piece, used by the forward-dynamics kernel
(:mod:`cable_sim.core.kernel.forward`), the anchor's Schur complement
(:mod:`cable_sim.core.kernel.anchor`) and the implicit operator
(:mod:`cable_sim.integrate.implicit.operator`):

* a link's new 2x2 articulated inertia in its own frame (:func:`articulated_parts`);
* the inward (tip to platform) sweep of the 2x2 articulated inertias (each kept in its link's
  frame: one rotation per link) and bias forces, with the unit end-force right-hand sides of
  the anchor and the heavy-load Woodbury form;
* the outward (platform to tip) acceleration sweep, also for the implicit operator's 3x3 form
  (joint "armature" coupling a link to its parent's rotation);
* the 2x2 solve and the column update of the anchor / heavy-load correction.

The per-link terms they use (cos/sin, velocities, drag, joint torques, the Woodbury choice) are
in :mod:`cable_sim.core.kernel.links`, the changes of frame of a 2x2 inertia in
:mod:`cable_sim.core.kernel.frames`. Every function takes plain arrays and floats (compiled with
numba, ``cache=True``); the small per-link ones are inlined (``inline="always"``) into their
callers.

Core layer, compiled kernel: imports numba, numpy and :mod:`cable_sim.core.kernel.frames`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.frames import relative_trig, to_world

#: Magnitude below which the unit-force right-hand sides are flushed to zero: a unit end force
#: on a line without tension (zero velocity and gravity in these solves) decays geometrically up
#: the line; flushing it long before it turns subnormal keeps it fast (subnormal arithmetic is
#: ~100x slower). 1e-150 of the unit force.
TINY = 1e-150
EPS = float(np.finfo(np.float64).eps)
#: 1/3 and 1/6: the sweeps multiply by these instead of dividing by 3 and 6 (a division per
#: link costs the divider's throughput; equal to round-off).
THIRD = 1.0 / 3.0
SIXTH = 1.0 / 6.0


# ---- articulated inertia of a link -------------------------------------------------------------


@nb.njit(cache=True, inline="always")
def articulated_parts(
    m3: float, m4: float, m6: float, me: float, x: float, y: float, z: float, xp: float
) -> tuple[float, float, float, float, float]:
    """New articulated inertia A' = mn t t^T + me e e^T + A - h h^T / D of a link in its own
    frame, as ``(t^T A' t, t^T A' e, e^T A' e) = ixp (kp, kr, ku) + (0, 0, cu)``: returns
    ``ixp = 1/xp, kp, kr, ku, cu`` (``m3, m4, m6`` = mn/3, mn/4, mn/6; mn = me = m without added
    mass, then A' = m I + A - h h^T / D).

    Assembled in the link frame (t, e) to avoid cancellation in the t direction:
    ``a_tt = mn (x/3 + mn/12) / xp`` is written ``(x + mn/4) (mn/3) / xp``, ``a_te = -y (mn/6) / xp``,
    ``a_ee = me + z - y^2 / xp``, the three divisions by xp as one reciprocal. The parts do not
    wait for that division: the inward sweep turns them into the parent's frame while ``1/xp``
    is being formed.
    """
    return 1.0 / xp, (x + m4) * m3, -y * m6, -(y * y), me + z


@nb.njit(cache=True, inline="always")
def child_inertia(
    last: bool, mload: float, m3: float, ixp: float, kp: float, kr: float, ku: float, cu: float,
    cc: float, ss: float, cs: float,
) -> tuple[float, float, float, float]:
    """The child's articulated inertia in a link's frame, ``(x, y, z) = (t.A.t, t.A.e, e.A.e)``,
    and ``xp = x + mn/3`` (``m3``): the load's isotropic ``mload I`` below the last link
    (``last``), else the child's parts ``(ixp, kp, kr, ku, cu)`` (:func:`articulated_parts`)
    turned by the relative angle (``cc, ss, cs``: its cos^2, sin^2, cos sin), each part turned
    while the child's ``1/xp`` is being formed."""
    if last:
        return mload, 0.0, mload, mload + m3
    tcs = 2.0 * cs
    kx = kp * cc + (kr * tcs + ku * ss)
    ky = (ku - kp) * cs + kr * (cc - ss)
    kz = kp * ss - kr * tcs + ku * cc
    cx = cu * ss
    return ixp * kx + cx, ixp * ky + cu * cs, ixp * kz + cu * cc, ixp * kx + (cx + m3)


@nb.njit(cache=True, inline="always")
def link_coupling(x: float, y: float, hm: float, lc: float, ls: float) -> tuple[float, float]:
    """``h = l A t + (mn l/2) t`` (world x, z) with ``A t = x t + y e`` (``hm`` = mn/2,
    ``lc, ls`` = l t)."""
    xh = x + hm
    return lc * xh + ls * y, ls * xh - lc * y


@nb.njit(cache=True, inline="always")
def bias_step(
    sc: np.ndarray, i: int, y: float, z: float, lc: float, ls: float, h_x: float, h_z: float,
    inv_d: float, b0x: float, b0z: float,
) -> tuple[float, float, float, float]:
    """One link of the applied-force right-hand side: ``R = applied couple + l^2 w^2 t.A.e -
    l t.b`` and ``b += G - w^2 l (me/2 e + A e) + h R/D`` from the factors of
    :func:`sweep_prep` in ``sc``; stores R/D in ``sc`` and returns ``(R, R/D, b_x, b_z)``."""
    r0 = (sc[_S_RA, i] + sc[_S_L2W2, i] * y) - (lc * b0x + ls * b0z)
    rd = r0 * inv_d
    sc[_S_RD, i] = rd
    wlc = sc[_S_WLC, i]
    wls = sc[_S_WLS, i]
    b0x = ((b0x + sc[_S_FX0, i]) - (wlc * y + wls * z)) + h_x * rd
    b0z = ((b0z + sc[_S_FZ0, i]) - (wls * y - wlc * z)) + h_z * rd
    return r0, rd, b0x, b0z


@nb.njit(cache=True, inline="always")
def flush_cross(i: int, ixp: float, kp: float, kr: float, ku: float, cu: float) -> float:
    """The cross term ``kr`` of a link's articulated parts, or 0 where it has decayed below
    TINY of the inertia: along a straight stretch (relative angle 0) it decays geometrically
    (factor < 1/2 per link) and is flushed long before it turns subnormal (~100x slower
    arithmetic), far below round-off; tested every 16th link only (a test per link costs ~10 %
    of the sweep)."""
    if i & 15 == 0 and abs(kr * ixp) < TINY * (abs(kp * ixp) + abs(cu + ku * ixp)):
        return 0.0
    return kr


# ---- inward sweep (tip to platform) ------------------------------------------------------------


@nb.njit(cache=True, inline="always")
def unit_force_step(
    bx: float, bz: float, lc: float, ls: float, h_x: float, h_z: float, inv_d: float,
    flush: bool,
) -> tuple[float, float, float]:
    """One link of a unit end-force right-hand side (no velocity, no gravity), flushed at TINY
    when ``flush`` (``lc, ls = l t``; ``inv_d = 1 / D_i``). The sweep tests every 16th link
    (the anchored inward sweep at n = 640: 8.7 us against 10.5 us with a test per link): a
    force above TINY reaches the subnormal range (~2e-308) before the next test only if it
    shrinks by more than ~1e-10 per link. Subnormals would cost speed only, not accuracy."""
    rk = -(lc * bx + ls * bz)
    rd = rk * inv_d
    bx += h_x * rd
    bz += h_z * rd
    if flush and abs(bx) + abs(bz) < TINY:
        bx = 0.0
        bz = 0.0
    return rk, bx, bz


#: Rows of the per-link model constants of :func:`inward_sweep_ws`: mn/3, mn/4, mn/6, mn/2,
#: 1/l^2, me/2, l^2 (the same as :func:`cable_sim.core.kernel.packing.link_constants`, which
#: the packed model carries in its rows ``ARR_MK:``).
MK_ROWS = 7
_K_M3, _K_M4, _K_M6, _K_HM, _K_IL2, _K_HME, _K_L2 = range(MK_ROWS)

#: Rows of the inward sweep's scratch (:func:`inward_sweep_ws`), each of n entries: per link
#: (i) the trig of its angle relative to its child's (cos^2, sin^2, cos sin), l t = (l c, l s),
#: w^2 l t, l^2 w^2, the applied couple and the bias forces' velocity-free parts, and the
#: outputs h/D (x, z) and R/D of the applied-force right-hand side, and the affine map of
#: :func:`outward_sweep_bias` (P: xx, xz, zx, zz; v: x, z).
SW_ROWS = 20
(_S_CC, _S_SS, _S_CS, _S_LC, _S_LS, _S_WLC, _S_WLS, _S_L2W2, _S_RA, _S_FX0, _S_FZ0, _S_GX,
 _S_GZ, _S_RD, _S_PXX, _S_PXZ, _S_PZX, _S_PZZ, _S_VX, _S_VZ) = range(SW_ROWS)

@nb.njit(cache=True, inline="always")
def fill_link_constants(l: np.ndarray, mn: np.ndarray, me: np.ndarray, mk: np.ndarray) -> None:
    """The per-link model constants of :func:`inward_sweep_ws` (rows :data:`MK_ROWS`) into
    ``mk`` (also what :func:`cable_sim.core.kernel.packing.link_constants` packs into the model)."""
    for i in range(l.shape[0]):
        mk[_K_M3, i] = mn[i] * THIRD
        mk[_K_M4, i] = 0.25 * mn[i]
        mk[_K_M6, i] = mn[i] * SIXTH
        mk[_K_HM, i] = 0.5 * mn[i]
        mk[_K_L2, i] = l[i] * l[i]
        mk[_K_IL2, i] = 1.0 / (l[i] * l[i])
        mk[_K_HME, i] = 0.5 * me[i]


@nb.njit(cache=True, inline="always")
def sweep_prep(
    l: np.ndarray, mk: np.ndarray, cth: np.ndarray, sth: np.ndarray, qd: np.ndarray,
    tau: np.ndarray, cpl: np.ndarray, fgx: np.ndarray, fgz: np.ndarray, bias: bool,
    sc: np.ndarray,
) -> None:
    """The per-link factors of :func:`inward_sweep_ws` that do not depend on the recursion, in
    short loops without a carried dependence (they vectorise) into the scratch ``sc`` (rows
    :data:`SW_ROWS`); with ``bias`` also those of the applied-force right-hand side."""
    n = l.shape[0]
    lc = sc[_S_LC]
    ls = sc[_S_LS]
    for i in range(n):
        lc[i] = l[i] * cth[i]
        ls[i] = l[i] * sth[i]
    rc = sc[_S_CC]
    rs = sc[_S_SS]
    rcs = sc[_S_CS]
    for i in range(n - 1):
        cr, sr = relative_trig(cth[i], sth[i], cth[i + 1], sth[i + 1])
        rc[i] = cr * cr
        rs[i] = sr * sr
        rcs[i] = cr * sr
    if bias:
        wlc = sc[_S_WLC]
        wls = sc[_S_WLS]
        l2w2 = sc[_S_L2W2]
        l2 = mk[_K_L2]
        for i in range(n):
            w2 = qd[i + 1] * qd[i + 1]
            wlc[i] = lc[i] * w2
            wls[i] = ls[i] * w2
            l2w2[i] = l2[i] * w2
        ra = sc[_S_RA]
        for i in range(n):
            ra[i] = -tau[i] + tau[i + 1] + cpl[i] + 0.5 * (lc[i] * fgx[i] + ls[i] * fgz[i])
        fx0 = sc[_S_FX0]
        fz0 = sc[_S_FZ0]
        hme = mk[_K_HME]
        for i in range(n):
            fx0[i] = -fgx[i] - hme[i] * wls[i]
            fz0[i] = -fgz[i] + hme[i] * wlc[i]


@nb.njit(cache=True, inline="always")
def inward_sweep_ws(
    l: np.ndarray, mk: np.ndarray, me: np.ndarray, cth: np.ndarray, sth: np.ndarray,
    qd: np.ndarray, tau: np.ndarray, cpl: np.ndarray, fgx: np.ndarray, fgz: np.ndarray,
    bias: bool, mload: float, bx: np.ndarray, bz: np.ndarray, idd: np.ndarray, hx: np.ndarray,
    hz: np.ndarray, rr: np.ndarray, sc: np.ndarray, full: bool = True,
    endm: np.ndarray | None = None,
) -> float:
    """:func:`inward_sweep` with the per-link model constants ``mk`` (:data:`MK_ROWS` rows of
    l, mn, me: :func:`fill_link_constants`, or the packed model's) on the caller's scratch
    ``sc`` (:data:`SW_ROWS` x n or more), which also
    receives h/D and (with ``bias``) R/D of the applied-force right-hand side for
    :func:`outward_sweep_bias`. Without ``full``, ``idd``, ``hx``, ``hz`` and ``rr[0]`` are
    not written (the caller needs only the scratch's outputs).

    The same recursion, arranged for speed (equal to round-off): the factors that do not
    depend on the recursion are formed first in vectorised loops (:func:`sweep_prep`); the
    child's inertia is carried as ``(p, r, u) = ixp (kp, kr, ku) + (0, 0, cu)``
    (:func:`articulated_parts`) so that its turn into the link's frame (linear in A) overlaps
    the division ``ixp = 1/xp``; 1/D is ``ixp / l^2``; the end forces of the first three
    right-hand sides ride in registers.

    With ``endm`` (5 entries; with ``bias`` and the two unit end forces, ``nrhs >= 3``) it also
    sums, off the recursion's chain, what the end correction needs without an outward sweep of
    the unit forces: ``endm[0:3] = sum_i u_x u_x / D, u_x u_z / D, u_z u_z / D`` and
    ``endm[3:5] = sum_i -B_k . v_i`` (k = x, z). Here ``u_k,i = R_i`` of unit force k (``l t_i .
    Psi_i^T e_k``) and ``B_k,i = -Psi_i^T e_k`` its end force below link i, where ``Psi_i =
    P_n ... P_(i+1)`` and ``P_i = I - (l t_i) (h_i / D_i)^T`` is the outward sweep's map
    ``a_i = P_i a_(i-1) + v_i`` (:func:`outward_sweep_bias`): the inward propagation of an end
    force is ``P_i^T``, so ``e_k . a_n = sum_i (Psi_i^T e_k) . v_i + (Psi_0^T e_k) . a_0``.
    Hence ``J M^-1 J^T`` (without the platform's share) is the first sum and the applied
    forces' end acceleration (without the platform's share) the second; see
    :func:`end_correction_terms`.
    """
    n = l.shape[0]
    nrhs = bx.shape[0]
    sweep_prep(l, mk, cth, sth, qd, tau, cpl, fgx, fgz, bias, sc)
    m3 = mk[_K_M3]
    m4 = mk[_K_M4]
    m6 = mk[_K_M6]
    hm = mk[_K_HM]
    il2 = mk[_K_IL2]
    rc = sc[_S_CC]
    rs = sc[_S_SS]
    rcs = sc[_S_CS]
    lcs = sc[_S_LC]
    lss = sc[_S_LS]
    gxs = sc[_S_GX]
    gzs = sc[_S_GZ]
    ixp = 0.0
    kp = 0.0
    kr = 0.0
    ku = 0.0
    cu = 0.0
    b0x = bx[0] if nrhs > 0 else 0.0
    b0z = bz[0] if nrhs > 0 else 0.0
    b1x = bx[1] if nrhs > 1 else 0.0
    b1z = bz[1] if nrhs > 1 else 0.0
    b2x = bx[2] if nrhs > 2 else 0.0
    b2z = bz[2] if nrhs > 2 else 0.0
    g00 = 0.0
    g01 = 0.0
    g11 = 0.0
    e0 = 0.0
    e1 = 0.0
    for i in range(n - 1, -1, -1):
        x, y, z, xp = child_inertia(i == n - 1, mload, m3[i], ixp, kp, kr, ku, cu, rc[i], rs[i],
                                    rcs[i])
        ixp = 1.0 / xp
        inv_d = ixp * il2[i]  # 1/D = 1/(l^2 xp)
        lc = lcs[i]
        ls = lss[i]
        h_x, h_z = link_coupling(x, y, hm[i], lc, ls)
        if full:
            idd[i] = inv_d
            hx[i] = h_x
            hz[i] = h_z
        gxs[i] = h_x * inv_d
        gzs[i] = h_z * inv_d
        if bias:
            r0, rd, b0x, b0z = bias_step(sc, i, y, z, lc, ls, h_x, h_z, inv_d, b0x, b0z)
            if full:
                rr[0, i] = r0
            if endm is not None:
                # end-correction sums (see the docstring), with the end forces below this link
                vx = lc * rd - sc[_S_WLS, i]
                vz = ls * rd + sc[_S_WLC, i]
                e0 -= b1x * vx + b1z * vz
                e1 -= b2x * vx + b2z * vz
        if nrhs > 1:
            flush = i & 15 == 0
            rr[1, i], b1x, b1z = unit_force_step(b1x, b1z, lc, ls, h_x, h_z, inv_d, flush)
            if nrhs > 2:
                rr[2, i], b2x, b2z = unit_force_step(b2x, b2z, lc, ls, h_x, h_z, inv_d, flush)
                for k in range(3, nrhs):
                    rr[k, i], bx[k], bz[k] = unit_force_step(bx[k], bz[k], lc, ls, h_x, h_z,
                                                             inv_d, flush)
        ixp, kp, kr, ku, cu = articulated_parts(m3[i], m4[i], m6[i], me[i], x, y, z, xp)
        kr = flush_cross(i, ixp, kp, kr, ku, cu)
    if nrhs > 0:
        bx[0] = b0x
        bz[0] = b0z
    if nrhs > 1:
        bx[1] = b1x
        bz[1] = b1z
    if nrhs > 2:
        bx[2] = b2x
        bz[2] = b2z
    if endm is not None:
        # the u u^T / D sums after the recursion, in a loop that vectorises
        for i in range(n):
            u0 = rr[1, i]
            u1 = rr[2, i]
            g00 += (u0 * u0) * idd[i]
            g01 += (u0 * u1) * idd[i]
            g11 += (u1 * u1) * idd[i]
        endm[0] = g00
        endm[1] = g01
        endm[2] = g11
        endm[3] = e0
        endm[4] = e1
    if n == 0:
        return mload
    return to_world(kp * ixp, kr * ixp, cu + ku * ixp, cth[0], sth[0])[2]


@nb.njit(cache=True, inline="always")
def inward_sweep(
    l: np.ndarray, mn: np.ndarray, me: np.ndarray, cth: np.ndarray, sth: np.ndarray, qd: np.ndarray,
    tau: np.ndarray, cpl: np.ndarray, fgx: np.ndarray, fgz: np.ndarray, bias: bool,
    mload: float, bx: np.ndarray, bz: np.ndarray, idd: np.ndarray, hx: np.ndarray,
    hz: np.ndarray, rr: np.ndarray,
) -> float:
    """Articulated inertias (force-independent) and bias forces, tip to platform.

    Starts from the load ``A_(n+1) = mload I`` and the end forces ``bx, bz`` (one per
    right-hand side, updated in place to the platform's). Row 0 is the applied forces (when
    ``bias``: joint torques ``tau``, couples ``cpl``, centre forces ``fgx, fgz``, velocities);
    rows 1.. are unit end forces. Fills ``idd`` (1/D_i), ``hx, hz`` (h_i) and ``rr`` (R_i per
    right-hand side); returns ``A_1,zz`` (the platform's articulated mass beyond its own).

    Link masses: ``mn`` as seen along the link normal t and ``me`` along its axis e (the link
    mass plus the Morison added mass m_an l, m_at l: a per-link anisotropic inertia in the link
    frame, MODEL.md "Round 2 terms"; both are the link mass m without added mass). With the
    added mass A = m_an t t^T + m_at e e^T per length, the link's rotation sees mn (t.A.e = 0),
    so D = l^2 (mn/3 + t.A_child.t), h = l A_child t + (mn l/2) t, and the centripetal term
    -w^2 (me l/2) e.

    Each articulated inertia stays in its link's frame; the parent turns it into its own by the
    relative angle (one rotation per link on the recursion's chain instead of one out of the
    link frame and one into the next). Runs :func:`inward_sweep_ws` on scratch of its own (the
    forward dynamics passes its workspace and the packed model's constants instead).
    """
    n = l.shape[0]
    mk = np.empty((MK_ROWS, n))
    fill_link_constants(l, mn, me, mk)
    return inward_sweep_ws(l, mk, me, cth, sth, qd, tau, cpl, fgx, fgz, bias, mload, bx, bz, idd,
                           hx, hz, rr, np.empty((SW_ROWS, n)))


# ---- outward sweep (platform to tip) -----------------------------------------------------------


@nb.njit(cache=True, inline="always")
def outward_sweep(
    l: np.ndarray, cth: np.ndarray, sth: np.ndarray, qd: np.ndarray, velocity: bool,
    beta: np.ndarray, coupled: bool, rr: np.ndarray, hx: np.ndarray, hz: np.ndarray,
    idd: np.ndarray, zdd: float, sol: np.ndarray,
) -> tuple[float, float]:
    """Link accelerations from the platform's ``zdd`` outwards; returns the end's acceleration.

    ``alpha_i = (R_i - h_i . a_(i-1) [+ beta_i alpha_(i-1)]) / D_i`` (the bracket with
    ``coupled``: the implicit operator's joint armature), ``a_i = a_(i-1) + l (t alpha_i - e w^2)``
    (the centripetal term with ``velocity``, from ``qd``). Writes ``sol = [zdd, alpha_1..n]``.
    ``idd`` holds the reciprocals 1/D_i (formed once per factorisation, not per solve).
    Evaluated as ``R/D - (h/D) . a_(i-1)`` and ``(a_(i-1) - l w^2 e) + (l t) alpha_i``, the
    factors formed off the recursion's chain (equal to round-off).
    """
    n = l.shape[0]
    sol[0] = zdd
    ap = 0.0
    apx = 0.0
    apz = zdd
    for i in range(n):
        li = l[i]
        # every factor known ahead is formed off the chain (1/D, h/D, R/D, l t, l w^2 e): on
        # the chain, alpha costs a product and two sums, a_i a product and a sum
        inv = idd[i]
        gx = hx[i] * inv
        gz = hz[i] * inv
        if coupled:
            alpha = (rr[i] * inv + beta[i] * inv * ap) - (gx * apx + gz * apz)
        else:
            alpha = rr[i] * inv - (gx * apx + gz * apz)
        sol[i + 1] = alpha
        ap = alpha
        ltx = li * cth[i]
        ltz = li * sth[i]
        if velocity:
            w2 = qd[i + 1] * qd[i + 1]
            apx = (apx - ltz * w2) + ltx * alpha
            apz = (apz + ltx * w2) + ltz * alpha
        else:
            apx += ltx * alpha
            apz += ltz * alpha
    return apx, apz


@nb.njit(cache=True, inline="always")
def outward_bias_map(sc: np.ndarray, n: int) -> None:
    """The affine map ``a_i = P_i a_(i-1) + v_i`` of :func:`outward_sweep_bias` into the
    scratch ``sc`` (rows P: xx, xz, zx, zz; v: x, z), from the factors :func:`inward_sweep_ws`
    left there: ``P = I - (l t) g^T`` (g = h/D), ``v = (l t) R/D - w^2 l e``; loops without a
    carried dependence (they vectorise)."""
    gx = sc[_S_GX]
    gz = sc[_S_GZ]
    rd = sc[_S_RD]
    lc = sc[_S_LC]
    ls = sc[_S_LS]
    wlc = sc[_S_WLC]
    wls = sc[_S_WLS]
    pxx = sc[_S_PXX]
    pxz = sc[_S_PXZ]
    pzx = sc[_S_PZX]
    pzz = sc[_S_PZZ]
    vx = sc[_S_VX]
    vz = sc[_S_VZ]
    for i in range(n):
        pxx[i] = 1.0 - lc[i] * gx[i]
        pxz[i] = -(lc[i] * gz[i])
        pzx[i] = -(ls[i] * gx[i])
        pzz[i] = 1.0 - ls[i] * gz[i]
    for i in range(n):
        vx[i] = lc[i] * rd[i] - wls[i]
        vz[i] = ls[i] * rd[i] + wlc[i]


@nb.njit(cache=True, inline="always")
def outward_bias_link(sc: np.ndarray, i: int, apx: float, apz: float
                      ) -> tuple[float, float, float]:
    """One link of :func:`outward_sweep_bias` (map in ``sc``, :func:`outward_bias_map`): from
    the parent pin's acceleration ``(apx, apz)``, link i's angular acceleration ``R/D - g .
    a_(i-1)`` (off the chain) and its lower pin's acceleration ``P_i a_(i-1) + v_i``."""
    alpha = sc[_S_RD, i] - (sc[_S_GX, i] * apx + sc[_S_GZ, i] * apz)
    ax = (sc[_S_VX, i] + sc[_S_PXX, i] * apx) + sc[_S_PXZ, i] * apz
    az = (sc[_S_VZ, i] + sc[_S_PZZ, i] * apz) + sc[_S_PZX, i] * apx
    return alpha, ax, az


@nb.njit(cache=True, inline="always")
def outward_sweep_bias(sc: np.ndarray, n: int, zdd: float, sol: np.ndarray) -> tuple[float, float]:
    """:func:`outward_sweep` of the applied-force right-hand side (with the velocity terms,
    no armature) from the factors :func:`inward_sweep_ws` (with ``bias``) left in its scratch
    ``sc``: h/D, R/D, l t and w^2 l t. Writes ``sol = [zdd, alpha_1..n]``; returns the end's
    acceleration.

    ``alpha_i = R/D - g . a_(i-1)`` (g = h/D) and ``a_i = a_(i-1) - w^2 l e + l t alpha_i``
    make a_i affine in a_(i-1): ``a_i = P_i a_(i-1) + v_i`` with ``P = I - (l t) g^T`` and
    ``v = (l t) R/D - w^2 l e``, formed first in a vectorised loop (:func:`outward_bias_map`).
    The recursion's chain is then a product and two sums per link (alpha_i, off the chain, from
    a_(i-1); :func:`outward_bias_link`); equal to round-off.
    """
    outward_bias_map(sc, n)
    sol[0] = zdd
    apx = 0.0
    apz = zdd
    for i in range(n):
        sol[i + 1], apx, apz = outward_bias_link(sc, i, apx, apz)
    return apx, apz


# ---- 2x2 end correction (anchor constraint, heavy load) ----------------------------------------


@nb.njit(cache=True, inline="always")
def singular_2x2(a11: float, a12: float, a21: float, a22: float) -> bool:
    """True if the 2x2 matrix is singular to working precision."""
    det = a11 * a22 - a12 * a21
    return abs(det) <= 4.0 * EPS * (abs(a11 * a22) + abs(a12 * a21))


@nb.njit(cache=True, inline="always")
def solve_2x2(
    a11: float, a12: float, a21: float, a22: float, r0: float, r1: float
) -> tuple[float, float]:
    """``[[a11, a12], [a21, a22]]^-1 (r0, r1)`` by Cramer's rule."""
    det = a11 * a22 - a12 * a21
    return (a22 * r0 - a12 * r1) / det, (a11 * r1 - a21 * r0) / det


@nb.njit(cache=True, inline="always")
def add_columns(out: np.ndarray, x0: np.ndarray, f0: float, x1: np.ndarray, f1: float) -> None:
    """``out += x0 f0 + x1 f1`` (the end correction ``X f``)."""
    for j in range(out.shape[0]):
        out[j] += x0[j] * f0 + x1[j] * f1
