"""A textbook Rosenbrock-W step in the classical k-form, written here independently of the cable
code, and small ODEs to run it on: the reference the tests of the ROS34 tableaus
(test_ros34.py, test_ros34prw.py) check the literature coefficients and the module's
transformed form against."""

from __future__ import annotations

from types import ModuleType

import numpy as np


def kform_step(f, T, y, h, table: ModuleType, weights=None):
    """Classical Rosenbrock-W step (Hairer & Wanner IV.7 (7.4) with W = I - h gamma T):
    ``(I - h g T) k_i = h f(y + sum alpha_ij k_j) + h T sum_{j<i} gamma_ij k_j``; ``table`` a
    module with ``ALPHA``, ``GAMMA_IJ``, ``GAMMA``, ``B`` (``weights`` replace ``B``)."""
    al, ga, g = table.ALPHA, table.GAMMA_IJ, table.GAMMA
    b = table.B if weights is None else weights
    d = y.size
    Wm = np.eye(d) - h * g * T
    ks = []
    for i in range(4):
        yi = y + sum((al[i, j] * ks[j] for j in range(i)), np.zeros(d))
        rhs = h * f(yi) + h * T @ sum((ga[i, j] * ks[j] for j in range(i)), np.zeros(d))
        ks.append(np.linalg.solve(Wm, rhs))
    return y + sum(b[i] * ks[i] for i in range(4))


def transformed_step(f, T, y, h, tableau):
    """The same step in the module's transformed s-form (``tableau.a_t, c_t, m_t, e_t``):
    (new state, embedded difference)."""
    g = tableau.gamma
    W = np.eye(y.size) - h * g * T
    s = []
    for i in range(4):
        yi = y + h * sum((tableau.a_t[i, j] * s[j] for j in range(i)), np.zeros(y.size))
        s.append(np.linalg.solve(W, g * (f(yi) + sum((tableau.c_t[i, j] * s[j] for j in range(i)),
                                                      np.zeros(y.size)))))
    return (y + h * sum(tableau.m_t[i] * s[i] for i in range(4)),
            h * sum(tableau.e_t[i] * s[i] for i in range(4)))


def oscillator(y):
    """Van der Pol-like smooth nonlinear 2D system without closed form; reference by fine steps."""
    return np.array([y[1], -y[0] - 0.5 * (y[0] ** 2 - 1.0) * y[1]])


def jac_osc(y):
    """Exact Jacobian of :func:`oscillator`."""
    return np.array([[0.0, 1.0], [-1.0 - y[0] * y[1], -0.5 * (y[0] ** 2 - 1.0)]])


def observed_order(f, T_of, y0, t_end, hs, exact, table: ModuleType, weights=None):
    """(log-log slope of the error at ``t_end`` over the steps ``hs``, the errors)."""
    errs = []
    for h in hs:
        y = y0.copy()
        for _ in range(round(t_end / h)):
            y = kform_step(f, T_of(y), y, h, table, weights)
        errs.append(np.max(np.abs(y - exact)))
    return np.polyfit(np.log(hs), np.log(errs), 1)[0], errs
