"""URDF robot description and TF transforms of a cable scene (pure Python, no ROS imports).

The cable is described as a serial chain, in the frames ROS viewers expect (REP-103: x forward,
z up, metres, radians; REP-105: one fixed ``world`` frame, no ``map``/``odom``)::

    world --platform_heave (prismatic, z)--> platform --(fixed)--> fairlead
    fairlead --joint_1 (about -y)--> link_1 --joint_2--> link_2 ... link_n --(fixed)--> cable_end
    cable_end --(fixed)--> load           (free end or the paper's anchor emulation: the load body)
    world --(fixed)--> anchor              (anchored end: the anchor point)

Joint names and order are those of the node's ``joint_states`` (:mod:`cable_sim.ros.messages`):
``platform_heave`` carries z_m and ``joint_i`` the *relative* angle phi_i = theta_i - theta_{i-1}.
Link i hangs along its frame's -z axis; joint i turns about -y, so a positive phi tilts the link
towards +x, and the chain reproduces MODEL.md's joints p_k = p_{k-1} + l_k (sin theta_k, 0,
-cos theta_k) with theta_k = phi_1 + ... + phi_k. The revolute joints are ``continuous`` (no limits:
a cable may wind up).

Inertials: link i is a thin rod of the model's mass m_i (in air; buoyancy and added mass are
hydrodynamic and not part of a URDF), inertia m_i l_i^2 / 12 about its centre for the swing axes
(as the model) and m_i d_i^2 / 8 about its own axis; visual and collision are cylinders of the
link's length and diameter. The platform is a box of the platform mass, the load a sphere of the
load mass (radius from the load's displaced volume, 1 m when it has none).

May import: numpy, the standard library, :mod:`cable_sim.core` and :mod:`cable_sim.scene`.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from typing import Any

import numpy as np

from cable_sim.core.model import END_CODES, CableModel

#: Name of the fixed frame at the root of the tree (REP-105).
WORLD = "world"
#: Size of the platform box [m] (x, y, z), the same as the platform marker.
PLATFORM_BOX = (8.0, 8.0, 3.0)
#: Radius of the load sphere when the load has no displaced volume [m].
DEFAULT_LOAD_RADIUS = 1.0
#: Radius of the anchor marker sphere [m] (visual only).
ANCHOR_RADIUS = 1.0
#: Axis of every revolute joint (a positive angle turns the link from -z towards +x).
JOINT_AXIS = (0.0, -1.0, 0.0)
#: Limits written on the prismatic heave joint: position [m], effort [N], velocity [m/s].
HEAVE_LIMIT = 1.0e4
EFFORT_LIMIT = 1.0e12
VELOCITY_LIMIT = 1.0e4

Transform = tuple[str, str, tuple[float, float, float], tuple[float, float, float, float]]


def joint_names(n: int) -> list[str]:
    """Names of the movable joints, in ``joint_states`` order: ``platform_heave``, ``joint_1..n``."""
    return ["platform_heave"] + [f"joint_{i + 1}" for i in range(n)]


def link_names(model: CableModel) -> list[str]:
    """Names of every link (frame) of the description, parents before children."""
    names = [WORLD, "platform", "fairlead"] + [f"link_{i + 1}" for i in range(model.n)] + ["cable_end"]
    if _has_load_body(model):
        names.append("load")
    if model.end == END_CODES["anchored"]:
        names.append("anchor")
    return names


def _has_load_body(model: CableModel) -> bool:
    return model.end != END_CODES["anchored"] and model.load_mass > 0.0


def _f(v: float) -> str:
    """Shortest text that reads back as the same double."""
    return repr(float(v))


def _vec(*v: float) -> str:
    return " ".join(_f(x) for x in v)


def _inertial(parent: ET.Element, mass: float, xyz: Sequence[float], ixx: float, iyy: float,
              izz: float) -> None:
    el = ET.SubElement(parent, "inertial")
    ET.SubElement(el, "origin", xyz=_vec(*xyz), rpy="0 0 0")
    ET.SubElement(el, "mass", value=_f(mass))
    ET.SubElement(el, "inertia", ixx=_f(ixx), ixy="0", ixz="0", iyy=_f(iyy), iyz="0", izz=_f(izz))


def _shape(parent: ET.Element, tag: str, xyz: Sequence[float], geometry: tuple[str, dict[str, str]],
           material: str | None = None) -> None:
    el = ET.SubElement(parent, tag)
    ET.SubElement(el, "origin", xyz=_vec(*xyz), rpy="0 0 0")
    geo = ET.SubElement(el, "geometry")
    ET.SubElement(geo, geometry[0], **geometry[1])
    if material is not None:
        ET.SubElement(el, "material", name=material)


def _fixed(robot: ET.Element, name: str, parent: str, child: str, xyz: Sequence[float]) -> None:
    j = ET.SubElement(robot, "joint", name=name, type="fixed")
    ET.SubElement(j, "origin", xyz=_vec(*xyz), rpy="0 0 0")
    ET.SubElement(j, "parent", link=parent)
    ET.SubElement(j, "child", link=child)


def load_radius(model: CableModel) -> float:
    """Radius of the load sphere [m]: from the load's displaced volume, else the default."""
    v = float(model.params.load_volume)
    return (3.0 * v / (4.0 * math.pi)) ** (1.0 / 3.0) if v > 0 else DEFAULT_LOAD_RADIUS


def urdf_for_model(model: CableModel, name: str = "cable") -> str:
    """URDF (XML text) of the chain of ``model``.

    Parameters
    ----------
    model : CableModel
        The model whose links, masses and end condition are described.
    name : str
        Robot name (letters, digits, ``_`` and ``-``; anything else becomes ``_``).

    Returns
    -------
    str
        The URDF document, one ``<robot>`` element (see the module docstring for its tree).
    """
    robot_name = re.sub(r"[^A-Za-z0-9_-]", "_", name) or "cable"
    robot = ET.Element("robot", name=robot_name)
    robot.append(ET.Comment(
        f" generated by cable_sim.ros.urdf: n = {model.n} links, end = "
        f"{model.params.end_condition}; joint_i carries the relative angle theta_i - theta_(i-1) "))
    for mat, rgba in (("cable", "0.1 0.2 0.9 1"), ("platform", "0.9 0.5 0.1 1"),
                      ("end", "0.3 0.3 0.3 1")):
        m = ET.SubElement(robot, "material", name=mat)
        ET.SubElement(m, "color", rgba=rgba)

    ET.SubElement(robot, "link", name=WORLD)
    plat = ET.SubElement(robot, "link", name="platform")
    bx, by, bz = PLATFORM_BOX
    mp = float(model.platform_mass)
    _inertial(plat, mp, (0, 0, 0), mp * (by**2 + bz**2) / 12, mp * (bx**2 + bz**2) / 12,
              mp * (bx**2 + by**2) / 12)
    box = ("box", {"size": _vec(*PLATFORM_BOX)})
    _shape(plat, "visual", (0, 0, 0), box, "platform")
    _shape(plat, "collision", (0, 0, 0), box)
    heave = ET.SubElement(robot, "joint", name="platform_heave", type="prismatic")
    ET.SubElement(heave, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(heave, "parent", link=WORLD)
    ET.SubElement(heave, "child", link="platform")
    ET.SubElement(heave, "axis", xyz="0 0 1")
    ET.SubElement(heave, "limit", lower=_f(-HEAVE_LIMIT), upper=_f(HEAVE_LIMIT),
                  effort=_f(EFFORT_LIMIT), velocity=_f(VELOCITY_LIMIT))
    ET.SubElement(robot, "link", name="fairlead")
    _fixed(robot, "fairlead_joint", "platform", "fairlead", (0, 0, 0))

    lengths = np.asarray(model.length, dtype=float)
    diam = np.broadcast_to(np.asarray(model.params.diameter, dtype=float), lengths.shape)
    parent, offset = "fairlead", 0.0
    for i in range(model.n):
        l, d, m = float(lengths[i]), float(diam[i]), float(model.mass[i])
        link = ET.SubElement(robot, "link", name=f"link_{i + 1}")
        _inertial(link, m, (0, 0, -l / 2), m * l * l / 12, m * l * l / 12, m * d * d / 8)
        cyl = ("cylinder", {"radius": _f(d / 2), "length": _f(l)})
        _shape(link, "visual", (0, 0, -l / 2), cyl, "cable")
        _shape(link, "collision", (0, 0, -l / 2), cyl)
        j = ET.SubElement(robot, "joint", name=f"joint_{i + 1}", type="continuous")
        ET.SubElement(j, "origin", xyz=_vec(0, 0, offset), rpy="0 0 0")
        ET.SubElement(j, "parent", link=parent)
        ET.SubElement(j, "child", link=f"link_{i + 1}")
        ET.SubElement(j, "axis", xyz=_vec(*JOINT_AXIS))
        ET.SubElement(j, "limit", effort=_f(EFFORT_LIMIT), velocity=_f(VELOCITY_LIMIT))
        parent, offset = f"link_{i + 1}", -l
    ET.SubElement(robot, "link", name="cable_end")
    _fixed(robot, "cable_end_joint", parent, "cable_end", (0, 0, offset))
    if _has_load_body(model):
        mc, r = float(model.load_mass), load_radius(model)
        load = ET.SubElement(robot, "link", name="load")
        i_s = 0.4 * mc * r * r
        _inertial(load, mc, (0, 0, 0), i_s, i_s, i_s)
        sphere = ("sphere", {"radius": _f(r)})
        _shape(load, "visual", (0, 0, 0), sphere, "end")
        _shape(load, "collision", (0, 0, 0), sphere)
        _fixed(robot, "load_joint", "cable_end", "load", (0, 0, 0))
    if model.end == END_CODES["anchored"]:
        anchor = ET.SubElement(robot, "link", name="anchor")
        _shape(anchor, "visual", (0, 0, 0), ("sphere", {"radius": _f(ANCHOR_RADIUS)}), "end")
        ax, az = (float(v) for v in model.anchor)
        _fixed(robot, "anchor_joint", WORLD, "anchor", (ax, 0.0, az))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def urdf_for_scene(scene: Any) -> str:
    """URDF of a :class:`cable_sim.scene.scenes.Scene` (its model at the scene's own n).

    A scene that asks for a tolerance (``position_tolerance``/``tension_tolerance``) has its n
    chosen when it is simulated: describe ``Simulation(scene).model`` with :func:`urdf_for_model`
    instead (``cable_sim_urdf`` does).
    """
    return urdf_for_model(scene.model(), f"cable_sim_{scene.name}")


def _rot(phi: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``phi`` about :data:`JOINT_AXIS`."""
    s, c = math.sin(0.5 * phi), math.cos(0.5 * phi)
    return (JOINT_AXIS[0] * s, JOINT_AXIS[1] * s, JOINT_AXIS[2] * s, c)


_IDENTITY = (0.0, 0.0, 0.0, 1.0)


def _fixed_transforms(model: CableModel) -> dict[str, Transform]:
    """Transforms of the fixed joints, by child frame."""
    n = model.n
    out = {"fairlead": ("platform", "fairlead", (0.0, 0.0, 0.0), _IDENTITY),
           "cable_end": (f"link_{n}", "cable_end", (0.0, 0.0, -float(model.length[-1])), _IDENTITY)}
    if _has_load_body(model):
        out["load"] = ("cable_end", "load", (0.0, 0.0, 0.0), _IDENTITY)
    if model.end == END_CODES["anchored"]:
        out["anchor"] = (WORLD, "anchor", (float(model.anchor[0]), 0.0, float(model.anchor[1])), _IDENTITY)
    return out


def static_transforms(model: CableModel) -> list[Transform]:
    """The transforms of the fixed joints (for ``/tf_static``), in the form of :func:`tf_transforms`."""
    return list(_fixed_transforms(model).values())


def tf_transforms(model: CableModel, joint_positions: Sequence[float] | np.ndarray,
                  include_fixed: bool = True) -> list[Transform]:
    """Parent-to-child transforms of the description at a joint state.

    Parameters
    ----------
    model : CableModel
        The model the URDF was generated from.
    joint_positions : sequence of float, length n + 1
        ``JointState.position`` of the node: heave z_m [m], then the relative angles phi_1..phi_n
        [rad] (:func:`cable_sim.ros.messages.joint_state_arrays`).
    include_fixed : bool
        Also return the fixed joints' transforms (:func:`static_transforms`); robot_state_publisher
        sends those on ``/tf_static`` and the moving ones on ``/tf``.

    Returns
    -------
    list of (parent, child, translation, rotation)
        ``translation`` (x, y, z) [m] of the child frame's origin in the parent frame and
        ``rotation`` its orientation as a unit quaternion (x, y, z, w), geometry_msgs order; one
        entry per child frame, every parent before its children (:func:`link_names` order).

    Raises
    ------
    ValueError
        When ``joint_positions`` does not hold n + 1 values.
    """
    pos = np.asarray(joint_positions, dtype=float)
    if pos.shape != (model.n + 1,):
        raise ValueError(f"joint_positions has shape {pos.shape}; the model needs ({model.n + 1},) "
                         "(heave, then one relative angle per link)")
    moving: dict[str, Transform] = {"platform": (WORLD, "platform", (0.0, 0.0, float(pos[0])), _IDENTITY)}
    parent, offset = "fairlead", 0.0
    for i in range(model.n):
        moving[f"link_{i + 1}"] = (parent, f"link_{i + 1}", (0.0, 0.0, offset), _rot(float(pos[i + 1])))
        parent, offset = f"link_{i + 1}", -float(model.length[i])
    if not include_fixed:
        return list(moving.values())
    both = {**moving, **_fixed_transforms(model)}
    return [both[name] for name in link_names(model) if name != WORLD]


__all__ = ["joint_names", "link_names", "urdf_for_model", "urdf_for_scene", "tf_transforms",
           "static_transforms", "load_radius"]
