"""Inputs from topics: ``heave_force`` and ``wave_elevation``, validated, counted, held, timed out.

A value is rejected (counted, logged, never applied) when it is not finite or exceeds its limit
parameter; an accepted value is held until the next one. Outside lockstep, a held value older
than ``input_timeout`` falls back to zero. Every received value is recorded as it came.

May import rclpy, std_msgs and the layers below.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

from std_msgs.msg import Float64

if TYPE_CHECKING:
    from rclpy.node import Node

INPUTS = ("heave_force", "wave_elevation")


def check_input(value: float, limit: float) -> str | None:
    """Why an input value is rejected (None if accepted)."""
    if not math.isfinite(value):
        return f"non-finite value {value!r}"
    if abs(value) > limit:
        return f"|{value:.6g}| exceeds the limit {limit:.6g}"
    return None


class TopicInputs:
    """Subscriptions of ``node`` to its inputs, with received / rejected counters.

    Parameters
    ----------
    node : cable_sim.ros.node.CableSimNode
        The node (its ``sim``, ``outputs``, ``pacing``, ``recorder`` and parameters).
    qos : QoSProfile
        QoS of the subscriptions.
    """

    def __init__(self, node: Node, qos) -> None:
        self.node = node
        self.received = dict.fromkeys(INPUTS, 0)
        self.rejected = dict.fromkeys(INPUTS, 0)
        self.last_input_wall = dict.fromkeys(INPUTS, 0.0)
        self.sub_heave_force = node.create_subscription(Float64, "heave_force", self.on_heave_force, qos)
        node.create_subscription(Float64, "wave_elevation", self.on_wave_elevation, qos)

    def accept(self, name: str, value: float) -> bool:
        """Count and record ``value`` of input ``name``; whether it passes :func:`check_input`."""
        node = self.node
        self.received[name] += 1
        if node.recorder is not None:
            node.recorder.write(node.outputs.topic[name], Float64(data=value), node.outputs.stamp())
        reason = check_input(value, node.get_parameter(f"{name}_limit").value)
        if reason is not None:
            self.rejected[name] += 1
            node.get_logger().warning(
                f"rejected {name} input: {reason} ({self.rejected[name]} rejected so far)",
                throttle_duration_sec=2.0)
            return False
        self.last_input_wall[name] = time.monotonic()
        return True

    def on_heave_force(self, msg: Float64) -> None:
        value = float(msg.data)
        if not self.accept("heave_force", value):
            return
        node = self.node
        if node.clock_mode == "lockstep":
            node.pacing.on_heave_force(value)
        elif value != node.sim.held_heave_force:
            node.sim.set_heave_force(value)
            node.outputs.publish_applied()

    def on_wave_elevation(self, msg: Float64) -> None:
        value = float(msg.data)
        if not self.accept("wave_elevation", value):
            return
        node = self.node
        if node.clock_mode == "lockstep":
            node.pacing.pending_wave = value  # applied at the next control-period boundary
        elif value != node.sim.held_wave_elevation:
            node.sim.set_wave_elevation(value)
            node.outputs.publish_applied()

    def check_timeouts(self) -> None:
        """Outside lockstep: a held input older than ``input_timeout`` falls back to zero."""
        node, sim = self.node, self.node.sim
        now, timeout = time.monotonic(), node.get_parameter("input_timeout").value
        for name, held, setter in (
            ("heave_force", sim.held_heave_force, sim.set_heave_force),
            ("wave_elevation", sim.held_wave_elevation, sim.set_wave_elevation),
        ):
            if held != 0.0 and now - self.last_input_wall[name] > timeout:
                setter(0.0)
                node.outputs.publish_applied()
                node.get_logger().warning(
                    f"{name} input older than input_timeout = {timeout:g} s: falling back to zero")
