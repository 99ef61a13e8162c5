"""Replay of a long run (issue 9, item 8): a bounded GIF, progress lines, fast loading.

The 10-minute recording is synthetic: joint states of a 5-link mooring line written with the
project's :class:`~cable_sim.ros.recorder.RunRecorder` (no simulation, so it takes seconds), with the
scene and run metadata the node writes. The decoded arrays are compared with the messages as built
here and with the generic ``mcap_ros2`` decoder.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mcap.reader import make_reader
from PIL import Image

from cable_sim.analysis.replay import cdr, gif_frame_indices, load_run, main
from cable_sim.ros.messages import build_float_array, build_wrench
from cable_sim.ros.recorder import RunRecorder, run_metadata
from cable_sim.scene.scenes import load_scene

pytestmark = pytest.mark.timeout(300)

N = 5
DURATION = 600.0
RATE = 20.0  # joint states per second: 12 001 messages
K = int(DURATION * RATE) + 1


def _angles(t: float) -> list[float]:
    """Relative joint angles at time t (a slow swing; any values will do for the replay)."""
    return [0.9 + 0.05 * math.sin(0.3 * t)] + [0.1 * math.sin(0.1 * t + i) for i in range(N - 1)]


@pytest.fixture(scope="module")
def long_run(tmp_path_factory):
    from sensor_msgs.msg import JointState

    scene = load_scene("mooring_line", {"n_links": N})
    path = tmp_path_factory.mktemp("gif") / "long.mcap"
    meta = run_metadata(dict(scene.source), kernel="fast", integrator="rk4", step=0.01, n_links=N,
                        clock_mode="fast")
    rec = RunRecorder(path, meta, max_queue=4 * K)  # a tight loop: no drops
    names = ["platform_heave"] + [f"joint_{i + 1}" for i in range(N)]
    try:
        for k in range(K):
            t = k / RATE
            ns = round(t * 1e9)
            msg = JointState(name=names, position=[0.2 * math.sin(t)] + _angles(t),
                             velocity=[float(k)] * (N + 1), effort=[-float(k)] * (N + 1))
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
            rec.write("/joint_states", msg, ns, ns)
            if k % 20 == 0:  # 1 Hz tensions
                rec.write("/fairlead_tension", build_wrench(np.array([1e3 + k, -2e3 - k]), ns, "world"),
                          ns, ns)
                rec.write("/line_tension", build_float_array(np.arange(N) + k), ns, ns)
    finally:
        rec.close()
    assert rec.stats["messages_dropped"] == 0 and rec.stats["errors"] == 0, rec.stats
    return rec.path


def test_long_run_loads_every_sample_with_the_fast_decoder(long_run):
    run = load_run(long_run)
    assert run.n_links == N and len(run.t) == K
    assert np.array_equal(run.t_ns, np.round(np.arange(K) / RATE * 1e9).astype(np.int64))
    k = 4321
    assert np.array_equal(run.joint_position[k], [0.2 * math.sin(k / RATE)] + _angles(k / RATE))
    assert np.array_equal(run.joint_velocity[:, 0], np.arange(K, dtype=float))
    assert np.array_equal(run.joint_effort[:, -1], -np.arange(K, dtype=float))
    assert len(run.fairlead) == len(run.line_tension) == (K - 1) // 20 + 1
    assert np.array_equal(run.fairlead.v[3], [1e3 + 60, -2e3 - 60])
    assert np.array_equal(run.line_tension.v[3], np.arange(N) + 60.0)
    # only joint states: the other series are empty, the counts still complete (from the summary)
    js = load_run(long_run, topics=["joint_states"])
    assert np.array_equal(js.joint_position, run.joint_position) and len(js.fairlead) == 0
    assert js.counts == run.counts == {"/joint_states": K, "/fairlead_tension": 601, "/line_tension": 601}
    with pytest.raises(ValueError, match="cable_markers"):
        load_run(long_run, topics=["cable_markers"])


def test_fast_decoder_agrees_with_mcap_ros2(long_run):
    generic, fast = cdr.decoders(), cdr.fast_decoders()
    with open(long_run, "rb") as f:
        for i, (schema, _, message) in enumerate(make_reader(f).iter_messages()):
            if i % 97:
                continue
            a, b = generic(schema, message.data), fast(schema, message.data)
            assert type(b) is cdr.Obj, schema.name  # the fast path was taken
            if schema.name == "sensor_msgs/msg/JointState":
                for field in ("position", "velocity", "effort"):
                    assert np.array_equal(getattr(a, field), getattr(b, field))
                assert (a.header.stamp.sec, a.header.stamp.nanosec) == (b.header.stamp.sec,
                                                                        b.header.stamp.nanosec)
            elif schema.name == "geometry_msgs/msg/WrenchStamped":
                assert (a.wrench.force.x, a.wrench.force.z) == (b.wrench.force.x, b.wrench.force.z)
            else:
                assert np.array_equal(a.data, b.data)


def test_gif_of_long_run_is_bounded_and_shows_progress(long_run, tmp_path, capsys):
    gif = tmp_path / "long.gif"
    assert main([str(long_run), "--gif", str(gif), "--quiet"]) == 0
    err = capsys.readouterr().err
    reads = [ln for ln in err.splitlines() if "messages (" in ln]
    frames = [ln for ln in err.splitlines() if ": frame " in ln]
    assert len(reads) == 10 and reads[-1].startswith(f"long.mcap: read {K}/{K} messages (100%")
    assert len(frames) == 10 and frames[-1].startswith("long.gif: frame 100/100 (100%")
    with Image.open(gif) as im:
        assert im.n_frames == 100  # 10 s at 10 fps
        assert im.info["duration"] == 100  # ms per frame: 10 fps

    small = tmp_path / "small.gif"
    assert main([str(long_run), "--gif", str(small), "--quiet", "--gif-seconds", "3",
                 "--gif-fps", "5", "--gif-interval", "1.0"]) == 0
    with Image.open(small) as im:
        assert im.n_frames == 15
    with pytest.raises(SystemExit):
        main([str(long_run), "--gif", str(small), "--gif-fps", "0"])
    assert "--gif-fps 0.0: must be > 0" in capsys.readouterr().err


def test_gif_frames_span_the_run_evenly(long_run):
    run = load_run(long_run, topics=["joint_states"])
    idx = gif_frame_indices(run, seconds=10.0, fps=10.0)
    t = run.t[idx]
    assert len(idx) == 100 and t[0] == 0.0 and t[-1] == DURATION
    assert np.allclose(np.diff(t), DURATION / 99, atol=1.0 / RATE)
    # a run shorter than the GIF plays in real time: one frame every 1/fps s
    short = load_run(long_run, topics=["joint_states"])
    short.t = short.t[:61]  # 3 s
    assert np.allclose(short.t[gif_frame_indices(short, 10.0, 10.0)], np.arange(0, 3.01, 0.1))
    for kw, name in (({"seconds": 0.0}, "gif seconds"), ({"fps": -1.0}, "gif fps"),
                     ({"interval": 0.0}, "frame interval")):
        with pytest.raises(ValueError, match=name):
            gif_frame_indices(run, **kw)
