"""Compiled explicit steppers: many checked RK4 or symplectic Euler steps in one numba call.

Each step evaluates the O(n) forward dynamics (:func:`cable_sim.core.kernel.forward.fd_packed_ws`,
its workspace allocated once per run) and ends with the compiled check
(:func:`cable_sim.core.kernel.checks.check_packed_ws`; the links' cos/sin at the new state,
formed once for it, serve the next step's first force evaluation too); the Python-level schemes are
:mod:`cable_sim.integrate.explicit`.

Integrate layer: imports numba, numpy and the compiled kernel (:mod:`cable_sim.core.kernel`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, STATUS_SINGULAR, check_packed_ws
from cable_sim.core.kernel.forward import fd_packed_ws, fd_trig, fd_workspace
from cable_sim.core.kernel.links import link_trig


@nb.njit(cache=True, inline="always")
def _slope(arr: np.ndarray, par: np.ndarray, u: float, eta: float, ys: np.ndarray,
           lam: np.ndarray, out: np.ndarray, ws: np.ndarray, trig_ready: bool = False) -> bool:
    """``out = [qd, qdd]`` at the state ``ys`` (qdd written in place by the forward dynamics;
    ``ws``: its workspace, holding the links' cos/sin at ``ys`` already when ``trig_ready``);
    False if the anchor matrix is singular."""
    n1 = out.shape[0] // 2
    if not fd_packed_ws(arr, par, u, eta, ys[:n1], ys[n1:], out[n1:], lam, ws, trig_ready):
        return False
    out[:n1] = ys[n1:]
    return True


@nb.njit(cache=True, inline="always")
def _axpy(y: np.ndarray, a: float, k: np.ndarray, out: np.ndarray) -> None:
    """``out = y + a k``."""
    for j in range(y.shape[0]):
        out[j] = y[j] + a * k[j]


@nb.njit(cache=True, error_model="numpy")
def rk4_run(arr: np.ndarray, par: np.ndarray, h: float, u: np.ndarray, eta: np.ndarray,
            y: np.ndarray, chk: np.ndarray, info: np.ndarray) -> int:
    """``u.shape[0]`` classical RK4 steps of size h, each followed by :func:`check_packed_ws`.

    ``u[k] = (u(t_k), u(t_k + h/2), u(t_k + h))`` and likewise ``eta``. On success ``y`` holds
    the final state; on failure the last good state, ``info[1]`` the index of the failed step
    and the status code is returned. The arithmetic is that of
    :meth:`cable_sim.integrate.explicit.RK4._step`.

    The links' cos/sin at the new state are formed once, for the check's energy
    (:func:`check_packed_ws`) and the next step's first slope.
    """
    n2 = y.shape[0]
    kk = np.empty((4, n2))  # the slopes k1..k4
    k1 = kk[0]
    k2 = kk[1]
    k3 = kk[2]
    k4 = kk[3]
    ys = np.empty(n2)
    yn = np.empty(n2)
    lam = np.empty(2)
    ws = fd_workspace(arr.shape[1])
    cth, sth = fd_trig(ws, arr.shape[1])
    link_trig(y, cth, sth)
    hh = h / 2
    h6 = h / 6
    for k in range(u.shape[0]):
        info[1] = k
        if not _slope(arr, par, u[k, 0], eta[k, 0], y, lam, k1, ws, True):
            return STATUS_SINGULAR
        _axpy(y, hh, k1, ys)
        if not _slope(arr, par, u[k, 1], eta[k, 1], ys, lam, k2, ws):
            return STATUS_SINGULAR
        _axpy(y, hh, k2, ys)
        if not _slope(arr, par, u[k, 1], eta[k, 1], ys, lam, k3, ws):
            return STATUS_SINGULAR
        _axpy(y, h, k3, ys)
        if not _slope(arr, par, u[k, 2], eta[k, 2], ys, lam, k4, ws):
            return STATUS_SINGULAR
        for j in range(n2):
            yn[j] = y[j] + h6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j])
        link_trig(yn, cth, sth)
        status = check_packed_ws(arr, par, yn, chk, info, cth, sth)
        if status != STATUS_OK:
            return status
        y[:] = yn
    return STATUS_OK


@nb.njit(cache=True, error_model="numpy")
def symplectic_euler_run(arr: np.ndarray, par: np.ndarray, h: float, u: np.ndarray,
                         eta: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray) -> int:
    """``u.shape[0]`` symplectic Euler steps (``u[k] = u(t_k)``), each checked; as
    :func:`rk4_run`. Arithmetic of :meth:`cable_sim.integrate.explicit.SemiImplicitEuler._step`."""
    n2 = y.shape[0]
    n1 = n2 // 2
    qdd = np.empty(n1)
    lam = np.empty(2)
    yn = np.empty(n2)
    ws = fd_workspace(arr.shape[1])
    cth, sth = fd_trig(ws, arr.shape[1])
    link_trig(y, cth, sth)
    for k in range(u.shape[0]):
        info[1] = k
        if not fd_packed_ws(arr, par, u[k], eta[k], y[:n1], y[n1:], qdd, lam, ws, True):
            return STATUS_SINGULAR
        for j in range(n1):
            yn[n1 + j] = y[n1 + j] + h * qdd[j]
            yn[j] = y[j] + h * yn[n1 + j]
        link_trig(yn, cth, sth)
        status = check_packed_ws(arr, par, yn, chk, info, cth, sth)
        if status != STATUS_OK:
            return status
        y[:] = yn
    return STATUS_OK
