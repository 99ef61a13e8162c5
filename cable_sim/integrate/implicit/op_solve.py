"""Solve with a factorised O(n) operator ``M + hg D + hg^2 K`` (see
:mod:`cable_sim.integrate.implicit.operator`): the inward and outward sweeps of a generalised
force written as affine maps of the previous link's values (:func:`_solve_inward`,
:func:`_solve_outward`), the solve with the anchored end's or heavy load's 2x2 correction
(:func:`_op_solve`) and, for Radau IIA's Newton iteration, the same solve with the anchor's
linearised Baumgarte stabilisation (:func:`_op_solve_stabilised`).

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` and the sibling
``op_layout``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

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
def _solve_inward(l: np.ndarray, G: np.ndarray, W: np.ndarray, rhs: np.ndarray,
                  rr: np.ndarray) -> float:
    """:func:`_op_rhs_inward` of a generalised force (``-b_i`` into ``rr``; returns the
    vertical force on the platform) with the recursion written as an affine map of the state
    ``(b_n, b_x, b_z)``: with ``s = b_n - r``, ``b = s + lt . (b_x, b_z)``, ``b_n' = k b``,
    ``(b_x, b_z)' = (b_x, b_z) - g b`` (``k = beta/D``, ``g = u/D``) expanded into products of
    the old state with the factorisation's factors (:func:`~.op_factor._solve_factors`:
    ``k l t``, ``1 - g_x l t_x``, ...), so that on the chain each new entry costs three
    products and two sums in a tree instead of the chain through b. Equal to round-off.
    ``G``: the real geometry rows (``G is W`` for a real ``hg``)."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
    gxa, gza, ka, kxa, kza, axx, axz, azx, azz = _factor_rows(W)
    bn = 0.0
    bx = 0.0
    bz = 0.0
    for i in range(l.shape[0] - 1, -1, -1):
        ltx = l[i] * cth[i]
        ltz = l[i] * sth[i]
        s = bn - rhs[i + 1]
        rr[i] = -(s + (ltx * bx + ltz * bz))
        bn_new = (kxa[i] * bx + kza[i] * bz) + ka[i] * s
        bx_new = (axx[i] * bx - axz[i] * bz) - gxa[i] * s
        bz = (azz[i] * bz - azx[i] * bx) - gza[i] * s
        bx = bx_new
        bn = bn_new
    return bz


@nb.njit(cache=True, inline="always")
def _solve_outward(l: np.ndarray, G: np.ndarray, W: np.ndarray, rr: np.ndarray, zdd: float,
                   x: np.ndarray) -> tuple[float, float]:
    """The outward sweep of :func:`_op_solve` (``x = [zdd, alpha_1..n]``; returns the end's
    acceleration), as :func:`cable_sim.core.kernel.sweeps.outward_sweep` with the armature
    (no velocity terms) but written as an affine map of the state ``(alpha, a_x, a_z)``:
    ``alpha' = R/D + k alpha - g . a``, ``a' = a + l t alpha'`` expanded so that the new pin
    acceleration is formed from the old state directly with the factorisation's factors
    (:func:`~.op_factor._solve_factors`; the map of ``a`` is the transpose of the inward
    sweep's), not through ``alpha'``. Equal to round-off."""
    cth = G[_W_COS]
    sth = G[_W_SIN]
    idd = W[_W_D]
    gxa, gza, ka, kxa, kza, axx, axz, azx, azz = _factor_rows(W)
    x[0] = zdd
    ap = 0.0
    apx = 0.0
    apz = zdd
    for i in range(l.shape[0]):
        ltx = l[i] * cth[i]
        ltz = l[i] * sth[i]
        rd = rr[i] * idd[i]
        alpha = (rd + ka[i] * ap) - (gxa[i] * apx + gza[i] * apz)
        x[i + 1] = alpha
        ax_new = (ltx * rd + kxa[i] * ap) + (axx[i] * apx - azx[i] * apz)
        apz = (ltz * rd + kza[i] * ap) + (azz[i] * apz - axz[i] * apx)
        apx = ax_new
        ap = alpha
    return apx, apz


@nb.njit(cache=True, error_model="numpy", fastmath={"contract"})
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
    zdd = 0.0 if par[7] != 0.0 else (rhs[0] - bz) / (par[4] + S[_S_BETA0] + S[_S_AZZ])
    apx, apz = _solve_outward(l, G, W, bcn, zdd, x)
    mode = S[_S_MODE]
    if mode == _MODE_NONE:
        return
    eps = 1.0 / S[_S_MC] if mode == _MODE_HEAVY else 0.0
    a11 = S[_S_J00] + eps
    a22 = S[_S_J11] + eps
    f0, f1 = solve_2x2(a11, S[_S_J01], S[_S_J10], a22, -apx, -apz)
    add_columns(x, X[0], f0, X[1], f1)


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
    if S[_S_MODE] != _MODE_CONSTRAINED:
        return
    alpha = par[13]
    beta2 = par[14] * par[14]
    jx, jz = _end_motion(arr, par, G, 2.0 * alpha, rv, beta2, rk)
    scale = hg / (1.0 + hg * (2.0 * alpha + beta2 * hg))
    f0, f1 = solve_2x2(S[_S_J00], S[_S_J01], S[_S_J10], S[_S_J11], scale * jx, scale * jz)
    add_columns(x, X[0], f0, X[1], f1)
