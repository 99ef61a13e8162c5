"""cable_sim_node: the rclpy adapter around :class:`cable_sim.scene.simulation.Simulation`.

All physics lives in the ROS-free core; this node declares the scene as ROS parameters, paces
the simulation (real time, as fast as possible with /clock, or lockstep with a controller),
turns inputs from topics into held inputs, publishes the outputs, and records the run to MCAP.
The interface (topics, types, units, QoS, parameters) is in ``msg_configs/interface.yaml`` and
the README.

The node composes small pieces, one idea each: :mod:`.parameters` (declarations, validation),
:mod:`.stepping` (one step and the outputs due), :mod:`.clock_modes` (pacing), :mod:`.timing`
(wall time, pauses, real-time factor), :mod:`.topic_inputs`, :mod:`.publishers`,
:mod:`.services`, :mod:`.diagnostics`, :mod:`.recording` and :mod:`.command_line`.

May import rclpy, the modules of :mod:`cable_sim.ros` and the layers below (scene, integrate, core).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from cable_sim.core.params import ParameterError
from cable_sim.ros.clock_modes import PACING, control_steps
from cable_sim.ros.command_line import ignored_cli_parameters
from cable_sim.ros.diagnostics import NodeDiagnostics
from cable_sim.ros.foxglove_view import start_foxglove_view
from cable_sim.ros.parameters import (
    CLOCK_MODES,
    check_node_parameters,
    declare_node_parameters,
    declare_scene,
)
from cable_sim.ros.publishers import NodeOutputs
from cable_sim.ros.recording import open_recorder
from cable_sim.ros.services import NodeServices
from cable_sim.ros.stepping import RunControl
from cable_sim.ros.timing import RunClock
from cable_sim.ros.topic_inputs import TopicInputs
from cable_sim.scene.simulation import Simulation


class CableSimNode(Node):
    """The cable simulation node (see the module docstring and the README's interface)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("cable_sim_node", **kwargs)
        self.scene = declare_scene(self)
        declare_node_parameters(self)
        self.add_on_set_parameters_callback(check_node_parameters)
        self.add_post_set_parameters_callback(lambda params: self.outputs.rates_changed())
        self.clock_mode = self.get_parameter("clock_mode").value
        if self.clock_mode not in CLOCK_MODES:
            raise ParameterError("clock_mode", self.clock_mode, " | ".join(CLOCK_MODES))
        self.frame_id = self.get_parameter("frame_id").value

        t_build = time.perf_counter()
        self._log_build_start()
        self.sim = Simulation(self.scene)
        self.sim.warm_up()  # compile before real time starts
        self.build_time = time.perf_counter() - t_build
        self.h = self.sim.h
        self.steps_per_control = control_steps(self.get_parameter("control_period").value, self.h,
                                               self.clock_mode == "lockstep")

        self.outputs = NodeOutputs(self)
        self.inputs = TopicInputs(self, self.outputs.qos)
        self.node_services = NodeServices(self)
        self.run = RunControl(self)
        self.diagnostics = NodeDiagnostics(self)
        self.recorder, self.record_error = open_recorder(self)
        self.foxglove = start_foxglove_view(self)
        self.clock = RunClock(time.monotonic())

        if self.clock_mode != "lockstep":
            self.outputs.publish_outputs(force_all=True)
        else:  # joint_states(t0) waits for a controller (see LockstepPacing.try_start)
            self.outputs.publish_outputs(mk=True, tn=True)
        self.pacing = PACING[self.clock_mode](self)
        self.diagnostics.start()
        if self.clock_mode != "lockstep":
            self.create_timer(0.1, self.inputs.check_timeouts)
        self._log_startup()

    def _log_build_start(self) -> None:
        """Say what the (possibly long, silent) build is doing before it starts: with the compiled
        kernel, the scene's steppers are compiled on the first start after an install or an
        upgrade (measured: 64 s on a 2-core machine for the default scene), later starts load
        them from its cache."""
        line = f"building scene '{self.scene.name}'"
        if self.scene.sim["kernel"] == "fast":
            cache = os.environ.get("NUMBA_CACHE_DIR", "the default kernel cache")
            line += (": compiling its kernels (the first start after an install or upgrade: about "
                     f"a minute on 2 cores) or loading them from {cache}")
        self.get_logger().info(line)

    # ------------------------------------------------------------------ views used by tests and tools
    @property
    def failure(self) -> str:
        """Why the run stopped ("" while it runs)."""
        return self.run.failure

    @property
    def rejected(self) -> dict[str, int]:
        """Rejected input values per input topic."""
        return self.inputs.rejected

    @property
    def every_js(self) -> int:
        """Steps between joint states."""
        return self.outputs.every_js

    @property
    def lockstep_started(self) -> bool:
        """False in lockstep until joint_states(t0) is published to a connected controller."""
        return self.clock_mode != "lockstep" or self.pacing.started

    @property
    def tick_times(self):
        """Wall times of the last timer ticks."""
        return self.clock.tick_times

    @property
    def tick_period(self) -> float | None:
        """Real-time tick period [s] (None in the other clock modes)."""
        return getattr(self.pacing, "tick_period", None)

    def diagnostics_values(self) -> dict[str, Any]:
        """Key/values of the diagnostics status (also used by tests and the benchmark)."""
        return self.diagnostics.values()

    def real_time_factor(self, now: float | None = None) -> tuple[float, float]:
        """``(windowed, mean)`` real-time factor (see :meth:`RunClock.real_time_factor`)."""
        return self.clock.real_time_factor(self.sim.t, now)

    def _log_startup(self) -> None:
        m, sim = self.sim.model, self.sim
        rate = {r: self.get_parameter(r).value for r in (
            "joint_state_rate", "marker_rate", "tension_rate", "line_tension_rate", "diagnostics_rate")}
        rate["line_tension_rate"] = rate["line_tension_rate"] or rate["tension_rate"]  # 0: with tensions
        rates = "/".join(f"{v:g}" for v in rate.values())
        rec = f"recording to {self.recorder.path}" if self.recorder else "not recording"
        duration = self.run.duration
        line = (
            f"simulating scene '{sim.scene.name}': n = {m.n} links, end = {m.params.end_condition}, "
            f"terms = [{', '.join(m.terms())}], integrator = {sim.integrator.name}, step = {self.h:g} s, "
            f"kernel = {sim.kernel}, clock = {self.clock_mode}, rates js/markers/tension/line_tension/diag = "
            f"{rates} Hz, duration = {duration if duration > 0 else 'unbounded'}, {rec}; "
            f"built in {self.build_time:.1f} s"
        )
        if sim.choice is not None:
            line += f"; chosen for the scene's tolerance: {sim.choice.reason}"
        self.get_logger().info(line)

    def close(self) -> None:
        """Close the recording and the live view (idempotent)."""
        if self.foxglove is not None:
            self.foxglove.close()
        if self.recorder is not None:
            self.recorder.close()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``cable_sim_node`` (``ros2 run cable_sim cable_sim_node``)."""
    os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)
    rclpy.init(args=args)
    node = None
    code = 0
    try:
        node = CableSimNode()
        problems = ignored_cli_parameters(node, sys.argv if args is None else args)
        if problems:
            print("cable_sim_node: " + "; ".join(problems), file=sys.stderr)
            code = 2
        else:
            rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except SystemExit as exc:
        code = int(exc.code or 0)
    except RCLError:
        if rclpy.ok():
            raise
        # a callback in flight when a signal shut rclpy down: the shutdown itself is clean
    except (ParameterError, ValueError, FileNotFoundError, ParameterException) as exc:
        print(f"cable_sim_node: {exc}", file=sys.stderr)
        code = 2
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == "__main__":
    sys.exit(main())
