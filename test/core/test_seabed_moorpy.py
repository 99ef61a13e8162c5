"""Issue 11, item 2: the static line on the seabed against MoorPy (test-only dependency, pinned
in the Makefile's TEST_PKGS).

MoorPy's quasi-static catenary solver (``moorpy.Catenary.catenary``, adapted from FAST's) takes
the anchor-to-fairlead span and rise, the length, the axial stiffness EA and the wet weight per
length, with a frictionless seabed at the anchor (CB = 0); it returns the fairlead force and the
length lying on the seabed. EA = 1e10 N keeps its stretch below 1e-4 (inextensible within 0.1 %,
checked). Our static solution (n = 80, no bending stiffness, stiff bed: 1 mm rest penetration)
must give the fairlead tension and the laid length within 1 % for three anchor positions.
"""

from __future__ import annotations

import numpy as np
import pytest
from moorpy.Catenary import catenary
from test_seabed_statics import DEPTH, L, W, line

from cable_sim.core import dynamics, seabed
from cable_sim.core.statics import static_equilibrium

EA = 1.0e10


@pytest.mark.parametrize("anchor_x", [220.0, 250.0, 270.0])
def test_fairlead_tension_and_laid_length_match_moorpy(anchor_x: float) -> None:
    model = line(anchor_x)
    q, _ = static_equilibrium(model)
    qd = np.zeros_like(q)
    qdd, anchor = dynamics.forward_dynamics(model, q, qd)
    F = dynamics.joint_forces(model, q, qd, qdd, anchor)
    out = seabed.seabed_outputs(model, q)
    rise = q[0] + DEPTH
    fAH, fAV, fBH, fBV, info = catenary(anchor_x, rise, L, EA, W, CB=0.0, Tol=1e-10, MaxIter=500)
    T_ref = float(np.hypot(fBH, fBV))
    assert T_ref / EA < 1e-4  # inextensible within 0.1 %
    err_T = np.linalg.norm(F[0]) / T_ref - 1.0
    err_lb = out.laid_length / info["LBot"] - 1.0
    print(f"anchor x = {anchor_x}: fairlead tension {np.linalg.norm(F[0]):.1f} N (MoorPy {T_ref:.1f}, "
          f"{err_T:+.2e}), laid {out.laid_length:.3f} m (MoorPy {info['LBot']:.3f}, {err_lb:+.2e})")
    assert info["LBot"] > 50.0
    assert abs(err_T) < 0.01 and abs(err_lb) < 0.01
