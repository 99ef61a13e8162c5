"""cable_sim_node: the rclpy adapter around :class:`cable_sim.scene.simulation.Simulation`.

All physics lives in the ROS-free core; this node declares the scene as ROS parameters, paces
the simulation (real time, as fast as possible with /clock, or lockstep with a controller),
turns inputs from topics into held inputs, publishes the outputs, and records the run to MCAP.
The interface (topics, types, units, QoS, parameters) is in ``msg_configs/interface.yaml`` and
the README.
"""

from __future__ import annotations

import math
import os
import re
import sys
import time
from collections import deque
from datetime import UTC, datetime
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from cable_sim.core.params import CableParams, ParameterError
from cable_sim.integrate import IntegrationError
from cable_sim.ros.messages import (
    build_diagnostics,
    build_float_array,
    build_joint_state,
    build_markers,
    build_wrench,
    clock_message,
)
from cable_sim.scene.scenes import (
    SIM_DEFAULTS,
    available_scenes,
    read_parameter_file,
    scene_from_dict,
    scene_path,
)
from cable_sim.scene.simulation import Outputs, Simulation

DEFAULT_SCENE = "mooring_line"
CLOCK_MODES = ("realtime", "fast", "lockstep")
#: Tick wall times kept for the tick-interval diagnostics (120 s at the 50 Hz real-time tick).
TICK_HISTORY = 6000
#: Window of the reported real-time factor [s of wall time, pauses excluded].
RTF_WINDOW = 10.0
#: Interval between (wall, sim time) samples of the real-time factor [s]; RTF_SAMPLES bounds them.
RTF_SAMPLE_INTERVAL = 0.25
RTF_SAMPLES = int(RTF_WINDOW / RTF_SAMPLE_INTERVAL) + 8

#: Built-in input keys a scene may leave out (defaults; see cable_sim.core.inputs.make_signal).
INPUT_DEFAULTS: dict[str, Any] = {
    "heave_force_amplitude": 0.0, "heave_force_period": 10.0, "heave_force_phase": 0.0,
    "heave_force_ramp": 0.0, "heave_force_value": 0.0,
    "wave_amplitude": 0.0, "wave_period": 10.0, "wave_phase": 0.0, "wave_ramp": 0.0,
    "wave_value": 0.0, "wave_hs": 2.0, "wave_tp": 10.0, "wave_gamma": 3.3, "wave_seed": 0,
    "frame_interval": 1.0,
}

#: Node settings: name -> (default, description, (low, high) or None). Changeable at run time.
NODE_PARAMS: dict[str, tuple[Any, str, tuple[float, float] | None]] = {
    "joint_state_rate": (50.0, "JointState publication rate [Hz] (sim time)", (0.1, 1000.0)),
    "marker_rate": (10.0, "MarkerArray publication rate [Hz] (sim time)", (0.1, 1000.0)),
    "tension_rate": (20.0, "fairlead/anchor force and line tension rate [Hz]", (0.1, 1000.0)),
    "diagnostics_rate": (1.0, "diagnostics rate [Hz] (wall time)", (0.05, 100.0)),
    "input_timeout": (2.0, "an input older than this [s] falls back to zero (not lockstep)",
                      (0.01, 3600.0)),
    "heave_force_limit": (1.0e7, "largest accepted |heave_force| [N]", (1.0, 1.0e12)),
    "wave_elevation_limit": (30.0, "largest accepted |wave_elevation| [m]", (0.01, 1000.0)),
}
READ_ONLY_NODE: dict[str, tuple[Any, str]] = {
    "clock_mode": ("realtime", "realtime | fast (publishes /clock) | lockstep (waits for heave_force)"),
    "control_period": (0.05, "lockstep: simulated time [s] advanced per heave_force message"),
    "record": (True, "record the run to MCAP"),
    "record_path": ("", "MCAP file; default runs/<scene>_<node>_<YYYYmmdd-HHMMSS-ffffff>.mcap (<node>: "
                        "namespace.name); an existing file is never overwritten (-1, -2, ... is added)"),
    "frame_id": ("world", "frame of all stamped outputs (x-z plane, z up)"),
    "exit_at_end": (False, "with duration > 0: stop, close the recording and exit 0 at the end"),
}
STRUCTURAL = set(CableParams.field_names()) | set(SIM_DEFAULTS) | set(INPUT_DEFAULTS)

#: Every scene key: (unit, description, allowed values). Read-only parameters of the node; the
#: same text is in msg_configs/interface.yaml (test_node_interface_data checks they agree).
SCENE_DOCS: dict[str, tuple[str, str, str]] = {
    # cable (cable_sim.core.params.CableParams)
    "n_links": ("", "number of rigid links n (n + 1 degrees of freedom)", "integer >= 1"),
    "total_length": ("m", "unstretched cable length L (links L/n long)", "> 0"),
    "link_lengths": ("m", "per-link lengths (override total_length)", "n values > 0"),
    "diameter": ("m", "hydrodynamic and displacement diameter d (scalar or per link)", "> 0"),
    "line_density": ("kg/m^3", "material density for the link mass rho_c pi d^2/4 l", "> 0"),
    "mass_per_length": ("kg/m", "mass per length in air (overrides line_density)", "> 0"),
    "stiffness_mode": ("", "per_joint: joint constants as given; bending: k = EI / mean link length",
                       "per_joint | bending"),
    "joint_stiffness": ("N m/rad", "joint spring k_i, joints 2..n (per_joint mode)", ">= 0"),
    "joint_damping": ("N m s/rad", "joint damper c_i, joints 2..n (per_joint mode)", ">= 0"),
    "bending_stiffness": ("N m^2", "bending stiffness EI (bending mode)", ">= 0"),
    "bending_damping": ("N m^2 s", "bending damping (bending mode)", ">= 0"),
    "pin_stiffness": ("N m/rad", "fairlead pin spring relative to the vertical (0: free pin)", ">= 0"),
    "pin_damping": ("N m s/rad", "fairlead pin damper", ">= 0"),
    "platform_mass": ("kg", "platform mass M", "> 0"),
    "heave_stiffness": ("N/m", "hydrostatic heave stiffness k_m (acts on eta - z_m)", ">= 0"),
    "heave_damping": ("N s/m", "platform heave damping c_m", ">= 0"),
    "heave_locked": ("", "hold the platform at its initial height (fixed top)", "true | false"),
    "load_mass": ("kg", "terminal load mass m_c (free end)", ">= 0"),
    "load_volume": ("m^3", "terminal load displaced volume V_c", ">= 0"),
    "water_density": ("kg/m^3", "water density rho_w", "> 0"),
    "gravity": ("m/s^2", "gravitational acceleration g", ">= 0"),
    "drag_model": ("", "hydrodynamic drag: none, the paper's angular drag, or Morison",
                   "none | paper | morison"),
    "paper_drag_gamma": ("kg/m", "gamma_i of the paper's drag", ">= 0"),
    "drag_cn": ("", "Morison normal drag coefficient C_dn", ">= 0"),
    "drag_ct": ("", "Morison tangential drag coefficient C_dt", ">= 0"),
    "current_speed": ("m/s", "uniform current along +x (Morison drag)", "finite"),
    "end_condition": ("", "free load, exact anchor constraint, or the paper's 8e8 kg emulation",
                      "free | anchored | paper_anchor"),
    "anchor_x": ("m", "anchor position x", "finite"),
    "anchor_z": ("m", "anchor position z (z up, still water at 0)", "finite"),
    "paper_anchor_mass": ("kg", "mass of the emulated anchor (paper_anchor)", "> 0"),
    "buoyancy": ("", "physics term switch: buoyancy", "true | false"),
    "joint_springs": ("", "physics term switch: joint springs", "true | false"),
    "joint_dampers": ("", "physics term switch: joint dampers", "true | false"),
    "platform_spring": ("", "physics term switch: heave spring", "true | false"),
    "platform_damper": ("", "physics term switch: heave damper", "true | false"),
    "wave_coupling": ("", "physics term switch: heave spring acts on the wave elevation",
                      "true | false"),
    "constraint_stiffness": ("1/s", "Baumgarte natural frequency of the anchor constraint", "> 0"),
    # simulation (cable_sim.scene.scenes.SIM_DEFAULTS)
    "scene_name": ("", "scene name (set by scene files)", ""),
    "description": ("", "one-line description of the scene", ""),
    "integrator": ("", "time integrator", "rk4 | symplectic_euler | dop853 | radau | rk45 | "
                   "the implicit schemes of cable_sim.integrate.implicit"),
    "step": ("s", "physics step h (simulated time is k h)", "> 0"),
    "kernel": ("", "forward-dynamics kernel: O(n) compiled or dense reference", "fast | dense"),
    "duration": ("s", "scene length (0: run until stopped); see exit_at_end", ">= 0"),
    "initial_state": ("", "start at static equilibrium or as a straight line at an angle",
                      "static | angle"),
    "initial_angle_deg": ("deg", "initial link angle from the downward vertical (angle)", "finite"),
    "initial_heave": ("m", "initial platform heave z_m (angle)", "finite"),
    "heave_force_source": ("", "built-in heave force, added to the heave_force topic",
                           "none | topic | constant | sine | regular_wave | jonswap"),
    "wave_source": ("", "built-in wave elevation, added to the wave_elevation topic",
                    "none | topic | constant | sine | regular_wave | jonswap"),
    "position_tolerance": ("m", "with tension_tolerance > 0: choose n, integrator, step to meet it",
                           ">= 0 (0: off)"),
    "tension_tolerance": ("", "fairlead tension tolerance relative to its peak (autoselect)",
                          ">= 0 (0: off)"),
    "tolerance_horizon": ("s", "simulated time over which autoselect measures errors", "> 0"),
    # built-in input signals (cable_sim.core.inputs.make_signal)
    "heave_force_value": ("N", "constant heave force (source constant)", "finite"),
    "heave_force_amplitude": ("N", "heave force amplitude (sine, regular_wave)", "finite"),
    "heave_force_period": ("s", "heave force period (sine, regular_wave)", "> 0"),
    "heave_force_phase": ("rad", "heave force phase (sine, regular_wave)", "finite"),
    "heave_force_ramp": ("s", "half-cosine start ramp of the heave force", ">= 0"),
    "wave_value": ("m", "constant wave elevation (source constant)", "finite"),
    "wave_amplitude": ("m", "wave amplitude (sine, regular_wave)", "finite"),
    "wave_period": ("s", "wave period (sine, regular_wave)", "> 0"),
    "wave_phase": ("rad", "wave phase (sine, regular_wave)", "finite"),
    "wave_ramp": ("s", "half-cosine start ramp of the wave", ">= 0"),
    "wave_hs": ("m", "significant wave height H_s (jonswap)", ">= 0"),
    "wave_tp": ("s", "peak period T_p (jonswap)", "> 0"),
    "wave_gamma": ("", "JONSWAP peak enhancement factor", ">= 1"),
    "wave_seed": ("", "seed of the JONSWAP random phases (reproducible sea state)", "integer"),
    "frame_interval": ("s", "interval between drawn frames in replay plots", "> 0"),
}


def _scene_descriptor(key: str) -> ParameterDescriptor:
    """Read-only descriptor of a scene key: description with unit, allowed values."""
    unit, desc, allowed = SCENE_DOCS.get(key, ("", "scene key (passed through to the scene)", ""))
    d = ParameterDescriptor(description=f"{desc} [{unit}]" if unit else desc,
                            additional_constraints=allowed, read_only=True)
    if key == "n_links":
        d.integer_range = [IntegerRange(from_value=1, to_value=1_000_000, step=1)]
    return d


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


def _check_input(value: float, limit: float) -> str | None:
    """Why an input value is rejected (None if accepted)."""
    if not math.isfinite(value):
        return f"non-finite value {value!r}"
    if abs(value) > limit:
        return f"|{value:.6g}| exceeds the limit {limit:.6g}"
    return None


class CableSimNode(Node):
    """The cable simulation node (see the module docstring and the README's interface)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("cable_sim_node", **kwargs)
        self.scene = self._declare_scene()
        for name, (default, desc, rng) in NODE_PARAMS.items():
            self._promote_int_override(name, default)
            d = ParameterDescriptor(description=desc)
            if rng is not None:
                d.floating_point_range = [FloatingPointRange(from_value=rng[0], to_value=rng[1])]
            self.declare_parameter(name, default, d)
        for name, (default, desc) in READ_ONLY_NODE.items():
            self._promote_int_override(name, default)
            self.declare_parameter(name, default, ParameterDescriptor(description=desc, read_only=True))
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(lambda params: self._rates_changed())
        self.clock_mode = self._p("clock_mode")
        if self.clock_mode not in CLOCK_MODES:
            raise ParameterError("clock_mode", self.clock_mode, " | ".join(CLOCK_MODES))
        self.frame_id = self._p("frame_id")

        t_build = time.perf_counter()
        self.sim = Simulation(self.scene)
        if self.sim.kernel == "fast":
            from cable_sim.core import kernel as fast

            fast.warmup()
            self.sim.integrator.step(0.0, self.sim.y.copy())  # compile the stepper before real time
            self.sim.integrator.nsteps = 0
        self.build_time = time.perf_counter() - t_build
        self.h = self.sim.h
        self.duration = float(self.scene.sim["duration"])
        cp = self._p("control_period")
        self.steps_per_control = max(1, int(round(cp / self.h)))
        if self.clock_mode == "lockstep" and abs(self.steps_per_control * self.h - cp) > 1e-9 * cp:
            raise ParameterError("control_period", cp, f"a multiple of the step {self.h} s")

        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.pub_js = self.create_publisher(JointState, "joint_states", qos)
        self.pub_mk = self.create_publisher(MarkerArray, "cable_markers", qos)
        self.pub_ft = self.create_publisher(WrenchStamped, "fairlead_tension", qos)
        self.pub_af = (self.create_publisher(WrenchStamped, "anchor_force", qos)
                       if self.sim.model.end != 0 else None)
        self.pub_lt = self.create_publisher(Float64MultiArray, "line_tension", qos)
        self.pub_dg = self.create_publisher(DiagnosticArray, "diagnostics", qos)
        self.pub_ai = self.create_publisher(Float64MultiArray, "applied_inputs", qos)
        self.pub_clock = (self.create_publisher(Clock, "/clock", qos)
                          if self.clock_mode != "realtime" else None)
        self.sub_hf = self.create_subscription(Float64, "heave_force", self._on_heave_force, qos)
        self.create_subscription(Float64, "wave_elevation", self._on_wave_elevation, qos)
        self.create_service(Trigger, "reset", self._on_reset)
        self.create_service(SetBool, "pause", self._on_pause)

        ns = self.get_namespace().rstrip("/")
        self._topic = {name: f"{ns}/{name}" for name in (
            "joint_states", "cable_markers", "fairlead_tension", "anchor_force", "line_tension",
            "diagnostics", "applied_inputs", "heave_force", "wave_elevation")}
        self._topic["clock"] = "/clock"
        self.published: dict[str, int] = {
            k: 0 for k in self._topic if k not in ("heave_force", "wave_elevation")}
        self.rejected = {"heave_force": 0, "wave_elevation": 0}
        self.received = {"heave_force": 0, "wave_elevation": 0}
        self.last_input_wall = {"heave_force": 0.0, "wave_elevation": 0.0}
        self.overruns = 0
        self.paused = False
        self.failure = ""
        self.finished = False
        self.step_wall = 0.0
        self.steps_done = 0
        #: Wall times of the last timer ticks (bounded: memory must not grow over long runs).
        self.tick_times: deque[float] = deque(maxlen=TICK_HISTORY)
        #: Wall time spent paused [s] (finished pauses) and the start of the pause in progress.
        self.paused_wall = 0.0
        self._pause_started: float | None = None
        #: (active wall, sim time) samples for the windowed real-time factor (bounded).
        self._rtf_samples: deque[tuple[float, float]] = deque(maxlen=RTF_SAMPLES)
        self._active_base = 0.0  # active wall time at the start / the last reset
        self.lockstep_queue: deque[float] = deque()
        self.pending_wave: float | None = None
        self.recorder = self._open_recorder()
        self._rates_changed()
        self.start_wall = time.monotonic()
        self.sim_wall_base = (self.start_wall, 0.0)  # (wall, sim time) pair that paces real time

        self.lockstep_started = self.clock_mode != "lockstep"
        if self.lockstep_started:
            self._publish_outputs(force_all=True)
        else:  # joint_states(t0) waits for a controller (see _lockstep_start)
            self._publish_outputs(mk=True, tn=True)
            self._peers_since: float | None = None
            self._waiting_since = time.monotonic()
            self._start_timer = self.create_timer(0.05, self._lockstep_start)
        if self.clock_mode == "realtime":
            self.tick_period = min(0.02, 1.0 / self._p("joint_state_rate"))
            self.create_timer(self.tick_period, self._tick_realtime)
        elif self.clock_mode == "fast":
            self.create_timer(0.0005, self._tick_fast)
        self.create_timer(1.0 / self._p("diagnostics_rate"), self._publish_diagnostics)
        if self.clock_mode != "lockstep":
            self.create_timer(0.1, self._check_input_timeouts)
        self._log_startup()

    # ------------------------------------------------------------------ parameters and scene
    def _p(self, name: str) -> Any:
        return self.get_parameter(name).value

    def _promote_int_override(self, name: str, default: Any) -> None:
        """An integer given for a double parameter (``-p step:=1``) is taken as that double."""
        o = self._parameter_overrides.get(name)
        if o is None or isinstance(default, bool) or isinstance(o.value, bool):
            return
        if isinstance(default, float) and isinstance(o.value, int):
            self._parameter_overrides[name] = Parameter(name, value=float(o.value))
        elif (isinstance(default, list) and o.type_ == Parameter.Type.INTEGER_ARRAY):
            self._parameter_overrides[name] = Parameter(name, value=[float(x) for x in o.value])

    def _declare_scene(self):
        """Declare every scene key as a read-only parameter and build the Scene from them."""
        self.declare_parameter("scene", "", ParameterDescriptor(
            description="shipped scene name or YAML path whose values are the defaults (empty: "
                        "scene_name of a --params-file, else mooring_line); other parameters "
                        "override them", additional_constraints=", ".join(available_scenes()),
            read_only=True))
        self.declare_parameter("scene_name", "", _scene_descriptor("scene_name"))
        name = self._p("scene") or self._p("scene_name") or DEFAULT_SCENE
        try:
            base = read_parameter_file(scene_path(name))
        except FileNotFoundError:
            if self._p("scene"):
                raise
            base = read_parameter_file(scene_path(DEFAULT_SCENE))
        defaults: dict[str, Any] = {k: v for k, v in CableParams().to_dict().items() if v is not None}
        for key in ("diameter", "line_density"):  # per-link fields: scalar default
            defaults[key] = float(defaults[key][0])
        defaults.update(SIM_DEFAULTS)
        defaults.update(INPUT_DEFAULTS)
        for key, v in base.items():  # `pin_stiffness: 0` in a scene file is still a double
            ref = defaults.get(key)
            if isinstance(ref, float) and isinstance(v, int) and not isinstance(v, bool):
                v = float(v)
            defaults[key] = v
        defaults.pop("scene_name", None)
        values: dict[str, Any] = {"scene_name": self._p("scene_name") or base.get("scene_name", name)}
        for key, default in defaults.items():
            if isinstance(default, (list, tuple)):
                default = [float(x) for x in default]
            self._promote_int_override(key, default)
            values[key] = self.declare_parameter(key, default, _scene_descriptor(key)).value
        if values.get("link_lengths") in ([], None):
            values.pop("link_lengths", None)
        return scene_from_dict(values)

    def _on_set_parameters(self, params: list) -> SetParametersResult:
        for p in params:
            if p.name in NODE_PARAMS:
                v = p.value
                lo, hi = NODE_PARAMS[p.name][2]
                if not isinstance(v, float) or not (lo <= v <= hi) or not math.isfinite(v):
                    return SetParametersResult(
                        successful=False,
                        reason=f"parameter '{p.name}' = {v!r} is invalid; allowed: a float in [{lo}, {hi}]")
        return SetParametersResult(successful=True)

    def _rates_changed(self) -> None:
        def every(rate: float) -> int:
            return max(1, int(round(1.0 / (rate * self.h))))

        self.every_js = every(self._p("joint_state_rate"))
        self.every_mk = every(self._p("marker_rate"))
        self.every_tn = every(self._p("tension_rate"))

    def _log_startup(self) -> None:
        m = self.sim.model
        end = m.params.end_condition
        rec = f"recording to {self.recorder.path}" if self.recorder else "not recording"
        line = (
            f"simulating scene '{self.sim.scene.name}': n = {m.n} links, end = {end}, terms = "
            f"[{', '.join(m.terms())}], integrator = {self.sim.integrator.name}, step = {self.h:g} s, "
            f"kernel = {self.sim.kernel}, clock = {self.clock_mode}, rates js/markers/tension/diag = "
            f"{self._p('joint_state_rate'):g}/{self._p('marker_rate'):g}/{self._p('tension_rate'):g}/"
            f"{self._p('diagnostics_rate'):g} Hz, duration = "
            f"{self.duration if self.duration > 0 else 'unbounded'}, {rec}"
        )
        if self.sim.choice is not None:
            line += f"; chosen for the scene's tolerance: {self.sim.choice.reason}"
        self.get_logger().info(line)

    # ------------------------------------------------------------------ recording
    def _open_recorder(self):
        if not self._p("record"):
            return None
        try:
            from cable_sim.ros.recorder import RecorderError, RunRecorder, run_metadata
        except ImportError as exc:  # pragma: no cover - recorder needs mcap
            self.get_logger().error(f"recording disabled: {exc}")
            return None
        start = datetime.now(UTC)
        fqn = self.get_fully_qualified_name()
        path = self._p("record_path") or default_record_path(self.sim.scene.name, fqn, start)
        meta = run_metadata(dict(self.sim.scene.source), kernel=self.sim.kernel,
                            integrator=self.sim.integrator.name, step=self.h,
                            n_links=self.sim.model.n, clock_mode=self.clock_mode,
                            start=start, node=fqn)
        try:
            # an existing file is never overwritten: RunRecorder picks a new name and warns
            return RunRecorder(path, meta, logger=self.get_logger())
        except RecorderError as exc:
            self.get_logger().error(f"{exc}; the simulation runs without recording")
            self.record_error = str(exc)
            return None

    def _stamp(self) -> int:
        return int(round(self.sim.k * self.h * 1e9))

    def _publish(self, name: str, pub, msg, stamp: int) -> None:
        if not self.context.ok():  # a timer firing while a signal shuts rclpy down
            return
        pub.publish(msg)
        self.published[name] += 1
        if self.recorder is not None:
            self.recorder.write(self._topic[name], msg, stamp)

    # ------------------------------------------------------------------ inputs
    def _accept(self, name: str, value: float, limit: float) -> bool:
        self.received[name] += 1
        if self.recorder is not None:
            self.recorder.write(self._topic[name], Float64(data=value), self._stamp())
        reason = _check_input(value, limit)
        if reason is not None:
            self.rejected[name] += 1
            self.get_logger().warning(
                f"rejected {name} input: {reason} ({self.rejected[name]} rejected so far)",
                throttle_duration_sec=2.0)
            return False
        self.last_input_wall[name] = time.monotonic()
        return True

    def _applied_changed(self) -> None:
        msg = build_float_array([self.sim.held_heave_force, self.sim.held_wave_elevation])
        self._publish("applied_inputs", self.pub_ai, msg, self._stamp())

    def _on_heave_force(self, msg: Float64) -> None:
        value = float(msg.data)
        if not self._accept("heave_force", value, self._p("heave_force_limit")):
            return
        if self.clock_mode == "lockstep":
            if not self.lockstep_started:  # before joint_states(t0): held, advances nothing
                if value != self.sim.held_heave_force:
                    self.sim.set_heave_force(value)
                    self._applied_changed()
                return
            self.lockstep_queue.append(value)
            self._advance_lockstep()
        elif value != self.sim.held_heave_force:
            self.sim.set_heave_force(value)
            self._applied_changed()

    def _on_wave_elevation(self, msg: Float64) -> None:
        value = float(msg.data)
        if not self._accept("wave_elevation", value, self._p("wave_elevation_limit")):
            return
        if self.clock_mode == "lockstep":
            self.pending_wave = value  # applied at the next control-period boundary
        elif value != self.sim.held_wave_elevation:
            self.sim.set_wave_elevation(value)
            self._applied_changed()

    def _check_input_timeouts(self) -> None:
        now, timeout = time.monotonic(), self._p("input_timeout")
        for name, held, setter in (
            ("heave_force", self.sim.held_heave_force, self.sim.set_heave_force),
            ("wave_elevation", self.sim.held_wave_elevation, self.sim.set_wave_elevation),
        ):
            if held != 0.0 and now - self.last_input_wall[name] > timeout:
                setter(0.0)
                self._applied_changed()
                self.get_logger().warning(
                    f"{name} input older than input_timeout = {timeout:g} s: falling back to zero")

    # ------------------------------------------------------------------ services
    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.sim.reset()
        self.failure = ""
        self.finished = False
        self.lockstep_queue.clear()
        self.pending_wave = None
        self.sim_wall_base = (time.monotonic(), 0.0)
        self._active_base = self.active_wall()
        self._rtf_samples.clear()
        self._applied_changed()
        # in lockstep before the controller is connected, joint_states(t0) still waits for it
        self._publish_outputs(js=self.lockstep_started, mk=True, tn=True)
        response.success, response.message = True, "reset to the scene's initial state at t = 0"
        self.get_logger().info(response.message)
        return response

    def _on_pause(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        if request.data != self.paused:
            now = time.monotonic()
            self._sample_rtf(now)
            self.paused = bool(request.data)
            if self.paused:
                self._pause_started = now
            elif self._pause_started is not None:
                self.paused_wall += now - self._pause_started
                self._pause_started = None
            self.sim_wall_base = (now, self.sim.t)
            if not self.paused and self.clock_mode == "lockstep":
                self._advance_lockstep()
        response.success = True
        response.message = "paused" if self.paused else "running"
        return response

    # ------------------------------------------------------------------ stepping
    def _running(self) -> bool:
        return not (self.paused or self.failure or self.finished)

    def _step_once(self) -> bool:
        """One physics step plus the outputs due at the new step; False when stopped."""
        w = time.perf_counter()
        try:
            self.sim.step()
        except IntegrationError as exc:
            self._fail(str(exc))
            return False
        self.step_wall += time.perf_counter() - w
        self.steps_done += 1
        k = self.sim.k
        due = (self.clock_mode != "lockstep" and k % self.every_js == 0,
               k % self.every_mk == 0, k % self.every_tn == 0)
        if any(due):
            self._publish_outputs(*due)
        if self.duration > 0 and self.sim.t >= self.duration - 1e-9:
            self._finish()
            return False
        return not self.failure

    def _fail(self, reason: str) -> None:
        self.failure = reason
        self.get_logger().error(f"simulation stopped at t = {self.sim.t:.4f} s: {reason}; "
                                "call the 'reset' service to start again")
        self._publish_diagnostics()

    def _finish(self) -> None:
        self.finished = True
        self.get_logger().info(f"scene duration {self.duration:g} s reached")
        self._publish_diagnostics()
        if self._p("exit_at_end"):
            raise SystemExit(0)

    def active_wall(self, now: float | None = None) -> float:
        """Wall time since the start [s] without the time spent paused."""
        now = time.monotonic() if now is None else now
        paused = self.paused_wall + (now - self._pause_started if self._pause_started is not None else 0.0)
        return now - self.start_wall - paused

    def _sample_rtf(self, now: float) -> None:
        """Add an (active wall, sim time) sample for the windowed real-time factor."""
        a = self.active_wall(now)
        if not self._rtf_samples or a - self._rtf_samples[-1][0] >= RTF_SAMPLE_INTERVAL:
            self._rtf_samples.append((a, self.sim.t))

    def real_time_factor(self, now: float | None = None) -> tuple[float, float]:
        """Real-time factor over the last :data:`RTF_WINDOW` s and since the start (or reset).

        Both are simulated time over *active* wall time: time spent paused does not count.
        Returns ``(windowed, mean)``; nan while no active wall time has passed.
        """
        now = time.monotonic() if now is None else now
        a = self.active_wall(now)
        since = a - self._active_base
        mean = self.sim.t / since if since > 1e-3 else math.nan
        a0, s0 = a - since, 0.0
        for aw, st in self._rtf_samples:  # oldest sample inside the window
            if a - aw <= RTF_WINDOW:
                a0, s0 = aw, st
                break
        windowed = (self.sim.t - s0) / (a - a0) if a - a0 > 1e-3 else mean
        return windowed, mean

    def _tick_realtime(self) -> None:
        now = time.monotonic()
        self.tick_times.append(now)
        self._sample_rtf(now)
        if not self._running():
            return
        wall0, sim0 = self.sim_wall_base
        target = sim0 + (now - wall0)
        budget_end = time.perf_counter() + 0.8 * self.tick_period
        while (self.sim.k + 1) * self.h <= target + 1e-12:
            if not self._step_once():
                return
            if time.perf_counter() > budget_end:
                break
        if target - self.sim.t > self.tick_period:
            self.overruns += 1
            if target - self.sim.t > 1.0:  # hopelessly behind: drop the backlog, keep pacing
                self.sim_wall_base = (now, self.sim.t)
                self.get_logger().warning("simulation is more than 1 s behind wall time: "
                                          "dropping the backlog", throttle_duration_sec=5.0)
        if self.pub_clock is not None:
            self._publish("clock", self.pub_clock, clock_message(self._stamp()), self._stamp())

    def _tick_fast(self) -> None:
        now = time.monotonic()
        self.tick_times.append(now)
        self._sample_rtf(now)
        if not self._running():
            return
        end = time.perf_counter() + 0.01
        while time.perf_counter() < end:
            if not self._step_once():
                break
        self._publish("clock", self.pub_clock, clock_message(self._stamp()), self._stamp())

    def _lockstep_start(self) -> None:
        """Lockstep start: publish joint_states(t0) once a controller is connected both ways.

        A message published before the subscriber is matched is lost, and the controller would
        wait for it forever; so the node waits until ``joint_states`` has a subscriber and
        ``heave_force`` a publisher, for 0.5 s (both directions of discovery), then publishes
        the state at t = 0 and advances one control period per ``heave_force`` message after it.
        """
        now = time.monotonic()
        if self.pub_js.get_subscription_count() == 0 or self.sub_hf.get_publisher_count() == 0:
            self._peers_since = None
            if now - self._waiting_since > 5.0:
                self.get_logger().warning(
                    "lockstep: waiting for a controller (a subscriber of joint_states and a "
                    "publisher of heave_force)", throttle_duration_sec=10.0)
            return
        if self._peers_since is None:
            self._peers_since = now
        if now - self._peers_since < 0.5:
            return
        self._start_timer.cancel()
        self.lockstep_started = True
        stamp = self._stamp()
        self._publish("clock", self.pub_clock, clock_message(stamp), stamp)
        out = self._outputs()
        if out is not None:
            self._publish("joint_states", self.pub_js, build_joint_state(out, stamp, self.frame_id), stamp)
        self.get_logger().info("lockstep: controller connected; published joint_states at "
                               f"t = {self.sim.t:g} s, advancing one control period per heave_force")

    def _advance_lockstep(self) -> None:
        self._sample_rtf(time.monotonic())
        while self.lockstep_queue and self._running():
            value = self.lockstep_queue.popleft()
            changed = value != self.sim.held_heave_force
            self.sim.set_heave_force(value)
            if self.pending_wave is not None:
                changed |= self.pending_wave != self.sim.held_wave_elevation
                self.sim.set_wave_elevation(self.pending_wave)
                self.pending_wave = None
            if changed:
                self._applied_changed()
            for _ in range(self.steps_per_control):
                if not self._step_once():
                    return
            stamp = self._stamp()
            self._publish("clock", self.pub_clock, clock_message(stamp), stamp)
            out = self._outputs()
            if out is not None:
                self._publish("joint_states", self.pub_js, build_joint_state(out, stamp, self.frame_id),
                              stamp)

    # ------------------------------------------------------------------ outputs
    def _outputs(self) -> Outputs | None:
        try:
            out = self.sim.outputs()
        except IntegrationError as exc:
            self._fail(str(exc))
            return None
        if not (np.all(np.isfinite(out.q)) and np.all(np.isfinite(out.axial_tension))
                and np.all(np.isfinite(out.fairlead_force))):
            self._fail("non-finite outputs (not published)")
            return None
        return out

    def _publish_outputs(self, js: bool = False, mk: bool = False, tn: bool = False,
                         force_all: bool = False) -> None:
        out = self._outputs()
        if out is None:
            return
        stamp = self._stamp()
        if js or force_all:
            self._publish("joint_states", self.pub_js, build_joint_state(out, stamp, self.frame_id),
                          stamp)
        if mk or force_all:
            self._publish("cable_markers", self.pub_mk,
                          build_markers(out, self.sim.model, stamp, self.frame_id), stamp)
        if tn or force_all:
            self._publish("fairlead_tension", self.pub_ft,
                          build_wrench(-out.fairlead_force, stamp, self.frame_id), stamp)
            if self.pub_af is not None:
                self._publish("anchor_force", self.pub_af,
                              build_wrench(-out.anchor_force, stamp, self.frame_id), stamp)
            self._publish("line_tension", self.pub_lt, build_float_array(out.axial_tension), stamp)
        problems = self.sim.health(out)
        if problems:
            self.get_logger().warning("; ".join(problems), throttle_duration_sec=5.0)
        self.last_outputs = out

    def diagnostics_values(self) -> dict[str, Any]:
        """Key/values of the diagnostics status (also used by tests and the benchmark)."""
        now = time.monotonic()
        wall = now - self.start_wall
        rtf, rtf_mean = self.real_time_factor(now)
        out = getattr(self, "last_outputs", None)
        ticks = np.diff(np.array(self.tick_times)) if len(self.tick_times) > 2 else np.zeros(1)
        v: dict[str, Any] = {
            "sim_time": repr(self.sim.t),
            "wall_time": repr(wall),
            "real_time_factor": repr(rtf),
            "real_time_factor_mean": repr(rtf_mean),
            "paused_time": repr(wall - self.active_wall(now)),
            "step_cost_us": repr(1e6 * self.step_wall / max(self.steps_done, 1)),
            "steps": str(self.sim.k),
            "energy": repr(out.energy) if out is not None else "nan",
            "fairlead_tension": repr(out.fairlead_tension) if out is not None else "nan",
            "constraint_drift": repr(out.constraint_drift) if out is not None else "nan",
            "slack": repr(out.slack) if out is not None else "nan",
            "rejected_heave_force": str(self.rejected["heave_force"]),
            "rejected_wave_elevation": str(self.rejected["wave_elevation"]),
            "rejected_inputs": str(sum(self.rejected.values())),
            "received_heave_force": str(self.received["heave_force"]),
            "received_wave_elevation": str(self.received["wave_elevation"]),
            "overruns": str(self.overruns),
            "tick_interval_p50_ms": repr(1e3 * float(np.percentile(ticks, 50))),
            "tick_interval_p99_ms": repr(1e3 * float(np.percentile(ticks, 99))),
            "tick_interval_max_ms": repr(1e3 * float(ticks.max())),
            "paused": str(self.paused),
            "failure": self.failure,
        }
        for name, count in self.published.items():
            v[f"published_{name}"] = str(count)
        if self.recorder is not None:
            st = self.recorder.stats
            v["recorder_path"] = st["path"]
            v["recorder_messages_written"] = str(st["messages_written"])
            v["recorder_messages_dropped"] = str(st["messages_dropped"])
            v["recorder_errors"] = str(st["errors"])
            v["recorder_last_error"] = st["last_error"]
        elif hasattr(self, "record_error"):
            v["recorder_last_error"] = self.record_error
        return v

    def _publish_diagnostics(self) -> None:
        v = self.diagnostics_values()
        stamp = self._stamp()
        msg = build_diagnostics(v, stamp)
        st = msg.status[0]
        st.name = f"{self.get_name()}: cable simulation"
        if self.failure:
            st.level, st.message = DiagnosticStatus.ERROR, f"stopped: {self.failure}"
        elif (self.recorder is None and self._p("record")) or (
                self.recorder is not None and self.recorder.stats["errors"]):
            st.level, st.message = DiagnosticStatus.WARN, "recording failed; simulation running"
        elif self.overruns or sum(self.rejected.values()):
            st.level = DiagnosticStatus.WARN
            st.message = f"{self.overruns} overruns, {sum(self.rejected.values())} rejected inputs"
        else:
            st.message = "paused" if self.paused else "running"
        self._publish("diagnostics", self.pub_dg, msg, stamp)

    def close(self) -> None:
        """Close the recording (idempotent)."""
        if self.recorder is not None:
            self.recorder.close()


def _cli_parameters(argv: list[str]) -> list[tuple[str, str]]:
    """``(name, value text)`` of every ``-p name:=value`` in the ROS arguments of ``argv``."""
    out, ros = [], False
    it = iter(argv)
    for tok in it:
        if tok == "--ros-args":
            ros = True
        elif tok == "--":
            ros = False
        elif ros and tok in ("-p", "--param"):
            item = next(it, "")
            if ":=" in item:
                name, _, text = item.partition(":=")
                out.append((name.split(":")[-1], text))  # node-name prefix "node:name" allowed
    return out


def ignored_cli_parameters(node: Node, argv: list[str]) -> list[str]:
    """Command-line values ROS dropped without a word.

    With ``--params-file`` holding ``n_links: 8``, rcl silently keeps the file's integer when
    ``-p n_links:=2.0`` gives a double, so the run would quietly use 8 links. Returns one message
    per such parameter (an integer for a double is fine: the node takes it as that double).
    """
    problems = []
    for name, text in _cli_parameters(argv):
        if not node.has_parameter(name):
            continue
        actual = node.get_parameter(name).value
        if isinstance(actual, bool) or not isinstance(actual, int):
            continue
        try:
            given = float(text)
        except ValueError:
            continue
        if given != actual or not text.lstrip("+-").isdigit():
            problems.append(f"parameter '{name}' = {text} is not an integer; '{name}' is an integer "
                            f"parameter (write {name}:={int(given) if given.is_integer() else '<integer>'})")
    return problems


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
