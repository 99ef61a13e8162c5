"""W6S4OS: a six-stage Rosenbrock W-method of order 4 on the O(n) operator, fixed step.

Why: the four-stage schemes (ROS34PW2, ROS34PRw) are of order 3 for any ``W``; on the paper's
free fall at n = 80 their largest step within 1 cm of the reference is 38.5 ms (ROS34PRw gives
1.9 cm at 50 ms, its error growing with the late swing's phase error). A W-method of order 4
keeps order 4 with the local ``M + hg D + hg^2 K`` of :mod:`cable_sim.integrate.implicit`, where
a classical Rosenbrock method of order 4 (RODAS-type) drops to the W-order of its tableau.

The coefficients are the transformed ones (``a``, ``C``, ``m``: Hairer & Wanner IV.7 (7.4'),
with W = I - h gamma J) of the method listed as *RosenbrockW6S4OS* in OrdinaryDiffEq.jl
(Rahunanthan & Stanescu, "High-order W-methods", J. Comput. Appl. Math. 233, 2010), ``gamma =
1/4``. They run on the compiled step of :mod:`cable_sim.integrate.implicit.ros34`, which takes
any number of stages; the classical form (``alpha``, ``Gamma``, ``b``) is recovered here from
them (``Gamma^-1 = diag(1/gamma) - C``, ``alpha = a Gamma``, ``b = m Gamma``). What the tests
check (test/integrate/test_w6s4os.py), independently of this code where they can:

* the stage times ``alpha 1`` equal the stage times the source lists separately, ``sum b = 1``;
* order 4 with the exact Jacobian *and* with wrong ones (a W-method of order 4), observed with
  a textbook step written in the test; order 4 on the cable with the compiled step;
* the stability function ``R(z) = 1 + z b^T (I - z (alpha + Gamma))^-1 1``: ``R(z) - exp(z) =
  O(z^5)``, ``|R| <= 1`` on the negative real axis, ``R(z) -> 0`` as ``z -> -inf``. It is not
  A-stable: ``|R(iy)|`` reaches 1.0064 on the imaginary axis (A(89.5 deg)-stable), so lightly
  damped fast modes can grow slowly at large steps. At n = 640 this shows: at 20 ms its error
  on the free fall is 1.2 m where ROS34PW2's is 0.11 m (README, "Speed against error"). It is the
  scheme for moderate n.

Six force evaluations, one O(n) factorisation and six O(n) solves per step (1.5 times a ROS34
step). There is no embedded solution (no error estimate): fixed step only.

Integrate layer: imports numpy and :mod:`cable_sim.integrate.implicit.ros34`.
"""

from __future__ import annotations

import numpy as np

from cable_sim.integrate.implicit.ros34 import Ros34PW2, RosTableau

#: Diagonal gamma.
GAMMA = 0.25
#: Transformed stage coefficients ``a`` (strictly lower triangular): stage i is evaluated at
#: ``y + h sum_j a_ij s_j``.
A_T = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.5812383407115008, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.9039624413714670, 1.8615191555345010, 0.0, 0.0, 0.0, 0.0],
    [2.0765797196750000, 0.1884255381414796, 1.8701589674910320, 0.0, 0.0, 0.0],
    [4.4355506384843120, 5.4571817986101890, 4.6163507880689300, 3.1181119524023610, 0.0, 0.0],
    [10.791701698483260, -10.05691522584131, 14.995644854284190, 5.2743399543909430,
     1.4297308712611900, 0.0],
])
#: Transformed coupling coefficients ``C = diag(1/gamma) - Gamma^-1`` (strictly lower).
C_T = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-2.661294105131369, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-3.128450202373838, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-6.920335474535658, -1.202675288266817, -9.733561811413620, 0.0, 0.0, 0.0],
    [-28.09530629102695, 20.371262954793770, -41.04375275302869, -19.66373175620895, 0.0, 0.0],
    [9.7998186780974000, 11.935792886603180, 3.6738749290132010, 14.807828541095500,
     0.8318583998690680, 0.0],
])
#: Transformed weights ``m = b Gamma^-1`` of the order-4 solution.
M_T = np.array([6.4562170746532350, -4.853141317768053, 9.7653183340692600, 2.0810841772787230,
                0.6603936866352417, 0.6])
#: The stage times the source lists (fractions of h); the tests compare ``alpha 1`` with them.
C_TIMES_LISTED = np.array([0.0, 0.1453095851778752, 0.3817422770256738, 0.6367813704374599,
                           0.7560744496323561, 0.9271047239875670])


def tableau_from_transformed(name: str, gamma: float, a_t: np.ndarray, c_t: np.ndarray,
                             m_t: np.ndarray) -> RosTableau:
    """The :class:`RosTableau` of a W-method given by its transformed coefficients, without an
    embedded solution (``b_hat = b``, ``e_t = 0``).

    Parameters
    ----------
    name : str
    gamma : float
        Diagonal of ``Gamma``.
    a_t, c_t : ndarray (s, s)
        Strictly lower triangular transformed coefficients ``a = alpha Gamma^-1`` and
        ``C = diag(1/gamma) - Gamma^-1``.
    m_t : ndarray (s,)
        ``m = b Gamma^-1``.
    """
    s = a_t.shape[0]
    gamma_ij = np.linalg.inv(np.diag(np.full(s, 1.0 / gamma)) - c_t)
    alpha = a_t @ gamma_ij
    b = m_t @ gamma_ij
    return RosTableau(name, float(gamma), alpha, gamma_ij, b, b.copy(), alpha.sum(axis=1),
                      a_t, c_t, m_t, np.zeros(s))


#: W6S4OS in both forms.
TABLEAU: RosTableau = tableau_from_transformed("W6S4OS", GAMMA, A_T, C_T, M_T)


class W6S4OS(Ros34PW2):
    """The six-stage Rosenbrock W-method W6S4OS with the local O(n) operator, fixed step.

    Order 4 for any approximation of the Jacobian, hence order 4 with the local ``D``, ``K`` of
    :mod:`cable_sim.integrate.implicit`; ``R(-inf) = 0``, A(89.5 deg)-stable (not A-stable, see
    :mod:`cable_sim.integrate.implicit.w6s4os`); six force evaluations, one O(n) factorisation
    and six O(n) solves per step, on the compiled step of
    :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2` with its own tableau. No embedded
    estimate, so no adaptive variant.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    geometric_stiffness, predict_drag, max_drift, taut_slack, max_condition, compiled
        See :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2`.
    """

    name = "w6s4os"
    order = 4
    tableau = TABLEAU


__all__ = ["A_T", "C_T", "C_TIMES_LISTED", "GAMMA", "M_T", "TABLEAU", "W6S4OS",
           "tableau_from_transformed"]
