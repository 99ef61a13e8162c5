"""The checks every step of every integrator passes before it is accepted.

:class:`StepChecks` is the part of the :class:`~cable_sim.integrate.base.Integrator` contract
that decides whether a new state may be accepted: finite, on the anchor constraint (projected),
not pulled taut (snap), and physically plausible — kinetic energy within the scene's energy
bound (:mod:`cable_sim.core.energy_bounds`), no energy rise in one step beyond what the inputs can
supply, no mode growing step after step. A failed check raises
:class:`~cable_sim.integrate.errors.IntegrationError` with a reason naming the real cause.

Integrate layer: imports the core only.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import kernel as fast
from cable_sim.core.energy_bounds import (
    available_energy,
    energy_floor,
    input_power_bound,
    kinetic_lower_bound,
)
from cable_sim.integrate.errors import (
    DRIFT,
    ENERGY_JUMP,
    ILL,
    NONFINITE,
    OSCILLATION,
    SINGULAR,
    TAUT,
    UNSTABLE,
    IntegrationError,
)

#: Slack below which the anchored end's Schur-matrix conditioning is also checked each step.
CONDITION_CHECK_SLACK = 1e-2

#: Projection tolerance (relative to the line length), as :func:`cable_sim.core.system.project_constraint`.
PROJECTION_TOL = 1e-12

#: A state is rejected when its kinetic energy exceeds this many times the available energy
#: (:func:`available_energy` plus the input work). A stable scheme's energy error is orders of
#: magnitude smaller; an instability grows by orders of magnitude per step.
ENERGY_MARGIN = 2.0

#: Integration-error allowance of the per-step energy check [1/s]: over one step of h the
#: mechanical energy may rise by at most ``h * (input power bound + ENERGY_RATE * E_avail)``.
#: A stable scheme's per-step energy error is far smaller (measured: < 3e-3 E_avail/s for
#: implicit Euler at 20 ms on an undamped line, < 1e-9 for RK4 at its working steps); an
#: instability's first visible step exceeds it by orders of magnitude.
ENERGY_RATE = 0.05


def disarm(chk: np.ndarray) -> None:
    """Turn the physical checks of a compiled-stepper ``chk`` off (kinetic-energy bound,
    energy allowance, runaway floor: inf) keeping the detector's memory; :meth:`Integrator.arm_checks`
    sets them for each call."""
    chk[5] = np.inf
    chk[7] = np.inf
    if chk.shape[0] > 10:
        chk[10] = np.inf


class StepChecks:
    """Energy budget and acceptance checks of an integrator (mixed into ``Integrator``;
    uses its ``system``, ``h``, ``max_drift``, ``taut_slack``, ``max_condition``)."""

    # ---- energy bound (numerical-instability check) ------------------------------------
    def reset_energy_budget(self, y: np.ndarray) -> None:
        """Start a new run at state ``y``: the kinetic-energy bound becomes
        :data:`ENERGY_MARGIN` x (:func:`available_energy` of ``y`` + :func:`energy_floor` +
        input work from now on)."""
        self._budget = available_energy(self.system.model, y) + energy_floor(self.system.model)
        self._last_y = np.array(y, dtype=float, copy=True)
        for mem in (getattr(self, "_osc", None), getattr(self, "_fast_pk", (None,) * 4)[3]):
            if mem is not None and mem.shape[0] > 9:
                mem[8:10] = 0.0  # the oscillation detector starts afresh
                mem[6] = np.nan  # the energy of the previous state: recomputed

    @property
    def kinetic_energy_bound(self) -> float:
        """The current bound [J] on the kinetic energy of an accepted state (inf: no run yet)."""
        return float("inf") if self._budget is None else ENERGY_MARGIN * self._budget

    def _budget_for(self, y: np.ndarray, duration: float, u_max: float, eta_max: float) -> bool:
        """Before steps over ``duration`` from ``y``: re-base the budget when ``y`` does not
        continue the last run, then add the inputs' work bound over the interval. Return True
        when ``y`` continues the last run. The power bound is kept in ``self._power``."""
        cont = not (self._budget is None or self._last_y is None or not np.array_equal(y, self._last_y))
        if not cont:
            self.reset_energy_budget(y)
        key = (u_max, eta_max)
        cached = getattr(self, "_power_cache", None)
        if cached is not None and cached[0] == key and (cached[2] or cached[3] == self._budget):
            p = cached[1]
        else:
            p = input_power_bound(self.system.model, u_max, eta_max, ENERGY_MARGIN * self._budget)
            # the bound depends on the energy only without a heave damper
            self._power_cache = (key, p, self.system.model.heave_c > 0, self._budget)
        self._power = p
        self._budget += duration * p
        return cont

    def _accepted(self, y: np.ndarray) -> np.ndarray:
        self._last_y = y.copy()
        return y

    def _input_bounds(self, t0: float, t1: float) -> tuple[float, float]:
        """Largest |heave force| and |wave elevation| sampled at t0, the midpoint and t1."""
        ins = [self.system.input_at(t) for t in (t0, 0.5 * (t0 + t1), t1)]
        return (max(abs(i.heave_force) for i in ins), max(abs(i.wave_elevation) for i in ins))

    # ---- checks ------------------------------------------------------------------------
    def _chk(self) -> np.ndarray:
        """Check parameters for the compiled steppers (see ``fast.check_packed``)."""
        return np.array([self.max_drift, self.taut_slack, PROJECTION_TOL, self.max_condition,
                         CONDITION_CHECK_SLACK, self.kinetic_energy_bound, np.nan, np.inf])

    def _osc_floor(self, h: float) -> float:
        """Smallest velocity increment [rad/s] the runaway detector looks at: ``OSC_ACCEL g h /
        l_min`` (g at least 1 m/s^2)."""
        scale = getattr(self, "_osc_scale", None)
        if scale is None or scale[0] is not self.system.model:
            model = self.system.model
            scale = (model, fast.OSC_ACCEL * max(float(model.gravity), 1.0) / float(np.min(model.length)))
            self._osc_scale = scale
        return scale[1] * h

    def _osc_memory(self) -> np.ndarray:
        """The oscillation detector's memory for the Python path (``fast.oscillation_packed``)."""
        mem = getattr(self, "_osc", None)
        if mem is None or mem.shape[0] != 11 + 2 * self.system.model.ndof:
            mem = np.zeros(11 + 2 * self.system.model.ndof)
            self._osc = mem
        return mem

    def _energy_jump_allowed(self, h: float) -> float:
        """Largest energy increase [J] accepted over one step of h (see :data:`ENERGY_RATE`),
        from the power bound of the last :meth:`_budget_for`."""
        if self._budget is None or not np.isfinite(self._budget):
            return float("inf")
        self._jump_allowed = h * (self._power + ENERGY_RATE * max(self._budget, 0.0))
        return self._jump_allowed

    def _energy(self, y: np.ndarray) -> float:
        n1 = self.system.model.ndof
        t_kin, v_pot = fast.energy(self.system.model, y[:n1], y[n1:])
        return float(t_kin + v_pot)

    def _raise_status(self, status: int, t: float, value: float, y_last: np.ndarray | None = None) -> None:
        """Raise the :class:`IntegrationError` for a status code; ``y_last`` (the last good
        state) adds the snap-load context when an anchored line was nearly taut."""
        if status == NONFINITE:
            reason = ("numerical instability: the state became non-finite (blow-up); reduce the "
                      "step or use an implicit integrator")
        elif status == UNSTABLE:
            reason = (f"numerical instability: kinetic energy {value:.3g} J (platform + link "
                      f"rotation alone) exceeds the physical bound {self.kinetic_energy_bound:.3g} J "
                      "(the scene's available mechanical energy plus the work its inputs can do, "
                      f"x{ENERGY_MARGIN:g}); the step h = {self.h:g} s is beyond this scheme's "
                      "stability limit: reduce the step or use an implicit scheme")
        elif status == ENERGY_JUMP:
            reason = (f"numerical instability: the mechanical energy rose by {value:.3g} J in one "
                      f"step, more than the inputs can supply plus the integration-error allowance "
                      f"({getattr(self, '_jump_allowed', float('nan')):.3g} J); the step h = "
                      f"{self.h:g} s is beyond this scheme's stability limit: reduce the step or "
                      "use an implicit scheme")
        elif status == OSCILLATION:
            reason = (f"numerical instability: a mode grew by x{value:.3g} per step "
                      f"for {fast.OSC_STEPS} steps in a row (|R(h lambda)| > 1: the step h = {self.h:g} s "
                      "is beyond this scheme's stability limit); reduce the step or use an "
                      "implicit scheme")
        elif status == SINGULAR and self.system.model.end == 0:
            reason = ("singular dynamics within a step on a free-end line; "
                      "the state is most likely diverging (numerical instability): reduce the "
                      "step or use an implicit integrator")
        elif status == DRIFT:
            reason = f"anchor constraint drift {value:.3g} m > {self.max_drift} m"
            if value > float(np.sum(self.system.model.length)):
                reason += " (the state is blowing up; reduce the step or use an implicit integrator)"
            else:  # the projection cannot pull a step this far back onto the constraint
                reason += (f": the step h = {self.h:g} s is too large to keep the anchor on its "
                           "constraint; reduce the step")
        elif status == TAUT:
            reason = (f"line pulled taut: slack 1 - |fairlead - anchor|/L = {value:.3g} < "
                      f"{self.taut_slack:g}; a straight rigid-link line between fairlead and anchor "
                      "is a kinematic singularity (snap load) this inextensible model cannot resolve")
        elif status == SINGULAR:
            reason = ("anchor constraint matrix J M^-1 J^T is singular to working precision: the "
                      "line is straight between fairlead and anchor (kinematic singularity, snap "
                      "load) or over-constrained")
        elif status == ILL:
            reason = (f"anchor constraint matrix J M^-1 J^T is ill-conditioned (condition number "
                      f"{value:.3g} > {self.max_condition:g}): the line is nearly straight between "
                      "fairlead and anchor (kinematic singularity, snap load)")
        else:
            reason = f"unknown failure (status {status})"
        if y_last is not None and status in (UNSTABLE, ENERGY_JUMP, OSCILLATION):
            slack = self._slack(y_last)
            if slack < CONDITION_CHECK_SLACK:  # an anchored line at its snap: say so first
                reason = (f"line pulled (nearly) taut: slack {slack:.3g} < {CONDITION_CHECK_SLACK:g}; "
                          "a straight rigid-link line is a kinematic singularity (snap load) this "
                          f"inextensible model cannot resolve, and the step diverged there ({reason})")
        elif y_last is not None and status not in (TAUT, ILL):
            slack = self._slack(y_last)
            if slack < CONDITION_CHECK_SLACK:
                reason += (f" (the line was nearly taut: slack {slack:.3g} < {CONDITION_CHECK_SLACK:g}; "
                           "a straight rigid-link line is a kinematic singularity: snap load)")
        raise IntegrationError(t, reason)

    def _slack(self, y: np.ndarray) -> float:
        """1 - |fairlead - anchor| / L (anchored ends), else inf."""
        m = self.system.model
        if m.end == 0:
            return float("inf")
        return 1.0 - float(np.hypot(m.anchor[0], y[0] - m.anchor[1])) / float(np.sum(m.length))

    def _check(self, t: float, y: np.ndarray, y_last: np.ndarray | None = None) -> np.ndarray:
        """Check (and, anchored, project) a new state at time t; ``y_last`` is the state the
        step started from (for the snap-load context of a failure)."""
        model = self.system.model
        if self.system.kernel == "fast":
            arr, par = fast.pack_arrays(model)
            y = np.array(y, dtype=float, copy=True)
            info = np.zeros(4)
            status = fast.check_packed(arr, par, y, self._chk(), info)
            if status != 0:
                self._raise_status(status, t, float(info[2]), y_last)
            return y
        y = self._check_dense(t, y, y_last)
        tlb = kinetic_lower_bound(model, y)
        if tlb > self.kinetic_energy_bound:
            self._raise_status(UNSTABLE, t, tlb, y_last)
        return y

    def _check_dense(self, t: float, y: np.ndarray, y_last: np.ndarray | None) -> np.ndarray:
        model = self.system.model
        if not np.all(np.isfinite(y)):
            self._raise_status(NONFINITE, t, float("nan"), y_last)
        if model.constrained:
            y = self.system.project(y)
            if not np.all(np.isfinite(y)):
                self._raise_status(NONFINITE, t, float("nan"), y_last)
            drift = self.system.constraint_drift(y)
            if drift > self.max_drift:
                self._raise_status(DRIFT, t, drift, y_last)
        if model.end != 0:
            slack = self._slack(y)
            if slack < self.taut_slack:
                self._raise_status(TAUT, t, slack)
            if slack < CONDITION_CHECK_SLACK:
                cond = fast.schur_condition(model, y[: model.ndof])
                if cond > self.max_condition:
                    self._raise_status(ILL, t, cond)
        return y
