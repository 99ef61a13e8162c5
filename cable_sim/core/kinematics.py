"""Joint positions and velocities of the n-link cable (pure numpy).

Below :mod:`cable_sim.core.dynamics` (which re-exports both) so that modules it imports, such as
:mod:`cable_sim.core.seabed`, can use them. Imports numpy and :mod:`cable_sim.core.model`.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core.model import CableModel


def joint_positions(model: CableModel, q: np.ndarray) -> np.ndarray:
    """Positions p_0..p_n of the joints, shape (n+1, 2), columns (x, z) [m]; p_0 is the fairlead."""
    th = q[1:]
    p = np.empty((model.n + 1, 2))  # not np.zeros: above 1 KiB it releases the GIL (see README)
    p[0] = 0.0
    p[1:, 0] = np.cumsum(model.length * np.sin(th))
    p[1:, 1] = -np.cumsum(model.length * np.cos(th))
    p[:, 1] += q[0]
    return p


def joint_velocities(model: CableModel, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Velocities of p_0..p_n, shape (n+1, 2) [m/s]."""
    th, w = q[1:], qd[1:]
    v = np.empty((model.n + 1, 2))
    v[0] = 0.0
    v[1:, 0] = np.cumsum(model.length * np.cos(th) * w)
    v[1:, 1] = np.cumsum(model.length * np.sin(th) * w)
    v[:, 1] += qd[0]
    return v
