"""Adaptive stepping of Radau IIA: the embedded error estimate (:func:`_radau_error`) and the
compiled adaptive run (:func:`_radau_adaptive_run`) on the shared step control of
:mod:`cable_sim.integrate.step_control`.

The estimate is Hairer & Wanner's (*Solving ODEs II*, IV.8, (8.19)-(8.20); RADAU5's
``ESTRAD``): with the converged stage increments ``Z_i`` and the slope ``f_0`` at the step's
start,

    err = (I - hg_1 T)^-1 (hg_1 f_0 + gamma_0 sum_i d_i Z_i),   hg_1 = h gamma_0,

``gamma_0 = 1 / lambda_1`` (the real eigenvalue of ``A^-1``) and ``d = (-(13 + 7 sqrt 6)/3,
(-13 + 7 sqrt 6)/3, -1/3)`` (:data:`DD`): the difference between the Radau IIA solution and an
embedded one of order 3, filtered by the real factorisation the Newton iteration already has
(one more O(n) solve), so that its stiff components stay bounded. When it exceeds the
tolerance it is formed once more with ``f`` at ``y + err`` instead of ``f_0`` (one more force
evaluation; RADAU5 does this on the first step and after a rejection, here on every step that
would otherwise be rejected: the refined estimate is the better one for stiff components).
The controller's exponent is therefore 1/4 (:data:`_K_EXP`).

A step whose Newton iteration does not converge is rejected like one whose error is too large
(the controller's smallest factor). The first guess of the stage increments extrapolates the
last accepted step's collocation polynomial (kept aside, so that a retry after a rejection
starts from it too); at the start of a call it is the explicit Euler increments.

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` (checks, forward),
:mod:`cable_sim.integrate.step_control` and the sibling module ``radau_step``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, STATUS_SINGULAR, check_packed
from cable_sim.core.kernel.forward import fd_packed_ws
from cable_sim.integrate.implicit.radau_step import (
    _STEP_OK,
    _STEP_SINGULAR,
    _radau_step,
    _solve_shifted,
    radau_workspace,
)
from cable_sim.integrate.step_control import (
    ERR_ROWS,
    STATUS_STEP_UNDERFLOW,
    accepted_step,
    clip_step,
    err_norm_ws,
    interp_input,
    rejection,
    scale_allowances,
)

_S6 = np.sqrt(6.0)
#: The estimate's weights ``d_i`` of the stage increments (RADAU5's DD1, DD2, DD3).
DD = np.array([-(13.0 + 7.0 * _S6) / 3.0, (-13.0 + 7.0 * _S6) / 3.0, -1.0 / 3.0])
#: 1 / (embedded order + 1): the exponent of the step-size controller (embedded order 3).
_K_EXP = 0.25


@nb.njit(cache=True)
def _radau_error(arr: np.ndarray, par: np.ndarray, h: float, lam1: float, dd: np.ndarray,
                 fq: np.ndarray, fv: np.ndarray, ws: tuple, err: np.ndarray) -> None:
    """The error estimate of the step of h just converged in ``ws`` (see the module docstring)
    with the slope ``f = (fq, fv)`` into ``err`` (``2(n+1)``: positions, then velocities)."""
    fs, _wc, _sc, _xc, Zq, Zv, _fq, _fv, wk, _cw, _jm, _yq, _fw2 = ws
    W, S, X = fs[4], fs[5], fs[6]
    rhs = wk[2]
    x = wk[3]
    rq = wk[4]
    rv = wk[5]
    rk = wk[6]
    n1 = fq.shape[0]
    hg = h / lam1
    g0 = 1.0 / lam1
    for j in range(n1):
        rq[j] = hg * fq[j] + g0 * (dd[0] * Zq[0, j] + dd[1] * Zq[1, j] + dd[2] * Zq[2, j])
        rv[j] = hg * fv[j] + g0 * (dd[0] * Zv[0, j] + dd[1] * Zv[1, j] + dd[2] * Zv[2, j])
    _solve_shifted(arr, par, hg, W, W, S, X, rq, rv, rk, rhs, x)
    for j in range(n1):
        err[j] = rq[j]
        err[n1 + j] = rv[j]


@nb.njit(cache=True)
def _radau_adaptive_run(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool,
                        t0: float, t1: float, tin0: float, tdt: float, uin: np.ndarray,
                        ein: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray,
                        ctl: np.ndarray, lam1: float, lam2: complex, ti1: np.ndarray,
                        ti2: np.ndarray, v1: np.ndarray, v2: np.ndarray, offsets: np.ndarray,
                        dd: np.ndarray, tol: float, maxit: int, newton: np.ndarray) -> int:
    """Adaptive Radau IIA steps from t0 to exactly t1, in place on y.

    Inputs, ``chk``, ``ctl`` and ``info`` as in
    :func:`cable_sim.integrate.implicit.ros_adaptive._ros_adaptive_run`; the eigenbasis,
    ``offsets``, ``tol`` and ``maxit`` as in
    :func:`cable_sim.integrate.implicit.radau_step._radau_step`; ``dd``: :data:`DD`.
    ``newton = [contraction estimate (carried), Newton iterations, attempts whose iteration
    did not converge]`` (the counts are added to).
    """
    n = arr.shape[1]
    n1 = n + 1
    ws = radau_workspace(n)
    fw = ws[0][0]
    Zq = ws[4]
    Zv = ws[5]
    wk = ws[8]
    acc = wk[0]
    lam = wk[8, :2]
    acc0 = wk[9]
    zq_acc = np.empty((3, n1))  # the last accepted step's stage increments
    zv_acc = np.empty((3, n1))
    yn = np.empty(2 * n1)
    ye = np.empty(2 * n1)
    err = np.empty(2 * n1)
    us = np.empty(4)
    es = np.empty(4)
    cnt = np.zeros(5)  # _radau_step's counters: [0] force evaluations, [3] Newton iterations
    eta = newton[:1]
    no_trig = np.empty(0)  # the error norm forms the links' cos/sin itself
    ewk = np.empty((ERR_ROWS, n))
    atol, rtol, hmax = ctl[0], ctl[1], ctl[5]
    h = min(ctl[7], hmax)
    hprev = 0.0  # the last accepted step; 0: none in this call
    t = t0
    while t < t1:
        hs, last = clip_step(t, t1, h)
        for i in range(4):
            ts = t + offsets[i] * hs
            us[i] = interp_input(ts, tin0, tdt, uin)
            es[i] = interp_input(ts, tin0, tdt, ein)
        ratio = hprev / hs if hprev > 0.0 else 0.0
        if ratio > 0.0:
            Zq[:, :] = zq_acc
            Zv[:, :] = zv_acc
        cnt[:] = 0.0
        res = _radau_step(arr, par, geometric, predict, hs, us, es, y, yn, ws, lam1, lam2, ti1,
                          ti2, v1, v2, offsets, tol, maxit, cnt, ratio, eta)
        info[0] += cnt[0]
        newton[1] += cnt[3]
        if res == _STEP_SINGULAR:
            info[3] = t
            return STATUS_SINGULAR
        en = np.inf
        if res == _STEP_OK:
            _radau_error(arr, par, hs, lam1, dd, y[n1:], acc0, ws, err)
            en = err_norm_ws(arr, y, yn, err, atol, rtol, no_trig, no_trig, False, ewk)
            if en > 1.0 and np.isfinite(en):  # refine with the slope at y + err
                for j in range(2 * n1):
                    ye[j] = y[j] + err[j]
                if fd_packed_ws(arr, par, us[0], es[0], ye[:n1], ye[n1:], acc, lam, fw):
                    info[0] += 1
                    _radau_error(arr, par, hs, lam1, dd, ye[n1:], acc, ws, err)
                    en = err_norm_ws(arr, y, yn, err, atol, rtol, no_trig, no_trig, False, ewk)
        else:
            newton[2] += 1
        if not np.isfinite(en) or en > 1.0:
            h, underflow = rejection(ctl, en, hs, _K_EXP, t, info)
            if underflow:
                return STATUS_STEP_UNDERFLOW
            continue
        scale_allowances(chk, ctl, hs)
        status = check_packed(arr, par, yn, chk, info)
        if status != STATUS_OK:
            info[3] = t + hs
            return status
        y[:] = yn
        zq_acc[:, :] = Zq
        zv_acc[:, :] = Zv
        hprev = hs
        info[1] += 1
        t = t1 if last else t + hs
        h = accepted_step(ctl, en, hs, h, last, _K_EXP)
    ctl[7] = h
    info[3] = t
    return STATUS_OK


__all__ = ["DD", "_K_EXP", "_radau_adaptive_run", "_radau_error"]
