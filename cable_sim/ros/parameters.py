"""The node's ROS parameters: one table of node settings, the scene keys, descriptors, validation.

Every node setting is declared by one loop over :data:`NODE_PARAMETERS`; every scene key (cable,
simulation, built-in input signals) is declared read-only with its unit and allowed values from
:data:`cable_sim.ros.scene_docs.SCENE_DOCS`, and the scene is built from the declared values.

May import rclpy, rcl_interfaces, :mod:`cable_sim.ros.scene_docs` and the layers below (scene, core).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from cable_sim.core.params import CableParams
from cable_sim.ros.scene_docs import SCENE_DOCS
from cable_sim.scene.scenes import (
    SIM_DEFAULTS,
    Scene,
    available_scenes,
    read_parameter_file,
    scene_from_dict,
    scene_path,
)

DEFAULT_SCENE = "mooring_line"
CLOCK_MODES = ("realtime", "fast", "lockstep")

#: Built-in input keys a scene may leave out (defaults; see cable_sim.core.inputs.make_signal).
INPUT_DEFAULTS: dict[str, Any] = {
    "heave_force_amplitude": 0.0, "heave_force_period": 10.0, "heave_force_phase": 0.0,
    "heave_force_ramp": 0.0, "heave_force_value": 0.0,
    "wave_amplitude": 0.0, "wave_period": 10.0, "wave_phase": 0.0, "wave_ramp": 0.0,
    "wave_value": 0.0, "wave_hs": 2.0, "wave_tp": 10.0, "wave_gamma": 3.3, "wave_seed": 0,
    "frame_interval": 1.0,
}


@dataclass(frozen=True)
class NodeParam:
    """One node setting: default, description, allowed range (floats) and whether it is read-only."""

    default: Any
    description: str
    range: tuple[float, float] | None = None
    read_only: bool = False


_RO = {"read_only": True}
#: Node settings in declaration order. Those with a range may change at run time (validated by
#: :func:`check_node_parameters`); the read-only ones are fixed at start (a range given for one
#: is checked by rclpy when it is declared; an integer default gets an integer range).
NODE_PARAMETERS: dict[str, NodeParam] = {
    "joint_state_rate": NodeParam(50.0, "JointState publication rate [Hz] (sim time)", (0.1, 1000.0)),
    "marker_rate": NodeParam(10.0, "MarkerArray publication rate [Hz] (sim time)", (0.1, 1000.0)),
    "tension_rate": NodeParam(20.0, "fairlead/anchor force and line tension rate [Hz]", (0.1, 1000.0)),
    "line_tension_rate": NodeParam(0.0, "line_tension (n link tensions) rate [Hz] (sim time), for a long "
                                   "line slower than the scalar forces; 0: with tension_rate",
                                   (0.0, 1000.0)),
    "diagnostics_rate": NodeParam(1.0, "diagnostics rate [Hz] (wall time)", (0.05, 100.0)),
    "input_timeout": NodeParam(2.0, "an input older than this [s] falls back to zero (not lockstep)",
                               (0.01, 3600.0)),
    "heave_force_limit": NodeParam(1.0e7, "largest accepted |heave_force| [N]", (1.0, 1.0e12)),
    "wave_elevation_limit": NodeParam(30.0, "largest accepted |wave_elevation| [m]", (0.01, 1000.0)),
    "clock_mode": NodeParam("realtime", "realtime | fast (publishes /clock) | lockstep (waits for "
                            "heave_force)", **_RO),
    "control_period": NodeParam(0.05, "lockstep: simulated time [s] advanced per heave_force message",
                                **_RO),
    "record": NodeParam(True, "record the run to MCAP", **_RO),
    "record_path": NodeParam("", "MCAP file; default runs/<scene>_<node>_<YYYYmmdd-HHMMSS-ffffff>.mcap "
                             "(<node>: namespace.name); an existing file is never overwritten (-1, -2, "
                             "... is added)", **_RO),
    "frame_id": NodeParam("world", "frame of all stamped outputs (x-z plane, z up)", **_RO),
    "exit_at_end": NodeParam(False, "with duration > 0: stop, close the recording and exit 0 at the end",
                             **_RO),
    "foxglove_port": NodeParam(0, "live Foxglove view: serve the Foxglove WebSocket protocol on this TCP "
                               "port of 127.0.0.1 (0: off; 8765 is Foxglove's usual port; needs "
                               "foxglove-sdk)", (0, 65535), read_only=True),
    "foxglove_rate": NodeParam(10.0, "live Foxglove view: scene and tension update rate [Hz] (wall time)",
                               (0.1, 100.0), read_only=True),
}
STRUCTURAL = set(CableParams.field_names()) | set(SIM_DEFAULTS) | set(INPUT_DEFAULTS)


def node_descriptor(name: str) -> ParameterDescriptor:
    """Descriptor of a node setting: description, float range, read-only flag."""
    spec = NODE_PARAMETERS[name]
    d = ParameterDescriptor(description=spec.description, read_only=spec.read_only)
    if spec.range is not None and isinstance(spec.default, int) and not isinstance(spec.default, bool):
        d.integer_range = [IntegerRange(from_value=int(spec.range[0]), to_value=int(spec.range[1]), step=1)]
    elif spec.range is not None:
        d.floating_point_range = [FloatingPointRange(from_value=spec.range[0], to_value=spec.range[1])]
    return d


def scene_descriptor(key: str) -> ParameterDescriptor:
    """Read-only descriptor of a scene key: description with unit, allowed values."""
    unit, desc, allowed = SCENE_DOCS.get(key, ("", "scene key (passed through to the scene)", ""))
    d = ParameterDescriptor(description=f"{desc} [{unit}]" if unit else desc,
                            additional_constraints=allowed, read_only=True)
    if key == "n_links":
        d.integer_range = [IntegerRange(from_value=1, to_value=1_000_000, step=1)]
    return d


def promote_int_override(node: Node, name: str, default: Any) -> None:
    """An integer given for a double parameter (``-p step:=1``) is taken as that double."""
    o = node._parameter_overrides.get(name)
    if o is None or isinstance(default, bool) or isinstance(o.value, bool):
        return
    if isinstance(default, float) and isinstance(o.value, int):
        node._parameter_overrides[name] = Parameter(name, value=float(o.value))
    elif isinstance(default, list) and o.type_ == Parameter.Type.INTEGER_ARRAY:
        node._parameter_overrides[name] = Parameter(name, value=[float(x) for x in o.value])


def declare_node_parameters(node: Node) -> None:
    """Declare every node setting of :data:`NODE_PARAMETERS` on ``node``."""
    for name, spec in NODE_PARAMETERS.items():
        promote_int_override(node, name, spec.default)
        node.declare_parameter(name, spec.default, node_descriptor(name))


def _scene_defaults(base: dict[str, Any]) -> dict[str, Any]:
    """Every scene key's default: the cable's, the simulation's and the inputs', then ``base``."""
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
    return defaults


def declare_scene(node: Node) -> Scene:
    """Declare every scene key as a read-only parameter of ``node`` and build the Scene from them."""
    node.declare_parameter("scene", "", ParameterDescriptor(
        description="shipped scene name or YAML path whose values are the defaults (empty: "
                    "scene_name of a --params-file, else mooring_line); other parameters "
                    "override them", additional_constraints=", ".join(available_scenes()),
        read_only=True))
    node.declare_parameter("scene_name", "", scene_descriptor("scene_name"))
    scene, scene_name = node.get_parameter("scene").value, node.get_parameter("scene_name").value
    name = scene or scene_name or DEFAULT_SCENE
    try:
        base = read_parameter_file(scene_path(name))
    except FileNotFoundError:
        if scene:
            raise
        base = read_parameter_file(scene_path(DEFAULT_SCENE))
    values: dict[str, Any] = {"scene_name": scene_name or base.get("scene_name", name)}
    for key, default in _scene_defaults(base).items():
        if isinstance(default, (list, tuple)):
            default = [float(x) for x in default]
        promote_int_override(node, key, default)
        values[key] = node.declare_parameter(key, default, scene_descriptor(key)).value
    if values.get("link_lengths") in ([], None):
        values.pop("link_lengths", None)
    return scene_from_dict(values)


def check_node_parameters(params: list[Parameter]) -> SetParametersResult:
    """Accept a run-time change only if every changed node setting is a finite float in its range."""
    for p in params:
        spec = NODE_PARAMETERS.get(p.name)
        if spec is None or spec.range is None or spec.read_only:  # read-only: fixed at start
            continue
        v, (lo, hi) = p.value, spec.range
        if not isinstance(v, float) or not (lo <= v <= hi) or not math.isfinite(v):
            return SetParametersResult(
                successful=False,
                reason=f"parameter '{p.name}' = {v!r} is invalid; allowed: a float in [{lo}, {hi}]")
    return SetParametersResult(successful=True)
