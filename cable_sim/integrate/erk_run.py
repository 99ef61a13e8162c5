"""The compiled adaptive run of an embedded explicit Runge-Kutta pair (:func:`erk_adaptive_run`)
and its tableau (:class:`ErkTableau`; Dormand-Prince 5(4): :data:`DOPRI5`, Tsitouras 5(4):
:data:`TSIT5`).

One call steps from t0 to exactly t1: every stage is the O(n) forward dynamics
(:func:`cable_sim.core.kernel.forward.fd_packed_ws`, workspace allocated once per call), the
error of a step is the embedded difference mapped to the joints
(:func:`cable_sim.integrate.step_control.err_norm`), the step size follows the PI controller of
:mod:`cable_sim.integrate.step_control` and every accepted state passes the compiled check
(:func:`cable_sim.core.kernel.checks.check_packed_ws`). First-same-as-last: when the tableau's
last stage is taken at the new solution (DOPRI5's is) and the check left the state as it was
(a free end: nothing is projected), that stage's slope is the next step's first (as long as the
run lasts: one call per output interval).

Integrate layer: imports numba, numpy, the compiled kernel and :mod:`.step_control`.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction as F

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, STATUS_SINGULAR, check_packed_ws
from cable_sim.core.kernel.forward import fd_trig, fd_workspace
from cable_sim.core.kernel.links import link_trig
from cable_sim.integrate.compiled_steppers import _slope
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


@dataclass(frozen=True)
class ErkTableau:
    """An embedded explicit Runge-Kutta pair as float arrays.

    Attributes
    ----------
    a : ndarray (s, s)
        Stage coefficients (strictly lower triangular).
    b : ndarray (s,)
        Weights of the propagated solution.
    e : ndarray (s,)
        ``b - b_hat``: weights of the error estimate (propagated minus embedded solution).
    c : ndarray (s,)
        Stage times as fractions of the step.
    order : int
        Order of the propagated solution.
    est_order : int
        Order of the embedded solution (the controller's exponent is ``1 / (est_order + 1)``).
    fsal : bool
        The last stage is evaluated at the propagated solution (its slope starts the next step).
    """

    a: np.ndarray
    b: np.ndarray
    e: np.ndarray
    c: np.ndarray
    order: int
    est_order: int
    fsal: bool


def _erk_tableau(a: list[list[F]], b: list[F], b_hat: list[F], order: int, est_order: int) -> ErkTableau:
    """Float arrays of an exact (rational) pair; ``c`` from the row sums, FSAL from the last row."""
    s = len(b)
    am = np.zeros((s, s))
    for i, row in enumerate(a):
        am[i, :len(row)] = [float(x) for x in row]
    c = np.array([float(sum(row, F(0))) for row in a])
    fsal = len(a[-1]) == s - 1 and list(a[-1]) == list(b[:-1]) and b[-1] == 0
    e = np.array([float(bi - bh) for bi, bh in zip(b, b_hat, strict=True)])
    return ErkTableau(am, np.array([float(x) for x in b]), e, c, order, est_order, bool(fsal))


#: Dormand & Prince (1980) 5(4) pair, "DOPRI5": 7 stages, FSAL (six force evaluations per
#: accepted step), propagated order 5, embedded order 4 (Hairer, Norsett & Wanner, Solving ODEs I,
#: table II.5.2).
DOPRI5_A = [
    [],
    [F(1, 5)],
    [F(3, 40), F(9, 40)],
    [F(44, 45), F(-56, 15), F(32, 9)],
    [F(19372, 6561), F(-25360, 2187), F(64448, 6561), F(-212, 729)],
    [F(9017, 3168), F(-355, 33), F(46732, 5247), F(49, 176), F(-5103, 18656)],
    [F(35, 384), F(0), F(500, 1113), F(125, 192), F(-2187, 6784), F(11, 84)],
]
DOPRI5_B = [F(35, 384), F(0), F(500, 1113), F(125, 192), F(-2187, 6784), F(11, 84), F(0)]
DOPRI5_B_HAT = [F(5179, 57600), F(0), F(7571, 16695), F(393, 640), F(-92097, 339200), F(187, 2100),
                F(1, 40)]
DOPRI5 = _erk_tableau(DOPRI5_A, DOPRI5_B, DOPRI5_B_HAT, 5, 4)

#: Tsitouras (2011) 5(4) pair, "Tsit5" (Ch. Tsitouras, Runge-Kutta pairs of order 5(4) satisfying
#: only the first column simplifying assumption, Comput. Math. Appl. 62 (2011) 770-775): 7 stages,
#: FSAL, propagated order 5, embedded order 4; decimal coefficients as the paper gives them
#: (exact binary values of those decimals here; the order conditions hold to round-off).
TSIT5_A = [[F(x) for x in row] for row in (
    [],
    [0.161],
    [-0.008480655492356989, 0.335480655492357],
    [2.8971530571054935, -6.359448489975075, 4.3622954328695815],
    [5.325864828439257, -11.748883564062828, 7.4955393428898365, -0.09249506636175525],
    [5.86145544294642, -12.92096931784711, 8.159367898576159, -0.071584973281401,
     -0.028269050394068383],
    [0.09646076681806523, 0.01, 0.4798896504144996, 1.379008574103742, -3.290069515436081,
     2.324710524099774],
)]
TSIT5_B = TSIT5_A[-1] + [F(0)]
#: The embedded weights: the propagated ones plus Tsitouras' differences (b_hat - b).
TSIT5_B_HAT = [b + F(d) for b, d in zip(TSIT5_B, (
    -0.00178001105222577714, -0.0008164344596567469, 0.007880878010261995, -0.1447110071732629,
    0.5823571654525552, -0.45808210592918697, 1.0 / 66.0), strict=True)]
TSIT5 = _erk_tableau(TSIT5_A, TSIT5_B, TSIT5_B_HAT, 5, 4)


@nb.njit(cache=True, inline="always")
def _input(t: float, tin0: float, tdt: float, vals: np.ndarray) -> float:
    """The input at t from its samples: cubic interpolation, or the one value of a constant input
    (a single sample)."""
    return vals[0] if vals.shape[0] == 1 else interp_input(t, tin0, tdt, vals)


@nb.njit(cache=True, inline="always")
def _lincomb(out: np.ndarray, base: np.ndarray, kk: np.ndarray, w: np.ndarray, m: int, h: float) -> None:
    """``out = base + h sum_(k < m) w[k] kk[k]`` (m >= 1), two slopes per pass over the state
    (a pass per slope loads and stores ``out`` m times: about twice the time at n = 80)."""
    n2 = out.shape[0]
    c0 = h * w[0]
    r0 = kk[0]
    if m == 1:
        for j in range(n2):
            out[j] = base[j] + c0 * r0[j]
        return
    c1 = h * w[1]
    r1 = kk[1]
    for j in range(n2):
        out[j] = base[j] + (c0 * r0[j] + c1 * r1[j])
    for k in range(2, m - 1, 2):
        d0 = h * w[k]
        d1 = h * w[k + 1]
        q0 = kk[k]
        q1 = kk[k + 1]
        for j in range(n2):
            out[j] += d0 * q0[j] + d1 * q1[j]
    if m % 2 == 1:
        d0 = h * w[m - 1]
        q0 = kk[m - 1]
        for j in range(n2):
            out[j] += d0 * q0[j]


@nb.njit(cache=True, error_model="numpy")
def _erk_step(arr: np.ndarray, par: np.ndarray, h: float, t: float, tin0: float, tdt: float,
              uin: np.ndarray, ein: np.ndarray, y: np.ndarray, kk: np.ndarray, first_ready: bool,
              a: np.ndarray, b: np.ndarray, e: np.ndarray, c: np.ndarray, fsal: bool, ys: np.ndarray,
              yn: np.ndarray, err: np.ndarray, zero: np.ndarray, lam: np.ndarray,
              ws: np.ndarray) -> bool:
    """One step of h from (t, y): ``yn`` the propagated solution, ``err`` the estimate
    ``h sum e_i k_i`` (``zero``: zeros of the state's size); ``kk[i]`` the stage slopes
    (``kk[0]`` given when ``first_ready``; the links' cos/sin at y are then in ``ws`` too).
    False if a force evaluation failed.

    With ``fsal`` the last stage's state is the propagated solution (its row of ``a`` is ``b``):
    ``yn`` is that state, and the links' cos/sin its force evaluation formed stay in ``ws``."""
    ns = b.shape[0]
    for i in range(ns):
        if i == 0:
            if not first_ready:
                if not _slope(arr, par, _input(t, tin0, tdt, uin), _input(t, tin0, tdt, ein), y, lam,
                              kk[0], ws, False):
                    return False
            continue
        _lincomb(ys, y, kk, a[i], i, h)
        ts = t + c[i] * h
        if not _slope(arr, par, _input(ts, tin0, tdt, uin), _input(ts, tin0, tdt, ein), ys, lam, kk[i],
                      ws, False):
            return False
    _lincomb(err, zero, kk, e, ns, h)
    if fsal:
        yn[:] = ys
    else:
        _lincomb(yn, y, kk, b, ns, h)
    return True


@nb.njit(cache=True, error_model="numpy")
def erk_adaptive_run(arr: np.ndarray, par: np.ndarray, t0: float, t1: float, tin0: float, tdt: float,
                     uin: np.ndarray, ein: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray,
                     ctl: np.ndarray, a: np.ndarray, b: np.ndarray, e: np.ndarray, c: np.ndarray,
                     fsal: bool, k_exp: float) -> int:
    """Adaptive steps of the pair ``(a, b, e, c)`` from t0 to exactly t1, in place on y.

    Inputs, ``chk``, ``ctl`` and ``info`` as in
    :func:`cable_sim.integrate.implicit.ros_adaptive._ros_adaptive_run`; ``k_exp`` the
    controller's exponent ``1 / (embedded order + 1)``; ``fsal``: the last stage is taken at the
    propagated solution. Returns a check status or :data:`STATUS_STEP_UNDERFLOW`.
    """
    ns = b.shape[0]
    n2 = y.shape[0]
    kk = np.empty((ns, n2))
    ys = np.empty(n2)
    yn = np.empty(n2)
    err = np.empty(n2)
    zero = np.zeros(n2)
    lam = np.empty(2)
    ws = fd_workspace(arr.shape[1])
    cth, sth = fd_trig(ws, arr.shape[1])
    ewk = np.empty((ERR_ROWS, arr.shape[1]))
    atol, rtol, hmax = ctl[0], ctl[1], ctl[5]
    reuse = fsal and par[10] == 0.0  # an anchored state is projected by the check: no reuse
    if uin.shape[0] > 1 and np.all(uin == uin[0]):  # a constant input: no interpolation
        uin = uin[:1]
    if ein.shape[0] > 1 and np.all(ein == ein[0]):
        ein = ein[:1]
    ready = False
    h = min(ctl[7], hmax)
    t = t0
    while t < t1:
        hs, last = clip_step(t, t1, h)
        ok = _erk_step(arr, par, hs, t, tin0, tdt, uin, ein, y, kk, ready, a, b, e, c, fsal, ys, yn,
                       err, zero, lam, ws)
        info[0] += ns - 1 if ready else ns
        ready = ready and ok  # the first slope at y stays valid on a rejection
        en = np.inf
        if ok:
            if not fsal:  # (FSAL: the last stage's force evaluation formed them at yn)
                link_trig(yn, cth, sth)  # for the error norm, the check and the next step
            en = err_norm_ws(arr, y, yn, err, atol, rtol, cth, sth, True, ewk)
        if not np.isfinite(en) or en > 1.0:
            h, underflow = rejection(ctl, en, hs, k_exp, t, info)
            if underflow:
                return STATUS_STEP_UNDERFLOW if ok else STATUS_SINGULAR
            continue
        scale_allowances(chk, ctl, hs)
        status = check_packed_ws(arr, par, yn, chk, info, cth, sth)
        if status != STATUS_OK:
            info[3] = t + hs
            return status
        y[:] = yn
        if reuse:
            kk[0, :] = kk[ns - 1, :]  # the last stage's slope at yn (its cos/sin are in ws)
            ready = True
        info[1] += 1
        t = t1 if last else t + hs
        h = accepted_step(ctl, en, hs, h, last, k_exp)
    ctl[7] = h
    info[3] = t
    return STATUS_OK


__all__ = ["DOPRI5", "DOPRI5_A", "DOPRI5_B", "DOPRI5_B_HAT", "TSIT5", "TSIT5_A", "TSIT5_B",
           "TSIT5_B_HAT", "ErkTableau", "erk_adaptive_run"]
