"""Smoke test of the benchmark (``cable_sim_bench --quick``) and of its MuJoCo chain.

- The quick bench runs every integrator ``make_integrator`` offers, writes the CSVs with the
  expected columns and finite values, the plots, the targets and the summary, and reuses its
  cached references on a second run.
- The bench's compiled timing path reproduces ``Integrator.advance`` exactly (same steps, same
  inputs), so what is timed is what the simulator computes.
- The MJCF chain reproduces our dense dynamics: generalised accelerations at random states,
  mapped from MuJoCo's relative joint angles to our absolute angles, agree to 1e-9 relative
  (skipped only when ``mujoco`` is not installed).
"""

from __future__ import annotations

import csv
import importlib.util
import math

import numpy as np
import pytest

from cable_sim.analysis import bench
from cable_sim.core import dynamics
from cable_sim.scene.scenes import load_scene

HAS_MUJOCO = importlib.util.find_spec("mujoco") is not None
needs_mujoco = pytest.mark.skipif(not HAS_MUJOCO,
                                  reason="mujoco not importable (optional: pip install mujoco)")

WP_COLUMNS = {"scene", "n", "kernel", "integrator", "kind", "step", "rtol", "duration", "status", "wall",
              "wall_inputs", "cost", "rtf", "rtf_incl_inputs", "us_per_step", "nfev", "error_m",
              "reference", "ref_err_est", "timing"}
MJ_COLUMNS = {"engine", "integrator", "n", "step", "duration", "status", "repeats", "wall", "rtf",
              "us_per_step", "us_per_step_python_loop", "speed_vs_mujoco_rk4", "error_m"}


@needs_mujoco
@pytest.mark.parametrize("overrides", [
    {"n_links": 5},
    {"n_links": 9, "load_volume": 0.02, "stiffness_mode": "bending", "bending_stiffness": 800.0,
     "bending_damping": 30.0, "pin_stiffness": 0.0, "pin_damping": 0.0},
])
def test_mjcf_chain_matches_dense_dynamics(overrides):
    from cable_sim.analysis.bench import mujoco_chain

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
    from cable_sim.analysis.bench import mujoco_chain

    rng = np.random.default_rng(3)
    q, qd = rng.normal(size=8), rng.normal(size=8)
    qpos, qvel = mujoco_chain.to_mujoco(q, qd)
    assert qpos[2] == pytest.approx(q[2] - q[1])
    q2, qd2 = mujoco_chain.from_mujoco(qpos, qvel)
    np.testing.assert_allclose(q2, q, rtol=0, atol=1e-12)  # O(1) values: 1e4 x round-off of the sums
    np.testing.assert_allclose(qd2, qd, rtol=0, atol=1e-12)


def test_bench_picks_up_every_integrator():
    names = bench.available_integrators()
    for name in ("rk4", "symplectic_euler", "dop853", "radau"):
        assert name in names
    assert bench.is_adaptive("dop853") and bench.is_adaptive("radau") and not bench.is_adaptive("rk4")
    try:
        from cable_sim.integrate import implicit
    except ImportError:
        return
    assert set(implicit.INTEGRATORS) <= set(names)


@pytest.mark.parametrize("scene,integ", [("paper_anchored_forced", "rk4"),
                                         ("paper_anchored_forced", "rosenbrock2"),
                                         ("paper_free_fall", "symplectic_euler")])
def test_timed_path_equals_advance(scene, integ):
    if bench.pick_kernel()[0] != "fast" or integ not in bench.available_integrators():
        pytest.skip("no compiled stepper here")
    a = bench.simulate(scene, 6, integ, 0.0125, 1.0, compiled_timing=True)
    b = bench.simulate(scene, 6, integ, 0.0125, 1.0, compiled_timing=False)
    assert a.ok and b.ok
    assert a.timing.startswith("compiled") and b.timing.startswith("Integrator.advance")
    np.testing.assert_array_equal(a.pos, b.pos)  # same kernel, same steps, same inputs
    assert a.wall > 0 and a.wall_inputs > 0


def _read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_bench_quick(tmp_path, capsys):
    assert bench.main(["--quick", "--out", str(tmp_path), "--no-contact", "--no-moordyn"]) == 0
    for name in ("workprecision.csv", "discretisation.csv", "cost_vs_n.csv", "targets.csv", "summary.md",
                 "workprecision_paper_free_fall.png", "workprecision_paper_anchored_forced.png",
                 "error_vs_n.png", "cost_vs_n.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert list((tmp_path / "cache").glob("ref_*.npz"))
    wp = _read(tmp_path / "workprecision.csv")
    assert WP_COLUMNS <= set(wp[0])
    assert {r["integrator"] for r in wp} == set(bench.available_integrators())
    assert {r["kernel"] for r in wp} == {bench.pick_kernel()[0]}
    assert {float(r["duration"]) for r in wp} == {2.0}
    for r in wp:  # every quick run succeeds, with finite, positive cost and error
        assert r["status"] == "ok", r
        for key in ("wall", "cost", "rtf", "rtf_incl_inputs", "error_m"):
            v = float(r[key])
            assert math.isfinite(v) and v >= 0, (key, r)
        assert float(r["wall"]) > 0 and int(r["nfev"]) > 0
        assert math.isfinite(float(r["step"] if r["kind"] == "fixed" else r["rtol"]))
    # the error shrinks with the step / tolerance (rk4 order 4, rosenbrock2 order 2, DOP853)
    for scene in ("paper_free_fall", "paper_anchored_forced"):
        for integ, ratio in (("rk4", 100), ("rosenbrock2", 10), ("dop853", 10)):
            rr = [r for r in wp if r["scene"] == scene and r["integrator"] == integ and r["n"] == "8"]
            if not rr:
                assert integ != "rk4"
                continue
            errs = [float(r["error_m"]) for r in rr]  # ladder order: coarse to fine
            assert len(errs) == 3 and errs[0] > errs[1] > errs[2] > 0, (scene, integ, errs)
            # rk4: step 4x smaller ~256x; rosenbrock2 ~16x; DOP853: tolerance 1e4x tighter
            assert errs[0] / errs[2] > ratio, (scene, integ, errs)
    disc = _read(tmp_path / "discretisation.csv")
    assert {"tip_error_m", "midline_error_m", "tension_rel_error"} <= set(disc[0])
    coarse = [r for r in disc if r["n"] == "4"]
    assert len(coarse) == 2 and all(float(r["tension_rel_error"]) > 0 for r in coarse)
    targets = _read(tmp_path / "targets.csv")
    assert {"target", "measured", "goal", "met", "detail"} <= set(targets[0])
    assert any("n=80" in r["target"] for r in targets) and any("n=2000" in r["target"] for r in targets)
    assert all(r["met"] == "False" for r in targets)  # nothing at n = 80 / 2000 in --quick
    assert "### Targets" in (tmp_path / "summary.md").read_text()
    if HAS_MUJOCO:
        mj = _read(tmp_path / "mujoco.csv")
        assert MJ_COLUMNS <= set(mj[0])
        rk = next(r for r in mj if r["integrator"] == "RK4")
        ours = next(r for r in mj if r["integrator"] == "rk4")
        # same model, same scheme, same step: both RK4 trajectories match our DOP853 reference
        assert rk["status"] == "ok" and float(rk["error_m"]) < 1e-6
        assert ours["status"] == "ok" and float(ours["error_m"]) < 1e-6
        for r in mj:
            assert r["status"] == "ok" and float(r["wall"]) > 0 and math.isfinite(float(r["rtf"])), r
    # a second run reuses the cached references, and with --resume the measured rows
    capsys.readouterr()
    first = tmp_path / "first.csv"
    (tmp_path / "workprecision.csv").rename(first)
    assert bench.main(["--quick", "--out", str(tmp_path), "--no-mujoco", "--no-contact", "--no-moordyn",
                       "--resume", str(first)]) == 0
    err = capsys.readouterr().err
    assert "reference paper_free_fall_n8" not in err and "taken from" in err
    again = _read(tmp_path / "workprecision.csv")
    assert len(again) == len(wp) and {r["source"] for r in again} == {str(first)}
    assert [r["error_m"] for r in again] == [r["error_m"] for r in wp]


def test_bench_quick_runs_contact_and_moordyn_studies(tmp_path, capsys):
    """The seabed-cost study and the MoorDyn peer are steps of the same invocation: their CSVs,
    plots and summary sections (the MoorDyn ones only with moordyn installed; without it the
    bench says why)."""
    argv = ["--quick", "--out", str(tmp_path), "--scenes", "paper_free_fall", "--n", "4",
            "--integrators", "rk4", "--no-mujoco"]
    assert bench.main(argv) == 0
    for name in ("contact_cost.csv", "contact_cost_ladder.csv", "contact_cost.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    chosen = _read(tmp_path / "contact_cost.csv")
    assert {(r["integrator"], r["seabed"]) for r in chosen} == {("rk4", "on"), ("rk4", "off")}
    summary = (tmp_path / "summary.md").read_text()
    assert "### Cost of seabed contact" in summary
    from cable_sim.analysis.bench.moordyn_run import moordyn_version

    if moordyn_version() is None:
        assert "moordyn not importable" in capsys.readouterr().err
        assert not (tmp_path / "moordyn.csv").exists()
    else:
        peer = _read(tmp_path / "moordyn.csv")
        assert [r["code"].split()[0] for r in peer] == ["cable_sim", "moordyn"]
        assert (tmp_path / "moordyn_tension.png").stat().st_size > 0
        assert "### MoorDyn as a second peer" in summary
        # the two converged answers of the same line agree to a few per cent
        assert abs(float(peer[1]["static_rel_diff_vs_cable_sim"])) < 0.03


def test_bench_rejects_unknown_integrator(tmp_path, capsys):
    assert bench.main(["--quick", "--out", str(tmp_path), "--integrators", "euler_maruyama"]) == 2
    err = capsys.readouterr().err
    assert "euler_maruyama" in err and "rk4" in err
