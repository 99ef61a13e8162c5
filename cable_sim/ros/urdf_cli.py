"""``cable_sim_urdf SCENE [-p key:=value ...] [-o FILE]``: print the URDF of a scene.

The scene is a shipped scene name (``mooring_line``) or a ROS parameter file path, exactly as
the node reads it; ``-p key:=value`` overrides a scene key the way ``--ros-args -p`` does for the
node (the value is read as YAML), so ``-p n_links:=20`` gives a 20-link description. The
launch file feeds this output to robot_state_publisher as ``robot_description``.

May import: the standard library, yaml, :mod:`cable_sim.core`, :mod:`cable_sim.scene` and
:mod:`cable_sim.ros.urdf` (no rclpy).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import yaml

from cable_sim.core.params import ParameterError
from cable_sim.ros.urdf import urdf_for_model
from cable_sim.scene.scenes import load_scene


def parse_override(text: str) -> tuple[str, Any]:
    """``key:=value`` -> ``(key, value)``, the value read as YAML like a ROS ``-p`` argument.

    Raises
    ------
    ValueError
        When ``text`` has no ``:=`` or an empty key.
    """
    key, sep, value = text.partition(":=")
    if not sep or not key.strip():
        raise ValueError(f"override {text!r} is not of the form key:=value")
    try:
        parsed = yaml.safe_load(value) if value.strip() else ""
    except yaml.YAMLError:
        parsed = value
    return key.strip(), parsed


def build_urdf(scene: str, overrides: dict[str, Any] | None = None) -> str:
    """URDF of ``scene`` (name or path) with ``overrides`` applied.

    A scene that asks for a tolerance has its n chosen as the node chooses it (this simulates
    short runs first, as the node does at start-up).
    """
    sc = load_scene(scene, overrides)
    if float(sc.sim.get("position_tolerance", 0.0)) > 0 and float(sc.sim.get("tension_tolerance", 0.0)) > 0:
        from cable_sim.scene.simulation import Simulation

        model = Simulation(sc).model
    else:
        model = sc.model()
    return urdf_for_model(model, f"cable_sim_{sc.name}")


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``cable_sim_urdf``; returns the exit status (2 on a bad scene or value)."""
    ap = argparse.ArgumentParser(prog="cable_sim_urdf", description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", help="shipped scene name (e.g. mooring_line) or path to a scene YAML file")
    ap.add_argument("-p", "--param", action="append", default=[], metavar="KEY:=VALUE",
                    help="override a scene key, as the node's --ros-args -p (repeatable)")
    ap.add_argument("-o", "--output", type=Path, help="write the URDF to this file instead of stdout")
    a = ap.parse_args(argv)
    try:
        overrides = dict(parse_override(p) for p in a.param)
        text = build_urdf(a.scene, overrides)
    except (ParameterError, ValueError, FileNotFoundError, TypeError) as exc:
        print(f"cable_sim_urdf: {exc}", file=sys.stderr)
        return 2
    if a.output is not None:
        a.output.write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
