"""Kinetic and potential energy of the chain in O(n) (compiled): link-centre velocities and
spins, platform and load; heights for gravity, relative angles for the joint springs.

Core layer, compiled kernel: imports numba, numpy, the kernel's ``contact``, ``links`` and
``packing`` and :mod:`cable_sim.core.model`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.contact import seabed_energy
from cable_sim.core.kernel.links import centre_velocity, link_trig, next_pin_velocity
from cable_sim.core.kernel.packing import pack, vec
from cable_sim.core.model import CableModel

#: 1/12 (a multiply per link instead of a division: equal to round-off).
_TWELFTH = 1.0 / 12.0


@nb.njit(cache=True)
def _energy_kernel(l: np.ndarray, m: np.ndarray, mw: np.ndarray, jk: np.ndarray, mc: float, mcw: float,
                   mp: float, hk: float, g: float, q: np.ndarray, qd: np.ndarray, seabed: bool,
                   zb: float, kb: np.ndarray) -> tuple[float, float]:
    """Kinetic and potential energy in O(n) from link-centre velocities and heights; with a
    seabed, V includes its elastic energy sum int 1/2 k_b delta^2 ds."""
    n = l.shape[0]
    trig = np.empty((2, n))  # the links' cos/sin in one vectorised pass first (twice as fast)
    link_trig(q, trig[0], trig[1])
    return energy_terms(l, m, mw, jk, mc, mcw, mp, hk, g, q, qd, seabed, zb, kb, trig[0], trig[1])


@nb.njit(cache=True, inline="always")
def energy_terms(l: np.ndarray, m: np.ndarray, mw: np.ndarray, jk: np.ndarray, mc: float,
                 mcw: float, mp: float, hk: float, g: float, q: np.ndarray, qd: np.ndarray,
                 seabed: bool, zb: float, kb: np.ndarray, cth: np.ndarray,
                 sth: np.ndarray) -> tuple[float, float]:
    """:func:`_energy_kernel` with the links' cos/sin at q given (``cth``, ``sth``, e.g. left by
    the caller's :func:`cable_sim.core.kernel.links.link_trig`)."""
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
        c = cth[i]
        s = sth[i]
        w = qd[i + 1]
        vcx, vcz = centre_velocity(vx, vz, li, c, s, w, 0.0)
        t_kin += 0.5 * m[i] * (vcx * vcx + vcz * vcz) + 0.5 * (m[i] * li * li * _TWELFTH) * w * w
        pz_next = pz - li * c
        v_grav += mw[i] * 0.5 * (pz + pz_next)
        phi = q[i + 1] - th_prev
        v_spr += 0.5 * jk[i] * phi * phi
        th_prev = q[i + 1]
        pz = pz_next
        vx, vz = next_pin_velocity(vx, vz, li, c, s, w)
    t_kin += 0.5 * mc * (vx * vx + vz * vz)
    v_grav += mcw * pz
    if seabed:
        v_spr += seabed_energy(l, zb, kb, q[0], cth, sth)
    return t_kin, g * v_grav + v_spr


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
    p = pack(model)
    t_kin, v_pot = _energy_kernel(
        p[0], p[1], p[2], p[3], p[10], p[11], p[12], p[13], p[17],
        vec(q, k, "q"), vec(qd, k, "qd"), p[23], p[24], p[25],
    )
    return float(t_kin), float(v_pot)
