"""ROS34PW2 (:mod:`cable_sim.integrate.implicit.ros34`): coefficients, order, error estimate,
adaptive tolerance.

1. The literature table (Rang & Angermann 2005) is checked independently of the cable code: a
   textbook Rosenbrock-W step in the classical k-form (``rosw_kform.py``, written here),
   applied to small ODEs with known solutions, converges at order 3 with the exact Jacobian
   *and* with wrong ones (a W-method), its embedded solution at order 2; the stability function
   ``R(z) = 1 + z b^T (I - z (alpha + Gamma))^-1 1`` matches ``exp(z)`` to O(z^4), is bounded by
   1 on the imaginary axis and in the left half-plane, and tends to 0 as ``z -> -inf``
   (L-stable). The module's transformed coefficients reproduce the k-form step.
2. On the cable (the order-test scene of ``test_integrator_order.py``: n = 10, Morison drag,
   sine heave force, free end / exact anchor / 8e8 kg anchor, DOP853 1e-13 reference) the
   fixed-step scheme converges at order 3 +- 0.3; so does ROS34PRw (test_ros34prw.py checks its
   table).
3. The embedded estimate of one step (ROS34PW2 and ROS34PRw) is within a factor 3 of the true
   local error of the embedded solution (what it estimates) over a ladder of steps.
4. The adaptive scheme meets its tolerance on the paper's free fall (n = 80, paper drag):
   max joint-position error vs DOP853 (1e-10) <= 10 atol, with steps far above Rosenbrock2's.
"""

from __future__ import annotations

import numpy as np
import pytest
from order_scenes import ENDS, SMOOTH, dop853_reference, max_joint_position_error, order_case
from rosw_kform import jac_osc, kform_step, observed_order, oscillator, transformed_step

from cable_sim.integrate import IntegrationError, ScipyIntegrator, make_integrator
from cable_sim.integrate.implicit import ros34, ros34prw
from cable_sim.scene.scenes import load_scene

# --------------------------------------------------------------------------------------------
# 1. the table, independently of the cable code
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("jac", ["exact", "zero", "wrong"])
def test_table_is_order_3_w_method(jac: str) -> None:
    # scalar y' = -y^2 (+ the 2D oscillator), y(0) = 1: y = 1 / (1 + t)
    f1 = lambda y: -(y**2)  # noqa: E731
    T1 = {"exact": lambda y: np.array([[-2.0 * y[0]]]), "zero": lambda y: np.zeros((1, 1)),
          "wrong": lambda y: np.array([[-7.0]])}[jac]
    hs = np.array([0.05, 0.025, 0.0125, 0.00625])
    p, errs = observed_order(f1, T1, np.array([1.0]), 2.0, hs, np.array([1.0 / 3.0]), ros34)
    print(f"y'=-y^2, T {jac}: errors {np.array2string(np.array(errs), precision=2)} order {p:.2f}")
    assert abs(p - 3.0) <= 0.3 and errs[-1] > 1e-13
    # the embedded weights: order 2
    p2, _ = observed_order(f1, T1, np.array([1.0]), 2.0, hs, np.array([1.0 / 3.0]), ros34,
                           ros34.B_HAT)
    assert abs(p2 - 2.0) <= 0.3, p2
    # nonlinear 2D system, reference: the same step at h/32 (converged far below the errors)
    T2 = {"exact": jac_osc, "zero": lambda y: np.zeros((2, 2)),
          "wrong": lambda y: np.array([[-3.0, 0.5], [0.2, -1.0]])}[jac]
    y0 = np.array([2.0, 0.0])
    y = y0.copy()
    for _ in range(round(2.0 / (hs[-1] / 32))):
        y = kform_step(oscillator, T2(y), y, hs[-1] / 32, ros34)
    p, errs = observed_order(oscillator, T2, y0, 2.0, hs, y, ros34)
    print(f"oscillator, T {jac}: errors {np.array2string(np.array(errs), precision=2)} order {p:.2f}")
    assert abs(p - 3.0) <= 0.3


def _stability(z: complex) -> complex:
    beta = ros34.ALPHA + ros34.GAMMA_IJ
    return 1.0 + z * (ros34.B @ np.linalg.solve(np.eye(4) - z * beta, np.ones(4)))


def test_stability_function_l_stable() -> None:
    # R(z) = exp(z) + O(z^4): order 3 on linear problems
    for z in (1e-2, -1e-2, 1e-2j):
        assert abs(_stability(z) - np.exp(z)) <= 0.1 * abs(z) ** 4 + 1e-15
    assert abs(_stability(-1e-1) - np.exp(-1e-1)) > 1e-9  # not higher than order 3.. (sanity)
    # L-stable: R -> 0 at -inf; A-stable: |R| <= 1 on the imaginary axis and in the left half-plane
    assert abs(_stability(-1e10)) < 1e-8
    assert abs(_stability(-1e4)) < 1e-3
    for y in np.logspace(-3, 4, 200):
        assert abs(_stability(1j * y)) <= 1.0 + 1e-12
    rng = np.random.default_rng(0)
    for z in -np.abs(rng.normal(0, 30, 400)) + 1j * rng.normal(0, 30, 400):
        assert abs(_stability(z)) <= 1.0 + 1e-12


def test_transformed_coefficients_reproduce_k_form() -> None:
    """The module's s-form (A_T, C_T, M_T, E_T) gives the k-form's solution and embedded difference."""
    T = np.array([[-3.0, 0.5], [0.2, -1.0]])
    y, h = np.array([2.0, 0.3]), 0.1
    yn, est = transformed_step(oscillator, T, y, h, ros34.TABLEAU)
    ref = kform_step(oscillator, T, y, h, ros34)
    ref_hat = kform_step(oscillator, T, y, h, ros34, ros34.B_HAT)
    np.testing.assert_allclose(yn, ref, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(est, ref - ref_hat, rtol=1e-9, atol=1e-15)


# --------------------------------------------------------------------------------------------
# 2.-4. on the cable
# --------------------------------------------------------------------------------------------

HORIZON = 2.0


SCHEMES = {"ros34pw2": ros34.TABLEAU, "ros34prw": ros34prw.TABLEAU}


@pytest.mark.parametrize("scheme", list(SCHEMES))
@pytest.mark.parametrize("end", list(ENDS))
def test_observed_order_3(end: str, scheme: str) -> None:
    scene, model, y0 = order_case(end)
    y_ref = dop853_reference(end, HORIZON)
    hs = np.array([0.04, 0.02, 0.01, 0.005])
    errs = np.array([np.max(np.abs(make_integrator(scheme, scene.system(model=model), float(h))
                                   .advance(0.0, y0, HORIZON) - y_ref)) for h in hs])
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    print(f"{scheme} {end:13s} errors {np.array2string(errs, precision=2)} -> order {slope:.2f}")
    assert errs[-1] > 1e3 * 1e-13 * np.max(np.abs(y_ref))  # well above the reference's round-off
    assert abs(slope - 3.0) <= 0.3
    assert np.all(np.diff(errs) < 0)


@pytest.mark.parametrize("scheme", list(SCHEMES))
@pytest.mark.parametrize("end", list(ENDS))
def test_embedded_estimate_tracks_true_error(end: str, scheme: str) -> None:
    """One step from a moving state: the estimate ``y - y_hat`` vs the true local error of
    ``y_hat`` (DOP853 1e-13 over the same step), both in the joint-mapped max norm."""
    scene, model, y0 = order_case(end)
    y1 = make_integrator(scheme, scene.system(model=model), 0.01).advance(0.0, y0, 1.0)
    arr = ros34.fast.pack_arrays(model)[0]
    ratios = []
    for h in (0.1, 0.05, 0.025, 0.0125):
        system = scene.system(model=model)
        y_new, est = ros34._dense_ros_step(system, 1.0, y1, h, True, tableau=SCHEMES[scheme])
        exact = ScipyIntegrator(scene.system(model=model), "DOP853", rtol=1e-13,
                                atol=1e-13).advance(1.0, y1, 1.0 + h)
        y_hat = y_new - est
        true = y_hat - exact
        n_est = ros34.err_norm(arr, y1, y_new, est, 1.0, 0.0)
        n_true = ros34.err_norm(arr, y1, y_new, true, 1.0, 0.0)
        ratios.append(n_est / n_true)
    print(f"{scheme} {end}: estimate / true error of the embedded solution {np.round(ratios, 3)}")
    assert all(1.0 / 3.0 <= r <= 3.0 for r in ratios), ratios


@pytest.fixture(scope="module")
def free_fall_80():
    scene = load_scene("paper_free_fall", {"n_links": 80, "kernel": "fast"})
    model = scene.model()
    y0 = scene.initial_state(model)
    ts = np.arange(0.0, 31.0 + 1e-9, 0.5)
    ref = ScipyIntegrator(scene.system(model=model), "DOP853", rtol=1e-10, atol=1e-10)
    traj = ref.integrate(y0, 0.0, 31.0, 0.5)
    return scene, model, y0, ts, traj.y


@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_adaptive_meets_tolerance_free_fall(free_fall_80, tol: float) -> None:
    scene, model, y0, ts, y_ref = free_fall_80
    integ = make_integrator("ros34pw2_adaptive", scene.system(model=model), 0.5, atol=tol)
    traj = integ.integrate(y0, 0.0, 31.0, 0.5)
    err = max_joint_position_error(model, traj.y, y_ref)
    mean_h = 31.0 / integ.nsteps
    print(f"atol {tol:g}: max joint-position error {err:.3g} m, {integ.nsteps} steps "
          f"(mean {mean_h * 1e3:.1f} ms), {integ.nrejected} rejected")
    assert err <= 10.0 * tol
    assert integ.nrejected <= 0.2 * integ.nsteps


def test_adaptive_stable_where_rosenbrock2_needs_small_steps(free_fall_80) -> None:
    """At a loose tolerance the adaptive scheme's mean step is above 60 ms and its error within
    1 m; Rosenbrock2 at a fixed 62.5 ms (beyond its measured stability limit 41.7 ms at n = 80)
    either fails loudly or is far less accurate."""
    scene, model, y0, ts, y_ref = free_fall_80
    integ = make_integrator("ros34pw2_adaptive", scene.system(model=model), 0.5, atol=0.1)
    err = max_joint_position_error(model, integ.integrate(y0, 0.0, 31.0, 0.5).y, y_ref)
    mean_h = 31.0 / integ.nsteps
    r2 = make_integrator("rosenbrock2", scene.system(model=model), 0.0625)
    try:
        err2 = max_joint_position_error(model, r2.integrate(y0, 0.0, 31.0, 0.5).y, y_ref)
    except IntegrationError:
        err2 = np.inf
    print(f"adaptive atol 0.1: mean step {mean_h * 1e3:.1f} ms, error {err:.3g} m; "
          f"rosenbrock2 62.5 ms: error {err2:.3g} m")
    assert mean_h > 0.06 and err <= 1.0
    assert err2 > 3.0 * err


def test_adaptive_parameters_validated() -> None:
    scene, model, y0 = order_case("free")
    for kw, match in (({"atol": 0.0}, "atol"), ({"rtol": -1.0}, "rtol"), ({"fac_max": 1.0}, "fac_max"),
                      ({"safety": 1.5}, "safety"), ({"input_spacing": 0.0}, "input_spacing")):
        with pytest.raises(ValueError, match=match):
            make_integrator("ros34pw2_adaptive", scene.system(model=model), 0.5, **kw)


def test_adaptive_keeps_output_grid_and_inputs() -> None:
    """Adaptive steps end exactly on every output time; with the sine heave force (inputs
    sampled and interpolated inside the compiled loop) the result matches DOP853 to the
    tolerance, and the compiled path equals the dense reference path."""
    scene, model, y0 = order_case("free")
    y_ref = dop853_reference("free", HORIZON)
    res = {}
    for kernel in ("fast", "dense"):
        sc = load_scene("paper_free_fall", {**SMOOTH, "kernel": kernel})
        integ = make_integrator("ros34pw2_adaptive", sc.system(model=sc.model()), 0.1, atol=1e-6)
        y = y0
        for k in range(20):  # 20 output intervals of 0.1 s
            y = integ.step(0.1 * k, y)
        res[kernel] = (y, integ.nsteps)
    err = max_joint_position_error(model, [res["fast"][0]], [y_ref])
    print(f"adaptive 1e-6 over 20 x 0.1 s: joint error {err:.3g} m, steps {res['fast'][1]}")
    assert err <= 1e-5
    # the same controller on the dense path: the same steps up to decisions at round-off
    assert abs(res["fast"][1] - res["dense"][1]) <= 2
    assert max_joint_position_error(model, [res["fast"][0]], [res["dense"][0]]) <= 1e-6
