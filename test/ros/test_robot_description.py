"""robot_description (transient local) from the real node, the QoS of every output as documented in
msg_configs/interface.yaml, and the MarkerArray conventions RViz relies on (issue 12).

The URDF is parsed with yourdfpy (an independent URDF library); QoS is read from the ROS graph
(``get_publishers_info_by_topic``), not from the node's code.
"""

from __future__ import annotations

import io
import time
from pathlib import Path

import pytest
import rclpy
import yaml
import yourdfpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_util import init_context, isolate_ros, kill_and_reap, spin_until, start_node
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker, MarkerArray

DOMAIN = isolate_ros()
DOC = yaml.safe_load((Path(__file__).resolve().parents[2] / "msg_configs" / "interface.yaml").read_text())
MARKER_NS = ("cable", "end", "platform", "water", "seabed", "touchdown")
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture(scope="module")
def graph():
    """The node (realtime, mooring_line, not recording) and a client node in the same domain."""
    proc = start_node("mooring_line", "record:=false", "n_links:=12", domain=DOMAIN)
    ctx = init_context(DOMAIN)
    node = rclpy.create_node("rd_client", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        js: list = []
        node.create_subscription(JointState, "joint_states", js.append, 10)
        assert spin_until(ex, lambda: len(js) > 0, 60.0), "no joint_states from the node"
        yield node, ex, js, proc
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        kill_and_reap(proc)


def test_late_subscriber_gets_the_urdf(graph):
    node, ex, js, _ = graph
    time.sleep(3.0)  # the node published robot_description long before this subscriber exists
    got: list = []
    node.create_subscription(String, "robot_description", got.append, LATCHED)
    assert spin_until(ex, lambda: len(got) > 0, 20.0), "late transient-local subscriber got nothing"
    assert len(got) == 1
    urdf = yourdfpy.URDF.load(io.StringIO(got[0].data))
    assert list(urdf.actuated_joint_names) == list(js[-1].name)
    assert len(js[-1].name) == 13


def test_a_late_volatile_subscriber_gets_nothing_old(graph):
    """The reference behaviour the test above relies on: without transient local, nothing arrives."""
    node, ex, _, _ = graph
    got: list = []
    node.create_subscription(String, "robot_description",
                             got.append, QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
    spin_until(ex, lambda: len(got) > 0, 3.0)
    assert got == []


def _qos_of(entry: dict) -> dict:
    return entry.get("qos", DOC["qos"])


def _topic(entry: dict) -> str:
    return entry["topic"] if entry["topic"].startswith("/") else "/" + entry["topic"]


def _node_publishers(node, topic: str) -> list:
    return [i for i in node.get_publishers_info_by_topic(topic) if i.node_name == "cable_sim_node"]


def test_every_output_has_the_documented_qos(graph):
    node, ex, _, proc = graph
    # discovery fills the graph in the background; on a loaded machine it can lag the first messages
    expected = [_topic(e) for e in DOC["publications"] if _topic(e) != "/clock"]
    spin_until(ex, lambda: all(len(_node_publishers(node, t)) == 1 for t in expected), 20.0)
    assert proc.poll() is None, f"the node exited ({proc.returncode})"
    # the graph reports reliability and durability of remote endpoints (not history and depth)
    rel = {ReliabilityPolicy.RELIABLE: "reliable", ReliabilityPolicy.BEST_EFFORT: "best_effort"}
    dur = {DurabilityPolicy.VOLATILE: "volatile", DurabilityPolicy.TRANSIENT_LOCAL: "transient_local"}
    checked = 0
    for entry in DOC["publications"]:
        topic = _topic(entry)
        infos = _node_publishers(node, topic)
        if topic == "/clock":  # realtime: no /clock
            assert infos == []
            continue
        assert len(infos) == 1, topic
        q = infos[0].qos_profile
        got = {"reliability": rel[q.reliability], "durability": dur[q.durability]}
        want = _qos_of(entry)
        assert got == {k: want[k] for k in got}, topic
        checked += 1
    assert checked == len(DOC["publications"]) - 1
    for entry in DOC["subscriptions"]:
        infos = node.get_subscriptions_info_by_topic("/" + entry["topic"])
        q = infos[0].qos_profile
        assert rel[q.reliability] == _qos_of(entry)["reliability"], entry["topic"]


def test_markers_follow_rviz_conventions_and_reset_clears_them(graph):
    node, ex, _, _ = graph
    got: list = []
    node.create_subscription(MarkerArray, "cable_markers", got.append, 50)
    assert spin_until(ex, lambda: len(got) >= 3, 20.0)
    for arr in got:
        ids = [(m.ns, m.id) for m in arr.markers]
        assert len(set(ids)) == len(ids)  # RViz flags duplicate (ns, id) in one array
        # stable, none cleared (mooring_line has a seabed: its line and the touchdown point)
        assert ids == [(ns, k) for k, ns in enumerate(MARKER_NS)]
        for m in arr.markers:
            assert m.action == Marker.ADD and not m.frame_locked
            assert m.lifetime.sec == 0 and m.lifetime.nanosec == 0
            assert m.header.frame_id == "world"
    client = node.create_client(Trigger, "reset")
    assert client.wait_for_service(timeout_sec=10.0)
    got.clear()
    fut = client.call_async(Trigger.Request())

    def cleared() -> list[int]:
        return [i for i, arr in enumerate(got) if arr.markers[0].action == Marker.DELETEALL]

    assert spin_until(ex, lambda: fut.done() and cleared() and len(got) >= cleared()[0] + 3, 20.0)
    assert fut.result().success
    (i,) = cleared()  # exactly one DELETEALL: with the first markers after the reset
    first = got[i].markers
    assert first[0].ns == "" and (first[0].header.stamp.sec, first[0].header.stamp.nanosec) == (0, 0)
    assert [(m.ns, m.id, m.action) for m in first[1:]] == [
        (ns, k, Marker.ADD) for k, ns in enumerate(MARKER_NS)]
    assert all(m.action == Marker.ADD for arr in got[i + 1:] for m in arr.markers)
