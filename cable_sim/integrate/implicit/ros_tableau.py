"""Coefficients of a Rosenbrock W-method in the two forms the compiled step and the dense
reference step use (:class:`RosTableau`, built by :func:`ros_tableau`), and those of ROS34PW2
(:data:`TABLEAU`, the classical coefficients ``GAMMA``, ``ALPHA``, ``GAMMA_IJ``, ``B``,
``B_HAT`` and the derived arrays).

Classical form (``k_i`` the stage increments, ``T`` the approximate Jacobian)::

    (I - h gamma T) k_i = h f(t + alpha_i h, y + sum_j alpha_ij k_j) + h T sum_j gamma_ij k_j
    y' = y + sum_i b_i k_i,      y_hat' = y + sum_i b_hat_i k_i

The schemes run it in the transformed variables ``s_i = sum_j gamma_ij k_j / h`` (Hairer &
Wanner, Solving ODEs II, IV.7), which need no product with ``T``::

    (I - h gamma T) s_i = gamma (f(Y_i) + sum_j c_ij s_j),   Y_i = y + h sum_j a_ij s_j
    y' = y + h sum_i m_i s_i,       a = alpha Gamma^-1, c = diag(1/gamma) - Gamma^-1, m = b Gamma^-1

ROS34PW2: Rang & Angermann, BIT Numer. Math. 45 (2005) 761-787 (coefficients as tabulated
there and in PETSc's ``TSROSWRA34PW2``; see :mod:`cable_sim.integrate.implicit.ros34`).

Integrate layer: imports numpy only.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# --------------------------------------------------------------------------------------------
# Coefficients (Rang & Angermann 2005, ROS34PW2; classical form)
# --------------------------------------------------------------------------------------------

#: Diagonal gamma of ROS34PW2.
GAMMA = 4.3586652150845900e-01
#: alpha_ij (strictly lower triangular).
ALPHA = np.array([
    [0.0, 0.0, 0.0, 0.0],
    [8.7173304301691801e-01, 0.0, 0.0, 0.0],
    [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
])
#: gamma_ij (lower triangular, diagonal GAMMA).
GAMMA_IJ = np.array([
    [GAMMA, 0.0, 0.0, 0.0],
    [-8.7173304301691801e-01, GAMMA, 0.0, 0.0],
    [-9.0338057013044082e-01, 5.4180672388095326e-02, GAMMA, 0.0],
    [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, GAMMA],
])
#: Weights of the order-3 solution.
B = np.array([2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, GAMMA])
#: Weights of the embedded order-2 solution.
B_HAT = np.array([3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01])


class RosTableau(NamedTuple):
    """A Rosenbrock W-method in both forms: the classical coefficients (``gamma``, ``alpha``,
    ``gamma_ij`` with diagonal ``gamma``, weights ``b`` and embedded ``b_hat``), the stage times
    ``c_times`` (row sums of ``alpha``) and the transformed coefficients ``a_t``, ``c_t``,
    ``m_t``, ``e_t`` the compiled step runs on (see the module docstring). Built by
    :func:`ros_tableau`."""

    name: str
    gamma: float
    alpha: np.ndarray
    gamma_ij: np.ndarray
    b: np.ndarray
    b_hat: np.ndarray
    c_times: np.ndarray
    a_t: np.ndarray
    c_t: np.ndarray
    m_t: np.ndarray
    e_t: np.ndarray


def ros_tableau(name: str, gamma: float, alpha: np.ndarray, gamma_ij: np.ndarray, b: np.ndarray,
                b_hat: np.ndarray) -> RosTableau:
    """The :class:`RosTableau` of a Rosenbrock W-method given in the classical form (Hairer &
    Wanner IV.7): ``a = alpha Gamma^-1``, ``c = diag(1/gamma) - Gamma^-1``, ``m = b Gamma^-1``,
    ``e = (b - b_hat) Gamma^-1``."""
    ginv = np.linalg.inv(gamma_ij)
    return RosTableau(name, float(gamma), alpha, gamma_ij, b, b_hat, alpha.sum(axis=1),
                      alpha @ ginv, np.diag(np.diag(ginv)) - ginv, b @ ginv, (b - b_hat) @ ginv)


#: ROS34PW2 in both forms.
TABLEAU = ros_tableau("ROS34PW2", GAMMA, ALPHA, GAMMA_IJ, B, B_HAT)
#: Stage times alpha_i (fractions of h) = row sums of ALPHA.
C_TIMES = TABLEAU.c_times
#: Transformed coefficients (see the module docstring).
A_T = TABLEAU.a_t
C_T = TABLEAU.c_t  # diag(1/gamma) - Gamma^-1: strictly lower
M_T = TABLEAU.m_t
E_T = TABLEAU.e_t  # error weights: y' - y_hat' = h sum_i E_T[i] s_i


__all__ = ["ALPHA", "A_T", "B", "B_HAT", "C_T", "C_TIMES", "E_T", "GAMMA", "GAMMA_IJ", "M_T", "TABLEAU",
           "RosTableau", "ros_tableau"]
