"""One physics step at a time: the outputs due at each step, stopping on failure or at the end.

A run is *running* unless it is paused, failed (an :class:`IntegrationError` or non-finite
outputs: it stays stopped until the ``reset`` service) or finished (the scene's duration).

May import rclpy and the layers below (scene, integrate).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from cable_sim.integrate import IntegrationError
from cable_sim.ros.timing import TickProfile

if TYPE_CHECKING:
    from rclpy.node import Node


class RunControl:
    """Stepping state of ``node``'s simulation: paused, failure, finished, step cost.

    Parameters
    ----------
    node : cable_sim.ros.node.CableSimNode
        The node (its ``sim``, ``outputs``, ``diagnostics`` and parameters).
    """

    def __init__(self, node: Node) -> None:
        self.node = node
        self.duration = float(node.scene.sim["duration"])
        self.paused = False
        self.failure = ""
        self.finished = False
        self.overruns = 0
        self.step_wall = 0.0
        self.steps_done = 0
        #: Wall time per part of the run (physics here; outputs, messages, publish, record in
        #: :class:`cable_sim.ros.publishers.NodeOutputs`; ticks in the real-time pacing).
        self.profile = TickProfile()

    def running(self) -> bool:
        """Whether the simulation may advance (not paused, failed or finished)."""
        return not (self.paused or self.failure or self.finished)

    def clear(self) -> None:
        """Forget a failure or the end of the scene (reset)."""
        self.failure = ""
        self.finished = False

    def step_once(self) -> bool:
        """One physics step plus the outputs due at the new step; False when stopped."""
        node, sim = self.node, self.node.sim
        w = time.perf_counter()
        try:
            sim.step()
        except IntegrationError as exc:
            self.fail(str(exc))
            return False
        dt = time.perf_counter() - w
        self.step_wall += dt
        self.profile.add("physics", dt)
        self.steps_done += 1
        k, o = sim.k, node.outputs
        due = (node.clock_mode != "lockstep" and k % o.every_js == 0, k % o.every_mk == 0,
               k % o.every_tn == 0, k % o.every_lt == 0)
        if any(due):
            o.publish_outputs(*due)
        if self.duration > 0 and sim.t >= self.duration - 1e-9:
            self.finish()
            return False
        return not self.failure

    def fail(self, reason: str) -> None:
        """Stop the run: log the reason and publish an ERROR diagnostic."""
        self.failure = reason
        self.node.get_logger().error(f"simulation stopped at t = {self.node.sim.t:.4f} s: {reason}; "
                                     "call the 'reset' service to start again")
        self.node.diagnostics.publish()

    def finish(self) -> None:
        """The scene's duration is reached: stop, and exit with ``exit_at_end``."""
        self.finished = True
        self.node.get_logger().info(f"scene duration {self.duration:g} s reached")
        self.node.diagnostics.publish()
        if self.node.get_parameter("exit_at_end").value:
            raise SystemExit(0)
