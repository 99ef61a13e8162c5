"""Issue #2, item 9: the static-equilibrium state stays still.

For a free-end scene (``paper_free_fall``) and two anchored scenes (``paper_anchored_forced``:
exact anchor, paper drag; ``mooring_line``: Morison drag, bending stiffness), started from
``initial_state: static`` with the inputs switched off (heave_force_source and wave_source
"none"), the scene's own integrator runs 10 s; at every 0.05 s sample the max joint angular
speed must stay < 1e-6 rad/s and the platform speed < 1e-6 m/s.

The free end rests hanging straight down (theta = 0), where the angular speeds stay zero by
symmetry; its non-trivial part is the platform, whose heave spring carries the line's wet
weight. The anchored lines rest curved.

Before running, the state is checked to be a stationary point of the potential computed in
this file's helper (conftest.RefLine, written from MODEL.md, central differences):
grad V(q) = J_end(q)^T lambda with lambda the anchor reaction statics returned (0 for a free
end), to 1e-6 of the wet weight times the line length (the finite-difference error is ~1e-9).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RefLine

from cable_sim.runner import Simulation
from cable_sim.scenes import load_scene
from cable_sim.statics import static_equilibrium

T_END, DT_OUT = 10.0, 0.05


@pytest.mark.parametrize("name", ["paper_free_fall", "paper_anchored_forced", "mooring_line"])
def test_static_state_stays_still(name):
    scene = load_scene(name, {"initial_state": "static", "heave_force_source": "none",
                              "wave_source": "none"})
    sim = Simulation(scene)
    model = sim.model
    q0 = sim.y[: model.ndof].copy()
    assert np.all(sim.y[model.ndof:] == 0.0)

    # an independent check that the start is a stationary point of V (with the anchor force)
    ref = RefLine(scene.params)
    q_s, lam = static_equilibrium(model)
    assert np.allclose(q_s, q0, rtol=0, atol=1e-12)
    resid = ref.potential_gradient(q0) - ref.end_jacobian(q0).T @ lam
    scale = ref.g * (np.abs(ref.mw).sum() + abs(ref.mcw)) * ref.l.sum()
    assert np.max(np.abs(resid)) < 1e-6 * scale, (np.max(np.abs(resid)), scale)
    if model.constrained:
        assert np.max(np.abs(np.diff(q0[1:]))) > 1e-3  # curved rest shape: a real test
    else:
        assert np.max(np.abs(q0[1:])) < 1e-12 and abs(q0[0]) > 1e-3

    w_max = v_max = dq_max = 0.0
    k = 0
    while sim.t < T_END - 1e-9:
        k += 1
        sim.run_until(min(k * DT_OUT, T_END))
        q, qd = sim.y[: model.ndof], sim.y[model.ndof:]
        assert np.all(np.isfinite(sim.y))
        w_max = max(w_max, float(np.max(np.abs(qd[1:]))))
        v_max = max(v_max, abs(float(qd[0])))
        dq_max = max(dq_max, float(np.max(np.abs(q - q0))))
    print(f"\n{name} (n={model.n}, {sim.integrator.name} {sim.h * 1e3:g} ms): |grad V - J^T lam| "
          f"{np.max(np.abs(resid)):.1e} (scale {scale:.3g}); over {T_END:g} s max |theta'| "
          f"{w_max:.2e} rad/s, max |z_m'| {v_max:.2e} m/s, max |q - q0| {dq_max:.2e}")
    assert abs(sim.t - T_END) < 1e-9
    assert w_max < 1e-6
    assert v_max < 1e-6
