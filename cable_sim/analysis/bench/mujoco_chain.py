"""The cable chain as a MuJoCo model (MJCF), for side-by-side timing and cross-checking.

The mapping (drag is left out: MuJoCo has no equivalent of either drag model here, so the
benchmark compares both engines with drag switched off):

- a ``slide`` joint along z for the platform (mass M, heave spring k_m / damper c_m, ``springref``
  0) with ``gravcomp="1"``, since our heave equation cancels the platform's own weight by its
  displacement;
- a chain of ``hinge`` joints about -y (so a positive angle swings the link towards +x, as our
  theta does): joint 1 relative to the platform (the fairlead pin k_1, c_1), joint i relative to
  link i-1 (k_i, c_i), i.e. MuJoCo's ``qpos = [z_m, phi_1 .. phi_n]`` with the relative angles
  ``phi_1 = theta_1``, ``phi_i = theta_i - theta_{i-1}``;
- each link a uniform rod: mass m_i at its centre, inertia m_i l_i^2 / 12 about the centre
  (tiny values about the other axes, which no joint can excite);
- the load a point mass m_c welded at the end of link n;
- buoyancy rho_w V g as a constant upward ``xfrc_applied`` at each body's centre of mass
  (:func:`apply_buoyancy`; MuJoCo keeps ``xfrc_applied`` between steps);
- no contacts, no geoms (nothing collides).

``mujoco`` is an optional dependency (``pip install mujoco``); this module imports it lazily.
Part of the analysis layer (the benchmark's MuJoCo peer, :mod:`.mujoco_compare`): may import
every layer; here core only.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core.dynamics import relative_angles
from cable_sim.core.model import CableModel

#: Inertia [kg m^2] about axes no joint can excite (MuJoCo wants a positive-definite body inertia).
_TINY_INERTIA = 1e-9


def _f(x: float) -> str:
    return repr(float(x))


def chain_mjcf(model: CableModel, timestep: float, integrator: str = "RK4") -> str:
    """MJCF text of the chain (see the module docstring for the mapping).

    Parameters
    ----------
    model : CableModel
        A free-end model (the anchored constraint has no counterpart here).
    timestep : float
        MuJoCo ``option/timestep`` [s].
    integrator : str
        MuJoCo integrator (``RK4``, ``implicitfast``, ``implicit``, ``Euler``).
    """
    if model.end != 0:
        raise ValueError("chain_mjcf: only free-end models are mapped (end_condition 'free')")
    p = model.params
    l, m = np.asarray(model.length), np.asarray(model.mass)
    g = model.gravity
    lines = [
        '<mujoco model="cable_chain">',
        '  <compiler angle="radian" inertiafromgeom="false"/>',
        f'  <option timestep="{_f(timestep)}" integrator="{integrator}" gravity="0 0 {_f(-g)}">',
        '    <flag contact="disable"/>',
        "  </option>",
        "  <worldbody>",
        '    <body name="platform" pos="0 0 0" gravcomp="1">',
        f'      <joint name="platform_heave" type="slide" axis="0 0 1" stiffness="{_f(model.heave_k)}"'
        f' damping="{_f(model.heave_c)}" springref="0"/>',
        f'      <inertial pos="0 0 0" mass="{_f(model.platform_mass)}" diaginertia="1 1 1"/>',
    ]
    indent = "      "
    for i in range(model.n):
        li, mi = float(l[i]), float(m[i])
        pos = "0 0 0" if i == 0 else f"0 0 {_f(-float(l[i - 1]))}"
        rod = max(mi * li * li / 12.0, _TINY_INERTIA)
        lines += [
            f'{indent}<body name="link_{i + 1}" pos="{pos}">',
            f'{indent}  <joint name="joint_{i + 1}" type="hinge" axis="0 -1 0"'
            f' stiffness="{_f(model.joint_k[i])}" damping="{_f(model.joint_c[i])}" springref="0"/>',
            f'{indent}  <inertial pos="0 0 {_f(-li / 2)}" mass="{_f(mi)}"'
            f' diaginertia="{_f(rod)} {_f(rod)} {_f(_TINY_INERTIA)}"/>',
        ]
        indent += "  "
    if model.load_mass > 0:
        lines += [
            f'{indent}<body name="load" pos="0 0 {_f(-float(l[-1]))}">',
            f'{indent}  <inertial pos="0 0 0" mass="{_f(model.load_mass)}"'
            f' diaginertia="{_f(_TINY_INERTIA)} {_f(_TINY_INERTIA)} {_f(_TINY_INERTIA)}"/>',
            f"{indent}</body>",
        ]
    for _ in range(model.n):
        indent = indent[:-2]
        lines.append(f"{indent}</body>")
    lines += ["    </body>", "  </worldbody>", "</mujoco>"]
    del p
    return "\n".join(lines)


def build(model: CableModel, timestep: float, integrator: str = "RK4"):
    """``(mjModel, mjData)`` of the chain with buoyancy applied (needs ``mujoco``)."""
    import mujoco

    mj = mujoco.MjModel.from_xml_string(chain_mjcf(model, timestep, integrator))
    data = mujoco.MjData(mj)
    apply_buoyancy(model, mj, data)
    return mj, data


def apply_buoyancy(model: CableModel, mj, data) -> None:
    """Constant upward force g (m - m~) at each link's (and the load's) centre of mass."""
    import mujoco

    g = model.gravity
    lift = g * (np.asarray(model.mass) - np.asarray(model.weight_mass))
    data.xfrc_applied[:] = 0.0
    for i in range(model.n):
        bid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, f"link_{i + 1}")
        data.xfrc_applied[bid, 2] = lift[i]
    if model.load_mass > 0:
        bid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, "load")
        data.xfrc_applied[bid, 2] = g * (model.load_mass - model.load_weight_mass)


def to_mujoco(q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Our ``(q, qd)`` (absolute angles) -> MuJoCo ``(qpos, qvel)`` (relative angles)."""
    qpos, qvel = np.array(q, dtype=float), np.array(qd, dtype=float)
    qpos[1:] = relative_angles(qpos[1:])
    qvel[1:] = relative_angles(qvel[1:])
    return qpos, qvel


def from_mujoco(qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo ``(qpos, qvel)`` (or ``qacc``) -> our absolute-angle ``(q, qd)``."""
    q, qd = np.array(qpos, dtype=float), np.array(qvel, dtype=float)
    q[1:] = np.cumsum(qpos[1:])
    qd[1:] = np.cumsum(qvel[1:])
    return q, qd


def accelerations(model: CableModel, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """MuJoCo's generalised accelerations at our state, mapped back to our coordinates."""
    import mujoco

    mj, data = build(model, 1e-3)
    data.qpos[:], data.qvel[:] = to_mujoco(q, qd)
    mujoco.mj_forward(mj, data)
    _, qdd = from_mujoco(np.zeros(model.ndof), data.qacc)
    return qdd


__all__ = ["chain_mjcf", "build", "apply_buoyancy", "to_mujoco", "from_mujoco", "accelerations"]
