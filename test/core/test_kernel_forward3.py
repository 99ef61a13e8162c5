"""The three-state forward dynamics :func:`cable_sim.core.kernel.forward3.fd3_packed_ws` (Radau
IIA's stage evaluations side by side) against the dense reference solver
(:func:`cable_sim.core.dynamics.forward_dynamics`), state by state, at three different random
states with different inputs per call: every end condition, drag model and heave lock of the
kernel's own test, a heavy free load (Woodbury path) and the seabed with added mass. Also what
the Radau step relies on: each workspace is left holding its state's link cos/sin.
"""

from __future__ import annotations

import numpy as np
import pytest
from kernel_models import make_model

from cable_sim.core import dynamics as dense
from cable_sim.core.dynamics import Inputs
from cable_sim.core.kernel.forward import fd_trig, fd_workspace
from cable_sim.core.kernel.forward3 import fd3_packed_ws
from cable_sim.core.kernel.packing import pack_arrays
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams

RTOL = 1e-9  # as the single-state kernel's test against the same reference


def _three_states(model: CableModel, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                         np.ndarray]:
    rng = np.random.default_rng(seed)
    k = model.ndof
    q = np.column_stack([rng.normal(size=3), rng.uniform(-1.4, 1.4, (3, k - 1))])
    qd = rng.normal(size=(3, k))
    return q, qd, 2.0e4 * rng.normal(size=3), rng.normal(size=3)


def _check(model: CableModel, seed: int) -> None:
    arr, par = pack_arrays(model)
    q, qd, u, eta = _three_states(model, seed)
    ws = [fd_workspace(model.n) for _ in range(3)]
    qdd = np.full((3, model.ndof), np.nan)
    lam = np.full(2, np.nan)
    assert fd3_packed_ws(arr, par, u, eta, q, qd, qdd, lam, *ws)
    for k in range(3):
        ref, ref_lam = dense.forward_dynamics(model, q[k], qd[k], Inputs(u[k], eta[k]))
        err = np.linalg.norm(qdd[k] - ref) / np.linalg.norm(ref)
        assert err <= RTOL, (k, err)
        cth, sth = fd_trig(ws[k], model.n)
        np.testing.assert_allclose(cth, np.cos(q[k, 1:]), rtol=0, atol=1e-14)
        np.testing.assert_allclose(sth, np.sin(q[k, 1:]), rtol=0, atol=1e-14)
    # the anchor reaction is the last state's (zero at a free end)
    np.testing.assert_allclose(lam, ref_lam, rtol=RTOL, atol=RTOL * np.abs(ref_lam).max())


@pytest.mark.parametrize("n", [1, 2, 5, 17, 60])
@pytest.mark.parametrize("end", ["free", "anchored"])
@pytest.mark.parametrize("drag", ["none", "paper", "morison"])
@pytest.mark.parametrize("locked", [False, True])
def test_three_states_match_dense(n: int, end: str, drag: str, locked: bool) -> None:
    if end == "anchored" and n + (0 if locked else 1) - 2 < 1:
        pytest.skip("no free degree of freedom (refused by CableParams)")
    _check(make_model(n, end, drag, locked), 131 * n + 7 * locked + len(drag))


@pytest.mark.parametrize("n", [2, 17])
def test_heavy_free_load_matches_dense(n: int) -> None:
    model = make_model(n, "free", "morison", False)
    model = CableModel.from_params(model.params.replace(load_mass=3000.0, load_volume=0.2))
    assert model.load_mass > model.mass.sum()
    _check(model, 99 + n)


@pytest.mark.parametrize("end", ["free", "anchored"])
def test_seabed_and_added_mass_match_dense(end: str) -> None:
    zb = -20.0
    p = CableParams(
        n_links=25, total_length=40.0, diameter=0.1, mass_per_length=50.0, drag_model="morison",
        stiffness_mode="bending", bending_stiffness=30.0, bending_damping=10.0,
        end_condition=end, anchor_x=25.0, anchor_z=zb - 0.5, load_mass=20.0, seabed=True,
        seabed_depth=zb, seabed_stiffness=3.0e4, seabed_damping=2.0e3, added_mass=True,
        added_mass_cn=1.0, added_mass_ct=0.3)
    model = CableModel.from_params(p)
    arr, par = pack_arrays(model)
    rng = np.random.default_rng(5 + (end == "anchored"))
    th = np.where(np.arange(model.n) < model.n // 2, 0.9, 1.9) + rng.normal(0.0, 0.15, (3, model.n))
    q = np.column_stack([zb + rng.uniform(4.0, 9.0, 3), th])
    qd = rng.normal(0.0, 0.3, (3, model.ndof))
    u = rng.normal(0.0, 1e3, 3)
    eta = rng.normal(0.0, 0.5, 3)
    qdd = np.empty((3, model.ndof))
    ws = [fd_workspace(model.n) for _ in range(3)]
    assert fd3_packed_ws(arr, par, u, eta, q, qd, qdd, np.empty(2), *ws)
    touching = 0
    for k in range(3):
        ref, _ = dense.forward_dynamics(model, q[k], qd[k], Inputs(u[k], eta[k]))
        assert np.abs(qdd[k] - ref).max() <= RTOL * np.abs(ref).max()
        touching += bool(np.abs(dense.seabed_force(model, q[k], qd[k])).max() > 0)
    assert touching >= 2  # the contact terms are exercised
