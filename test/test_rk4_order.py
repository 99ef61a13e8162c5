"""RK4 converges at order 4 on the paper's free-fall scene.

Reference: scipy's DOP853 (order 8) at rtol = atol = 1e-13 on the same right-hand side; its own
error is estimated against DOP853 at the tolerance floor 2.5e-14 and must be at least 10x smaller
than every RK4 error used. Scene: paper_free_fall as shipped (n = 60, paper drag, 60 kg load,
released from horizontal, dense kernel) shortened to the first 2 s, the violent start of the
fall. Steps h = 4, 2, 1 ms lie inside RK4's stability region for this horizon (the paper drag
makes RK4 stability-limited near 3-4 ms only over long runs / larger n). Error: the largest
distance [m] of any joint from its reference position over samples every 0.1 s, with joint
positions from the independent kinematics of ``conftest.RefLine``.
"""

from __future__ import annotations

import numpy as np
from conftest import RefLine

from cable_sim.integrators import RK4, ScipyIntegrator
from cable_sim.scenes import load_scene

HORIZON, DT_OUT = 2.0, 0.1
STEPS = (0.004, 0.002, 0.001)


def test_rk4_fourth_order_on_free_fall() -> None:
    """Observed order log2(e(h)/e(h/2)) within 3.5-4.5 for each halving (and the fitted slope)."""
    scene = load_scene("paper_free_fall", {"kernel": "dense"})
    model = scene.model()
    ref = RefLine(scene.params)
    n1 = model.ndof
    y0 = scene.initial_state(model)

    def joints(ys: np.ndarray) -> np.ndarray:
        return np.array([ref.joints(y[:n1]) for y in ys])

    def reference(tol: float) -> np.ndarray:
        integ = ScipyIntegrator(scene.system(model=model), rtol=tol, atol=tol)
        return joints(integ.integrate(y0, 0.0, HORIZON, DT_OUT).y)

    p_ref = reference(1e-13)
    ref_err = np.max(np.linalg.norm(p_ref - reference(2.5e-14), axis=2))
    errors = []
    for h in STEPS:
        tr = RK4(scene.system(model=model), step=h).integrate(y0, 0.0, HORIZON, DT_OUT)
        assert np.all(np.isfinite(tr.y))
        errors.append(float(np.max(np.linalg.norm(joints(tr.y) - p_ref, axis=2))))
    errors = np.array(errors)
    orders = np.log2(errors[:-1] / errors[1:])
    slope = np.polyfit(np.log(STEPS), np.log(errors), 1)[0]
    print("RK4 max joint-position errors [m]: " + ", ".join(
        f"h = {h * 1e3:g} ms: {e:.3g}" for h, e in zip(STEPS, errors, strict=True)))
    print(f"observed orders {np.round(orders, 3).tolist()}, fitted slope {slope:.3f}, "
          f"reference error estimate {ref_err:.2g} m")
    assert errors.min() > 10 * ref_err, "reference not accurate enough for the smallest step"
    assert np.all((orders > 3.5) & (orders < 4.5))
    assert 3.5 < slope < 4.5
