"""Internal joint forces in O(n) by the Newton recursion from the line's end (compiled).

With a seabed, each link's contact resultant is subtracted like its drag; with added mass, the
link's added-mass force -l A a_c (A = m_an t t^T + m_at e e^T, a_c the centre acceleration) is.

Core layer, compiled kernel: imports numba, numpy, :mod:`cable_sim.core.kernel.links`,
:mod:`cable_sim.core.kernel.contact`, :mod:`cable_sim.core.kernel.packing` and
:mod:`cable_sim.core.model`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.contact import seabed_links_nb
from cable_sim.core.kernel.links import link_trig_libm, morison_drag
from cable_sim.core.kernel.packing import pack_arrays, vec
from cable_sim.core.model import CableModel

#: Rows of the joint-force workspace (:func:`jf_workspace`): link cos/sin, link-centre
#: accelerations (x, z), per-link applied forces other than gravity (x, z), four rows
#: holding the seabed's per-link resultants and first moments ((n, 2) each), and the Morison
#: drag's pin velocities (x, z).
JF_ROWS = 12
_J_COS, _J_SIN, _J_ACX, _J_ACZ, _J_DFX, _J_DFZ, _J_BED, _J_PVX, _J_PVZ = 0, 1, 2, 3, 4, 5, 6, 10, 11


@nb.njit(cache=True)
def jf_workspace(n: int) -> np.ndarray:
    """Scratch of :func:`joint_forces_packed_ws` for n links, shape ``(JF_ROWS, n + 1)``; it
    carries nothing from one call to the next (every entry read is written first)."""
    return np.empty((JF_ROWS, n + 1))


@nb.njit(cache=True)
def joint_forces_packed_ws(arr: np.ndarray, par: np.ndarray, lamx: float, lamz: float,
                           q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, cth: np.ndarray,
                           sth: np.ndarray, ws: np.ndarray, out: np.ndarray) -> None:
    """Joint forces by the Newton recursion from the end (see ``dynamics.joint_forces``) on the
    packed model into ``out`` (n+1, 2); ``cth, sth``: cos/sin of the links' angles ``q[1:]``
    (e.g. those the forward dynamics just computed); ``ws``: the caller's scratch
    (:func:`jf_workspace`). The model is unpacked here (a compiled call costs per array
    argument)."""
    l, m, mw, cn, ct = arr[0], arr[1], arr[2], arr[6], arr[7]
    kb, cb, mua, mut, mn, me = arr[8], arr[9], arr[10], arr[11], arr[12], arr[13]
    current, drag, mc, mcw, g = par[0], int(par[1]), par[2], par[3], par[9]
    constrained, seabed, zb, vc = par[10] != 0.0, par[17] != 0.0, par[18], par[19]
    n = l.shape[0]
    acx = ws[_J_ACX]  # link-centre accelerations
    acz = ws[_J_ACZ]
    dfx = ws[_J_DFX]  # Morison drag (and seabed, added mass) on the centres
    dfz = ws[_J_DFZ]
    # joint accelerations summed in the dense order (cumulative sum, platform added last) so
    # that the load force m_c a_n, which is a cancellation for a heavy load, rounds alike
    ax = 0.0
    az = 0.0
    for i in range(n):
        li = l[i]
        c = cth[i]
        s = sth[i]
        w = qd[i + 1]
        a = qdd[i + 1]
        ax_next = ax + li * (c * a - s * w * w)
        az_next = az + li * (s * a + c * w * w)
        acx[i] = 0.5 * (ax + ax_next)
        acz[i] = 0.5 * ((az + qdd[0]) + (az_next + qdd[0]))
        ax = ax_next
        az = az_next
    for i in range(n):
        dfx[i] = 0.0
        dfz[i] = 0.0
    if drag == 2:  # the same Morison forces as the forward dynamics (one implementation)
        morison_drag(l, cn, ct, current, qd, cth, sth, dfx, dfz, ws[_J_PVX], ws[_J_PVZ])
    out[n, 0] = 0.0
    out[n, 1] = 0.0
    if constrained:
        out[n, 0] = -lamx
        out[n, 1] = -lamz
    else:
        out[n, 0] = mc * ax
        out[n, 1] = mc * (az + qdd[0]) + mcw * g
    if seabed:
        F = ws[_J_BED:_J_BED + 2].reshape(-1)[:2 * n].reshape((n, 2))
        S = ws[_J_BED + 2:_J_BED + 4].reshape(-1)[:2 * n].reshape((n, 2))
        seabed_links_nb(l, zb, kb, cb, mua, mut, vc, q, qd, cth, sth, F, S)
        for i in range(n):
            dfx[i] += F[i, 0]
            dfz[i] += F[i, 1]
    for i in range(n):
        man = mn[i] - m[i]
        mat = me[i] - m[i]
        if man != 0.0 or mat != 0.0:  # added-mass force -l A a_c on the link
            c = cth[i]
            s = sth[i]
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


@nb.njit(cache=True)
def joint_forces_packed(arr: np.ndarray, par: np.ndarray, lamx: float, lamz: float, q: np.ndarray,
                        qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """:func:`joint_forces_packed_ws` with scratch of its own (allocates; returns F (n+1, 2);
    the links' cos/sin from the libm functions, as numpy's)."""
    n = arr.shape[1]
    ws = jf_workspace(n)
    link_trig_libm(q, ws[_J_COS, :n], ws[_J_SIN, :n])
    out = np.empty((n + 1, 2))
    joint_forces_packed_ws(arr, par, lamx, lamz, q, qd, qdd, ws[_J_COS, :n], ws[_J_SIN, :n], ws,
                           out)
    return out


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
    arr, par = pack_arrays(model)
    lamx, lamz = (0.0, 0.0) if anchor_force is None else (float(anchor_force[0]),
                                                          float(anchor_force[1]))
    return joint_forces_packed(arr, par, lamx, lamz, vec(q, k, "q"), vec(qd, k, "qd"),
                               vec(qdd, k, "qdd"))
