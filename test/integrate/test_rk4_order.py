"""RK4 converges at order 4 on a free-fall line, measured far above the round-off floor: the one
home of the order reference (merged with the order test of test_verify_scenes, issue 10), for
both RK4 implementations — the Python ``RK4`` on the dense kernel and the compiled stepper that
``Simulation`` runs on the fast kernel.

Scene: ``paper_free_fall`` (paper masses, joint springs and dampers, 60 kg load, released from
horizontal, dense kernel) with n = 20 links and the drag switched off, over 8 s. Why this scene:

- The paper drag ``-gamma l^2/4 w|w|`` is only C^1 in the angular speed (its second derivative
  jumps where a joint's speed changes sign), so the classical order-4 error expansion does not
  hold for it; with it on, the measured order wanders (2.9-4.5 at n = 20). It also damps the
  fall so strongly that the RK4 error at usable steps sits near 1e-10 m, where the last bits of
  the result depend on the CPU (numba compiles for the host: FMA / AVX-512 change the rounding).
- Without drag the right-hand side is smooth and only lightly damped (joint and heave dampers), so
  the errors stay large: at h = 25, 12.5, 6.25 ms the largest joint-position error over 8 s is
  about 1.8e-3, 1.1e-4, 6.6e-6 m (measured), 1e5 times the round-off floor, and each halving
  gives an observed order of 4.03-4.04 (4.04 at h = 20, 10, 5 ms too). The horizon is 8 s
  because the error of this swinging chain grows faster than linearly in time: over 20 s the
  25 ms run leaves the asymptotic range (observed order 3.7). The steps divide the 0.1 s sampling
  interval exactly, so the integrator runs at the step asked for (checked by its step count).

Reference: scipy's DOP853 (order 8) at rtol = atol = 1e-12 on the same right-hand side. Its
error is bounded by its distance to DOP853 at 1e-10 (about 1e-9 m, measured), which must be below
1 % of every RK4 error. Error: the largest distance [m] of any joint from its reference position
over samples every 0.1 s, with joint positions from the independent kinematics of
``conftest.RefLine``. The reference runs once per module, on the dense kernel (so the compiled
code under test plays no part in it).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RefLine

from cable_sim.integrate import RK4, ScipyIntegrator
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

HORIZON, DT_OUT = 8.0, 0.1
STEPS = (0.025, 0.0125, 0.00625)
SCENE = {"kernel": "dense", "n_links": 20, "drag_model": "none"}


@pytest.fixture(scope="module")
def reference() -> dict:
    """DOP853 (tol 1e-12) joint positions at t = 0, 0.1, ..., 8 s, and its error bound (distance
    to DOP853 at tol 1e-10), on the dense kernel; plus the scene, model, reference line and y0."""
    scene = load_scene("paper_free_fall", SCENE)
    model = scene.model()
    ref = RefLine(scene.params)
    n1 = model.ndof
    y0 = scene.initial_state(model)

    def joints(ys: np.ndarray) -> np.ndarray:
        return np.array([ref.joints(y[:n1]) for y in ys])

    def run(tol: float) -> np.ndarray:
        integ = ScipyIntegrator(scene.system(model=model), "DOP853", rtol=tol, atol=tol)
        return joints(integ.integrate(y0, 0.0, HORIZON, DT_OUT).y)

    p_ref = run(1e-12)
    ref_err = float(np.max(np.linalg.norm(p_ref - run(1e-10), axis=2)))
    return {"scene": scene, "model": model, "ref": ref, "y0": y0, "joints": joints, "p": p_ref,
            "err": ref_err}


def check_order(errors: np.ndarray, ref_err: float, what: str) -> None:
    """Errors far above round-off and the reference's error; observed orders within 3.7..4.3."""
    orders = np.log2(errors[:-1] / errors[1:])
    slope = np.polyfit(np.log(STEPS), np.log(errors), 1)[0]
    print(f"{what}: max joint-position errors [m]: " + ", ".join(
        f"h = {h * 1e3:g} ms: {e:.3g}" for h, e in zip(STEPS, errors, strict=True)))
    print(f"observed orders {np.round(orders, 3).tolist()}, fitted slope {slope:.3f}, "
          f"reference error bound {ref_err:.2g} m")
    assert errors.min() > 1e-6, (
        f"smallest RK4 error {errors.min():.3g} m must be > 1e-6 m (far above round-off)")
    assert ref_err < 0.01 * errors.min(), (
        f"reference error bound {ref_err:.3g} m must be < 1 % of the smallest RK4 error "
        f"{errors.min():.3g} m")
    assert np.all((orders > 3.7) & (orders < 4.3)), f"observed orders {orders} outside 3.7..4.3"
    assert 3.7 < slope < 4.3, f"fitted slope {slope:.3f} outside 3.7..4.3"


def test_rk4_fourth_order_on_free_fall(reference: dict) -> None:
    """Python RK4 on the dense kernel: observed order log2(e(h)/e(h/2)) within 3.7-4.3 for each
    halving (and the fitted slope)."""
    scene, model, y0 = reference["scene"], reference["model"], reference["y0"]
    errors = []
    for h in STEPS:
        integ = RK4(scene.system(model=model), step=h)
        tr = integ.integrate(y0, 0.0, HORIZON, DT_OUT)
        assert integ.nsteps == round(HORIZON / h), (
            f"RK4 took {integ.nsteps} steps for h = {h} s; expected {round(HORIZON / h)}")
        assert np.all(np.isfinite(tr.y))
        errors.append(float(np.max(np.linalg.norm(reference["joints"](tr.y) - reference["p"], axis=2))))
    check_order(np.array(errors), reference["err"], "RK4 (dense)")


def test_compiled_rk4_fourth_order_through_simulation(reference: dict) -> None:
    """The compiled RK4 stepper on the fast kernel, driven by ``Simulation`` at the step asked
    for and sampled every 0.1 s with ``run_until``: same orders, same reference."""
    scene = load_scene("paper_free_fall", {**SCENE, "kernel": "fast"})
    ks = np.arange(1, int(round(HORIZON / DT_OUT)) + 1)
    errors = []
    for h in STEPS:
        sim = Simulation(scene, step=h)
        assert sim.integrator.name == "rk4" and sim.integrator.compiled
        assert sim.h == h, f"Simulation runs at h = {sim.h} s; asked for {h} s"
        e = 0.0
        for k in ks:
            sim.run_until(k * DT_OUT)
            e = max(e, float(np.max(np.linalg.norm(reference["joints"](sim.y[None])[0]
                                                   - reference["p"][k], axis=1))))
        assert abs(sim.t - HORIZON) < 1e-9
        errors.append(e)
    check_order(np.array(errors), reference["err"], "compiled RK4 (fast, Simulation)")
