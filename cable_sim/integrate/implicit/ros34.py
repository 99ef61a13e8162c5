"""ROS34PW2: a four-stage, order-3, L-stable Rosenbrock W-method on the O(n) operator, fixed
step and adaptive (embedded order-2 estimate, PI step controller).

Method: Rang & Angermann, "New Rosenbrock W-methods of order 3 for partial differential
algebraic equations of index 1", BIT Numer. Math. 45 (2005) 761-787, method ROS34PW2
(coefficients as tabulated there and in PETSc's ``TSROSWRA34PW2``, ``src/ts/impls/rosw/rosw.c``).
It is a *W-method*: order 3 for any approximation ``T`` of the Jacobian in
``W = I - h gamma T`` -- here the local damping/stiffness ``D``, ``K`` of
:mod:`cable_sim.integrate.implicit.operator` -- L-stable (``R(inf) = 0``) and stiffly accurate;
the embedded solution (weights ``b_hat``) is of order 2.

Classical form (``k_i`` the stage increments, ``T`` the approximate Jacobian)::

    (I - h gamma T) k_i = h f(t + alpha_i h, y + sum_j alpha_ij k_j) + h T sum_j gamma_ij k_j
    y' = y + sum_i b_i k_i,      y_hat' = y + sum_i b_hat_i k_i

It is run in the transformed variables ``s_i = sum_j gamma_ij k_j / h`` (Hairer & Wanner,
Solving ODEs II, IV.7), which need no product with ``T``::

    (I - h gamma T) s_i = gamma (f(Y_i) + sum_j c_ij s_j),   Y_i = y + h sum_j a_ij s_j
    y' = y + h sum_i m_i s_i,       a = alpha Gamma^-1, c = diag(1/gamma) - Gamma^-1, m = b Gamma^-1

For the cable, ``y = (q, v)``, ``f = (v, a(q, v))``, ``T = [[0, I], [-M^-1 K, -M^-1 D]]``, and
a stage with right-hand side ``(rq, rv)`` is (as in :class:`~.schemes.Rosenbrock2`)
``sv = rv - M~^-1 (hg D rv + hg K (rq + hg rv))``, ``sq = rq + hg sv`` with
``M~ = M + hg D + hg^2 K``, ``hg = gamma h``: one factorisation and four O(n) solves and four
force evaluations per step. The drag part of ``D`` is linearised at the predicted velocity
``v + h a(q, v)`` (``predict_drag``, default): at rest the paper drag's Jacobian is zero, and
linearised at ``v`` the first steps of a free fall treat the drag explicitly (measured at n = 80:
unstable from 50 ms; with the prediction stable to 125 ms). Any ``W`` keeps the W-method's order.

The coefficients are one :class:`RosTableau` (class attribute ``tableau``); the compiled step,
runs and the dense reference step take them as arguments, so another four-stage W-method
(:mod:`cable_sim.integrate.implicit.ros34prw`) is a subclass that swaps the tableau.

Error norm of the adaptive scheme (:class:`Ros34PW2Adaptive`): the embedded difference,
mapped to the joints (linearised: ``dp_j = dz e_z + sum_{i<j} l_i (cos th_i, sin th_i) dth_i``,
likewise the joint velocities), in the max norm over joints with scale
``atol + rtol |p_j - p_0|`` (positions, m) and ``atol + rtol |v_j|`` (velocities, m/s): the
tolerance is on what the user reads, the joint positions.

Integrate layer: imports numba, numpy, :mod:`cable_sim.core` (dynamics, kernel, system),
:mod:`cable_sim.integrate.base`, :mod:`cable_sim.integrate.checks`,
:mod:`cable_sim.integrate.errors` and the sibling modules ``dense`` and ``operator``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from cable_sim.core import dynamics
from cable_sim.core import kernel as fast
from cable_sim.core.kernel.checks import STATUS_OK, STATUS_SINGULAR, check_packed, check_packed_ws
from cable_sim.core.kernel.forward import fd_packed_ws, fd_trig
from cable_sim.core.kernel.links import link_trig
from cable_sim.core.kernel.signals import sample_program
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.system import CableSystem
from cable_sim.integrate.base import _WARMED, Integrator
from cable_sim.integrate.checks import disarm
from cable_sim.integrate.errors import ENERGY_JUMP, OSCILLATION, IntegrationError
from cable_sim.integrate.implicit.dense import _dense_solve, dense_operator
from cable_sim.integrate.implicit.operator import _dk_product, _op_solve
from cable_sim.integrate.implicit.operator import geometric_stiffness as _geometric_stiffness
from cable_sim.integrate.implicit.run import _factor_at, factor_workspace

# --------------------------------------------------------------------------------------------
# Coefficients (Rang & Angermann 2005, ROS34PW2; classical form)
# --------------------------------------------------------------------------------------------

#: Diagonal gamma of ROS34PW2.
GAMMA = 4.3586652150845900e-01
#: alpha_ij (strictly lower triangular).
ALPHA = np.array([
    [0.0, 0.0, 0.0, 0.0],
    [8.7173304301691801e-01, 0.0, 0.0, 0.0],
    [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
])
#: gamma_ij (lower triangular, diagonal GAMMA).
GAMMA_IJ = np.array([
    [GAMMA, 0.0, 0.0, 0.0],
    [-8.7173304301691801e-01, GAMMA, 0.0, 0.0],
    [-9.0338057013044082e-01, 5.4180672388095326e-02, GAMMA, 0.0],
    [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, GAMMA],
])
#: Weights of the order-3 solution.
B = np.array([2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, GAMMA])
#: Weights of the embedded order-2 solution.
B_HAT = np.array([3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01])


class RosTableau(NamedTuple):
    """A Rosenbrock W-method in both forms: the classical coefficients (``gamma``, ``alpha``,
    ``gamma_ij`` with diagonal ``gamma``, weights ``b`` and embedded ``b_hat``), the stage times
    ``c_times`` (row sums of ``alpha``) and the transformed coefficients ``a_t``, ``c_t``,
    ``m_t``, ``e_t`` the compiled step runs on (see the module docstring). Built by
    :func:`ros_tableau`."""

    name: str
    gamma: float
    alpha: np.ndarray
    gamma_ij: np.ndarray
    b: np.ndarray
    b_hat: np.ndarray
    c_times: np.ndarray
    a_t: np.ndarray
    c_t: np.ndarray
    m_t: np.ndarray
    e_t: np.ndarray


def ros_tableau(name: str, gamma: float, alpha: np.ndarray, gamma_ij: np.ndarray, b: np.ndarray,
                b_hat: np.ndarray) -> RosTableau:
    """The :class:`RosTableau` of a Rosenbrock W-method given in the classical form (Hairer &
    Wanner IV.7): ``a = alpha Gamma^-1``, ``c = diag(1/gamma) - Gamma^-1``, ``m = b Gamma^-1``,
    ``e = (b - b_hat) Gamma^-1``."""
    ginv = np.linalg.inv(gamma_ij)
    return RosTableau(name, float(gamma), alpha, gamma_ij, b, b_hat, alpha.sum(axis=1),
                      alpha @ ginv, np.diag(np.diag(ginv)) - ginv, b @ ginv, (b - b_hat) @ ginv)


#: ROS34PW2 in both forms.
TABLEAU = ros_tableau("ROS34PW2", GAMMA, ALPHA, GAMMA_IJ, B, B_HAT)
#: Stage times alpha_i (fractions of h) = row sums of ALPHA.
C_TIMES = TABLEAU.c_times
#: Transformed coefficients (see the module docstring).
A_T = TABLEAU.a_t
C_T = TABLEAU.c_t  # diag(1/gamma) - Gamma^-1: strictly lower
M_T = TABLEAU.m_t
E_T = TABLEAU.e_t  # error weights: y' - y_hat' = h sum_i E_T[i] s_i

#: Status of the adaptive kernel when the step size fell below its floor (not a check status).
STATUS_STEP_UNDERFLOW = 100

#: Default input-sampling spacing of the adaptive scheme [s] (cubic interpolation in between).
INPUT_SPACING = 0.02


# --------------------------------------------------------------------------------------------
# Compiled step
# --------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _ros_step(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool, h: float, us: np.ndarray,
              es: np.ndarray, y: np.ndarray, yn: np.ndarray, err: np.ndarray, fs: tuple,
              sq: np.ndarray, sv: np.ndarray, wk: np.ndarray, at: np.ndarray, ct: np.ndarray,
              mt: np.ndarray, et: np.ndarray, gamma: float, trig_ready: bool = False) -> bool:
    """One step of h of the W-method with transformed coefficients ``at, ct, mt, et`` and
    diagonal ``gamma`` (ROS34PW2's or another's, :class:`RosTableau`) from y into ``yn`` and the
    embedded difference into ``err`` (both ``2(n+1)``); ``us[i], es[i]`` are the inputs at stage
    i's time. Returns False when a force evaluation or the factorisation is singular. ``fs`` is
    the factorisation's scratch (:func:`cable_sim.integrate.implicit.run.factor_workspace`),
    ``wk`` a (9, n+1) workspace. ``trig_ready``: the forward dynamics' workspace (``fs[0]``)
    holds the links' cos/sin at y already (:func:`cable_sim.core.kernel.forward.fd_trig`; the
    fixed-step run leaves those of the check there), not recomputed by the first stage."""
    n1 = y.shape[0] // 2
    hg = gamma * h
    fw, jw, F, kgeo, W, S, X = fs
    acc = wk[2]
    rd = wk[3]
    rk = wk[4]
    rhs = wk[5]
    x = wk[6]
    lam = wk[8, :2]
    ns = at.shape[0]
    # the stage combinations run stage by stage over whole rows (vectorised loops), adding the
    # terms in the same order as a per-entry sum over the stages: the same arithmetic
    Yq = wk[0]
    Yv = wk[1]
    for i in range(ns):
        for j in range(n1):
            Yq[j] = y[j]
            Yv[j] = y[n1 + j]
        for m in range(i):
            c = h * at[i, m]
            for j in range(n1):
                Yq[j] += c * sq[m, j]
                Yv[j] += c * sv[m, j]
        if not fd_packed_ws(arr, par, us[i], es[i], Yq, Yv, acc, lam, fw, trig_ready and i == 0):
            return False
        if i == 0:
            # drag linearised at the predicted velocity v + h a (a W-method keeps its order for
            # any W; at rest the drag Jacobian at v itself is zero and the first steps of a
            # free fall would treat the drag explicitly)
            vp = wk[7]
            for j in range(n1):
                vp[j] = Yv[j] + h * acc[j] if predict else Yv[j]
            if not _factor_at(arr, par, geometric, hg, Yq, Yv, acc, lam, vp, fw, jw, F, kgeo, W, S,
                              X, h):
                return False
        for j in range(n1):
            rk[j] = Yv[j]  # the sums of rq, rv first (in rk, rd)
            rd[j] = acc[j]
        for m in range(i):
            c = ct[i, m]
            for j in range(n1):
                rk[j] += c * sq[m, j]
                rd[j] += c * sv[m, j]
        for j in range(n1):
            rq = rk[j] * gamma
            rv = rd[j] * gamma
            rd[j] = rv
            rk[j] = rq + hg * rv
            sq[i, j] = rq  # completed below
        _dk_product(arr, par, hg, W, rd, rk, rhs)
        _op_solve(arr, par, W, S, X, rhs, x)
        for j in range(n1):
            sv[i, j] = rd[j] - x[j]
            sq[i, j] += hg * sv[i, j]
    dq = wk[0]  # the stage rows are free now: the weighted sums of the stages
    dv = wk[1]
    eq = wk[2]
    ev = wk[3]
    for j in range(n1):
        dq[j] = 0.0
        dv[j] = 0.0
        eq[j] = 0.0
        ev[j] = 0.0
    for i in range(ns):
        mi = mt[i]
        ei = et[i]
        for j in range(n1):
            dq[j] += mi * sq[i, j]
            dv[j] += mi * sv[i, j]
            eq[j] += ei * sq[i, j]
            ev[j] += ei * sv[i, j]
    for j in range(n1):
        yn[j] = y[j] + h * dq[j]
        yn[n1 + j] = y[n1 + j] + h * dv[j]
        err[j] = h * eq[j]
        err[n1 + j] = h * ev[j]
    return True


@nb.njit(cache=True, inline="always")
def _workspace(n: int, ns: int):
    """Scratch arrays of one compiled run (the factorisation's scratch of
    :func:`cable_sim.integrate.implicit.run.factor_workspace`, stage positions/velocities, work
    rows, new state and error) for n links and ns stages."""
    n1 = n + 1
    return (factor_workspace(n), np.zeros((ns, n1)), np.zeros((ns, n1)),
            np.zeros((9, max(n1, 2))), np.empty(2 * n1), np.empty(2 * n1))


@nb.njit(cache=True)
def _ros_fixed_run(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool, h: float, u: np.ndarray,
                   eta: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray,
                   at: np.ndarray, ct: np.ndarray, mt: np.ndarray, et: np.ndarray,
                   gamma: float) -> int:
    """``u.shape[0]`` checked fixed steps (``u[k, i]``: input at stage i of step k), in place
    on y; as :func:`cable_sim.integrate.implicit.run._implicit_run`."""
    ns = at.shape[0]
    n = arr.shape[1]
    fs, sq, sv, wk, yn, err = _workspace(n, ns)
    # the links' cos/sin at y in the forward dynamics' workspace: the check of each step leaves
    # those of the new state there, the next step's first force evaluation reuses them
    cth, sth = fd_trig(fs[0], n)
    link_trig(y, cth, sth)
    for k in range(u.shape[0]):
        info[1] = k
        ok = _ros_step(arr, par, geometric, predict, h, u[k], eta[k], y, yn, err, fs, sq, sv, wk,
                       at, ct, mt, et, gamma, True)
        info[0] += ns
        if not ok:
            return STATUS_SINGULAR
        if par[10] == 0.0:  # (anchored: the check's projection recomputes them)
            link_trig(yn, cth, sth)
        status = check_packed_ws(arr, par, yn, chk, info, cth, sth)
        if status != STATUS_OK:
            return status
        y[:] = yn
    return STATUS_OK


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


# --------------------------------------------------------------------------------------------
# Integrators
# --------------------------------------------------------------------------------------------


def _dense_ros_step(system: CableSystem, t: float, y: np.ndarray, h: float, geometric: bool,
                    predict: bool = True, tableau: RosTableau = TABLEAU
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One step of the Rosenbrock W-method ``tableau`` (default ROS34PW2) with the dense ``M``,
    ``D``, ``K`` (reference for the O(n) path): the new state and the embedded difference."""
    model = system.model
    n1 = model.ndof
    q, v = y[:n1], y[n1:]
    gamma, at, ct, ctimes = tableau.gamma, tableau.a_t, tableau.c_t, tableau.c_times
    hg = gamma * h
    ns = at.shape[0]
    sq = np.zeros((ns, n1))
    sv = np.zeros((ns, n1))
    Mt = None
    for i in range(ns):
        Yq = q + h * (at[i, :i] @ sq[:i])
        Yv = v + h * (at[i, :i] @ sv[:i])
        acc, lam = system.accelerations(t + ctimes[i] * h, np.concatenate([Yq, Yv]))
        system.nfev += 1
        if i == 0:
            kgeo = None
            if geometric:
                F = dynamics.joint_forces(model, Yq, Yv, acc, lam)
                kgeo = _geometric_stiffness(model, Yq, F)
            M, D, K = dense_operator(model, Yq, Yv + h * acc if predict else Yv, kgeo)
            Mt = M + hg * D + hg * hg * K
        rq = gamma * (Yv + ct[i, :i] @ sq[:i])
        rv = gamma * (acc + ct[i, :i] @ sv[:i])
        sv[i] = rv - _dense_solve(model, q, Mt, hg * (D @ rv) + hg * (K @ (rq + hg * rv)))
        sq[i] = rq + hg * sv[i]
    mt, et = tableau.m_t, tableau.e_t
    yn = np.concatenate([q + h * (mt @ sq), v + h * (mt @ sv)])
    return yn, np.concatenate([h * (et @ sq), h * (et @ sv)])


class Ros34PW2(Integrator):
    """ROS34PW2 (Rang & Angermann 2005) with the local O(n) operator, fixed step.

    Order 3 for any approximation of the Jacobian (a Rosenbrock W-method), hence order 3 with
    the local ``D``, ``K`` of :mod:`cable_sim.integrate.implicit`. Four stages: four force
    evaluations, one O(n) factorisation and four O(n) solves per step (twice the work of
    :class:`~cable_sim.integrate.implicit.schemes.Rosenbrock2`). Stability: L-stable for the
    part in ``W`` (``R(z) -> 0`` as ``z -> -inf``), stiffly accurate; embedded order-2
    solution (used by :class:`Ros34PW2Adaptive`). See :mod:`cable_sim.integrate.implicit.ros34`.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    geometric_stiffness : bool
        Include the tension stiffness in ``K`` (default True).
    predict_drag : bool
        Linearise the drag (``D``) at the predicted velocity ``v + h a`` instead of ``v``
        (default True; any ``W`` keeps the order, this one keeps the drag implicit from rest).
    max_drift, taut_slack, max_condition, compiled
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "ros34pw2"
    order = 3
    #: The scheme's coefficients (a subclass with another four-stage W-method swaps only these).
    tableau: RosTableau = TABLEAU
    _fast_offsets = tuple(float(c) for c in TABLEAU.c_times)

    def __init__(self, system: CableSystem, step: float = 1e-2, geometric_stiffness: bool = True,
                 predict_drag: bool = True, **kwargs) -> None:
        self.geometric = bool(geometric_stiffness)
        self.predict = bool(predict_drag)
        super().__init__(system, step=step, **kwargs)

    def _fast_kernel(self, arr, par, h, u, eta, y, chk, info) -> int:
        tb = self.tableau
        return _ros_fixed_run(arr, par, self.geometric, self.predict, h, u, eta, y, chk, info, tb.a_t,
                              tb.c_t, tb.m_t, tb.e_t, tb.gamma)

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        return _dense_ros_step(self.system, t, y, h, self.geometric, self.predict, self.tableau)[0]


class Ros34PW2Adaptive(Ros34PW2):
    """ROS34PW2 with its embedded order-2 error estimate and a PI step-size controller.

    Order 3 (the propagated solution; the estimate is order 2), L-stable, see :class:`Ros34PW2`.
    :meth:`advance` steps adaptively from t to exactly ``t_end`` (the output grid stays fixed:
    the last step of an interval is shortened to end on it, the controller's proposal carries
    over to the next interval). Error per step: the joint-mapped max norm of the module
    docstring against ``atol + rtol |.|``; PI controller (Gustafsson) with safety factor,
    ``fac_min``/``fac_max`` bounds and rejection. Inputs are sampled every ``input_spacing`` s
    (at least four samples per interval) and interpolated cubically inside the compiled loop.

    Parameters
    ----------
    system : CableSystem
    step : float
        Output interval of :meth:`Integrator.integrate`-style use and of :meth:`step` [s].
    rtol, atol : float
        Relative tolerance (>= 0) and absolute tolerance [m, m/s] (> 0) of the joint positions
        and velocities per step.
    first_step : float
        First trial step [s] (default 1e-3).
    max_step : float
        Largest step [s] (default inf).
    safety, fac_min, fac_max : float
        Controller safety factor (0 < safety <= 1) and bounds of the step change per step
        (0 < fac_min < 1 < fac_max).
    input_spacing : float
        Input sampling interval [s] (> 0).
    geometric_stiffness, max_drift, taut_slack, max_condition, compiled
        See :class:`Ros34PW2`.
    """

    name = "ros34pw2_adaptive"
    order = 3
    adaptive = True

    def __init__(self, system: CableSystem, step: float = 1e-2, rtol: float = 0.0,
                 atol: float = 1e-3, first_step: float = 1e-3, max_step: float = np.inf,
                 safety: float = 0.9, fac_min: float = 0.2, fac_max: float = 2.0,
                 input_spacing: float = INPUT_SPACING, **kwargs) -> None:
        checks = (("rtol", rtol, np.isfinite(rtol) and rtol >= 0, "finite number >= 0"),
                  ("atol", atol, np.isfinite(atol) and atol > 0, "finite number > 0"),
                  ("first_step", first_step, np.isfinite(first_step) and first_step > 0,
                   "finite number > 0"),
                  ("max_step", max_step, max_step > 0, "number > 0 (inf allowed)"),
                  ("safety", safety, 0 < safety <= 1, "0 < safety <= 1"),
                  ("fac_min", fac_min, 0 < fac_min < 1, "0 < fac_min < 1"),
                  ("fac_max", fac_max, 1 < fac_max < np.inf, "1 < fac_max < inf"),
                  ("input_spacing", input_spacing, np.isfinite(input_spacing) and input_spacing > 0,
                   "finite number > 0"))
        for name, value, ok, allowed in checks:
            if not ok:
                raise ValueError(f"parameter '{name}' = {value!r} is invalid; allowed: {allowed}")
        self.rtol, self.atol = float(rtol), float(atol)
        self.input_spacing = float(input_spacing)
        self._ctl = np.array([atol, rtol, safety, fac_min, fac_max, max_step, 1e-10,
                              first_step, 0.0, 0.0, 0.0, 0.0], dtype=float)
        self.first_step = float(first_step)
        #: Rejected steps so far.
        self.nrejected = 0
        super().__init__(system, step=step, **kwargs)

    def _warm(self) -> None:
        cls = type(self)
        if cls in _WARMED:
            return
        arr, par = fast.pack_arrays(CableModel.from_params(CableParams(n_links=2)))
        ctl = self._ctl.copy()
        tb = self.tableau
        _ros_adaptive_run(arr, par, True, True, 0.0, 1e-3, 0.0, 1e-3, np.zeros(2), np.zeros(2),
                          np.zeros(6), self._chk(), np.zeros(5), ctl, tb.a_t, tb.c_t, tb.c_times,
                          tb.m_t, tb.e_t, tb.gamma)
        _WARMED.add(cls)

    def step(self, t: float, y: np.ndarray, h: float | None = None) -> np.ndarray:
        """Advance adaptively over one output interval ``h`` (default: the configured step)."""
        return self.advance(t, y, t + (self.h if h is None else h))

    def _sample(self, t0: float, t1: float) -> tuple[float, np.ndarray, np.ndarray]:
        k = max(3, int(np.ceil((t1 - t0) / self.input_spacing - 1e-9)))
        dt = (t1 - t0) / k
        prog = self.system.input_program()
        if prog is not None:  # the scene's built-in signals: one compiled call, same times
            u, eta = np.empty((k + 1, 1)), np.empty((k + 1, 1))
            sample_program(prog, float(t0), float(dt), np.zeros(1), u, eta)
            return dt, u.reshape(k + 1), eta.reshape(k + 1)
        ins = [self.system.input_at(t0 + i * dt) for i in range(k + 1)]
        return (dt, np.array([i.heave_force for i in ins]),
                np.array([i.wave_elevation for i in ins]))

    def advance(self, t: float, y: np.ndarray, t_end: float) -> np.ndarray:
        """Adaptive steps from t to exactly ``t_end`` (checked as every step of the contract)."""
        y = self._validate(y)
        if not t_end > t:
            raise ValueError(f"parameter 't_end' = {t_end!r} is invalid; allowed: > t = {t!r}")
        if self._last_y is None or not np.array_equal(y, self._last_y):
            self._ctl[7] = self.first_step  # a new run: start afresh
            self._ctl[8] = 0.0
            self._ctl[11] = 0.0
        dt, u, eta = self._sample(t, t_end)
        if self.compiled:
            return self._advance_fast(t, y, t_end, dt, u, eta)
        return self._advance_python(t, y, t_end, dt, u, eta)

    def _advance_fast(self, t, y, t_end, dt, u, eta) -> np.ndarray:
        arr, par, chk = self._fast_model()
        yc = np.array(y, dtype=float, copy=True)
        span = t_end - t
        self.arm_checks(yc, span, 1, u, eta, chk)
        self._ctl[9] = chk[7] / span
        self._ctl[10] = (chk[10] / span) if chk.shape[0] > 10 else 0.0
        info = np.zeros(5)
        tb = self.tableau
        try:
            status = _ros_adaptive_run(arr, par, self.geometric, self.predict, float(t), float(t_end),
                                       float(t), float(dt), u, eta, yc, chk, info, self._ctl, tb.a_t,
                                       tb.c_t, tb.c_times, tb.m_t, tb.e_t, tb.gamma)
        finally:
            disarm(chk)
        self.nsteps += int(info[1])
        self.nrejected += int(info[4])
        self.system.nfev += int(info[0])
        if status != 0:
            chk[6] = np.nan
            self._fail(status, float(info[3]), float(info[2]), yc)
        self.step_used = span / max(1, int(info[1]))
        return self._accepted(yc)

    def _fail(self, status: int, t: float, value: float, y: np.ndarray) -> None:
        if status == STATUS_STEP_UNDERFLOW:
            raise IntegrationError(t, f"step size {value:.3g} s below the floor {self._ctl[6]:g} s: "
                                   f"the error estimate does not fall below atol = {self.atol:g}, "
                                   f"rtol = {self.rtol:g} (singular or diverging dynamics)")
        self._raise_status(status, t, value, y)

    def _advance_python(self, t, y, t_end, dt, u, eta) -> np.ndarray:
        """The same controller on the dense step (reference path)."""
        ctl = self._ctl
        atol, rtol, hmax, hmin = ctl[0], ctl[1], ctl[5], ctl[6]
        span = t_end - t
        self._budget_for(y, span, float(np.abs(u).max()), float(np.abs(eta).max()))
        rate = self._energy_jump_allowed(span) / span
        arr, _par = fast.pack_arrays(self.system.model)
        saved = self.system.input_at
        h = min(ctl[7], hmax)
        try:
            t_in = t  # the sampling grid's origin (t itself advances below)
            self.system.input_at = lambda s: dynamics.Inputs(
                float(_interp(s, t_in, dt, u)), float(_interp(s, t_in, dt, eta)))
            while t < t_end:
                hs, last = _clip(t, t_end, h)
                try:
                    yn, err = _dense_ros_step(self.system, t, y, hs, self.geometric, self.predict,
                                              self.tableau)
                    en = err_norm(arr, y, yn, err, atol, rtol)
                except np.linalg.LinAlgError:
                    en = np.inf
                if not np.isfinite(en) or en > 1.0:
                    self.nrejected += 1
                    h = _rejected_step(ctl, float(en), float(hs))
                    if h < hmin:
                        self._fail(STATUS_STEP_UNDERFLOW, t, h, y)
                    continue
                yn = self._check(t + hs, yn, y)
                jump = self._energy(yn) - self._energy(y)
                if jump > rate * hs:
                    self._raise_status(ENERGY_JUMP, t + hs, jump, y)
                mem = self._osc_memory()
                mem[10] = self._osc_floor(hs)
                info = np.zeros(4)
                if fast.oscillation_packed(yn, mem, info) != 0:
                    self._raise_status(OSCILLATION, t + hs, float(info[2]), y)
                y = yn
                self.nsteps += 1
                t = t_end if last else t + hs
                h = _accepted_step(ctl, float(en), float(hs), float(h), bool(last))
        finally:
            self.system.input_at = saved
        ctl[7] = h
        return self._accepted(y)


__all__ = ["ALPHA", "B", "B_HAT", "GAMMA", "GAMMA_IJ", "TABLEAU", "RosTableau", "Ros34PW2",
           "Ros34PW2Adaptive", "err_norm", "ros_tableau"]
