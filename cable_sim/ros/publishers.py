"""The node's outputs: publishers, their topics, the rates in steps, and publishing with recording.

Every message the node publishes goes through :meth:`NodeOutputs.publish`, which counts it and
hands it to the recorder with its simulated-time stamp. Outputs are checked before they are
published: an :class:`IntegrationError` or a non-finite value stops the run instead.

May import rclpy, the ROS message packages, :mod:`cable_sim.ros.messages` and the layers below.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from visualization_msgs.msg import MarkerArray

from cable_sim.integrate import IntegrationError
from cable_sim.ros.messages import (
    build_float_array,
    build_joint_state,
    build_markers,
    build_wrench,
    clock_message,
)
from cable_sim.scene.simulation import Outputs

if TYPE_CHECKING:
    from rclpy.node import Node

#: Topics relative to the node's namespace (``/clock`` is global).
TOPICS = ("joint_states", "cable_markers", "fairlead_tension", "anchor_force", "line_tension",
          "diagnostics", "applied_inputs", "heave_force", "wave_elevation")
INPUT_TOPICS = ("heave_force", "wave_elevation")


class NodeOutputs:
    """Publishers of ``node`` (reliable, keep last 10) and what they have published.

    Parameters
    ----------
    node : cable_sim.ros.node.CableSimNode
        The node (its ``sim``, ``h``, ``clock_mode``, ``frame_id``, ``recorder`` and ``run``).
    """

    def __init__(self, node: Node) -> None:
        self.node = node
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.qos = qos
        pub = node.create_publisher
        self.pub: dict[str, Any] = {
            "joint_states": pub(JointState, "joint_states", qos),
            "cable_markers": pub(MarkerArray, "cable_markers", qos),
            "fairlead_tension": pub(WrenchStamped, "fairlead_tension", qos),
        }
        if node.sim.model.end != 0:
            self.pub["anchor_force"] = pub(WrenchStamped, "anchor_force", qos)
        self.pub["line_tension"] = pub(Float64MultiArray, "line_tension", qos)
        self.pub["diagnostics"] = pub(DiagnosticArray, "diagnostics", qos)
        self.pub["applied_inputs"] = pub(Float64MultiArray, "applied_inputs", qos)
        if node.clock_mode != "realtime":
            self.pub["clock"] = pub(Clock, "/clock", qos)
        ns = node.get_namespace().rstrip("/")
        self.topic = {name: f"{ns}/{name}" for name in TOPICS}
        self.topic["clock"] = "/clock"
        self.published: dict[str, int] = {k: 0 for k in self.topic if k not in INPUT_TOPICS}
        self.last: Outputs | None = None
        #: Called with ``(outputs, stamp)`` after every publication of outputs: the place where a
        #: further view of the same state (e.g. /tf in the recording, a live viewer) plugs in.
        self.listeners: list[Callable[[Outputs, int], None]] = []
        self.rates_changed()

    def rates_changed(self) -> None:
        """Steps between joint states, markers and tensions from the rate parameters."""
        def every(name: str) -> int:
            return max(1, int(round(1.0 / (self.node.get_parameter(name).value * self.node.h))))

        self.every_js = every("joint_state_rate")
        self.every_mk = every("marker_rate")
        self.every_tn = every("tension_rate")

    def stamp(self) -> int:
        """Simulated time of the current step [ns]."""
        return int(round(self.node.sim.k * self.node.h * 1e9))

    def publish(self, name: str, msg, stamp: int) -> None:
        """Publish ``msg`` on output ``name`` (if that output exists), count and record it."""
        pub = self.pub.get(name)
        if pub is None or not self.node.context.ok():  # a timer firing while a signal shuts rclpy down
            return
        pub.publish(msg)
        self.published[name] += 1
        if self.node.recorder is not None:
            self.node.recorder.write(self.topic[name], msg, stamp)

    def publish_clock(self) -> None:
        """``/clock`` at the current simulated time (fast and lockstep modes only)."""
        stamp = self.stamp()
        self.publish("clock", clock_message(stamp), stamp)

    def current(self) -> Outputs | None:
        """The simulation's outputs now; None (and the run stopped) if they cannot be published."""
        sim = self.node.sim
        try:
            out = sim.outputs()
        except IntegrationError as exc:
            self.node.run.fail(str(exc))
            return None
        if not (np.all(np.isfinite(out.q)) and np.all(np.isfinite(out.axial_tension))
                and np.all(np.isfinite(out.fairlead_force))):
            self.node.run.fail("non-finite outputs (not published)")
            return None
        return out

    def publish_joint_states(self) -> None:
        """Joint states at the current step (lockstep: once per control period)."""
        out = self.current()
        if out is not None:
            stamp = self.stamp()
            self.publish("joint_states", build_joint_state(out, stamp, self.node.frame_id), stamp)

    def publish_outputs(self, js: bool = False, mk: bool = False, tn: bool = False,
                        force_all: bool = False) -> None:
        """Publish the chosen outputs (joint states, markers, tensions) at the current step."""
        node = self.node
        out = self.current()
        if out is None:
            return
        stamp, frame = self.stamp(), node.frame_id
        if js or force_all:
            self.publish("joint_states", build_joint_state(out, stamp, frame), stamp)
        if mk or force_all:
            self.publish("cable_markers", build_markers(out, node.sim.model, stamp, frame), stamp)
        if tn or force_all:
            self.publish("fairlead_tension", build_wrench(-out.fairlead_force, stamp, frame), stamp)
            if "anchor_force" in self.pub:
                self.publish("anchor_force", build_wrench(-out.anchor_force, stamp, frame), stamp)
            self.publish("line_tension", build_float_array(out.axial_tension), stamp)
        for listener in self.listeners:
            listener(out, stamp)
        problems = node.sim.health(out)
        if problems:
            node.get_logger().warning("; ".join(problems), throttle_duration_sec=5.0)
        self.last = out

    def publish_applied(self) -> None:
        """``applied_inputs``: the held heave force and wave elevation."""
        sim = self.node.sim
        self.publish("applied_inputs", build_float_array([sim.held_heave_force, sim.held_wave_elevation]),
                     self.stamp())
