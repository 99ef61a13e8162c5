"""RunRecorder: rosbag2-compatible MCAP, never blocks or raises, survives crashes.

Independent readers: ``rosbags`` (AnyReader on the bare .mcap, its own CDR decoder and its own
parser of the concatenated message definitions) and ``mcap_ros2`` (decoder from the schema).
"""

import errno
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import deserialize_message, serialize_message
from ros_util import kill_and_reap, popen
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from cable_sim.analysis.replay import record_headless
from cable_sim.ros.recorder import (
    RecorderError,
    RunRecorder,
    cdr_length,
    message_definition,
    recover,
    scan_records,
    serialize,
)

ROOT = Path(__file__).resolve().parents[2]
JAZZY = get_typestore(Stores.ROS2_JAZZY)


def _tname(msg):
    return f"{type(msg).__module__.split('.')[0]}/msg/{type(msg).__name__}"


def _all_messages_rosbags(path):
    out = {}
    with AnyReader([Path(path)]) as r:
        for c, _, raw in r.messages():
            r.deserialize(raw, c.msgtype)  # raises on any size or layout mismatch
            out[c.topic] = out.get(c.topic, 0) + 1
    return out


def _all_messages_mcap_ros2(path):
    out = {}
    with open(path, "rb") as f:
        for _, ch, _, _ in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            out[ch.topic] = out.get(ch.topic, 0) + 1
    return out


def test_message_definition_is_complete_and_parses_like_jazzy():
    text = message_definition("visualization_msgs/msg/MarkerArray")
    for dep in ("visualization_msgs/Marker", "std_msgs/Header", "builtin_interfaces/Time",
                "geometry_msgs/Pose", "geometry_msgs/Point", "std_msgs/ColorRGBA",
                "builtin_interfaces/Duration", "sensor_msgs/CompressedImage",
                "visualization_msgs/UVCoordinate", "visualization_msgs/MeshFile"):
        assert f"{'=' * 80}\nMSG: {dep}\n" in text, dep
        assert text.count(f"MSG: {dep}\n") == 1
    # rosbags parses the concatenation into the same field layout as its built-in Jazzy store
    for tname in ("visualization_msgs/msg/MarkerArray", "sensor_msgs/msg/JointState",
                  "diagnostic_msgs/msg/DiagnosticArray", "geometry_msgs/msg/WrenchStamped"):
        types = get_types_from_msg(message_definition(tname), tname)
        for name, (consts, fields) in types.items():
            ref_consts, ref_fields = JAZZY.fielddefs[name]
            assert [f[0] for f in fields] == [f[0] for f in ref_fields], name
            assert sorted(c[0] for c in consts) == sorted(c[0] for c in ref_consts), name


def test_unknown_type_has_clear_error():
    with pytest.raises(FileNotFoundError, match="nosuch_msgs/msg/Thing.msg"):
        message_definition("nosuch_msgs/msg/Thing")


@pytest.mark.parametrize("make", [
    lambda: JointState(),
    lambda: JointState(name=["a", "bb"], position=[1.0, 2.0]),  # empty velocity/effort
    lambda: JointState(name=["a"], position=[1.0], velocity=[2.0], effort=[3.0]),
    lambda: Float64MultiArray(data=[]),
    lambda: Float64MultiArray(data=[1.5, -2.0, 3.0]),
    lambda: Float64(data=4.0),
])
def test_serialized_bytes_are_exact_cdr(make):
    msg = make()
    raw = serialize(msg)
    full = serialize_message(msg)
    assert len(raw) == cdr_length(msg) <= len(full)  # rclpy may add an estimated tail
    assert raw == serialize(msg)  # deterministic (rclpy leaves padding uninitialised)
    same = np.frombuffer(raw, np.uint8) == np.frombuffer(full[: len(raw)], np.uint8)
    assert same.sum() >= len(raw) - 12  # only alignment padding may differ
    ref = JAZZY.serialize_cdr(JAZZY.deserialize_cdr(raw, _tname(msg)), _tname(msg))
    assert bytes(ref) == raw  # an independent serialiser gives the same bytes (zero padding)
    md = JAZZY.get_msgdef(_tname(msg))
    _, pos = md.deserialize_cdr_le(raw[4:], 0, md.cls, JAZZY)
    assert pos + 4 == len(raw)
    assert deserialize_message(raw, type(msg)) == msg


def test_headless_run_opens_with_rosbags_and_mcap_ros2(tmp_path):
    path = tmp_path / "run.mcap"
    st = record_headless("paper_anchored_forced", path, 1.0, overrides={"n_links": 12},
                         inputs=[(0.2, "heave_force", 1000.0), (0.5, "wave_elevation", 0.3)])
    assert st["messages_dropped"] == 0 and st["errors"] == 0
    assert st["messages_written"] == sum(st["published"].values())
    assert _all_messages_rosbags(path) == st["published"]
    assert _all_messages_mcap_ros2(path) == st["published"]
    assert st["published"]["/applied_inputs"] == 2
    assert st["published"]["/joint_states"] == 51  # 50 Hz over 1 s, both ends included
    with open(path, "rb") as f:
        r = make_reader(f)
        header = r.get_header()
        summ = r.get_summary()
        meta = {m.name: m.metadata for m in r.iter_metadata()}
    assert header.profile == "ros2"
    assert {s.encoding for s in summ.schemas.values()} == {"ros2msg"}
    assert {c.message_encoding for c in summ.channels.values()} == {"cdr"}
    assert "sensor_msgs/msg/JointState" in {s.name for s in summ.schemas.values()}
    assert summ.statistics.chunk_count >= 1
    assert all(ci.compression == "zstd" for ci in summ.chunk_indexes)
    assert json.loads(meta["scene"]["json"])["scene_name"] == "paper_anchored_forced"
    assert meta["run"]["n_links"] == "12" and float(meta["run"]["step"]) == 0.002


def test_unwritable_paths_raise_recorder_error_naming_path_and_reason(tmp_path):
    afile = tmp_path / "a_file"
    afile.write_text("x")
    with pytest.raises(RecorderError, match=r"a_file/run\.mcap.*a_file is not a directory"):
        RunRecorder(afile / "run.mcap")
    with pytest.raises(RecorderError, match=r"cannot record to .*: it is a directory"):
        RunRecorder(tmp_path)
    with pytest.raises(RecorderError, match=r"'/dev/full': .*No space left on device"):
        RunRecorder("/dev/full")
    if os.geteuid() != 0:  # root ignores permission bits
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        with pytest.raises(RecorderError, match="Permission denied"):
            RunRecorder(ro / "x.mcap")


def test_missing_parent_directories_are_created(tmp_path):
    p = tmp_path / "runs" / "deep" / "x.mcap"
    with RunRecorder(p) as rec:
        rec.write("/x", Float64(data=1.0), 5)
    assert _all_messages_mcap_ros2(p) == {"/x": 1}


def test_queue_overflow_drops_and_counts_without_blocking(tmp_path):
    logs = []
    rec = RunRecorder(tmp_path / "q.mcap", max_queue=20, logger=logs.append)
    release = threading.Event()
    real = rec._register

    def slow(*a, **k):  # the writer thread stalls on the first message until released
        release.wait(10)
        return real(*a, **k)

    rec._register = slow
    n = 500
    for i in range(n):
        rec.write("/x", Float64(data=float(i)), i)
    release.set()
    rec.close()
    st = rec.stats
    assert st["messages_dropped"] > 0
    assert st["messages_written"] + st["messages_dropped"] == n
    assert st["messages_written"] <= 21  # one in the writer's hands + the queue
    assert any("queue full" in m for m in logs)
    assert _all_messages_rosbags(tmp_path / "q.mcap") == {"/x": st["messages_written"]}


def test_disk_full_is_counted_logged_and_later_writes_dropped(tmp_path):
    logs = []
    rec = RunRecorder(tmp_path / "full.mcap", logger=logs.append, flush_period=0.05)
    for i in range(10):
        rec.write("/x", Float64(data=float(i)), i)
    time.sleep(0.3)  # flushed to disk

    def enospc(data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    rec._sink.write = enospc
    for i in range(10, 200):
        rec.write("/x", Float64(data=float(i)), i)  # must not raise
        time.sleep(0.001)
    time.sleep(0.3)
    rec.close()  # must not raise either
    rec.close()
    st = rec.stats
    assert st["errors"] >= 1 and "disk full" in st["last_error"]
    assert st["messages_written"] + st["messages_dropped"] == 200
    assert st["messages_dropped"] > 0
    assert sum("disk full" in m for m in logs) >= 1
    # the 10 messages flushed before the disk filled are still readable
    records, err = scan_records(tmp_path / "full.mcap")
    assert err is not None
    assert sum(type(r).__name__ == "Message" for r in records) >= 10


def test_close_is_idempotent_and_thread_safe(tmp_path):
    rec = RunRecorder(tmp_path / "c.mcap")
    for i in range(1000):
        rec.write("/js", JointState(name=["a"], position=[float(i)]), i)
    threads = [threading.Thread(target=rec.close) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    rec.close()
    rec.write("/js", JointState(), 2000)  # after close: dropped, not raised
    assert rec.stats["messages_written"] == 1000 and rec.stats["messages_dropped"] == 1
    assert _all_messages_rosbags(tmp_path / "c.mcap") == {"/js": 1000}


def test_periodic_flush_makes_data_readable_while_open(tmp_path):
    path = tmp_path / "live.mcap"
    rec = RunRecorder(path, {"scene": {"json": "{}"}}, flush_period=0.1)
    for i in range(300):
        rec.write("/x", Float64(data=float(i)), i)
    time.sleep(0.5)
    records, err = scan_records(path)  # file still open, no summary yet
    assert err is not None  # incomplete: no footer yet
    vals = [deserialize_message(r.data, Float64).data for r in records if type(r).__name__ == "Message"]
    assert vals == [float(i) for i in range(300)]
    rec.close()
    records, err = scan_records(path)
    assert err is None


WRITER = textwrap.dedent("""
    import sys, time
    from cable_sim.ros.recorder import RunRecorder
    from std_msgs.msg import Float64
    rec = RunRecorder(sys.argv[1], {"scene": {"json": "{}"}}, flush_period=0.1)
    try:
        k = 0
        while True:
            rec.write("/x", Float64(data=float(k)), k)
            k += 1
            if k % 100 == 0:
                time.sleep(0.002)
            if k == 3000:
                print("ready", flush=True)
    finally:
        rec.close()
""")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_signals_leave_readable_files(tmp_path, sig):
    """SIGTERM/SIGINT: complete file. SIGKILL: flushed chunks stream-decode; recover() completes it.

    (The plain Python writer gets KeyboardInterrupt on SIGINT and dies on SIGTERM by default;
    the atexit hook does not run on SIGTERM, so SIGTERM is given a handler that raises.)
    """
    path = tmp_path / "sig.mcap"
    code = WRITER
    if sig == signal.SIGTERM:
        code = "import signal, sys\nsignal.signal(signal.SIGTERM, lambda *a: sys.exit(143))\n" + code
    # default SIGINT/SIGTERM in the writer even when pytest runs with SIGINT ignored (background job)
    p = popen([sys.executable, "-c", code, str(path)], stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert p.stdout.readline().strip() == "ready"
        time.sleep(0.5)
        p.send_signal(sig)
        p.wait(20)
    finally:
        kill_and_reap(p)
    records, err = scan_records(path)
    msgs = [r for r in records if type(r).__name__ == "Message"]
    vals = [deserialize_message(m.data, Float64).data for m in msgs]
    assert len(vals) >= 3000
    assert vals == [float(i) for i in range(len(vals))]  # every decoded message, in order, no gaps
    if sig == signal.SIGKILL:
        assert err is not None  # truncated
        fixed = tmp_path / "fixed.mcap"
        info = recover(path, fixed)
        assert info["truncated"] and info["messages"] == len(vals)
        assert _all_messages_rosbags(fixed) == {"/x": len(vals)}
        with open(fixed, "rb") as f:
            assert [m.name for m in make_reader(f).iter_metadata()] == ["scene"]
    else:
        assert err is None, err  # complete: footer and summary written
        assert _all_messages_rosbags(path) == {"/x": len(vals)}
        with open(path, "rb") as f:
            assert make_reader(f).get_summary().statistics.message_count == len(vals)


def test_recover_of_complete_file_is_identity_of_content(tmp_path):
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    with RunRecorder(a, {"m": {"k": "v"}}) as rec:
        for i in range(50):
            rec.write("/js", JointState(name=["a"], position=[float(i)], velocity=[1.0], effort=[2.0]), i)
    info = recover(a, b)
    assert not info["truncated"] and info["messages"] == 50

    def content(p):
        with open(p, "rb") as f:
            return [(c.topic, s.name, m.log_time, m.data) for s, c, m in make_reader(f).iter_messages()]

    assert content(a) == content(b)
    with open(b, "rb") as f:
        recs = list(StreamReader(f).records)
    assert type(recs[-1]).__name__ == "Footer"
    assert np.isfinite(len(recs))


def test_recorded_bytes_equal_the_bytes_a_subscriber_receives():
    """serialize() == what a raw subscription receives over Fast DDS (exact length, zero padding)."""
    import random

    import rclpy
    from rclpy.context import Context
    from visualization_msgs.msg import Marker, MarkerArray

    from cable_sim.ros.messages import build_diagnostics

    os.environ["ROS_DOMAIN_ID"] = str(random.randint(1, 100))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    ctx = Context()
    rclpy.init(context=ctx)
    try:
        node = rclpy.create_node("wire_check", context=ctx)
        m = Marker(type=Marker.LINE_STRIP, ns="cable")
        m.points = [type(m.pose.position)(x=float(i), z=-float(i)) for i in range(5)]
        m.colors = [type(m.color)(r=0.5, a=1.0) for _ in range(5)]
        msgs = [JointState(name=["platform_heave", "joint_1"], position=[1.0, 2.0]),
                JointState(name=["platform_heave", "joint_10"], position=[1.0, 2.0], velocity=[0.1, 0.2],
                           effort=[3.0, 4.0]),
                MarkerArray(markers=[m, Marker(type=Marker.SPHERE, ns="end")]),
                build_diagnostics({"real_time_factor": "1.5", "overruns": "0"}, 123),
                Float64MultiArray(data=[1.0, -2.0])]
        executor = rclpy.executors.SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        for i, msg in enumerate(msgs):
            got = []
            topic = f"wire_{i}"
            pub = node.create_publisher(type(msg), topic, 10)
            node.create_subscription(type(msg), topic, got.append, 10, raw=True)
            t0 = time.monotonic()
            while not got and time.monotonic() - t0 < 10:
                pub.publish(msg)
                executor.spin_once(timeout_sec=0.05)
            assert got, f"no message received on {topic}"
            assert serialize(msg) == got[0], type(msg).__name__
    finally:
        rclpy.try_shutdown(context=ctx)


def test_serialize_matches_an_independent_cdr_serialiser_on_many_layouts():
    """rosbags' own CDR serialiser (zero padding, exact length) gives the same bytes as serialize()
    for nested, fixed-layout, string, sequence and empty types, and for random JointStates and
    MarkerArrays (strings of every length mod 4, empty and non-empty sequences)."""
    import random

    from geometry_msgs.msg import Point32, PolygonStamped
    from sensor_msgs.msg import BatteryState, CameraInfo, Imu, PointCloud2, PointField
    from std_msgs.msg import Bool, Empty, MultiArrayDimension, String
    from visualization_msgs.msg import Marker, MarkerArray

    def check(m):
        raw = serialize(m)
        ref = bytes(JAZZY.serialize_cdr(JAZZY.deserialize_cdr(raw, _tname(m)), _tname(m)))
        assert ref == raw, _tname(m)
        assert len(raw) == cdr_length(m)

    fma = Float64MultiArray(data=[1.0])
    fma.layout.dim = [MultiArrayDimension(label="ab", size=2, stride=2)]
    fma.layout.data_offset = 1
    poly = PolygonStamped()
    poly.polygon.points = [Point32(x=1.0)] * 3
    for m in [JointState(), CameraInfo(), Imu(), Empty(), Bool(data=True), String(data="héllo"), fma, poly,
              PointCloud2(fields=[PointField(name="x", offset=0, datatype=7, count=1)],
                          data=bytes(range(10))),
              BatteryState(cell_voltage=[1.0, 2.0], location="a")]:
        check(m)
    rnd = random.Random(4)
    for _ in range(200):
        j = JointState(name=["n" * rnd.randint(0, 9) for _ in range(rnd.randint(0, 5))],
                       position=[1.0] * rnd.randint(0, 3), velocity=[2.0] * rnd.randint(0, 2))
        j.header.frame_id = "f" * rnd.randint(0, 7)
        check(j)
        mk = Marker(ns="x" * rnd.randint(0, 5), text="t" * rnd.randint(0, 3))
        mk.points = [type(mk.pose.position)(x=rnd.random())] * rnd.randint(0, 3)
        check(MarkerArray(markers=[mk] * rnd.randint(0, 3)))
