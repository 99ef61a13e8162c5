"""Per-link terms of the planar chain (``MODEL.md``): kinematics, drag, joint torques, the load.

* the links' cos/sin (:func:`link_trig`, vectorised; :func:`link_trig_libm`, numpy's bit for bit);
* a link centre's velocity relative to the water, the next pin's velocity, a velocity in the
  link frame (``t = (cos, sin)`` normal, ``e = (sin, -cos)`` axis) and back;
* the Morison drag forces on the link centres (:func:`morison_drag`, for the forward dynamics
  and the joint forces alike); the joint spring/damper torques;
* whether the terminal load enters the recursion by Woodbury.

Used by the sweeps (:mod:`cable_sim.core.kernel.sweeps`), the forward dynamics, the joint
forces, the energy and the checks. Every function takes plain arrays and floats (compiled with
numba, ``cache=True``, inlined into its callers).

Core layer, compiled kernel: imports numba, numpy and :mod:`cable_sim.core.kernel.trig`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.trig import LARGE, sincos

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
def morison_drag(
    l: np.ndarray, cn: np.ndarray, ct: np.ndarray, current: float, qd: np.ndarray,
    cth: np.ndarray, sth: np.ndarray, fgx: np.ndarray, fgz: np.ndarray, pvx: np.ndarray,
    pvz: np.ndarray,
) -> None:
    """Add the Morison force on each link centre to ``fgx, fgz`` (the dense
    ``link_drag_forces``' force, equal to round-off), in two loops: the top pins' velocities (a
    running sum, into the scratch ``pvx, pvz``, length n), then the forces, without a value
    carried from one link to the next or a branch (it vectorises). The forward dynamics and the
    joint forces both use it.

    The force is formed in the link frame: the centre's velocity relative to the water has the
    normal component ``v_n = (v_pin - current x) . t + w l/2`` and the axial one
    ``v_e = (v_pin - current x) . e``, and ``F = -c_n |v_n| v_n t - c_t |v_e| v_e e``. (The
    normal part ``v - v_e e`` of the dense formula is ``v_n t``, its length ``|v_n|``: no square
    root, and no cancellation when the flow is nearly axial.)
    """
    n = l.shape[0]
    vx = 0.0
    vz = qd[0]
    for i in range(n):
        pvx[i] = vx
        pvz[i] = vz
        vx, vz = next_pin_velocity(vx, vz, l[i], cth[i], sth[i], qd[i + 1])
    for i in range(n):
        c = cth[i]
        s = sth[i]
        vx = pvx[i] - current
        vz = pvz[i]
        vn, ve = link_frame_velocity(vx, vz, c, s)
        vn += 0.5 * l[i] * qd[i + 1]
        fn = -cn[i] * abs(vn) * vn
        fe = -ct[i] * abs(ve) * ve
        fx, fz = from_link_frame(fn, fe, c, s)
        fgx[i] += fx
        fgz[i] += fz


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
    if n > 0:
        tau[0] = joint_torque(jk[0], jc[0], q[1], 0.0, qd[1], 0.0)
    for i in range(1, n):  # no value carried from one joint to the next: it vectorises
        tau[i] = joint_torque(jk[i], jc[i], q[i + 1], q[i], qd[i + 1], qd[i])
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
