"""W6S4OS (:mod:`cable_sim.integrate.implicit.w6s4os`): its table, order and stability.

1. The table, checked without the cable code: the classical stage times ``alpha 1`` recovered
   from the transformed coefficients equal the stage times the source lists separately; the
   weights sum to 1.
2. Order 4 with the exact Jacobian and with two wrong ones (the W-method property), observed
   with an s-stage Rosenbrock-W step in the transformed form written here (Hairer & Wanner IV.7
   (7.4')) on a smooth nonlinear 2-D system, against DOP853 at 1e-13.
3. The stability function from the classical form, ``R(z) = 1 + z b^T (I - z (alpha +
   Gamma))^-1 1``: ``R(z) - exp(z)`` shrinks like ``z^5``; ``|R(x)| <= 1`` for x < 0;
   ``R(z) -> 0`` as ``z -> -inf``; on the imaginary axis ``|R|`` stays within 1 % of 1 (the
   method is not A-stable: the module docstring's 1.0064).
4. On the cable the dense fallback gives the compiled step's trajectory to 1e-7 of its size
   (the order-test scene, ``order_scenes.py``). Its observed order there (4, steps 40, 20,
   10 ms, each end condition) is checked with every fixed-step scheme's in
   ``test_integrator_order.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from order_scenes import order_case
from rosw_kform import jac_osc, oscillator
from scipy.integrate import solve_ivp

from cable_sim.integrate import make_integrator
from cable_sim.integrate.implicit import w6s4os

TB = w6s4os.TABLEAU


def test_stage_times_match_the_listed_ones_and_weights_sum_to_one() -> None:
    assert np.max(np.abs(TB.alpha.sum(axis=1) - w6s4os.C_TIMES_LISTED)) < 1e-13
    assert abs(TB.b.sum() - 1.0) < 1e-13
    assert TB.a_t.shape == (6, 6)


def _step(f, T, y, h):
    """Six-stage Rosenbrock-W step, transformed form, W = I - h gamma T (written here)."""
    g = TB.gamma
    W = np.eye(y.size) - h * g * T
    s: list[np.ndarray] = []
    for i in range(6):
        yi = y + h * sum((TB.a_t[i, j] * s[j] for j in range(i)), np.zeros(y.size))
        rhs = g * (f(yi) + sum((TB.c_t[i, j] * s[j] for j in range(i)), np.zeros(y.size)))
        s.append(np.linalg.solve(W, rhs))
    return y + h * sum(TB.m_t[i] * s[i] for i in range(6))


@pytest.mark.parametrize("which", ["exact", "zero", "perturbed"])
def test_order_4_for_any_jacobian(which: str) -> None:
    T_of = {"exact": jac_osc,
            "zero": lambda y: np.zeros((2, 2)),
            "perturbed": lambda y: 0.3 * jac_osc(y) + np.array([[0.2, -0.4], [0.7, 0.1]])}[which]
    y0, t_end = np.array([2.0, 0.0]), 2.0
    exact = solve_ivp(lambda t, y: oscillator(y), (0.0, t_end), y0, method="DOP853", rtol=1e-13,
                      atol=1e-13).y[:, -1]
    hs = np.array([0.1, 0.05, 0.025, 0.0125])
    errs = []
    for h in hs:
        y = y0.copy()
        for _ in range(round(t_end / h)):
            y = _step(oscillator, T_of(y), y, h)
        errs.append(np.max(np.abs(y - exact)))
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    print(f"W6S4OS, T {which}: errors {np.array2string(np.array(errs), precision=2)} -> {slope:.2f}")
    assert errs[-1] > 1e-11  # well above DOP853's 1e-13
    assert abs(slope - 4.0) <= 0.2


def _stability(z: complex) -> complex:
    one = np.ones(6)
    A = TB.alpha + TB.gamma_ij
    return 1.0 + z * TB.b @ np.linalg.solve(np.eye(6) - z * A, one)


def test_stability_function() -> None:
    zs = np.array([0.1, 0.05, 0.025])
    dev = np.array([abs(_stability(-z) - np.exp(-z)) for z in zs])
    assert np.all(np.abs(np.diff(np.log(dev)) / np.diff(np.log(zs)) - 5.0) <= 0.3)
    xs = np.logspace(-3, 8, 400)
    assert max(abs(_stability(-x)) for x in xs) <= 1.0
    assert abs(_stability(-1e10)) < 1e-6
    on_axis = max(abs(_stability(1j * y)) for y in np.logspace(-3, 4, 400))
    assert 1.0 < on_axis < 1.01


def test_dense_fallback_agrees_with_the_compiled_step() -> None:
    scene, model, y0 = order_case("free")
    fast = make_integrator("w6s4os", scene.system(model=model), 0.02).advance(0.0, y0, 1.0)
    dense = make_integrator("w6s4os", scene.system(kernel="dense", model=model), 0.02).advance(0.0, y0, 1.0)
    assert np.max(np.abs(fast - dense)) <= 1e-7 * np.max(np.abs(fast))
    assert np.max(np.abs(fast - y0)) > 1e-2  # the state moved: the comparison is not trivial
