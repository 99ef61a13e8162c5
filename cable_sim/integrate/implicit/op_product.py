"""The product ``hg D rd + hg K rk`` with the local damping and stiffness of the O(n) operator
(see :mod:`cable_sim.integrate.implicit.operator`): joints, platform, links' rotation
(:func:`_dk_product`), seabed contact (:func:`_contact_product`) and Morison drag
(:func:`_morison_product`).

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` and the siblings
``op_layout``, ``op_terms``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.jit import HOT_KERNEL
from cable_sim.core.kernel.links import (
    centre_velocity,
    from_link_frame,
    joint_torque,
    link_frame_velocity,
    next_pin_velocity,
)
from cable_sim.integrate.implicit.op_layout import (
    _W_CA,
    _W_CB,
    _W_COS,
    _W_DROT,
    _W_GE,
    _W_GT,
    _W_KGEO,
    _W_PX,
    _W_PZ,
    _W_SIN,
)
from cable_sim.integrate.implicit.op_terms import _contact_moments


@nb.njit(**HOT_KERNEL)
def _dk_product(arr: np.ndarray, par: np.ndarray, hg: float, G: np.ndarray, W: np.ndarray,
                rd: np.ndarray, rk: np.ndarray, out: np.ndarray) -> None:
    """``out = hg D rd + hg K rk`` with the local ``D``, ``K`` of the factorisation in W
    (``G``: its real geometry rows, W itself for a real ``hg``)."""
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
        _morison_product(l, G, W, rd, out)
    if par[17] != 0.0:
        _contact_product(arr, hg, G, W, rd, rk, out)


@nb.njit(**HOT_KERNEL)
def _contact_product(arr: np.ndarray, hg: float, G: np.ndarray, W: np.ndarray, rd: np.ndarray,
                     rk: np.ndarray, out: np.ndarray) -> None:
    """``out += int J_z^T hg (c_b J_z rd + k_b J_z rk) ds`` over each link's contact interval:
    the z "velocities" ``J_z(s) r = r_z,pin + s sin(theta) r_theta`` (linear in s), their
    resultant and first moment per link, generalised by ``J_z^T`` (reverse sums)."""
    n = arr.shape[1]
    l = arr[0]
    kb = arr[8]
    cb = arr[9]
    sth = G[_W_SIN]
    fz = W[_W_PX]  # per-link scratch: resultant and first moment of the z forces
    mzs = W[_W_PZ]
    pd = rd[0]
    pk = rk[0]
    for i in range(n):
        s = sth[i]
        a = G[_W_CA, i]
        b = G[_W_CB, i]
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


@nb.njit(**HOT_KERNEL)
def _morison_product(l: np.ndarray, G: np.ndarray, W: np.ndarray, rd: np.ndarray,
                     out: np.ndarray) -> None:
    """``out += J_c^T (hg G) J_c rd``: centre "velocities" ``J_c rd``, forces ``hg G J_c rd``,
    generalised by ``J_c^T`` (reverse sums)."""
    n = l.shape[0]
    cth = G[_W_COS]
    sth = G[_W_SIN]
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
