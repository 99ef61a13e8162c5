"""Step-size control shared by the adaptive schemes: the next step towards an output time
(:func:`clip_step`), the cubic interpolation of the sampled inputs (:func:`interp_input`), the
error norm (:func:`err_norm`) and the PI controller (:func:`rejected_step`,
:func:`accepted_step`), all compiled.

Error norm: the embedded difference, mapped to the joints (linearised:
``dp_j = dz e_z + sum_{i<j} l_i (cos th_i, sin th_i) dth_i``, likewise the joint velocities),
in the max norm over joints with scale ``atol + rtol |p_j - p_0|`` (positions, m) and
``atol + rtol |v_j|`` (velocities, m/s): the tolerance is on what the user reads, the joint
positions.

``ctl`` (the controller's state, one float array per integrator) =
``[atol, rtol, safety, fac_min, fac_max, h_max, h_min, h (in: proposal; out: next proposal),
err_prev, jump-allowance rate, runaway-floor rate, growths in a row]``.

Integrate layer: imports numba and numpy only.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: Status of the adaptive kernel when the step size fell below its floor (not a check status).
STATUS_STEP_UNDERFLOW = 100


@nb.njit(cache=True)
def clip_step(t: float, t1: float, h: float) -> tuple[float, bool]:
    """The next step from t towards t1 with the proposal h, and whether it ends on t1: the
    remainder when it is at most h, half of it when it is below 2 h (no sliver step)."""
    r = t1 - t
    if r <= h * (1.0 + 1e-12):
        return r, True
    if r < 2.0 * h:
        return 0.5 * r, False
    return h, False


@nb.njit(cache=True, inline="always")
def interp_input(t: float, t0: float, dt: float, vals: np.ndarray) -> float:
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
    no_trig = np.empty(0)  # formed here
    return err_norm_ws(arr, y, yn, err, atol, rtol, no_trig, no_trig, False,
                       np.empty((ERR_ROWS, arr.shape[1])))


#: Rows of the scratch of :func:`err_norm_ws`.
ERR_ROWS = 8


@nb.njit(cache=True, inline="always", fastmath=True)
def _joint_error_max(wk: np.ndarray, n: int, atol: float, rtol: float) -> float:
    """``max_i max(|dp_i| / (atol + rtol |p_i|), |dv_i| / (atol + rtol |v_i|))`` over the joints
    of the running sums in ``wk`` (see :func:`err_norm_ws`): squared ratios, one square root at
    the end; ``fastmath`` lets the loop vectorise (round-off only: the value feeds a step-size
    factor)."""
    out = 0.0
    for i in range(n):
        sp = atol + rtol * math.sqrt(wk[0, i] * wk[0, i] + wk[1, i] * wk[1, i])
        sv_ = atol + rtol * math.sqrt(wk[2, i] * wk[2, i] + wk[3, i] * wk[3, i])
        ep = (wk[4, i] * wk[4, i] + wk[5, i] * wk[5, i]) / (sp * sp)
        ev = (wk[6, i] * wk[6, i] + wk[7, i] * wk[7, i]) / (sv_ * sv_)
        out = max(out, max(ep, ev))
    return math.sqrt(out)


@nb.njit(cache=True, inline="always")
def err_norm_ws(arr: np.ndarray, y: np.ndarray, yn: np.ndarray, err: np.ndarray, atol: float,
                rtol: float, cth: np.ndarray, sth: np.ndarray, trig_ready: bool,
                wk: np.ndarray) -> float:
    """:func:`err_norm` with scratch ``wk`` (``ERR_ROWS`` x links) and the links' cos/sin at
    ``yn`` given in ``cth``, ``sth`` when ``trig_ready`` (else formed here, libm).

    Two passes: the running sums along the line (the joints' positions, velocities and their
    errors), then every joint's scaled error, a loop without carried dependencies (its square
    roots and divisions vectorise); the arithmetic per joint is the same either way."""
    n1 = y.shape[0] // 2
    n = n1 - 1
    l = arr[0]
    px = 0.0
    pz = 0.0
    vx = 0.0
    vz = 0.0
    dpx = 0.0
    dvx = 0.0
    dz0 = err[0]
    dvz0 = err[n1]
    vz0 = yn[n1]
    sc = atol + rtol * max(abs(yn[n1]), abs(y[n1]))
    out = max(abs(dvz0) / sc, abs(dz0) / atol)
    dpz = 0.0
    dvz = 0.0
    for i in range(n):
        th = yn[1 + i]
        w = yn[n1 + 1 + i]
        c = cth[i] if trig_ready else math.cos(th)
        s = sth[i] if trig_ready else math.sin(th)
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
        wk[0, i] = px
        wk[1, i] = pz
        wk[2, i] = vx
        wk[3, i] = vz + vz0
        wk[4, i] = dpx
        wk[5, i] = dpz + dz0
        wk[6, i] = dvx
        wk[7, i] = dvz + dvz0
    return max(out, _joint_error_max(wk, n, atol, rtol))


@nb.njit(cache=True)
def rejected_step(ctl: np.ndarray, en: float, hs: float, k_exp: float) -> float:
    """The retry step after a step of size ``hs`` was rejected with error norm ``en`` (inf: the
    step failed), with the controller's exponent ``k_exp = 1 / (embedded order + 1)``; resets the
    growth count ``ctl[11]`` (``ctl`` as in the module docstring)."""
    safety, fmin = ctl[2], ctl[3]
    fac = fmin if not np.isfinite(en) else max(fmin, min(1.0, safety * en ** (-k_exp)))
    ctl[11] = 0.0
    return hs * fac


@nb.njit(cache=True)
def accepted_step(ctl: np.ndarray, en: float, hs: float, h: float, last: bool,
                  k_exp: float) -> float:
    """The next step after an accepted step of size ``hs`` (proposed ``h``; ``last``: it was clipped
    to the interval's end) with error norm ``en``: PI controller (Gustafsson),
    fac = safety en^(-0.7 k) en_prev^(0.4 k), k = ``k_exp``; updates ``ctl[8]`` (the previous error)
    and ``ctl[11]`` (steps grown in a row)."""
    safety, fmin, fmax, hmax = ctl[2], ctl[3], ctl[4], ctl[5]
    en = max(en, 1e-10)
    ep = ctl[8] if ctl[8] > 0.0 else en
    fac = safety * en ** (-0.7 * k_exp) * ep ** (0.4 * k_exp)
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


@nb.njit(cache=True, inline="always")
def rejection(ctl: np.ndarray, en: float, hs: float, k_exp: float, t: float,
              info: np.ndarray) -> tuple[float, bool]:
    """A rejected step of ``hs`` from t with error norm ``en`` in an adaptive run: counted in
    ``info[4]``; returns the retry step (:func:`rejected_step`) and whether it is below the floor
    ``ctl[6]`` (then ``info[3] = t``, ``info[2]`` = that step, and the run stops)."""
    info[4] += 1
    h = rejected_step(ctl, en, hs, k_exp)
    if h < ctl[6]:
        info[3] = t
        info[2] = h
        return h, True
    return h, False


@nb.njit(cache=True, inline="always")
def scale_allowances(chk: np.ndarray, ctl: np.ndarray, hs: float) -> None:
    """The check's per-step allowances for an accepted adaptive step of ``hs``, in proportion to
    it: the energy jump ``chk[7]`` and (when the check has it) the runaway floor ``chk[10]``,
    from the rates ``ctl[9]``, ``ctl[10]``."""
    chk[7] = ctl[9] * hs
    if chk.shape[0] > 10:
        chk[10] = ctl[10] * hs


__all__ = ["STATUS_STEP_UNDERFLOW", "accepted_step", "clip_step", "ERR_ROWS", "err_norm", "err_norm_ws",
           "interp_input", "rejected_step", "rejection", "scale_allowances"]
