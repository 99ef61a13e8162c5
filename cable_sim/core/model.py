"""Immutable cable model: per-link arrays and prefix sums built once from :class:`CableParams`.

The model/state split follows MuJoCo's: :class:`CableModel` never changes after construction;
the state is a plain array ``y = [q, qdot]`` with ``q = [z_m, theta_1 .. theta_n]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cable_sim.core.params import CableParams

#: Integer codes used by the compiled kernels.
DRAG_CODES = {"none": 0, "paper": 1, "morison": 2}
END_CODES = {"free": 0, "anchored": 1, "paper_anchor": 2}


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class CableModel:
    """Precomputed, read-only model of an n-link cable (see MODEL.md for every symbol).

    Attributes
    ----------
    params : CableParams
        The parameters it was built from.
    n : int
        Number of links; ``ndof = n + 1``.
    length, mass, weight_mass : ndarray (n,)
        l_i [m], m_i [kg] and the reduced (buoyancy-corrected) mass m~_i [kg] used in weights.
    mass_below : ndarray (n,)
        B_i = sum_{k>i} m_k + m_c [kg].
    mu, mu_weight : ndarray (n,)
        Coupling masses mu_i = m_i/2 + B_i and mu~_i (with reduced masses).
    load_mass, load_weight_mass : float
        m_c and m~_c [kg] (``paper_anchor``: 8e8 kg, neutrally buoyant; ``anchored``: 0).
    total_mass : float
        M_00 = M + sum m_k + m_c.
    joint_k, joint_c : ndarray (n,)
        k_1..k_n [N m/rad] and c_1..c_n [N m s/rad]; index 0 is the fairlead pin. Zero when switched off.
    heave_k, heave_c : float
        Platform spring and damper (zero when switched off).
    drag : int
        0 none, 1 paper, 2 Morison (see :data:`DRAG_CODES`).
    drag_gamma_l2 : ndarray (n,)
        gamma_i l_i^2 / 4 for the paper drag.
    morison_cn, morison_ct : ndarray (n,)
        1/2 rho_w d_i l_i C_dn and 1/2 rho_w d_i l_i pi C_dt [kg/m].
    current : float
        Uniform current along +x [m/s].
    end : int
        0 free, 1 anchored constraint, 2 paper anchor emulation.
    anchor : ndarray (2,)
        Anchor position (x, z) [m].
    baumgarte_alpha, baumgarte_beta : float
        Constraint stabilisation: Phi'' + 2 alpha Phi' + beta^2 Phi = 0.
    seabed : bool
        Seabed contact on (MODEL.md, "Round 2 terms").
    seabed_z : float
        z of the seabed [m] (-inf when off).
    seabed_k, seabed_c : ndarray (n,)
        Contact stiffness [N/m^2] and damping [N s/m^2] per unit length on each link (zero when off).
    friction_axial, friction_transverse : ndarray (n,)
        Coulomb coefficients per link (zero when off or without a seabed).
    friction_speed : float
        Regularisation slip speed v_c [m/s].
    added_mass : bool
        Morison added mass on.
    added_mass_normal, added_mass_axial : ndarray (n,)
        m_an = C_an rho_w pi d_i^2/4 and m_at = C_at rho_w pi d_i^2/4 per unit length [kg/m]
        (zero when off).
    """

    params: CableParams
    n: int
    length: np.ndarray
    mass: np.ndarray
    weight_mass: np.ndarray
    mass_below: np.ndarray
    mu: np.ndarray
    mu_weight: np.ndarray
    load_mass: float
    load_weight_mass: float
    platform_mass: float
    total_mass: float
    joint_k: np.ndarray
    joint_c: np.ndarray
    heave_k: float
    heave_c: float
    heave_locked: bool
    wave_coupling: bool
    gravity: float
    water_density: float
    drag: int
    drag_gamma_l2: np.ndarray
    morison_cn: np.ndarray
    morison_ct: np.ndarray
    current: float
    end: int
    anchor: np.ndarray
    baumgarte_alpha: float
    baumgarte_beta: float
    seabed: bool = False
    seabed_z: float = -np.inf
    seabed_k: np.ndarray | None = None
    seabed_c: np.ndarray | None = None
    friction_axial: np.ndarray | None = None
    friction_transverse: np.ndarray | None = None
    friction_speed: float = 1.0
    added_mass: bool = False
    added_mass_normal: np.ndarray | None = None
    added_mass_axial: np.ndarray | None = None

    @property
    def ndof(self) -> int:
        """Number of generalised coordinates, n + 1."""
        return self.n + 1

    @property
    def constrained(self) -> bool:
        """True when the end is held by the exact anchor constraint."""
        return self.end == END_CODES["anchored"]

    @classmethod
    def from_params(cls, p: CableParams) -> CableModel:
        """Build the model (all precomputation happens here, once)."""
        n = p.n_links
        l = p.lengths()
        d = np.array(p.diameter, dtype=float)
        area = np.pi * d**2 / 4.0
        if p.mass_per_length is not None:
            m = p.mass_per_length * l
        else:
            m = np.array(p.line_density) * area * l
        rho_w = p.water_density
        m_w = m - rho_w * area * l if p.buoyancy else m.copy()
        if p.end_condition == "free":
            m_c = p.load_mass
            m_c_w = m_c - rho_w * p.load_volume if p.buoyancy else m_c
        elif p.end_condition == "paper_anchor":
            m_c = p.paper_anchor_mass
            m_c_w = 0.0  # buoyancy equals weight (paper)
        else:
            m_c, m_c_w = 0.0, 0.0
        # B_i = sum_{k>i} m_k + m_c (reverse cumulative sum, exclusive)
        rev = np.cumsum(m[::-1])[::-1]
        below = rev - m + m_c
        rev_w = np.cumsum(m_w[::-1])[::-1]
        below_w = rev_w - m_w + m_c_w
        mu = m / 2.0 + below
        mu_w = m_w / 2.0 + below_w

        if p.stiffness_mode == "per_joint":
            k = np.full(n, p.joint_stiffness)
            c = np.full(n, p.joint_damping)
        else:
            lbar = np.empty(n)
            lbar[0] = l[0]
            lbar[1:] = 0.5 * (l[1:] + l[:-1])
            k = p.bending_stiffness / lbar
            c = p.bending_damping / lbar
        k[0] = p.pin_stiffness
        c[0] = p.pin_damping
        if not p.joint_springs:
            k[:] = 0.0
        if not p.joint_dampers:
            c[:] = 0.0

        omega_b = p.constraint_stiffness
        zb = p.seabed_z()
        on = np.full(n, 1.0 if zb is not None else 0.0)
        am = np.full(n, 1.0 if p.added_mass else 0.0)
        return cls(
            params=p,
            n=n,
            length=_frozen(l),
            mass=_frozen(m),
            weight_mass=_frozen(m_w),
            mass_below=_frozen(below),
            mu=_frozen(mu),
            mu_weight=_frozen(mu_w),
            load_mass=float(m_c),
            load_weight_mass=float(m_c_w),
            platform_mass=p.platform_mass,
            total_mass=float(p.platform_mass + m.sum() + m_c),
            joint_k=_frozen(k),
            joint_c=_frozen(c),
            heave_k=p.heave_stiffness if p.platform_spring else 0.0,
            heave_c=p.heave_damping if p.platform_damper else 0.0,
            heave_locked=p.heave_locked,
            wave_coupling=p.wave_coupling,
            gravity=p.gravity,
            water_density=rho_w,
            drag={"none": 0, "paper": 1, "morison": 2}[p.drag_model],
            drag_gamma_l2=_frozen(np.full(n, p.paper_drag_gamma) * l**2 / 4.0),
            morison_cn=_frozen(0.5 * rho_w * d * l * p.drag_cn),
            morison_ct=_frozen(0.5 * rho_w * d * l * np.pi * p.drag_ct),
            current=p.current_speed,
            end=END_CODES[p.end_condition],
            anchor=_frozen(np.array([p.anchor_x, p.anchor_z])),
            baumgarte_alpha=omega_b,
            baumgarte_beta=omega_b,
            seabed=zb is not None,
            seabed_z=-np.inf if zb is None else float(zb),
            seabed_k=_frozen(on * p.seabed_stiffness),
            seabed_c=_frozen(on * p.seabed_damping),
            friction_axial=_frozen(on * p.seabed_friction_axial),
            friction_transverse=_frozen(on * p.seabed_friction_transverse),
            friction_speed=p.seabed_friction_speed,
            added_mass=bool(p.added_mass),
            added_mass_normal=_frozen(am * p.added_mass_cn * rho_w * area),
            added_mass_axial=_frozen(am * p.added_mass_ct * rho_w * area),
        )

    def terms(self) -> list[str]:
        """Names of the physics terms this model computes (for the start-up log line)."""
        out = ["inertia", "gravity"]
        if self.params.buoyancy:
            out.append("buoyancy")
        if np.any(self.joint_k):
            out.append("joint_springs")
        if np.any(self.joint_c):
            out.append("joint_dampers")
        if self.heave_k:
            out.append("platform_spring")
        if self.heave_c:
            out.append("platform_damper")
        if self.wave_coupling and self.heave_k:
            out.append("wave_coupling")
        out.append({0: "no_drag", 1: "paper_drag", 2: "morison_drag"}[self.drag])
        if self.drag == 2 and self.current:
            out.append("current")
        if self.heave_locked:
            out.append("heave_locked")
        if self.seabed:
            out.append("seabed")
            if np.any(self.friction_axial) or np.any(self.friction_transverse):
                out.append("seabed_friction")
        if self.added_mass:
            out.append("added_mass")
        return out
