"""Per-link terms of the O(n) operator ``M + hg D + hg^2 K`` (see
:mod:`cable_sim.integrate.implicit.operator`): the joint armature, extra rotational inertia and
anisotropic centre masses of each link (:func:`_link_terms`), the seabed contact's vertical mass
over the touching part of a link (:func:`_contact_terms`, :func:`_contact_moments`) and the
tension stiffness from the joint forces (:func:`_kgeo_from_forces`), written into the rows of the
factorisation workspace (:mod:`cable_sim.integrate.implicit.op_layout`).

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` and the sibling
``op_layout``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.contact import touching_interval
from cable_sim.core.kernel.jit import HOT_KERNEL
from cable_sim.core.kernel.links import centre_velocity, link_frame_velocity, next_pin_velocity
from cable_sim.core.kernel.trig import sincos
from cable_sim.integrate.implicit.op_layout import (
    _W_BETA,
    _W_CA,
    _W_CB,
    _W_COS,
    _W_DROT,
    _W_GE,
    _W_GT,
    _W_KGEO,
    _W_ROT,
    _W_SIN,
)


@nb.njit(cache=True, inline="always")
def _link_terms(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray, hg: float,
                kgeo: np.ndarray, G: np.ndarray, W: np.ndarray, horizon: float) -> None:
    """Per-link terms of ``M~`` at (q, qd) into W (``G``: the real geometry rows, whose
    cos/sin already hold those of q; the contact interval is written there): joint armature
    ``beta``, extra rotational inertia (paper drag ``drot``, tension stiffness ``kg``), extra
    centre masses ``g_t, g_e`` (the Jacobian of the Morison force:
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
            c = G[_W_COS, i]
            s = G[_W_SIN, i]
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
    _contact_terms(arr, par, q, qd, G, horizon)


@nb.njit(cache=True, inline="always")
def _contact_terms(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray,
                   G: np.ndarray, horizon: float) -> None:
    """Each link's seabed contact interval ``[a, b]`` into the real geometry rows G (the
    factorisation's W or, for a complex ``hg``, the real factorisation's at the same state;
    ``a = b = 0`` without; not
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
        c = G[_W_COS, i]
        s = G[_W_SIN, i]
        w = qd[i + 1]
        if horizon > 0.0:
            # in the bed now, and at the extrapolated state (k = 1, c = 0: the force is delta)
            a, b = touching_interval(pz, 0.0, c, s, 0.0, l[i], zb, 1.0, 0.0)
            ce, se = sincos(q[i + 1] + horizon * w)
            ap, bp = touching_interval(pze, 0.0, ce, se, 0.0, l[i], zb, 1.0, 0.0)
            pze -= l[i] * ce
            if b <= a:
                a, b = ap, bp
            elif bp > ap:
                a = min(a, ap)
                b = max(b, bp)
        else:
            a, b = touching_interval(pz, vz, c, s, w, l[i], zb, kb[i], cb[i])
        G[_W_CA, i] = a
        G[_W_CB, i] = b
        pz -= l[i] * c
        vz += l[i] * s * w


@nb.njit(cache=True, inline="always")
def _contact_moments(a: float, b: float) -> tuple[float, float, float]:
    """``int_a^b (1, s, s^2) ds`` written without cancellation."""
    h = b - a
    return h, 0.5 * h * (a + b), h * ((a + b) * (a + b) + a * a + b * b) / 6.0


@nb.njit(**HOT_KERNEL)
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
