"""The generated URDF (cable_sim.ros.urdf) read by an independent URDF library, and its TF.

References: yourdfpy (a separately written URDF parser with its own forward kinematics) for the
description; MODEL.md's joint positions p_k (cable_sim.core.dynamics.joint_positions, which the
node publishes as the cable polyline) for the geometry; scipy's Rotation for composing the
transforms of ``tf_transforms``; the JointState the node builds (cable_sim.ros.messages) for the
joint names and values; ``conftest.RefLine`` (masses from the parameters alone) for the inertials.
Tolerance 1e-9 m on a 240-300 m line: round-off is ~1e-13 m, a wrong sign or offset is metres.
"""

from __future__ import annotations

import dataclasses
import io
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from conftest import RefLine
from scipy.spatial.transform import Rotation

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.ros.messages import build_joint_state
from cable_sim.ros.urdf import static_transforms, tf_transforms, urdf_for_model, urdf_for_scene
from cable_sim.ros.urdf_cli import build_urdf, main
from cable_sim.scene.scenes import available_scenes, load_scene
from cable_sim.scene.simulation import Simulation

TOL = 1e-9
ROTATIONAL = ("revolute", "continuous")


def _load(text: str) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(io.StringIO(text), build_scene_graph=True, load_meshes=False)


def _set_cfg(robot: yourdfpy.URDF, names, positions) -> None:
    """Set a joint configuration. yourdfpy keeps its kinematics in a trimesh scene graph, which
    ignores an edge update that changes the transform by less than 1e-8 (trimesh
    EnforcedForest.add_edge); relative angles of 1e-9 rad occur in a nearly straight line, so
    every joint is first moved 1 m / 1 rad away, then set."""
    cfg = dict(zip(names, positions, strict=True))
    robot.update_cfg({k: v + 1.0 for k, v in cfg.items()})
    robot.update_cfg(cfg)
    assert np.array_equal(robot.cfg, np.asarray(positions, dtype=float))


def _fk_points(robot: yourdfpy.URDF, n: int) -> np.ndarray:
    """(x, y, z) of the fairlead and the lower end of every link, by yourdfpy's kinematics."""
    frames = [f"link_{i + 1}" for i in range(n)] + ["cable_end"]
    return np.array([robot.get_transform(f, "world")[:3, 3] for f in frames])


def _planar(p: np.ndarray) -> np.ndarray:
    """(x, z) polyline as (x, 0, z)."""
    return np.column_stack([p[:, 0], np.zeros(len(p)), p[:, 1]])


@pytest.fixture(scope="module", params=available_scenes())
def running(request):
    """A shipped scene simulated headless for 0.2 s (its own integrator and step, the dense
    kernel: no compilation): the simulation, its outputs and the JointState the node would publish."""
    sim = Simulation(load_scene(request.param), kernel="dense")
    sim.run_until(0.2)
    out = sim.outputs()
    return sim, out, build_joint_state(out, 0)


def _bent(out, seed: int = 3):
    """The outputs with every absolute angle moved by up to +-1 rad (a line hanging straight down
    would not test the sign of the joint axis)."""
    rng = np.random.default_rng(seed)
    q = out.q.copy()
    q[1:] += rng.uniform(-1.0, 1.0, len(q) - 1)
    return dataclasses.replace(out, q=q)


def test_every_shipped_scene_is_covered() -> None:
    assert len(available_scenes()) >= 4
    assert {"mooring_line", "paper_free_fall", "paper_anchored_forced"} <= set(available_scenes())


def test_yourdfpy_forward_kinematics_reproduces_the_polyline(running) -> None:
    """At the simulated state and at a bent one (JointState built as the node builds it)."""
    sim, out, js = running
    robot = _load(urdf_for_model(sim.model, sim.scene.name))
    assert robot.validate()
    for state in (out, _bent(out)):
        msg = build_joint_state(state, 0)
        _set_cfg(robot, msg.name, msg.position)
        ref = _planar(dynamics.joint_positions(sim.model, state.q))
        err = np.abs(_fk_points(robot, sim.model.n) - ref).max()
        assert err < TOL, f"{sim.scene.name}: URDF forward kinematics off the polyline by {err:.3g} m"
    assert np.ptp(ref[:, 0]) > 1.0  # the bent line is not a trivial vertical one


def test_joint_names_and_count_equal_joint_states(running) -> None:
    sim, _, js = running
    robot = _load(urdf_for_scene(sim.scene))
    moving = [j for j in robot.robot.joints if j.type != "fixed"]
    assert [j.name for j in moving] == list(js.name)
    assert robot.actuated_joint_names == list(js.name)
    assert [j.type for j in moving] == ["prismatic"] + ["continuous"] * sim.model.n
    assert moving[0].axis.tolist() == [0.0, 0.0, 1.0]
    assert all(np.allclose(j.axis, [0.0, -1.0, 0.0]) for j in moving[1:])


def test_inertials_and_shapes_follow_the_scene(running) -> None:
    sim, _, _ = running
    p = sim.scene.params
    ref = RefLine(p)
    robot = _load(urdf_for_scene(sim.scene))
    links = robot.link_map
    for i in range(p.n_links):
        link = links[f"link_{i + 1}"]
        l, d, m = ref.l[i], ref.d[i], ref.m[i]
        assert link.inertial.mass == pytest.approx(m, rel=1e-12)
        assert link.inertial.origin[:3, 3] == pytest.approx([0, 0, -l / 2], abs=1e-12)
        assert np.diag(link.inertial.inertia) == pytest.approx([m * l * l / 12, m * l * l / 12,
                                                                m * d * d / 8], rel=1e-12)
        for shape in (link.visuals[0], link.collisions[0]):
            assert shape.geometry.cylinder.length == pytest.approx(l, rel=1e-12)
            assert shape.geometry.cylinder.radius == pytest.approx(d / 2, rel=1e-12)
            assert shape.origin[:3, 3] == pytest.approx([0, 0, -l / 2], abs=1e-12)
    assert links["platform"].inertial.mass == pytest.approx(p.platform_mass)
    if p.end_condition == "anchored":
        assert "load" not in links and "anchor" in links
        assert robot.get_transform("anchor", "world")[:3, 3] == pytest.approx(
            [p.anchor_x, 0, p.anchor_z], abs=1e-12)
    else:
        mc = p.load_mass if p.end_condition == "free" else p.paper_anchor_mass
        assert links["load"].inertial.mass == pytest.approx(mc)
        assert links["load"].visuals[0].geometry.sphere is not None
    assert robot.get_transform("fairlead", "platform") == pytest.approx(np.eye(4), abs=1e-15)


def _chain(transforms) -> dict[str, np.ndarray]:
    """World pose (4x4) of every child frame, composed with scipy's Rotation (in any order, as a
    TF listener would; each frame has one parent)."""
    assert len({c for _, c, *_ in transforms}) == len(transforms), "a frame with two parents"
    pose = {"world": np.eye(4)}
    todo = list(transforms)
    while todo:
        ready = [tf for tf in todo if tf[0] in pose]
        assert ready, f"frames not connected to world: {[tf[1] for tf in todo]}"
        for parent, child, t, qxyzw in ready:
            T = np.eye(4)
            T[:3, :3] = Rotation.from_quat(qxyzw).as_matrix()
            T[:3, 3] = t
            pose[child] = pose[parent] @ T
            todo.remove((parent, child, t, qxyzw))
    return pose


def test_tf_transforms_chained_reproduce_the_polyline(running) -> None:
    sim, out, _ = running
    out = _bent(out, seed=5)
    js = build_joint_state(out, 0)
    n = sim.model.n
    tfs = tf_transforms(sim.model, js.position)
    assert all(abs(np.linalg.norm(q) - 1) < 1e-14 for *_, q in tfs)
    pose = _chain(tfs)
    pts = np.array([pose[f][:3, 3] for f in [f"link_{i + 1}" for i in range(n)] + ["cable_end"]])
    err = np.abs(pts - _planar(dynamics.joint_positions(sim.model, out.q))).max()
    assert err < TOL, f"{sim.scene.name}: tf chain off the polyline by {err:.3g} m"
    # the same frames as the URDF, and the same poses as yourdfpy's kinematics
    robot = _load(urdf_for_scene(sim.scene))
    assert set(pose) == set(robot.link_map)
    _set_cfg(robot, js.name, js.position)
    for frame, T in pose.items():
        assert np.abs(robot.get_transform(frame, "world") - T).max() < TOL, frame
    moving = tf_transforms(sim.model, js.position, include_fixed=False)
    assert [c for _, c, *_ in moving] == ["platform"] + [f"link_{i + 1}" for i in range(n)]
    assert sorted(moving + static_transforms(sim.model)) == sorted(tfs)


def test_random_states_uneven_links_and_wound_up_angles() -> None:
    """Absolute angles beyond +-pi and per-link lengths: FK still equals MODEL.md's p_k."""
    rng = np.random.default_rng(7)
    lengths = tuple(rng.uniform(2.0, 9.0, 6))
    model = CableModel.from_params(CableParams(n_links=6, link_lengths=lengths, diameter=0.05))
    robot = _load(urdf_for_model(model, "uneven"))
    for _ in range(5):
        q = np.concatenate([[rng.uniform(-5, 5)], rng.uniform(-3 * math.pi, 3 * math.pi, 6)])
        # MODEL.md's geometry, written out here: p_k = p_{k-1} + l_k (sin th_k, 0, -cos th_k)
        ref = [np.array([0.0, 0.0, q[0]])]
        for lk, th in zip(lengths, q[1:], strict=True):
            ref.append(ref[-1] + lk * np.array([math.sin(th), 0.0, -math.cos(th)]))
        phi = np.concatenate([[q[0]], np.diff(q[1:], prepend=0.0)])  # heave, relative angles
        _set_cfg(robot, ["platform_heave"] + [f"joint_{i}" for i in range(1, 7)], phi)
        assert np.abs(_fk_points(robot, 6) - np.array(ref)).max() < TOL
        pose = _chain(tf_transforms(model, phi))
        pts = [pose[f"link_{i}"][:3, 3] for i in range(1, 7)] + [pose["cable_end"][:3, 3]]
        assert np.abs(np.array(pts) - np.array(ref)).max() < TOL


def test_tf_transforms_rejects_a_wrong_length() -> None:
    model = CableModel.from_params(CableParams(n_links=3))
    with pytest.raises(ValueError, match=r"shape \(3,\).*\(4,\)"):
        tf_transforms(model, [0.0, 0.1, 0.2])


def test_override_changes_the_urdf() -> None:
    robot = _load(build_urdf("mooring_line", {"n_links": 7}))
    rot = [j for j in robot.robot.joints if j.type in ROTATIONAL]
    assert len(rot) == 7 and robot.actuated_joint_names == ["platform_heave"] + [
        f"joint_{i}" for i in range(1, 8)]
    assert sum(robot.link_map[f"link_{i}"].inertial.mass for i in range(1, 8)) == pytest.approx(
        115.0 * 300.0)
    default = _load(build_urdf("mooring_line"))
    assert len([j for j in default.robot.joints if j.type in ROTATIONAL]) == 40


def test_cli_main_prints_the_urdf(capsys, tmp_path: Path) -> None:
    assert main(["paper_free_fall", "-p", "n_links:=7"]) == 0
    robot = _load(capsys.readouterr().out)
    assert len([j for j in robot.robot.joints if j.type in ROTATIONAL]) == 7
    assert robot.link_map["load"].inertial.mass == pytest.approx(60.0)
    # a path works like a name, -o writes a file
    dest = tmp_path / "x.urdf"
    assert main([str(Path(__file__).resolve().parents[2] / "config" / "mooring_line.yaml"),
                 "-o", str(dest)]) == 0
    assert _load(dest.read_text()).robot.name == "cable_sim_mooring_line"


@pytest.mark.parametrize("args, words", [
    (["mooring_line", "-p", "n_links:=1"], ["n_links", "1"]),
    (["mooring_line", "-p", "n_links:=2.5"], ["n_links", "2.5", "integer"]),
    (["mooring_line", "-p", "n_links"], ["key:=value"]),
    (["no_such_scene"], ["no_such_scene", "not found"]),
])
def test_cli_errors_name_the_value(capsys, args, words) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("cable_sim_urdf: ") and all(w in err for w in words), err


def test_installed_console_script() -> None:
    exe = shutil.which("cable_sim_urdf", path=str(Path(sys.executable).parent))
    assert exe, "cable_sim_urdf is not installed next to this interpreter (run make venv)"
    r = subprocess.run([exe, "mooring_line", "-p", "n_links:=7"], capture_output=True, text=True,
                       timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    assert len([j for j in _load(r.stdout).robot.joints if j.type in ROTATIONAL]) == 7
