"""The node's per-tick messages as CDR bytes, from templates of the interface's own builders.

Each encoder is a :class:`cable_sim.ros.cdr_template.TemplateEncoder` whose prototype is built by
the functions of :mod:`cable_sim.ros.messages` (the one definition of the layout) with sentinel
values in the fields that change from tick to tick; encoding is a copy of the template and a few
array writes, whatever n (the bytes equal the serialiser's for the message the builders give:
test/ros/test_encoders.py). The node publishes these bytes and records the same bytes: one
serialisation for both.

May import numpy, :mod:`cable_sim.ros.messages` and :mod:`cable_sim.ros.cdr_template`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cable_sim.ros.cdr_template import TemplateEncoder, sentinel, stamp_sentinel
from cable_sim.ros.messages import (
    SEABED_LABELS,
    build_float_array,
    build_seabed_contact,
    build_wrench,
    joint_state_message,
    markers_message,
)

#: ROS type names of the encoded messages (as the recorder stores them).
JOINT_STATE = "sensor_msgs/msg/JointState"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
WRENCH = "geometry_msgs/msg/WrenchStamped"
FLOAT_ARRAY = "std_msgs/msg/Float64MultiArray"


def _marker_sentinels(model: Any) -> dict[str, np.ndarray]:
    """Sentinel values of every :func:`cable_sim.ros.messages.marker_values` field of ``model``."""
    n1 = model.n + 1
    s = {"line_points": sentinel((n1, 3), seed=10), "line_colors": sentinel((n1, 4), np.float32, seed=11),
         "end_position": sentinel(3, seed=12), "platform_position": sentinel(3, seed=13),
         "water_points": sentinel((2, 3), seed=14)}
    if model.seabed:
        s["seabed_points"] = sentinel((2, 3), seed=15)
        s["touchdown_action"] = np.array([0x2A3B4C5D], dtype=np.int32)
        s["touchdown_position"] = sentinel(3, seed=16)
    return s


class OutputEncoders:
    """Template encoders of the node's periodic outputs for one model and frame.

    Parameters
    ----------
    model : cable_sim.core.model.CableModel
        The simulated model (n and the seabed are fixed for the node's life).
    frame_id : str
        Frame of the stamped messages.
    """

    def __init__(self, model: Any, frame_id: str) -> None:
        n1 = model.n + 1
        st = stamp_sentinel()
        js = [sentinel(n1, seed=k) for k in range(3)]
        self._joint_state = TemplateEncoder(
            joint_state_message(*js, st, frame_id),
            {"position": (js[0], 1), "velocity": (js[1], 1), "effort": (js[2], 1)}, stamp=st)
        mk = _marker_sentinels(model)
        self._marker_fields = tuple(mk)
        self._markers = TemplateEncoder(markers_message(mk, model, st, frame_id),
                                        {k: (v, 1) for k, v in mk.items()}, stamp=st,
                                        stamps=6 if model.seabed else 4)
        wf = sentinel(3, seed=20)
        wf[1] = 0.0
        self._wrench = TemplateEncoder(build_wrench(wf[[0, 2]], st, frame_id), {"force": (wf, 1)},
                                       stamp=st)
        tn = sentinel(model.n, seed=21)
        self._tension = TemplateEncoder(build_float_array(tn), {"data": (tn, 1)})
        sb = sentinel(len(SEABED_LABELS), seed=22)
        self._seabed = TemplateEncoder(build_seabed_contact(sb), {"data": (sb, 1)})

    def joint_state(self, pos: np.ndarray, vel: np.ndarray, eff: np.ndarray, stamp_ns: int) -> bytes:
        """JointState bytes (:func:`cable_sim.ros.messages.joint_state_message`)."""
        return self._joint_state.encode(stamp_ns, position=pos, velocity=vel, effort=eff)

    def markers(self, values: dict[str, np.ndarray], stamp_ns: int) -> bytes:
        """MarkerArray bytes of :func:`cable_sim.ros.messages.marker_values` (no DELETEALL: the
        rare message that starts with one is built by :func:`markers_message`)."""
        return self._markers.encode(stamp_ns, **{k: values[k] for k in self._marker_fields})

    def wrench(self, force: np.ndarray, stamp_ns: int) -> bytes:
        """WrenchStamped bytes with force (F_x, 0, F_z) [N] (:func:`build_wrench`)."""
        return self._wrench.encode(stamp_ns, force=np.array([force[0], 0.0, force[1]]))

    def line_tension(self, tension: np.ndarray) -> bytes:
        """Float64MultiArray bytes of the n link tensions [N]."""
        return self._tension.encode(data=tension)

    def seabed_contact(self, values: np.ndarray) -> bytes:
        """Float64MultiArray bytes of the seabed outputs (:func:`build_seabed_contact`)."""
        return self._seabed.encode(data=values)
