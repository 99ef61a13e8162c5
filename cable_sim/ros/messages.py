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


def build_joint_state(out: Any, stamp_ns: int, frame_id: str = "world"):
    """sensor_msgs/JointState of the interface (heave then relative angles)."""
    from sensor_msgs.msg import JointState

    pos, vel, eff = joint_state_arrays(out)
    n = len(pos) - 1
    return JointState(header=_header(stamp_ns, frame_id),
                      name=["platform_heave"] + [f"joint_{i + 1}" for i in range(n)],
                      position=pos.tolist(), velocity=vel.tolist(), effort=eff.tolist())


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


def _seabed_markers(hdr: Any, model: Any, values: np.ndarray, x0: float, x1: float) -> list[Any]:
    """The seabed line at the bed's z and the touchdown sphere (DELETE while nothing touches)."""
    from geometry_msgs.msg import Point
    from std_msgs.msg import ColorRGBA
    from visualization_msgs.msg import Marker

    zb = float(model.seabed_z)
    bed = Marker(header=hdr, ns="seabed", type=Marker.LINE_STRIP, action=Marker.ADD)
    bed.pose.orientation.w = 1.0
    bed.scale.x = 0.5
    bed.points = [Point(x=x0, z=zb), Point(x=x1, z=zb)]
    bed.color = ColorRGBA(r=0.45, g=0.35, b=0.2, a=1.0)
    touching = values[2] > 0.0
    td = Marker(header=hdr, ns="touchdown", type=Marker.SPHERE,
                action=Marker.ADD if touching else Marker.DELETE)
    td.pose.position.x, td.pose.position.z = float(values[1]), zb
    td.pose.orientation.w = 1.0
    td.scale.x = td.scale.y = td.scale.z = 3.0
    td.color = ColorRGBA(r=1.0, g=0.85, b=0.0, a=1.0)
    return [bed, td]


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
    from geometry_msgs.msg import Point
    from std_msgs.msg import ColorRGBA
    from visualization_msgs.msg import Marker, MarkerArray

    hdr = _header(stamp_ns, frame_id)
    p = out.joint_positions
    ten = np.abs(out.axial_tension)
    tmax = float(ten.max()) if len(ten) and ten.max() > 0 else 1.0
    line = Marker(header=hdr, ns="cable", id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
    line.pose.orientation.w = 1.0
    line.scale.x = 0.5
    line.points = [Point(x=float(x), y=0.0, z=float(z)) for x, z in p]
    tn = np.concatenate([ten[:1], ten]) / tmax
    line.colors = [ColorRGBA(r=float(a), g=0.2, b=float(1.0 - a), a=1.0) for a in tn]
    end = Marker(header=hdr, ns="end", id=1, action=Marker.ADD,
                 type=Marker.CUBE if model.end != 0 else Marker.SPHERE)
    end.pose.position.x, end.pose.position.z = float(p[-1, 0]), float(p[-1, 1])
    end.pose.orientation.w = 1.0
    end.scale.x = end.scale.y = end.scale.z = 2.0
    end.color = ColorRGBA(r=0.3, g=0.3, b=0.3, a=1.0)
    plat = Marker(header=hdr, ns="platform", id=2, type=Marker.CUBE, action=Marker.ADD)
    plat.pose.position.x, plat.pose.position.z = float(p[0, 0]), float(p[0, 1])
    plat.pose.orientation.w = 1.0
    plat.scale.x, plat.scale.y, plat.scale.z = 8.0, 8.0, 3.0
    plat.color = ColorRGBA(r=0.9, g=0.5, b=0.1, a=1.0)
    water = Marker(header=hdr, ns="water", id=3, type=Marker.LINE_STRIP, action=Marker.ADD)
    water.pose.orientation.w = 1.0
    water.scale.x = 0.2
    eta = float(out.inputs.wave_elevation)
    x0, x1 = float(min(p[:, 0].min(), 0.0)) - 20.0, float(p[:, 0].max()) + 20.0
    water.points = [Point(x=x0, z=eta), Point(x=x1, z=eta)]
    water.color = ColorRGBA(r=0.1, g=0.4, b=1.0, a=0.6)
    markers = [line, end, plat, water]
    if model.seabed:
        values = seabed_contact_values(out, model) if seabed is None else seabed
        markers += _seabed_markers(hdr, model, values, x0, x1)
    for mk in markers:
        mk.id = MARKER_IDS[mk.ns]
        mk.frame_locked = False
    if delete_all:
        clear = Marker(header=hdr, ns="", id=0, action=Marker.DELETEALL)
        clear.pose.orientation.w = 1.0
        markers.insert(0, clear)
    return MarkerArray(markers=markers)


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
