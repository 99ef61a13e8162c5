"""Compile (or load from numba's on-disk cache) the kernels before real time starts.

Core layer: imports numpy, :mod:`cable_sim.core.params`, :mod:`cable_sim.core.model` and the
kernel's Python API (forward, energy, joint_forces).
"""

from __future__ import annotations

import numpy as np

from cable_sim.core.dynamics import Inputs
from cable_sim.core.kernel.energy import energy
from cable_sim.core.kernel.forward import forward_dynamics, state_derivative
from cable_sim.core.kernel.joint_forces import joint_forces
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams


def warmup() -> None:
    """Compile (or load from the on-disk cache) every kernel on a tiny model.

    Call once at start-up, before real time starts, so the first real step is not a compile.
    """
    for end, drag in (("free", "morison"), ("anchored", "paper")):
        p = CableParams(n_links=2, drag_model=drag, end_condition=end, current_speed=0.1,
                        anchor_x=10.0, anchor_z=-200.0)
        model = CableModel.from_params(p)
        q = np.array([0.0, 0.3, 0.2])
        qd = np.array([0.1, -0.2, 0.05])
        qdd, lam = forward_dynamics(model, q, qd, Inputs(1.0, 0.1))
        joint_forces(model, q, qd, qdd, lam)
        energy(model, q, qd)
        state_derivative(model, np.concatenate([q, qd]))
