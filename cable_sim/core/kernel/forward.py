"""O(n) compiled forward dynamics of the n-link cable (same contract as :mod:`cable_sim.core.dynamics`).

The dense reference builds ``M(q)`` and factors it (O(n^3)). This module solves the same
equations of motion in O(n) per call with an articulated-body recursion specialised to the
planar chain of ``MODEL.md``:

* the base is the platform, a point mass ``M`` on a vertical prismatic joint (``z_m``);
* link i hangs from a pin at joint ``p_{i-1}``; a pin transmits no moment besides the joint
  spring/damper torque, so the articulated inertia seen *at a pin* is a 2x2 matrix ``A_i``
  relating the force the parent exerts on the subtree to the acceleration of the pin:
  ``f_i = A_i a_{i-1} + b_i``;
* the terminal load is a point mass at ``p_n`` (``A_{n+1} = m_c I``; but see "heavy load").

Backward sweep (tip to platform), for link i with centre of mass at mid-length, unit axis
``e_i = (sin theta_i, -cos theta_i)`` and ``t_i = (cos theta_i, sin theta_i)`` (note
``e x u = t . u`` in the x-z plane), from each link's Newton equation and its moment equation
about ``p_{i-1}``::

    D_i = m l^2/3 + l^2 t^T A t          h_i = l A t + (m l / 2) t
    R_i = -tau_i + tau_{i+1} + C_i + (l/2) t.G_i + l^2 w^2 t^T A e - l t.b
    A_i = m I + A - h h^T / D            b_i = b - G_i - w^2 (m l/2 e + l A e) + h R / D

(``A``, ``b`` of link i+1; ``G_i`` the weight-minus-buoyancy plus Morison drag on the centre,
``C_i`` the paper drag couple, ``tau_i = k_i phi_i + c_i phi_dot_i`` the joint torque on the
relative angle). Forward sweep: the platform ``(M + A_1,zz) zdd = Q_0 - b_1,z`` (or ``zdd = 0``
when heave-locked), then ``theta_dd_i = (R_i - h_i . a_{i-1}) / D_i`` and
``a_i = a_{i-1} + l (t theta_dd_i - e w^2)``. The recursion yields the *absolute* angle
accelerations directly.

Anchored end: the exact constraint ``p_n = anchor`` is enforced by the Schur complement. The
articulated inertias do not depend on the applied forces, so the inward sweep also carries two
extra right-hand sides (a unit force at ``p_n`` along x and z with zero velocity and gravity).
Their outward solutions are not needed: the outward sweep is affine, ``a_i = P_i a_(i-1) + v_i``,
and an end force travels inwards by ``P_i^T``, so the inward sweep sums ``J X = J M^-1 J^T`` and
the applied forces' end acceleration ``a_end,0 = J qdd_free + (dJ/dt) qd`` as it goes
(:func:`cable_sim.core.kernel.sweeps.inward_sweep_ws`, :func:`end_correction_terms`). Then
``lambda = (J X)^-1 (gamma - J qdd_free)`` with the dense solver's Baumgarte ``gamma``
(:func:`end_force`), and one outward sweep of the applied forces plus ``lambda`` at the end
gives ``qdd`` (measured at n = 640 on the anchored paper scene: 13-15 us a call, against 19-21
us with the two unit-force outward sweeps and the column update it replaces).

Heavy load (the paper's 8e8 kg anchor emulation, or any load heavier than the line): putting
``m_c I`` into the recursion makes the articulated inertias m_c-sized while the physics lives in
their differences, costing ~m_c/m_link of the precision. Instead the load's inertia ``m_c J^T J``
is added by Woodbury with the same sums: ``qdd = qdd_s + X f``,
``f = -(J X + I/m_c)^-1 a_end,s`` (subscript s: the line with a massless load that keeps its
weight), ``X f`` again by the one outward sweep. This is exact algebra and leaves every
intermediate quantity of the line's own scale; measured against a 40-digit solve it is accurate
to ~1e-15, whereas the dense float64 Cholesky of the ill-conditioned M is off by up to ~1e-6 at
n = 60.

Round-2 terms (MODEL.md; off unless the model switches them on): the seabed contact of each link
(:mod:`cable_sim.core.kernel.contact`) enters like its drag, as a force at the centre plus a
couple; the Morison added mass as a per-link anisotropic inertia in the inward sweep (mass
m + m_an l along the link normal, m + m_at l along its axis: ``mn``, ``me``).

All kernels take plain arrays and floats (numba cannot take the dataclass) and are compiled
with ``cache=True``; call :func:`warmup` once before real time starts.

Core layer, compiled kernel: imports numba, numpy, :mod:`cable_sim.core.kernel.sweeps`,
:mod:`cable_sim.core.kernel.links`, :mod:`cable_sim.core.kernel.anchor` (``end_position``),
:mod:`cable_sim.core.kernel.contact`,
:mod:`cable_sim.core.kernel.packing` and the core's
``dynamics`` (``Inputs``) and ``model``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.dynamics import NO_INPUT, Inputs
from cable_sim.core.kernel.anchor import end_position
from cable_sim.core.kernel.contact import seabed_links_nb
from cable_sim.core.kernel.jit import HOT_KERNEL
from cable_sim.core.kernel.links import (
    joint_torques,
    link_trig,
    morison_drag,
)
from cable_sim.core.kernel.packing import ARR_MK, pack_arrays, vec
from cable_sim.core.kernel.sweeps import (
    _S_LC,
    _S_LS,
    _S_RD,
    MK_ROWS,
    SW_ROWS,
    inward_sweep_ws,
    outward_sweep_bias,
    singular_2x2,
    solve_2x2,
)
from cable_sim.core.model import CableModel

# ---- the steps of the forward dynamics ---------------------------------------------------------


@nb.njit(cache=True, inline="always")
def applied_link_forces(
    l: np.ndarray, mw: np.ndarray, gl2: np.ndarray, cn: np.ndarray, ct: np.ndarray,
    current: float, drag: int, g: float, qd: np.ndarray, cth: np.ndarray, sth: np.ndarray,
    fgx: np.ndarray, fgz: np.ndarray, cpl: np.ndarray, pvx: np.ndarray, pvz: np.ndarray,
) -> None:
    """Force on each link centre (weight - buoyancy + Morison drag) into ``fgx, fgz`` and couple
    (paper drag) into ``cpl`` (all overwritten); ``pvx, pvz``: scratch of n entries (the
    Morison drag's pin velocities, :func:`cable_sim.core.kernel.links.morison_drag`)."""
    n = l.shape[0]
    for i in range(n):
        fgx[i] = 0.0
        fgz[i] = -mw[i] * g
        cpl[i] = 0.0
    if drag == 1:
        for i in range(n):
            w = qd[i + 1]
            cpl[i] = -gl2[i] * w * abs(w)
    elif drag == 2:
        morison_drag(l, cn, ct, current, qd, cth, sth, fgx, fgz, pvx, pvz)


@nb.njit(cache=True, inline="always")
def add_seabed_loads(
    l: np.ndarray, zb: float, kb: np.ndarray, cb: np.ndarray, mua: np.ndarray, mut: np.ndarray,
    vc: float, q: np.ndarray, qd: np.ndarray, cth: np.ndarray, sth: np.ndarray, fgx: np.ndarray,
    fgz: np.ndarray, cpl: np.ndarray, F: np.ndarray, S: np.ndarray,
) -> None:
    """Seabed contact on each link (exact over its length, :mod:`cable_sim.core.kernel.contact`)
    as a force at the centre plus a couple: resultant F and first moment S about the upper pin
    (scratch arrays (n, 2), overwritten) give ``fg += F`` and ``cpl += t . (S - l/2 F)`` (so
    that the link's own generalised force is t . S, like the per-link drag force)."""
    n = l.shape[0]
    seabed_links_nb(l, zb, kb, cb, mua, mut, vc, q, qd, cth, sth, F, S)
    for i in range(n):
        fgx[i] += F[i, 0]
        fgz[i] += F[i, 1]
        hl = 0.5 * l[i]
        cpl[i] += cth[i] * (S[i, 0] - hl * F[i, 0]) + sth[i] * (S[i, 1] - hl * F[i, 1])


@nb.njit(cache=True, inline="always")
def end_velocity(lc: np.ndarray, ls: np.ndarray, qd: np.ndarray) -> tuple[float, float]:
    """Velocity ``J qd`` of the line's end ``p_n`` from the links' ``l t = (lc, ls)`` (the
    inward sweep's scratch rows; sums without a carried dependence between links)."""
    vx = 0.0
    vz = qd[0]
    for i in range(lc.shape[0]):
        vx += lc[i] * qd[i + 1]
        vz += ls[i] * qd[i + 1]
    return vx, vz


@nb.njit(cache=True, inline="always")
def end_correction_terms(endm: np.ndarray, bz: np.ndarray, zdd: np.ndarray) -> tuple:
    """``J M^-1 J^T`` (entries 00, 01, 11) and the applied forces' end acceleration
    ``a_end,0`` (x, z) from the inward sweep's end-correction sums ``endm``
    (:func:`cable_sim.core.kernel.sweeps.inward_sweep_ws`) plus the platform's share: a
    platform acceleration ``zdd_k`` moves the end by ``(Psi_0^T e_j)_z zdd_k = -bz[j] zdd_k``
    (``bz[1:3]``: the unit forces' end forces carried to the platform; ``zdd[0:3]``: the
    platform accelerations of the three right-hand sides, zero when heave-locked)."""
    g00 = endm[0] - bz[1] * zdd[1]
    g01 = endm[1] - bz[1] * zdd[2]
    g11 = endm[2] - bz[2] * zdd[2]
    ax = endm[3] - bz[1] * zdd[0]
    az = endm[4] - bz[2] * zdd[0]
    return g00, g01, g11, ax, az


@nb.njit(cache=True, inline="always")
def end_force(
    heavy: bool, mc: float, g00: float, g01: float, g11: float, aex: float, aez: float,
    ax: float, az: float, balpha: float, bbeta: float, vx: float, vz: float, px: float,
    pz: float,
) -> tuple[bool, float, float]:
    """The force f on the line's end that the correction adds, ``qdd = qdd_0 + M^-1 J^T f``
    (``G = J M^-1 J^T``, ``a_end,0`` = ``(aex, aez)``):

    * heavy load (Woodbury): ``(G + I/m_c) f = -a_end,0`` (f: the load's inertial force);
    * anchored end (Schur): ``G f = gamma - J qdd_0`` with the dense solver's Baumgarte
      ``gamma``, i.e. ``-a_end,0 - 2 alpha v_end - beta^2 (p_end - anchor)`` (``a_end,0``
      includes the centripetal terms ``dJ/dt qd``).

    Returns ``(ok, fx, fz)``; ``ok`` False if the anchored end's G is singular to working
    precision (e.g. one link on a heave-locked platform: 1 dof, 2 constraints).
    """
    if heavy:
        eps = 1.0 / mc
        fx, fz = solve_2x2(g00 + eps, g01, g01, g11 + eps, -aex, -aez)
        return True, fx, fz
    rx = -aex - 2.0 * balpha * vx - bbeta * bbeta * (px - ax)
    rz = -aez - 2.0 * balpha * vz - bbeta * bbeta * (pz - az)
    if singular_2x2(g00, g01, g01, g11):
        return False, 0.0, 0.0
    fx, fz = solve_2x2(g00, g01, g01, g11, rx, rz)
    return True, fx, fz


# ---- workspace -------------------------------------------------------------------------------

# rows of the forward-dynamics workspace (FD_ROWS x max(n + 1, 5)): link cos/sin, joint torques,
# applied centre forces and couples, the sweep's 1/D, h and R (three right-hand sides), the
# right-hand sides' end forces, the end-correction sums (5 entries) and the three platform
# accelerations, four rows holding the seabed's per-link resultants and first moments ((n, 2)
# each), the Morison drag's pin velocities (x, z), and the inward sweep's scratch
# (:data:`cable_sim.core.kernel.sweeps.SW_ROWS` rows)
(_F_COS, _F_SIN, _F_TAU, _F_FGX, _F_FGZ, _F_CPL, _F_DD, _F_HX, _F_HZ, _F_RR, _F_BX, _F_BZ,
 _F_ENDM, _F_ZDD, _F_BED, _F_PVX, _F_PVZ, _F_SW) = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 14, 15,
                                                   16, 20, 21, 22)
#: Rows of the forward-dynamics workspace (:func:`fd_workspace`).
FD_ROWS = _F_SW + SW_ROWS


@nb.njit(cache=True)
def fd_workspace(n: int) -> np.ndarray:
    """Scratch of :func:`fd_packed_ws` for n links, shape ``(FD_ROWS, max(n + 1, 5))``.

    It carries nothing from one call to the next (every entry read is written first in the
    same call), so one workspace serves any number of calls, states and models of n links.
    """
    return np.empty((FD_ROWS, max(n + 1, 5)))


@nb.njit(cache=True, inline="always")
def fd_trig(ws: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The cos/sin of the n links' angles left in a workspace by the last
    :func:`fd_packed_ws` call with it (views, length n), for reuse at the same q."""
    return ws[_F_COS, :n], ws[_F_SIN, :n]


@nb.njit(cache=True, inline="always")
def applied_generalised_forces(arr: np.ndarray, par: np.ndarray, q: np.ndarray, qd: np.ndarray,
                               ws: np.ndarray, trig_ready: bool) -> None:
    """The first steps of :func:`fd_packed_ws` into its workspace ``ws``: the links' cos/sin
    (unless ``trig_ready``), the joint torques, and each link's centre force and couple
    (weight - buoyancy, drag, seabed contact)."""
    n = arr.shape[1]
    l, mw, jk, jc, gl2, cn, ct = arr[0], arr[2], arr[3], arr[4], arr[5], arr[6], arr[7]
    kb, cb, mua, mut = arr[8], arr[9], arr[10], arr[11]
    current, drag, g, seabed, zb, vc = par[0], int(par[1]), par[9], par[17] != 0.0, par[18], par[19]
    cth = ws[_F_COS, :n]
    sth = ws[_F_SIN, :n]
    if not trig_ready:
        link_trig(q, cth, sth)
    joint_torques(jk, jc, q, qd, ws[_F_TAU, :n + 1])
    fgx = ws[_F_FGX, :n]
    fgz = ws[_F_FGZ, :n]
    cpl = ws[_F_CPL, :n]
    applied_link_forces(l, mw, gl2, cn, ct, current, drag, g, qd, cth, sth, fgx, fgz, cpl,
                        ws[_F_PVX, :n], ws[_F_PVZ, :n])
    if seabed:
        F = ws[_F_BED:_F_BED + 2].reshape(-1)[:2 * n].reshape((n, 2))
        S = ws[_F_BED + 2:_F_BED + 4].reshape(-1)[:2 * n].reshape((n, 2))
        add_seabed_loads(l, zb, kb, cb, mua, mut, vc, q, qd, cth, sth, fgx, fgz, cpl, F, S)


@nb.njit(cache=True, inline="always")
def platform_force(par: np.ndarray, u: float, eta: float, q: np.ndarray, qd: np.ndarray) -> float:
    """The generalised force on the platform's heave besides the line: the input heave force
    ``u``, the heave spring and damper, and the wave elevation ``eta`` through the spring."""
    q0 = u - par[5] * q[0] - par[6] * qd[0]
    if par[8] != 0.0:
        q0 += par[5] * eta
    return q0


@nb.njit(**HOT_KERNEL)
def fd_packed_ws(arr: np.ndarray, par: np.ndarray, u: float, eta: float, q: np.ndarray,
                 qd: np.ndarray, qdd: np.ndarray, lam: np.ndarray, ws: np.ndarray,
                 trig_ready: bool = False) -> bool:
    """Articulated-body forward dynamics on the packed model
    (:func:`cable_sim.core.kernel.packing.pack_arrays`); writes ``qdd`` and ``lam``. ``ws`` is
    scratch from :func:`fd_workspace` (the compiled steppers allocate it once per run); its rows
    ``_F_COS``, ``_F_SIN`` hold the links' cos/sin afterwards (:func:`fd_trig`). With
    ``trig_ready`` they hold those at q already (the caller's
    :func:`cable_sim.core.kernel.links.link_trig` into :func:`fd_trig`) and are not recomputed.

    Steps: link trig, applied forces, the inward sweep (with the two unit end-force right-hand
    sides and the end-correction sums when anchored or for a heavy load), the end force of the
    heavy-load (Woodbury) or anchor (Schur) correction, then one outward sweep. Returns False if
    the anchored end's 2x2 constraint matrix is singular to working precision.

    The model's rows and scalars are unpacked here, not passed one by one: a compiled call
    costs per array argument (~0.4 us a call for the 17 arrays).

    Compiled with ``error_model="numpy"`` (no division-by-zero branches: a zero divisor gives
    inf/NaN, which the steppers' checks catch) and ``fastmath={"contract"}`` only (products and
    sums fused into FMAs where LLVM chooses: round-off-level differences; no assumption about
    NaN/Inf, which the blow-up detection relies on).
    """
    n = arr.shape[1]
    l, me = arr[0], arr[13]
    mc, mcw, mp = par[2], par[3], par[4]
    locked, g = par[7] != 0.0, par[9]
    constrained, ax, az, balpha, bbeta = par[10] != 0.0, par[11], par[12], par[13], par[14]
    heavy = par[20] != 0.0
    applied_generalised_forces(arr, par, q, qd, ws, trig_ready)
    cth = ws[_F_COS, :n]
    sth = ws[_F_SIN, :n]
    tau = ws[_F_TAU, :n + 1]
    fgx = ws[_F_FGX, :n]
    fgz = ws[_F_FGZ, :n]
    cpl = ws[_F_CPL, :n]
    nrhs = 3 if (constrained or heavy) else 1
    dd = ws[_F_DD, :n]
    hx = ws[_F_HX, :n]
    hz = ws[_F_HZ, :n]
    rr = ws[_F_RR:_F_RR + nrhs]
    bx = ws[_F_BX, :nrhs]
    bz = ws[_F_BZ, :nrhs]
    bx[:] = 0.0
    bz[:] = 0.0
    bz[0] = mcw * g
    sw = ws[_F_SW:_F_SW + SW_ROWS]
    mk = arr[ARR_MK:ARR_MK + MK_ROWS]
    q0 = platform_force(par, u, eta, q, qd)
    lam[0] = 0.0
    lam[1] = 0.0
    if nrhs == 1:
        azz = inward_sweep_ws(l, mk, me, cth, sth, qd, tau, cpl, fgx, fgz, True, mc, bx, bz, dd,
                              hx, hz, rr, sw, False)
        outward_sweep_bias(sw, n, 0.0 if locked else (q0 - bz[0]) / (mp + azz), qdd)
        return True
    # the end correction: a unit external force +x, +z on p_n (the link exerts -F on "the end")
    # rides along the inward sweep, which also sums what J M^-1 J^T and the applied forces' end
    # acceleration need; then one outward sweep of the applied forces plus the end force f
    bx[1] = -1.0
    bz[2] = -1.0
    endm = ws[_F_ENDM, :5]
    azz = inward_sweep_ws(l, mk, me, cth, sth, qd, tau, cpl, fgx, fgz, True,
                          0.0 if heavy else mc, bx, bz, dd, hx, hz, rr, sw, True, endm)
    zdd = ws[_F_ZDD, :3]
    for k in range(3):
        zdd[k] = 0.0 if locked else ((q0 if k == 0 else 0.0) - bz[k]) / (mp + azz)
    g00, g01, g11, aex, aez = end_correction_terms(endm, bz, zdd)
    vx = vz = px = pz = 0.0  # the Baumgarte terms: anchored end only
    if constrained:
        vx, vz = end_velocity(sw[_S_LC, :n], sw[_S_LS, :n], qd)
        px, pz = end_position(l, q[0], cth, sth)
    ok, fx, fz = end_force(heavy, mc, g00, g01, g11, aex, aez, ax, az, balpha, bbeta, vx, vz,
                           px, pz)
    if not ok:
        return False
    rd = sw[_S_RD, :n]
    r1 = rr[1]
    r2 = rr[2]
    for i in range(n):
        rd[i] += (fx * r1[i] + fz * r2[i]) * dd[i]
    outward_sweep_bias(sw, n, zdd[0] + fx * zdd[1] + fz * zdd[2], qdd)
    if constrained:
        lam[0] = fx
        lam[1] = fz
    return True


@nb.njit(cache=True)
def fd_packed(arr: np.ndarray, par: np.ndarray, u: float, eta: float, q: np.ndarray, qd: np.ndarray,
              qdd: np.ndarray, lam: np.ndarray) -> bool:
    """:func:`fd_packed_ws` with a workspace of its own (same arithmetic, same results)."""
    return fd_packed_ws(arr, par, u, eta, q, qd, qdd, lam, fd_workspace(arr.shape[1]))


# ---- Python API --------------------------------------------------------------------------------


def forward_dynamics(
    model: CableModel, q: np.ndarray, qd: np.ndarray, inputs: Inputs = NO_INPUT
) -> tuple[np.ndarray, np.ndarray]:
    """Generalised accelerations and anchor reaction in O(n) (articulated-body recursion).

    Same contract as :func:`cable_sim.core.dynamics.forward_dynamics`.

    Parameters
    ----------
    model : CableModel
        Immutable model.
    q, qd : ndarray (n+1,)
        Generalised positions ``[z_m, theta_1..theta_n]`` and velocities.
    inputs : Inputs, optional
        Heave force and wave elevation (held).

    Returns
    -------
    qdd : ndarray (n+1,)
        Generalised accelerations (``qdd[0] = 0`` when heave-locked).
    anchor_force : ndarray (2,)
        Force (x, z) [N] the anchor exerts on the cable end (zeros unless anchored).

    Raises
    ------
    numpy.linalg.LinAlgError
        If the anchored end's 2x2 matrix ``J M^-1 J^T`` is singular to working precision
        (e.g. one link on a heave-locked platform: one dof against two constraints).
    """
    k = model.n + 1
    qv = vec(q, k, "q")
    qdv = vec(qd, k, "qd")
    qdd = np.empty(k)
    lam = np.empty(2)
    arr, par = pack_arrays(model)
    ok = fd_packed(arr, par, float(inputs.heave_force), float(inputs.wave_elevation), qv, qdv, qdd,
                   lam)
    if not ok:
        raise np.linalg.LinAlgError("singular anchor constraint matrix J M^-1 J^T")
    return qdd, lam


def state_derivative(model: CableModel, y: np.ndarray, inputs: Inputs = NO_INPUT) -> np.ndarray:
    """Time derivative of the state ``y = [q, qd]`` using the O(n) kernel.

    Parameters
    ----------
    model : CableModel
        Immutable model.
    y : ndarray (2(n+1),)
        State ``[q, qd]``.
    inputs : Inputs, optional
        Heave force and wave elevation (held).

    Returns
    -------
    ydot : ndarray (2(n+1),)
        ``[qd, qdd]``.
    """
    k = model.n + 1
    y = np.asarray(y, dtype=np.float64)
    if y.shape != (2 * k,):
        raise ValueError(f"y has shape {y.shape}; expected ({2 * k},)")
    qdd, _ = forward_dynamics(model, y[:k], y[k:], inputs)
    return np.concatenate([y[k:], qdd])
