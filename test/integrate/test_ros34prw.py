"""ROS34PRw (:mod:`cable_sim.integrate.implicit.ros34prw`): coefficients, order, stability,
error estimate, compiled vs dense path.

1. The table (Rang 2015 / PETSc ``TSROSWR34PRW``), independently of the cable code:

   * the order conditions of a Rosenbrock W-method up to order 3, in exact rational arithmetic
     of the 16-digit table. Derivation (written here, not taken from the module): expand
     ``k_i = h f(y + sum_j alpha_ij k_j) + h T sum_{j<=i} gamma_ij k_j`` in h with ``T``
     independent of ``f'``: ``k_i = h f + h^2 (alpha_i f'f + g_i Tf) + h^3 (sum_j alpha_ij
     alpha_j f'f'f + alpha_i^2/2 f''(f,f) + sum_j alpha_ij g_j f'Tf + sum_j gamma_ij alpha_j
     Tf'f + sum_j gamma_ij g_j TTf) + O(h^4)`` (``alpha_i``, ``g_i`` row sums of alpha and
     Gamma); matching ``y + h f + h^2/2 f'f + h^3/6 (f''(f,f) + f'f'f)`` term by term gives
     the eight conditions of :func:`_w_conditions`;
   * the same for the embedded weights: order 2 with the exact Jacobian (``T = f'``: the Tf and
     f'f conditions merge), *not* as a W-method (the module docstring says so);
   * a textbook k-form step on small ODEs converges at order 3 with the exact, a zero and a
     wrong ``T``;
   * stability function ``R(z) = 1 + z b^T (I - z (alpha + Gamma))^-1 1``: ``exp(z) + O(z^4)``,
     ``R(inf) = 0`` (L-stable, stiffly accurate), ``R_hat(inf) = -1/4`` for the embedded
     weights, ``|R| <= 1`` on the imaginary axis and in the left half-plane;
   * the module's transformed coefficients reproduce the k-form step (``rosw_kform.py``).
2. On the cable: the observed order (3 +- 0.3) and the embedded estimate (within a factor 3 of
   the true error) are tested with ROS34PW2's in test_ros34.py (parametrised by scheme).
3. The compiled (O(n)) path agrees with the dense reference path, fixed and adaptive.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from order_scenes import ENDS, SMOOTH, dop853_reference, max_joint_position_error, order_case
from rosw_kform import jac_osc, kform_step, observed_order, oscillator, transformed_step

from cable_sim.integrate import make_integrator
from cable_sim.integrate.implicit import ros34, ros34prw
from cable_sim.scene.scenes import load_scene

# --------------------------------------------------------------------------------------------
# 1. the table, independently of the cable code
# --------------------------------------------------------------------------------------------


def _exact(a) -> list:
    """The table as exact rationals (the binary values of the 16-digit literals)."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        return [Fraction(float(x)) for x in a]
    return [[Fraction(float(x)) for x in row] for row in a]


def _mv(A: list, x: list) -> list:
    return [sum((A[i][j] * x[j] for j in range(len(x))), Fraction(0)) for i in range(len(A))]


def _dot(x: list, y: list) -> Fraction:
    return sum((a * b for a, b in zip(x, y, strict=True)), Fraction(0))


def _w_conditions(b: list, A: list, G: list) -> dict[str, Fraction]:
    """Residuals of the order conditions of a W-method (any T) up to order 3, per elementary
    differential (``A`` = alpha strictly lower, ``G`` = Gamma with its diagonal)."""
    e = [Fraction(1)] * len(b)
    Ae, Ge = _mv(A, e), _mv(G, e)
    return {
        "f": _dot(b, e) - 1,
        "f'f": _dot(b, Ae) - Fraction(1, 2),
        "Tf": _dot(b, Ge),
        "f''(f,f)": _dot(b, [x * x for x in Ae]) - Fraction(1, 3),
        "f'f'f": _dot(b, _mv(A, Ae)) - Fraction(1, 6),
        "f'Tf": _dot(b, _mv(A, Ge)),
        "Tf'f": _dot(b, _mv(G, Ae)),
        "TTf": _dot(b, _mv(G, Ge)),
    }


#: 16-digit table: conditions hold to this (residuals of exact arithmetic on the literals)
_TABLE_TOL = Fraction(1, 10**15)


def test_order_conditions_w_method_order_3() -> None:
    A, G = _exact(ros34prw.ALPHA), _exact(ros34prw.GAMMA_IJ)
    res = _w_conditions(_exact(ros34prw.B), A, G)
    print({k: f"{float(v):.2e}" for k, v in res.items()})
    for name, r in res.items():
        assert abs(r) <= _TABLE_TOL, (name, float(r))
    # the structure the conditions assume: alpha strictly lower, Gamma lower with diagonal gamma
    g = Fraction(ros34prw.GAMMA)
    for i in range(4):
        assert G[i][i] == g and all(A[i][j] == 0 for j in range(i, 4))
        assert all(G[i][j] == 0 for j in range(i + 1, 4))
    # not order 4 (sanity: the check can fail): the bushy tree f'''(f,f,f) of order 4
    e = [Fraction(1)] * 4
    assert abs(_dot(_exact(ros34prw.B), [x**3 for x in _mv(A, e)]) - Fraction(1, 4)) > Fraction(1, 100)


def test_embedded_weights_rosenbrock_order_2_not_w() -> None:
    A, G = _exact(ros34prw.ALPHA), _exact(ros34prw.GAMMA_IJ)
    bh = _exact(ros34prw.B_HAT)
    res = _w_conditions(bh, A, G)
    assert abs(res["f"]) <= _TABLE_TOL
    # with T = f' the order-2 conditions are the sum of the f'f and Tf rows: b^T (alpha+Gamma) 1 = 1/2
    assert abs(res["f'f"] + res["Tf"]) <= _TABLE_TOL
    # ... but separately they fail: with an approximate T the embedded solution is of order 1
    assert abs(res["f'f"]) > Fraction(1, 10)
    # ROS34PW2's embedded weights, for contrast, are of W-order 2
    res2 = _w_conditions(_exact(ros34.B_HAT), _exact(ros34.ALPHA), _exact(ros34.GAMMA_IJ))
    assert abs(res2["f'f"]) <= _TABLE_TOL and abs(res2["Tf"]) <= _TABLE_TOL


def test_stiffly_accurate() -> None:
    A, G, b = _exact(ros34prw.ALPHA), _exact(ros34prw.GAMMA_IJ), _exact(ros34prw.B)
    for j in range(4):
        assert abs(b[j] - (A[3][j] + G[3][j])) <= _TABLE_TOL
    assert abs(sum(A[3]) - 1) <= _TABLE_TOL


@pytest.mark.parametrize("jac", ["exact", "zero", "wrong"])
def test_kform_converges_at_order_3_for_any_t(jac: str) -> None:
    f1 = lambda y: -(y**2)  # noqa: E731  (y(0) = 1: y = 1 / (1 + t))
    T1 = {"exact": lambda y: np.array([[-2.0 * y[0]]]), "zero": lambda y: np.zeros((1, 1)),
          "wrong": lambda y: np.array([[-7.0]])}[jac]
    hs = np.array([0.05, 0.025, 0.0125, 0.00625])
    p, errs = observed_order(f1, T1, np.array([1.0]), 2.0, hs, np.array([1.0 / 3.0]), ros34prw)
    print(f"y'=-y^2, T {jac}: errors {np.array2string(np.array(errs), precision=2)} order {p:.2f}")
    assert abs(p - 3.0) <= 0.3 and errs[-1] > 1e-13
    # the embedded weights: order 2 with the exact Jacobian, order 1 with a wrong one
    p2, _ = observed_order(f1, T1, np.array([1.0]), 2.0, hs, np.array([1.0 / 3.0]), ros34prw,
                           ros34prw.B_HAT)
    assert abs(p2 - (2.0 if jac == "exact" else 1.0)) <= 0.3, p2
    T2 = {"exact": jac_osc, "zero": lambda y: np.zeros((2, 2)),
          "wrong": lambda y: np.array([[-3.0, 0.5], [0.2, -1.0]])}[jac]
    y0 = np.array([2.0, 0.0])
    y = y0.copy()
    for _ in range(round(2.0 / (hs[-1] / 8))):
        y = kform_step(oscillator, T2(y), y, hs[-1] / 8, ros34prw)
    p, errs = observed_order(oscillator, T2, y0, 2.0, hs, y, ros34prw)
    print(f"oscillator, T {jac}: errors {np.array2string(np.array(errs), precision=2)} order {p:.2f}")
    assert abs(p - 3.0) <= 0.3


def _stability(z: complex, b=None) -> complex:
    beta = ros34prw.ALPHA + ros34prw.GAMMA_IJ
    b = ros34prw.B if b is None else b
    return 1.0 + z * (b @ np.linalg.solve(np.eye(4) - z * beta, np.ones(4)))


def test_stability_function() -> None:
    # order 3 on linear problems, and not more
    for z in (1e-2, -1e-2, 1e-2j):
        assert abs(_stability(z) - np.exp(z)) <= 0.1 * abs(z) ** 4 + 1e-15
    assert abs(_stability(-1e-1) - np.exp(-1e-1)) > 1e-7
    # R(inf) = 1 - b^T (alpha + Gamma)^-1 1, exactly from the table: 0 (L-stable); embedded -1/4
    beta = [[Fraction(x) for x in row] for row in ros34prw.ALPHA + ros34prw.GAMMA_IJ]
    w = [Fraction(0)] * 4  # forward substitution: beta w = 1 (beta lower triangular)
    for i in range(4):
        w[i] = (1 - sum((beta[i][j] * w[j] for j in range(i)), Fraction(0))) / beta[i][i]
    r_inf = 1 - _dot(_exact(ros34prw.B), w)
    r_hat_inf = 1 - _dot(_exact(ros34prw.B_HAT), w)
    print(f"R(inf) = {float(r_inf):.2e}, R_hat(inf) = {float(r_hat_inf):.15f}")
    assert abs(r_inf) <= Fraction(1, 10**14)
    assert abs(r_hat_inf + Fraction(1, 4)) <= Fraction(1, 10**14)
    assert abs(_stability(-1e10)) < 1e-8 and abs(_stability(-1e4)) < 1e-3
    # A-stable: |R| <= 1 on the imaginary axis and in the left half-plane
    for y in np.logspace(-3, 5, 300):
        assert abs(_stability(1j * y)) <= 1.0 + 1e-12
    rng = np.random.default_rng(0)
    for z in -np.abs(rng.normal(0, 30, 400)) + 1j * rng.normal(0, 30, 400):
        assert abs(_stability(z)) <= 1.0 + 1e-12


def test_transformed_coefficients_reproduce_k_form() -> None:
    tb = ros34prw.TABLEAU
    T = np.array([[-3.0, 0.5], [0.2, -1.0]])
    y, h = np.array([2.0, 0.3]), 0.1
    yn, est = transformed_step(oscillator, T, y, h, tb)
    ref = kform_step(oscillator, T, y, h, ros34prw)
    ref_hat = kform_step(oscillator, T, y, h, ros34prw, ros34prw.B_HAT)
    np.testing.assert_allclose(yn, ref, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(est, ref - ref_hat, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(tb.c_times, ros34prw.ALPHA.sum(axis=1), rtol=0, atol=0)


# --------------------------------------------------------------------------------------------
# 2.-4. on the cable
# --------------------------------------------------------------------------------------------

HORIZON = 2.0


@pytest.mark.parametrize("end", ["free", "paper_anchor"])
def test_fast_path_agrees_with_dense(end: str) -> None:
    """The compiled O(n) step and the dense reference step (different linear algebra) agree far
    below the scheme's error at this step (~1e-4 m)."""
    scene, model, y0 = order_case(end)
    res = {}
    for kernel in ("fast", "dense"):
        sc = load_scene("paper_free_fall", {**SMOOTH, **ENDS[end], "anchor_x": 150.0,
                                            "anchor_z": -150.0, "kernel": kernel})
        integ = make_integrator("ros34prw", sc.system(model=model), 0.02)
        assert integ.compiled is (kernel == "fast")
        res[kernel] = integ.advance(0.0, y0, 0.5)
    assert max_joint_position_error(model, [res["fast"]], [res["dense"]]) <= 1e-7


def test_adaptive_fast_path_agrees_with_dense_and_tolerance() -> None:
    """Adaptive steps end on every output time; compiled and dense controller take the same steps
    (up to decisions at round-off) and the result meets the tolerance against DOP853."""
    scene, model, y0 = order_case("free")
    y_ref = dop853_reference("free", HORIZON)
    res = {}
    for kernel in ("fast", "dense"):
        sc = load_scene("paper_free_fall", {**SMOOTH, "kernel": kernel})
        integ = make_integrator("ros34prw_adaptive", sc.system(model=sc.model()), 0.1, atol=1e-5)
        y = y0
        for k in range(20):  # 20 output intervals of 0.1 s
            y = integ.step(0.1 * k, y)
        res[kernel] = (y, integ.nsteps)
    err = max_joint_position_error(model, [res["fast"][0]], [y_ref])
    print(f"adaptive 1e-5 over 20 x 0.1 s: joint error {err:.3g} m, steps {res['fast'][1]} "
          f"(dense {res['dense'][1]})")
    assert err <= 1e-4
    assert abs(res["fast"][1] - res["dense"][1]) <= 2
    assert max_joint_position_error(model, [res["fast"][0]], [res["dense"][0]]) <= 1e-6
