"""Internal joint forces in O(n) by the Newton recursion from the line's end (compiled).

With a seabed, each link's contact resultant is subtracted like its drag; with added mass, the
link's added-mass force -l A a_c (A = m_an t t^T + m_at e e^T, a_c the centre acceleration) is.

Core layer, compiled kernel: imports numba, numpy, :mod:`cable_sim.core.kernel.sweeps`,
:mod:`cable_sim.core.kernel.contact`, :mod:`cable_sim.core.kernel.packing` and
:mod:`cable_sim.core.model`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.contact import seabed_links_nb
from cable_sim.core.kernel.packing import pack, vec
from cable_sim.core.kernel.sweeps import centre_velocity, link_drag, next_pin_velocity
from cable_sim.core.model import CableModel


@nb.njit(cache=True)
def _joint_forces_kernel(
    l: np.ndarray, m: np.ndarray, mw: np.ndarray, cn: np.ndarray, ct: np.ndarray, current: float,
    drag: int, mc: float, mcw: float, g: float, constrained: bool, lamx: float, lamz: float,
    q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, seabed: bool, zb: float, kb: np.ndarray,
    cb: np.ndarray, mua: np.ndarray, mut: np.ndarray, vc: float, mn: np.ndarray, me: np.ndarray,
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
            vcx, vcz = centre_velocity(vx, vz, li, c, s, w, current)
            dfx[i], dfz[i] = link_drag(c, s, vcx, vcz, cn[i], ct[i])
        vx, vz = next_pin_velocity(vx, vz, li, c, s, w)
    out = np.zeros((n + 1, 2))
    if constrained:
        out[n, 0] = -lamx
        out[n, 1] = -lamz
    else:
        out[n, 0] = mc * ax
        out[n, 1] = mc * (az + qdd[0]) + mcw * g
    if seabed:
        F = np.empty((n, 2))
        S = np.empty((n, 2))
        seabed_links_nb(l, zb, kb, cb, mua, mut, vc, q, qd, F, S)
        for i in range(n):
            dfx[i] += F[i, 0]
            dfz[i] += F[i, 1]
    for i in range(n):
        man = mn[i] - m[i]
        mat = me[i] - m[i]
        if man != 0.0 or mat != 0.0:  # added-mass force -l A a_c on the link
            c = np.cos(q[i + 1])
            s = np.sin(q[i + 1])
            at = c * acx[i] + s * acz[i]
            ae = s * acx[i] - c * acz[i]
            dfx[i] -= man * at * c + mat * ae * s
            dfz[i] -= man * at * s - mat * ae * c
    fx = out[n, 0]
    fz = out[n, 1]
    for i in range(n - 1, -1, -1):
        fx += m[i] * acx[i] - dfx[i]
        fz += m[i] * acz[i] - dfz[i] + mw[i] * g
        out[i, 0] = fx
        out[i, 1] = fz
    return out


@nb.njit(cache=True)
def joint_forces_packed(arr: np.ndarray, par: np.ndarray, lamx: float, lamz: float, q: np.ndarray,
                        qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """:func:`_joint_forces_kernel` on the packed model."""
    return _joint_forces_kernel(
        arr[0], arr[1], arr[2], arr[6], arr[7], par[0], int(par[1]), par[2], par[3], par[9],
        par[10] != 0.0, lamx, lamz, q, qd, qdd, par[17] != 0.0, par[18], arr[8], arr[9], arr[10],
        arr[11], par[19], arr[12], arr[13],
    )


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
    p = pack(model)
    lamx, lamz = (0.0, 0.0) if anchor_force is None else (float(anchor_force[0]),
                                                          float(anchor_force[1]))
    return _joint_forces_kernel(
        p[0], p[1], p[2], p[6], p[7], p[8], p[9], p[10], p[11], p[17], p[18], lamx, lamz,
        vec(q, k, "q"), vec(qd, k, "qd"), vec(qdd, k, "qdd"), *p[23:32],
    )
