"""The node's services: ``reset`` (std_srvs/Trigger) and ``pause`` (std_srvs/SetBool).

May import rclpy, std_srvs and the layers below.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from std_srvs.srv import SetBool, Trigger

if TYPE_CHECKING:
    from rclpy.node import Node


class NodeServices:
    """``reset`` and ``pause`` of ``node``."""

    def __init__(self, node: Node) -> None:
        self.node = node
        node.create_service(Trigger, "reset", self.on_reset)
        node.create_service(SetBool, "pause", self.on_pause)

    def on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Back to the scene's initial state at t = 0 (also after a failure or the end)."""
        node = self.node
        node.sim.reset()
        node.run.clear()
        lockstep = getattr(node.pacing, "clear", None)
        if lockstep is not None:
            lockstep()
        node.pacing.rebase(time.monotonic())
        node.clock.reset()
        node.outputs.publish_applied()
        node.outputs.clear_markers()  # RViz drops the markers of the run before the reset
        # in lockstep before the controller is connected, joint_states(t0) still waits for it
        node.outputs.publish_outputs(js=node.lockstep_started, mk=True, tn=True)
        response.success, response.message = True, "reset to the scene's initial state at t = 0"
        node.get_logger().info(response.message)
        return response

    def on_pause(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        """Pause (``data`` true) or resume; paused wall time does not count in the real-time factor."""
        node, run = self.node, self.node.run
        if request.data != run.paused:
            now = time.monotonic()
            node.clock.sample(now, node.sim.t)
            run.paused = bool(request.data)
            node.clock.set_paused(run.paused, now)
            node.pacing.rebase(now)
            if not run.paused and node.clock_mode == "lockstep":
                node.pacing.advance()
        response.success = True
        response.message = "paused" if run.paused else "running"
        return response
