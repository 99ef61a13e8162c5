"""Compiled (numba) seabed contact per link and its O(n) generalised force.

The same exact piecewise integration as :func:`cable_sim.core.seabed.link_contact` written for
numba on plain floats (:func:`link_contact_nb`; the quadrature of one piece, :func:`gauss_piece`,
is the single implementation both use), one O(n) pass down the line for every link's
resultant and first moment (:func:`seabed_links_nb`, used by the forward-dynamics, joint-force
and energy kernels), and an O(n) pass that maps them to generalised forces
(Q_0 = sum F_z, Q_theta_j = t_j . (l_j sum_{i>j} F_i + S_j)).

Core layer, compiled kernel: imports numba and numpy only.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

_G1 = 0.5 - 0.5 / math.sqrt(3.0)
_G2 = 0.5 + 0.5 / math.sqrt(3.0)


@nb.njit(cache=True, inline="always")
def _sat(x: float) -> float:
    if x < -1.0:
        return -1.0
    if x > 1.0:
        return 1.0
    return x


@nb.njit(cache=True, inline="always")
def gauss_piece(
    a: float, h: float, d0: float, d1: float, z0: float, z1: float, f0: float, f1: float,
    k: float, touching: bool, friction: bool, mu_a: float, fa: float, mu_t: float, t0: float,
    t1: float, vc: float,
) -> tuple[float, float, float, float, float, float]:
    """One piece ``[a, a + h]`` of a link between breakpoints, 2-point Gauss-Legendre (exact:
    the integrands are polynomials of degree <= 3 there): (fx, fz, mx, mz, potential,
    spring_power) of :func:`link_contact_nb`, the forces only if ``touching``.

    The single implementation of the contact quadrature: the dense reference
    (:func:`cable_sim.core.seabed.link_contact`) runs it uncompiled (``gauss_piece.py_func``),
    so it calls nothing but arithmetic and the builtins ``min``/``max``.
    """
    fx = 0.0
    fz = 0.0
    mx = 0.0
    mz = 0.0
    pot = 0.0
    sp = 0.0
    wq = 0.5 * h
    for gi in range(2):
        s = a + (_G1 if gi == 0 else _G2) * h
        delta = d0 + d1 * s
        pot += wq * 0.5 * k * delta * delta
        sp += wq * k * delta * (z0 + z1 * s)
        if touching:
            fn = f0 + f1 * s
            fxs = 0.0
            if friction:
                fxs = -fn * (mu_a * fa + mu_t * min(1.0, max(-1.0, (t0 + t1 * s) / vc)))
            fz += wq * fn
            mz += wq * s * fn
            fx += wq * fxs
            mx += wq * s * fxs
    return fx, fz, mx, mz, pot, sp


@nb.njit(cache=True, inline="always")
def _clip_half_line(c0: float, c1: float, a: float, b: float) -> tuple[float, float]:
    """[a, b] intersected with {s : c0 + c1 s > 0} (empty: a == b)."""
    if c1 > 0.0:
        a = max(a, -c0 / c1)
    elif c1 < 0.0:
        b = min(b, -c0 / c1)
    elif c0 <= 0.0:
        b = a
    if b < a:
        b = a
    return a, b


@nb.njit(cache=True, inline="always")
def touching_interval(
    pz: float, vpz: float, ct: float, st: float, w: float, length: float, zb: float, k: float,
    c: float,
) -> tuple[float, float]:
    """The part [a, b] of a link (s from its upper joint) where the bed pushes on it: the
    penetration ``delta(s) = zb - z(s) > 0`` and the normal force ``k delta - c zdot > 0``
    (a == b when nowhere). Both are linear in s on a straight link, so this is an interval;
    it is where :func:`link_contact_nb` integrates the normal force, and the normal force's
    Jacobian is ``-int_a^b (k J_z^T J_z) ds`` (positions), ``-int_a^b (c J_z^T J_z) ds``
    (velocities), up to the terms the implicit operator leaves out (see
    :mod:`cable_sim.integrate.implicit.operator`). ``ct``, ``st``: cos and sin of the link's
    angle."""
    d0 = zb - pz
    d1 = ct
    if d0 <= 0.0 and d0 + d1 * length <= 0.0:
        return 0.0, 0.0
    a, b = _clip_half_line(d0, d1, 0.0, length)
    return _clip_half_line(k * d0 - c * vpz, k * d1 - c * w * st, a, b)


@nb.njit(cache=True)
def link_contact_nb(
    px: float, pz: float, vpx: float, vpz: float, ct: float, st: float, w: float, length: float,
    zb: float, k: float, c: float, mu_a: float, mu_t: float, vc: float, cuts: np.ndarray,
) -> tuple[float, float, float, float, float, float]:
    """Seabed force on one link: (fx, fz, mx, mz, potential, spring_power); see
    :func:`cable_sim.core.seabed.link_contact` for the definitions. ``ct``, ``st``: cos and sin
    of the link's angle; ``cuts``: scratch of 6 entries."""
    d0 = zb - pz
    d1 = ct
    if d0 <= 0.0 and d0 + d1 * length <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    z0 = vpz
    z1 = w * st
    ua = vpx * st - vpz * ct
    vax = ua * st
    t0 = vpx - vax
    t1 = w * ct
    f0 = k * d0 - c * z0
    f1 = k * d1 - c * z1
    friction = mu_a > 0.0 or mu_t > 0.0
    nc = 0
    cuts[nc] = 0.0
    nc += 1
    cuts[nc] = length
    nc += 1
    if d1 != 0.0:
        cuts[nc] = -d0 / d1
        nc += 1
    if f1 != 0.0:
        cuts[nc] = -f0 / f1
        nc += 1
    if friction and mu_t > 0.0 and t1 != 0.0:
        cuts[nc] = (vc - t0) / t1
        nc += 1
        cuts[nc] = (-vc - t0) / t1
        nc += 1
    # keep the cuts inside [0, l] and sort (insertion sort: at most 6 values)
    m = 0
    for j in range(nc):
        sj = cuts[j]
        if 0.0 <= sj <= length:
            cuts[m] = sj
            m += 1
    for j in range(1, m):
        key = cuts[j]
        r = j - 1
        while r >= 0 and cuts[r] > key:
            cuts[r + 1] = cuts[r]
            r -= 1
        cuts[r + 1] = key
    fa = _sat(vax / vc) if friction else 0.0
    fx = 0.0
    fz = 0.0
    mx = 0.0
    mz = 0.0
    pot = 0.0
    sp = 0.0
    for j in range(m - 1):
        a = cuts[j]
        b = cuts[j + 1]
        h = b - a
        if h <= 0.0:
            continue
        sm = 0.5 * (a + b)
        if d0 + d1 * sm <= 0.0:
            continue
        pfx, pfz, pmx, pmz, ppot, psp = gauss_piece(a, h, d0, d1, z0, z1, f0, f1, k,
                                                     f0 + f1 * sm > 0.0, friction, mu_a, fa,
                                                     mu_t, t0, t1, vc)
        fx += pfx
        fz += pfz
        mx += pmx
        mz += pmz
        pot += ppot
        sp += psp
    return fx, fz, mx, mz, pot, sp


@nb.njit(cache=True, inline="always")
def seabed_energy(l: np.ndarray, zb: float, kb: np.ndarray, z0: float, cth: np.ndarray,
                  sth: np.ndarray) -> float:
    """The bed's elastic energy ``sum_i int 1/2 k_i delta(s)^2 ds`` [J] over the penetrated
    part of each link (``delta(s) = zb - z(s) > 0``), the potential of
    :func:`seabed_links_nb` without the forces: the penetration is linear in s on a link, so
    its square is integrated exactly by the 2-point Gauss rule on the one interval where it is
    positive (:func:`gauss_piece` splits that interval further where the forces change form;
    the energy is the same polynomial on every piece). ``z0`` is the platform heave, ``cth``,
    ``sth`` the links' cos/sin."""
    pot = 0.0
    pz = z0
    for i in range(l.shape[0]):
        d0 = zb - pz
        d1 = cth[i]
        li = l[i]
        if d0 > 0.0 or d0 + d1 * li > 0.0:
            a, b = _clip_half_line(d0, d1, 0.0, li)
            h = b - a
            if h > 0.0:
                e0 = d0 + d1 * (a + _G1 * h)
                e1 = d0 + d1 * (a + _G2 * h)
                pot += 0.25 * h * kb[i] * (e0 * e0 + e1 * e1)
        pz -= li * d1
    return pot


# ``_nrt=True`` set here, not inherited: the hot kernels that call it compile without numba's
# runtime (:data:`cable_sim.core.kernel.jit.HOT_KERNEL`), and this one allocates its scratch
@nb.njit(cache=True, _nrt=True)
def seabed_links_nb(
    l: np.ndarray, zb: float, kb: np.ndarray, cb: np.ndarray, mua: np.ndarray, mut: np.ndarray,
    vc: float, q: np.ndarray, qd: np.ndarray, cth: np.ndarray, sth: np.ndarray, F: np.ndarray,
    S: np.ndarray,
) -> tuple[float, float]:
    """Per-link resultants ``F`` (n, 2) and first moments ``S`` (n, 2) (written in place), in one
    O(n) pass down the line; returns (bed elastic energy, spring power). ``cth``, ``sth``: the
    links' cos/sin at q (:func:`cable_sim.core.kernel.links.link_trig`)."""
    n = l.shape[0]
    px = 0.0
    pz = q[0]
    vx = 0.0
    vz = qd[0]
    pot = 0.0
    sp = 0.0
    cuts = np.empty(6)
    for i in range(n):
        w = qd[i + 1]
        c = cth[i]
        s = sth[i]
        fx, fz, mx, mz, e, pw = link_contact_nb(px, pz, vx, vz, c, s, w, l[i], zb, kb[i], cb[i],
                                                mua[i], mut[i], vc, cuts)
        F[i, 0] = fx
        F[i, 1] = fz
        S[i, 0] = mx
        S[i, 1] = mz
        pot += e
        sp += pw
        px += l[i] * s
        pz -= l[i] * c
        vx += l[i] * c * w
        vz += l[i] * s * w
    return pot, sp


@nb.njit(cache=True)
def generalised_from_links_nb(
    l: np.ndarray, q: np.ndarray, F: np.ndarray, S: np.ndarray, Q: np.ndarray
) -> None:
    """Q += J^T of per-link forces given as resultants F and first moments S (O(n), from the tip)."""
    n = l.shape[0]
    bx = 0.0
    bz = 0.0
    for i in range(n - 1, -1, -1):
        th = q[i + 1]
        Q[i + 1] += math.cos(th) * (l[i] * bx + S[i, 0]) + math.sin(th) * (l[i] * bz + S[i, 1])
        bx += F[i, 0]
        bz += F[i, 1]
    Q[0] += bz
