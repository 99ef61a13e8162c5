"""ROS34PW2: a four-stage, order-3, L-stable Rosenbrock W-method on the O(n) operator, fixed
step and adaptive (embedded order-2 estimate, PI step controller).

Method: Rang & Angermann, "New Rosenbrock W-methods of order 3 for partial differential
algebraic equations of index 1", BIT Numer. Math. 45 (2005) 761-787, method ROS34PW2
(coefficients as tabulated there and in PETSc's ``TSROSWRA34PW2``, ``src/ts/impls/rosw/rosw.c``).
It is a *W-method*: order 3 for any approximation ``T`` of the Jacobian in
``W = I - h gamma T`` -- here the local damping/stiffness ``D``, ``K`` of
:mod:`cable_sim.integrate.implicit.operator` -- L-stable (``R(inf) = 0``) and stiffly accurate;
the embedded solution (weights ``b_hat``) is of order 2. It runs in the transformed variables
(:mod:`cable_sim.integrate.implicit.ros_tableau`) with one factorisation of
``M~ = M + hg D + hg^2 K`` (``hg = gamma h``), four O(n) solves and four force evaluations per
step (:mod:`cable_sim.integrate.implicit.ros_step`).

The drag part of ``D`` is linearised at the predicted velocity ``v + h a(q, v)``
(``predict_drag``, default): at rest the paper drag's Jacobian is zero, and linearised at ``v``
the first steps of a free fall treat the drag explicitly (measured at n = 80: unstable from
50 ms; with the prediction stable to 125 ms). Any ``W`` keeps the W-method's order.

The coefficients are one :class:`~cable_sim.integrate.implicit.ros_tableau.RosTableau` (class
attribute ``tableau``); the compiled step, runs and the dense reference step take them as
arguments, so another four-stage W-method (:mod:`cable_sim.integrate.implicit.ros34prw`) is a
subclass that swaps the tableau. The adaptive scheme (:class:`Ros34PW2Adaptive`) controls the
joint-mapped max norm of the embedded difference
(:func:`~cable_sim.integrate.step_control.err_norm`).

Modules: ``ros_tableau`` (:class:`RosTableau`, :func:`ros_tableau`, ROS34PW2's coefficients
:data:`TABLEAU`), ``ros_step`` (the compiled step and the fixed-step run), ``ros_adaptive``
(the compiled adaptive run, on :mod:`cable_sim.integrate.step_control`). This module
keeps the dense reference step, the integrator classes :class:`Ros34PW2`,
:class:`Ros34PW2Adaptive` and re-exports the names the other modules and the tests use.

Integrate layer: imports numpy, :mod:`cable_sim.core` (dynamics, kernel, system),
:mod:`cable_sim.integrate.base`, :mod:`cable_sim.integrate.adaptive`,
:mod:`cable_sim.integrate.step_control` and the sibling modules ``dense``, ``operator``,
``ros_tableau``, ``ros_step`` and ``ros_adaptive``.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core import kernel as fast
from cable_sim.core.system import CableSystem
from cable_sim.integrate.adaptive import AdaptiveStepping
from cable_sim.integrate.base import Integrator
from cable_sim.integrate.implicit.dense import _dense_solve, dense_operator
from cable_sim.integrate.implicit.operator import geometric_stiffness as _geometric_stiffness
from cable_sim.integrate.implicit.ros_adaptive import _K_EXP, _ros_adaptive_run
from cable_sim.integrate.implicit.ros_step import _ros_fixed_run, _ros_step, _workspace
from cable_sim.integrate.implicit.ros_tableau import (
    A_T,
    ALPHA,
    B_HAT,
    C_T,
    C_TIMES,
    E_T,
    GAMMA,
    GAMMA_IJ,
    M_T,
    TABLEAU,
    B,
    RosTableau,
    ros_tableau,
)
from cable_sim.integrate.step_control import err_norm

# --------------------------------------------------------------------------------------------
# Integrators
# --------------------------------------------------------------------------------------------


def _dense_ros_step(system: CableSystem, t: float, y: np.ndarray, h: float, geometric: bool,
                    predict: bool = True, tableau: RosTableau = TABLEAU
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One step of the Rosenbrock W-method ``tableau`` (default ROS34PW2) with the dense ``M``,
    ``D``, ``K`` (reference for the O(n) path): the new state and the embedded difference."""
    model = system.model
    n1 = model.ndof
    q, v = y[:n1], y[n1:]
    gamma, at, ct, ctimes = tableau.gamma, tableau.a_t, tableau.c_t, tableau.c_times
    hg = gamma * h
    ns = at.shape[0]
    sq = np.zeros((ns, n1))
    sv = np.zeros((ns, n1))
    Mt = None
    for i in range(ns):
        Yq = q + h * (at[i, :i] @ sq[:i])
        Yv = v + h * (at[i, :i] @ sv[:i])
        acc, lam = system.accelerations(t + ctimes[i] * h, np.concatenate([Yq, Yv]))
        system.nfev += 1
        if i == 0:
            kgeo = None
            if geometric:
                F = dynamics.joint_forces(model, Yq, Yv, acc, lam)
                kgeo = _geometric_stiffness(model, Yq, F)
            M, D, K = dense_operator(model, Yq, Yv + h * acc if predict else Yv, kgeo)
            Mt = M + hg * D + hg * hg * K
        rq = gamma * (Yv + ct[i, :i] @ sq[:i])
        rv = gamma * (acc + ct[i, :i] @ sv[:i])
        sv[i] = rv - _dense_solve(model, q, Mt, hg * (D @ rv) + hg * (K @ (rq + hg * rv)))
        sq[i] = rq + hg * sv[i]
    mt, et = tableau.m_t, tableau.e_t
    yn = np.concatenate([q + h * (mt @ sq), v + h * (mt @ sv)])
    return yn, np.concatenate([h * (et @ sq), h * (et @ sv)])


class Ros34PW2(Integrator):
    """ROS34PW2 (Rang & Angermann 2005) with the local O(n) operator, fixed step.

    Order 3 for any approximation of the Jacobian (a Rosenbrock W-method), hence order 3 with
    the local ``D``, ``K`` of :mod:`cable_sim.integrate.implicit`. Four stages: four force
    evaluations, one O(n) factorisation and four O(n) solves per step (twice the work of
    :class:`~cable_sim.integrate.implicit.schemes.Rosenbrock2`). Stability: L-stable for the
    part in ``W`` (``R(z) -> 0`` as ``z -> -inf``), stiffly accurate; embedded order-2
    solution (used by :class:`Ros34PW2Adaptive`). See :mod:`cable_sim.integrate.implicit.ros34`.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    geometric_stiffness : bool
        Include the tension stiffness in ``K`` (default True).
    predict_drag : bool
        Linearise the drag (``D``) at the predicted velocity ``v + h a`` instead of ``v``
        (default True; any ``W`` keeps the order, this one keeps the drag implicit from rest).
    max_drift, taut_slack, max_condition, compiled
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "ros34pw2"
    order = 3
    #: The scheme's coefficients (a subclass with another W-method, of any number of stages,
    #: swaps only these; its stage times for the input sampling follow from them).
    tableau: RosTableau = TABLEAU
    _fast_offsets = tuple(float(c) for c in TABLEAU.c_times)

    def __init_subclass__(cls, **kwargs) -> None:
        """Derive a subclass's input-sampling offsets from its tableau's stage times."""
        super().__init_subclass__(**kwargs)
        cls._fast_offsets = tuple(float(c) for c in cls.tableau.c_times)

    def __init__(self, system: CableSystem, step: float = 1e-2, geometric_stiffness: bool = True,
                 predict_drag: bool = True, **kwargs) -> None:
        self.geometric = bool(geometric_stiffness)
        self.predict = bool(predict_drag)
        super().__init__(system, step=step, **kwargs)

    def _fast_kernel(self, arr, par, h, u, eta, y, chk, info) -> int:
        tb = self.tableau
        return _ros_fixed_run(arr, par, self.geometric, self.predict, h, u, eta, y, chk, info, tb.a_t,
                              tb.c_t, tb.m_t, tb.e_t, tb.gamma)

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        return _dense_ros_step(self.system, t, y, h, self.geometric, self.predict, self.tableau)[0]


class Ros34PW2Adaptive(AdaptiveStepping, Ros34PW2):
    """ROS34PW2 with its embedded order-2 error estimate and a PI step-size controller.

    Order 3 (the propagated solution; the estimate is order 2), L-stable, see :class:`Ros34PW2`.
    The stepping (output grid, error norm, controller, rejection, input interpolation) is that
    of :class:`cable_sim.integrate.adaptive.AdaptiveStepping`.

    Parameters
    ----------
    system : CableSystem
    step : float
        Output interval of :meth:`Integrator.integrate`-style use and of :meth:`step` [s].
    rtol, atol, first_step, max_step, safety, fac_min, fac_max, input_spacing
        See :class:`cable_sim.integrate.adaptive.AdaptiveStepping`.
    geometric_stiffness, max_drift, taut_slack, max_condition, compiled
        See :class:`Ros34PW2`.
    """

    name = "ros34pw2_adaptive"
    order = 3
    k_exp = _K_EXP

    def _run_adaptive(self, arr, par, t0, t1, tin0, tdt, u, eta, y, chk, info, ctl) -> int:
        tb = self.tableau
        return _ros_adaptive_run(arr, par, self.geometric, self.predict, t0, t1, tin0, tdt, u, eta, y,
                                 chk, info, ctl, tb.a_t, tb.c_t, tb.c_times, tb.m_t, tb.e_t, tb.gamma)

    def _embedded_step(self, t: float, y: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        return _dense_ros_step(self.system, t, y, h, self.geometric, self.predict, self.tableau)


__all__ = ["ALPHA", "B", "B_HAT", "GAMMA", "GAMMA_IJ", "TABLEAU", "RosTableau", "Ros34PW2",
           "Ros34PW2Adaptive", "err_norm", "ros_tableau",
           # re-exported from ros_tableau, ros_step, ros_adaptive (importers of ros34 keep working)
           "A_T", "C_T", "C_TIMES", "E_T", "M_T", "fast", "_K_EXP", "_dense_ros_step",
           "_ros_adaptive_run", "_ros_fixed_run", "_ros_step", "_workspace"]
