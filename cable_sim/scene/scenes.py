"""Scenes: a YAML file in ROS parameter-file format -> model, inputs, initial state, integrator.

A scene file looks like::

    /**:
      ros__parameters:
        scene_name: paper_free_fall
        n_links: 60            # any CableParams field, by name
        drag_model: paper
        integrator: rk4
        step: 0.002
        heave_force_source: none
        ...

Keys that are :class:`~cable_sim.core.params.CableParams` fields build the physics; the keys in
:data:`SIM_DEFAULTS` choose the integrator, initial state and built-in inputs; every other key
(rates, clock mode, recording, ...) is kept in :attr:`Scene.extra` for the ROS node.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from cable_sim.core.dynamics import Inputs
from cable_sim.core.inputs import make_signal
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams, ParameterError
from cable_sim.core.statics import static_equilibrium
from cable_sim.core.system import CableSystem
from cable_sim.integrate import Integrator, make_integrator

CONFIG_DIR = Path(__file__).resolve().parents[2] / "config"

#: Simulation keys a scene may set, with their defaults.
SIM_DEFAULTS: dict[str, Any] = {
    "scene_name": "unnamed",
    "description": "",
    "integrator": "rk4",
    "step": 0.002,
    "kernel": "fast",
    "duration": 0.0,
    "initial_state": "static",  # static | angle
    "initial_angle_deg": 90.0,
    "initial_heave": 0.0,
    "heave_force_source": "none",
    "wave_source": "none",
    # "model only what a scene needs": when both are > 0, n, integrator and step are chosen
    # by cable_sim.scene.autoselect to meet them (position [m], tension relative to its peak).
    "position_tolerance": 0.0,
    "tension_tolerance": 0.0,
    "tolerance_horizon": 10.0,
}


def _installed_config_dir() -> Path | None:
    """share/cable_sim/config of the install: from the ament index, else under sys.prefix."""
    try:
        from ament_index_python.packages import get_package_share_directory

        return Path(get_package_share_directory("cable_sim")) / "config"
    except Exception:  # noqa: BLE001 - not in an ament environment
        d = Path(sys.prefix) / "share" / "cable_sim" / "config"
        return d if d.is_dir() else None


def scene_path(name_or_path: str | Path) -> Path:
    """Resolve a scene name (``paper_free_fall``) or a path to a YAML file."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and p.exists():
        return p
    for d in (CONFIG_DIR, _installed_config_dir()):
        if d is not None and (d / f"{name_or_path}.yaml").exists():
            return d / f"{name_or_path}.yaml"
    raise FileNotFoundError(f"scene {str(name_or_path)!r} not found (looked in {CONFIG_DIR})")


def read_parameter_file(path: Path) -> dict[str, Any]:
    """Flatten the ``ros__parameters`` of a ROS 2 parameter file (first node entry)."""
    doc = yaml.safe_load(Path(path).read_text()) or {}
    for node in doc.values():
        if isinstance(node, dict) and "ros__parameters" in node:
            return _flatten(node["ros__parameters"])
    raise ValueError(f"{path}: no 'ros__parameters' section")


def _flatten(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


@dataclass
class Scene:
    """A parsed scene.

    Attributes
    ----------
    params : CableParams
        Validated physics.
    sim : dict
        Keys of :data:`SIM_DEFAULTS` (integrator, step, kernel, inputs, initial state, ...).
    extra : dict
        Every other key (node settings), passed through untouched.
    source : dict
        The full flat key/value set the scene was built from (for recording as metadata).
    """

    params: CableParams
    sim: dict[str, Any]
    extra: dict[str, Any] = field(default_factory=dict)
    source: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """Scene name."""
        return str(self.sim["scene_name"])

    def model(self) -> CableModel:
        """Build the immutable model."""
        return CableModel.from_params(self.params)

    def input_function(self):
        """``f(t) -> Inputs`` from the scene's built-in sources (topic sources give zero)."""
        cfg = {**self.sim, **self.extra}
        heave = make_signal(self.sim["heave_force_source"], "heave_force", cfg)
        wave = make_signal(self.sim["wave_source"], "wave", cfg)
        return lambda t: Inputs(heave(t), wave(t))

    def initial_state(self, model: CableModel | None = None) -> np.ndarray:
        """Initial state y0 = [q0, 0]: static equilibrium, or a straight line at an angle."""
        model = model or self.model()
        q = np.zeros(model.ndof)
        kind = self.sim["initial_state"]
        if kind == "static":
            if model.end == 2:  # paper emulation: start where the exact anchor would rest
                anchored = CableModel.from_params(self.params.replace(end_condition="anchored"))
                q, _ = static_equilibrium(anchored, self.input_function()(0.0))
            else:
                q, _ = static_equilibrium(model, self.input_function()(0.0))
        elif kind == "angle":
            q[0] = float(self.sim["initial_heave"])
            q[1:] = np.deg2rad(float(self.sim["initial_angle_deg"]))
        else:
            raise ParameterError("initial_state", kind, "'static' or 'angle'")
        return np.concatenate([q, np.zeros(model.ndof)])

    def system(self, kernel: str | None = None, model: CableModel | None = None) -> CableSystem:
        """The model bound to the scene's kernel and built-in inputs."""
        return CableSystem(model or self.model(), self.input_function(), kernel or self.sim["kernel"])

    def integrator(
        self, system: CableSystem, name: str | None = None, step: float | None = None
    ) -> Integrator:
        """The scene's integrator (or another by name) on ``system``."""
        return make_integrator(name or self.sim["integrator"], system, step or float(self.sim["step"]))

    def with_links(self, n_links: int) -> Scene:
        """The same scene at another resolution (physical quantities per length held fixed).

        Per-joint constants (paper mode) are first converted to the equivalent bending
        stiffness and damping, EI = k_i l and c_i l at the scene's own (uniform) link length, so
        the cable's physics does not change with n (MODEL.md, "Resolution independence").
        """
        p = self.params
        if n_links == p.n_links:
            return self
        if p.stiffness_mode == "per_joint":
            l0 = float(p.lengths().mean())
            p = p.replace(stiffness_mode="bending", bending_stiffness=p.joint_stiffness * l0,
                          bending_damping=p.joint_damping * l0)
        return Scene(p.replace(n_links=n_links), dict(self.sim), dict(self.extra),
                     dict(self.source))


def scene_from_dict(values: dict[str, Any]) -> Scene:
    """Build a scene from flat key/values (unknown keys go to ``extra``).

    An anchored scene (``end_condition`` anchored or paper_anchor) without a ``seabed`` key gets
    a seabed at the anchor's depth (``seabed_depth`` unset); free-end scenes have none unless
    they ask for it. The shipped scenes all state ``seabed`` and ``added_mass`` explicitly.
    """
    pnames = set(CableParams.field_names())
    pkw = {k: v for k, v in values.items() if k in pnames}
    if "seabed" not in pkw and pkw.get("end_condition") in ("anchored", "paper_anchor"):
        # an anchored scene that does not say otherwise lies on a seabed at the anchor's depth
        pkw["seabed"] = True
    if "link_lengths" in pkw and not pkw["link_lengths"]:
        pkw["link_lengths"] = None
    if "mass_per_length" in pkw and pkw["mass_per_length"] in (0, 0.0, None):
        pkw["mass_per_length"] = None
    sim = dict(SIM_DEFAULTS)
    sim.update({k: v for k, v in values.items() if k in SIM_DEFAULTS})
    step = sim["step"]
    if not isinstance(step, (int, float)) or not np.isfinite(step) or step <= 0:
        raise ParameterError("step", step, "a finite number > 0 [s]")
    extra = {k: v for k, v in values.items() if k not in pnames and k not in SIM_DEFAULTS}
    return Scene(CableParams(**pkw), sim, extra, dict(values))


def load_scene(name_or_path: str | Path, overrides: dict[str, Any] | None = None) -> Scene:
    """Load a scene file (by name or path) and apply overrides."""
    values = read_parameter_file(scene_path(name_or_path))
    values.update(overrides or {})
    return scene_from_dict(values)


def available_scenes() -> list[str]:
    """Names of the scenes shipped in ``config/``."""
    return sorted(p.stem for p in CONFIG_DIR.glob("*.yaml"))


__all__ = ["Scene", "load_scene", "scene_from_dict", "available_scenes"]
