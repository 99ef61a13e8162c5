"""Three forward dynamics of one model at once (:func:`fd3_packed_ws`): the stage evaluations
of an implicit Runge-Kutta iteration (Radau IIA evaluates its three stages together, at states
known before any of them is evaluated).

Same arithmetic per state as :func:`cable_sim.core.kernel.forward.fd_packed_ws` (the same
inlined steps: :func:`~cable_sim.core.kernel.sweeps.child_inertia`,
:func:`~cable_sim.core.kernel.sweeps.bias_step`, ...), so the results are those of three calls
bit for bit where the compiler fuses the same operations (equal to round-off in any case). What
differs is the order: the inward and the outward recursions are chains of dependent operations
per link (on the inward one a division waits on the previous link's inertia), and one state's
chain leaves most of the core's units idle while it waits on their latencies. Here the three
states' recursions run side by side in one loop over the links, three independent chains the
core overlaps; the factors without a carried dependence (cos/sin, forces, the sweeps' per-link
factors) are formed per state in the loops that vectorise, as before.

Free end only (no anchor, no heavy load: the recursions carry one right-hand side); for the
other ends the three states are evaluated one after the other by ``fd_packed_ws``.

Core layer, compiled kernel: imports numba, numpy and the kernel's ``forward``, ``frames``,
``packing`` and ``sweeps``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.forward import (
    _F_COS,
    _F_CPL,
    _F_FGX,
    _F_FGZ,
    _F_SIN,
    _F_SW,
    _F_TAU,
    applied_generalised_forces,
    fd_packed_ws,
    platform_force,
)
from cable_sim.core.kernel.frames import to_world
from cable_sim.core.kernel.jit import HOT_KERNEL
from cable_sim.core.kernel.packing import ARR_MK
from cable_sim.core.kernel.sweeps import (
    _K_HM,
    _K_IL2,
    _K_M3,
    _K_M4,
    _K_M6,
    _S_CC,
    _S_CS,
    _S_GX,
    _S_GZ,
    _S_LC,
    _S_LS,
    _S_SS,
    MK_ROWS,
    SW_ROWS,
    articulated_parts,
    bias_step,
    child_inertia,
    flush_cross,
    link_coupling,
    outward_bias_link,
    outward_bias_map,
    sweep_prep,
)


@nb.njit(cache=True, inline="always")
def _prepare(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray, ws: np.ndarray
             ) -> np.ndarray:
    """One state's applied forces and the inward sweep's per-link factors into its workspace
    ``ws``; returns the sweep's scratch rows."""
    n = arr.shape[1]
    applied_generalised_forces(arr, par, q, qd, ws, False)
    sw = ws[_F_SW:_F_SW + SW_ROWS]
    sweep_prep(arr[0], arr[ARR_MK:ARR_MK + MK_ROWS], ws[_F_COS, :n], ws[_F_SIN, :n], qd,
               ws[_F_TAU, :n + 1], ws[_F_CPL, :n], ws[_F_FGX, :n], ws[_F_FGZ, :n], True, sw)
    return sw


@nb.njit(cache=True, inline="always")
def _inward_link(i: int, last: bool, mload: float, mk: np.ndarray, me: float, sc: np.ndarray,
                 st: tuple) -> tuple:
    """One link of the free end's inward sweep
    (:func:`cable_sim.core.kernel.sweeps.inward_sweep_ws` with ``bias``, one right-hand side,
    not ``full``) for one state: its scratch ``sc`` and carried ``st = (ixp, kp, kr, ku, cu,
    b_x, b_z)`` (the child's articulated parts and end force) to the link's own."""
    ixp, kp, kr, ku, cu, b0x, b0z = st
    x, y, z, xp = child_inertia(last, mload, mk[_K_M3, i], ixp, kp, kr, ku, cu, sc[_S_CC, i],
                                sc[_S_SS, i], sc[_S_CS, i])
    ixp = 1.0 / xp
    inv_d = ixp * mk[_K_IL2, i]
    lc = sc[_S_LC, i]
    ls = sc[_S_LS, i]
    h_x, h_z = link_coupling(x, y, mk[_K_HM, i], lc, ls)
    sc[_S_GX, i] = h_x * inv_d
    sc[_S_GZ, i] = h_z * inv_d
    _, _, b0x, b0z = bias_step(sc, i, y, z, lc, ls, h_x, h_z, inv_d, b0x, b0z)
    ixp, kp, kr, ku, cu = articulated_parts(mk[_K_M3, i], mk[_K_M4, i], mk[_K_M6, i], me, x, y, z,
                                            xp)
    return ixp, kp, flush_cross(i, ixp, kp, kr, ku, cu), ku, cu, b0x, b0z


@nb.njit(cache=True, inline="always")
def _platform_acceleration(par: np.ndarray, u: float, eta: float, q: np.ndarray, qd: np.ndarray,
                           st: tuple, mload: float, c0: float, s0: float, n: int) -> float:
    """The platform's heave acceleration after a state's inward sweep (``st``: its carried
    parts at the first link, ``c0, s0``: that link's cos/sin; 0 when heave-locked)."""
    if par[7] != 0.0:
        return 0.0
    ixp, kp, kr, ku, cu, _, b0z = st
    azz = mload if n == 0 else to_world(kp * ixp, kr * ixp, cu + ku * ixp, c0, s0)[2]
    return (platform_force(par, u, eta, q, qd) - b0z) / (par[4] + azz)


@nb.njit(**HOT_KERNEL)
def fd3_packed_ws(arr: np.ndarray, par: np.ndarray, u: np.ndarray, eta: np.ndarray,
                  q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, lam: np.ndarray,
                  ws0: np.ndarray, ws1: np.ndarray, ws2: np.ndarray) -> bool:
    """The forward dynamics at three states: row k of ``q, qd`` (3, n+1) into row k of ``qdd``,
    with the inputs ``u[k], eta[k]`` and the workspace ``ws0``, ``ws1`` or ``ws2``
    (:func:`cable_sim.core.kernel.forward.fd_workspace`; each left as ``fd_packed_ws`` leaves
    it, e.g. the links' cos/sin of its state for
    :func:`~cable_sim.core.kernel.forward.fd_trig`); ``lam`` as there (the last state's anchor
    reaction). Returns False if one of them failed (an anchored end's singular constraint)."""
    n = arr.shape[1]
    if par[10] != 0.0 or par[20] != 0.0:  # anchored or a heavy load: one after the other
        return (fd_packed_ws(arr, par, u[0], eta[0], q[0], qd[0], qdd[0], lam, ws0)
                and fd_packed_ws(arr, par, u[1], eta[1], q[1], qd[1], qdd[1], lam, ws1)
                and fd_packed_ws(arr, par, u[2], eta[2], q[2], qd[2], qdd[2], lam, ws2))
    lam[0] = 0.0
    lam[1] = 0.0
    sa = _prepare(arr, par, q[0], qd[0], ws0)
    sb = _prepare(arr, par, q[1], qd[1], ws1)
    sc = _prepare(arr, par, q[2], qd[2], ws2)
    mk = arr[ARR_MK:ARR_MK + MK_ROWS]
    me = arr[13]
    mload = par[2]
    a = b = c = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, par[3] * par[9])  # the load's weight at the end
    for i in range(n - 1, -1, -1):
        last = i == n - 1
        a = _inward_link(i, last, mload, mk, me[i], sa, a)
        b = _inward_link(i, last, mload, mk, me[i], sb, b)
        c = _inward_link(i, last, mload, mk, me[i], sc, c)
    za = _platform_acceleration(par, u[0], eta[0], q[0], qd[0], a, mload, ws0[_F_COS, 0],
                                ws0[_F_SIN, 0], n)
    zb = _platform_acceleration(par, u[1], eta[1], q[1], qd[1], b, mload, ws1[_F_COS, 0],
                                ws1[_F_SIN, 0], n)
    zc = _platform_acceleration(par, u[2], eta[2], q[2], qd[2], c, mload, ws2[_F_COS, 0],
                                ws2[_F_SIN, 0], n)
    outward_bias_map(sa, n)
    outward_bias_map(sb, n)
    outward_bias_map(sc, n)
    qdd[0, 0] = za
    qdd[1, 0] = zb
    qdd[2, 0] = zc
    ax0, az0, ax1, az1, ax2, az2 = 0.0, za, 0.0, zb, 0.0, zc
    for i in range(n):
        qdd[0, i + 1], ax0, az0 = outward_bias_link(sa, i, ax0, az0)
        qdd[1, i + 1], ax1, az1 = outward_bias_link(sb, i, ax1, az1)
        qdd[2, i + 1], ax2, az2 = outward_bias_link(sc, i, ax2, az2)
    return True


__all__ = ["fd3_packed_ws"]
