"""Seabed outputs of the real node (issue 11, "Outputs"): the seabed_contact topic, its recording,
the diagnostics, the markers and the replay summary.

The node runs as a subprocess (installed console script) on ``mooring_line`` in fast clock mode,
recording, for 3 s of simulated time; the wave ramps in over 10 s, so the line stays close to its
static shape. The recording is decoded with rosbags (independent of the package's reader).

References independent of the code under test:

- the inextensible catenary with touchdown, solved here (bisection in a = H / w, MODEL.md
  "Catenary with touchdown"), for the fairlead height read from the recorded joint state at the
  same stamp: laid length L_b and touchdown x = D - L_b. A chain of rigid links touches the bed at a
  hinge (and the scene's chain has some bending stiffness), so the geometric touchdown and the
  laid length must agree within one link length l = L / n;
- the bed carries the weight in water of the laid length (the line is horizontal at the
  touchdown): the seabed reaction must be w L_b within 3 %;
- vertical balance of the whole line: seabed reaction + the vertical pulls of platform and anchor
  on the line (the recorded fairlead_tension and anchor_force topics, computed by the joint-force
  recursion, not the contact integral) = w L, to 1e-6 at the static start (t = 0); while the buoy
  moves, the line's inertia, added mass and drag take part of the load: within 2 % (measured
  1.1 % at t = 2 s, where the buoy accelerates at 0.16 m/s^2).

A free-end scene without a seabed publishes no seabed topic, no seabed markers and no seabed
diagnostics.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import rclpy
from ros_util import init_context, isolate_ros, kill_and_reap, run_to_end, spin_until, start_node
from rosbags.highlevel import AnyReader
from scipy.optimize import brentq

from cable_sim.analysis.replay import load_run, summary, summary_values
from cable_sim.scene.scenes import load_scene

DOMAIN = isolate_ros()
ROOT = Path(__file__).resolve().parents[2]
LABEL = "touchdown_arc_length_m,touchdown_x_m,laid_length_m,seabed_reaction_N"  # interface.yaml
DURATION = 3.0


def catenary_touchdown(D: float, V: float, L: float) -> float:
    """Laid length of the inextensible catenary with touchdown (anchor on the bed, span D, fairlead
    V above the bed, length L), by bisection in a = H / w."""

    def closing(a: float) -> float:
        ls = math.sqrt(V * V + 2.0 * a * V)
        return a * math.asinh(ls / a) + (L - ls) - D

    a = brentq(closing, 1e-6, 1e6, xtol=1e-12)
    return L - math.sqrt(V * V + 2.0 * a * V)


def _run(scene: str, path: Path, *params: str) -> str:
    return run_to_end(scene, "clock_mode:=fast", f"duration:={DURATION}", "exit_at_end:=true",
                      f"record_path:={path}", *params, domain=DOMAIN, cwd=ROOT, timeout=180)


def _read(path: Path) -> tuple[dict[str, list], dict[str, str]]:
    """Messages per topic as (log time [ns], decoded message), and the type of every topic."""
    msgs: dict[str, list] = {}
    with AnyReader([path]) as r:
        types = {c.topic: c.msgtype for c in r.connections}
        for c, t, raw in r.messages():
            msgs.setdefault(c.topic, []).append((t, r.deserialize(raw, c.msgtype)))
    return msgs, types


def _stamp(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


@pytest.fixture(scope="module")
def mooring(tmp_path_factory):
    path = tmp_path_factory.mktemp("seabed") / "mooring.mcap"
    _run("mooring_line", path, "tension_rate:=20.0", "joint_state_rate:=50.0", "marker_rate:=10.0")
    msgs, types = _read(path)
    return path, msgs, types


def test_seabed_contact_is_recorded_with_the_documented_layout(mooring):
    _, msgs, types = mooring
    assert types["/seabed_contact"] == "std_msgs/msg/Float64MultiArray"
    sc = msgs["/seabed_contact"]
    # at tension_rate (20 Hz of simulated time) from t = 0 to 3 s, with the tensions' log times
    assert len(sc) == round(DURATION * 20) + 1
    assert [t for t, _ in sc] == [t for t, _ in msgs["/line_tension"]]
    for _, m in sc:
        (dim,) = m.layout.dim
        assert (dim.label, dim.size, dim.stride) == (LABEL, 4, 4)
        assert len(m.data) == 4 and np.all(np.isfinite(m.data))
    # every published message was recorded (the node's own count, in its last diagnostics)
    last = {kv.key: kv.value for kv in msgs["/diagnostics"][-1][1].status[0].values}
    assert int(last["published_seabed_contact"]) == len(sc)


def test_seabed_contact_matches_the_catenary_with_touchdown(mooring):
    _, msgs, _ = mooring
    p = load_scene("mooring_line").params
    n, L, D, zb = p.n_links, p.total_length, p.anchor_x, p.seabed_depth
    link = L / n
    w = (p.mass_per_length - p.water_density * math.pi * p.diameter[0] ** 2 / 4) * p.gravity
    heave = {_stamp(m.header): m.position[0] for _, m in msgs["/joint_states"]}
    fair = {_stamp(m.header): m.wrench.force.z for _, m in msgs["/fairlead_tension"]}
    anch = {_stamp(m.header): m.wrench.force.z for _, m in msgs["/anchor_force"]}
    checked = 0
    worst = {"x": 0.0, "laid": 0.0, "R": 0.0, "balance": 0.0}
    balance = {}
    for t, m in msgs["/seabed_contact"]:
        arc, x_td, laid, reaction = m.data
        lb_ref = catenary_touchdown(D, heave[t] - zb, L) if t in heave else None
        if lb_ref is not None:
            worst["x"] = max(worst["x"], abs(x_td - (D - lb_ref)))
            worst["laid"] = max(worst["laid"], abs(laid - lb_ref), abs(arc - lb_ref))
            checked += 1
        worst["R"] = max(worst["R"], abs(reaction / (w * (lb_ref or laid)) - 1.0))
        # forces on the line: bed + platform (minus the cable's pull on it) + anchor = weight in water
        balance[t] = (reaction - fair[t] - anch[t]) / (w * L) - 1.0
        worst["balance"] = max(worst["balance"], abs(balance[t]))
    print(f"{checked} samples vs catenary with touchdown: |x_td - ref| <= {worst['x']:.3f} m, laid and "
          f"arc length within {worst['laid']:.3f} m (link {link:.2f} m); |R / (w L_b) - 1| <= "
          f"{worst['R']:.2e}; vertical balance at t = 0 {balance[0]:+.1e}, within {worst['balance']:.2e} "
          "of w L during the run")
    assert checked >= 10
    assert worst["x"] < link and worst["laid"] < link
    assert worst["R"] < 0.03
    assert abs(balance[0]) < 1e-6
    assert worst["balance"] < 0.02


def test_diagnostics_and_markers_show_the_seabed(mooring):
    _, msgs, _ = mooring
    p = load_scene("mooring_line").params
    last = {kv.key: kv.value for kv in msgs["/diagnostics"][-1][1].status[0].values}
    values = {k: float(last[k]) for k in ("touchdown_arc_length", "touchdown_x", "laid_length",
                                          "seabed_reaction")}
    assert all(math.isfinite(v) for v in values.values())
    assert 100.0 < values["laid_length"] < 200.0 and 0.0 < values["touchdown_x"] < p.anchor_x
    by_stamp = {t: m.data for t, m in msgs["/seabed_contact"]}  # log time = simulated-time stamp
    for _, arr in msgs["/cable_markers"]:
        mk = {m.ns: m for m in arr.markers if m.ns}
        assert (mk["seabed"].id, mk["touchdown"].id) == (4, 5)
        bed, td = mk["seabed"], mk["touchdown"]
        assert bed.type == bed.LINE_STRIP and [pt.z for pt in bed.points] == [p.seabed_depth] * 2
        assert bed.points[0].x < 0.0 and bed.points[1].x > p.anchor_x  # spans fairlead to anchor
        assert td.type == td.SPHERE and td.action == td.ADD and td.pose.position.z == p.seabed_depth
        stamp = _stamp(td.header)
        if stamp in by_stamp:  # markers and seabed_contact of the same step: the same point
            assert td.pose.position.x == by_stamp[stamp][1]


def test_replay_summary_gives_the_recorded_ranges(mooring):
    path, msgs, _ = mooring
    v = np.array([m.data for _, m in msgs["/seabed_contact"]])
    run = load_run(path)
    s = summary_values(run)
    assert (s["touchdown_x_min"], s["touchdown_x_max"]) == (v[:, 1].min(), v[:, 1].max())
    assert s["touchdown_excursion"] == v[:, 1].max() - v[:, 1].min()
    assert (s["touchdown_arc_min"], s["touchdown_arc_max"]) == (v[:, 0].min(), v[:, 0].max())
    assert (s["laid_length_min"], s["laid_length_max"]) == (v[:, 2].min(), v[:, 2].max())
    text = summary(run)
    print(text)
    assert f"x {v[:, 1].min():.6g} .. {v[:, 1].max():.6g} m" in text
    assert f"laid length   {v[:, 2].min():.6g} .. {v[:, 2].max():.6g} m" in text


def test_a_subscriber_receives_seabed_contact_live():
    """Real time, not recording: a subscriber in another process gets the topic as documented."""
    from std_msgs.msg import Float64MultiArray

    proc = start_node("mooring_line", "record:=false", "n_links:=12", domain=DOMAIN)
    ctx = init_context(DOMAIN)
    try:
        node = rclpy.create_node("seabed_listener", context=ctx)
        ex = rclpy.executors.SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        got: list = []
        node.create_subscription(Float64MultiArray, "seabed_contact", got.append, 10)
        assert spin_until(ex, lambda: len(got) >= 10, 60.0), "no seabed_contact from the node"
        for m in got:
            assert [(d.label, d.size, d.stride) for d in m.layout.dim] == [(LABEL, 4, 4)]
            arc, x_td, laid, reaction = m.data
            # all laid chain lies between the anchor and the touchdown point
            assert 100.0 < laid < 200.0 and arc >= laid - 1e-9 and reaction > 0
    finally:
        ex.shutdown()
        rclpy.try_shutdown(context=ctx)
        kill_and_reap(proc)


def test_free_end_scene_without_seabed_has_no_seabed_outputs(tmp_path):
    path = tmp_path / "free.mcap"
    assert not load_scene("control_experiment").model().seabed
    _run("control_experiment", path)
    msgs, types = _read(path)
    assert "/joint_states" in types and "/seabed_contact" not in types
    last = {kv.key: kv.value for kv in msgs["/diagnostics"][-1][1].status[0].values}
    assert last["published_seabed_contact"] == "0"
    assert not {"touchdown_x", "laid_length", "seabed_reaction", "touchdown_arc_length"} & set(last)
    assert all({m.ns for m in arr.markers} <= {"", "cable", "end", "platform", "water"}
               for _, arr in msgs["/cable_markers"])
    run = load_run(path)
    assert "touchdown_x_min" not in summary_values(run) and "touchdown" not in summary(run)


def test_live_view_marks_the_touchdown_point():
    """The Foxglove scene's touchdown sphere sits at the package's touchdown x (its geometric
    definition: where the first link reaching below the bed crosses it) and is deleted when the
    line is lifted clear of the bed."""
    pytest.importorskip("foxglove")
    from cable_sim.core.seabed import seabed_outputs
    from cable_sim.ros.foxglove_view import FoxgloveView
    from cable_sim.scene.simulation import Simulation

    sim = Simulation(load_scene("mooring_line"))
    out = sim.outputs()
    want = seabed_outputs(sim.model, out.q, out.qd).touchdown_x
    with FoxgloveView(sim.model, port=0) as view:
        touching = repr(view.scene_update(0.0, out.joint_positions, out.axial_tension, 0.0))
        lifted = out.joint_positions + np.array([0.0, 50.0])
        clear = repr(view.scene_update(0.0, lifted, out.axial_tension, 0.0))
    sphere = touching[touching.index('id: "touchdown"'):]
    x = float(sphere.split("position: Some(Vector3 { x: ", 1)[1].split(",", 1)[0])
    assert x == pytest.approx(want, abs=1e-9) and "z: -100.0" in sphere.split("size", 1)[0]
    assert "deletions=[]" in touching
    assert 'deletions=[SceneEntityDeletion' in clear and 'id: "touchdown"' in clear.split("entities=", 1)[0]
    assert 'id: "touchdown"' not in clear.split("entities=", 1)[1]
