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
(:func:`~cable_sim.integrate.implicit.ros_adaptive.err_norm`).

Modules: ``ros_tableau`` (:class:`RosTableau`, :func:`ros_tableau`, ROS34PW2's coefficients
:data:`TABLEAU`), ``ros_step`` (the compiled step and the fixed-step run), ``ros_adaptive``
(error norm, PI controller, input interpolation and the compiled adaptive run). This module
keeps the dense reference step, the integrator classes :class:`Ros34PW2`,
:class:`Ros34PW2Adaptive` and re-exports the names the other modules and the tests use.

Integrate layer: imports numpy, :mod:`cable_sim.core` (dynamics, kernel, model, params, system),
:mod:`cable_sim.integrate.base`, :mod:`cable_sim.integrate.checks`,
:mod:`cable_sim.integrate.errors` and the sibling modules ``dense``, ``operator``,
``ros_tableau``, ``ros_step`` and ``ros_adaptive``.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core import kernel as fast
from cable_sim.core.kernel.signals import sample_program
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.system import CableSystem
from cable_sim.integrate.base import _WARMED, Integrator
from cable_sim.integrate.checks import disarm
from cable_sim.integrate.errors import ENERGY_JUMP, OSCILLATION, IntegrationError
from cable_sim.integrate.implicit.dense import _dense_solve, dense_operator
from cable_sim.integrate.implicit.operator import geometric_stiffness as _geometric_stiffness
from cable_sim.integrate.implicit.ros_adaptive import (
    _K_EXP,
    STATUS_STEP_UNDERFLOW,
    _accepted_step,
    _clip,
    _interp,
    _rejected_step,
    _ros_adaptive_run,
    err_norm,
)
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

#: Default input-sampling spacing of the adaptive scheme [s] (cubic interpolation in between).
INPUT_SPACING = 0.02


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


class Ros34PW2Adaptive(Ros34PW2):
    """ROS34PW2 with its embedded order-2 error estimate and a PI step-size controller.

    Order 3 (the propagated solution; the estimate is order 2), L-stable, see :class:`Ros34PW2`.
    :meth:`advance` steps adaptively from t to exactly ``t_end`` (the output grid stays fixed:
    the last step of an interval is shortened to end on it, the controller's proposal carries
    over to the next interval). Error per step: the joint-mapped max norm of
    :mod:`cable_sim.integrate.implicit.ros_adaptive` against ``atol + rtol |.|``; PI controller
    (Gustafsson) with safety factor, ``fac_min``/``fac_max`` bounds and rejection. Inputs are
    sampled every ``input_spacing`` s (at least four samples per interval) and interpolated
    cubically inside the compiled loop.

    Parameters
    ----------
    system : CableSystem
    step : float
        Output interval of :meth:`Integrator.integrate`-style use and of :meth:`step` [s].
    rtol, atol : float
        Relative tolerance (>= 0) and absolute tolerance [m, m/s] (> 0) of the joint positions
        and velocities per step.
    first_step : float
        First trial step [s] (default 1e-3).
    max_step : float
        Largest step [s] (default inf).
    safety, fac_min, fac_max : float
        Controller safety factor (0 < safety <= 1) and bounds of the step change per step
        (0 < fac_min < 1 < fac_max).
    input_spacing : float
        Input sampling interval [s] (> 0).
    geometric_stiffness, max_drift, taut_slack, max_condition, compiled
        See :class:`Ros34PW2`.
    """

    name = "ros34pw2_adaptive"
    order = 3
    adaptive = True

    def __init__(self, system: CableSystem, step: float = 1e-2, rtol: float = 0.0,
                 atol: float = 1e-3, first_step: float = 1e-3, max_step: float = np.inf,
                 safety: float = 0.9, fac_min: float = 0.2, fac_max: float = 2.0,
                 input_spacing: float = INPUT_SPACING, **kwargs) -> None:
        checks = (("rtol", rtol, np.isfinite(rtol) and rtol >= 0, "finite number >= 0"),
                  ("atol", atol, np.isfinite(atol) and atol > 0, "finite number > 0"),
                  ("first_step", first_step, np.isfinite(first_step) and first_step > 0,
                   "finite number > 0"),
                  ("max_step", max_step, max_step > 0, "number > 0 (inf allowed)"),
                  ("safety", safety, 0 < safety <= 1, "0 < safety <= 1"),
                  ("fac_min", fac_min, 0 < fac_min < 1, "0 < fac_min < 1"),
                  ("fac_max", fac_max, 1 < fac_max < np.inf, "1 < fac_max < inf"),
                  ("input_spacing", input_spacing, np.isfinite(input_spacing) and input_spacing > 0,
                   "finite number > 0"))
        for name, value, ok, allowed in checks:
            if not ok:
                raise ValueError(f"parameter '{name}' = {value!r} is invalid; allowed: {allowed}")
        self.rtol, self.atol = float(rtol), float(atol)
        self.input_spacing = float(input_spacing)
        self._ctl = np.array([atol, rtol, safety, fac_min, fac_max, max_step, 1e-10,
                              first_step, 0.0, 0.0, 0.0, 0.0], dtype=float)
        self.first_step = float(first_step)
        #: Rejected steps so far.
        self.nrejected = 0
        super().__init__(system, step=step, **kwargs)

    def _warm(self) -> None:
        cls = type(self)
        if cls in _WARMED:
            return
        arr, par = fast.pack_arrays(CableModel.from_params(CableParams(n_links=2)))
        ctl = self._ctl.copy()
        tb = self.tableau
        _ros_adaptive_run(arr, par, True, True, 0.0, 1e-3, 0.0, 1e-3, np.zeros(2), np.zeros(2),
                          np.zeros(6), self._chk(), np.zeros(5), ctl, tb.a_t, tb.c_t, tb.c_times,
                          tb.m_t, tb.e_t, tb.gamma)
        _WARMED.add(cls)

    def step(self, t: float, y: np.ndarray, h: float | None = None) -> np.ndarray:
        """Advance adaptively over one output interval ``h`` (default: the configured step)."""
        return self.advance(t, y, t + (self.h if h is None else h))

    def _sample(self, t0: float, t1: float) -> tuple[float, np.ndarray, np.ndarray]:
        k = max(3, int(np.ceil((t1 - t0) / self.input_spacing - 1e-9)))
        dt = (t1 - t0) / k
        prog = self.system.input_program()
        if prog is not None:  # the scene's built-in signals: one compiled call, same times
            u, eta = np.empty((k + 1, 1)), np.empty((k + 1, 1))
            sample_program(prog, float(t0), float(dt), np.zeros(1), u, eta)
            return dt, u.reshape(k + 1), eta.reshape(k + 1)
        ins = [self.system.input_at(t0 + i * dt) for i in range(k + 1)]
        return (dt, np.array([i.heave_force for i in ins]),
                np.array([i.wave_elevation for i in ins]))

    def advance(self, t: float, y: np.ndarray, t_end: float) -> np.ndarray:
        """Adaptive steps from t to exactly ``t_end`` (checked as every step of the contract)."""
        y = self._validate(y)
        if not t_end > t:
            raise ValueError(f"parameter 't_end' = {t_end!r} is invalid; allowed: > t = {t!r}")
        if self._last_y is None or not np.array_equal(y, self._last_y):
            self._ctl[7] = self.first_step  # a new run: start afresh
            self._ctl[8] = 0.0
            self._ctl[11] = 0.0
        dt, u, eta = self._sample(t, t_end)
        if self.compiled:
            return self._advance_fast(t, y, t_end, dt, u, eta)
        return self._advance_python(t, y, t_end, dt, u, eta)

    def _advance_fast(self, t, y, t_end, dt, u, eta) -> np.ndarray:
        arr, par, chk = self._fast_model()
        yc = np.array(y, dtype=float, copy=True)
        span = t_end - t
        self.arm_checks(yc, span, 1, u, eta, chk)
        self._ctl[9] = chk[7] / span
        self._ctl[10] = (chk[10] / span) if chk.shape[0] > 10 else 0.0
        info = np.zeros(5)
        tb = self.tableau
        try:
            status = _ros_adaptive_run(arr, par, self.geometric, self.predict, float(t), float(t_end),
                                       float(t), float(dt), u, eta, yc, chk, info, self._ctl, tb.a_t,
                                       tb.c_t, tb.c_times, tb.m_t, tb.e_t, tb.gamma)
        finally:
            disarm(chk)
        self.nsteps += int(info[1])
        self.nrejected += int(info[4])
        self.system.nfev += int(info[0])
        if status != 0:
            chk[6] = np.nan
            self._fail(status, float(info[3]), float(info[2]), yc)
        self.step_used = span / max(1, int(info[1]))
        return self._accepted(yc)

    def _fail(self, status: int, t: float, value: float, y: np.ndarray) -> None:
        if status == STATUS_STEP_UNDERFLOW:
            raise IntegrationError(t, f"step size {value:.3g} s below the floor {self._ctl[6]:g} s: "
                                   f"the error estimate does not fall below atol = {self.atol:g}, "
                                   f"rtol = {self.rtol:g} (singular or diverging dynamics)")
        self._raise_status(status, t, value, y)

    def _advance_python(self, t, y, t_end, dt, u, eta) -> np.ndarray:
        """The same controller on the dense step (reference path)."""
        ctl = self._ctl
        atol, rtol, hmax, hmin = ctl[0], ctl[1], ctl[5], ctl[6]
        span = t_end - t
        self._budget_for(y, span, float(np.abs(u).max()), float(np.abs(eta).max()))
        rate = self._energy_jump_allowed(span) / span
        arr, _par = fast.pack_arrays(self.system.model)
        saved = self.system.input_at
        h = min(ctl[7], hmax)
        try:
            t_in = t  # the sampling grid's origin (t itself advances below)
            self.system.input_at = lambda s: dynamics.Inputs(
                float(_interp(s, t_in, dt, u)), float(_interp(s, t_in, dt, eta)))
            while t < t_end:
                hs, last = _clip(t, t_end, h)
                try:
                    yn, err = _dense_ros_step(self.system, t, y, hs, self.geometric, self.predict,
                                              self.tableau)
                    en = err_norm(arr, y, yn, err, atol, rtol)
                except np.linalg.LinAlgError:
                    en = np.inf
                if not np.isfinite(en) or en > 1.0:
                    self.nrejected += 1
                    h = _rejected_step(ctl, float(en), float(hs))
                    if h < hmin:
                        self._fail(STATUS_STEP_UNDERFLOW, t, h, y)
                    continue
                yn = self._check(t + hs, yn, y)
                jump = self._energy(yn) - self._energy(y)
                if jump > rate * hs:
                    self._raise_status(ENERGY_JUMP, t + hs, jump, y)
                mem = self._osc_memory()
                mem[10] = self._osc_floor(hs)
                info = np.zeros(4)
                if fast.oscillation_packed(yn, mem, info) != 0:
                    self._raise_status(OSCILLATION, t + hs, float(info[2]), y)
                y = yn
                self.nsteps += 1
                t = t_end if last else t + hs
                h = _accepted_step(ctl, float(en), float(hs), float(h), bool(last))
        finally:
            self.system.input_at = saved
        ctl[7] = h
        return self._accepted(y)


__all__ = ["ALPHA", "B", "B_HAT", "GAMMA", "GAMMA_IJ", "TABLEAU", "RosTableau", "Ros34PW2",
           "Ros34PW2Adaptive", "err_norm", "ros_tableau",
           # re-exported from ros_tableau, ros_step, ros_adaptive (importers of ros34 keep working)
           "A_T", "C_T", "C_TIMES", "E_T", "M_T", "INPUT_SPACING", "STATUS_STEP_UNDERFLOW", "fast",
           "_K_EXP", "_accepted_step", "_clip", "_dense_ros_step", "_interp", "_rejected_step",
           "_ros_adaptive_run", "_ros_fixed_run", "_ros_step", "_workspace"]
