"""The node in this process, for the benchmarks that time it (realtime_bench, recorder_bench).

Part of the analysis layer; imports rclpy and :mod:`cable_sim.ros.node` when used.
"""

from __future__ import annotations

import contextlib
import os
import random
import sys
from collections.abc import Iterator
from typing import Any


@contextlib.contextmanager
def in_process_node(**params: Any) -> Iterator[tuple[Any, Any]]:
    """rclpy initialised, a :class:`cable_sim.ros.node.CableSimNode` with ``params`` as parameter
    overrides and a single-threaded executor spinning it: ``(node, executor)``. On leaving, the
    node is closed (its recording too) and destroyed and rclpy shut down, whatever happened.

    Unless set, the ROS domain is a random one in 101..200 and discovery stays on localhost, so a
    benchmark does not meet other nodes.
    """
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 200)))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from cable_sim.ros.node import CableSimNode

    rclpy.init()
    try:
        node = CableSimNode(parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
        ex = SingleThreadedExecutor()
        ex.add_node(node)
        try:
            yield node, ex
        finally:
            node.close()
            ex.shutdown()
            node.destroy_node()
    finally:
        rclpy.try_shutdown()
