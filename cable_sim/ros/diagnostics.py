"""The node's diagnostics: key/values of the run (timing, inputs, outputs, seabed, recorder) and their status.

May import rclpy, diagnostic_msgs and :mod:`cable_sim.ros.messages`.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus

from cable_sim.ros.messages import build_diagnostics

if TYPE_CHECKING:
    from rclpy.node import Node


#: Diagnostic keys of the seabed outputs (scenes with a seabed) and their index in the values of
#: :func:`cable_sim.ros.messages.seabed_contact_values`.
SEABED_KEYS = {"touchdown_arc_length": 0, "touchdown_x": 1, "laid_length": 2, "seabed_reaction": 3}


def _repr_or_nan(out, field: str) -> str:
    return repr(getattr(out, field)) if out is not None else "nan"


class NodeDiagnostics:
    """Diagnostics of ``node``, published every 1 / ``diagnostics_rate`` s of wall time."""

    def __init__(self, node: Node) -> None:
        self.node = node

    def start(self) -> None:
        """Create the diagnostics timer (the rate is read once, at the start)."""
        self.node.create_timer(1.0 / self.node.get_parameter("diagnostics_rate").value, self.publish)

    def values(self) -> dict[str, Any]:
        """Key/values of the diagnostics status (also used by tests and the benchmark)."""
        node, run, clock = self.node, self.node.run, self.node.clock
        inputs = node.inputs
        now = time.monotonic()
        wall = now - clock.start_wall
        rtf, rtf_mean = clock.real_time_factor(node.sim.t, now)
        out = node.outputs.last
        ticks = clock.tick_intervals()
        v: dict[str, Any] = {
            "sim_time": repr(node.sim.t),
            "wall_time": repr(wall),
            "real_time_factor": repr(rtf),
            "real_time_factor_mean": repr(rtf_mean),
            "paused_time": repr(wall - clock.active_wall(now)),
            "step_cost_us": repr(1e6 * run.step_wall / max(run.steps_done, 1)),
            "steps": str(node.sim.k),
            **{f: _repr_or_nan(out, f) for f in ("energy", "fairlead_tension", "constraint_drift", "slack")},
            "rejected_heave_force": str(inputs.rejected["heave_force"]),
            "rejected_wave_elevation": str(inputs.rejected["wave_elevation"]),
            "rejected_inputs": str(sum(inputs.rejected.values())),
            "received_heave_force": str(inputs.received["heave_force"]),
            "received_wave_elevation": str(inputs.received["wave_elevation"]),
            "overruns": str(run.overruns),
            "tick_interval_p50_ms": repr(1e3 * float(np.percentile(ticks, 50))),
            "tick_interval_p99_ms": repr(1e3 * float(np.percentile(ticks, 99))),
            "tick_interval_max_ms": repr(1e3 * float(ticks.max())),
            "paused": str(run.paused),
            "failure": run.failure,
        }
        if node.sim.model.seabed:
            seabed = node.outputs.seabed_values(out) if out is not None else None
            for key, i in SEABED_KEYS.items():
                v[key] = repr(float(seabed[i])) if seabed is not None else "nan"
        for name, count in node.outputs.published.items():
            v[f"published_{name}"] = str(count)
        if node.recorder is not None:
            st = node.recorder.stats
            v["recorder_path"] = st["path"]
            v["recorder_messages_written"] = str(st["messages_written"])
            v["recorder_messages_dropped"] = str(st["messages_dropped"])
            v["recorder_errors"] = str(st["errors"])
            v["recorder_last_error"] = st["last_error"]
        elif node.record_error is not None:
            v["recorder_last_error"] = node.record_error
        return v

    def status(self) -> tuple[int, str]:
        """Level and message of the status: ERROR when stopped, WARN on recording or input trouble."""
        node, run = self.node, self.node.run
        rejected = sum(node.inputs.rejected.values())
        if run.failure:
            return DiagnosticStatus.ERROR, f"stopped: {run.failure}"
        if (node.recorder is None and node.get_parameter("record").value) or (
                node.recorder is not None and node.recorder.stats["errors"]):
            return DiagnosticStatus.WARN, "recording failed; simulation running"
        if run.overruns or rejected:
            return DiagnosticStatus.WARN, f"{run.overruns} overruns, {rejected} rejected inputs"
        return DiagnosticStatus.OK, "paused" if run.paused else "running"

    def publish(self) -> None:
        """Publish (and record) the diagnostics now."""
        v = self.values()
        stamp = self.node.outputs.stamp()
        msg = build_diagnostics(v, stamp)
        st = msg.status[0]
        st.name = f"{self.node.get_name()}: cable simulation"
        st.level, st.message = self.status()
        self.node.outputs.publish("diagnostics", msg, stamp)
        view = getattr(self.node, "foxglove", None)
        if view is not None:  # the live Foxglove view's plottable diagnostics (handed over, not awaited)
            level = st.level[0] if isinstance(st.level, bytes) else int(st.level)
            view.publish_diagnostics(v, self.node.sim.t, level, st.message)
