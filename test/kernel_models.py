"""Models shared by the kernel tests (``test/core``): non-uniform links, pin spring/damper,
buoyant load and a current, any end condition, drag model and heave lock."""

from __future__ import annotations

import numpy as np

from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams


def make_model(n: int, end: str, drag: str, locked: bool) -> CableModel:
    """A model with non-uniform links, pin spring/damper, buoyant load and a current."""
    rng = np.random.default_rng(1000 + n)
    p = CableParams(
        n_links=n,
        link_lengths=tuple(240.0 / n * rng.uniform(0.7, 1.3, n)),
        diameter=tuple(rng.uniform(0.008, 0.012, n)),
        pin_stiffness=40.0,
        pin_damping=2.0,
        drag_model=drag,
        end_condition=end,
        heave_locked=locked,
        current_speed=0.6,
        load_volume=0.01,
        anchor_x=120.0,
        anchor_z=-190.0,
    )
    return CableModel.from_params(p)
