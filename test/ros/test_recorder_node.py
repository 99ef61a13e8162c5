"""Recording by the real node process (``cable_sim_node``): readers, bytes, signals, recovery.

The node runs as a subprocess exactly as a user starts it (installed console script, scene
parameter file, ``-p`` overrides), in a random ROS domain restricted to localhost.
"""

import dataclasses
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from ros_util import isolate_ros, kill_and_reap, start_node

ROOT = Path(__file__).resolve().parents[2]
VENV = Path(sys.prefix)
NODE = VENV / "bin" / "cable_sim_node"

pytestmark = pytest.mark.skipif(not (ROOT / "cable_sim" / "ros" / "node.py").exists() or not NODE.exists(),
                                reason="cable_sim/ros/node.py or the installed cable_sim_node is missing")

DOMAIN = isolate_ros()  # this module's own ROS domain, localhost discovery
os.environ["PYTHONUNBUFFERED"] = "1"

from mcap.reader import make_reader  # noqa: E402
from mcap_ros2.decoder import DecoderFactory  # noqa: E402
from rosbags.highlevel import AnyReader  # noqa: E402

from cable_sim.analysis.replay import load_run  # noqa: E402
from cable_sim.ros.recorder import recover, scan_records  # noqa: E402


def _installed_is_current():
    """Every module of cable_sim/ros (node pieces, recorder package) is installed as in the sources
    (or this interpreter imports the sources themselves)."""
    import importlib.util

    spec = importlib.util.find_spec("cable_sim.ros")
    source_dir = ROOT / "cable_sim" / "ros"
    if spec is not None and Path(spec.origin).resolve().parent == source_dir.resolve():
        return True
    site = list((VENV / "lib").glob("python3*/site-packages/cable_sim/ros"))
    if not site:
        return True
    return all((d / p.relative_to(source_dir)).is_file()
               and (d / p.relative_to(source_dir)).read_bytes() == p.read_bytes()
               for d in site for p in source_dir.rglob("*.py"))


def launch(scene, record_path, *params):
    """The installed node for ``scene`` recording to ``record_path``, in this module's domain, run from
    the repository root (``ros_util.start_node``: default signals, killed and reaped after the test)."""
    return start_node(scene, f"record_path:={record_path}", *params, domain=DOMAIN, cwd=ROOT)


def counts_rosbags(path):
    out = {}
    with AnyReader([Path(path)]) as r:
        for c, _, raw in r.messages():
            r.deserialize(raw, c.msgtype)
            out[c.topic] = out.get(c.topic, 0) + 1
    return out


def counts_mcap_ros2(path):
    out = {}
    with open(path, "rb") as f:
        for _, ch, _, _ in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            out[ch.topic] = out.get(ch.topic, 0) + 1
    return out


def test_installed_package_is_current():
    assert _installed_is_current(), "the installed cable_sim is older than the sources: run `make venv`"


def test_node_recording_opens_with_both_readers(tmp_path):
    """Every message decodes with rosbags and mcap_ros2; per-topic counts equal the node's own
    published counts (its last diagnostics); what a live subscriber received is byte-identical
    to what was recorded."""
    import rclpy
    from rclpy.context import Context
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    path = tmp_path / "run.mcap"
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN)
    live: dict[str, list[bytes]] = {"/joint_states": [], "/line_tension": []}
    try:
        node = rclpy.create_node("recording_listener", context=ctx)
        ex = rclpy.executors.SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        node.create_subscription(JointState, "joint_states", live["/joint_states"].append, 100, raw=True)
        node.create_subscription(Float64MultiArray, "line_tension", live["/line_tension"].append, 100,
                                 raw=True)
        proc = launch("paper_anchored_forced", path, "clock_mode:=realtime", "duration:=5.0",
                      "exit_at_end:=true", "n_links:=20")
        t0 = time.monotonic()
        while proc.poll() is None and time.monotonic() - t0 < 60:
            ex.spin_once(timeout_sec=0.01)
        for _ in range(20):
            ex.spin_once(timeout_sec=0.01)
        out, _ = proc.communicate(timeout=30)
        assert proc.returncode == 0, out[-3000:]
    finally:
        rclpy.try_shutdown(context=ctx)

    a = counts_rosbags(path)
    b = counts_mcap_ros2(path)
    assert a == b
    with open(path, "rb") as f:
        r = make_reader(f, decoder_factories=[DecoderFactory()])
        stats = r.get_summary().statistics
        meta = {m.name: m.metadata for m in r.iter_metadata()}
        last_diag = None
        recorded: dict[str, set[bytes]] = {t: set() for t in live}
        for _, ch, msg, dec in r.iter_decoded_messages():
            if ch.topic == "/diagnostics":
                last_diag = {kv.key: kv.value for kv in dec.status[0].values}
            if ch.topic in recorded:
                recorded[ch.topic].add(bytes(msg.data))
    assert stats.message_count == sum(a.values())
    assert set(meta) >= {"scene", "run"} and meta["run"]["clock_mode"] == "realtime"
    for name in ("joint_states", "cable_markers", "fairlead_tension", "anchor_force", "line_tension",
                 "applied_inputs", "clock"):
        assert a.get(f"/{name}", 0) == int(last_diag[f"published_{name}"]), name
    assert a["/diagnostics"] == int(last_diag["published_diagnostics"]) + 1  # the last one itself
    assert a["/joint_states"] >= 250
    for topic, msgs in live.items():
        # discovery can take a few seconds: the subscriber must have received a good part of the run
        assert len(msgs) >= 0.25 * a[topic], (topic, {t: len(m) for t, m in live.items()}, a)
        # every received message was recorded with the same bytes
        missing = [m for m in msgs if m not in recorded[topic]]
        assert not missing, (topic, len(missing), [_closest_diff(m, recorded[topic]) for m in missing[:3]])
    run = load_run(path)
    assert run.n_links == 20 and run.t[-1] == pytest.approx(5.0, abs=0.05)


def _closest_diff(raw, candidates):
    """(length, other length, differing byte offsets) against the recorded message sharing the
    most bytes with ``raw`` — to tell a different message from different padding bytes."""
    def same(c):
        return sum(x == y for x, y in zip(raw, c, strict=False))

    best = max(candidates, key=same)
    return len(raw), len(best), [i for i, (x, y) in enumerate(zip(raw, best, strict=False)) if x != y][:20]


def _start_long_node(path):
    p = launch("paper_anchored_forced", path, "clock_mode:=fast", "duration:=0.0", "n_links:=20")
    t0 = time.monotonic()
    while time.monotonic() - t0 < 60:
        if path.exists() and path.stat().st_size > 50_000:
            break
        if p.poll() is not None:
            raise AssertionError(f"node exited early ({p.returncode}):\n{p.stdout.read()[-3000:]}")
        time.sleep(0.1)
    else:
        p.kill()
        raise AssertionError("node did not record 50 kB within 60 s")
    time.sleep(1.5)  # past at least one flush period
    return p


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_sigint_leave_complete_files(tmp_path, sig):
    """The recording is complete (footer, summary, every message decodes) whatever the exit code."""
    path = tmp_path / "sig.mcap"
    p = _start_long_node(path)
    p.send_signal(sig)
    p.communicate(timeout=30)
    records, err = scan_records(path)
    assert err is None, err
    assert type(records[-1]).__name__ == "Footer"
    n = counts_rosbags(path)
    assert n["/joint_states"] > 10
    assert counts_mcap_ros2(path) == n


def test_sigkill_leaves_streamable_chunks_and_recover_completes(tmp_path):
    path = tmp_path / "kill.mcap"
    p = _start_long_node(path)
    p.kill()
    p.wait(10)
    records, err = scan_records(path)
    assert err is not None  # no footer: truncated
    n_msgs = sum(type(r).__name__ == "Message" for r in records)
    assert n_msgs > 100
    fixed = tmp_path / "fixed.mcap"
    info = recover(path, fixed)
    assert info["truncated"] and info["messages"] == n_msgs
    counts = counts_rosbags(fixed)
    assert sum(counts.values()) == n_msgs
    assert counts_mcap_ros2(fixed) == counts
    run = load_run(fixed)
    assert len(run.t) > 10



def test_lockstep_run_replays_bit_for_bit_from_its_recording(tmp_path):
    """A controller drives the node in lockstep (one heave_force per control period, waiting for
    each joint_states); re-simulating from the recorded applied_inputs with the recorded settings
    reproduces every recorded joint state bit for bit; a re-simulation without those inputs does not."""
    import rclpy
    from rclpy.context import Context
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from cable_sim.analysis.replay import compare, resimulate

    path = tmp_path / "lockstep.mcap"
    proc = launch("paper_anchored_forced", path, "clock_mode:=lockstep", "control_period:=0.05",
                  "duration:=1.5", "exit_at_end:=true", "n_links:=20")
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN)
    sent = []
    try:
        node = rclpy.create_node("lockstep_controller", context=ctx)
        ex = rclpy.executors.SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        got = []
        node.create_subscription(JointState, "joint_states", got.append, 10)
        pub_f = node.create_publisher(Float64, "heave_force", 10)
        pub_w = node.create_publisher(Float64, "wave_elevation", 10)
        def stamps():
            return {j.header.stamp.sec * 1_000_000_000 + j.header.stamp.nanosec for j in got}

        # the node publishes joint_states(t = 0) once it sees the controller both ways; the
        # controller answers every joint state with one heave_force (one control period)
        t0 = time.monotonic()
        while 0 not in stamps():
            if proc.poll() is not None or time.monotonic() - t0 > 60:
                proc.kill()
                raise AssertionError(f"no joint_states(t0) from the node:\n{proc.communicate()[0][-3000:]}")
            ex.spin_once(timeout_sec=0.05)
        rnd = random.Random(7)
        for i in range(30):  # 30 x 0.05 s = 1.5 s = duration
            if i in (5, 17):
                pub_w.publish(Float64(data=rnd.uniform(-0.5, 0.5)))
            value = round(rnd.uniform(-20000.0, 20000.0), 3) if i % 4 else 0.0
            pub_f.publish(Float64(data=value))
            sent.append(value)
            t1 = time.monotonic()
            want = (i + 1) * 50_000_000  # the joint state at the end of this control period [ns]
            while want not in stamps():
                if i == 29 and proc.poll() is not None:
                    break  # the last period ends the scene: the node exits instead of answering
                if proc.poll() is not None or time.monotonic() - t1 > 20:
                    proc.kill()
                    raise AssertionError(f"no joint_states at t = {want / 1e9} s after control input {i}; "
                                         f"node output:\n{proc.communicate()[0][-3000:]}")
                ex.spin_once(timeout_sec=0.02)
        try:
            out, _ = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            raise AssertionError(f"node did not exit at the end:\n{proc.communicate()[0][-3000:]}") from None
        assert proc.returncode == 0, out[-3000:]
    finally:
        kill_and_reap(proc)
        rclpy.try_shutdown(context=ctx)

    run = load_run(path)
    assert run.run_info["clock_mode"] == "lockstep"
    assert np.array_equal(run.received["heave_force"].v, sent)
    assert len(run.applied) >= 20 and len(run.t) >= 30
    rs = resimulate(run)
    d = compare(run, rs)
    assert np.array_equal(rs.joint_position, run.joint_position)
    assert np.array_equal(rs.joint_velocity, run.joint_velocity)
    assert np.array_equal(rs.joint_effort, run.joint_effort)
    assert d["identical_joint_states"] == 1.0 and d["heave_max"] == 0.0 and d["tension_max"] == 0.0
    # the inputs matter: without them the heave differs by far more than round-off
    no_in = dataclasses.replace(run, applied=dataclasses.replace(run.applied, v=run.applied.v * 0.0))
    assert compare(run, resimulate(no_in))["heave_max"] > 1e-3
