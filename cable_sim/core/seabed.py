"""Seabed contact of the n-link cable: per-link contact integrals and output helpers (pure numpy).

A point of link i at distance s from its upper joint is r(s) = p_{i-1} + s e_i (MODEL.md,
"Round 2 terms"). With the flat seabed at z = z_b its penetration is delta(s) = z_b - z(s), linear
in s on a straight link. Per unit length the bed pushes up with

    f_z(s) = max(0, k_b delta(s) - c_b zdot(s))      where delta(s) > 0, else 0

(spring-damper, never pulling down) and, optionally, resists horizontal slip with a smoothed
Coulomb law (MoorDyn's "cv" form): the slip velocity's horizontal part is split into the part
along the link axis (axial) and the rest (transverse); each gets

    f = -mu f_z sat(v / v_c),   sat(x) = clip(x, -1, 1)

(linear below the regularisation speed v_c, Coulomb above). Every integrand is polynomial in s
between the breakpoints (delta = 0, f_z = 0, slip = +-v_c); :func:`link_contact` integrates each
piece with 2-point Gauss-Legendre, exact up to cubics, so the link's resultant force and its
first moment are exact (no quadrature error). That piece's quadrature is written once, in
:func:`cable_sim.core.kernel.contact.gauss_piece`, and run here uncompiled.

Also the outputs a mooring engineer looks at: touchdown point, laid length, total seabed
reaction (:func:`touchdown`). This module imports numpy, :mod:`cable_sim.core.model` and (on
first use) :mod:`cable_sim.core.kernel.contact`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cable_sim.core.kinematics import joint_positions
from cable_sim.core.model import CableModel

_PIECE = None


def _gauss_piece():
    """The quadrature of one piece (:func:`cable_sim.core.kernel.contact.gauss_piece`), run
    uncompiled. Imported on first use, not at the top: :mod:`cable_sim.core.kernel` imports
    :mod:`cable_sim.core.dynamics`, which imports this module."""
    global _PIECE
    if _PIECE is None:
        from cable_sim.core.kernel.contact import gauss_piece

        _PIECE = gauss_piece.py_func
    return _PIECE


def _links_compiled():
    """:func:`cable_sim.core.kernel.contact.seabed_links_nb` (compiled; imported on first use for
    the reason given in :func:`_gauss_piece`)."""
    from cable_sim.core.kernel.contact import seabed_links_nb

    return seabed_links_nb


def _sat(x: float) -> float:
    return -1.0 if x < -1.0 else (1.0 if x > 1.0 else x)


def link_contact(
    px: float, pz: float, vpx: float, vpz: float, th: float, w: float, length: float,
    zb: float, k: float, c: float, mu_a: float, mu_t: float, vc: float,
) -> tuple[float, float, float, float, float, float]:
    """Seabed force on one straight link, integrated exactly over its length.

    Parameters
    ----------
    px, pz, vpx, vpz : float
        Position [m] and velocity [m/s] of the link's upper joint.
    th, w : float
        Link angle theta_i [rad] (from the downward vertical) and its rate [rad/s].
    length : float
        Link length l_i [m].
    zb : float
        Seabed height [m].
    k, c : float
        Contact stiffness [N/m^2] and damping [N s/m^2] per unit length.
    mu_a, mu_t, vc : float
        Axial and transverse friction coefficients, regularisation speed [m/s] (vc > 0).

    Returns
    -------
    fx, fz : float
        Resultant force on the link [N].
    mx, mz : float
        First moments int s f ds [N m] (s from the upper joint).
    potential : float
        Elastic energy int 1/2 k delta^2 ds over the penetrating part [J].
    spring_power : float
        int k delta zdot ds over the penetrating part [W] (= -d(potential)/dt).
    """
    ct, st = math.cos(th), math.sin(th)
    d0, d1 = zb - pz, ct  # delta(s) = d0 + d1 s
    if d0 <= 0.0 and d0 + d1 * length <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    z0, z1 = vpz, w * st  # zdot(s)
    x0, x1 = vpx, w * ct  # xdot(s)
    ua = vpx * st - vpz * ct  # slip along the axis, uniform along the link
    vax = ua * st  # its horizontal part
    t0, t1 = vpx - vax, x1  # transverse horizontal slip v_tx(s)
    f0, f1 = k * d0 - c * z0, k * d1 - c * z1  # k delta - c zdot
    friction = mu_a > 0.0 or mu_t > 0.0
    cuts = [0.0, length]
    for a0, a1 in ((d0, d1), (f0, f1)):
        if a1 != 0.0:
            cuts.append(-a0 / a1)
    if friction and mu_t > 0.0 and t1 != 0.0:
        cuts.append((vc - t0) / t1)
        cuts.append((-vc - t0) / t1)
    cuts = sorted(s for s in cuts if 0.0 <= s <= length)
    fa = _sat(vax / vc) if friction else 0.0
    piece = _gauss_piece()
    fx = fz = mx = mz = pot = sp = 0.0
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        h = b - a
        if h <= 0.0:
            continue
        sm = 0.5 * (a + b)
        if d0 + d1 * sm <= 0.0:
            continue
        r = piece(a, h, d0, d1, z0, z1, f0, f1, k, f0 + f1 * sm > 0.0, friction, mu_a, fa, mu_t,
                  t0, t1, vc)
        fx, fz, mx, mz = fx + r[0], fz + r[1], mx + r[2], mz + r[3]
        pot, sp = pot + r[4], sp + r[5]
    del x0
    return fx, fz, mx, mz, pot, sp


@dataclass(frozen=True)
class SeabedOutputs:
    """What lies on the seabed (all zero / nan when the scene has no seabed).

    Attributes
    ----------
    touchdown_arc : float
        Arc length [m] from the line's end (the anchor) to the touchdown point, the uppermost
        point of the line in contact with the bed (0 when nothing touches).
    touchdown_x : float
        x of the touchdown point [m] (nan when nothing touches).
    laid_length : float
        Total length of line below the bed level [m].
    reaction : float
        Total vertical seabed force on the line [N] (spring and damper).
    """

    touchdown_arc: float
    touchdown_x: float
    laid_length: float
    reaction: float


def seabed_outputs(model: CableModel, q: np.ndarray, qd: np.ndarray | None = None) -> SeabedOutputs:
    """Touchdown point, laid length and total seabed reaction of a state (O(n)).

    Parameters
    ----------
    model : CableModel
    q : ndarray (n+1,)
        Generalised positions.
    qd : ndarray (n+1,), optional
        Generalised velocities (default: at rest; they only enter the reaction's damping part).
    """
    if not model.seabed:
        return SeabedOutputs(0.0, float("nan"), 0.0, 0.0)
    qd = np.zeros_like(q) if qd is None else qd
    p = joint_positions(model, q)
    zb, l, n = model.seabed_z, model.length, model.n
    d = zb - p[:, 1]  # penetration at every joint
    da, db = d[:-1], d[1:]  # at both ends of each link
    inside = (da > 0.0) | (db > 0.0)
    if not inside.any():
        return SeabedOutputs(0.0, float("nan"), 0.0, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = np.where(inside & ((da <= 0.0) | (db <= 0.0)), da / (da - db), 0.0)
    # fraction of each link below the bed and where (from its upper joint) that part starts
    frac_in = np.where(da > 0.0, np.where(db > 0.0, 1.0, cross), np.where(db > 0.0, 1.0 - cross, 0.0))
    start = np.where((da <= 0.0) & (db > 0.0), cross, 0.0)
    # a sum and nonzero, not np.dot / np.argmax: those release the GIL at every call (BLAS,
    # argmax), which costs a recording node's simulation thread a thread hand-over each time
    laid = float((frac_in * l).sum())
    i = int(inside.nonzero()[0][0])  # the first link (from the fairlead) below the bed
    frac = float(start[i])
    s_td = float(l[:i].sum()) + frac * l[i]
    x_td = p[i, 0] + frac * (p[i + 1, 0] - p[i, 0])
    F, S, zero = np.empty((n, 2)), np.empty((n, 2)), np.zeros(n)
    _links_compiled()(l, zb, model.seabed_k, model.seabed_c, zero, zero, 1.0, q, qd,
                      np.cos(q[1:]), np.sin(q[1:]), F, S)
    reaction = float(F[:, 1].sum())
    return SeabedOutputs(float(l.sum() - s_td), float(x_td), laid, reaction)
