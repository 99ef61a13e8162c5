"""/tf, /tf_static and robot_description in the node's MCAP recording (issue 12).

References independent of the code under test: the TFMessage CDR bytes are checked against
mcap_ros2's serialiser built from the schema text; the recording is read with rosbags (AnyReader
registers tf2_msgs/msg/TFMessage from the file's schema), the transforms are chained from ``world``
here with our own quaternion algebra, and the chain is compared with the MarkerArray line points
and the joint states recorded in the same file at the same stamps.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from mcap_ros2._dynamic import serialize_dynamic
from ros_util import isolate_ros, run_to_end
from rosbags.highlevel import AnyReader

from cable_sim.ros.recorder.definitions import message_definition
from cable_sim.ros.tf_output import CableTf, frame_namer
from cable_sim.ros.urdf import static_transforms, tf_transforms
from cable_sim.scene.scenes import load_scene

DOMAIN = isolate_ros()


def _rotation(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _tf_dict(tfs) -> dict:
    return {"transforms": [{
        "header": {"stamp": {"sec": 7, "nanosec": 250_000_000}, "frame_id": p}, "child_frame_id": c,
        "transform": {"translation": dict(zip("xyz", t, strict=True)),
                      "rotation": dict(zip("xyzw", q, strict=True))}} for p, c, t, q in tfs]}


@pytest.mark.parametrize("scene", ["mooring_line", "paper_free_fall"])
def test_tf_bytes_equal_a_serialiser_built_from_the_definition(scene):
    model = load_scene(scene).model()
    enc = serialize_dynamic("tf2_msgs/TFMessage", message_definition("tf2_msgs/msg/TFMessage"))
    enc = enc["tf2_msgs/TFMessage"]
    cable = CableTf(model)
    pos = np.random.default_rng(3).normal(size=model.n + 1)
    want = tf_transforms(model, pos, include_fixed=False)
    np.testing.assert_array_equal(cable.moving_values(pos), [[*t, *q] for _, _, t, q in want])
    assert cable.tf(pos, 7_250_000_000) == bytes(enc(_tf_dict(want)))
    assert cable.tf_static(7_250_000_000) == bytes(enc(_tf_dict(static_transforms(model))))


def test_tf_bytes_do_not_depend_on_earlier_calls():
    """tf() writes into scratch it keeps: each call's bytes are those of its own joint state
    (checked against the serialiser built from the definition), whatever was encoded before."""
    model = load_scene("mooring_line").model()
    enc = serialize_dynamic("tf2_msgs/TFMessage", message_definition("tf2_msgs/msg/TFMessage"))
    enc = enc["tf2_msgs/TFMessage"]
    cable = CableTf(model)
    rng = np.random.default_rng(5)
    states = [rng.normal(size=model.n + 1) * 3.0 for _ in range(3)]
    first = [cable.tf(p, 7_250_000_000) for p in states]
    again = [cable.tf(p, 7_250_000_000) for p in reversed(states)][::-1]
    assert first == again
    for p, data in zip(states, first, strict=True):
        assert data == bytes(enc(_tf_dict(tf_transforms(model, p, include_fixed=False))))


@pytest.mark.parametrize("scene", ["mooring_line", "paper_free_fall"])
def test_tf_many_gives_each_message_the_serialiser_bytes(scene):
    """tf_many (the writer thread's batch of /tf) gives, per joint state and stamp, the bytes of a
    serialiser built from the definition for that state's transforms, whatever the frame names'
    lengths (``link_9``, ``link_10``, ...) and stamps."""
    model = load_scene(scene, {"n_links": 120}).model()
    enc = serialize_dynamic("tf2_msgs/TFMessage", message_definition("tf2_msgs/msg/TFMessage"))
    enc = enc["tf2_msgs/TFMessage"]
    cable = CableTf(model, "leg/world")
    name = frame_namer("leg/world")
    rng = np.random.default_rng(11)
    states = [rng.normal(size=model.n + 1) * 3.0 for _ in range(4)]
    stamps = [7_250_000_000, 0, 1_999_999_999, 3_000_000_001]
    got = cable.tf_many(states, stamps)
    for p, st, data in zip(states, stamps, got, strict=True):
        want = _tf_dict([(name(a), name(b), t, q) for a, b, t, q in
                         tf_transforms(model, p, include_fixed=False)])
        for tf in want["transforms"]:
            tf["header"]["stamp"] = {"sec": st // 1_000_000_000, "nanosec": st % 1_000_000_000}
        assert data == bytes(enc(want))
    assert cable.tf_many(states[:0], []) == []
    with pytest.raises(ValueError):
        cable.tf_many([states[0][1:]], [0])
    with pytest.raises(ValueError):
        cable.tf_many(states[:1], [-1])


def test_frame_prefix_follows_frame_id():
    assert frame_namer("world")("link_3") == "link_3"
    assert frame_namer("leg1/world")("link_3") == "leg1/link_3"
    assert frame_namer("leg1/world")("world") == "leg1/world"
    assert frame_namer("sea")("world") == "sea" and frame_namer("sea")("link_1") == "link_1"


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("tf") / "run.mcap"
    run_to_end("mooring_line", "clock_mode:=fast", "duration:=2.0", "exit_at_end:=true",
               f"record_path:={path}", "joint_state_rate:=50.0", "marker_rate:=10.0", domain=DOMAIN)
    return path


def _read(path: Path):
    msgs: dict[str, list] = {}
    with AnyReader([path]) as r:
        qos = {c.topic: c.ext.offered_qos_profiles for c in r.connections}
        types = {c.topic: c.msgtype for c in r.connections}
        for c, t, raw in r.messages():
            msgs.setdefault(c.topic, []).append((t, r.deserialize(raw, c.msgtype)))
    return msgs, qos, types


def _stamp(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def test_recording_holds_tf_tf_static_and_robot_description(recording):
    msgs, qos, types = _read(recording)
    assert types["/tf"] == types["/tf_static"] == "tf2_msgs/msg/TFMessage"
    assert types["/robot_description"] == "std_msgs/msg/String"
    assert len(msgs["/tf_static"]) == 1 and len(msgs["/robot_description"]) == 1
    for topic in ("/tf_static", "/robot_description"):
        (q,) = qos[topic]  # rosbags' parse of rosbag2's offered_qos_profiles
        assert (q.durability.name, q.reliability.name, q.depth) == ("TRANSIENT_LOCAL", "RELIABLE", 1), q
        assert msgs[topic][0][0] <= min(t for t, _ in msgs["/tf"])  # at the start of the recording
    assert qos["/tf"][0].durability.name == "VOLATILE"
    # one /tf per joint state, same stamps
    js_stamps = [_stamp(m.header) for _, m in msgs["/joint_states"]]
    tf_stamps = [_stamp(m.transforms[0].header) for _, m in msgs["/tf"]]
    assert len(js_stamps) >= 100 and tf_stamps == js_stamps
    # the recorded URDF describes the recorded joints
    urdf = yourdfpy.URDF.load(io.StringIO(msgs["/robot_description"][0][1].data))
    assert list(urdf.actuated_joint_names) == list(msgs["/joint_states"][0][1].name)


def test_frames_follow_rep105(recording):
    msgs, _, _ = _read(recording)
    parents, children = set(), set()
    for topic in ("/tf", "/tf_static"):
        for _, m in msgs[topic]:
            for tr in m.transforms:
                parents.add(tr.header.frame_id)
                children.add(tr.child_frame_id)
    assert parents - children == {"world"}  # one root, the fixed world frame
    assert not ({"map", "odom", "base_link"} & (parents | children))
    assert len(children) == len(set(children))
    js = msgs["/joint_states"][0][1]
    assert js.header.frame_id == "world"


def test_tf_chain_reproduces_the_recorded_polyline(recording):
    msgs, _, _ = _read(recording)
    static = {tr.child_frame_id: tr for _, m in msgs["/tf_static"] for tr in m.transforms}
    markers = {_stamp(m.markers[-1].header): m for _, m in msgs["/cable_markers"]}
    n = len(msgs["/joint_states"][0][1].name) - 1
    compared = 0
    worst = 0.0
    for _, m in msgs["/tf"]:
        stamp = _stamp(m.transforms[0].header)
        frames = {**static, **{tr.child_frame_id: tr for tr in m.transforms}}
        pose: dict[str, tuple[np.ndarray, np.ndarray]] = {"world": (np.eye(3), np.zeros(3))}

        def world_pose(name, frames=frames, pose=pose):
            if name not in pose:
                tr = frames[name]
                R0, p0 = world_pose(tr.header.frame_id)
                t, q = tr.transform.translation, tr.transform.rotation
                pose[name] = (R0 @ _rotation((q.x, q.y, q.z, q.w)), R0 @ np.array([t.x, t.y, t.z]) + p0)
            return pose[name]

        chain = np.array([world_pose(f"link_{i + 1}")[1] for i in range(n)] + [world_pose("cable_end")[1]])
        assert np.all(chain[:, 1] == 0.0)
        mk = markers.get(stamp)
        if mk is None:
            continue
        line = next(x for x in mk.markers if x.ns == "cable")
        pts = np.array([[p.x, p.y, p.z] for p in line.points])
        worst = max(worst, float(np.abs(chain - pts).max()))
        compared += 1
    assert compared >= 15, compared
    assert worst < 1e-9, worst
