"""Solve with a factorised O(n) operator ``M + hg D + hg^2 K`` (see
:mod:`cable_sim.integrate.implicit.operator`): the inward and outward sweeps of a generalised
force written as affine maps of the previous link's values (:func:`_solve_inward`,
:func:`_solve_outward`), the solve with the anchored end's or heavy load's 2x2 correction
(:func:`_op_solve`) and, for Radau IIA's Newton iteration, the same solve with the anchor's
linearised Baumgarte stabilisation (:func:`_op_solve_stabilised`), also for a real and a complex
system at once (:func:`_op_solve_stabilised_pair`).

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` and the sibling
``op_layout``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.jit import HOT_KERNEL
from cable_sim.core.kernel.sweeps import add_columns, solve_2x2
from cable_sim.integrate.implicit.op_layout import (
    _MODE_CONSTRAINED,
    _MODE_HEAVY,
    _MODE_NONE,
    _S_AZZ,
    _S_BETA0,
    _S_J00,
    _S_J01,
    _S_J10,
    _S_J11,
    _S_MC,
    _S_MODE,
    _W_AXX,
    _W_AXZ,
    _W_AZX,
    _W_AZZ,
    _W_BCN,
    _W_COS,
    _W_D,
    _W_GX,
    _W_GZ,
    _W_K,
    _W_KX,
    _W_KZ,
    _W_SIN,
)


@nb.njit(cache=True, inline="always")
def _factor_rows(W: np.ndarray) -> tuple:
    """The rows of the solve's per-link factors (:func:`~.op_factor._solve_factors`): ``g_x,
    g_z, k, k l t_x, k l t_z`` and the affine map's entries ``1 - g_x l t_x, g_x l t_z,
    g_z l t_x, 1 - g_z l t_z`` (views)."""
    return (W[_W_GX], W[_W_GZ], W[_W_K], W[_W_KX], W[_W_KZ], W[_W_AXX], W[_W_AXZ], W[_W_AZX],
            W[_W_AZZ])


@nb.njit(cache=True, inline="always")
def _inward_link(i: int, l: np.ndarray, cth: np.ndarray, sth: np.ndarray, rows: tuple,
                 rhs: np.ndarray, rr: np.ndarray, bn: float, bx: float, bz: float) -> tuple:
    """Link i of :func:`_solve_inward`: ``-b_i`` into ``rr[i]`` and the next state
    ``(b_n, b_x, b_z)`` from the old one (``rows``: :func:`_factor_rows`)."""
    gxa, gza, ka, kxa, kza, axx, axz, azx, azz = rows
    ltx = l[i] * cth[i]
    ltz = l[i] * sth[i]
    s = bn - rhs[i + 1]
    rr[i] = -(s + (ltx * bx + ltz * bz))
    return ((kxa[i] * bx + kza[i] * bz) + ka[i] * s, (axx[i] * bx - axz[i] * bz) - gxa[i] * s,
            (azz[i] * bz - azx[i] * bx) - gza[i] * s)


@nb.njit(cache=True, inline="always")
def _solve_inward(l: np.ndarray, G: np.ndarray, W: np.ndarray, rhs: np.ndarray,
                  rr: np.ndarray) -> float:
    """:func:`_op_rhs_inward` of a generalised force (``-b_i`` into ``rr``; returns the
    vertical force on the platform) with the recursion written as an affine map of the state
    ``(b_n, b_x, b_z)``: with ``s = b_n - r``, ``b = s + lt . (b_x, b_z)``, ``b_n' = k b``,
    ``(b_x, b_z)' = (b_x, b_z) - g b`` (``k = beta/D``, ``g = u/D``) expanded into products of
    the old state with the factorisation's factors (:func:`~.op_factor._solve_factors`:
    ``k l t``, ``1 - g_x l t_x``, ...), so that on the chain each new entry costs three
    products and two sums in a tree instead of the chain through b (:func:`_inward_link`).
    Equal to round-off. ``G``: the real geometry rows (``G is W`` for a real ``hg``)."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
    rows = _factor_rows(W)
    bn = bx = bz = 0.0 * rhs[0]
    for i in range(l.shape[0] - 1, -1, -1):
        bn, bx, bz = _inward_link(i, l, cth, sth, rows, rhs, rr, bn, bx, bz)
    return bz


@nb.njit(cache=True, inline="always")
def _solve_inward_pair(l: np.ndarray, G: np.ndarray, W: np.ndarray, rhs: np.ndarray,
                       rr: np.ndarray, Wc: np.ndarray, rhsc: np.ndarray,
                       rrc: np.ndarray) -> tuple:
    """:func:`_solve_inward` of two systems on the same geometry ``G`` (a real factorisation W
    and a complex one Wc) in one loop: two independent chains the core overlaps."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
    rows = _factor_rows(W)
    rowsc = _factor_rows(Wc)
    bn = bx = bz = 0.0 * rhs[0]
    cn = cx = cz = 0.0 * rhsc[0]
    for i in range(l.shape[0] - 1, -1, -1):
        bn, bx, bz = _inward_link(i, l, cth, sth, rows, rhs, rr, bn, bx, bz)
        cn, cx, cz = _inward_link(i, l, cth, sth, rowsc, rhsc, rrc, cn, cx, cz)
    return bz, cz


@nb.njit(cache=True, inline="always")
def _outward_link(i: int, l: np.ndarray, cth: np.ndarray, sth: np.ndarray, idd: np.ndarray,
                  rows: tuple, rr: np.ndarray, x: np.ndarray, ap: float, apx: float,
                  apz: float) -> tuple:
    """Link i of :func:`_solve_outward`: ``alpha_i`` into ``x[i + 1]`` and the next state
    ``(alpha, a_x, a_z)`` from the old one (``rows``: :func:`_factor_rows`)."""
    gxa, gza, ka, kxa, kza, axx, axz, azx, azz = rows
    ltx = l[i] * cth[i]
    ltz = l[i] * sth[i]
    rd = rr[i] * idd[i]
    alpha = (rd + ka[i] * ap) - (gxa[i] * apx + gza[i] * apz)
    x[i + 1] = alpha
    return (alpha, (ltx * rd + kxa[i] * ap) + (axx[i] * apx - azx[i] * apz),
            (ltz * rd + kza[i] * ap) + (azz[i] * apz - axz[i] * apx))


@nb.njit(cache=True, inline="always")
def _solve_outward(l: np.ndarray, G: np.ndarray, W: np.ndarray, rr: np.ndarray, zdd: float,
                   x: np.ndarray) -> tuple[float, float]:
    """The outward sweep of :func:`_op_solve` (``x = [zdd, alpha_1..n]``; returns the end's
    acceleration), as :func:`cable_sim.core.kernel.sweeps.outward_sweep` with the armature
    (no velocity terms) but written as an affine map of the state ``(alpha, a_x, a_z)``:
    ``alpha' = R/D + k alpha - g . a``, ``a' = a + l t alpha'`` expanded so that the new pin
    acceleration is formed from the old state directly with the factorisation's factors
    (:func:`~.op_factor._solve_factors`; the map of ``a`` is the transpose of the inward
    sweep's), not through ``alpha'`` (:func:`_outward_link`). Equal to round-off."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
    idd = W[_W_D]
    rows = _factor_rows(W)
    x[0] = zdd
    ap = apx = 0.0 * zdd
    apz = zdd
    for i in range(l.shape[0]):
        ap, apx, apz = _outward_link(i, l, cth, sth, idd, rows, rr, x, ap, apx, apz)
    return apx, apz


@nb.njit(cache=True, inline="always")
def _solve_outward_pair(l: np.ndarray, G: np.ndarray, W: np.ndarray, rr: np.ndarray,
                        zdd: float, x: np.ndarray, Wc: np.ndarray, rrc: np.ndarray,
                        zddc: complex, xc: np.ndarray) -> tuple:
    """:func:`_solve_outward` of the two systems of :func:`_solve_inward_pair` in one loop."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
    idd = W[_W_D]
    iddc = Wc[_W_D]
    rows = _factor_rows(W)
    rowsc = _factor_rows(Wc)
    x[0] = zdd
    xc[0] = zddc
    ap = apx = 0.0 * zdd
    apz = zdd
    cp = cpx = 0.0 * zddc
    cpz = zddc
    for i in range(l.shape[0]):
        ap, apx, apz = _outward_link(i, l, cth, sth, idd, rows, rr, x, ap, apx, apz)
        cp, cpx, cpz = _outward_link(i, l, cth, sth, iddc, rowsc, rrc, xc, cp, cpx, cpz)
    return apx, apz, cpx, cpz


@nb.njit(cache=True, inline="always")
def _platform_zdd(par: np.ndarray, S: np.ndarray, rhs: np.ndarray, bz: float) -> float:
    """The platform's entry of a solve after its inward sweep (0 when heave-locked)."""
    return 0.0 * bz if par[7] != 0.0 else (rhs[0] - bz) / (par[4] + S[_S_BETA0] + S[_S_AZZ])


@nb.njit(cache=True, inline="always")
def _end_correction(S: np.ndarray, X: np.ndarray, x: np.ndarray, apx: float, apz: float) -> None:
    """Add the anchored end's or heavy load's 2x2 correction to a solve ``x`` whose free
    outward sweep ended at the end acceleration ``(apx, apz)``."""
    mode = S[_S_MODE]
    if mode == _MODE_NONE:
        return
    eps = 1.0 / S[_S_MC] if mode == _MODE_HEAVY else 0.0
    a11 = S[_S_J00] + eps
    a22 = S[_S_J11] + eps
    f0, f1 = solve_2x2(a11, S[_S_J01], S[_S_J10], a22, -apx, -apz)
    add_columns(x, X[0], f0, X[1], f1)


@nb.njit(**HOT_KERNEL)
def _op_solve(arr: np.ndarray, par: np.ndarray, G: np.ndarray, W: np.ndarray, S: np.ndarray,
              X: np.ndarray, rhs: np.ndarray, x: np.ndarray) -> None:
    """Solve ``M~ x = rhs`` (anchored: with ``J x = 0``) using a factorisation from
    :func:`_op_factor` (``G``: its real geometry rows, W itself for a real ``hg``). ``rhs``
    is a generalised force: ``rhs[0]`` a vertical force on the platform, ``rhs[i]`` a couple
    on link i. The two sweeps are :func:`_solve_inward` and
    :func:`_solve_outward` (the unit end forces of the factorisation take
    :func:`_op_rhs_inward` and the shared outward sweep)."""
    l = arr[0]
    bcn = W[_W_BCN]
    bz = _solve_inward(l, G, W, rhs, bcn)
    apx, apz = _solve_outward(l, G, W, bcn, _platform_zdd(par, S, rhs, bz), x)
    _end_correction(S, X, x, apx, apz)


@nb.njit(**HOT_KERNEL)
def _op_solve_pair(arr: np.ndarray, par: np.ndarray, G: np.ndarray, W: np.ndarray,
                   S: np.ndarray, X: np.ndarray, rhs: np.ndarray, x: np.ndarray, Wc: np.ndarray,
                   Sc: np.ndarray, Xc: np.ndarray, rhsc: np.ndarray, xc: np.ndarray) -> None:
    """:func:`_op_solve` with a real factorisation (``W, S, X``; ``G is W``) and a complex one
    at the same geometry (``Wc, Sc, Xc``) at once, their sweeps side by side
    (:func:`_solve_inward_pair`, :func:`_solve_outward_pair`). Equal to the two solves to
    round-off."""
    l = arr[0]
    bcn = W[_W_BCN]
    bcnc = Wc[_W_BCN]
    bz, bzc = _solve_inward_pair(l, G, W, rhs, bcn, Wc, rhsc, bcnc)
    apx, apz, cpx, cpz = _solve_outward_pair(l, G, W, bcn, _platform_zdd(par, S, rhs, bz), x,
                                             Wc, bcnc, _platform_zdd(par, Sc, rhsc, bzc), xc)
    _end_correction(S, X, x, apx, apz)
    _end_correction(Sc, Xc, xc, cpx, cpz)


@nb.njit(cache=True, inline="always")
def _end_motion(arr: np.ndarray, par: np.ndarray, G: np.ndarray, a: float, u: np.ndarray, b: float,
                w: np.ndarray) -> tuple:
    """``J (a u + b w)``: the anchored end's (x, z) motion from the generalised increment
    ``a u + b w``, with ``J = d p_n / d q`` (``l_i cos th_i``, ``l_i sin th_i``; 1 for the
    platform in z unless its heave is locked) at the factorisation's geometry ``G``. One pass
    over the links; real or complex ``u``, ``w``."""
    l = arr[0]
    cth = G[_W_COS]
    sth = G[_W_SIN]
    v0 = a * u[0] + b * w[0]
    jx = 0.0 * v0
    jz = v0 if par[7] == 0.0 else 0.0 * v0
    for i in range(l.shape[0]):
        v = a * u[i + 1] + b * w[i + 1]
        jx += l[i] * cth[i] * v
        jz += l[i] * sth[i] * v
    return jx, jz


@nb.njit(cache=True, inline="always")
def _op_solve_stabilised(arr: np.ndarray, par: np.ndarray, hg: complex, G: np.ndarray,
                         W: np.ndarray, S: np.ndarray, X: np.ndarray, rhs: np.ndarray,
                         x: np.ndarray, rv: np.ndarray, rk: np.ndarray) -> None:
    """:func:`_op_solve` for the shifted system ``(I - hg T) s = (rq, rv)`` (``x = rv - sv``,
    ``rk = rq + hg rv``), where at an anchored end ``J x`` is not 0 but what the linearised
    Baumgarte stabilisation of the forward dynamics (``J a = ... - 2 alpha J v - beta^2 Phi``)
    asks: ``J x = hg (2 alpha J rv + beta^2 J rk) / (1 + 2 alpha hg + beta^2 hg^2)``. Without
    it the iteration matrix has no term for the constraint-violating directions, where the
    forward dynamics' Jacobian has ``2 alpha`` and ``beta^2``; a simplified Newton iteration
    over a step with ``hg beta`` near 1 or more then diverges there (the stage states of an
    implicit Runge-Kutta step are off the constraint). Other end conditions: :func:`_op_solve`."""
    _op_solve(arr, par, G, W, S, X, rhs, x)
    _stabilise(arr, par, hg, G, S, X, x, rv, rk)


@nb.njit(cache=True, inline="always")
def _stabilise(arr: np.ndarray, par: np.ndarray, hg: complex, G: np.ndarray, S: np.ndarray,
               X: np.ndarray, x: np.ndarray, rv: np.ndarray, rk: np.ndarray) -> None:
    """The anchor's linearised Baumgarte term of :func:`_op_solve_stabilised`, added to a
    solve ``x`` of :func:`_op_solve` (nothing at other end conditions)."""
    if S[_S_MODE] != _MODE_CONSTRAINED:
        return
    alpha = par[13]
    beta2 = par[14] * par[14]
    jx, jz = _end_motion(arr, par, G, 2.0 * alpha, rv, beta2, rk)
    scale = hg / (1.0 + hg * (2.0 * alpha + beta2 * hg))
    f0, f1 = solve_2x2(S[_S_J00], S[_S_J01], S[_S_J10], S[_S_J11], scale * jx, scale * jz)
    add_columns(x, X[0], f0, X[1], f1)


@nb.njit(cache=True, inline="always")
def _op_solve_stabilised_pair(arr: np.ndarray, par: np.ndarray, hg: float, hgc: complex,
                              G: np.ndarray, W: np.ndarray, S: np.ndarray, X: np.ndarray,
                              rhs: np.ndarray, x: np.ndarray, rv: np.ndarray, rk: np.ndarray,
                              Wc: np.ndarray, Sc: np.ndarray, Xc: np.ndarray,
                              rhsc: np.ndarray, xc: np.ndarray, rvc: np.ndarray,
                              rkc: np.ndarray) -> None:
    """:func:`_op_solve_stabilised` of a real system (``hg``, ``W, S, X``, ``G is W``) and a
    complex one (``hgc``, ``Wc, Sc, Xc``) on the same geometry, solved side by side
    (:func:`_op_solve_pair`)."""
    _op_solve_pair(arr, par, G, W, S, X, rhs, x, Wc, Sc, Xc, rhsc, xc)
    _stabilise(arr, par, hg, G, S, X, x, rv, rk)
    _stabilise(arr, par, hgc, G, Sc, Xc, xc, rvc, rkc)
