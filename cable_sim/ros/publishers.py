"""The node's outputs: publishers, their topics, the rates in steps, and publishing with recording.

Every message the node publishes goes through :meth:`NodeOutputs.publish` (an rclpy message) or
:meth:`NodeOutputs.publish_bytes` (CDR bytes), which count it and hand it to the recorder with its
simulated-time stamp; the recording also gets ``/tf`` at every joint state and ``/tf_static`` +
``robot_description`` at its start (:mod:`cable_sim.ros.tf_output`). One serialisation serves both:
the periodic outputs (joint states, markers, wrenches, tensions, seabed contact) are encoded from
templates (:mod:`cable_sim.ros.encoders`: a copy and a few array writes, whatever n), and with a
recording any other message is serialised once and its bytes published and recorded. The wall time
of each part (outputs, messages, publish, record) goes to the node's
:class:`cable_sim.ros.timing.TickProfile`.
Outputs are checked before they are published: an :class:`IntegrationError` or a non-finite value
stops the run instead. With a seabed, ``seabed_contact`` goes out with the tensions, and the markers
draw the bed and the touchdown point, from one computation per published step
(:meth:`NodeOutputs.seabed_values`, shared with the diagnostics).

QoS (REP-2003): the streams are reliable, volatile, keep last 10 (:data:`STREAM_QOS`): the node is
a simulator, not a sensor driver, so a subscriber that can keep up gets every state (plots and
controllers need gap-free series; with best effort a reliable subscriber, the default of
``ros2 topic echo`` and rclpy, would not match at all), and a late joiner gets the next state
(no stale history). ``robot_description`` is reliable, transient local, keep last 1
(:data:`DESCRIPTION_QOS`), as robot_state_publisher offers it: a late subscriber still gets it.

May import rclpy, the ROS message packages, :mod:`cable_sim.ros.messages`, :mod:`cable_sim.ros.urdf`,
:mod:`cable_sim.ros.tf_output`, :mod:`cable_sim.ros.encoders`, :mod:`cable_sim.ros.recorder` (cdr,
definitions) and the layers below.
"""

from __future__ import annotations

from collections.abc import Callable
from time import perf_counter
from typing import TYPE_CHECKING, Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from visualization_msgs.msg import MarkerArray

from cable_sim.integrate import IntegrationError
from cable_sim.ros import encoders
from cable_sim.ros.messages import (
    build_float_array,
    build_robot_description,
    clock_message,
    joint_state_arrays,
    marker_values,
    markers_message,
    seabed_contact_values,
)
from cable_sim.ros.recorder.cdr import serialize
from cable_sim.ros.recorder.definitions import type_name_of
from cable_sim.ros.tf_output import TfRecording
from cable_sim.ros.urdf import urdf_for_model
from cable_sim.scene.simulation import Outputs

if TYPE_CHECKING:
    from rclpy.node import Node

#: Topics relative to the node's namespace (``/clock`` is global).
TOPICS = ("joint_states", "cable_markers", "fairlead_tension", "anchor_force", "line_tension",
          "diagnostics", "applied_inputs", "heave_force", "wave_elevation", "seabed_contact")
INPUT_TOPICS = ("heave_force", "wave_elevation")

#: QoS of the node's streams (every output but robot_description) and inputs.
STREAM_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                        durability=DurabilityPolicy.VOLATILE)
#: QoS of robot_description (as robot_state_publisher): latched for late subscribers.
DESCRIPTION_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)


class NodeOutputs:
    """Publishers of ``node`` (:data:`STREAM_QOS`; robot_description :data:`DESCRIPTION_QOS`) and what
    they have published. ``robot_description`` is published once, here (the scene's n is fixed for
    the node's life: a reset keeps it).

    Parameters
    ----------
    node : cable_sim.ros.node.CableSimNode
        The node (its ``sim``, ``h``, ``clock_mode``, ``frame_id``, ``recorder`` and ``run``).
    """

    def __init__(self, node: Node) -> None:
        self.node = node
        qos = STREAM_QOS
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
        if node.sim.model.seabed:
            self.pub["seabed_contact"] = pub(Float64MultiArray, "seabed_contact", qos)
        self.pub["diagnostics"] = pub(DiagnosticArray, "diagnostics", qos)
        self.pub["applied_inputs"] = pub(Float64MultiArray, "applied_inputs", qos)
        self.pub["robot_description"] = pub(String, "robot_description", DESCRIPTION_QOS)
        if node.clock_mode != "realtime":
            self.pub["clock"] = pub(Clock, "/clock", qos)
        ns = node.get_namespace().rstrip("/")
        self.topic = {name: f"{ns}/{name}" for name in (*TOPICS, "robot_description")}
        self.topic["clock"] = "/clock"
        self.published: dict[str, int] = {k: 0 for k in self.topic if k not in INPUT_TOPICS}
        #: The URDF of the simulated model (as ``cable_sim_urdf`` prints it for the same parameters).
        self.urdf = urdf_for_model(node.sim.model, f"cable_sim_{node.sim.scene.name}")
        self.description = build_robot_description(self.urdf)
        self.pub["robot_description"].publish(self.description)  # recorded with the first output
        self.published["robot_description"] = 1
        #: TF in the recording (None until the first recorded message).
        self._tf: TfRecording | None = None
        #: Start the next MarkerArray with DELETEALL (first markers, and after a reset).
        self._clear_markers = True
        self.last: Outputs | None = None
        #: Template encoders of the periodic outputs (n and frame fixed for the node's life).
        self.encoders = encoders.OutputEncoders(node.sim.model, node.frame_id)
        #: The outputs whose seabed values were computed last, and those values.
        self._seabed: tuple[Outputs | None, np.ndarray | None] = (None, None)
        #: Called with ``(outputs, stamp)`` after every publication of outputs: the place where a
        #: further view of the same state (e.g. /tf in the recording, a live viewer) plugs in.
        self.listeners: list[Callable[[Outputs, int], None]] = []
        self.rates_changed()

    def rates_changed(self) -> None:
        """Steps between joint states, markers, tensions and line tensions from the rate
        parameters (``line_tension_rate`` 0: with the tensions)."""
        def every(name: str) -> int:
            return max(1, int(round(1.0 / (self.node.get_parameter(name).value * self.node.h))))

        self.every_js = every("joint_state_rate")
        self.every_mk = every("marker_rate")
        self.every_tn = every("tension_rate")
        lt_rate = self.node.get_parameter("line_tension_rate").value
        self.every_lt = self.every_tn if lt_rate == 0.0 else every("line_tension_rate")

    def stamp(self) -> int:
        """Simulated time of the current step [ns]."""
        return int(round(self.node.sim.k * self.node.h * 1e9))

    def publish(self, name: str, msg, stamp: int) -> None:
        """Publish the rclpy message ``msg`` on output ``name`` (if that output exists), count and
        record it (serialised once, when recording: the same bytes are published and recorded)."""
        pub = self.pub.get(name)
        if pub is None or not self.node.context.ok():
            return
        rec = self.node.recorder
        data = None
        if rec is not None:
            w = perf_counter()
            try:
                data = serialize(msg)
            except Exception:  # noqa: BLE001 - never raise into the simulation: rclpy's path below
                data = None
            self.node.run.profile.add("messages", perf_counter() - w)
        if data is not None:
            self.publish_bytes(name, data, type_name_of(msg), stamp)
            return
        w = perf_counter()
        pub.publish(msg)
        self.node.run.profile.add("publish", perf_counter() - w)
        self.published[name] += 1
        if rec is not None:  # counts and logs the serialisation error, drops the message
            rec.write(self.topic[name], msg, stamp)

    def publish_bytes(self, name: str, data: bytes, type_name: str, stamp: int,
                      joint_positions: np.ndarray | None = None) -> None:
        """Publish the CDR bytes ``data`` (a ``type_name`` message) on output ``name`` (if that output
        exists), count and record them; ``joint_positions`` (JointState position) drive the
        recording's /tf."""
        pub = self.pub.get(name)
        if pub is None or not self.node.context.ok():  # a timer firing while a signal shuts rclpy down
            return
        profile = self.node.run.profile
        w = perf_counter()
        pub.publish(data)
        w1 = perf_counter()
        profile.add("publish", w1 - w)
        self.published[name] += 1
        rec = self.node.recorder
        if rec is not None:
            tf = self._tf if self._tf is not None else self._start_tf(rec, stamp)
            rec.write_serialized(self.topic[name], type_name, data, stamp)
            if joint_positions is not None:
                tf.joint_state(joint_positions, stamp)
            profile.add("record", perf_counter() - w1)

    def _joint_states(self, out: Outputs, stamp: int) -> None:
        w = perf_counter()
        pos, vel, eff = joint_state_arrays(out)
        data = self.encoders.joint_state(pos, vel, eff, stamp)
        self.node.run.profile.add("messages", perf_counter() - w)
        self.publish_bytes("joint_states", data, encoders.JOINT_STATE, stamp, joint_positions=pos)

    def _start_tf(self, rec: Any, stamp: int) -> TfRecording:
        """Start the recording's TF: ``robot_description`` and ``/tf_static`` at ``stamp``."""
        node = self.node
        self._tf = TfRecording(rec, node.sim.model, node.frame_id, self.topic["robot_description"])
        self._tf.start(self.description, stamp)
        return self._tf

    def clear_markers(self) -> None:
        """Send DELETEALL before the next markers (the reset service calls this)."""
        self._clear_markers = True

    def publish_clock(self) -> None:
        """``/clock`` at the current simulated time (fast and lockstep modes only)."""
        stamp = self.stamp()
        self.publish("clock", clock_message(stamp), stamp)

    def current(self) -> Outputs | None:
        """The simulation's outputs now; None (and the run stopped) if they cannot be published."""
        sim = self.node.sim
        w = perf_counter()
        try:
            out = sim.outputs()
        except IntegrationError as exc:
            self.node.run.fail(str(exc))
            return None
        finally:
            self.node.run.profile.add("outputs", perf_counter() - w)
        if not (np.all(np.isfinite(out.q)) and np.all(np.isfinite(out.axial_tension))
                and np.all(np.isfinite(out.fairlead_force))):
            self.node.run.fail("non-finite outputs (not published)")
            return None
        return out

    def seabed_values(self, out: Outputs) -> np.ndarray | None:
        """The ``seabed_contact`` values of ``out`` (None without a seabed), computed once per
        outputs (markers, topic and diagnostics share them)."""
        done, values = self._seabed
        if done is not out:
            w = perf_counter()
            values = seabed_contact_values(out, self.node.sim.model)
            self._seabed = (out, values)
            self.node.run.profile.add("outputs", perf_counter() - w)
        return values

    def publish_joint_states(self) -> None:
        """Joint states at the current step (lockstep: once per control period)."""
        out = self.current()
        if out is not None:
            self._joint_states(out, self.stamp())

    def publish_outputs(self, js: bool = False, mk: bool = False, tn: bool = False,
                        lt: bool | None = None, force_all: bool = False) -> None:
        """Publish the chosen outputs at the current step: joint states, markers, tensions (the
        fairlead/anchor wrenches and seabed_contact) and line tensions (``lt``; None: with ``tn``)."""
        if lt is None:
            lt = tn
        node = self.node
        out = self.current()
        if out is None:
            return
        stamp, frame = self.stamp(), node.frame_id
        seabed = self.seabed_values(out) if (mk or tn or force_all) else None
        if seabed is not None and not np.all(np.isfinite(seabed)):
            node.run.fail("non-finite seabed outputs (not published)")
            return
        if js or force_all:
            self._joint_states(out, stamp)
        enc, profile = self.encoders, node.run.profile
        if mk or force_all:
            clear, self._clear_markers = self._clear_markers, False
            w = perf_counter()
            values = marker_values(out, node.sim.model, seabed)
            if clear:  # the rare message that starts with DELETEALL: built, not templated
                msg = markers_message(values, node.sim.model, stamp, frame, delete_all=True)
                data = serialize(msg)
            else:
                data = enc.markers(values, stamp)
            profile.add("messages", perf_counter() - w)
            self.publish_bytes("cable_markers", data, encoders.MARKER_ARRAY, stamp)
        if tn or lt or force_all:
            w = perf_counter()
            msgs = []
            if tn or force_all:
                msgs.append(("fairlead_tension", enc.wrench(-out.fairlead_force, stamp), encoders.WRENCH))
                if "anchor_force" in self.pub:
                    msgs.append(("anchor_force", enc.wrench(-out.anchor_force, stamp), encoders.WRENCH))
            if lt or force_all:
                msgs.append(("line_tension", enc.line_tension(out.axial_tension), encoders.FLOAT_ARRAY))
            if (tn or force_all) and seabed is not None:
                msgs.append(("seabed_contact", enc.seabed_contact(seabed), encoders.FLOAT_ARRAY))
            profile.add("messages", perf_counter() - w)
            for name, data, type_name in msgs:
                self.publish_bytes(name, data, type_name, stamp)
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
