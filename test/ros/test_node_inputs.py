"""Bad inputs and bad parameters are refused with a clear message while the node keeps running;
the reset and pause services work. The node runs in this process (fast clock)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from ros_util import init_context, isolate_ros, spin_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from cable_sim.ros.node import CableSimNode

DOMAIN = isolate_ros()


@pytest.fixture()
def rig():
    ctx = init_context(DOMAIN)
    sim_node = CableSimNode(context=ctx, parameter_overrides=[
        Parameter("scene", value="control_experiment"),
        Parameter("clock_mode", value="fast"),
        Parameter("record", value=False),
        Parameter("input_timeout", value=60.0),
    ])
    peer = rclpy.create_node("peer", context=ctx)
    states: list[JointState] = []
    peer.create_subscription(JointState, "joint_states", states.append, 50)
    pub = peer.create_publisher(Float64, "heave_force", 10)
    wave = peer.create_publisher(Float64, "wave_elevation", 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(sim_node)
    ex.add_node(peer)
    assert spin_until(ex, lambda: pub.get_subscription_count() > 0 and len(states) > 2, 30)
    yield {"node": sim_node, "peer": peer, "states": states, "pub": pub, "wave": wave, "ex": ex}
    ex.shutdown()
    sim_node.close()
    sim_node.destroy_node()
    peer.destroy_node()
    rclpy.try_shutdown(context=ctx)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 5.0e9])
def test_bad_heave_force_rejected_and_counted(rig, value):
    node, ex = rig["node"], rig["ex"]
    rig["pub"].publish(Float64(data=1000.0))  # a good value first: it must stay held
    assert spin_until(ex, lambda: node.sim.held_heave_force == 1000.0, 10)
    rig["pub"].publish(Float64(data=value))
    assert spin_until(ex, lambda: node.rejected["heave_force"] == 1, 10)
    assert node.sim.held_heave_force == 1000.0
    n = len(rig["states"])
    assert spin_until(ex, lambda: len(rig["states"]) > n + 20, 10)  # still running
    assert all(np.all(np.isfinite(m.position)) for m in rig["states"])
    assert node.diagnostics_values()["rejected_heave_force"] == "1"
    assert not node.failure


def test_bad_wave_elevation_rejected(rig):
    node, ex = rig["node"], rig["ex"]
    rig["wave"].publish(Float64(data=math.nan))
    rig["wave"].publish(Float64(data=1.0e6))
    assert spin_until(ex, lambda: node.rejected["wave_elevation"] == 2, 10)
    assert node.sim.held_wave_elevation == 0.0


def test_wrong_type_parameter_refused(rig):
    node = rig["node"]
    res = node.set_parameters([Parameter("joint_state_rate", value="fast")])[0]
    assert not res.successful and "type" in res.reason.lower(), res.reason
    assert node.get_parameter("joint_state_rate").value == 50.0


@pytest.mark.parametrize("name,value,word", [
    ("joint_state_rate", 1.0e6, "joint_state_rate"),
    ("heave_force_limit", -1.0, "heave_force_limit"),
    ("input_timeout", 0.0, "input_timeout"),
])
def test_out_of_range_parameter_refused(rig, name, value, word):
    node = rig["node"]
    before = node.get_parameter(name).value
    res = node.set_parameters([Parameter(name, value=value)])[0]
    assert not res.successful
    assert word in res.reason or "range" in res.reason.lower(), res.reason
    assert node.get_parameter(name).value == before
    n = len(rig["states"])
    assert spin_until(rig["ex"], lambda: len(rig["states"]) > n + 5, 10)


def test_structural_parameter_is_read_only(rig):
    res = rig["node"].set_parameters([Parameter("n_links", value=20)])[0]
    assert not res.successful and "read-only" in res.reason.lower(), res.reason
    assert rig["node"].sim.model.n == 8


def test_valid_rate_update_applies(rig):
    node = rig["node"]
    assert node.set_parameters([Parameter("joint_state_rate", value=20.0)])[0].successful
    assert node.every_js == round(1 / (20.0 * node.h))  # 20 Hz at h = 5 ms: every 10 steps


def _call(rig, srv_type, name, request):
    client = rig["peer"].create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=10)
    fut = client.call_async(request)
    assert spin_until(rig["ex"], fut.done, 10)
    return fut.result()


def test_pause_and_resume(rig):
    node, ex = rig["node"], rig["ex"]
    assert _call(rig, SetBool, "pause", SetBool.Request(data=True)).success
    k = node.sim.k
    spin_until(ex, lambda: False, 0.5)
    assert node.sim.k == k
    assert _call(rig, SetBool, "pause", SetBool.Request(data=False)).success
    assert spin_until(ex, lambda: node.sim.k > k + 50, 10)


def test_reset_returns_to_initial_state(rig):
    node, ex = rig["node"], rig["ex"]
    rig["pub"].publish(Float64(data=2.0e5))
    assert spin_until(ex, lambda: node.sim.t > 2.0, 30)
    assert not np.array_equal(node.sim.y, node.sim.y0)
    assert _call(rig, SetBool, "pause", SetBool.Request(data=True)).success
    res = _call(rig, Trigger, "reset", Trigger.Request())
    assert res.success and "t = 0" in res.message
    assert node.sim.k == 0 and node.sim.held_heave_force == 0.0
    np.testing.assert_array_equal(node.sim.y, node.sim.y0)
