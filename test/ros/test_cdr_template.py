"""TemplateEncoder: patched template bytes == the exact serialiser's bytes of the same message,
for the node's message shapes (JointState, Float64MultiArray, a MarkerArray with a shared stamp),
decoded independently by rosbags; a wrong prototype is refused."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rclpy")

from geometry_msgs.msg import Point  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import ColorRGBA, Float64MultiArray, Header, MultiArrayDimension  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray  # noqa: E402

from cable_sim.ros.cdr_template import (  # noqa: E402
    TemplateEncoder,
    TemplateError,
    sentinel,
    stamp_sentinel,
)
from cable_sim.ros.recorder.cdr import serialize  # noqa: E402

STORE = get_typestore(Stores.ROS2_JAZZY)


def _header(stamp: int, frame: str = "world") -> Header:
    h = Header(frame_id=frame)
    h.stamp.sec, h.stamp.nanosec = divmod(stamp, 1_000_000_000)
    return h


def _joint_state(stamp: int, p: np.ndarray, v: np.ndarray, e: np.ndarray) -> JointState:
    return JointState(header=_header(stamp), name=[f"joint_{i}" for i in range(len(p))],
                      position=p.tolist(), velocity=v.tolist(), effort=e.tolist())


@pytest.mark.parametrize("n", [1, 2, 3, 81, 2001])
def test_joint_state_bytes_equal_the_serialiser(n: int) -> None:
    s = [sentinel(n, seed=k) for k in range(3)]
    enc = TemplateEncoder(_joint_state(stamp_sentinel(), *s),
                          {"position": (s[0], 1), "velocity": (s[1], 1), "effort": (s[2], 1)},
                          stamp=stamp_sentinel())
    rng = np.random.default_rng(n)
    for stamp in (0, 1_500_000_000, 123 * 10**9 + 7):
        p, v, e = rng.normal(size=(3, n)) * 10.0 ** rng.integers(-3, 4, size=(3, 1))
        data = enc.encode(stamp, position=p, velocity=v, effort=e)
        assert data == serialize(_joint_state(stamp, p, v, e))
        msg = STORE.deserialize_cdr(data, "sensor_msgs/msg/JointState")
        assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == divmod(stamp, 10**9)
        assert np.array_equal(msg.position, p) and np.array_equal(msg.effort, e)


def test_float_array_with_labelled_layout() -> None:
    def build(values: np.ndarray) -> Float64MultiArray:
        m = Float64MultiArray(data=values.tolist())
        m.layout.dim = [MultiArrayDimension(label="link", size=len(values), stride=len(values))]
        return m

    s = sentinel(7)
    enc = TemplateEncoder(build(s), {"data": (s, 1)})
    x = np.linspace(-1e5, 3e5, 7)
    assert enc.encode(data=x) == serialize(build(x))


def _markers(stamp: int, pts: np.ndarray, cols: np.ndarray, end: np.ndarray) -> MarkerArray:
    hdr = _header(stamp)
    line = Marker(header=hdr, ns="cable", id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
    line.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in pts]
    line.colors = [ColorRGBA(r=float(r), g=float(g), b=float(b), a=float(a)) for r, g, b, a in cols]
    ball = Marker(header=hdr, ns="end", id=1, type=Marker.SPHERE, action=Marker.ADD)
    ball.pose.position.x, ball.pose.position.y, ball.pose.position.z = (float(v) for v in end)
    ball.pose.orientation.w = 1.0
    return MarkerArray(markers=[line, ball])


def test_marker_array_with_a_shared_stamp() -> None:
    n = 41
    sp, sc, se = sentinel((n, 3), seed=1), sentinel((n, 4), np.float32, seed=2), sentinel(3, seed=3)
    enc = TemplateEncoder(_markers(stamp_sentinel(), sp, sc, se),
                          {"points": (sp, 1), "colors": (sc, 1), "end": (se, 1)},
                          stamp=stamp_sentinel(), stamps=2)
    rng = np.random.default_rng(0)
    pts, end = rng.normal(size=(n, 3)) * 100, rng.normal(size=3)
    cols = rng.uniform(size=(n, 4)).astype(np.float32)
    data = enc.encode(2_000_000_001, points=pts, colors=cols, end=end)
    assert data == serialize(_markers(2_000_000_001, pts, cols, end))
    msg = STORE.deserialize_cdr(data, "visualization_msgs/msg/MarkerArray")
    assert [m.header.stamp.nanosec for m in msg.markers] == [1, 1]
    assert msg.markers[1].pose.position.z == end[2]


def test_a_prototype_without_its_sentinel_is_refused() -> None:
    s = sentinel(5)
    proto = _joint_state(stamp_sentinel(), np.zeros(5), s, s)
    with pytest.raises(TemplateError, match="position"):
        TemplateEncoder(proto, {"position": (s, 1)})
    with pytest.raises(TemplateError, match="velocity.*2 times"):  # velocity and effort share it
        TemplateEncoder(proto, {"velocity": (s, 1)})
    enc = TemplateEncoder(proto, {"velocity": (s, 2)}, stamp=stamp_sentinel())
    with pytest.raises(ValueError, match="shape"):
        enc.encode(0, velocity=np.zeros(4))
