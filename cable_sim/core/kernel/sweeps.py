"""The shared O(n) sweeps of the articulated-body recursion on the planar chain (``MODEL.md``).

One implementation of each piece, used by the forward-dynamics kernel
(:mod:`cable_sim.core.kernel.forward`), the anchor's Schur complement
(:mod:`cable_sim.core.kernel.anchor`) and the implicit operator
(:mod:`cable_sim.integrate.implicit.operator`):

* link kinematics: the links' cos/sin, centre velocity relative to the water, the next pin's
  velocity, a velocity in the link frame (``t = (cos, sin)`` normal, ``e = (sin, -cos)`` axis);
* the Morison drag force on a link centre; the joint torques; whether the load enters by
  Woodbury;
* a 2x2 articulated inertia seen in the link frame and turned back to the world frame, or into
  the parent link's frame;
* the inward (tip to platform) sweep of the 2x2 articulated inertias (each kept in its link's
  frame: one rotation per link) and bias forces, with the unit end-force right-hand sides of
  the anchor and the heavy-load Woodbury form;
* the outward (platform to tip) acceleration sweep, also for the implicit operator's 3x3 form
  (joint "armature" coupling a link to its parent's rotation);
* the 2x2 solve and the column update of the anchor / heavy-load correction.

Every function takes plain arrays and floats (compiled with numba, ``cache=True``); the small
per-link ones are inlined (``inline="always"``) into their callers.

Core layer, compiled kernel: imports numba, numpy and :mod:`cable_sim.core.kernel.trig`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.trig import LARGE, sincos

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


# ---- link kinematics ---------------------------------------------------------------------------


@nb.njit(cache=True, inline="always")
def link_trig(q: np.ndarray, cth: np.ndarray, sth: np.ndarray) -> None:
    """``cth[i], sth[i] = cos, sin`` of link i's absolute angle ``q[i + 1]``.

    One vectorisable pass of :func:`cable_sim.core.kernel.trig.sincos` (2.5x faster than the
    libm calls, within 2 ulp of them), then the libm functions for any angle beyond
    :data:`cable_sim.core.kernel.trig.LARGE`.
    """
    for i in range(cth.shape[0]):
        cth[i], sth[i] = sincos(q[i + 1])
    for i in range(cth.shape[0]):
        if abs(q[i + 1]) > LARGE:
            cth[i] = np.cos(q[i + 1])
            sth[i] = np.sin(q[i + 1])


@nb.njit(cache=True, inline="always")
def link_trig_libm(q: np.ndarray, cth: np.ndarray, sth: np.ndarray) -> None:
    """:func:`link_trig` with the libm functions, numpy's cos and sin bit for bit: for results
    compared with numpy's at a tolerance that round-off amplified by the problem would exceed
    (a heavy load's joint forces carry the load force ``m_c a_n``, a cancellation)."""
    for i in range(cth.shape[0]):
        cth[i] = np.cos(q[i + 1])
        sth[i] = np.sin(q[i + 1])


@nb.njit(cache=True, inline="always")
def centre_velocity(
    vx: float, vz: float, li: float, c: float, s: float, w: float, current: float
) -> tuple[float, float]:
    """Velocity of a link's centre relative to the water, from its top pin's velocity."""
    hl = 0.5 * li * w
    return vx + hl * c - current, vz + hl * s


@nb.njit(cache=True, inline="always")
def next_pin_velocity(
    vx: float, vz: float, li: float, c: float, s: float, w: float
) -> tuple[float, float]:
    """Velocity of a link's bottom pin from its top pin's velocity."""
    return vx + li * c * w, vz + li * s * w


@nb.njit(cache=True, inline="always")
def link_frame_velocity(vx: float, vz: float, c: float, s: float) -> tuple[float, float]:
    """Components of (vx, vz) along the link normal ``t`` and along the link axis ``e``."""
    return vx * c + vz * s, vx * s - vz * c


@nb.njit(cache=True, inline="always")
def from_link_frame(vt: float, ve: float, c: float, s: float) -> tuple[float, float]:
    """World (x, z) of ``vt t + ve e``."""
    return vt * c + ve * s, vt * s - ve * c


@nb.njit(cache=True, inline="always")
def link_drag(
    c: float, s: float, vcx: float, vcz: float, cn: float, ct: float
) -> tuple[float, float]:
    """Morison force on one link centre (the dense ``link_drag_forces``' formula; its
    ``hypot`` written as the square root of the sum of squares, equal to round-off and without
    the libm call, which halves the cost of the drag loops)."""
    vt_mag = link_frame_velocity(vcx, vcz, c, s)[1]  # axial component, e = (s, -c)
    vtx = vt_mag * s
    vtz = -vt_mag * c
    vnx = vcx - vtx
    vnz = vcz - vtz
    vn_mag = np.sqrt(vnx * vnx + vnz * vnz)
    fx = -cn * vn_mag * vnx - ct * abs(vt_mag) * vtx
    fz = -cn * vn_mag * vnz - ct * abs(vt_mag) * vtz
    return fx, fz


# ---- joints and load ------------------------------------------------------------------------


@nb.njit(cache=True, inline="always")
def joint_torque(k: float, c: float, th: float, th_prev: float, w: float, w_prev: float) -> float:
    """Spring/damper torque of one joint on its relative angle and rate."""
    return k * (th - th_prev) + c * (w - w_prev)


@nb.njit(cache=True, inline="always")
def joint_torques(jk: np.ndarray, jc: np.ndarray, q: np.ndarray, qd: np.ndarray,
                  tau: np.ndarray) -> None:
    """``tau[0..n-1] = tau_1..tau_n`` of the joint springs/dampers on relative angles (joint 1
    relative to the vertical), and ``tau[n] = tau_(n+1) = 0`` (written in place, length n+1)."""
    n = jk.shape[0]
    th_prev = 0.0
    w_prev = 0.0
    for i in range(n):
        tau[i] = joint_torque(jk[i], jc[i], q[i + 1], th_prev, qd[i + 1], w_prev)
        th_prev = q[i + 1]
        w_prev = qd[i + 1]
    tau[n] = 0.0


@nb.njit(cache=True, inline="always")
def woodbury_load(m: np.ndarray, mc: float, constrained: bool, locked: bool) -> bool:
    """Whether the terminal load enters by Woodbury rather than as ``A_(n+1) = m_c I``.

    A heavy load (paper anchor: 8e8 kg) in the recursion would make the articulated inertias
    carry m_c-sized terms whose differences are the physical answer (cancellation). A single
    link on a locked platform keeps the direct form (``J M^-1 J^T`` is then singular; the
    recursion is exact there).
    """
    n = m.shape[0]
    if constrained or (locked and n == 1):
        return False
    line_mass = 0.0
    for i in range(n):
        line_mass += m[i]
        if line_mass >= mc:  # masses are >= 0: the whole line is at least as heavy
            return False
    return True


# ---- 2x2 articulated inertia in the link frame -------------------------------------------------


@nb.njit(cache=True, inline="always")
def link_frame(axx: float, axz: float, azz: float, c: float, s: float) -> tuple[float, float, float]:
    """``t^T A t, t^T A e, e^T A e`` of a symmetric world-frame A (xx, xz, zz).

    The rotation of :func:`to_parent_frame` with the world frame (x, -z) as the "child"
    (``x^T A (-z) = -axz``): ``t = c x - s (-z)``, ``e = s x + c (-z)``, i.e. relative cos/sin
    ``c, -s``; the sign changes are exact, so this is the same arithmetic. An isotropic A (the
    load, ``m_c I``) gives ``t^T A e = 0`` exactly.
    """
    return to_parent_frame(axx, -axz, azz, c, -s)


@nb.njit(cache=True, inline="always")
def to_world(a_tt: float, a_te: float, a_ee: float, c: float, s: float) -> tuple[float, float, float]:
    """World-frame (xx, xz, zz) of ``a_tt t t^T + a_te (t e^T + e t^T) + a_ee e e^T``.

    The rotation of :func:`to_parent_frame` with the link as the "child" and the world frame
    (x, -z) as the "parent": ``x = c t + s e`` and ``-z = -s t + c e`` for the link's
    ``t = (c, s)``, ``e = (s, -c)``; the world's xz entry is minus that frame's cross term.
    """
    axx, neg_axz, azz = to_parent_frame(a_tt, a_te, a_ee, c, s)
    return axx, -neg_axz, azz


@nb.njit(cache=True, inline="always")
def to_parent_frame(p: float, r: float, u: float, cr: float, sr: float) -> tuple[float, float, float]:
    """``t^T A t, t^T A e, e^T A e`` in a link's frame (t, e) of a symmetric A given in its
    child's frame (t', e') as ``p = t'^T A t', r = t'^T A e', u = e'^T A e'``.

    ``cr = t.t' = e.e'`` and ``sr = t.e' = -e.t'`` are the cos/sin of the child's angle minus
    the link's (:func:`relative_trig`): ``t = cr t' + sr e'``, ``e = -sr t' + cr e'``. An
    isotropic A (``p = u``, ``r = 0``) gives ``t^T A e = 0`` exactly; A enters each product
    once (the trig products do not depend on the recursion).
    """
    cc = cr * cr
    ss = sr * sr
    cs = cr * sr
    x = p * cc + r * (2.0 * cs) + u * ss
    y = (u - p) * cs + r * (cc - ss)
    z = p * ss - r * (2.0 * cs) + u * cc
    return x, y, z


@nb.njit(cache=True, inline="always")
def relative_trig(c: float, s: float, cc: float, sc: float) -> tuple[float, float]:
    """cos and sin of a child link's angle minus its parent's (child ``cc, sc``, parent
    ``c, s``)."""
    return c * cc + s * sc, c * sc - s * cc


@nb.njit(cache=True, inline="always")
def articulated_inertia(
    mn: float, me: float, x: float, y: float, z: float, xp: float
) -> tuple[float, float, float]:
    """New articulated inertia A' = mn t t^T + me e e^T + A - h h^T / D of a link in its own
    frame (``t^T A' t, t^T A' e, e^T A' e``); mn = me = m without added mass (then
    A' = m I + A - h h^T / D).

    Assembled in the link frame (t, e) to avoid cancellation in the t direction; the inward
    sweep keeps it there (its parent turns it into its own frame, :func:`to_parent_frame`).
    ``a_tt = mn (x/3 + mn/12) / xp`` is written ``(x + mn/4) (mn/3) / xp`` and the three
    divisions by xp as one reciprocal: one division on the sweep's chain instead of two in
    series.
    """
    ixp = 1.0 / xp
    a_tt = (x + 0.25 * mn) * (mn * THIRD) * ixp
    a_te = -y * (mn * SIXTH) * ixp
    a_ee = me + z - y * y * ixp
    return a_tt, a_te, a_ee


# ---- inward sweep (tip to platform) ------------------------------------------------------------


@nb.njit(cache=True, inline="always")
def bias_step(
    bx: float, bz: float, r_applied: float, fgx: float, fgz: float, li: float, mi: float,
    c: float, s: float, w2: float, y: float, aex: float, aez: float, h_x: float, h_z: float,
    inv_d: float,
) -> tuple[float, float, float]:
    """One link of the applied-force right-hand side: ``R_i`` and the new bias ``b_i``
    (``inv_d = 1 / D_i``).

    ``r_applied = -tau_i + tau_(i+1) + C_i + (l/2) t.G_i`` (couples on the link).
    """
    r0 = r_applied + li * li * w2 * y - li * (c * bx + s * bz)
    rd = r0 * inv_d
    bx += -fgx - w2 * (0.5 * mi * li * s + li * aex) + h_x * rd
    bz += -fgz - w2 * (-0.5 * mi * li * c + li * aez) + h_z * rd
    return r0, bx, bz


@nb.njit(cache=True, inline="always")
def unit_force_step(
    bx: float, bz: float, li: float, c: float, s: float, h_x: float, h_z: float, inv_d: float
) -> tuple[float, float, float]:
    """One link of a unit end-force right-hand side (no velocity, no gravity), flushed at TINY
    (``inv_d = 1 / D_i``)."""
    rk = -li * (c * bx + s * bz)
    rd = rk * inv_d
    bx += h_x * rd
    bz += h_z * rd
    if abs(bx) + abs(bz) < TINY:
        bx = 0.0
        bz = 0.0
    return rk, bx, bz


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
    link frame and one into the next).
    """
    n = l.shape[0]
    nrhs = bx.shape[0]
    # A of the child in the child's frame (p, r, u); the load's is isotropic (any frame)
    p = mload
    r = 0.0
    u = mload
    cc = 1.0
    sc = 0.0
    for i in range(n - 1, -1, -1):
        c = cth[i]
        s = sth[i]
        li = l[i]
        mi = mn[i]
        if i == n - 1:
            x, y, z = p, r, u
        else:
            cr, sr = relative_trig(c, s, cc, sc)
            x, y, z = to_parent_frame(p, r, u, cr, sr)
        cc = c
        sc = s
        xp = x + mi * THIRD
        d = li * li * xp
        # A t = x t + y e and A e = y t + z e, in world components
        atx, atz = from_link_frame(x, y, c, s)
        aex, aez = from_link_frame(y, z, c, s)
        h_x = li * atx + 0.5 * mi * li * c
        h_z = li * atz + 0.5 * mi * li * s
        inv_d = 1.0 / d  # from the inertia recursion: off the right-hand sides' chains
        idd[i] = inv_d
        hx[i] = h_x
        hz[i] = h_z
        if bias:
            ra = -tau[i] + tau[i + 1] + cpl[i] + 0.5 * li * (c * fgx[i] + s * fgz[i])
            w2 = qd[i + 1] * qd[i + 1]
            rr[0, i], bx[0], bz[0] = bias_step(
                bx[0], bz[0], ra, fgx[i], fgz[i], li, me[i], c, s, w2, y, aex, aez, h_x, h_z,
                inv_d,
            )
        for k in range(1, nrhs):
            rr[k, i], bx[k], bz[k] = unit_force_step(bx[k], bz[k], li, c, s, h_x, h_z, inv_d)
        p, r, u = articulated_inertia(mi, me[i], x, y, z, xp)
        # along a straight stretch (relative angle 0) the cross term decays geometrically
        # (factor < 1/2 per link): flushed at TINY of the inertia, long before it turns
        # subnormal (~100x slower arithmetic), far below round-off; tested every 16th link
        # only (a test per link costs ~10 % of the sweep)
        if i & 15 == 0 and abs(r) < TINY * (abs(p) + abs(u)):
            r = 0.0
    if n == 0:
        return mload
    return to_world(p, r, u, cc, sc)[2]


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
