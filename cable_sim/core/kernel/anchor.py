"""The anchored end in O(n): projection, drift and the Schur matrix.

* :func:`project_packed_ws` (:func:`project_packed`), :func:`end_drift_packed`: the projection
  onto ``Phi(q) = 0``, ``Phi_q qd = 0`` and the end's distance from the anchor;
* :func:`schur_packed`, :func:`condition_2x2`, :func:`schur_condition`: ``J M^-1 J^T`` (the
  shared inward/outward sweeps with the two unit end forces, outward-solved) and its
  condition number, which grows without bound as the line is pulled straight.

Core layer, compiled kernel: imports numba, numpy, :mod:`cable_sim.core.kernel.sweeps`,
:mod:`cable_sim.core.kernel.links`,
:mod:`cable_sim.core.kernel.packing`, :mod:`cable_sim.core.model`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.links import link_trig
from cable_sim.core.kernel.packing import pack_arrays
from cable_sim.core.kernel.sweeps import inward_sweep, outward_sweep, solve_2x2
from cable_sim.core.model import CableModel


@nb.njit(cache=True, inline="always")
def end_position(l: np.ndarray, z0: float, cth: np.ndarray, sth: np.ndarray) -> tuple[float, float]:
    """Position of the line's end ``p_n`` [m] from the platform heave ``z0`` and the links'
    cos/sin."""
    px = 0.0
    pz = z0
    for i in range(l.shape[0]):
        px += l[i] * sth[i]
        pz -= l[i] * cth[i]
    return px, pz


@nb.njit(cache=True, inline="always")
def end_gram(l: np.ndarray, cth: np.ndarray, sth: np.ndarray, y: np.ndarray, free: bool,
             velocity: bool) -> tuple:
    """``J J^T`` (a11, a12, a22) over the free coordinates and, with ``velocity``, ``J qd``
    (``J`` from the links' cos/sin)."""
    n1 = l.shape[0] + 1
    a11 = 0.0
    a12 = 0.0
    a22 = 1.0 if free else 0.0
    vx = 0.0
    vz = y[n1] if (free and velocity) else 0.0
    for i in range(l.shape[0]):
        jx = l[i] * cth[i]
        jz = l[i] * sth[i]
        a11 += jx * jx
        a12 += jx * jz
        a22 += jz * jz
        if velocity:
            vx += jx * y[n1 + i + 1]
            vz += jz * y[n1 + i + 1]
    return a11, a12, a22, vx, vz


@nb.njit(cache=True, inline="always")
def subtract_jt(l: np.ndarray, cth: np.ndarray, sth: np.ndarray, y: np.ndarray, off: int,
                free: bool, mx: float, mz: float) -> None:
    """``y[off:off + n + 1] -= J^T (mx, mz)`` over the free coordinates (``J`` from the links'
    cos/sin)."""
    if free:
        y[off] -= mz
    for i in range(l.shape[0]):
        y[off + i + 1] -= l[i] * cth[i] * mx + l[i] * sth[i] * mz


@nb.njit(cache=True)
def project_packed_ws(arr: np.ndarray, par: np.ndarray, y: np.ndarray, tol: float,
                      cth: np.ndarray, sth: np.ndarray) -> float:
    """In-place projection onto Phi(q) = 0 and Phi_q qd = 0; returns the end's remaining
    distance from the anchor [m] and leaves the cos/sin of the projected links in ``cth``,
    ``sth`` (length n).

    The algorithm of :func:`cable_sim.core.system.project_constraint` (at most 5 Gauss-Newton
    steps ``dq = -J^T (J J^T)^-1 Phi`` on the free coordinates, then the least-squares velocity
    projection), O(n). The links' cos/sin are formed once per configuration (one vectorised
    pass of :func:`cable_sim.core.kernel.links.link_trig`) and serve the end position, ``J J^T``
    and ``J^T``: two passes for a projection of one Gauss-Newton step.
    """
    l = arr[0]
    free = par[7] == 0.0
    link_trig(y, cth, sth)
    for _ in range(5):
        px, pz = end_position(l, y[0], cth, sth)
        fx = px - par[11]
        fz = pz - par[12]
        if np.hypot(fx, fz) <= tol * par[16]:
            break
        a11, a12, a22, _vx, _vz = end_gram(l, cth, sth, y, free, False)
        mx, mz = solve_2x2(a11, a12, a12, a22, fx, fz)
        subtract_jt(l, cth, sth, y, 0, free, mx, mz)
        link_trig(y, cth, sth)
    a11, a12, a22, vx, vz = end_gram(l, cth, sth, y, free, True)
    mx, mz = solve_2x2(a11, a12, a12, a22, vx, vz)
    subtract_jt(l, cth, sth, y, l.shape[0] + 1, free, mx, mz)
    px, pz = end_position(l, y[0], cth, sth)
    return np.hypot(px - par[11], pz - par[12])


@nb.njit(cache=True)
def project_packed(arr: np.ndarray, par: np.ndarray, y: np.ndarray, tol: float) -> None:
    """:func:`project_packed_ws` with scratch of its own."""
    n = arr.shape[1]
    project_packed_ws(arr, par, y, tol, np.empty(n), np.empty(n))


@nb.njit(cache=True)
def end_drift_packed(arr: np.ndarray, par: np.ndarray, y: np.ndarray) -> float:
    """|p_n - anchor| [m]."""
    n = arr.shape[1]
    cth = np.empty(n)
    sth = np.empty(n)
    link_trig(y, cth, sth)
    px, pz = end_position(arr[0], y[0], cth, sth)
    return np.hypot(px - par[11], pz - par[12])


@nb.njit(cache=True)
def schur_packed(arr: np.ndarray, par: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``J M^-1 J^T`` (2x2, end accelerations per unit end force) in O(n), load excluded.

    The inward and outward sweeps of the forward dynamics with only its two unit-force
    right-hand sides (zero velocity and gravity); the terminal load is not included (as for
    the anchored end and the heavy-load Woodbury form).
    """
    n = arr.shape[1]
    l = arr[0]
    cth = np.empty(n)
    sth = np.empty(n)
    link_trig(q, cth, sth)
    dd = np.empty(n)
    hx = np.empty(n)
    hz = np.empty(n)
    rr = np.empty((3, n))  # row 0 (applied forces) unused here
    bx = np.zeros(3)
    bz = np.zeros(3)
    bx[1] = -1.0
    bz[2] = -1.0
    azz = inward_sweep(l, arr[12], arr[13], cth, sth, q, dd, dd, dd, dd, False, 0.0, bx, bz, dd, hx,
                       hz, rr)
    out = np.empty((2, 2))
    sol = np.empty(n + 1)
    for k in range(2):
        zdd = 0.0 if par[7] != 0.0 else -bz[k + 1] / (par[4] + azz)
        out[0, k], out[1, k] = outward_sweep(l, cth, sth, q, False, dd, False, rr[k + 1], hx, hz,
                                             dd, zdd, sol)
    return out


@nb.njit(cache=True)
def condition_2x2(a11: float, a12: float, a21: float, a22: float) -> float:
    """2-norm condition number of a 2x2 matrix (inf if singular)."""
    # singular values from the Frobenius norm and the determinant
    fro2 = a11 * a11 + a12 * a12 + a21 * a21 + a22 * a22
    det = abs(a11 * a22 - a12 * a21)
    disc = np.sqrt(max(fro2 * fro2 - 4.0 * det * det, 0.0))
    smax2 = 0.5 * (fro2 + disc)
    if det == 0.0 or smax2 == 0.0:
        return np.inf
    smin2 = det * det / smax2
    return np.sqrt(smax2 / smin2)


def schur_condition(model: CableModel, q: np.ndarray) -> float:
    """Condition number of the anchored end's 2x2 ``J M^-1 J^T`` (load excluded), O(n).

    Grows without bound as the line is pulled straight (kinematic singularity); the
    integrators stop when it exceeds their ``max_condition``.

    Parameters
    ----------
    model : CableModel
        Immutable model.
    q : ndarray (n+1,)
        Generalised positions.

    Returns
    -------
    float
        The 2-norm condition number (inf if singular).
    """
    arr, par = pack_arrays(model)
    s = schur_packed(arr, par, np.ascontiguousarray(q, dtype=float))
    return float(condition_2x2(s[0, 0], s[0, 1], s[1, 0], s[1, 1]))
