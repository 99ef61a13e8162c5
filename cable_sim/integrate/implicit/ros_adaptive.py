"""Adaptive stepping of the four-stage Rosenbrock W-methods: the next step towards an output time
(:func:`_clip`), the cubic interpolation of the sampled inputs (:func:`_interp`), the error
norm (:func:`err_norm`), the PI step-size controller (:func:`_rejected_step`,
:func:`_accepted_step`) and the compiled adaptive run (:func:`_ros_adaptive_run`).

Error norm: the embedded difference, mapped to the joints (linearised:
``dp_j = dz e_z + sum_{i<j} l_i (cos th_i, sin th_i) dth_i``, likewise the joint velocities),
in the max norm over joints with scale ``atol + rtol |p_j - p_0|`` (positions, m) and
``atol + rtol |v_j|`` (velocities, m/s): the tolerance is on what the user reads, the joint
positions.

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel.checks` and the sibling
module ``ros_step``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, check_packed
from cable_sim.integrate.implicit.ros_step import _ros_step, _workspace

#: Status of the adaptive kernel when the step size fell below its floor (not a check status).
STATUS_STEP_UNDERFLOW = 100


@nb.njit(cache=True)
def _clip(t: float, t1: float, h: float) -> tuple[float, bool]:
    """The next step from t towards t1 with the proposal h, and whether it ends on t1: the
    remainder when it is at most h, half of it when it is below 2 h (no sliver step)."""
    r = t1 - t
    if r <= h * (1.0 + 1e-12):
        return r, True
    if r < 2.0 * h:
        return 0.5 * r, False
    return h, False


@nb.njit(cache=True, inline="always")
def _interp(t: float, t0: float, dt: float, vals: np.ndarray) -> float:
    """Cubic Lagrange interpolation of samples ``vals`` on the grid ``t0 + k dt``."""
    nn = vals.shape[0]
    if nn == 1:
        return vals[0]
    k = int(math.floor((t - t0) / dt)) - 1
    k = max(0, min(k, nn - 4)) if nn >= 4 else 0
    m = min(4, nn)
    s = 0.0
    for a in range(m):
        ta = t0 + (k + a) * dt
        w = 1.0
        for b in range(m):
            if b != a:
                w *= (t - (t0 + (k + b) * dt)) / (ta - (t0 + (k + b) * dt))
        s += w * vals[k + a]
    return s


@nb.njit(cache=True)
def err_norm(arr: np.ndarray, y: np.ndarray, yn: np.ndarray, err: np.ndarray, atol: float,
             rtol: float) -> float:
    """Scaled max norm of the embedded difference ``err`` mapped to the joints (linearised
    positions and velocities relative to the fairlead, see the module docstring)."""
    n1 = y.shape[0] // 2
    l = arr[0]
    px = 0.0
    pz = 0.0
    vx = 0.0
    vz = 0.0
    dpx = 0.0
    dvx = 0.0
    dz0 = err[0]
    dvz0 = err[n1]
    sc = atol + rtol * max(abs(yn[n1]), abs(y[n1]))
    out = max(abs(dvz0) / sc, abs(dz0) / atol)
    dpz = 0.0
    dvz = 0.0
    for i in range(n1 - 1):
        th = yn[1 + i]
        w = yn[n1 + 1 + i]
        c = math.cos(th)
        s = math.sin(th)
        li = l[i]
        dth = err[1 + i]
        dw = err[n1 + 1 + i]
        px += li * s
        pz -= li * c
        vx += li * c * w
        vz += li * s * w
        dpx += li * c * dth
        dpz += li * s * dth
        dvx += li * (c * dw - s * w * dth)
        dvz += li * (s * dw + c * w * dth)
        sp = atol + rtol * math.sqrt(px * px + pz * pz)
        sv_ = atol + rtol * math.sqrt(vx * vx + (vz + yn[n1]) ** 2)
        e = max(math.sqrt(dpx * dpx + (dpz + dz0) ** 2) / sp,
                math.sqrt(dvx * dvx + (dvz + dvz0) ** 2) / sv_)
        if e > out:
            out = e
    return out


#: 1 / (embedded order + 1): the exponent of the step-size controller.
_K_EXP = 1.0 / 3.0


@nb.njit(cache=True)
def _rejected_step(ctl: np.ndarray, en: float, hs: float) -> float:
    """The retry step after a step of size ``hs`` was rejected with error norm ``en`` (inf: the
    step failed); resets the growth count ``ctl[11]``. ``ctl`` as in :func:`_ros_adaptive_run`."""
    safety, fmin = ctl[2], ctl[3]
    fac = fmin if not np.isfinite(en) else max(fmin, min(1.0, safety * en ** (-_K_EXP)))
    ctl[11] = 0.0
    return hs * fac


@nb.njit(cache=True)
def _accepted_step(ctl: np.ndarray, en: float, hs: float, h: float, last: bool) -> float:
    """The next step after an accepted step of size ``hs`` (proposed ``h``; ``last``: it was clipped
    to the interval's end) with error norm ``en``: PI controller (Gustafsson),
    fac = safety en^(-0.7 k) en_prev^(0.4 k), k = 1/3; updates ``ctl[8]`` (the previous error)
    and ``ctl[11]`` (steps grown in a row)."""
    safety, fmin, fmax, hmax = ctl[2], ctl[3], ctl[4], ctl[5]
    en = max(en, 1e-10)
    ep = ctl[8] if ctl[8] > 0.0 else en
    fac = safety * en ** (-0.7 * _K_EXP) * ep ** (0.4 * _K_EXP)
    # growth cap: at most 1.4 once the step grew in each of the last two steps, so that
    # steadily growing steps are not read as a runaway mode by the check
    cap = fmax if ctl[11] < 2.0 else min(fmax, 1.4)
    fac = max(fmin, min(cap, fac))
    ctl[11] = ctl[11] + 1.0 if fac > 1.4 else 0.0
    if hs >= h * (1.0 - 1e-12):  # a shortened step's error says little about h
        ctl[8] = en
    hnew = min(hs * fac, hmax)
    if last and hs < h:
        hnew = max(hnew, h) if fac >= 1.0 else min(h, hnew)  # a clipped last step: keep h
    return hnew


@nb.njit(cache=True)
def _ros_adaptive_run(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool, t0: float, t1: float,
                      tin0: float, tdt: float, uin: np.ndarray, ein: np.ndarray, y: np.ndarray,
                      chk: np.ndarray, info: np.ndarray, ctl: np.ndarray, at: np.ndarray,
                      ct: np.ndarray, ctimes: np.ndarray, mt: np.ndarray, et: np.ndarray,
                      gamma: float) -> int:
    """Adaptive steps from t0 to exactly t1, in place on y.

    Inputs: samples ``uin, ein`` on the grid ``tin0 + k tdt`` (cubic interpolation).
    ``ctl = [atol, rtol, safety, fac_min, fac_max, h_max, h_min, h (in: proposal; out: next
    proposal), err_prev, jump-allowance rate, runaway-floor rate, growths in a row]``.
    ``chk[7]``, ``chk[10]`` are set per step from the rates (both proportional to the step).
    ``info = [force evaluations, accepted steps, value, t reached, rejected steps]``.
    """
    ns = at.shape[0]
    fs, sq, sv, wk, yn, err = _workspace(arr.shape[1], ns)
    us = np.empty(ns)
    es = np.empty(ns)
    atol, rtol, hmax, hmin = ctl[0], ctl[1], ctl[5], ctl[6]
    h = min(ctl[7], hmax)
    t = t0
    while t < t1:
        hs, last = _clip(t, t1, h)
        for i in range(ns):
            ts = t + ctimes[i] * hs
            us[i] = _interp(ts, tin0, tdt, uin)
            es[i] = _interp(ts, tin0, tdt, ein)
        ok = _ros_step(arr, par, geometric, predict, hs, us, es, y, yn, err, fs, sq, sv, wk, at,
                       ct, mt, et, gamma)
        info[0] += ns
        en = err_norm(arr, y, yn, err, atol, rtol) if ok else np.inf
        if not np.isfinite(en) or en > 1.0:
            info[4] += 1
            h = _rejected_step(ctl, en, hs)
            if h < hmin:
                info[3] = t
                info[2] = h
                return STATUS_STEP_UNDERFLOW
            continue
        chk[7] = ctl[9] * hs
        if chk.shape[0] > 10:
            chk[10] = ctl[10] * hs
        status = check_packed(arr, par, yn, chk, info)
        if status != STATUS_OK:
            info[3] = t + hs
            return status
        y[:] = yn
        info[1] += 1
        t = t1 if last else t + hs
        h = _accepted_step(ctl, en, hs, h, last)
    ctl[7] = h
    info[3] = t
    return STATUS_OK


__all__ = ["STATUS_STEP_UNDERFLOW", "err_norm", "_clip", "_interp", "_K_EXP", "_rejected_step",
           "_accepted_step", "_ros_adaptive_run"]
