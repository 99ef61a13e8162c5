"""Adaptive stepping of the Rosenbrock W-methods: the compiled adaptive run
(:func:`_ros_adaptive_run`) on the shared step control of :mod:`cable_sim.integrate.step_control`
with this pair's controller exponent :data:`_K_EXP` (embedded order 2).

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel.checks`,
:mod:`cable_sim.integrate.step_control` and the sibling module ``ros_step``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, check_packed
from cable_sim.integrate.implicit.ros_step import _ros_step, _workspace
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

#: 1 / (embedded order + 1): the exponent of the step-size controller (embedded order 2).
_K_EXP = 1.0 / 3.0


@nb.njit(cache=True)
def _ros_adaptive_run(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool, t0: float, t1: float,
                      tin0: float, tdt: float, uin: np.ndarray, ein: np.ndarray, y: np.ndarray,
                      chk: np.ndarray, info: np.ndarray, ctl: np.ndarray, at: np.ndarray,
                      ct: np.ndarray, ctimes: np.ndarray, mt: np.ndarray, et: np.ndarray,
                      gamma: float) -> int:
    """Adaptive steps from t0 to exactly t1, in place on y.

    Inputs: samples ``uin, ein`` on the grid ``tin0 + k tdt`` (cubic interpolation).
    ``ctl``: the controller state of :mod:`cable_sim.integrate.step_control`.
    ``chk[7]``, ``chk[10]`` are set per step from the rates (both proportional to the step).
    ``info = [force evaluations, accepted steps, value, t reached, rejected steps]``.
    """
    ns = at.shape[0]
    fs, sq, sv, wk, yn, err = _workspace(arr.shape[1], ns)
    us = np.empty(ns)
    es = np.empty(ns)
    no_trig = np.empty(0)  # the error norm forms the links' cos/sin itself
    ewk = np.empty((ERR_ROWS, arr.shape[1]))
    atol, rtol, hmax = ctl[0], ctl[1], ctl[5]
    h = min(ctl[7], hmax)
    t = t0
    while t < t1:
        hs, last = clip_step(t, t1, h)
        for i in range(ns):
            ts = t + ctimes[i] * hs
            us[i] = interp_input(ts, tin0, tdt, uin)
            es[i] = interp_input(ts, tin0, tdt, ein)
        ok = _ros_step(arr, par, geometric, predict, hs, us, es, y, yn, err, fs, sq, sv, wk, at,
                       ct, mt, et, gamma)
        info[0] += ns
        en = err_norm_ws(arr, y, yn, err, atol, rtol, no_trig, no_trig, False, ewk) if ok else np.inf
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
        info[1] += 1
        t = t1 if last else t + hs
        h = accepted_step(ctl, en, hs, h, last, _K_EXP)
    ctl[7] = h
    info[3] = t
    return STATUS_OK


__all__ = ["_K_EXP", "_ros_adaptive_run"]
