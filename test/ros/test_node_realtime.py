"""Real-time mode with the default scene keeps up for 30 s: simulated time (joint-state stamps)
tracks the test's own wall clock within 2 %, and overruns are counted in diagnostics.
(Tick jitter figures live in the benchmark, python -m cable_sim.analysis.realtime_bench.)"""

from __future__ import annotations

import signal
import time

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from ros_util import diag_values, init_context, isolate_ros, spin_until, start_node, stop
from sensor_msgs.msg import JointState

# wall-clock rates and real-time factors: run apart from the parallel part of `make test`
pytestmark = pytest.mark.realtime

DOMAIN = isolate_ros()


def test_default_scene_keeps_real_time_for_30_s(tmp_path):
    proc = start_node("mooring_line", f"record_path:={tmp_path / 'rt.mcap'}", domain=DOMAIN, cwd=tmp_path)
    ctx = init_context(DOMAIN)
    node = rclpy.create_node("rt_observer", context=ctx)
    samples: list[tuple[float, float]] = []
    diags: list[DiagnosticArray] = []

    def on_js(m: JointState) -> None:
        samples.append((time.monotonic(), m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec))

    node.create_subscription(JointState, "joint_states", on_js, 100)
    node.create_subscription(DiagnosticArray, "diagnostics", diags.append, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        assert spin_until(ex, lambda: len(samples) > 10, 60)
        t0 = time.monotonic()
        spin_until(ex, lambda: time.monotonic() - t0 > 30.0, 40)
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        code, out = stop(proc, signal.SIGINT)
    assert code == 0, out
    w0, s0 = samples[5]
    w1, s1 = samples[-1]
    assert w1 - w0 > 29.0
    ratio = (s1 - s0) / (w1 - w0)
    print(f"sim/wall over {w1 - w0:.1f} s: {ratio:.4f}; last diagnostics: {diag_values(diags[-1])}")
    assert abs(ratio - 1.0) <= 0.02, ratio
    vals = diag_values(diags[-1])
    assert int(vals["overruns"]) >= 0 and float(vals["real_time_factor"]) > 0.9
