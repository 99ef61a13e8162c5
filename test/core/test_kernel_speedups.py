"""The compiled kernel's fast paths: the packed per-link constants, the forward dynamics with
the links' cos/sin supplied, the Morison drag in the link frame, and the check that takes the
links' cos/sin (and recomputes them after the anchor's projection).

References are independent of the path under test: numpy's own products for the constants,
the dense O(n^3) forward dynamics (:mod:`cable_sim.core.dynamics`) for the accelerations,
numpy's cos/sin for the trig.
"""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core import dynamics
from cable_sim.core.kernel.checks import STATUS_OK, check_packed_ws
from cable_sim.core.kernel.forward import fd_packed_ws, fd_trig, fd_workspace
from cable_sim.core.kernel.links import morison_drag
from cable_sim.core.kernel.packing import ARR_MK, pack_arrays
from cable_sim.core.kernel.sweeps import MK_ROWS
from cable_sim.scene.scenes import load_scene


def _model(scene: str, n: int, **overrides):
    return load_scene(scene, overrides or None).with_links(n).model()


@pytest.mark.parametrize("scene", ["paper_free_fall", "mooring_line"])
def test_packed_link_constants(scene: str) -> None:
    model = _model(scene, 9)
    arr, _ = pack_arrays(model)
    mk = arr[ARR_MK:ARR_MK + MK_ROWS]
    l = np.asarray(model.length, dtype=float)
    mn = np.asarray(model.mass + model.added_mass_normal * model.length, dtype=float)
    me = np.asarray(model.mass + model.added_mass_axial * model.length, dtype=float)
    want = [mn / 3.0, mn / 4.0, mn / 6.0, mn / 2.0, 1.0 / l**2, me / 2.0, l**2]
    for row, w in zip(mk, want, strict=True):
        np.testing.assert_allclose(row, w, rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("scene", ["paper_free_fall", "mooring_line"])
def test_fd_with_trig_supplied_matches_dense(scene: str) -> None:
    """trig_ready: the caller's cos/sin in the workspace rows are used as they are."""
    n = 7
    model = _model(scene, n)
    arr, par = pack_arrays(model)
    rng = np.random.default_rng(3)
    q = np.concatenate([[0.3], rng.uniform(0.2, 1.3, n)])
    qd = rng.normal(size=n + 1)
    ws = fd_workspace(n)
    ws[:] = np.nan
    cth, sth = fd_trig(ws, n)
    cth[:] = np.cos(q[1:])
    sth[:] = np.sin(q[1:])
    qdd, lam = np.empty(n + 1), np.empty(2)
    assert fd_packed_ws(arr, par, 0.0, 0.0, q, qd, qdd, lam, ws, True)
    qdd_ref, lam_ref = dynamics.forward_dynamics(model, q, qd)
    scale = np.max(np.abs(qdd_ref))
    np.testing.assert_allclose(qdd, qdd_ref, rtol=0.0, atol=1e-8 * scale)
    np.testing.assert_allclose(lam, lam_ref, rtol=1e-8, atol=1e-8 * max(np.max(np.abs(lam_ref)), 1.0))


@pytest.mark.parametrize(("scene", "overrides", "heavy"), [
    ("paper_free_fall", {}, False),  # 60 kg load under a 148 kg line
    ("paper_free_fall", {"load_mass": 500.0}, True),
    ("paper_anchored_forced", {"end_condition": "paper_anchor"}, True),  # 8e8 kg
    ("mooring_line", {}, False),  # anchored: the Schur complement instead
])
def test_packed_woodbury_choice(scene: str, overrides: dict, heavy: bool) -> None:
    """The Woodbury choice packed once per model (``par[20]``): a free end whose load outweighs
    the line (the forward dynamics of both forms is compared with the dense reference in
    ``test_fast_kernel``)."""
    n = 8
    model = _model(scene, n, **overrides)
    _, par = pack_arrays(model)
    assert (par[20] != 0.0) == heavy
    assert heavy == (not model.constrained and model.load_mass > float(np.sum(model.mass)))


@pytest.mark.parametrize("current", [0.0, 0.7])
def test_morison_drag_matches_dense(current: float) -> None:
    """The link-frame Morison force (no square root) against the dense per-link forces
    (``hypot`` of the normal part), on states with nearly axial and nearly normal flow."""
    n = 12
    model = _model("paper_free_fall", n, drag_model="morison", current_speed=current)
    arr, par = pack_arrays(model)
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = np.concatenate([[0.1], rng.uniform(-3.0, 3.0, n)])
        qd = rng.normal(scale=2.0, size=n + 1)
        fx = np.full(n, 1.5)  # added to: start from a known value
        fz = np.full(n, -2.0)
        morison_drag(arr[0], arr[6], arr[7], par[0], qd, np.cos(q[1:]), np.sin(q[1:]), fx, fz,
                     np.empty(n), np.empty(n))
        want = dynamics.link_drag_forces(model, q, qd)
        scale = np.max(np.abs(want))
        assert scale > 1.0
        np.testing.assert_allclose(fx - 1.5, want[:, 0], rtol=0.0, atol=1e-12 * scale)
        np.testing.assert_allclose(fz + 2.0, want[:, 1], rtol=0.0, atol=1e-12 * scale)


@pytest.mark.parametrize("drag", ["morison", "paper", "none"])
def test_fd_drag_models_match_dense(drag: str) -> None:
    """The forward dynamics with each drag model against the dense reference."""
    n = 9
    model = _model("paper_free_fall", n, drag_model=drag, current_speed=0.3)
    arr, par = pack_arrays(model)
    rng = np.random.default_rng(5)
    q = np.concatenate([[0.2], rng.uniform(0.1, 2.0, n)])
    qd = rng.normal(size=n + 1)
    qdd, lam = np.empty(n + 1), np.empty(2)
    assert fd_packed_ws(arr, par, 0.0, 0.0, q, qd, qdd, lam, fd_workspace(n))
    qdd_ref, _ = dynamics.forward_dynamics(model, q, qd)
    np.testing.assert_allclose(qdd, qdd_ref, rtol=0.0, atol=1e-9 * np.max(np.abs(qdd_ref)))


def test_check_recomputes_trig_after_projection() -> None:
    """Anchored end: the check projects y; on return the trig is that of the projected y."""
    n = 6
    model = _model("mooring_line", n)
    arr, par = pack_arrays(model)
    assert par[10] != 0.0  # anchored
    # a state on the constraint (the scene's initial one), then nudged off it
    y0 = np.asarray(load_scene("mooring_line").with_links(n).initial_state(model), dtype=float)
    y = y0.copy()
    y[1:n + 1] += 1e-7
    chk = np.array([1e9, -np.inf, 1e-12, np.inf, 0.0, np.inf, np.nan, np.inf])
    info = np.zeros(4)
    cth = np.full(n, np.nan)
    sth = np.full(n, np.nan)
    status = check_packed_ws(arr, par, y, chk, info, cth, sth)
    assert status == STATUS_OK
    assert np.max(np.abs(y[1:n + 1] - (y0[1:n + 1] + 1e-7))) > 0.0  # projected
    np.testing.assert_allclose(cth, np.cos(y[1:n + 1]), rtol=0.0, atol=1e-14)
    np.testing.assert_allclose(sth, np.sin(y[1:n + 1]), rtol=0.0, atol=1e-14)
