"""The anchored end's correction from the inward sweep's sums, against the dense algebra.

The forward dynamics of an anchored line no longer solves the two unit end forces outwards: the
inward sweep sums ``J M^-1 J^T`` and the applied forces' end acceleration
(:func:`cable_sim.core.kernel.sweeps.inward_sweep_ws` with ``endm``, completed by the platform's
share in :func:`cable_sim.core.kernel.forward.end_correction_terms`). Here both are compared with
the dense formulas of :mod:`cable_sim.core.dynamics` built from the mass matrix:
``G = J M^-1 J^T`` and ``a_end,0 = J M^-1 Q + (dJ/dt) qd`` over the free coordinates (the
platform's heave dropped when locked). The whole forward dynamics is checked against the same
dense solver and mpmath in ``test_fast_kernel.py``; this test pins the two intermediate results
that the Schur complement rests on, with and without Morison drag and added mass.
"""

from __future__ import annotations

import numpy as np
import pytest
from kernel_models import make_model
from scipy.linalg import cho_factor, cho_solve

from cable_sim.core import dynamics as dense
from cable_sim.core.kernel.forward import (
    _F_BZ,
    _F_ENDM,
    _F_ZDD,
    end_correction_terms,
    fd_packed_ws,
    fd_workspace,
)
from cable_sim.core.kernel.packing import pack_arrays
from cable_sim.core.model import CableModel

#: Norm-wise relative agreement required (measured ~1e-14 on these cases; the margin is for
#: the round-off of other CPUs, the quantities are well conditioned at these states).
RTOL = 1e-9


def anchored_model(n: int, locked: bool, drag: str, added_mass: bool) -> CableModel:
    """The kernel tests' anchored line (:func:`kernel_models.make_model`), with or without the
    Morison added mass."""
    model = make_model(n, "anchored", drag, locked)
    return CableModel.from_params(model.params.replace(added_mass=added_mass))


def dense_terms(model: CableModel, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``J M^-1 J^T`` and ``J M^-1 Q + (dJ/dt) qd`` from the dense mass matrix."""
    M = dense.mass_matrix(model, q)
    if model.added_mass:
        M = M + dense.added_mass_terms(model, q, qd)[0]
    Q = dense.applied_force(model, q, qd)
    s = 1 if model.heave_locked else 0
    cf = cho_factor(M[s:, s:])
    J = dense.constraint_jacobian(model, q)[:, s:]
    G = J @ cho_solve(cf, J.T)
    a = J @ cho_solve(cf, Q[s:]) + dense.constraint_bias(model, q, qd)
    return G, a


@pytest.mark.parametrize("n", [3, 12, 60])
@pytest.mark.parametrize("locked", [False, True])
@pytest.mark.parametrize("drag,added_mass", [("none", False), ("morison", True)])
def test_end_correction_sums_match_dense(n: int, locked: bool, drag: str,
                                         added_mass: bool) -> None:
    model = anchored_model(n, locked, drag, added_mass)
    arr, par = pack_arrays(model)
    rng = np.random.default_rng(5 * n + locked)
    ws = fd_workspace(n)
    for _ in range(3):
        q = np.concatenate([[rng.normal()], rng.uniform(-1.4, 1.4, n)])
        qd = np.concatenate([[0.0 if locked else rng.normal()], rng.normal(size=n)])
        qdd = np.empty(n + 1)
        lam = np.empty(2)
        assert fd_packed_ws(arr, par, 0.0, 0.0, q, qd, qdd, lam, ws)
        g00, g01, g11, ax, az = end_correction_terms(ws[_F_ENDM, :5], ws[_F_BZ, :3],
                                                     ws[_F_ZDD, :3])
        G_ref, a_ref = dense_terms(model, q, qd)
        G = np.array([[g00, g01], [g01, g11]])
        assert np.linalg.norm(G - G_ref) <= RTOL * np.linalg.norm(G_ref)
        assert np.linalg.norm(np.array([ax, az]) - a_ref) <= RTOL * np.linalg.norm(a_ref)
