"""What every tolerance-controlled scheme of ours shares: :class:`AdaptiveStepping`.

Its contract, for a scheme ``class S(AdaptiveStepping, <an Integrator>)``:

- :meth:`AdaptiveStepping.advance` steps from t to exactly ``t_end`` (the output grid stays
  fixed: the last step of an interval is shortened to end on it, the controller's proposal
  carries over to the next interval). The error of a step is the joint-mapped max norm of
  :func:`cable_sim.integrate.step_control.err_norm` against ``atol + rtol |.|``; the step size
  follows the PI controller of :mod:`cable_sim.integrate.step_control` (exponent
  :attr:`k_exp` = 1 / (embedded order + 1)); a step whose error exceeds 1 is rejected and
  retried smaller, below ``1e-10`` s the run fails loudly.
- Inputs are sampled every ``input_spacing`` s (at least four samples per interval) and
  interpolated cubically inside the step (:func:`~cable_sim.integrate.step_control.interp_input`).
- The scheme supplies :meth:`_run_adaptive` (the compiled run over one interval, same arguments
  as :func:`cable_sim.integrate.erk_run.erk_adaptive_run` after its model arrays) and
  :meth:`_embedded_step` (one step on the Python right-hand side: new state and error estimate,
  the reference path used when not :attr:`compiled`).
- Every accepted state passes the checks of :class:`cable_sim.integrate.base.Integrator`.

Integrate layer: imports numpy, :mod:`.base`, :mod:`.step_control` and the core.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core import kernel as fast
from cable_sim.core.kernel.signals import sample_program
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.system import CableSystem
from cable_sim.integrate.base import _WARMED
from cable_sim.integrate.checks import disarm
from cable_sim.integrate.errors import ENERGY_JUMP, OSCILLATION, IntegrationError
from cable_sim.integrate.step_control import (
    STATUS_STEP_UNDERFLOW,
    accepted_step,
    clip_step,
    err_norm,
    interp_input,
    rejected_step,
)

#: Default input-sampling spacing of the adaptive schemes [s] (cubic interpolation in between).
INPUT_SPACING = 0.02


class AdaptiveStepping:
    """Tolerance-controlled stepping over fixed output intervals (see the module docstring).

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
    **kwargs
        Passed on to the scheme's integrator class.
    """

    adaptive = True
    #: 1 / (order of the embedded solution + 1): the step-size controller's exponent.
    k_exp: float = 1.0 / 3.0

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

    # ---- what a scheme supplies ----------------------------------------------------------
    def _run_adaptive(self, arr: np.ndarray, par: np.ndarray, t0: float, t1: float, tin0: float,
                      tdt: float, u: np.ndarray, eta: np.ndarray, y: np.ndarray, chk: np.ndarray,
                      info: np.ndarray, ctl: np.ndarray) -> int:
        """The compiled adaptive run from t0 to t1 in place on y; returns a status code."""
        raise NotImplementedError

    def _embedded_step(self, t: float, y: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """One step of h on the Python right-hand side: (new state, error estimate)."""
        raise NotImplementedError

    # ---- shared ------------------------------------------------------------------------------
    def _warm(self) -> None:
        cls = type(self)
        if cls in _WARMED:
            return
        arr, par = fast.pack_arrays(CableModel.from_params(CableParams(n_links=2)))
        self._run_adaptive(arr, par, 0.0, 1e-3, 0.0, 1e-3, np.zeros(2), np.zeros(2), np.zeros(6),
                           self._chk(), np.zeros(5), self._ctl.copy())
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
        y, dt, u, eta = self._begin(t, y, t_end)
        if self.compiled:
            return self._advance_fast(t, y, t_end, dt, u, eta)
        return self._advance_python(t, y, t_end, dt, u, eta)

    def _begin(self, t: float, y: np.ndarray, t_end: float
               ) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
        """Validate, reset the controller when ``y`` starts a new run, sample the inputs:
        (state, sample spacing, heave-force and wave-elevation samples)."""
        y = self._validate(y)
        if not t_end > t:
            raise ValueError(f"parameter 't_end' = {t_end!r} is invalid; allowed: > t = {t!r}")
        if self._last_y is None or not np.array_equal(y, self._last_y):
            self._ctl[7] = self.first_step  # a new run: start afresh
            self._ctl[8] = 0.0
            self._ctl[11] = 0.0
        dt, u, eta = self._sample(t, t_end)
        return y, dt, u, eta

    def _arm_adaptive(self, t: float, y: np.ndarray, t_end: float, u: np.ndarray, eta: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Model arrays, armed checks, a copy of ``y`` and the counters for one compiled run:
        ``(arr, par, chk, y copy, info)``; the caller disarms ``chk`` after the run."""
        arr, par, chk = self._fast_model()
        yc = np.array(y, dtype=float, copy=True)
        span = t_end - t
        self.arm_checks(yc, span, 1, u, eta, chk)
        self._ctl[9] = chk[7] / span
        self._ctl[10] = (chk[10] / span) if chk.shape[0] > 10 else 0.0
        return arr, par, chk, yc, np.zeros(5)

    def _finish_adaptive(self, status: int, span: float, info: np.ndarray, chk: np.ndarray,
                         y: np.ndarray) -> np.ndarray:
        """Count the run's steps and force evaluations; raise on a failed run; accept ``y``."""
        self.nsteps += int(info[1])
        self.nrejected += int(info[4])
        self.system.nfev += int(info[0])
        if status != 0:
            chk[6] = np.nan
            self._fail(status, float(info[3]), float(info[2]), y)
        self.step_used = span / max(1, int(info[1]))
        return self._accepted(y)

    def _advance_fast(self, t, y, t_end, dt, u, eta) -> np.ndarray:
        arr, par, chk, yc, info = self._arm_adaptive(t, y, t_end, u, eta)
        try:
            status = self._run_adaptive(arr, par, float(t), float(t_end), float(t), float(dt), u, eta,
                                        yc, chk, info, self._ctl)
        finally:
            disarm(chk)
        return self._finish_adaptive(status, t_end - t, info, chk, yc)

    def _fail(self, status: int, t: float, value: float, y: np.ndarray) -> None:
        if status == STATUS_STEP_UNDERFLOW:
            raise IntegrationError(t, f"step size {value:.3g} s below the floor {self._ctl[6]:g} s: "
                                   f"the error estimate does not fall below atol = {self.atol:g}, "
                                   f"rtol = {self.rtol:g} (singular or diverging dynamics)")
        self._raise_status(status, t, value, y)

    def _advance_python(self, t, y, t_end, dt, u, eta) -> np.ndarray:
        """The same controller on :meth:`_embedded_step` (reference path)."""
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
                float(interp_input(s, t_in, dt, u)), float(interp_input(s, t_in, dt, eta)))
            while t < t_end:
                hs, last = clip_step(t, t_end, h)
                try:
                    yn, err = self._embedded_step(t, y, hs)
                    en = err_norm(arr, y, yn, err, atol, rtol)
                except np.linalg.LinAlgError:
                    en = np.inf
                if not np.isfinite(en) or en > 1.0:
                    self.nrejected += 1
                    h = rejected_step(ctl, float(en), float(hs), self.k_exp)
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
                h = accepted_step(ctl, float(en), float(hs), float(h), bool(last), self.k_exp)
        finally:
            self.system.input_at = saved
        ctl[7] = h
        return self._accepted(y)


__all__ = ["INPUT_SPACING", "AdaptiveStepping"]
