"""Lockstep mode: a controller in the test process closes the loop over topics.

The node advances one control period per heave_force message, so the result does not depend on
how fast the controller answers: a PD heave controller reduces the platform's heave amplitude
under the control_experiment scene's regular wave, and two runs with the same inputs give
bit-identical joint states. The controller only answers joint states (it never publishes first):
the node publishes joint_states(t0) once the controller is connected both ways, so a controller
started after the node does not wait forever.
"""

from __future__ import annotations

import signal

import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from ros_util import init_context, isolate_ros, spin_until, start_node, stop
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

DOMAIN = isolate_ros()
PERIODS = 400  # x 0.05 s = 20 s of simulated time
KP, KD = 150000.0, 200000.0  # N/m, N s/m


def closed_loop(tmp_path, gains: tuple[float, float] | None, tag: str) -> np.ndarray:
    """Run the node in lockstep with a controller; return joint positions per period."""
    proc = start_node("control_experiment", "clock_mode:=lockstep", "control_period:=0.05",
                      f"record_path:={tmp_path / (tag + '.mcap')}", domain=DOMAIN, cwd=tmp_path)
    ctx = init_context(DOMAIN)
    node = rclpy.create_node(f"controller_{tag}", context=ctx)
    pub = node.create_publisher(Float64, "heave_force", 10)
    states: list[tuple[int, list[float], list[float]]] = []

    def on_js(m: JointState) -> None:
        stamp = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
        if states and stamp == states[-1][0]:
            return
        states.append((stamp, list(m.position), list(m.velocity)))
        if len(states) <= PERIODS:
            z, zd = m.position[0], m.velocity[0]
            u = 0.0 if gains is None else -gains[0] * z - gains[1] * zd
            pub.publish(Float64(data=u))

    node.create_subscription(JointState, "joint_states", on_js, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0
                          and node.count_publishers("joint_states") > 0, 60), "node not found"
        assert spin_until(ex, lambda: len(states) > PERIODS, 120), len(states)
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        code, out = stop(proc, signal.SIGINT)
        assert code == 0, out
    stamps = np.array([s[0] for s in states[: PERIODS + 1]])
    assert stamps[0] == 0  # the first state the controller sees is the initial one
    np.testing.assert_array_equal(np.diff(stamps), 50_000_000)  # one state per control period
    return np.array([s[1] for s in states[: PERIODS + 1]])


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("lockstep")
    return {
        "open": closed_loop(tmp, None, "open"),
        "pd1": closed_loop(tmp, (KP, KD), "pd1"),
        "pd2": closed_loop(tmp, (KP, KD), "pd2"),
    }


def test_controller_reduces_heave_amplitude(runs):
    def amplitude(pos: np.ndarray) -> float:
        z = pos[200:, 0]  # the last 10 s (the wave ramp lasts 6 s)
        return 0.5 * float(z.max() - z.min())

    a_open, a_pd = amplitude(runs["open"]), amplitude(runs["pd1"])
    print(f"heave amplitude: open loop {a_open:.4f} m, PD {a_pd:.4f} m")
    assert a_open > 0.3, a_open  # the wave really moves the platform
    assert a_pd < 0.5 * a_open, (a_pd, a_open)


def test_same_inputs_bit_identical(runs):
    np.testing.assert_array_equal(runs["pd1"], runs["pd2"])
    assert not np.array_equal(runs["pd1"], runs["open"])


def test_controller_started_after_the_node_gets_the_initial_state(tmp_path):
    """Regression: joint_states(t0) published before any subscriber was lost and the node waited
    for an answer forever. Now a controller that connects 2 s after the node still starts it."""
    proc = start_node("control_experiment", "clock_mode:=lockstep", "record:=false",
                      domain=DOMAIN, cwd=tmp_path)
    ctx = init_context(DOMAIN)
    node = rclpy.create_node("late_controller", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    stamps: list[int] = []
    try:
        assert spin_until(ex, lambda: node.count_publishers("joint_states") > 0, 60), "node not found"
        spin_until(ex, lambda: False, 2.0)  # the node is up and has long published its t0 outputs
        pub = node.create_publisher(Float64, "heave_force", 10)

        def on_js(m: JointState) -> None:
            stamps.append(m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec)
            pub.publish(Float64(data=0.0))

        node.create_subscription(JointState, "joint_states", on_js, 10)
        assert spin_until(ex, lambda: len(stamps) > 10, 30), stamps
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        code, out = stop(proc, signal.SIGINT)
        assert code == 0, out
    assert stamps[:11] == [k * 50_000_000 for k in range(11)]
