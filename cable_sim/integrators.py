"""Time integrators behind one interface.

:class:`Integrator` is the base class. Its contract:

- A subclass implements :meth:`Integrator._step` (one step of size ``h`` from ``(t, y)``,
  returning the new state) and sets the class attributes ``name``, ``order`` (classical order
  of accuracy) and ``adaptive``.
- The base class validates the initial state (finite, right size), projects onto the anchor
  constraint after each step when the system is anchored, checks every new state for NaN/Inf
  and for constraint drift, and keeps the counters ``nsteps`` (accepted steps) and ``nfev``
  (right-hand-side evaluations, read from the system).
- A failed check raises :class:`IntegrationError` carrying the time and the reason; nothing
  non-finite is ever returned.
- Divergence is detected from physics, not from overflow: every step is also checked against
  an energy bound derived from the scene (:func:`available_energy`: the state's mechanical
  energy above the lowest potential energy the scene admits, plus an upper bound on the work
  the inputs can do, :func:`input_power_bound`). A state whose kinetic energy (its platform and
  link-rotation part, a lower bound of the total) exceeds :data:`ENERGY_MARGIN` times that bound
  is a numerical instability and is never accepted; so is a step that raises the mechanical
  energy by more than the inputs can supply plus :data:`ENERGY_RATE` of the budget per second,
  and a step that ends :data:`cable_sim.fast.OSC_STEPS` steps in a row of velocity increments
  growing by :data:`cable_sim.fast.OSC_GROWTH` (a mode with |R(h lambda)| > 1; increments below
  ``OSC_ACCEL g h / l_min`` are ignored). The bound is set from the first state an
  integrator is given and re-based whenever a caller passes a state other than the last one
  returned (a new run); :meth:`Integrator.reset_energy_budget` sets it explicitly.
- For an anchored line (exact constraint or the paper's emulation) the check also stops with a
  clear reason when the line is pulled (nearly) taut: slack ``1 - |fairlead - anchor| / L``
  below ``taut_slack``, or the anchor's 2x2 Schur matrix ``J M^-1 J^T`` singular or with a
  condition number above ``max_condition`` (a straight rigid-link line is a kinematic
  singularity: snap load). A singular constraint solve inside a step is reported the same way.
- When the system's kernel is ``"fast"``, :class:`RK4` and :class:`SemiImplicitEuler` run their
  steps, the check and the projection compiled (numba), one call per :meth:`Integrator.step`
  or per :meth:`Integrator.advance`; the results equal the Python path up to roundoff.

Fixed-step schemes here: :class:`RK4` (order 4, explicit; stability limited by the stiffest
joint/drag mode), :class:`SemiImplicitEuler` (order 1, explicit; symplectic only for a constant
mass matrix, see its docstring).
:class:`ScipyIntegrator` wraps ``scipy.integrate.solve_ivp`` (DOP853, RK45, Radau, ...) as the
adaptive reference. Stiff implicit schemes live in :mod:`cable_sim.implicit`.
"""

from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from .system import CableSystem


class IntegrationError(RuntimeError):
    """The integration cannot go on (non-finite state, drifting constraint, failed tolerance).

    Attributes
    ----------
    t : float
        Simulation time [s] at which the failure was detected.
    reason : str
        Human-readable reason.
    """

    def __init__(self, t: float, reason: str) -> None:
        self.t = t
        self.reason = reason
        super().__init__(f"integration failed at t = {t:.6g} s: {reason}")


@dataclass
class Trajectory:
    """Sampled solution: ``t`` shape (k,), ``y`` shape (k, 2(n+1)).

    ``step_used`` is the step size [s] the fixed-step schemes actually took (equal to the
    requested step when the output interval is a multiple of it; see :meth:`Integrator.integrate`),
    None for the adaptive schemes.
    """

    t: np.ndarray
    y: np.ndarray
    step_used: float | None = None


#: Slack below which the anchored end's Schur-matrix conditioning is also checked each step.
CONDITION_CHECK_SLACK = 1e-2

#: Projection tolerance (relative to the line length), as :func:`cable_sim.system.project_constraint`.
_PROJECTION_TOL = 1e-12

#: Integrator classes whose compiled stepper has been compiled/loaded in this process.
_WARMED: set[type] = set()

# status codes of the compiled steppers (cable_sim.fast.STATUS_*)
_NONFINITE, _DRIFT, _TAUT, _SINGULAR, _ILL, _UNSTABLE, _ENERGY_JUMP, _OSCILLATION = range(1, 9)

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

log = logging.getLogger(__name__)


def _disarm(chk: np.ndarray) -> None:
    """Turn the physical checks of a compiled-stepper ``chk`` off (kinetic-energy bound,
    energy allowance, runaway floor: inf) keeping the detector's memory; :meth:`Integrator.arm_checks`
    sets them for each call."""
    chk[5] = np.inf
    chk[7] = np.inf
    if chk.shape[0] > 10:
        chk[10] = np.inf


def _osc_steps() -> int:
    from . import fast

    return fast.OSC_STEPS


def kinetic_lower_bound(model, y: np.ndarray) -> float:
    """``1/2 M zd^2 + sum_i 1/2 (m_i l_i^2 / 12) thd_i^2`` [J]: the platform's and the links'
    rotational kinetic energy, a lower bound of the kinetic energy (what the per-step check of
    :func:`cable_sim.fast.check_packed` compares with the bound)."""
    n1 = model.ndof
    w = np.asarray(y[n1 + 1:], dtype=float)
    return float(0.5 * model.platform_mass * y[n1] ** 2
                 + np.sum(model.mass * model.length ** 2 * w * w) / 24.0)


def available_energy(model, y: np.ndarray) -> float:
    """Energy [J] that can become kinetic without input work: ``E(y) - V_min``.

    ``V_min`` is a lower bound of the potential energy over all configurations: each link
    centre (load) at most its arc length s_i (L) below or above the fairlead, joint springs
    relaxed, and the heave spring plus the line's weight at their minimum
    ``-(g G)^2 / (2 k_m)`` (``G`` the total weight-minus-buoyancy mass; the platform's own
    position when heave is locked). Infinite when the potential is unbounded below (free
    platform with no heave stiffness under a net weight): the check is then off.
    """
    from . import fast

    n1 = model.ndof
    q, qd = np.asarray(y[:n1], dtype=float), np.asarray(y[n1:], dtype=float)
    t_kin, v_pot = fast.energy(model, q, qd)
    g = float(model.gravity)
    s = np.cumsum(model.length) - 0.5 * model.length
    G = g * (float(np.sum(model.weight_mass)) + float(model.load_weight_mass))
    spread = g * (float(np.sum(np.abs(model.weight_mass) * s))
                  + abs(float(model.load_weight_mass)) * float(np.sum(model.length)))
    km = float(model.heave_k)
    if model.heave_locked:
        v_heave = 0.5 * km * q[0] ** 2 + G * q[0]
    elif km > 0:
        v_heave = -G * G / (2.0 * km)
    elif G == 0.0:
        v_heave = 0.0
    else:
        return float("inf")
    return float(t_kin + v_pot - (v_heave - spread))


def energy_floor(model) -> float:
    """The scene's own energy scale [J], added to every energy budget so that a line at rest
    (available energy ~0) is not held to a round-off-deep bound: the line and load moving at
    1 m/s, each link lifted by its own length, each joint spring turned by 1 rad and the heave
    spring stretched by 1 m."""
    g = float(model.gravity)
    lmin = float(np.min(model.length))
    return float(0.5 * (float(np.sum(model.mass)) + float(model.load_mass)) * 1.0
                 + g * (float(np.sum(np.abs(model.weight_mass) * model.length))
                        + abs(float(model.load_weight_mass)) * lmin)
                 + 0.5 * float(np.sum(model.joint_k)) + 0.5 * float(model.heave_k))


def input_power_bound(model, heave_force: float, wave_elevation: float, energy: float) -> float:
    """Upper bound [W] of the power the inputs can feed into the line.

    The platform force ``u + k_m eta`` (wave term when coupled) against the heave damper:
    ``max_v (u v - c_m v^2) = u^2 / (4 c_m)``; without a damper ``|u| sqrt(2 E / M)`` (the
    platform speed bounded by the energy ``E``). A uniform current through Morison drag:
    ``max_w c |w|^2 (|U| - |w|) = (4/27) c |U|^3`` per link. Joint dampers and drag
    otherwise only dissipate.
    """
    p = 0.0
    if not model.heave_locked:
        u = abs(float(heave_force))
        if model.wave_coupling:
            u += abs(float(model.heave_k * wave_elevation))
        if u > 0:
            if model.heave_c > 0:
                p += u * u / (4.0 * float(model.heave_c))
            elif model.platform_mass > 0:
                p += u * np.sqrt(2.0 * max(energy, 0.0) / float(model.platform_mass))
            else:
                return float("inf")
    if model.drag == 2 and model.current:
        c = np.maximum(model.morison_cn, model.morison_ct)
        p += 4.0 / 27.0 * float(np.sum(c)) * abs(float(model.current)) ** 3
    return float(p)


class Integrator(ABC):
    """Base class of all integrators (see the module docstring for the contract).

    Parameters
    ----------
    system : CableSystem
        What to integrate.
    step : float
        Step size h [s] (fixed-step schemes) or the maximum output interval (adaptive).
    max_drift : float
        Anchor constraint drift [m] above which the step fails loudly.
    taut_slack : float
        Anchored line: stop when the slack ``1 - |fairlead - anchor| / L`` drops below this.
    max_condition : float
        Anchored line: stop when the condition number of ``J M^-1 J^T`` exceeds this (checked
        while the slack is below :data:`CONDITION_CHECK_SLACK`).
    compiled : bool
        Use the compiled fast path when the scheme has one and the kernel is ``"fast"``
        (default). False forces the Python path (same results up to roundoff; for testing).
    """

    name: str = "base"
    order: int = 0
    adaptive: bool = False

    def __init__(
        self,
        system: CableSystem,
        step: float = 1e-3,
        max_drift: float = 1e-2,
        taut_slack: float = 1e-4,
        max_condition: float = 1e8,
        compiled: bool = True,
    ) -> None:
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"parameter 'step' = {step!r} is invalid; allowed: finite number > 0")
        for name, value in (("max_drift", max_drift), ("taut_slack", taut_slack),
                            ("max_condition", max_condition)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"parameter '{name}' = {value!r} is invalid; allowed: finite number > 0")
        self.system = system
        self.h = float(step)
        self.max_drift = max_drift
        self.taut_slack = taut_slack
        self.max_condition = max_condition
        self.use_compiled = bool(compiled)
        self.nsteps = 0
        self._budget: float | None = None  # available energy [J] incl. input work so far
        #: Step size [s] of the last :meth:`advance` (may be shorter than h; see there).
        self.step_used: float = self.h
        self._last_y: np.ndarray | None = None  # last state returned (continuity of a run)
        if self.compiled:
            self._warm()

    @property
    def nfev(self) -> int:
        """Right-hand-side evaluations performed by the system."""
        return self.system.nfev

    def _validate(self, y: np.ndarray) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        if y.shape != (2 * self.system.model.ndof,):
            raise ValueError(
                f"state has shape {y.shape}; expected ({2 * self.system.model.ndof},) = 2(n+1)"
            )
        if not np.all(np.isfinite(y)):
            raise ValueError("initial state is not finite")
        return y

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
        return np.array([self.max_drift, self.taut_slack, _PROJECTION_TOL, self.max_condition,
                         CONDITION_CHECK_SLACK, self.kinetic_energy_bound, np.nan, np.inf])

    def _osc_floor(self, h: float) -> float:
        """Smallest velocity increment [rad/s] the runaway detector looks at: ``OSC_ACCEL g h /
        l_min`` (g at least 1 m/s^2)."""
        scale = getattr(self, "_osc_scale", None)
        if scale is None or scale[0] is not self.system.model:
            from . import fast

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
        from . import fast

        n1 = self.system.model.ndof
        t_kin, v_pot = fast.energy(self.system.model, y[:n1], y[n1:])
        return float(t_kin + v_pot)

    def _raise_status(self, status: int, t: float, value: float, y_last: np.ndarray | None = None) -> None:
        """Raise the :class:`IntegrationError` for a status code; ``y_last`` (the last good
        state) adds the snap-load context when an anchored line was nearly taut."""
        if status == _NONFINITE:
            reason = ("numerical instability: the state became non-finite (blow-up); reduce the "
                      "step or use an implicit integrator")
        elif status == _UNSTABLE:
            reason = (f"numerical instability: kinetic energy {value:.3g} J (platform + link "
                      f"rotation alone) exceeds the physical bound {self.kinetic_energy_bound:.3g} J "
                      "(the scene's available mechanical energy plus the work its inputs can do, "
                      f"x{ENERGY_MARGIN:g}); the step h = {self.h:g} s is beyond this scheme's "
                      "stability limit: reduce the step or use an implicit scheme")
        elif status == _ENERGY_JUMP:
            reason = (f"numerical instability: the mechanical energy rose by {value:.3g} J in one "
                      f"step, more than the inputs can supply plus the integration-error allowance "
                      f"({getattr(self, '_jump_allowed', float('nan')):.3g} J); the step h = "
                      f"{self.h:g} s is beyond this scheme's stability limit: reduce the step or "
                      "use an implicit scheme")
        elif status == _OSCILLATION:
            reason = (f"numerical instability: a mode grew by x{value:.3g} per step "
                      f"for {_osc_steps()} steps in a row (|R(h lambda)| > 1: the step h = {self.h:g} s "
                      "is beyond this scheme's stability limit); reduce the step or use an "
                      "implicit scheme")
        elif status == _SINGULAR and self.system.model.end == 0:
            reason = ("singular dynamics within a step on a free-end line; "
                      "the state is most likely diverging (numerical instability): reduce the "
                      "step or use an implicit integrator")
        elif status == _DRIFT:
            reason = f"anchor constraint drift {value:.3g} m > {self.max_drift} m"
            if value > float(np.sum(self.system.model.length)):
                reason += " (the state is blowing up; reduce the step or use an implicit integrator)"
        elif status == _TAUT:
            reason = (f"line pulled taut: slack 1 - |fairlead - anchor|/L = {value:.3g} < "
                      f"{self.taut_slack:g}; a straight rigid-link line between fairlead and anchor "
                      "is a kinematic singularity (snap load) this inextensible model cannot resolve")
        elif status == _SINGULAR:
            reason = ("anchor constraint matrix J M^-1 J^T is singular to working precision: the "
                      "line is straight between fairlead and anchor (kinematic singularity, snap "
                      "load) or over-constrained")
        elif status == _ILL:
            reason = (f"anchor constraint matrix J M^-1 J^T is ill-conditioned (condition number "
                      f"{value:.3g} > {self.max_condition:g}): the line is nearly straight between "
                      "fairlead and anchor (kinematic singularity, snap load)")
        else:
            reason = f"unknown failure (status {status})"
        if y_last is not None and status in (_UNSTABLE, _ENERGY_JUMP, _OSCILLATION):
            slack = self._slack(y_last)
            if slack < CONDITION_CHECK_SLACK:  # an anchored line at its snap: say so first
                reason = (f"line pulled (nearly) taut: slack {slack:.3g} < {CONDITION_CHECK_SLACK:g}; "
                          "a straight rigid-link line is a kinematic singularity (snap load) this "
                          f"inextensible model cannot resolve, and the step diverged there ({reason})")
        elif y_last is not None and status not in (_TAUT, _ILL):
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
            from . import fast

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
            self._raise_status(_UNSTABLE, t, tlb, y_last)
        return y

    def _check_dense(self, t: float, y: np.ndarray, y_last: np.ndarray | None) -> np.ndarray:
        model = self.system.model
        if not np.all(np.isfinite(y)):
            self._raise_status(_NONFINITE, t, float("nan"), y_last)
        if model.constrained:
            y = self.system.project(y)
            if not np.all(np.isfinite(y)):
                self._raise_status(_NONFINITE, t, float("nan"), y_last)
            drift = self.system.constraint_drift(y)
            if drift > self.max_drift:
                self._raise_status(_DRIFT, t, drift, y_last)
        if model.end != 0:
            slack = self._slack(y)
            if slack < self.taut_slack:
                self._raise_status(_TAUT, t, slack)
            if slack < CONDITION_CHECK_SLACK:
                from .implicit import schur_condition

                cond = schur_condition(model, y[: model.ndof])
                if cond > self.max_condition:
                    self._raise_status(_ILL, t, cond)
        return y

    @abstractmethod
    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """One step of size h from (t, y); return the new state (subclass implements)."""

    def step(self, t: float, y: np.ndarray, h: float | None = None) -> np.ndarray:
        """Advance one step of size ``h`` (default: the configured step) and check the result."""
        h = self.h if h is None else h
        if self.compiled:
            return self._run_fast(t, y, h, 1)
        self._budget_for(y, h, *self._input_bounds(t, t + h))
        allowed = self._energy_jump_allowed(h)
        e_old = self._energy(y) if np.isfinite(allowed) else 0.0
        try:
            y_new = self._step(t, y, h)
        except np.linalg.LinAlgError:
            self._raise_status(_SINGULAR, t + h, float("nan"), y)
        y_new = self._check(t + h, y_new, y)
        if np.isfinite(allowed):
            jump = self._energy(y_new) - e_old
            if jump > allowed:
                self._raise_status(_ENERGY_JUMP, t + h, jump, y)
        from . import fast

        info = np.zeros(4)
        mem = self._osc_memory()
        mem[10] = self._osc_floor(h)
        if fast.oscillation_packed(y_new, mem, info) != 0:
            self._raise_status(_OSCILLATION, t + h, float(info[2]), y)
        self.nsteps += 1
        return self._accepted(y_new)

    # ---- compiled fast path (system kernel "fast") ------------------------------------
    #: Where a compiled step samples the inputs, as fractions of h (empty: no compiled path).
    _fast_offsets: tuple[float, ...] = ()
    #: Force evaluations per compiled step (None: the kernel counts them in ``info[0]``).
    _fast_fevals: int | None = None

    def _fast_kernel(self, arr: np.ndarray, par: np.ndarray, h: float, u: np.ndarray,
                     eta: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray) -> int:
        """Run ``u.shape[0]`` compiled, checked steps in place on y; return a status code."""
        raise NotImplementedError

    @property
    def compiled(self) -> bool:
        """True when steps run compiled (a compiled scheme on the ``fast`` kernel)."""
        return self.use_compiled and bool(self._fast_offsets) and self.system.kernel == "fast"

    def _fast_model(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Packed model arrays and check parameters, cached per model and settings."""
        model = self.system.model
        key = (model, self.max_drift, self.taut_slack, self.max_condition)
        pk = getattr(self, "_fast_pk", None)
        if pk is None or pk[0][0] is not model or pk[0][1:] != key[1:]:
            from . import fast

            arr, par = fast.pack_arrays(model)
            chk = np.concatenate([self._chk(), np.zeros(3 + 2 * model.ndof)])
            _disarm(chk)
            pk = (key, arr, par, chk)
            self._fast_pk = pk
        return pk[1], pk[2], pk[3]

    def _warm(self) -> None:
        """Compile (or load from numba's disk cache) this scheme's stepper once per process, at
        construction, so that the first real step is not a compile (the node builds its
        integrator before real time starts)."""
        cls = type(self)
        if cls in _WARMED:
            return
        from . import fast
        from .model import CableModel
        from .params import CableParams

        arr, par = fast.pack_arrays(CableModel.from_params(CableParams(n_links=2)))
        k = len(self._fast_offsets)
        self._fast_kernel(arr, par, 1e-3, np.zeros((1, k)), np.zeros((1, k)), np.zeros(6),
                          self._chk(), np.zeros(4))
        _WARMED.add(cls)

    def _run_fast(self, t0: float, y: np.ndarray, h: float, nsteps: int) -> np.ndarray:
        """``nsteps`` compiled steps of size h from (t0, y); raise on a failed check.

        The inputs are sampled in Python (``system.input_at`` may be any callable) at
        ``t_k + offset * h`` with ``t_k = t0 + k h``, exactly the times the Python path uses.
        """
        arr, par, chk = self._fast_model()
        f = self.system.input_at
        offs = [o * h for o in self._fast_offsets]  # 0.5 * h == h / 2 exactly
        if nsteps == 1:
            ins = [f(t0 + o) for o in offs]
            u = np.array([[i.heave_force for i in ins]])
            eta = np.array([[i.wave_elevation for i in ins]])
        else:
            tk = t0 + np.arange(nsteps, dtype=float) * h
            ins = [f(float(t) + o) for t in tk for o in offs]
            u = np.array([i.heave_force for i in ins]).reshape(nsteps, len(offs))
            eta = np.array([i.wave_elevation for i in ins]).reshape(nsteps, len(offs))
        yc = np.array(y, dtype=float, copy=True)
        if yc.shape != (2 * self.system.model.ndof,):  # the compiled code does not bounds-check
            raise ValueError(
                f"state has shape {yc.shape}; expected ({2 * self.system.model.ndof},) = 2(n+1)"
            )
        self.arm_checks(yc, h, nsteps, u, eta, chk)
        info = np.zeros(4)
        try:
            status = self._fast_kernel(arr, par, float(h), u, eta, yc, chk, info)
        finally:
            _disarm(chk)
        done = nsteps if status == 0 else int(info[1])
        self.nsteps += done
        self.system.nfev += int(info[0]) if self._fast_fevals is None else self._fast_fevals * done
        if status != 0:
            chk[6] = np.nan  # a retry may start from another state
            self._raise_status(status, t0 + (done + 1) * h, float(info[2]), yc)
        return self._accepted(yc)

    def _steps_for(self, duration: float) -> tuple[int, float]:
        """Number of equal steps of at most h covering ``duration`` and their size; the size
        is kept in :attr:`step_used` and a warning is logged (once per size) when it differs
        from the requested step h by more than 1e-9 relative."""
        n = max(1, int(np.ceil(duration / self.h - 1e-9)))
        h = duration / n
        self.step_used = h
        if abs(h - self.h) > 1e-9 * self.h:
            warned = self.__dict__.setdefault("_warned_steps", set())
            key = round(h / self.h, 9)
            if key not in warned:
                warned.add(key)
                log.warning(
                    "%s: the requested step h = %g s does not divide the interval %g s; "
                    "stepping with h = %.6g s instead (%d equal steps per interval)",
                    self.name, self.h, duration, h, n)
        return n, h

    def arm_checks(self, y: np.ndarray, h: float, nsteps: int, u: np.ndarray, eta: np.ndarray,
                   chk: np.ndarray) -> None:
        """Set the physical checks of ``chk`` (from :meth:`_fast_model`) for one compiled call
        of ``nsteps`` steps of h from ``y`` with the sampled inputs ``u``, ``eta``: the
        kinetic-energy bound, the per-step energy allowance and the runaway detector's floor.
        Whoever calls :meth:`_fast_kernel` directly must call this first (else those three
        checks are off) and reset ``chk`` afterwards with :func:`_disarm`."""
        cont = self._budget_for(y, nsteps * h, float(np.abs(u).max()), float(np.abs(eta).max()))
        chk[5] = self.kinetic_energy_bound
        chk[7] = self._energy_jump_allowed(h)
        if not (cont and np.isfinite(chk[6])):  # else: the energy the last call ended with
            chk[6] = self._energy(y) if np.isfinite(chk[7]) else np.nan
        chk[10] = self._osc_floor(h)

    def advance(self, t: float, y: np.ndarray, t_end: float) -> np.ndarray:
        """Advance from t to t_end in equal steps of at most h (one compiled call when
        :attr:`compiled`).

        When ``t_end - t`` is not a multiple of h, the step is shortened to the largest size
        that divides it: the size taken is kept in :attr:`step_used` and a warning is logged.
        """
        y = self._validate(y)
        n, h = self._steps_for(t_end - t)
        if self.compiled:
            return self._run_fast(t, y, h, n)
        for k in range(n):
            y = self.step(t + k * h, y, h)
        return y

    def integrate(self, y0: np.ndarray, t0: float, t_end: float, dt_out: float) -> Trajectory:
        """Integrate and sample every ``dt_out`` seconds (including t0 and t_end).

        The requested step h is used exactly when ``dt_out`` is a multiple of it. Otherwise the
        step is shortened to ``dt_out / ceil(dt_out / h)`` (e.g. h = 3 ms with dt_out = 0.04 s
        runs at 2.857 ms): a warning is logged and the step actually taken is returned in
        :attr:`Trajectory.step_used`. Likewise, when ``t_end - t0`` is not a multiple of
        ``dt_out`` the output interval is adjusted (logged; the samples are in ``t``).
        """
        y = self._validate(y0)
        if not (np.isfinite(dt_out) and dt_out > 0):
            raise ValueError(f"parameter 'dt_out' = {dt_out!r} is invalid; allowed: finite number > 0")
        k = max(1, int(round((t_end - t0) / dt_out)))
        ts = np.linspace(t0, t_end, k + 1)
        if abs((t_end - t0) / k - dt_out) > 1e-9 * dt_out:
            log.warning("%s: t_end - t0 = %g s is not a multiple of dt_out = %g s; sampling "
                        "every %.6g s instead", self.name, t_end - t0, dt_out, (t_end - t0) / k)
        self.reset_energy_budget(y)
        ys = np.empty((k + 1, y.size))
        ys[0] = y
        for i in range(k):
            y = self.advance(ts[i], y, ts[i + 1])
            ys[i + 1] = y
        return Trajectory(ts, ys, step_used=self.step_used)


class RK4(Integrator):
    """Classical fourth-order Runge-Kutta, fixed step. Order 4; explicit, so the step is bounded
    by the stiffest mode (joint springs, paper drag at large n)."""

    name = "rk4"
    order = 4

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        f = self.system.rhs
        k1 = f(t, y)
        k2 = f(t + h / 2, y + h / 2 * k1)
        k3 = f(t + h / 2, y + h / 2 * k2)
        k4 = f(t + h, y + h * k3)
        return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    _fast_offsets = (0.0, 0.5, 1.0)
    _fast_fevals = 4

    def _fast_kernel(self, arr, par, h, u, eta, y, chk, info) -> int:
        from . import fast

        return fast.rk4_run(arr, par, h, u, eta, y, chk, info)


class SemiImplicitEuler(Integrator):
    """Semi-implicit (symplectic) Euler in (q, qd): qd' = qd + h qdd(q, qd); q' = q + h qd'.

    Order 1, explicit (stable for ``h omega < 2`` on undamped modes; damping and drag are
    explicit too). It is symplectic only where the mass matrix is constant: this chain's
    ``M(q)`` is not, and the step acts on ``qd`` rather than on the canonical momentum
    ``M(q) qd``, so without damping the energy drifts by O(h) per unit time (measured in
    ``test/test_hard_cases.py``: ~6 J/s at h = 2 ms on a 20-link line exchanging ~1.5e5 J).
    """

    name = "symplectic_euler"
    order = 1

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        n1 = self.system.model.ndof
        qdd, _ = self.system.accelerations(t, y)
        self.system.nfev += 1
        out = y.copy()
        out[n1:] += h * qdd
        out[:n1] += h * out[n1:]
        return out

    _fast_offsets = (0.0,)
    _fast_fevals = 1

    def _fast_kernel(self, arr, par, h, u, eta, y, chk, info) -> int:
        from . import fast

        return fast.symplectic_euler_run(arr, par, h, u[:, 0], eta[:, 0], y, chk, info)


class ScipyIntegrator(Integrator):
    """Adaptive reference via ``scipy.integrate.solve_ivp``.

    Parameters
    ----------
    system : CableSystem
    method : str
        ``"DOP853"`` (order 8, explicit, default), ``"RK45"``, ``"Radau"`` (order 5, implicit), ...
    rtol, atol : float
        Tolerances passed to solve_ivp.
    step : float
        Used only by :meth:`step` calls (one solve over [t, t+h]).
    """

    name = "scipy"
    adaptive = True

    def __init__(
        self,
        system: CableSystem,
        method: str = "DOP853",
        rtol: float = 1e-10,
        atol: float = 1e-10,
        step: float = 1e-2,
        max_drift: float = 1e-2,
        **kwargs,
    ) -> None:
        super().__init__(system, step=step, max_drift=max_drift, **kwargs)
        self.method = method
        self.name = f"scipy_{method.lower()}"
        self.order = {"DOP853": 8, "RK45": 5, "RK23": 3, "Radau": 5, "BDF": 5, "LSODA": 5}.get(method, 0)
        self.rtol, self.atol = rtol, atol

    def _solve(self, y0: np.ndarray, t0: float, t_end: float, t_eval: np.ndarray | None):
        try:
            sol = solve_ivp(
                self.system.rhs, (t0, t_end), y0, method=self.method, rtol=self.rtol,
                atol=self.atol, t_eval=t_eval,
            )
        except np.linalg.LinAlgError:
            self._raise_status(_SINGULAR, t0, float("nan"))
        if sol.status != 0:
            raise IntegrationError(float(sol.t[-1]), f"{self.method} failed: {sol.message}")
        self.nsteps += int(sol.t.size) if t_eval is None else 0
        return sol

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        return self._solve(y, t, t + h, None).y[:, -1]

    def advance(self, t: float, y: np.ndarray, t_end: float) -> np.ndarray:
        """One adaptive solve from t to t_end (checked)."""
        y = self._validate(y)
        self._budget_for(y, t_end - t, *self._input_bounds(t, t_end))
        return self._accepted(self._check(t_end, self._step(t, y, t_end - t), y))

    def integrate(self, y0: np.ndarray, t0: float, t_end: float, dt_out: float) -> Trajectory:
        """One adaptive solve, sampled every ``dt_out`` by the dense output."""
        y0 = self._validate(y0)
        k = max(1, int(round((t_end - t0) / dt_out)))
        ts = np.linspace(t0, t_end, k + 1)
        sol = self._solve(y0, t0, t_end, ts)
        ys = sol.y.T.copy()
        for i in range(ys.shape[0]):
            if not np.all(np.isfinite(ys[i])):
                raise IntegrationError(float(ts[i]), "state became non-finite")
        return Trajectory(ts, ys)


#: Registry of integrator names -> classes (the node and the benchmark pick from here).
INTEGRATORS: dict[str, type[Integrator]] = {
    "rk4": RK4,
    "symplectic_euler": SemiImplicitEuler,
    "dop853": ScipyIntegrator,
}


def make_integrator(name: str, system: CableSystem, step: float, **kwargs) -> Integrator:
    """Build an integrator by name (``rk4``, ``symplectic_euler``, ``dop853``, ``radau``, and
    the implicit schemes of :mod:`cable_sim.implicit` when available)."""
    if name in ("dop853", "radau", "rk45"):
        method = {"dop853": "DOP853", "radau": "Radau", "rk45": "RK45"}[name]
        return ScipyIntegrator(system, method=method, step=step, **kwargs)
    registry = dict(INTEGRATORS)
    try:
        from . import implicit

        registry.update(implicit.INTEGRATORS)
    except ImportError:
        pass
    if name not in registry:
        allowed = sorted(set(registry) | {"dop853", "radau", "rk45"})
        raise ValueError(f"parameter 'integrator' = {name!r} is invalid; allowed: one of {allowed}")
    return registry[name](system, step=step, **kwargs)
