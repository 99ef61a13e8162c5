"""The node's recording: the default file name and opening a :class:`RunRecorder` for the run.

May import rclpy (a node and its logger), :mod:`cable_sim.ros.recorder` (lazily: it needs mcap)
and the standard library.
"""

from __future__ import annotations

import os
import re
from datetime import UTC, datetime
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rclpy.node import Node

    from cable_sim.ros.recorder.writer import RunRecorder


def default_record_path(scene: str, node_fqn: str, start: datetime) -> str:
    """Default recording file ``runs/<scene>_<node>_<YYYYmmdd-HHMMSS-ffffff>.mcap``.

    Parameters
    ----------
    scene : str
        Scene name.
    node_fqn : str
        Fully qualified node name (``/leg1/cable_sim_node``); written as ``leg1.cable_sim_node``
        (every character other than letters, digits, ``_``, ``-`` and ``.`` becomes ``_``), so
        nodes of one launch in different namespaces never share a default name.
    start : datetime
        Start time (local time of day in the name, to the microsecond).
    """
    node = re.sub(r"[^A-Za-z0-9_.-]", "_", ".".join(p for p in node_fqn.split("/") if p)) or "node"
    stamp = start.astimezone().strftime("%Y%m%d-%H%M%S-%f")
    return os.path.join("runs", f"{scene}_{node}_{stamp}.mcap")


def open_recorder(node: Node) -> tuple[RunRecorder | None, str | None]:
    """The recorder of ``node``'s run, or None (``record`` false, or it cannot be opened).

    Returns ``(recorder, error)``: the error text when the file could not be opened (the
    simulation then runs without recording; the diagnostics report it).
    """
    if not node.get_parameter("record").value:
        return None, None
    try:
        from cable_sim.ros.recorder.metadata import run_metadata
        from cable_sim.ros.recorder.writer import RecorderError, RunRecorder
    except ImportError as exc:  # pragma: no cover - recorder needs mcap
        node.get_logger().error(f"recording disabled: {exc}")
        return None, None
    sim = node.sim
    start = datetime.now(UTC)
    fqn = node.get_fully_qualified_name()
    path = node.get_parameter("record_path").value or default_record_path(sim.scene.name, fqn, start)
    meta = run_metadata(dict(sim.scene.source), kernel=sim.kernel, integrator=sim.integrator.name,
                        step=node.h, n_links=sim.model.n, clock_mode=node.clock_mode, start=start, node=fqn)
    try:
        # an existing file is never overwritten: RunRecorder picks a new name and warns
        return RunRecorder(path, meta, logger=node.get_logger()), None
    except RecorderError as exc:
        node.get_logger().error(f"{exc}; the simulation runs without recording")
        return None, str(exc)
