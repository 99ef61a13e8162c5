"""Static equilibrium: the rest configuration of a scene.

Stationary points of the potential energy V(q) (gravity-minus-buoyancy, joint springs, heave
spring), with the anchor constraint where the end is anchored, found by Newton's method on the
KKT system with the analytic Hessian (diagonal + tridiagonal, so each step is cheap). The
initial guess for an anchored line is the inextensible catenary through fairlead and anchor.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from cable_sim.core import dynamics
from cable_sim.core.dynamics import NO_INPUT, Inputs
from cable_sim.core.model import CableModel


class StaticsError(RuntimeError):
    """No static equilibrium was found (reason in the message)."""


def catenary_points(
    span: float, rise: float, length: float, s: np.ndarray
) -> np.ndarray:
    """Points of an inextensible catenary hanging from (0, 0) to (span, rise).

    Parameters
    ----------
    span : float
        Horizontal distance to the lower end [m] (> 0).
    rise : float
        Vertical offset of the other end [m] (negative: below).
    length : float
        Arc length [m]; must exceed the chord.
    s : ndarray
        Arc-length stations from the first end [m].

    Returns
    -------
    ndarray (len(s), 2)
        (x, z) of each station.
    """
    chord = np.hypot(span, rise)
    if length <= chord:
        raise StaticsError(f"line length {length:.6g} m does not exceed the chord {chord:.6g} m "
                           "(the line would be taut: no catenary)")
    target = np.sqrt(length**2 - rise**2)
    # 2 a sinh(span / 2a) = target; solve for u = span / 2a
    u = brentq(lambda u: np.sinh(u) / u - target / span, 1e-12, 50.0)
    a = span / (2 * u)
    # z = a cosh((x - x0)/a) + C through both ends
    x0 = span / 2 - a * np.arcsinh(rise / (2 * a * np.sinh(span / (2 * a))))
    s0 = a * np.sinh((0.0 - x0) / a)
    x = x0 + a * np.arcsinh((s + s0) / a)
    z = a * np.cosh((x - x0) / a) - a * np.cosh(x0 / a)
    return np.stack([x, z], axis=1)


def _initial_guess(model: CableModel, z_top: float) -> np.ndarray:
    q = np.zeros(model.ndof)
    q[0] = z_top
    if model.constrained:
        ax, az = model.anchor
        sgn = 1.0 if ax >= 0 else -1.0
        span = max(abs(ax), 1e-6 * model.params.total_length)
        stations = np.concatenate([[0.0], np.cumsum(model.length)])
        pts = catenary_points(span, az - z_top, model.length.sum(), stations)
        d = np.diff(pts, axis=0)
        q[1:] = np.arctan2(sgn * d[:, 0], -d[:, 1])
    return q


def _hessian(model: CableModel, q: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Hessian of the Lagrangian V - lam . Phi (dense assembly of diagonal + tridiagonal)."""
    n = model.n
    th, l = q[1:], model.length
    H = np.zeros((n + 1, n + 1))
    H[0, 0] = model.heave_k
    k = model.joint_k
    d = model.gravity * model.mu_weight * l * np.cos(th) + k
    d[:-1] += k[1:]
    if model.constrained:
        d -= lam[0] * (-l * np.sin(th)) + lam[1] * (l * np.cos(th))
    idx = np.arange(1, n + 1)
    H[idx, idx] = d
    H[idx[:-1], idx[1:]] = -k[1:]
    H[idx[1:], idx[:-1]] = -k[1:]
    return H


def _check_stable(model: CableModel, q: np.ndarray, lam: np.ndarray, s: int) -> None:
    """Raise StaticsError unless the Hessian of the Lagrangian is positive definite on the
    constraint's tangent space (a rest state, not an unstable stationary point)."""
    H = _hessian(model, q, lam)[s:, s:]
    if model.constrained:
        J = dynamics.constraint_jacobian(model, q)[:, s:]
        _, sv, vt = np.linalg.svd(J)
        Z = vt[int(np.sum(sv > 1e-12 * sv.max())):].T  # null space of J
        H = Z.T @ H @ Z
    eig = np.linalg.eigvalsh(0.5 * (H + H.T))
    if eig.size and eig.min() <= -1e-9 * max(np.abs(eig).max(), 1.0):
        raise StaticsError(
            f"Newton converged to an unstable equilibrium (lowest reduced stiffness "
            f"{eig.min():.3g}); start from another guess"
        )


def static_equilibrium(
    model: CableModel,
    inputs: Inputs = NO_INPUT,
    q0: np.ndarray | None = None,
    z_top: float | None = None,
    tol: float = 1e-11,
    max_iter: int = 100,
) -> tuple[np.ndarray, np.ndarray]:
    """Rest configuration of the cable.

    Parameters
    ----------
    model : CableModel
    inputs : Inputs
        Steady heave force and wave elevation to balance.
    q0 : ndarray, optional
        Initial guess (default: vertical hang, or the catenary to the anchor).
    z_top : float, optional
        Fairlead height for the initial guess, and the held height when heave is locked.
        Default: the height where the heave spring carries the line's wet weight.
    tol : float
        Convergence tolerance on the force residual, relative to the line's wet weight.

    Returns
    -------
    q : ndarray (n+1,)
        Equilibrium coordinates.
    anchor_force : ndarray (2,)
        Anchor reaction on the cable [N] (zeros for a free end).

    Raises
    ------
    StaticsError
        When Newton's method does not converge or the problem has no equilibrium.
    """
    wet_weight = model.gravity * (np.abs(model.weight_mass).sum() + abs(model.load_weight_mass))
    scale = max(wet_weight * model.params.total_length, 1.0)
    s = 1 if model.heave_locked else 0
    if not model.heave_locked and model.heave_k <= 0:
        raise StaticsError("the platform has no heave spring and is not locked: no equilibrium")
    if z_top is None:
        z_top = 0.0
        if not model.heave_locked:
            f_ext = dynamics.external_force(model, inputs)[0]
            z_top = (f_ext - dynamics.gravity_vector(model, np.zeros(model.ndof))[0]) / model.heave_k
    q = _initial_guess(model, z_top) if q0 is None else np.array(q0, dtype=float)
    if model.heave_locked:
        q[0] = z_top
    qext = dynamics.external_force(model, inputs)
    m = 2 if model.constrained else 0
    lam = np.zeros(2)
    if m:
        # Start the anchor reaction from the least-squares force balance at the guess: with
        # lam = 0 the first Hessian lacks the line's tension stiffness and Newton can jump to
        # an unstable stationary point.
        r0 = dynamics.gravity_vector(model, q) + dynamics.elastic_force(model, q) - qext
        J0 = dynamics.constraint_jacobian(model, q)[:, s:]
        lam = np.linalg.lstsq(J0.T, r0[s:], rcond=None)[0]
    for _ in range(max_iter):
        r = dynamics.gravity_vector(model, q) + dynamics.elastic_force(model, q) - qext
        J = dynamics.constraint_jacobian(model, q)
        if model.constrained:
            r = r - J.T @ lam
            phi = dynamics.constraint_residual(model, q)
        else:
            phi = np.zeros(0)
        res = np.concatenate([r[s:] / wet_weight, phi / model.params.total_length])
        H = _hessian(model, q, lam)[s:, s:]
        K = np.zeros((H.shape[0] + m, H.shape[0] + m))
        K[: H.shape[0], : H.shape[0]] = H
        if m:
            K[: H.shape[0], H.shape[0]:] = -J[:, s:].T
            K[H.shape[0]:, : H.shape[0]] = J[:, s:]
        try:
            delta = np.linalg.solve(K, -np.concatenate([r[s:], phi]))
        except np.linalg.LinAlgError as exc:
            raise StaticsError(f"singular equilibrium system ({exc})") from exc
        # damp huge angle steps (Newton far from the solution)
        big = np.max(np.abs(delta[1 - s: H.shape[0]])) if H.shape[0] > 1 - s else 0.0
        alpha = min(1.0, 0.5 / big) if big > 0 else 1.0
        q[s:] += alpha * delta[: H.shape[0]]
        if m:
            lam += alpha * delta[H.shape[0]:]
        if np.max(np.abs(res)) < tol and alpha == 1.0:
            _check_stable(model, q, lam, s)
            return q, lam
    raise StaticsError(
        f"Newton did not converge in {max_iter} iterations (residual {np.max(np.abs(res)):.3g}, "
        f"tolerance {tol:g}); torque/force scale {scale:.3g}"
    )
