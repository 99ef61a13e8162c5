"""The compiled step of a four-stage Rosenbrock W-method on the O(n) operator
(:func:`_ros_step`), the scratch of a compiled run (:func:`_workspace`) and the fixed-step run
(:func:`_ros_fixed_run`).

The step runs in the transformed variables of :mod:`cable_sim.integrate.implicit.ros_tableau`
and takes the coefficients (``a_t``, ``c_t``, ``m_t``, ``e_t``, ``gamma`` of a
:class:`~cable_sim.integrate.implicit.ros_tableau.RosTableau`) as arguments, so ROS34PW2 and
ROS34PRw share it. For the cable, ``y = (q, v)``, ``f = (v, a(q, v))``,
``T = [[0, I], [-M^-1 K, -M^-1 D]]``, and a stage with right-hand side ``(rq, rv)`` is (as in
:class:`~cable_sim.integrate.implicit.schemes.Rosenbrock2`)
``sv = rv - M~^-1 (hg D rv + hg K (rq + hg rv))``, ``sq = rq + hg sv`` with
``M~ = M + hg D + hg^2 K``, ``hg = gamma h``: one factorisation (at the first stage, the drag
linearised at the predicted velocity ``v + h a`` when ``predict``) and one O(n) solve and one
force evaluation per stage.

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` (checks, forward, links)
and the sibling modules ``operator`` and ``run``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, STATUS_SINGULAR, check_packed_ws
from cable_sim.core.kernel.forward import fd_packed_ws, fd_trig
from cable_sim.core.kernel.links import link_trig
from cable_sim.integrate.implicit.operator import _dk_product, _op_solve
from cable_sim.integrate.implicit.run import _factor_at, factor_workspace

# --------------------------------------------------------------------------------------------
# Compiled step
# --------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _ros_step(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool, h: float, us: np.ndarray,
              es: np.ndarray, y: np.ndarray, yn: np.ndarray, err: np.ndarray, fs: tuple,
              sq: np.ndarray, sv: np.ndarray, wk: np.ndarray, at: np.ndarray, ct: np.ndarray,
              mt: np.ndarray, et: np.ndarray, gamma: float, trig_ready: bool = False) -> bool:
    """One step of h of the W-method with transformed coefficients ``at, ct, mt, et`` and
    diagonal ``gamma`` (ROS34PW2's or another's,
    :class:`~cable_sim.integrate.implicit.ros_tableau.RosTableau`) from y into ``yn`` and the
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
        _dk_product(arr, par, hg, W, W, rd, rk, rhs)
        _op_solve(arr, par, W, W, S, X, rhs, x)
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


__all__ = ["_ros_step", "_workspace", "_ros_fixed_run"]
