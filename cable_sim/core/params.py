"""Validated physical parameters of a cable scene.

Every quantity is SI (m, kg, s, N, rad). :class:`CableParams` is a frozen dataclass;
constructing one validates every field and raises :class:`ParameterError` that names the
parameter, the offending value and the allowed range. Conventions follow ``MODEL.md``
(REP-103: x-z plane, z up, still water at z = 0).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

DRAG_MODELS = ("none", "paper", "morison")
END_CONDITIONS = ("free", "anchored", "paper_anchor")
STIFFNESS_MODES = ("per_joint", "bending")


class ParameterError(ValueError):
    """A parameter is outside its allowed range.

    Parameters
    ----------
    name : str
        Parameter name as the user wrote it.
    value : Any
        The rejected value.
    allowed : str
        Human-readable allowed range, e.g. ``"integer >= 1"``.
    """

    def __init__(self, name: str, value: Any, allowed: str) -> None:
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"parameter '{name}' = {value!r} is invalid; allowed: {allowed}")


def _finite(name: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ParameterError(name, value, "a finite real number") from None
    if not math.isfinite(x):
        raise ParameterError(name, value, "a finite real number")
    return x


def _positive(name: str, value: Any) -> float:
    x = _finite(name, value)
    if x <= 0.0:
        raise ParameterError(name, value, "a finite number > 0")
    return x


def _non_negative(name: str, value: Any) -> float:
    x = _finite(name, value)
    if x < 0.0:
        raise ParameterError(name, value, "a finite number >= 0")
    return x


def _per_link(name: str, value: Any, n: int, check) -> tuple[float, ...]:
    """Scalar or length-n sequence -> tuple of n validated floats."""
    if np.ndim(value) == 0:
        return (check(name, value),) * n
    seq = list(np.asarray(value, dtype=object).ravel())
    if len(seq) != n:
        raise ParameterError(name, value, f"a scalar or a sequence of n_links = {n} values")
    return tuple(check(f"{name}[{i}]", v) for i, v in enumerate(seq))


def _choice(name: str, value: Any, options: tuple[str, ...]) -> str:
    if value not in options:
        raise ParameterError(name, value, "one of " + ", ".join(repr(o) for o in options))
    return str(value)


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(name, value, "true or false")
    return bool(value)


@dataclass(frozen=True)
class CableParams:
    """Physical description of one cable scene (immutable, validated on construction).

    Parameters
    ----------
    n_links : int
        Number of rigid links n (>= 1); the model has n + 1 degrees of freedom.
    total_length : float
        Unstretched cable length L [m]; links are L/n long unless ``link_lengths`` is given.
    link_lengths : tuple of float or None
        Per-link lengths [m] (overrides ``total_length``).
    diameter : float or tuple
        Hydrodynamic and displacement diameter d [m] (scalar or per link).
    line_density : float or tuple
        Material density rho_c [kg/m^3] used for link mass m_i = rho_c pi d^2/4 l_i.
    mass_per_length : float or None
        If given [kg/m], overrides the density-based link mass (displacement still uses d).
    stiffness_mode : {"per_joint", "bending"}
        ``per_joint``: joint constants k_i, c_i as given (paper mode). ``bending``: k_i = EI / l_bar_i,
        c_i = bending_damping / l_bar_i, l_bar_i the mean length of the two links at joint i.
    joint_stiffness, joint_damping : float
        Per-joint constants for joints 2..n [N m/rad], [N m s/rad] (``per_joint`` mode).
    bending_stiffness, bending_damping : float
        EI [N m^2] and bending damping [N m^2 s] (``bending`` mode).
    pin_stiffness, pin_damping : float
        Fairlead pin (joint 1) spring/damper relative to the vertical; 0 gives a free pin.
    platform_mass, heave_stiffness, heave_damping : float
        Platform mass M [kg], hydrostatic heave stiffness k_m [N/m], heave damping c_m [N s/m].
    heave_locked : bool
        If true the platform is held at its initial height (fixed top).
    load_mass, load_volume : float
        Terminal load mass m_c [kg] and displaced volume V_c [m^3] (free end).
    water_density, gravity : float
        rho_w [kg/m^3], g [m/s^2].
    drag_model : {"none", "paper", "morison"}
        Hydrodynamic drag model (see MODEL.md).
    paper_drag_gamma : float
        gamma_i of the paper's drag [kg/m].
    drag_cn, drag_ct : float
        Morison normal and tangential drag coefficients.
    current_speed : float
        Uniform current along +x [m/s] (Morison drag only).
    end_condition : {"free", "anchored", "paper_anchor"}
        Free terminal load, exact anchor constraint, or the paper's 8e8 kg emulation.
    anchor_x, anchor_z : float
        Anchor position [m] for the anchored ends.
    paper_anchor_mass : float
        Mass of the emulated anchor in ``paper_anchor`` mode (neutrally buoyant).
    buoyancy, joint_springs, joint_dampers, platform_spring, platform_damper, wave_coupling : bool
        Physics-term switches; a switched-off term is not computed.
    constraint_stiffness : float
        Baumgarte natural frequency omega_b [1/s] for the anchor constraint (critically damped).
    seabed : bool
        Flat seabed contact on (MODEL.md, "Round 2 terms"). Off by default.
    seabed_depth : float or None
        z of the floor [m] (< 0: below the fairlead at the still-water level). None: the anchor's
        depth (anchored ends; required for a free end with a seabed).
    seabed_stiffness : float
        Contact stiffness k_b per unit length per metre of penetration [N/m^2] (> 0); a resting
        line sinks w / k_b (w its wet weight per length). MoorDyn's per-area kBot times d.
    seabed_damping : float
        Contact damping c_b per unit length [N s/m^2]; acts only in contact, never pulls down.
    seabed_friction_axial, seabed_friction_transverse : float
        Coulomb coefficients along the link axis and across it (0: no friction).
    seabed_friction_speed : float
        Regularisation slip speed v_c [m/s] (> 0): below it friction grows linearly with the
        slip speed (MoorDyn's "cv" form), above it is mu times the contact force.
    added_mass : bool
        Morison added mass on (switchable inertia term). Off by default.
    added_mass_cn, added_mass_ct : float
        Normal and tangential added-mass coefficients: per length m_an = C_an rho_w pi d^2/4,
        m_at = C_at rho_w pi d^2/4.
    """

    n_links: int = 60
    total_length: float = 240.0
    link_lengths: tuple[float, ...] | None = None
    diameter: Any = 0.01
    line_density: Any = 7850.0
    mass_per_length: float | None = None
    stiffness_mode: str = "per_joint"
    joint_stiffness: float = 104.7
    joint_damping: float = 2.8
    bending_stiffness: float = 0.0
    bending_damping: float = 0.0
    pin_stiffness: float = 0.0
    pin_damping: float = 0.0
    platform_mass: float = 6000.0
    heave_stiffness: float = 1200.0
    heave_damping: float = 237.6
    heave_locked: bool = False
    load_mass: float = 60.0
    load_volume: float = 0.0
    water_density: float = 1025.0
    gravity: float = 9.81
    drag_model: str = "paper"
    paper_drag_gamma: float = 200.0
    drag_cn: float = 1.2
    drag_ct: float = 0.008
    current_speed: float = 0.0
    end_condition: str = "free"
    anchor_x: float = 150.0
    anchor_z: float = -150.0
    paper_anchor_mass: float = 8.0e8
    buoyancy: bool = True
    joint_springs: bool = True
    joint_dampers: bool = True
    platform_spring: bool = True
    platform_damper: bool = True
    wave_coupling: bool = True
    constraint_stiffness: float = 20.0
    seabed: bool = False
    seabed_depth: float | None = None
    seabed_stiffness: float = 1.0e5
    seabed_damping: float = 2.0e3
    seabed_friction_axial: float = 0.0
    seabed_friction_transverse: float = 0.0
    seabed_friction_speed: float = 0.01
    added_mass: bool = False
    added_mass_cn: float = 1.0
    added_mass_ct: float = 0.0
    _validated: bool = field(default=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = self.n_links
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ParameterError("n_links", n, "integer >= 1")
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        set_("n_links", int(n))
        set_("total_length", _positive("total_length", self.total_length))
        if self.link_lengths is not None:
            set_("link_lengths", _per_link("link_lengths", self.link_lengths, n, _positive))
        set_("diameter", _per_link("diameter", self.diameter, n, _positive))
        set_("line_density", _per_link("line_density", self.line_density, n, _positive))
        if self.mass_per_length is not None:
            set_("mass_per_length", _positive("mass_per_length", self.mass_per_length))
        set_("stiffness_mode", _choice("stiffness_mode", self.stiffness_mode, STIFFNESS_MODES))
        for name in (
            "joint_stiffness", "joint_damping", "bending_stiffness", "bending_damping",
            "pin_stiffness", "pin_damping", "heave_stiffness", "heave_damping", "load_mass",
            "load_volume", "gravity", "paper_drag_gamma", "drag_cn", "drag_ct", "seabed_damping",
            "seabed_friction_axial", "seabed_friction_transverse", "added_mass_cn", "added_mass_ct",
        ):
            set_(name, _non_negative(name, getattr(self, name)))
        for name in ("platform_mass", "water_density", "paper_anchor_mass", "constraint_stiffness",
                     "seabed_stiffness", "seabed_friction_speed"):
            set_(name, _positive(name, getattr(self, name)))
        for name in ("current_speed", "anchor_x", "anchor_z"):
            set_(name, _finite(name, getattr(self, name)))
        set_("drag_model", _choice("drag_model", self.drag_model, DRAG_MODELS))
        set_("end_condition", _choice("end_condition", self.end_condition, END_CONDITIONS))
        for name in (
            "heave_locked", "buoyancy", "joint_springs", "joint_dampers", "platform_spring",
            "platform_damper", "wave_coupling", "seabed", "added_mass",
        ):
            set_(name, _flag(name, getattr(self, name)))
        self._check_seabed()
        if self.end_condition == "anchored":
            free_dofs = self.n_links + (0 if self.heave_locked else 1) - 2
            if free_dofs < 1:
                raise ParameterError(
                    "n_links", self.n_links,
                    "an anchored line needs at least one free degree of freedom: n_links >= "
                    + ("3 with heave_locked" if self.heave_locked else "2"),
                )
        if self.link_lengths is not None:
            object.__setattr__(self, "total_length", float(sum(self.link_lengths)))
        set_("_validated", True)

    def _check_seabed(self) -> None:
        """Seabed geometry: below the fairlead (z = 0), and not above an anchor."""
        if self.seabed_depth is not None:
            zb = _finite("seabed_depth", self.seabed_depth)
            object.__setattr__(self, "seabed_depth", zb)
        if not self.seabed:
            return
        anchored = self.end_condition in ("anchored", "paper_anchor")
        if self.seabed_depth is None and not anchored:
            raise ParameterError("seabed_depth", None,
                                 "a finite number < 0 [m] (z of the floor): a free-end line with a "
                                 "seabed needs its depth")
        zb = self.anchor_z if self.seabed_depth is None else self.seabed_depth
        if zb >= 0.0:
            raise ParameterError("seabed_depth", zb,
                                 "a finite number < 0 [m]: the seabed must lie below the fairlead "
                                 "(the platform floats at z = 0)")
        if anchored and self.anchor_z > zb:
            raise ParameterError("anchor_z", self.anchor_z,
                                 f"<= seabed_depth = {zb:g} m (an anchor cannot float above the seabed)")

    def seabed_z(self) -> float | None:
        """z of the seabed [m] when the seabed is on (the anchor's depth unless set), else None."""
        if not self.seabed:
            return None
        return self.anchor_z if self.seabed_depth is None else float(self.seabed_depth)

    def lengths(self) -> np.ndarray:
        """Link lengths l_i [m] as a float array of shape (n,)."""
        if self.link_lengths is not None:
            return np.array(self.link_lengths, dtype=float)
        return np.full(self.n_links, self.total_length / self.n_links)

    def replace(self, **changes: Any) -> CableParams:
        """Return a validated copy with some fields changed.

        Per-link sequences sized for the old ``n_links`` are reset to their first value when
        ``n_links`` changes, so a scene can be re-resolved with a different n.
        """
        d = self.to_dict()
        if "n_links" in changes and changes["n_links"] != self.n_links:
            for k in ("diameter", "line_density"):
                if k not in changes:
                    d[k] = d[k][0]
            if "link_lengths" not in changes:
                d["link_lengths"] = None
        d.update(changes)
        return CableParams(**d)

    def to_dict(self) -> dict[str, Any]:
        """Plain dictionary of the public fields (for metadata and YAML)."""
        d = asdict(self)
        d.pop("_validated", None)
        return d

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of the public parameters."""
        return tuple(f.name for f in fields(cls) if not f.name.startswith("_"))
