"""The compiled step of three-stage Radau IIA on the O(n) operator (:func:`_radau_step`) and its
fixed-step run with step halving where the stage equations do not converge
(:func:`_radau_fixed_run`).

The stage equations ``Z = h (A x I) F(y + Z)`` (``Z`` the three stage increments of
``y = (q, v)``) are solved by simplified Newton in the eigenbasis of ``A^-1`` (Hairer & Wanner
IV.8): with ``A^-1 = V diag(lambda) V^-1`` (one real eigenvalue ``lambda_1``, a complex pair
``lambda_2``, its conjugate), ``W = V^-1 Z`` and ``G = V^-1 F``, each iteration solves

    (I - hg_k T) dW_k = hg_k G_k - W_k,    hg_k = h / lambda_k,

for ``k = 1`` (real) and ``k = 2`` (complex; ``k = 3`` is its conjugate), then
``Z += V dW = v_1 dW_1 + 2 Re(v_2 dW_2)``. ``T`` is the W-methods' local operator
(:mod:`cable_sim.integrate.implicit`): a system ``(I - hg T) s = (rq, rv)`` is
``sv = rv - M~^-1 (hg D rv + hg K (rq + hg rv))``, ``sq = rq + hg sv`` with
``M~ = M + hg D + hg^2 K`` -- one O(n) solve with a real ``hg`` and one with a complex ``hg``
per iteration (the complex factorisation reads its geometry from the real one's workspace:
:func:`cable_sim.integrate.implicit.op_factor._op_factor_trig`). Both are factored once per
step, at the step's start, with the drag linearised at the predicted velocity ``v + h a``
(``predict``) and the seabed contact over the step. At an anchored end the solves add the
anchor's linearised Baumgarte stabilisation
(:func:`cable_sim.integrate.implicit.op_solve._op_solve_stabilised`): the stage states are off
the constraint, where the forward dynamics pull back at rates ``2 alpha``, ``beta^2`` that the
W-methods' operator leaves out.

Newton's increments are measured where the step's accuracy is judged, at the joints
(:func:`_add_increments`): the largest joint-position change over ``tol L`` (L the line's
length) and joint-velocity change over ``tol (L / 1 s + |v_j|)``, per stage. The iteration
stops when that times ``theta / (1 - theta)`` (its contraction rate, of the previous step in
the first iteration) is at most 1, and fails when the increments stop
shrinking or cannot reach that in ``maxit`` iterations (:func:`newton_verdict`). The
fixed-step run then redoes the step as two halves (each factored with its own h, so that the
drag is linearised at ``v + h_sub a``), down to ``h / 2^MAX_HALVINGS``; the halves' inputs come
from the cubic through the step's four input samples (at 0, c_1, c_2, 1). The first guess of
the stage increments extrapolates the previous step's collocation polynomial (the explicit
Euler increments after a failed attempt and at the start of a run; a call that continues
the previous call's run, from its final state, continues its guess and contraction estimate:
:func:`_radau_fixed_run`'s ``ws`` and ``carry``).

Integrate layer: imports numba, numpy, :mod:`cable_sim.core.kernel` (checks, forward, forward3,
links) and the sibling modules ``op_factor``, ``op_product``, ``op_solve``, ``run``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.checks import STATUS_OK, STATUS_SINGULAR, check_packed_ws
from cable_sim.core.kernel.forward import fd_packed_ws, fd_trig, fd_workspace
from cable_sim.core.kernel.forward3 import fd3_packed_ws
from cable_sim.core.kernel.links import link_trig
from cable_sim.integrate.implicit.op_factor import _op_factor_trig
from cable_sim.integrate.implicit.op_layout import _NS, _NW, _W_COS, _W_SIN
from cable_sim.integrate.implicit.op_product import _dk_product
from cable_sim.integrate.implicit.op_solve import _op_solve_stabilised, _op_solve_stabilised_pair
from cable_sim.integrate.implicit.run import _factor_at, factor_workspace

#: A step whose Newton iteration fails is halved at most this often (down to h / 4096).
MAX_HALVINGS = 12
#: Status of a fixed-step run whose stage equations did not converge even at h / 2^MAX_HALVINGS
#: (``info[2]``: the smallest substep tried).
STATUS_NEWTON = 101

# results of one step attempt
_STEP_OK, _STEP_NO_CONVERGENCE, _STEP_SINGULAR = 0, 1, 2
# verdicts of :func:`newton_verdict`
NEWTON_GO_ON, NEWTON_CONVERGED, NEWTON_FAILED = 0, 1, 2
#: A contraction this close to 1 counts as not converging.
THETA_MAX = 0.99


@nb.njit(cache=True)
def newton_verdict(it: int, big: float, prev: float, eta: float, maxit: int) -> tuple[int, float]:
    """Stopping rule of the simplified Newton iteration (Hairer & Wanner IV.8): after iteration
    ``it`` (from 0) whose scaled increment is ``big`` (the previous one ``prev``), with the
    contraction estimate ``eta = theta / (1 - theta)`` (of the previous step at ``it`` = 0):
    converged when ``eta big <= 1`` (the estimated distance to the solution within the
    tolerance); failed on a non-finite increment, on ``theta = big / prev >= THETA_MAX``, or
    when ``theta^(maxit - 1 - it) / (1 - theta) big > 1`` (the iterations left cannot reach the
    tolerance). Returns the verdict and the updated ``eta``."""
    if not np.isfinite(big):
        return NEWTON_FAILED, eta
    if it > 0:
        theta = big / prev
        if theta >= THETA_MAX:
            return NEWTON_FAILED, eta
        if theta ** (maxit - 1 - it) / (1.0 - theta) * big > 1.0:
            return NEWTON_FAILED, eta
        eta = theta / (1.0 - theta)
    if eta * big <= 1.0:
        return NEWTON_CONVERGED, eta
    if it == maxit - 1:
        return NEWTON_FAILED, eta
    return NEWTON_GO_ON, eta


@nb.njit(cache=True)
def radau_workspace(n: int) -> tuple:
    """Scratch of :func:`_radau_step` for n links: the real factorisation's
    (:func:`cable_sim.integrate.implicit.run.factor_workspace`), the complex one's ``Wc, Sc,
    Xc``, stage increments ``Zq, Zv`` (3, n+1), stage slopes ``Fq, Fv`` (3, n+1), real rows
    (10, n+1; row 8 holds the anchor reaction, row 9 the accelerations at the step's start),
    complex rows (5, n+1), the joint map of the Newton test (5, n+1; :func:`_joint_map`), the
    stage positions ``Yq`` (3, n+1) and the forward dynamics' workspaces of the first two stages
    (:func:`~cable_sim.core.kernel.forward.fd_workspace`; the third stage's is the real
    factorisation's, where its cos/sin stay for the next
    step: :func:`cable_sim.core.kernel.forward3.fd3_packed_ws`)."""
    n1 = n + 1
    return (factor_workspace(n), np.zeros((_NW, n), dtype=np.complex128),
            np.zeros(_NS, dtype=np.complex128), np.zeros((2, n1), dtype=np.complex128),
            np.zeros((3, n1)), np.zeros((3, n1)), np.zeros((3, n1)), np.zeros((3, n1)),
            np.zeros((10, max(n1, 2))), np.zeros((5, n1), dtype=np.complex128),
            np.zeros((5, n1)), np.zeros((3, n1)), (fd_workspace(n), fd_workspace(n)))


@nb.njit(cache=True, inline="always")
def _transformed_rhs(ti1: np.ndarray, ti2: np.ndarray, hg1: float, hg2: complex, Fq: np.ndarray,
                     Fv: np.ndarray, Zq: np.ndarray, Zv: np.ndarray, rq: np.ndarray,
                     rv: np.ndarray, crq: np.ndarray, crv: np.ndarray) -> None:
    """The real and the complex transformed systems' right-hand sides ``hg_k (V^-1 F)_k -
    (V^-1 Z)_k`` (``ti1``, ``ti2``: rows 1 and 2 of ``V^-1``, real and complex) into ``rq, rv``
    and ``crq, crv``, in one pass as ``(hg_k t_k) . F - t_k . Z`` (equal to round-off): the
    complex rows' products with the real F and Z in real arithmetic, two products per entry
    (a complex row times a real entry promoted to complex costs four)."""
    a0, a1, a2 = hg1 * ti1[0], hg1 * ti1[1], hg1 * ti1[2]
    t0, t1, t2 = ti1[0], ti1[1], ti1[2]
    c0, c1, c2 = hg2 * ti2[0], hg2 * ti2[1], hg2 * ti2[2]
    cr0, cr1, cr2 = c0.real, c1.real, c2.real
    ci0, ci1, ci2 = c0.imag, c1.imag, c2.imag
    tr0, tr1, tr2 = ti2[0].real, ti2[1].real, ti2[2].real
    tm0, tm1, tm2 = ti2[0].imag, ti2[1].imag, ti2[2].imag
    for j in range(rq.shape[0]):
        f0, f1, f2 = Fq[0, j], Fq[1, j], Fq[2, j]
        z0, z1, z2 = Zq[0, j], Zq[1, j], Zq[2, j]
        g0, g1, g2 = Fv[0, j], Fv[1, j], Fv[2, j]
        w0, w1, w2 = Zv[0, j], Zv[1, j], Zv[2, j]
        rq[j] = (a0 * f0 + a1 * f1 + a2 * f2) - (t0 * z0 + t1 * z1 + t2 * z2)
        rv[j] = (a0 * g0 + a1 * g1 + a2 * g2) - (t0 * w0 + t1 * w1 + t2 * w2)
        crq[j] = complex((cr0 * f0 + cr1 * f1 + cr2 * f2) - (tr0 * z0 + tr1 * z1 + tr2 * z2),
                         (ci0 * f0 + ci1 * f1 + ci2 * f2) - (tm0 * z0 + tm1 * z1 + tm2 * z2))
        crv[j] = complex((cr0 * g0 + cr1 * g1 + cr2 * g2) - (tr0 * w0 + tr1 * w1 + tr2 * w2),
                         (ci0 * g0 + ci1 * g1 + ci2 * g2) - (tm0 * w0 + tm1 * w1 + tm2 * w2))


@nb.njit(cache=True, inline="always")
def _solve_shifted(arr: np.ndarray, par: np.ndarray, hg: complex, G: np.ndarray, W: np.ndarray,
                   S: np.ndarray, X: np.ndarray, rq: np.ndarray, rv: np.ndarray, rk: np.ndarray,
                   rhs: np.ndarray, x: np.ndarray) -> None:
    """``(I - hg T) s = (rq, rv)`` in place (``rv`` becomes ``sv``, ``rq`` becomes ``sq``) with a
    factorisation W, S, X at ``hg``: real (``G is W``) or complex (``G``: the real
    factorisation's geometry rows; compiled once per kind). At an anchored end ``T`` includes
    the anchor's Baumgarte stabilisation (:func:`_op_solve_stabilised`)."""
    n1 = rq.shape[0]
    for j in range(n1):
        rk[j] = rq[j] + hg * rv[j]
    _dk_product(arr, par, hg, G, W, rv, rk, rhs)
    _op_solve_stabilised(arr, par, hg, G, W, S, X, rhs, x, rv, rk)
    for j in range(n1):
        rv[j] = rv[j] - x[j]
        rq[j] = rq[j] + hg * rv[j]


@nb.njit(cache=True, inline="always")
def _solve_shifted_pair(arr: np.ndarray, par: np.ndarray, hg: float, hgc: complex, W: np.ndarray,
                        S: np.ndarray, X: np.ndarray, rq: np.ndarray, rv: np.ndarray,
                        rk: np.ndarray, rhs: np.ndarray, x: np.ndarray, Wc: np.ndarray,
                        Sc: np.ndarray, Xc: np.ndarray, crq: np.ndarray, crv: np.ndarray,
                        crk: np.ndarray, crhs: np.ndarray, cx: np.ndarray) -> None:
    """:func:`_solve_shifted` of the real system (``hg``, factorisation W, S, X) and the complex
    one (``hgc``, Wc, Sc, Xc, at W's geometry) of a Newton iteration, their O(n) sweeps side by
    side (:func:`cable_sim.integrate.implicit.op_solve._op_solve_stabilised_pair`): each sweep
    is a chain of dependent operations per link, and two independent chains in one loop keep
    more of the core busy than one after the other. Equal to the two calls to round-off."""
    n1 = rq.shape[0]
    for j in range(n1):
        rk[j] = rq[j] + hg * rv[j]
        crk[j] = crq[j] + hgc * crv[j]
    _dk_product(arr, par, hg, W, W, rv, rk, rhs)
    _dk_product(arr, par, hgc, W, Wc, crv, crk, crhs)
    _op_solve_stabilised_pair(arr, par, hg, hgc, W, W, S, X, rhs, x, rv, rk, Wc, Sc, Xc, crhs,
                              cx, crv, crk)
    for j in range(n1):
        rv[j] = rv[j] - x[j]
        rq[j] = rq[j] + hg * rv[j]
        crv[j] = crv[j] - cx[j]
        crq[j] = crq[j] + hgc * crv[j]


@nb.njit(cache=True, inline="always")
def _joint_map(l: np.ndarray, v: np.ndarray, cth: np.ndarray, sth: np.ndarray, tol: float,
               length: float, jm: np.ndarray) -> float:
    """What the Newton test of a step needs to map an increment of (q, v) to the joints,
    linearised at the step's start (links' cos/sin ``cth, sth``, velocities ``v``), into ``jm``:
    rows 0, 1 per link ``l c``, ``l s``; rows 2, 3 ``l c w``, ``l s w`` (``w`` its angular
    velocity); row 4 per joint ``1 / (tol (L + |v_j|))`` with L = ``length``, the line's length
    (read as m/s here), and ``|v_j|`` the joint velocity's largest component. Returns
    ``1 / (tol L)``."""
    vx = 0.0
    vz = v[0]
    jm[4, 0] = 1.0 / (tol * (length + abs(vz)))
    for k in range(l.shape[0]):
        w = v[k + 1]
        lc = l[k] * cth[k]
        ls = l[k] * sth[k]
        jm[0, k] = lc
        jm[1, k] = ls
        jm[2, k] = lc * w
        jm[3, k] = ls * w
        vx += lc * w
        vz += ls * w
        jm[4, k + 1] = 1.0 / (tol * (length + max(abs(vx), abs(vz))))
    return 1.0 / (tol * length)


@nb.njit(cache=True, inline="always")
def _joint_change(dq: float, dv: float, lc: float, ls: float, lcw: float, lsw: float, px: float,
                  pz: float, vx: float, vz: float) -> tuple[float, float, float, float]:
    """The running sums of one stage's joint changes (position x, z; velocity x, z) past a link
    whose angle and angular velocity change by ``dq``, ``dv`` (``lc, ls, lcw, lsw``: its column
    of :func:`_joint_map`)."""
    return (px + lc * dq, pz + ls * dq, vx + (lc * dv - lsw * dq), vz + (ls * dv + lcw * dq))


@nb.njit(cache=True, inline="always")
def _add_increments(Zq: np.ndarray, Zv: np.ndarray, v1: np.ndarray, v2: np.ndarray,
                    rq: np.ndarray, rv: np.ndarray, crq: np.ndarray, crv: np.ndarray,
                    jm: np.ndarray, inv_pos: float) -> float:
    """Add the Newton increments ``Z_i += v1_i dW_1 + 2 Re(v2_i dW_2)`` of the three stages
    (``dW_1 = (rq, rv)``, ``dW_2 = (crq, crv)``) and return their largest size at the joints
    (``jm``, ``inv_pos``: :func:`_joint_map`): the largest joint-position component of a stage's
    change times ``inv_pos`` and joint-velocity component times ``jm[4, j]``, the joints' changes
    summed along the line as the error norm sums an error
    (:func:`cable_sim.integrate.step_control.err_norm_ws`). A change of one link's angle moves
    the joints by its length times the change, so on a finely divided line a local correction
    (a kink running down the line) counts for what it moves, not as a whole radian.

    The three stages in one pass: their running sums are independent chains side by side."""
    a0, a1, a2 = v1[0], v1[1], v1[2]
    br0, br1, br2 = 2.0 * v2[0].real, 2.0 * v2[1].real, 2.0 * v2[2].real
    bi0, bi1, bi2 = 2.0 * v2[0].imag, 2.0 * v2[1].imag, 2.0 * v2[2].imag
    # the platform (j = 0): its heave moves every joint alike
    q, v = rq[0], rv[0]
    cqr, cqi, cvr, cvi = crq[0].real, crq[0].imag, crv[0].real, crv[0].imag
    pz0 = a0 * q + (br0 * cqr - bi0 * cqi)
    pz1 = a1 * q + (br1 * cqr - bi1 * cqi)
    pz2 = a2 * q + (br2 * cqr - bi2 * cqi)
    vz0 = a0 * v + (br0 * cvr - bi0 * cvi)
    vz1 = a1 * v + (br1 * cvr - bi1 * cvi)
    vz2 = a2 * v + (br2 * cvr - bi2 * cvi)
    Zq[0, 0] += pz0
    Zq[1, 0] += pz1
    Zq[2, 0] += pz2
    Zv[0, 0] += vz0
    Zv[1, 0] += vz1
    Zv[2, 0] += vz2
    px0 = px1 = px2 = vx0 = vx1 = vx2 = 0.0
    big = max(max(abs(pz0), abs(pz1), abs(pz2)) * inv_pos,
              max(abs(vz0), abs(vz1), abs(vz2)) * jm[4, 0])
    for j in range(1, Zq.shape[1]):
        k = j - 1
        lc, ls, lcw, lsw = jm[0, k], jm[1, k], jm[2, k], jm[3, k]
        q, v = rq[j], rv[j]
        cqr, cqi, cvr, cvi = crq[j].real, crq[j].imag, crv[j].real, crv[j].imag
        dq = a0 * q + (br0 * cqr - bi0 * cqi)
        dv = a0 * v + (br0 * cvr - bi0 * cvi)
        Zq[0, j] += dq
        Zv[0, j] += dv
        px0, pz0, vx0, vz0 = _joint_change(dq, dv, lc, ls, lcw, lsw, px0, pz0, vx0, vz0)
        dq = a1 * q + (br1 * cqr - bi1 * cqi)
        dv = a1 * v + (br1 * cvr - bi1 * cvi)
        Zq[1, j] += dq
        Zv[1, j] += dv
        px1, pz1, vx1, vz1 = _joint_change(dq, dv, lc, ls, lcw, lsw, px1, pz1, vx1, vz1)
        dq = a2 * q + (br2 * cqr - bi2 * cqi)
        dv = a2 * v + (br2 * cvr - bi2 * cvi)
        Zq[2, j] += dq
        Zv[2, j] += dv
        px2, pz2, vx2, vz2 = _joint_change(dq, dv, lc, ls, lcw, lsw, px2, pz2, vx2, vz2)
        pos = max(max(abs(px0), abs(pz0)), max(abs(px1), abs(pz1)), max(abs(px2), abs(pz2)))
        vel = max(max(abs(vx0), abs(vz0)), max(abs(vx1), abs(vz1)), max(abs(vx2), abs(vz2)))
        big = max(big, pos * inv_pos, vel * jm[4, j])
    return big


@nb.njit(cache=True)
def _radau_step(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool, h: float,
                us: np.ndarray, es: np.ndarray, y: np.ndarray, yn: np.ndarray, ws: tuple,
                lam1: float, lam2: complex, ti1: np.ndarray, ti2: np.ndarray, v1: np.ndarray,
                v2: np.ndarray, offsets: np.ndarray, tol: float, maxit: int, info: np.ndarray,
                ratio: float, newton: np.ndarray, slope_ready: bool = False) -> int:
    """One Radau IIA step of h from y into ``yn`` (``2(n+1)``); ``us[0], es[0]``: the inputs at
    the step's start, ``us[1 + i], es[1 + i]`` at stage i. ``lam1, lam2``: the real and one
    complex eigenvalue of ``A^-1``; ``ti1, ti2``: the matching rows of ``V^-1``; ``v1, v2``:
    the columns of ``V``; ``offsets``: 0 and the stage times (fractions of h). ``ratio`` > 0: the
    stage increments in ``ws`` are those of the previous step, which ended at y and was
    ``ratio`` times as long; the initial guess extrapolates its collocation polynomial
    (Hairer & Wanner IV.8). Otherwise (0) the guess is the explicit Euler increments.
    ``newton[0]``: the contraction estimate ``eta`` of the last converged iteration (updated;
    :func:`newton_verdict`). ``slope_ready``: y is the end of the previous step, converged
    in ``ws``, and the links' cos/sin at y are in the forward dynamics' workspace; its last
    stage's slope (at y to within the Newton tolerance) then stands in for the accelerations
    at y, which only the iteration matrix, the drag's predicted velocity and the first guess
    use (one force evaluation fewer per step). On return the factorisations, the stage
    increments and (row 9 of the real rows) the accelerations at y stay in ``ws`` for the
    error estimate of :mod:`cable_sim.integrate.implicit.radau_adaptive` (which evaluates them
    afresh). Returns ``_STEP_OK``,
    ``_STEP_NO_CONVERGENCE`` or ``_STEP_SINGULAR``; ``info[0]`` counts the force evaluations,
    ``info[3]`` the Newton iterations (``info`` as in :func:`_radau_fixed_run`)."""
    n1 = y.shape[0] // 2
    fs, Wc, Sc, Xc, Zq, Zv, Fq, Fv, wk, cw, jm, Yq, fw2 = ws
    fw, jw, F, kgeo, W, S, X = fs
    acc = wk[0]
    vp = wk[1]
    rhs = wk[2]
    x = wk[3]
    rq = wk[4]
    rv = wk[5]
    rk = wk[6]
    lam = wk[8, :2]
    q = y[:n1]
    v = y[n1:]
    if slope_ready:
        for j in range(n1):
            acc[j] = Fv[2, j]
    else:
        if not fd_packed_ws(arr, par, us[0], es[0], q, v, acc, lam, fw):
            return _STEP_SINGULAR
        info[0] += 1
    acc0 = wk[9]  # kept for the error estimate (radau_adaptive)
    for j in range(n1):
        vp[j] = v[j] + h * acc[j] if predict else v[j]
        acc0[j] = acc[j]
    hg1 = h / lam1
    hg2 = h / lam2
    if not _factor_at(arr, par, geometric, hg1, q, v, acc, lam, vp, fw, jw, F, kgeo, W, S, X, h):
        return _STEP_SINGULAR
    if not _op_factor_trig(arr, par, q, vp, hg2, kgeo, W, Wc, Sc, Xc, h):
        return _STEP_SINGULAR
    inv_pos = _joint_map(arr[0], v, W[_W_COS], W[_W_SIN], tol, par[16], jm)  # par[16]: length
    if ratio > 0.0:
        _extrapolate(Zq, Zv, offsets, 1.0 / ratio)
    else:  # the explicit Euler increments to each stage time
        for i in range(3):
            c = offsets[i + 1] * h
            for j in range(n1):
                Zq[i, j] = c * v[j]
                Zv[i, j] = c * acc[j]
    crq = cw[0]
    crv = cw[1]
    crk = cw[2]
    crhs = cw[3]
    cx = cw[4]
    prev = 0.0
    # the previous step's contraction, moved towards 1 (Hairer's RADAU5: eta^0.8)
    eta = max(newton[0], 1e-16) ** 0.8
    for it in range(maxit):
        info[3] += 1
        for i in range(3):  # the stage slopes: (v + Zv_i, the accelerations there)
            for j in range(n1):
                Yq[i, j] = q[j] + Zq[i, j]
                Fq[i, j] = v[j] + Zv[i, j]
        # the three stages' forward dynamics side by side (the last stage's in fw)
        if not fd3_packed_ws(arr, par, us[1:], es[1:], Yq, Fq, Fv, lam, fw2[0], fw2[1], fw):
            return _STEP_NO_CONVERGENCE  # a stage state the dynamics cannot take: not a fix
        info[0] += 3
        # the real and the complex transformed systems' right-hand sides hg G - W
        _transformed_rhs(ti1, ti2, hg1, hg2, Fq, Fv, Zq, Zv, rq, rv, crq, crv)
        _solve_shifted_pair(arr, par, hg1, hg2, W, S, X, rq, rv, rk, rhs, x, Wc, Sc, Xc, crq,
                            crv, crk, crhs, cx)
        # Z += V dW: v1 dW1 + 2 Re(v2 dW2), and the increment's scaled size at the joints
        big = _add_increments(Zq, Zv, v1, v2, rq, rv, crq, crv, jm, inv_pos)
        verdict, eta = newton_verdict(it, big, prev, eta, maxit)
        if verdict == NEWTON_CONVERGED:
            newton[0] = eta
            for j in range(n1):
                yn[j] = q[j] + Zq[2, j]  # stiffly accurate: the last stage is the solution
                yn[n1 + j] = v[j] + Zv[2, j]
            return _STEP_OK
        if verdict == NEWTON_FAILED:
            return _STEP_NO_CONVERGENCE
        prev = big
    return _STEP_NO_CONVERGENCE


@nb.njit(cache=True, inline="always")
def _lagrange_weight(s: float, nodes: np.ndarray, k: int) -> float:
    """The Lagrange basis polynomial of node k of the four ``nodes`` at s."""
    w = 1.0
    for m in range(4):
        if m != k:
            w *= (s - nodes[m]) / (nodes[k] - nodes[m])
    return w


@nb.njit(cache=True, inline="always")
def _extrapolate(Zq: np.ndarray, Zv: np.ndarray, offsets: np.ndarray, r: float) -> None:
    """The previous step's collocation polynomial (through 0 and its stage increments ``Z_i`` at
    ``c_i``, in units of its step; ``offsets`` = (0, c_1, c_2, c_3)) at the new step's stage
    times ``1 + r c_j`` (``r``: new step / old step), less its end value ``Z_3``: the new stages'
    increments from the new state, in place."""
    lag = np.empty((3, 3))  # lag[j, i]: the Lagrange weight of old stage i at new stage j
    for j in range(3):
        for i in range(3):
            lag[j, i] = _lagrange_weight(1.0 + r * offsets[j + 1], offsets, i + 1)
    for k in range(Zq.shape[1]):
        a0, a1, a2 = Zq[0, k], Zq[1, k], Zq[2, k]
        b0, b1, b2 = Zv[0, k], Zv[1, k], Zv[2, k]
        for j in range(3):
            Zq[j, k] = lag[j, 0] * a0 + lag[j, 1] * a1 + lag[j, 2] * a2 - a2
            Zv[j, k] = lag[j, 0] * b0 + lag[j, 1] * b1 + lag[j, 2] * b2 - b2


@nb.njit(cache=True, inline="always")
def _cubic_input(s: float, nodes: np.ndarray, vals: np.ndarray) -> float:
    """The cubic through ``(nodes[k], vals[k])``, k = 0..3, at s (Lagrange form)."""
    out = 0.0
    for k in range(4):
        out += _lagrange_weight(s, nodes, k) * vals[k]
    return out


@nb.njit(cache=True)
def _radau_fixed_run(arr: np.ndarray, par: np.ndarray, geometric: bool, predict: bool, h: float,
                     u: np.ndarray, eta: np.ndarray, y: np.ndarray, chk: np.ndarray,
                     info: np.ndarray, lam1: float, lam2: complex, ti1: np.ndarray,
                     ti2: np.ndarray, v1: np.ndarray, v2: np.ndarray, offsets: np.ndarray,
                     tol: float, maxit: int, ws: tuple, carry: np.ndarray) -> int:
    """``u.shape[0]`` checked steps of h, in place on y (``u[k], eta[k]``: the inputs at
    ``offsets`` = (0, c_1, c_2, 1) of step k). A step whose Newton iteration fails is redone
    in halves (see the module docstring); the check runs at the end of each step of h. On
    failure ``y`` keeps the last good state, ``info[1]`` is the failed step's index;
    ``STATUS_NEWTON`` with the smallest substep tried in ``info[2]``. ``info`` has five entries:
    ``info[0]`` counts the force evaluations, ``info[3]`` the Newton iterations and ``info[4]``
    the failed attempts.

    ``ws`` (:func:`radau_workspace` for n links) and ``carry`` (``[hprev, eta]``) are what one
    step hands the next, updated in place: ``hprev`` the last accepted (sub)step, whose stage
    increments, last stage slope and end state's link cos/sin are in ``ws`` (0: none; the
    first guess is then the explicit Euler increments), ``eta`` the Newton contraction
    estimate (1 to start). A caller whose next call continues from this call's final y (bit
    for bit, same h) passes both back unchanged, so that a run split into calls takes the
    same steps as one call; otherwise a fresh workspace and ``[0, 1]``."""
    n = arr.shape[1]
    n1 = n + 1
    cth, sth = fd_trig(ws[0][0], n)
    full = 1 << MAX_HALVINGS  # a step of h in units of its smallest substep
    ys = np.empty(2 * n1)
    yn = np.empty(2 * n1)
    us = np.empty(4)
    es = np.empty(4)
    hprev = carry[0]  # the last accepted (sub)step, whose stages are in ws; 0: none usable
    newton = carry[1:2]  # the contraction estimate eta carried from step to step (a view)
    for k in range(u.shape[0]):
        info[1] = k
        for j in range(2 * n1):
            ys[j] = y[j]
        done = 0
        size = full
        while done < full:
            hs = h * size / full
            if size == full:
                us[:] = u[k]
                es[:] = eta[k]
            else:
                for i in range(4):
                    s = (done + offsets[i] * size) / full
                    us[i] = _cubic_input(s, offsets, u[k])
                    es[i] = _cubic_input(s, offsets, eta[k])
            ratio = hprev / hs if hprev > 0.0 else 0.0
            # after an accepted (sub)step its last stage's slope serves as the one at ys
            # (the check below leaves the links' cos/sin at ys in the workspace, and so does
            # the last stage's force evaluation between substeps, to the Newton tolerance)
            res = _radau_step(arr, par, geometric, predict, hs, us, es, ys, yn, ws, lam1, lam2,
                              ti1, ti2, v1, v2, offsets, tol, maxit, info, ratio, newton,
                              hprev > 0.0)
            if res == _STEP_SINGULAR:
                carry[0] = 0.0
                return STATUS_SINGULAR
            if res == _STEP_OK:
                for j in range(2 * n1):
                    ys[j] = yn[j]
                done += size
                hprev = hs
                size = min(2 * size, full - done)  # back towards h after a halving
            else:
                info[4] += 1
                hprev = 0.0  # the failed attempt overwrote the stages
                if size == 1:
                    info[2] = hs
                    carry[0] = 0.0
                    return STATUS_NEWTON
                size //= 2
        if par[10] == 0.0:  # (anchored: the check's projection recomputes them)
            link_trig(ys, cth, sth)
        status = check_packed_ws(arr, par, ys, chk, info, cth, sth)
        if status != STATUS_OK:
            carry[0] = 0.0
            return status
        y[:] = ys
    carry[0] = hprev
    return STATUS_OK


__all__ = ["MAX_HALVINGS", "NEWTON_CONVERGED", "NEWTON_FAILED", "NEWTON_GO_ON", "STATUS_NEWTON",
           "THETA_MAX", "newton_verdict", "radau_workspace", "_radau_step", "_radau_fixed_run"]
