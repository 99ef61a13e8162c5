"""ROS messages of the cable_sim interface, built from :class:`cable_sim.scene.simulation.Outputs`.

One place for the message layout (see ``msg_configs/interface.yaml``): the node publishes these,
and the headless recorder of :mod:`cable_sim.analysis.replay` writes the same bytes without a ROS graph.
Message modules are imported inside the functions so that importing this module needs no ROS.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from cable_sim.core.dynamics import relative_angles
from cable_sim.core.seabed import seabed_outputs

#: Labels of the ``seabed_contact`` values, in their order (unit in each name).
SEABED_LABELS = ("touchdown_arc_length_m", "touchdown_x_m", "laid_length_m", "seabed_reaction_N")


def joint_state_arrays(out: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """JointState position, velocity, effort of :class:`cable_sim.scene.simulation.Outputs` (interface
    convention: heave then relative angles; effort = applied heave force, joint torques)."""
    q, qd = out.q, out.qd
    n = len(q) - 1
    pos = np.empty(n + 1)
    vel = np.empty(n + 1)
    pos[0] = q[0]
    pos[1:] = relative_angles(q[1:])
    vel[0] = qd[0]
    vel[1:] = relative_angles(qd[1:])
    eff = np.empty(n + 1)
    eff[0] = out.inputs.heave_force
    eff[1:] = out.joint_torques
    return pos, vel, eff


def _header(stamp_ns: int, frame_id: str):
    from std_msgs.msg import Header

    h = Header(frame_id=frame_id)
    h.stamp.sec, h.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return h


def joint_names(n: int) -> list[str]:
    """Joint names of the interface: ``platform_heave``, then ``joint_1`` .. ``joint_n``."""
    return ["platform_heave"] + [f"joint_{i + 1}" for i in range(n)]


def joint_state_message(pos: np.ndarray, vel: np.ndarray, eff: np.ndarray, stamp_ns: int,
                        frame_id: str = "world"):
    """sensor_msgs/JointState of the interface from its three arrays (n + 1 values each)."""
    from sensor_msgs.msg import JointState

    return JointState(header=_header(stamp_ns, frame_id), name=joint_names(len(pos) - 1),
                      position=np.asarray(pos, float).tolist(), velocity=np.asarray(vel, float).tolist(),
                      effort=np.asarray(eff, float).tolist())


def build_joint_state(out: Any, stamp_ns: int, frame_id: str = "world"):
    """sensor_msgs/JointState of the interface (heave then relative angles)."""
    return joint_state_message(*joint_state_arrays(out), stamp_ns, frame_id)


def build_wrench(force: np.ndarray, stamp_ns: int, frame_id: str = "world"):
    """geometry_msgs/WrenchStamped with force (F_x, 0, F_z)."""
    from geometry_msgs.msg import WrenchStamped

    w = WrenchStamped(header=_header(stamp_ns, frame_id))
    w.wrench.force.x = float(force[0])
    w.wrench.force.z = float(force[1])
    return w


def build_float_array(values: Iterable[float]):
    """std_msgs/Float64MultiArray."""
    from std_msgs.msg import Float64MultiArray

    return Float64MultiArray(data=[float(v) for v in values])


def seabed_contact_values(out: Any, model: Any) -> np.ndarray | None:
    """The ``seabed_contact`` values of a state, in the order of :data:`SEABED_LABELS`.

    Touchdown arc length from the line's end (the anchor) [m], touchdown x [m], laid length [m]
    and total vertical seabed reaction [N] (:func:`cable_sim.core.seabed.seabed_outputs`). When
    no part of the line is below the bed level, the touchdown is at the line's end (arc length
    0, x of the last joint) and laid length and reaction are 0: every value is finite.

    Parameters
    ----------
    out : cable_sim.scene.simulation.Outputs
        The state (``q``, ``qd``, ``joint_positions``).
    model : cable_sim.core.model.CableModel
        The simulated model.

    Returns
    -------
    ndarray (4,) or None
        None when the model has no seabed.
    """
    if not model.seabed:
        return None
    s = seabed_outputs(model, out.q, out.qd)
    if not np.isfinite(s.touchdown_x):  # nothing below the bed level
        return np.array([0.0, float(out.joint_positions[-1, 0]), 0.0, 0.0])
    return np.array([s.touchdown_arc, s.touchdown_x, s.laid_length, s.reaction])


def build_seabed_contact(values: Iterable[float]):
    """std_msgs/Float64MultiArray of the seabed outputs: one dimension of size 4 whose label names
    the values in order (:data:`SEABED_LABELS`, units in the names)."""
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    msg = Float64MultiArray(data=[float(v) for v in values])
    msg.layout.dim = [MultiArrayDimension(label=",".join(SEABED_LABELS), size=len(SEABED_LABELS),
                                          stride=len(SEABED_LABELS))]
    return msg


#: (ns, id) of every marker of :func:`build_markers`: one marker per namespace, ids fixed for a run.
MARKER_IDS = {"cable": 0, "end": 1, "platform": 2, "water": 3, "seabed": 4, "touchdown": 5}


def marker_values(out: Any, model: Any, seabed: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The changing values of the node's markers (:func:`markers_message`), as arrays.

    ``line_points`` (n+1, 3) and ``line_colors`` (n+1, 4, float32: red with tension, blue without,
    scaled by the largest tension), ``end_position``, ``platform_position`` (3), ``water_points``
    (2, 3) at the wave elevation over the line's x range +- 20 m; with a seabed also
    ``seabed_points`` (2, 3) at the bed's z over the same range, ``touchdown_action`` (int32 (1,):
    ADD, or DELETE while nothing lies on the bed) and ``touchdown_position`` (3). ``seabed`` are the
    :func:`seabed_contact_values` of ``out`` (computed here when not given).
    """
    from visualization_msgs.msg import Marker

    p = out.joint_positions
    ten = np.abs(out.axial_tension)
    tmax = float(ten.max()) if len(ten) and ten.max() > 0 else 1.0
    tn = np.concatenate([ten[:1], ten]) / tmax
    pts = np.empty((len(p), 3))
    pts[:, 0], pts[:, 1], pts[:, 2] = p[:, 0], 0.0, p[:, 1]
    cols = np.empty((len(p), 4), dtype=np.float32)
    cols[:, 0], cols[:, 1], cols[:, 2], cols[:, 3] = tn, 0.2, 1.0 - tn, 1.0
    x0, x1 = float(min(p[:, 0].min(), 0.0)) - 20.0, float(p[:, 0].max()) + 20.0
    eta = float(out.inputs.wave_elevation)
    values = {
        "line_points": pts, "line_colors": cols,
        "end_position": np.array([p[-1, 0], 0.0, p[-1, 1]]),
        "platform_position": np.array([p[0, 0], 0.0, p[0, 1]]),
        "water_points": np.array([[x0, 0.0, eta], [x1, 0.0, eta]]),
    }
    if model.seabed:
        sv = seabed_contact_values(out, model) if seabed is None else seabed
        zb = float(model.seabed_z)
        values["seabed_points"] = np.array([[x0, 0.0, zb], [x1, 0.0, zb]])
        values["touchdown_action"] = np.array([Marker.ADD if sv[2] > 0.0 else Marker.DELETE], np.int32)
        values["touchdown_position"] = np.array([float(sv[1]), 0.0, zb])
    return values


def _points(xyz: np.ndarray) -> list[Any]:
    from geometry_msgs.msg import Point

    return [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in xyz]


def _position(marker: Any, xyz: np.ndarray) -> None:
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (float(v) for v in xyz)
    marker.pose.orientation.w = 1.0


def markers_message(values: dict[str, np.ndarray], model: Any, stamp_ns: int, frame_id: str = "world",
                    delete_all: bool = False):
    """visualization_msgs/MarkerArray of :func:`marker_values` (see :func:`build_markers`)."""
    from std_msgs.msg import ColorRGBA
    from visualization_msgs.msg import Marker, MarkerArray

    hdr = _header(stamp_ns, frame_id)
    line = Marker(header=hdr, ns="cable", type=Marker.LINE_STRIP, action=Marker.ADD)
    line.pose.orientation.w = 1.0
    line.scale.x = 0.5
    line.points = _points(values["line_points"])
    line.colors = [ColorRGBA(r=float(r), g=float(g), b=float(b), a=float(a))
                   for r, g, b, a in values["line_colors"]]
    end = Marker(header=hdr, ns="end", action=Marker.ADD,
                 type=Marker.CUBE if model.end != 0 else Marker.SPHERE)
    _position(end, values["end_position"])
    end.scale.x = end.scale.y = end.scale.z = 2.0
    end.color = ColorRGBA(r=0.3, g=0.3, b=0.3, a=1.0)
    plat = Marker(header=hdr, ns="platform", type=Marker.CUBE, action=Marker.ADD)
    _position(plat, values["platform_position"])
    plat.scale.x, plat.scale.y, plat.scale.z = 8.0, 8.0, 3.0
    plat.color = ColorRGBA(r=0.9, g=0.5, b=0.1, a=1.0)
    water = Marker(header=hdr, ns="water", type=Marker.LINE_STRIP, action=Marker.ADD)
    water.pose.orientation.w = 1.0
    water.scale.x = 0.2
    water.points = _points(values["water_points"])
    water.color = ColorRGBA(r=0.1, g=0.4, b=1.0, a=0.6)
    markers = [line, end, plat, water]
    if "seabed_points" in values:
        bed = Marker(header=hdr, ns="seabed", type=Marker.LINE_STRIP, action=Marker.ADD)
        bed.pose.orientation.w = 1.0
        bed.scale.x = 0.5
        bed.points = _points(values["seabed_points"])
        bed.color = ColorRGBA(r=0.45, g=0.35, b=0.2, a=1.0)
        td = Marker(header=hdr, ns="touchdown", type=Marker.SPHERE,
                    action=int(values["touchdown_action"][0]))
        _position(td, values["touchdown_position"])
        td.scale.x = td.scale.y = td.scale.z = 3.0
        td.color = ColorRGBA(r=1.0, g=0.85, b=0.0, a=1.0)
        markers += [bed, td]
    for mk in markers:
        mk.id = MARKER_IDS[mk.ns]
        mk.frame_locked = False
    if delete_all:
        clear = Marker(header=hdr, ns="", id=0, action=Marker.DELETEALL)
        clear.pose.orientation.w = 1.0
        markers.insert(0, clear)
    return MarkerArray(markers=markers)


def build_markers(out: Any, model: Any, stamp_ns: int, frame_id: str = "world", delete_all: bool = False,
                  seabed: np.ndarray | None = None):
    """visualization_msgs/MarkerArray: cable line strip coloured by tension, end, platform, water,
    and with a seabed the bed line and the touchdown point.

    RViz conventions: one (ns, id) per marker, the same every message (:data:`MARKER_IDS`), so each
    message replaces the previous one in place; ``lifetime`` 0 (kept until replaced: a paused run
    stays on screen) and ``frame_locked`` false (every marker is in ``frame_id``, a fixed frame;
    there is nothing to re-transform). ``delete_all`` puts a ``DELETEALL`` marker (empty ns: every
    namespace) first, which RViz applies before the markers after it in the same array: the node
    sends it with its first markers and after a reset, so markers of an earlier run never linger.

    With a seabed (``model.seabed``): ns ``seabed``, a line strip at the bed's z over the same x
    range as the water line; ns ``touchdown``, a sphere at the touchdown point (touchdown x, bed
    z), whose action is ``DELETE`` while no part of the line is below the bed level. ``seabed``
    are the :func:`seabed_contact_values` of ``out`` (computed here when not given).
    """
    return markers_message(marker_values(out, model, seabed), model, stamp_ns, frame_id, delete_all)


def build_robot_description(urdf: str):
    """std_msgs/String holding the URDF (what robot_state_publisher takes on ``robot_description``)."""
    from std_msgs.msg import String

    return String(data=urdf)


def build_diagnostics(values: dict[str, Any], stamp_ns: int, name: str = "cable_sim"):
    """diagnostic_msgs/DiagnosticArray with one status holding ``values``."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    st = DiagnosticStatus(level=DiagnosticStatus.OK, name=name, message="ok", hardware_id="cable_sim")
    st.values = [KeyValue(key=str(k), value=str(v)) for k, v in values.items()]
    return DiagnosticArray(header=_header(stamp_ns, ""), status=[st])


def clock_message(stamp_ns: int):
    """rosgraph_msgs/Clock at ``stamp_ns``."""
    from rosgraph_msgs.msg import Clock

    c = Clock()
    c.clock.sec, c.clock.nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return c
