"""Message definitions as rosbag2 stores them in MCAP schemas (``ros2msg``), and the file's constants.

Reads the ``.msg`` files of the ament prefixes. May import only the standard library (and
``ament_index_python`` when present).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path
from typing import Any

#: MCAP profile and encodings rosbag2 uses.
PROFILE = "ros2"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"
LIBRARY = "cable_sim recorder (mcap python)"

#: Delimiter rosbag2 puts between the sections of a concatenated message definition.
DEFINITION_SEPARATOR = "=" * 80

#: QoS the node offers on its publishers (reliable, volatile, keep last 10), in the YAML form
#: rosbag2 (Jazzy) stores in the channel metadata.
DEFAULT_QOS_YAML = (
    "- history: keep_last\n"
    "  depth: 10\n"
    "  reliability: reliable\n"
    "  durability: volatile\n"
    "  deadline:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  liveliness: automatic\n"
    "  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  avoid_ros_namespace_conventions: false\n"
)

#: QoS of latched outputs (``robot_description``, ``/tf_static``): reliable, transient local, keep
#: last 1, as robot_state_publisher offers them; ``ros2 bag play`` re-offers them the same way, so a
#: late subscriber of a replayed run still gets them.
TRANSIENT_LOCAL_QOS_YAML = DEFAULT_QOS_YAML.replace("depth: 10", "depth: 1").replace(
    "durability: volatile", "durability: transient_local")

#: Definitions of types recorded without their package installed (no wheel of tf2_msgs here): the
#: ``.msg`` text as the package ships it; nested types are read from the installed packages.
SUPPLIED_DEFINITIONS = {
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
}

_PRIMITIVES = {
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring", "time", "duration",
}



def _share_dirs() -> list[Path]:
    dirs: list[Path] = []
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / "share")
    dirs.append(Path(sys.prefix) / "share")
    return dirs


def msg_file(type_name: str) -> Path:
    """The ``.msg`` file of ``pkg/msg/Type`` (or ``pkg/Type``) in the ament prefixes.

    Raises
    ------
    FileNotFoundError
        When no prefix of ``AMENT_PREFIX_PATH`` (nor ``sys.prefix``) has it.
    """
    pkg, name = _split_type(type_name)
    candidates = []
    try:  # a real ROS install: ask the ament index first
        from ament_index_python.packages import get_package_share_directory

        candidates.append(Path(get_package_share_directory(pkg)) / "msg" / f"{name}.msg")
    except Exception:  # noqa: BLE001 - no ament index / package not indexed
        pass
    candidates += [d / pkg / "msg" / f"{name}.msg" for d in _share_dirs()]
    for c in candidates:
        if c.is_file():
            return c
    raise FileNotFoundError(
        f"message definition {pkg}/msg/{name}.msg not found in {[str(c.parent) for c in candidates]}"
        " (set AMENT_PREFIX_PATH to the ROS install / venv prefix)"
    )


def _split_type(type_name: str) -> tuple[str, str]:
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise ValueError(f"message type {type_name!r}: expected 'pkg/msg/Type' or 'pkg/Type'")


_FIELD_RE = re.compile(r"^\s*([A-Za-z_][\w/]*)(?:\s*<=\s*\d+)?(?:\[[^\]]*\])?\s+[A-Za-z_]\w*")


def _dependencies(text: str, pkg: str) -> list[str]:
    """Nested message types (``pkg/Type``) used by the fields of a ``.msg`` text, in order."""
    deps: list[str] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = _FIELD_RE.match(line)
        if not m:
            continue
        ftype = m.group(1)
        # constants ("TYPE NAME=VALUE") are always primitives
        if ftype in _PRIMITIVES:
            continue
        if ftype == "Header":
            ftype = "std_msgs/Header"
        elif "/" not in ftype:
            ftype = f"{pkg}/{ftype}"
        else:
            p, n = _split_type(ftype)
            ftype = f"{p}/{n}"
        if ftype not in deps:
            deps.append(ftype)
    return deps


def _msg_text(type_name: str) -> str:
    """The ``.msg`` text of ``pkg/Type``: the installed file, else :data:`SUPPLIED_DEFINITIONS`."""
    try:
        return msg_file(type_name).read_text()
    except FileNotFoundError:
        pkg, name = _split_type(type_name)
        supplied = SUPPLIED_DEFINITIONS.get(f"{pkg}/{name}")
        if supplied is None:
            raise
        return supplied


def message_definition(type_name: str) -> str:
    """Full concatenated definition of a message type, as rosbag2 stores it in MCAP schemas.

    The type's own ``.msg`` text, then for every nested type (depth first, each once) a section
    ``"=" * 80 + "\\nMSG: pkg/Type\\n" + text``.
    """
    pkg, name = _split_type(type_name)
    root = _msg_text(f"{pkg}/{name}")
    seen = {f"{pkg}/{name}"}
    sections: list[str] = []
    stack = list(reversed(_dependencies(root, pkg)))
    while stack:
        dep = stack.pop()
        if dep in seen:
            continue
        seen.add(dep)
        dpkg, _ = _split_type(dep)
        text = _msg_text(dep)
        sections.append(f"{DEFINITION_SEPARATOR}\nMSG: {dep}\n{text}")
        stack.extend(reversed([d for d in _dependencies(text, dpkg) if d not in seen]))
    out = root
    for s in sections:
        if not out.endswith("\n"):
            out += "\n"
        out += s
    return out


def type_name_of(msg: Any) -> str:
    """``pkg/msg/Type`` of an rclpy message instance (or class)."""
    cls = msg if isinstance(msg, type) else type(msg)
    module = cls.__module__.split(".")
    return f"{module[0]}/{module[1]}/{cls.__name__}"
