"""The compiled loop of the linearly implicit schemes: many checked steps in one numba call.

Per step: forward dynamics, the tension stiffness (joint forces), one factorisation of the
operator and one (implicit Euler) or two (ROS2) stage solves, then the compiled check
(:func:`cable_sim.core.kernel.checks.check_packed`). The scratch of all of them is allocated
once per run (:func:`factor_workspace`), and the links' cos/sin of the forward dynamics at the
factorisation's state serve the joint forces and the operator too.

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` (forward, joint_forces,
checks) and the sibling :mod:`cable_sim.integrate.implicit.operator`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, STATUS_SINGULAR, check_packed
from cable_sim.core.kernel.forward import fd_packed_ws, fd_trig, fd_workspace
from cable_sim.core.kernel.joint_forces import jf_workspace, joint_forces_packed_ws
from cable_sim.integrate.implicit.operator import (
    _NS,
    _NW,
    _W_COS,
    _W_SIN,
    _dk_product,
    _kgeo_from_forces,
    _op_factor_trig,
    _op_solve,
)


@nb.njit(cache=True)
def factor_workspace(n: int) -> tuple:
    """Scratch of :func:`_factor_at` for n links, allocated once per compiled run: the forward
    dynamics' (``fw``), the joint forces' (``jw``) and their output ``F``, the tension
    stiffness ``kgeo`` and the operator's factorisation ``W, S, X``. No entry is read before
    it is written in the same step (a reused workspace carries nothing over)."""
    return (fd_workspace(n), jf_workspace(n), np.empty((n + 1, 2)), np.zeros(n),
            np.zeros((_NW, n)), np.zeros(_NS), np.zeros((2, n + 1)))


@nb.njit(cache=True, inline="always")
def _factor_at(arr: np.ndarray, par: np.ndarray, geometric: bool, hg: float, q: np.ndarray,
               v: np.ndarray, a1: np.ndarray, lam: np.ndarray, vf: np.ndarray, fw: np.ndarray,
               jw: np.ndarray, F: np.ndarray, kgeo: np.ndarray, W: np.ndarray, S: np.ndarray,
               X: np.ndarray, h: float) -> bool:
    """Factor the operator at (q, vf) (seabed contact over the step h, see
    :func:`cable_sim.integrate.implicit.op_factor._op_factor`); with ``geometric`` the tension
    stiffness from the joint forces at (q, v), the accelerations ``a1`` and anchor reaction
    ``lam`` first. ``fw`` is the workspace of the forward dynamics just evaluated at q: its
    links' cos/sin serve the joint forces, the tension stiffness and the operator."""
    n = arr.shape[1]
    cth, sth = fd_trig(fw, n)
    if geometric:
        joint_forces_packed_ws(arr, par, lam[0], lam[1], q, v, a1, cth, sth, jw, F)
        _kgeo_from_forces(arr, cth, sth, F, kgeo)
    for i in range(n):
        W[_W_COS, i] = cth[i]
        W[_W_SIN, i] = sth[i]
    return _op_factor_trig(arr, par, q, vf, hg, kgeo, W, W, S, X, h)


@nb.njit(cache=True, inline="always")
def _stage(arr: np.ndarray, par: np.ndarray, hg: float, W: np.ndarray, S: np.ndarray,
           X: np.ndarray, rd: np.ndarray, rk: np.ndarray, rhs: np.ndarray, x: np.ndarray,
           kv: np.ndarray) -> None:
    """One stage's velocity slope ``kv = rd - M~^-1 (hg D rd + hg K rk)``."""
    _dk_product(arr, par, hg, W, W, rd, rk, rhs)
    _op_solve(arr, par, W, W, S, X, rhs, x)
    for j in range(kv.shape[0]):
        kv[j] = rd[j] - x[j]


@nb.njit(cache=True)
def _implicit_run(arr: np.ndarray, par: np.ndarray, scheme: int, gamma: float, geometric: bool,
                  h: float, u: np.ndarray, eta: np.ndarray, y: np.ndarray, chk: np.ndarray,
                  info: np.ndarray) -> int:
    """``u.shape[0]`` steps of the linearly implicit Euler (scheme 0) or ROS2 (scheme 1).

    ``u[k] = (u(t_k), u(t_k + h))`` (one column suffices for scheme 0), likewise ``eta``.
    Each step is followed by the compiled check (:func:`cable_sim.core.kernel.checks.check_packed`).
    On failure ``y`` keeps the last good state, ``info[1]`` is the failed step's index and the
    status is returned. ``info[0]`` counts the force evaluations.
    """
    n = arr.shape[1]
    n1 = n + 1
    fw, jw, F, kgeo, W, S, X = factor_workspace(n)
    a1 = np.empty(n1)
    a2 = np.empty(n1)
    lam = np.empty(2)
    rd = np.empty(n1)
    rk = np.empty(n1)
    rhs = np.empty(n1)
    x = np.empty(n1)
    k1q = np.empty(n1)
    k1v = np.empty(n1)
    k2v = np.empty(n1)
    q2 = np.empty(n1)
    v2 = np.empty(n1)
    rqa = np.empty(n1)
    yn = np.empty(2 * n1)
    hg = gamma * h
    last = u.shape[1] - 1
    for k in range(u.shape[0]):
        info[1] = k
        q = y[:n1]
        v = y[n1:]
        if not fd_packed_ws(arr, par, u[k, 0], eta[k, 0], q, v, a1, lam, fw):
            return STATUS_SINGULAR
        info[0] += 1
        if not _factor_at(arr, par, geometric, hg, q, v, a1, lam, v, fw, jw, F, kgeo, W, S, X, h):
            return STATUS_SINGULAR
        for j in range(n1):
            rk[j] = v[j] + hg * a1[j]
        _stage(arr, par, hg, W, S, X, a1, rk, rhs, x, k1v)
        if scheme == 0:
            for j in range(n1):
                yn[n1 + j] = v[j] + h * k1v[j]
                yn[j] = q[j] + h * yn[n1 + j]
        else:
            for j in range(n1):
                k1q[j] = v[j] + hg * k1v[j]
                q2[j] = q[j] + h * k1q[j]
                v2[j] = v[j] + h * k1v[j]
            if not fd_packed_ws(arr, par, u[k, last], eta[k, last], q2, v2, a2, lam, fw):
                return STATUS_SINGULAR
            info[0] += 1
            for j in range(n1):
                rqa[j] = v2[j] - 2.0 * k1q[j]
                rd[j] = a2[j] - 2.0 * k1v[j]
                rk[j] = rqa[j] + hg * rd[j]
            _stage(arr, par, hg, W, S, X, rd, rk, rhs, x, k2v)
            for j in range(n1):
                k2q = rqa[j] + hg * k2v[j]
                yn[j] = q[j] + 1.5 * h * k1q[j] + 0.5 * h * k2q
                yn[n1 + j] = v[j] + 1.5 * h * k1v[j] + 0.5 * h * k2v[j]
        status = check_packed(arr, par, yn, chk, info)
        if status != STATUS_OK:
            return status
        y[:] = yn
    return STATUS_OK
