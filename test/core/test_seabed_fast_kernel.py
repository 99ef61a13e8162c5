"""Issue 11, item 4: the O(n) kernel = the dense reference with seabed contact (damping and
friction on) and added mass, at random states: accelerations, anchor force, joint forces and
energy to 1e-9 of their scale; the added-mass and seabed terms are really exercised (they change
the accelerations by far more than the tolerance). Free and anchored ends, heave free and locked.
"""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core import dynamics
from cable_sim.core import kernel as fast
from cable_sim.core.dynamics import Inputs
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

ZB = -20.0


def _params(end: str, locked: bool, n: int) -> CableParams:
    return CableParams(
        n_links=n, total_length=40.0, diameter=0.1, mass_per_length=50.0, drag_model="morison",
        stiffness_mode="bending", bending_stiffness=30.0, bending_damping=10.0, heave_locked=locked,
        end_condition=end, anchor_x=25.0, anchor_z=ZB - 0.5, load_mass=20.0, seabed=True,
        seabed_depth=ZB, seabed_stiffness=3.0e4, seabed_damping=2.0e3, seabed_friction_axial=0.4,
        seabed_friction_transverse=0.9, seabed_friction_speed=0.05, added_mass=True,
        added_mass_cn=1.0, added_mass_ct=0.3)


def _state(m: CableModel, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    th = np.where(np.arange(m.n) < m.n // 2, 1.2, 1.9) + rng.normal(0.0, 0.15, m.n)
    q = np.concatenate([[ZB + rng.uniform(4.0, 9.0)], th])
    return q, rng.normal(0.0, 0.3, m.ndof)


@pytest.mark.parametrize("end,locked", [("free", False), ("free", True), ("anchored", False),
                                        ("anchored", True)])
@pytest.mark.parametrize("n", [4, 25])
def test_fast_equals_dense_with_seabed_and_added_mass(end: str, locked: bool, n: int) -> None:
    rng = np.random.default_rng(n + 10 * locked + 100 * (end == "anchored"))
    p = _params(end, locked, n)
    m = CableModel.from_params(p)
    plain = CableModel.from_params(p.replace(seabed=False, added_mass=False))
    worst, effect, touching = 0.0, 0.0, 0
    for _ in range(10):
        q, qd = _state(m, rng)
        inp = Inputs(heave_force=rng.normal(0, 1e3), wave_elevation=rng.normal(0, 0.5))
        a_d, l_d = dynamics.forward_dynamics(m, q, qd, inp)
        a_f, l_f = fast.forward_dynamics(m, q, qd, inp)
        sc = np.abs(a_d).max()
        worst = max(worst, np.abs(a_f - a_d).max() / sc)
        if end == "anchored":
            worst = max(worst, np.abs(l_f - l_d).max() / np.abs(l_d).max())
        F_d = dynamics.joint_forces(m, q, qd, a_d, l_d)
        F_f = fast.joint_forces(m, q, qd, a_d, l_d)
        worst = max(worst, np.abs(F_f - F_d).max() / np.abs(F_d).max())
        T, V = fast.energy(m, q, qd)
        worst = max(worst, abs(T - dynamics.kinetic_energy(m, q, qd)) / abs(T),
                    abs(T + V - dynamics.total_energy(m, q, qd)) / (abs(T) + abs(V)))
        effect = max(effect, np.abs(dynamics.forward_dynamics(plain, q, qd, inp)[0] - a_d).max() / sc)
        touching += bool(np.abs(dynamics.seabed_force(m, q, qd)).max() > 0)
    print(f"{end}, locked={locked}, n={n}: max relative difference fast - dense {worst:.2e}; the "
          f"new terms change qdd by {effect:.2e}; {touching}/10 states touch the bed")
    assert worst < 1e-9
    assert effect > 1e-3 and touching >= 3


def test_terms_off_fast_kernel_is_unchanged() -> None:
    """Off (default), however their parameters are set, the compiled kernel gives identical bits."""
    base = CableModel.from_params(CableParams(n_links=12, drag_model="morison"))
    other = CableModel.from_params(CableParams(n_links=12, drag_model="morison", seabed_depth=-10.0,
                                               added_mass_cn=2.0, seabed_stiffness=1e6))
    rng = np.random.default_rng(1)
    q, qd = rng.normal(size=13), rng.normal(size=13)
    a0, _ = fast.forward_dynamics(base, q, qd)
    a1, _ = fast.forward_dynamics(other, q, qd)
    assert np.array_equal(a0, a1)


@pytest.mark.parametrize("end", ["free", "anchored"])
def test_implicit_operator_includes_added_mass(end: str) -> None:
    """The O(n) implicit operator M~ = M + hg D + hg^2 K solves with M including the added-mass
    matrix M_a (the dense operator's M): backward error at round-off."""
    from cable_sim.integrate import implicit

    p = _params(end, False, 17).replace(seabed=False)
    model = CableModel.from_params(p)
    rng = np.random.default_rng(5)
    q, qd = _state(model, rng)
    hg, rhs = 0.05, 100.0 * rng.normal(size=model.ndof)
    x = implicit.operator_solve(model, q, qd, hg, rhs)
    M, D, K = implicit.dense_operator(model, q, qd)
    assert np.abs(M - dynamics.mass_matrix(model, q)).max() > 1.0  # M_a is in it
    Mt = M + hg * D + hg * hg * K
    r = Mt @ x - rhs
    if model.constrained:
        J = dynamics.constraint_jacobian(model, q)
        r = r + J.T @ np.linalg.lstsq(J.T, -r, rcond=None)[0]
    backward = np.linalg.norm(r) / (np.linalg.norm(Mt) * np.linalg.norm(x))
    print(f"{end}: backward error of the O(n) operator solve with added mass {backward:.1e}")
    assert backward < 1e-10
