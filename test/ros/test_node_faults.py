"""The node under faults and edge conditions: a failed integration step or non-finite outputs
stop the simulation with an ERROR diagnostic and nothing non-finite published, the node stays up
and `reset` recovers; a stale input falls back to zero (applied_inputs says so); an unwritable
record path leaves the simulation running with a WARN; fast mode publishes /clock; with
``duration`` and ``exit_at_end`` the process ends with code 0 and a closed recording.

In-process nodes (fast clock) except the last test, which runs the installed console script.
"""

from __future__ import annotations

import dataclasses
import subprocess

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from ros_util import diag_values, init_context, isolate_ros, spin_until, start_node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from cable_sim.integrate import IntegrationError
from cable_sim.ros.node import CableSimNode

DOMAIN = isolate_ros()


class Rig:
    """A node in this process plus a peer that records what it publishes."""

    def __init__(self, *overrides: Parameter) -> None:
        self.ctx = init_context(DOMAIN)
        self.node = CableSimNode(context=self.ctx, parameter_overrides=[
            Parameter("scene", value="control_experiment"), Parameter("clock_mode", value="fast"),
            Parameter("record", value=False), *overrides])
        self.peer = rclpy.create_node("peer", context=self.ctx)
        self.states: list[JointState] = []
        self.diags: list[DiagnosticArray] = []
        self.applied: list[list[float]] = []
        self.clock: list[Clock] = []
        self.tension: list[list[float]] = []
        self.peer.create_subscription(JointState, "joint_states", self.states.append, 100)
        self.peer.create_subscription(DiagnosticArray, "diagnostics", self.diags.append, 10)
        self.peer.create_subscription(Float64MultiArray, "applied_inputs",
                                      lambda m: self.applied.append(list(m.data)), 100)
        self.peer.create_subscription(Clock, "/clock", self.clock.append, 100)
        self.peer.create_subscription(Float64MultiArray, "line_tension",
                                      lambda m: self.tension.append(list(m.data)), 100)
        self.pub = self.peer.create_publisher(Float64, "heave_force", 10)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)
        self.ex.add_node(self.peer)
        assert self.spin(lambda: self.pub.get_subscription_count() > 0 and len(self.states) > 2, 30)

    def spin(self, cond, timeout: float = 10.0) -> bool:
        return spin_until(self.ex, cond, timeout)

    def call(self, srv_type, name: str, request):
        client = self.peer.create_client(srv_type, name)
        assert client.wait_for_service(timeout_sec=10)
        fut = client.call_async(request)
        assert self.spin(fut.done, 10)
        return fut.result()

    def close(self) -> None:
        self.ex.shutdown()
        self.node.close()
        self.node.destroy_node()
        self.peer.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


@pytest.fixture()
def rig(request):
    r = Rig(*getattr(request, "param", ()))
    yield r
    r.close()


def _assert_stopped_with_error(rig: Rig, word: str) -> None:
    node = rig.node
    assert rig.spin(lambda: bool(node.failure), 10)
    assert word in node.failure, node.failure
    k = node.sim.k
    n_diag = len(rig.diags)
    assert rig.spin(lambda: len(rig.diags) > n_diag, 10)
    st = rig.diags[-1].status[0]
    assert st.level == DiagnosticStatus.ERROR and word in st.message, st.message
    rig.spin(lambda: False, 0.5)
    assert node.sim.k == k  # stopped stepping
    last = max(m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in rig.states)
    assert last <= round(k * node.h * 1e9), (last, k)  # nothing after the failure
    assert all(np.all(np.isfinite(m.position)) and np.all(np.isfinite(m.velocity))
               and np.all(np.isfinite(m.effort)) for m in rig.states)
    assert rig.tension and np.all(np.isfinite(rig.tension))
    assert rig.call(SetBool, "pause", SetBool.Request(data=True)).success  # still serving


def _assert_reset_recovers(rig: Rig) -> None:
    res = rig.call(Trigger, "reset", Trigger.Request())
    assert res.success
    assert not rig.node.failure
    assert rig.call(SetBool, "pause", SetBool.Request(data=False)).success
    n_js = len(rig.states)
    assert rig.spin(lambda: rig.node.sim.t > 1.0 and len(rig.states) > n_js + 20, 20)
    assert diag_values(rig.diags[-1]) is not None


def test_integration_error_stops_cleanly_and_reset_recovers(rig):
    sim = rig.node.sim
    real_step = sim.step
    calls = {"n": 0}

    def failing_step() -> None:  # the documented failure of Simulation.step
        calls["n"] += 1
        if calls["n"] == 50:
            raise IntegrationError(sim.t, "state became non-finite (injected)")
        real_step()

    sim.step = failing_step
    _assert_stopped_with_error(rig, "injected")
    sim.step = real_step
    _assert_reset_recovers(rig)


def test_non_finite_outputs_are_never_published(rig):
    sim = rig.node.sim
    real_outputs = sim.outputs

    def nan_outputs():
        out = real_outputs()
        if sim.t > 0.5:
            out = dataclasses.replace(out, axial_tension=np.full_like(out.axial_tension, np.nan))
        return out

    sim.outputs = nan_outputs
    _assert_stopped_with_error(rig, "non-finite")
    sim.outputs = real_outputs
    _assert_reset_recovers(rig)


@pytest.mark.parametrize("rig", [(Parameter("input_timeout", value=0.5),)], indirect=True)
def test_stale_input_falls_back_to_zero(rig):
    rig.pub.publish(Float64(data=1234.0))
    assert rig.spin(lambda: [1234.0, 0.0] in rig.applied, 10)
    assert rig.node.sim.held_heave_force == 1234.0
    assert rig.spin(lambda: rig.applied and rig.applied[-1] == [0.0, 0.0], 5)  # > 0.5 s: zero
    assert rig.node.sim.held_heave_force == 0.0
    n = len(rig.applied)
    rig.spin(lambda: False, 1.0)
    assert len(rig.applied) == n  # one fallback, not one per check
    n_js = len(rig.states)
    assert rig.spin(lambda: len(rig.states) > n_js + 5, 10)
    assert rig.states[-1].effort[0] == 0.0  # the applied heave force is zero again


@pytest.mark.parametrize("rig", [(Parameter("record", value=True),
                                  Parameter("record_path", value="/proc/no/such/dir/run.mcap"))],
                         indirect=True)
def test_unwritable_record_path_warns_and_runs(rig):
    assert rig.node.recorder is None
    n = len(rig.diags)
    assert rig.spin(lambda: len(rig.diags) > n, 10)
    st = rig.diags[-1].status[0]
    assert st.level == DiagnosticStatus.WARN and "record" in st.message, st.message
    assert "/proc/no/such/dir/run.mcap" in diag_values(rig.diags[-1]).get("recorder_last_error", "")
    k = rig.node.sim.k
    assert rig.spin(lambda: rig.node.sim.k > k + 100, 10)


def test_fast_mode_publishes_clock(rig):
    n = len(rig.clock)
    assert rig.spin(lambda: len(rig.clock) > n + 20, 10)
    ns = np.array([c.clock.sec * 1_000_000_000 + c.clock.nanosec for c in rig.clock[n:]])
    assert np.all(np.diff(ns) > 0)  # simulated time only moves forward
    assert np.all(ns % 5_000_000 == 0)  # and is k * h (h = 5 ms), not wall time


def test_duration_and_exit_at_end_exit_zero_with_closed_recording(tmp_path):
    path = tmp_path / "end.mcap"
    proc = start_node("control_experiment", "clock_mode:=fast", "duration:=3.0", "exit_at_end:=true",
                      f"record_path:={path}", domain=DOMAIN, cwd=tmp_path)
    try:
        out, _ = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert proc.returncode == 0, out
    assert "duration 3 s reached" in out, out
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()  # written by close(): the file was finished
    assert summary is not None and summary.statistics.message_count > 0
    counts = {summary.channels[cid].topic: n
              for cid, n in summary.statistics.channel_message_counts.items()}
    # rates in simulated time, t = 0 .. 3 s inclusive: joint states 50 Hz, markers 10 Hz
    assert counts["/joint_states"] == 151 and counts["/cable_markers"] == 31, counts


def _run_to_end(tmp_path, *overrides: str) -> tuple[int, str]:
    proc = start_node("control_experiment", "clock_mode:=fast", "duration:=0.2", "exit_at_end:=true",
                      *overrides, domain=DOMAIN, cwd=tmp_path)
    try:
        out, _ = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    return proc.returncode, out


def test_double_for_integer_parameter_on_command_line_is_refused(tmp_path):
    # rcl keeps the params file's `n_links: 8` and drops `-p n_links:=2.0` without a word
    code, out = _run_to_end(tmp_path, "n_links:=2.0", "record:=false")
    assert code == 2, out
    assert "n_links" in out and "integer" in out and "Traceback" not in out, out


def test_integer_for_double_parameter_on_command_line_is_taken(tmp_path):
    path = tmp_path / "int.mcap"
    code, out = _run_to_end(tmp_path, "heave_damping:=70000", f"record_path:={path}")
    assert code == 0, out
    import json

    from mcap.reader import make_reader

    with open(path, "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert json.loads(meta["scene"]["json"])["heave_damping"] == 70000.0
