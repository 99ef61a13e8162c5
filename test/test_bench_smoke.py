"""Smoke test of the benchmark (``cable_sim_bench --quick``) and of its MuJoCo chain.

The MJCF chain must reproduce our dense dynamics: generalised accelerations at random states,
mapped from MuJoCo's relative joint angles to our absolute angles, agree to 1e-9 relative.
"""

from __future__ import annotations

import csv
import importlib.util

import numpy as np
import pytest

from cable_sim import bench, dynamics
from cable_sim.scenes import load_scene

HAS_MUJOCO = importlib.util.find_spec("mujoco") is not None
needs_mujoco = pytest.mark.skipif(not HAS_MUJOCO,
                                  reason="mujoco not importable (optional: pip install mujoco)")


@needs_mujoco
@pytest.mark.parametrize("overrides", [
    {"n_links": 5},
    {"n_links": 9, "load_volume": 0.02, "stiffness_mode": "bending", "bending_stiffness": 800.0,
     "bending_damping": 30.0, "pin_stiffness": 0.0, "pin_damping": 0.0},
])
def test_mjcf_chain_matches_dense_dynamics(overrides):
    from cable_sim import mujoco_chain

    sc = load_scene("paper_free_fall", {**overrides, "drag_model": "none", "kernel": "dense"})
    model = sc.model()
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = rng.uniform(-1.5, 1.5, model.ndof)
        qd = rng.uniform(-2.0, 2.0, model.ndof)
        ours, _ = dynamics.forward_dynamics(model, q, qd)
        theirs = mujoco_chain.accelerations(model, q, qd)
        assert np.max(np.abs(theirs - ours)) <= 1e-9 * np.max(np.abs(ours))


@needs_mujoco
def test_mjcf_coordinate_mapping_roundtrip():
    from cable_sim import mujoco_chain

    rng = np.random.default_rng(3)
    q, qd = rng.normal(size=8), rng.normal(size=8)
    qpos, qvel = mujoco_chain.to_mujoco(q, qd)
    assert qpos[2] == pytest.approx(q[2] - q[1])
    q2, qd2 = mujoco_chain.from_mujoco(qpos, qvel)
    np.testing.assert_allclose(q2, q, atol=1e-14)
    np.testing.assert_allclose(qd2, qd, atol=1e-14)


def _read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_bench_quick(tmp_path, capsys):
    assert bench.main(["--quick", "--out", str(tmp_path)]) == 0
    for name in ("workprecision.csv", "discretisation.csv", "cost_vs_n.csv", "targets.csv", "summary.md",
                 "workprecision_paper_free_fall.png", "error_vs_n.png", "cost_vs_n.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert list((tmp_path / "cache").glob("ref_*.npz"))
    wp = _read(tmp_path / "workprecision.csv")
    assert {r["integrator"] for r in wp} == {"rk4", "rosenbrock2"}
    # every quick run succeeds and its error shrinks with the step (rk4: order 4, ros2: order 2)
    for scene in ("paper_free_fall", "paper_anchored_forced"):
        for integ in ("rk4", "rosenbrock2"):
            rr = sorted((r for r in wp if r["scene"] == scene and r["integrator"] == integ and r["n"] == "8"),
                        key=lambda r: -float(r["step"]))
            assert [r["status"] for r in rr] == ["ok"] * 3
            errs = [float(r["error_m"]) for r in rr]
            assert errs[0] > errs[1] > errs[2] > 0, (scene, integ, errs)
            # step 4x smaller: rk4 (order 4) ~256x, rosenbrock2 (order 2) ~16x smaller error
            assert errs[0] / errs[2] > (100 if integ == "rk4" else 10), (scene, integ, errs)
    targets = _read(tmp_path / "targets.csv")
    assert any("n=80" in r["target"] for r in targets)
    assert "### Targets" in (tmp_path / "summary.md").read_text()
    if HAS_MUJOCO:
        mj = _read(tmp_path / "mujoco.csv")
        rk = [r for r in mj if r["integrator"] == "RK4"][0]
        ours = [r for r in mj if r["integrator"] == "rk4"][0]
        # same model, same scheme, same step: the two RK4 trajectories agree with our reference
        assert rk["status"] == "ok" and float(rk["error_m"]) < 1e-6
        assert float(ours["error_m"]) < 1e-6
    # a second run reuses the cached references
    capsys.readouterr()
    assert bench.main(["--quick", "--out", str(tmp_path), "--no-mujoco"]) == 0
    assert "reference paper_free_fall_n8" not in capsys.readouterr().err
