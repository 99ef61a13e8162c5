"""ROS34PRw: a four-stage, order-3, L-stable Rosenbrock W-method on the O(n) operator, fixed
step and adaptive; the compiled step, runs and controller of
:mod:`cable_sim.integrate.implicit.ros34` with another tableau.

Method: J. Rang, "Improved traditional Rosenbrock-Wanner methods for stiff ODEs and DAEs",
J. Comput. Appl. Math. 286 (2015) 128-144, method ROS34PRw (coefficients as in PETSc's
``TSROSWR34PRW``, ``src/ts/impls/rosw/rosw.c``, 16 digits). It shares ROS34PW2's diagonal
``gamma = 0.435866521508459`` (so the same operator ``M + hg D + hg^2 K`` per step) and its
second row; it was built to be B_PR-consistent of order 3 (order 3 on the Prothero-Robinson
problem ``y' = lambda (y - g) + g'`` uniformly in ``lambda``, i.e. less order reduction for
stiff components driven by a slow forcing), where ROS34PW2 is of B_PR order 2 (the paper's and
PETSc's statement, not checked here).

Measured against ROS34PW2 at equal fixed steps (paper free fall, 31 s, max joint-position
error against the benchmark's references; the cost per step is the same): n = 80 paper drag,
h = 0.5/k s, k = 10..14: 9-27 % smaller errors (41.7 ms: 1.008 cm against 1.110 cm); n = 80
Morison drag, k = 4..9: 1.9-2.6x smaller (100 ms: 0.94 cm against 2.13 cm); n = 160, 320,
k = 8..16: 1.9-3.7x smaller; n = 640, 5-20 ms: the same within +-25 %.

Properties (checked in ``test/integrate/test_ros34prw.py`` from the coefficients):

* order 3 for *any* approximation ``T`` of the Jacobian in ``W = I - h gamma T`` (the eight
  order conditions of a W-method up to order 3 hold to round-off), so order 3 with the local
  ``D``, ``K`` of :mod:`cable_sim.integrate.implicit.operator`;
* L-stable: A-stable (``|R(iy)| <= 1``) and ``R(inf) = 1 - b^T (alpha + Gamma)^-1 1 = 0``;
* stiffly accurate: ``b_i = alpha_4i + gamma_4i`` and ``sum_j alpha_4j = 1`` (the solution is
  the last stage);
* embedded solution (``b_hat``, used for the step-size control): order 2 as a Rosenbrock
  method (``T`` the exact Jacobian: ``b_hat^T (alpha + Gamma) 1 = 1/2``), but only order 1 as
  a W-method (``b_hat^T alpha 1 = 0.606``, ``b_hat^T Gamma 1 = -0.106``); its stability
  function has ``R_hat(inf) = -1/4`` (PETSc: 0.25 in magnitude). ROS34PW2's embedded solution
  is of W-order 2. With the local ``W`` of the cable the estimate therefore carries an ``O(h^2)``
  part ``0.106 h^2 (f' - T) f``; it still estimates the embedded solution's own error (the
  propagated solution is of order 3), which is what the controller uses.
* Stage 3 is evaluated at ``t + 1.154 h`` (``alpha_3 = 1.1538``, beyond the step); the inputs
  are sampled there (the fixed-step path from the exact input signals, the adaptive one by
  the same cubic interpolation, extrapolating over at most 0.154 h at an interval's end).

Integrate layer: imports numpy and the sibling module ``ros34``.
"""

from __future__ import annotations

import numpy as np

from cable_sim.integrate.implicit.ros34 import Ros34PW2, Ros34PW2Adaptive, RosTableau, ros_tableau

#: Diagonal gamma of ROS34PRw (the same as ROS34PW2's).
GAMMA = 4.3586652150845900e-01
#: alpha_ij (strictly lower triangular).
ALPHA = np.array([
    [0.0, 0.0, 0.0, 0.0],
    [8.7173304301691801e-01, 0.0, 0.0, 0.0],
    [1.4722022879435914e+00, -3.1840250568090289e-01, 0.0, 0.0],
    [8.1505192016694938e-01, 5.0000000000000000e-01, -3.1505192016694938e-01, 0.0],
])
#: gamma_ij (lower triangular, diagonal GAMMA).
GAMMA_IJ = np.array([
    [GAMMA, 0.0, 0.0, 0.0],
    [-8.7173304301691801e-01, GAMMA, 0.0, 0.0],
    [-1.2855347382089872e+00, 5.0507005541550687e-01, GAMMA, 0.0],
    [-4.8201449182864348e-01, 2.1793326075422950e-01, -1.7178529043404503e-01, GAMMA],
])
#: Weights of the order-3 solution (= the last row of ALPHA + GAMMA_IJ: stiffly accurate).
B = np.array([3.3303742833830591e-01, 7.1793326075422947e-01, -4.8683721060099439e-01, GAMMA])
#: Weights of the embedded solution (Rosenbrock order 2, W-order 1).
B_HAT = np.array([2.5000000000000000e-01, 7.4276119608319180e-01, -3.1472922970066219e-01,
                  3.2196803361747034e-01])

#: ROS34PRw in both forms (see :class:`cable_sim.integrate.implicit.ros34.RosTableau`).
TABLEAU: RosTableau = ros_tableau("ROS34PRw", GAMMA, ALPHA, GAMMA_IJ, B, B_HAT)


class Ros34PRw(Ros34PW2):
    """ROS34PRw (Rang 2015) with the local O(n) operator, fixed step.

    Order 3 for any approximation of the Jacobian (a Rosenbrock W-method), hence order 3 with
    the local ``D``, ``K`` of :mod:`cable_sim.integrate.implicit`. Four stages: four force
    evaluations, one O(n) factorisation and four O(n) solves per step, as
    :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2` (same ``gamma``, same compiled step,
    another tableau). L-stable (``R(inf) = 0``), stiffly accurate, B_PR-consistent of order 3;
    embedded solution of Rosenbrock order 2 (W-order 1), used by :class:`Ros34PRwAdaptive`.
    See :mod:`cable_sim.integrate.implicit.ros34prw`.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    geometric_stiffness, predict_drag, max_drift, taut_slack, max_condition, compiled
        See :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2`.
    """

    name = "ros34prw"
    order = 3
    tableau = TABLEAU


class Ros34PRwAdaptive(Ros34PW2Adaptive):
    """ROS34PRw with its embedded error estimate and the PI step-size controller of
    :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2Adaptive`.

    Order 3 (the propagated solution), L-stable, see :class:`Ros34PRw`; the estimate is the
    difference to the embedded solution (Rosenbrock order 2, W-order 1). Parameters, output
    grid, input sampling and error norm as
    :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2Adaptive`.

    Parameters
    ----------
    system : CableSystem
    step : float
        Output interval [s].
    rtol, atol, first_step, max_step, safety, fac_min, fac_max, input_spacing, **kwargs
        See :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2Adaptive`.
    """

    name = "ros34prw_adaptive"
    order = 3
    tableau = TABLEAU


__all__ = ["ALPHA", "B", "B_HAT", "GAMMA", "GAMMA_IJ", "TABLEAU", "Ros34PRw", "Ros34PRwAdaptive"]
