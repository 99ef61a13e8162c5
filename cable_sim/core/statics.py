"""Static equilibrium: the rest configuration of a scene.

Stationary points of the potential energy V(q) (gravity-minus-buoyancy, joint springs, heave
spring, and the seabed's elastic energy when the scene has a seabed), with the anchor constraint
where the end is anchored, found by Newton's method on the KKT system with the analytic Hessian
(diagonal + tridiagonal without a seabed, so each step is cheap; the contact adds a dense block
for the links below the bed). The initial guess for an anchored line is the inextensible
catenary through fairlead and anchor, or, with a seabed at the anchor's depth, the catenary with
touchdown (laid length on the bed, MODEL.md "Round 2 terms"). At rest the bed's damping and
friction exert no force, so statics ignores them (friction could hold other rest shapes too).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from cable_sim.core import dynamics
from cable_sim.core.dynamics import NO_INPUT, Inputs
from cable_sim.core.model import CableModel

_EPS = float(np.finfo(float).eps)


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


def catenary_touchdown(span: float, drop: float, length: float) -> tuple[float, float]:
    """Inextensible catenary with a laid length on a horizontal seabed (MODEL.md, round 2).

    The fairlead is ``drop`` [m] above the seabed and ``span`` [m] from the anchor, which lies on
    the seabed. Returns ``(laid_length, a)`` with a = H / w; laid_length = 0 when the line is
    fully suspended (no touchdown: use the ordinary catenary then).
    """
    V, D, L = drop, span, length

    def f(lb: float) -> float:
        ls = L - lb
        a = (ls * ls - V * V) / (2.0 * V)
        return a * np.arcsinh(ls / a) - (D - lb)

    hi = L - V
    if V <= 0 or hi <= 0 or f(0.0) <= 0.0 or f(hi * (1 - 1e-12)) >= 0.0:
        return 0.0, float("nan")
    lb = brentq(f, 0.0, hi * (1 - 1e-12), xtol=1e-13 * L)
    ls = L - lb
    return float(lb), float((ls * ls - V * V) / (2.0 * V))


def catenary_touchdown_points(
    span: float, drop: float, length: float, s: np.ndarray
) -> np.ndarray | None:
    """Points (x, z) at arc lengths ``s`` from the fairlead (at the origin) of the catenary with
    touchdown toward an anchor at (span, -drop) on the seabed; None when fully suspended."""
    lb, a = catenary_touchdown(span, drop, length)
    if lb <= 0.0:
        return None
    ls = length - lb
    x_td = span - lb
    sig = np.clip(ls - s, 0.0, None)
    x = np.where(s < ls, x_td - a * np.arcsinh(sig / a), x_td + (s - ls))
    z = np.where(s < ls, -drop + np.sqrt(a * a + sig * sig) - a, -drop)
    return np.stack([x, z], axis=1)


def _initial_guess(model: CableModel, z_top: float) -> np.ndarray:
    q = np.zeros(model.ndof)
    q[0] = z_top
    if model.constrained:
        ax, az = model.anchor
        sgn = 1.0 if ax >= 0 else -1.0
        span = max(abs(ax), 1e-6 * model.params.total_length)
        stations = np.concatenate([[0.0], np.cumsum(model.length)])
        pts = None
        if model.seabed and abs(az - model.seabed_z) <= 1e-9 * model.params.total_length:
            pts = catenary_touchdown_points(span, z_top - az, model.length.sum(), stations)
        if pts is None:
            pts = catenary_points(span, az - z_top, model.length.sum(), stations)
        d = np.diff(pts, axis=0)
        q[1:] = np.arctan2(sgn * d[:, 0], -d[:, 1])
    return q


def _restoring(model: CableModel, q: np.ndarray) -> np.ndarray:
    """dV/dq: gravity-minus-buoyancy, springs, and the bed's elastic reaction (at rest)."""
    r = dynamics.gravity_vector(model, q) + dynamics.elastic_force(model, q)
    if model.seabed:
        r -= dynamics.seabed_force(model, q, np.zeros_like(q))
    return r


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
    if model.seabed:
        H += seabed_hessian(model, q)
    return H


def seabed_hessian(model: CableModel, q: np.ndarray) -> np.ndarray:
    """Hessian of the bed's elastic energy sum int 1/2 k delta^2 ds (delta = z_b - z(s) > 0):
    int k J_z^T J_z ds - int k delta d^2 z / dq^2 ds over each link's penetrating interval, with
    J_z(s) = J_p,z + s sin(theta_i) e_i (z_m and the links above: l_j sin theta_j)."""
    n, l, th = model.n, model.length, q[1:]
    H = np.zeros((n + 1, n + 1))
    p = dynamics.joint_positions(model, q)
    F, S, _, _ = dynamics.seabed_link_forces(model, q, np.zeros_like(q))
    jz = np.concatenate([[1.0], l * np.sin(th)])  # dz/dq of the joints below
    cz = l * np.cos(th)
    for i in range(n):
        d0, d1 = model.seabed_z - p[i, 1], np.cos(th[i])
        if d0 <= 0.0 and d0 + d1 * l[i] <= 0.0:
            continue
        a, b = 0.0, l[i]
        if d1 != 0.0:
            root = -d0 / d1
            if d1 > 0.0:
                a = min(max(a, root), b)
            else:
                b = max(min(b, root), a)
        if b <= a:
            continue
        k = model.seabed_k[i]
        Jp = np.zeros(n + 1)
        Jp[: i + 1] = jz[: i + 1]
        Ts = np.sin(th[i])
        H += k * (b - a) * np.outer(Jp, Jp)
        cross = k * 0.5 * (b * b - a * a) * Ts * Jp
        H[:, i + 1] += cross
        H[i + 1, :] += cross
        H[i + 1, i + 1] += k * (b**3 - a**3) / 3.0 * Ts * Ts
        # - int k delta d2z/dq2: d2z/dtheta_j^2 = l_j cos theta_j (j < i), s cos theta_i (j = i)
        H[np.arange(1, i + 1), np.arange(1, i + 1)] -= cz[:i] * F[i, 1]
        H[i + 1, i + 1] -= np.cos(th[i]) * S[i, 1]
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
    if not model.seabed:
        return _newton(model, q, _initial_reaction(model, q, qext, s), qext, s, tol, max_iter)
    # Seabed: continuation in the bed stiffness. The first guess may sink into (or float above)
    # the bed by far more than the rest penetration w / k_b; a stiff bed then makes Newton's
    # contact set jump from step to step. A soft bed first (rest penetration ~2 % of a link)
    # and stiffer beds from the previous solution each converge in a few steps.
    k_target = float(model.params.seabed_stiffness)
    w_len = wet_weight / max(model.params.total_length, 1e-300)
    k = min(k_target, w_len / (0.02 * float(model.length.mean())))
    lam = None
    while True:
        stage = model if k >= k_target else CableModel.from_params(
            model.params.replace(seabed_stiffness=k))
        last = stage is model
        if lam is None:
            lam = _initial_reaction(stage, q, qext, s)
        # the residual's round-off floor grows with the bed stiffness: forces k_b delta with
        # delta = z_b - z(s) carry an absolute error ~eps |z_b| per length, over lever arms ~L
        floor = 16.0 * _EPS * k * abs(model.seabed_z) * model.params.total_length**2 / wet_weight
        q, lam = _newton(stage, q, lam, qext, s, max(tol, floor) if last else max(1e-6, floor),
                         max_iter, check=last)
        if last:
            return q, lam
        k = min(10.0 * k, k_target)


def _initial_reaction(model: CableModel, q: np.ndarray, qext: np.ndarray, s: int) -> np.ndarray:
    """Anchor reaction from the least-squares force balance at the guess (zeros for a free end):
    with lam = 0 the first Hessian lacks the line's tension stiffness and Newton can jump to an
    unstable stationary point."""
    if not model.constrained:
        return np.zeros(2)
    r0 = _restoring(model, q) - qext
    J0 = dynamics.constraint_jacobian(model, q)[:, s:]
    return np.linalg.lstsq(J0.T, r0[s:], rcond=None)[0]


def _kkt_residual(model: CableModel, q: np.ndarray, lam: np.ndarray, qext: np.ndarray,
                  s: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(force residual on the free coordinates, constraint residual, Phi_q)."""
    r = _restoring(model, q) - qext
    J = dynamics.constraint_jacobian(model, q)
    if model.constrained:
        r = r - J.T @ lam
        phi = dynamics.constraint_residual(model, q)
    else:
        phi = np.zeros(0)
    return r[s:], phi, J


def _newton(model: CableModel, q: np.ndarray, lam: np.ndarray, qext: np.ndarray, s: int,
            tol: float, max_iter: int, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Newton's method on the KKT system from (q, lam); with a seabed, a backtracking line
    search on the residual (the contact set may change within a step)."""
    wet_weight = model.gravity * (np.abs(model.weight_mass).sum() + abs(model.load_weight_mass))
    scale = max(wet_weight * model.params.total_length, 1.0)
    m = 2 if model.constrained else 0
    q = q.copy()
    lam = lam.copy()

    def scaled(r: np.ndarray, phi: np.ndarray) -> np.ndarray:
        return np.concatenate([r / wet_weight, phi / model.params.total_length])

    for _ in range(max_iter):
        r, phi, J = _kkt_residual(model, q, lam, qext, s)
        res = scaled(r, phi)
        H = _hessian(model, q, lam)[s:, s:]
        K = np.zeros((H.shape[0] + m, H.shape[0] + m))
        K[: H.shape[0], : H.shape[0]] = H
        if m:
            K[: H.shape[0], H.shape[0]:] = -J[:, s:].T
            K[H.shape[0]:, : H.shape[0]] = J[:, s:]
        try:
            delta = np.linalg.solve(K, -np.concatenate([r, phi]))
        except np.linalg.LinAlgError as exc:
            raise StaticsError(f"singular equilibrium system ({exc})") from exc
        # damp huge angle steps (Newton far from the solution)
        big = np.max(np.abs(delta[1 - s: H.shape[0]])) if H.shape[0] > 1 - s else 0.0
        alpha = min(1.0, 0.5 / big) if big > 0 else 1.0
        if np.max(np.abs(res)) < tol and alpha == 1.0:
            q[s:] += delta[: H.shape[0]]
            if m:
                lam += delta[H.shape[0]:]
            if check:
                _check_stable(model, q, lam, s)
            return q, lam
        if model.seabed:
            norm0 = np.linalg.norm(res)
            for _ls in range(12):
                qt = q.copy()
                qt[s:] += alpha * delta[: H.shape[0]]
                lt = lam + alpha * delta[H.shape[0]:] if m else lam
                if np.linalg.norm(scaled(*_kkt_residual(model, qt, lt, qext, s)[:2])) < norm0:
                    break
                alpha *= 0.5
        q[s:] += alpha * delta[: H.shape[0]]
        if m:
            lam += alpha * delta[H.shape[0]:]
    raise StaticsError(
        f"Newton did not converge in {max_iter} iterations (residual {np.max(np.abs(res)):.3g}, "
        f"tolerance {tol:g}); torque/force scale {scale:.3g}"
    )
