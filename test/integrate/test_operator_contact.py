"""Issue 11: the seabed contact's stiffness and damping are in the O(n) implicit operator.

The O(n) ``operator_product`` (``hg D rd + hg K rk``) and ``operator_solve``
(``(M + hg D + hg^2 K) x = rhs``, anchored: with ``J x = 0``) equal a dense reference built
independently of the O(n) code:

* ``M``, and ``D``, ``K`` without the bed: :func:`cable_sim.integrate.implicit.dense_operator`
  on the same line with the seabed switched off (dense ``M`` from the Lagrangian, added mass,
  joint and heave springs/dampers, Morison drag Jacobian, tension stiffness);
* the bed's ``D_c = -dQ_b/dqd`` by central finite differences of the dense reference contact
  force (:func:`cable_sim.core.dynamics.seabed_link_forces`, per link resultant and first
  moment, generalised with ``J^T``);
* the bed's ``K_c``: the position Jacobian of the contact force with ``J^T`` held at the state
  (finite differences of the per-link resultants and moments only), i.e. ``int k J_z^T J_z``
  over the part of each link the bed pushes. The operator leaves out the part of
  ``-dQ_b/dq`` that comes from turning ``J^T`` (diagonal, like gravity's: in the tension
  stiffness, which the bed's reaction already lowers) and the damper's ``d zdot / dq``. At rest
  (qd = 0) ``K_c`` is computed that way; in motion (where the damper also shortens the contact
  interval) as ``k_b / c_b`` times each link's own ``D_c`` (the same interval and shape).

States: a V-shaped line whose dip lies on the bed, with links fully, partly and not in contact
(asserted), random velocities large enough that the damper cuts the contact interval short
(the force ``k delta - c zdot`` reaches zero inside a link). Free and anchored ends, heave free
and locked, with and without added mass; a real ``hg`` and a complex one (Radau IIA's complex
eigenvalue, :mod:`cable_sim.integrate.implicit.radau`), and the two solved side by side as Radau
IIA's Newton iteration does. Tolerance 1e-9 relative (the finite differences are
good to ~1e-11 here); the bed's terms change the result by far more (asserted).
"""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.integrate import implicit
from cable_sim.integrate.implicit.dense import _dense_solve

ZB = -20.0
K_B, C_B = 3.0e4, 2.0e4
TOL = 1e-9


def _params(end: str, locked: bool, added: bool, n: int) -> CableParams:
    return CableParams(
        n_links=n, total_length=40.0, diameter=0.1, mass_per_length=50.0, drag_model="morison",
        stiffness_mode="bending", bending_stiffness=30.0, bending_damping=10.0, heave_locked=locked,
        end_condition=end, anchor_x=25.0, anchor_z=ZB - 0.5, load_mass=20.0, seabed=True,
        seabed_depth=ZB, seabed_stiffness=K_B, seabed_damping=C_B, added_mass=added,
        added_mass_cn=1.0, added_mass_ct=0.3)


def _state(m: CableModel, rng: np.random.Generator, moving: bool) -> tuple[np.ndarray, np.ndarray]:
    """A random state with links fully, partly and not in contact, in motion with the damper
    ending the contact inside a penetrating link, and joints clear of the contact's breakpoints
    (1 cm from the bed, the damper's zero 1 cm of spring deflection away: the finite
    differences never straddle one)."""
    while True:
        th = np.where(np.arange(m.n) < m.n // 2, 1.2, 1.9) + rng.normal(0.0, 0.15, m.n)
        q = np.concatenate([[ZB + rng.uniform(4.0, 7.0)], th])
        qd = rng.normal(0.0, 0.6, m.ndof) if moving else np.zeros(m.ndof)
        d = ZB - dynamics.joint_positions(m, q)[:, 1]
        f = d - C_B / K_B * dynamics.joint_velocities(m, q, qd)[:, 1]
        if (np.abs(d).min() > 0.01 and np.abs(f[d > 0]).min(initial=1.0) > 0.01
                and min(_contact_kinds(m, q)) > 0 and (not moving or _damper_cuts(m, q, qd) > 0)):
            return q, qd


def _contact_kinds(m: CableModel, q: np.ndarray) -> tuple[int, int, int]:
    """Links fully below, partly below and fully above the bed."""
    below = dynamics.joint_positions(m, q)[:, 1] < ZB
    both = below[:-1] & below[1:]
    one = below[:-1] ^ below[1:]
    return int(both.sum()), int(one.sum()), int((~(both | one)).sum())


def _damper_cuts(m: CableModel, q: np.ndarray, qd: np.ndarray) -> int:
    """Links on which the damper ends the contact inside the penetrating part: the per-length
    force k delta - c zdot (linear along the link) changes sign there."""
    p = dynamics.joint_positions(m, q)
    v = dynamics.joint_velocities(m, q, qd)
    count = 0
    for i in range(m.n):
        d = ZB - p[i:i + 2, 1]
        if d.max() <= 0.0:
            continue
        f = K_B * d - C_B * v[i:i + 2, 1]
        s_in = [0.0, 1.0]  # the penetrating part in fractions of the link
        if d.min() < 0.0:
            root = d[0] / (d[0] - d[1])
            s_in = [root, 1.0] if d[0] < 0.0 else [0.0, root]
        fa, fb = (f[0] + (f[1] - f[0]) * s for s in s_in)
        count += int(fa * fb < 0.0)
    return count


def _generalise(m: CableModel, q: np.ndarray, F: np.ndarray, S: np.ndarray) -> np.ndarray:
    """sum_i J_i^T of per-link resultants F_i and first moments S_i about the upper joint."""
    return dynamics._link_forces_to_generalised(m, q, F, S)


def _fd_link_forces(m, q, qd, j: int, wrt_velocity: bool, eps: float):
    """Central difference of every link's (F, S) in q_j or qd_j (4th order, Richardson)."""
    def at(dx: float):
        qq, vv = q.copy(), qd.copy()
        (vv if wrt_velocity else qq)[j] += dx
        F, S, _, _ = dynamics.seabed_link_forces(m, qq, vv)
        return F, S

    def central(e: float):
        (Fp, Sp), (Fm, Sm) = at(e), at(-e)
        return (Fp - Fm) / (2 * e), (Sp - Sm) / (2 * e)

    F1, S1 = central(eps)
    F2, S2 = central(2 * eps)
    return (4 * F1 - F2) / 3, (4 * S1 - S2) / 3


def _contact_reference(m: CableModel, q: np.ndarray, qd: np.ndarray):
    """(D_c, K_c) of the bed (see the module docstring): at rest K_c from the position
    differences and D_c = c_b / k_b times it per link; in motion D_c from the velocity
    differences and K_c = k_b / c_b times it per link."""
    n1 = m.ndof
    Dc = np.zeros((n1, n1))
    Kc = np.zeros((n1, n1))
    moving = bool(np.any(qd != 0.0))
    ratio = (m.seabed_k / m.seabed_c)[:, None]
    if moving:
        ratio = 1.0 / ratio
    for j in range(n1):
        dF, dS = _fd_link_forces(m, q, qd, j, moving, 1e-4)  # at rest: J^T held at q
        direct = -_generalise(m, q, dF, dS)
        other = -_generalise(m, q, dF / ratio, dS / ratio)
        Dc[:, j], Kc[:, j] = (direct, other) if moving else (other, direct)
    return Dc, Kc


def _cases():
    for end in ("free", "anchored"):
        for added in (False, True):
            yield end, False, added
    yield "free", True, True
    yield "anchored", True, False


@pytest.mark.parametrize("hg_kind", ["real", "complex"])
@pytest.mark.parametrize("moving", [False, True])
@pytest.mark.parametrize(("end", "locked", "added"), list(_cases()))
def test_operator_with_contact_equals_dense(end: str, locked: bool, added: bool, moving: bool,
                                            hg_kind: str) -> None:
    n = 24
    p = _params(end, locked, added, n)
    m = CableModel.from_params(p)
    bare = CableModel.from_params(p.replace(seabed=False))
    rng = np.random.default_rng(7 + 2 * moving + 4 * locked + 8 * added + 16 * (end == "anchored"))
    worst, effect = 0.0, np.inf
    for _ in range(3):
        q, qd = _state(m, rng, moving)
        hg = rng.uniform(0.01, 0.08)
        if hg_kind == "complex":  # Radau IIA's h / lambda_2: the argument of 1 / (2.68 + 3.05 i)
            hg = hg * np.exp(-0.85j)
        kgeo = rng.uniform(0.0, 2.0e3, n)
        M, D, K = implicit.dense_operator(bare, q, qd, kgeo)
        Dc, Kc = _contact_reference(m, q, qd)
        D, K = D + Dc, K + Kc
        Mt = M + hg * D + hg * hg * K
        for _ in range(2):
            rd, rk = rng.normal(size=m.ndof), rng.normal(size=m.ndof)
            if hg_kind == "complex":  # (the Newton iteration's right-hand sides are complex)
                rd = rd + 1j * rng.normal(size=m.ndof)
            ref = hg * (D @ rd) + hg * (K @ rk)
            got = implicit.operator_product(m, q, qd, hg, rd, rk, kgeo)
            without = implicit.operator_product(bare, q, qd, hg, rd, rk, kgeo)
            sc = np.abs(ref).max()
            worst = max(worst, np.abs(got - ref).max() / sc)
            effect = min(effect, np.abs(without - ref).max() / sc)
            rhs = 1e3 * rng.normal(size=m.ndof)
            if hg_kind == "complex":
                rhs = rhs + 1e3j * rng.normal(size=m.ndof)
            x_ref = _dense_solve(m, q, Mt, rhs)
            x = implicit.operator_solve(m, q, qd, hg, rhs, kgeo)
            x_bare = implicit.operator_solve(bare, q, qd, hg, rhs, kgeo)
            sc = np.abs(x_ref).max()
            worst = max(worst, np.abs(x - x_ref).max() / sc)
            effect = min(effect, np.abs(x_bare - x_ref).max() / sc)
    print(f"\n{end} locked={locked} added_mass={added} moving={moving} hg {hg_kind}: O(n) vs dense "
          f"{worst:.1e} (bed's terms change it by >= {effect:.1e})")
    assert worst < TOL
    assert effect > 1e3 * TOL


@pytest.mark.parametrize("moving", [False, True])
@pytest.mark.parametrize(("end", "locked", "added"), list(_cases()))
def test_paired_solves_equal_dense(end: str, locked: bool, added: bool, moving: bool) -> None:
    """Radau IIA's Newton iteration solves its real and its complex system side by side
    (:func:`implicit.operator_solve_pair`): each answer equals the dense solve of its own
    system (the dense references of the test above), and swapping the two right-hand sides
    changes both (the sweeps do not mix the systems' rows)."""
    n = 24
    p = _params(end, locked, added, n)
    m = CableModel.from_params(p)
    bare = CableModel.from_params(p.replace(seabed=False))
    rng = np.random.default_rng(11 + 2 * moving + 4 * locked + 8 * added + 16 * (end == "anchored"))
    worst = 0.0
    for _ in range(3):
        q, qd = _state(m, rng, moving)
        h = rng.uniform(0.05, 0.3)
        hg, hgc = h / 3.6378, h / (2.6811 + 3.0504j)  # Radau IIA's h / lambda_1, h / lambda_2
        kgeo = rng.uniform(0.0, 2.0e3, n)
        M, D, K = implicit.dense_operator(bare, q, qd, kgeo)
        Dc, Kc = _contact_reference(m, q, qd)
        D, K = D + Dc, K + Kc
        rhs = 1e3 * rng.normal(size=m.ndof)
        rhsc = 1e3 * (rng.normal(size=m.ndof) + 1j * rng.normal(size=m.ndof))
        x, xc = implicit.operator_solve_pair(m, q, qd, hg, hgc, rhs, rhsc, kgeo)
        x_ref = _dense_solve(m, q, M + hg * D + hg * hg * K, rhs)
        xc_ref = _dense_solve(m, q, M + hgc * D + hgc * hgc * K, rhsc)
        worst = max(worst, np.abs(x - x_ref).max() / np.abs(x_ref).max(),
                    np.abs(xc - xc_ref).max() / np.abs(xc_ref).max())
        xs, xcs = implicit.operator_solve_pair(m, q, qd, hg, hgc, rhsc.real, rhs + 0j, kgeo)
        assert np.abs(xs - x).max() > 1e-3 * np.abs(x).max()
        assert np.abs(xcs - xc).max() > 1e-3 * np.abs(xc).max()
    print(f"\n{end} locked={locked} added_mass={added} moving={moving}: paired O(n) solves vs "
          f"dense {worst:.1e}")
    assert worst < TOL


def _positive(c0: float, c1: float, a: float, b: float) -> tuple[float, float]:
    """[a, b] intersected with {s : c0 + c1 s > 0} (empty: a == b)."""
    if c1 != 0.0:
        r = -c0 / c1
        a, b = (max(a, r), b) if c1 > 0.0 else (a, min(b, r))
    elif c0 <= 0.0:
        b = a
    return a, max(a, b)


def _interval_reference(m: CableModel, q: np.ndarray, qd: np.ndarray, horizon: float):
    """(D_c, K_c) = sum_i (c_b, k_b) int_a^b J_z^T J_z ds, assembled densely: horizon 0 over
    the part of link i the bed pushes on; else over the smallest interval [a, b] holding the
    part in the bed now and the part in the bed at q + horizon qd. Also the number of links
    where the extrapolated state widens the interval."""
    n1 = m.ndof
    p = dynamics.joint_positions(m, q)
    v = dynamics.joint_velocities(m, q, qd)
    pe = dynamics.joint_positions(m, q + horizon * qd)
    Dc = np.zeros((n1, n1))
    Kc = np.zeros((n1, n1))
    widened = 0
    P = np.zeros(n1)  # d z(p_{i-1}) / dq
    P[0] = 1.0
    for i in range(m.n):
        th, w, li = q[i + 1], qd[i + 1], m.length[i]
        d0, d1 = ZB - p[i, 1], np.cos(th)
        a, b = _positive(d0, d1, 0.0, li)
        if horizon == 0.0:  # the damper's cut
            a, b = _positive(K_B * d0 - C_B * v[i, 1], K_B * d1 - C_B * w * np.sin(th), a, b)
        ap, bp = _positive(ZB - pe[i, 1], np.cos(th + horizon * w), 0.0, li)
        if horizon > 0.0 and bp > ap and (b <= a or ap < a or bp > b):
            widened += 1
            a, b = (ap, bp) if b <= a else (min(a, ap), max(b, bp))
        if b > a:
            e = np.zeros(n1)
            e[i + 1] = np.sin(th)
            G = ((b - a) * np.outer(P, P) + (b**2 - a**2) / 2 * (np.outer(P, e) + np.outer(e, P))
                 + (b**3 - a**3) / 3 * np.outer(e, e))
            Dc += C_B * G
            Kc += K_B * G
        P[i + 1] = li * np.sin(th)
    return Dc, Kc, widened


@pytest.mark.parametrize("end", ["free", "anchored"])
def test_operator_contact_over_the_step(end: str) -> None:
    """With a horizon (the schemes pass their step h) the contact terms cover the part of each
    link in the bed now or at q + h qd (the damper's cut ignored): a link about to touch down
    or rising out of the bed is already stiff in the operator. Dense reference assembled here;
    horizon 0 reproduces the finite-difference reference of the test above."""
    n = 24
    p = _params(end, False, True, n)
    m = CableModel.from_params(p)
    bare = CableModel.from_params(p.replace(seabed=False))
    rng = np.random.default_rng(3 + (end == "anchored"))
    worst, widened = 0.0, 0
    for _ in range(4):
        q, qd = _state(m, rng, True)
        hg, horizon = 0.03, 0.4
        kgeo = rng.uniform(0.0, 2.0e3, n)
        M, D, K = implicit.dense_operator(bare, q, qd, kgeo)
        for H in (0.0, horizon):
            Dc, Kc, wide = _interval_reference(m, q, qd, H)
            widened += wide
            Dt, Kt = D + Dc, K + Kc
            rd, rk = rng.normal(size=m.ndof), rng.normal(size=m.ndof)
            ref = hg * (Dt @ rd) + hg * (Kt @ rk)
            got = implicit.operator_product(m, q, qd, hg, rd, rk, kgeo, horizon=H)
            worst = max(worst, np.abs(got - ref).max() / np.abs(ref).max())
            rhs = 1e3 * rng.normal(size=m.ndof)
            x_ref = _dense_solve(m, q, M + hg * Dt + hg * hg * Kt, rhs)
            x = implicit.operator_solve(m, q, qd, hg, rhs, kgeo, horizon=H)
            worst = max(worst, np.abs(x - x_ref).max() / np.abs(x_ref).max())
    print(f"\n{end}: O(n) with horizon vs dense {worst:.1e}, {widened} links widened")
    assert widened > 0
    assert worst < TOL
