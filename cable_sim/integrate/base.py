"""The integrator contract: one base class all time integrators derive from.

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
  and a step that ends :data:`cable_sim.core.kernel.OSC_STEPS` steps in a row of velocity increments
  growing by :data:`cable_sim.core.kernel.OSC_GROWTH` (a mode with |R(h lambda)| > 1; increments below
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
  or per :meth:`Integrator.advance`; the results equal the Python path up to roundoff. The
  inputs of those steps are sampled compiled too when the system carries an input program
  (:meth:`CableSystem.input_program`, set by :class:`cable_sim.scene.simulation.Simulation`):
  then a fixed-step run calls no Python per step. Any other input callable is sampled in Python.

Fixed-step schemes here: :class:`RK4` (order 4, explicit; stability limited by the stiffest
joint/drag mode), :class:`SemiImplicitEuler` (order 1, explicit; symplectic only for a constant
mass matrix, see its docstring).
:class:`ScipyIntegrator` wraps ``scipy.integrate.solve_ivp`` (DOP853, RK45, Radau, ...) as the
adaptive reference. Schemes: :mod:`.explicit`, :mod:`.reference`, :mod:`.implicit`; by name: :mod:`.registry`.
"""

from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from cable_sim.core import kernel as fast
from cable_sim.core.inputs import Jonswap, Sine
from cable_sim.core.kernel.signals import pack_program, sample_program
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.system import CableSystem
from cable_sim.integrate.checks import StepChecks, disarm
from cable_sim.integrate.errors import ENERGY_JUMP, OSCILLATION, SINGULAR

#: Integrator classes whose compiled stepper has been compiled/loaded in this process.
_WARMED: set[type] = set()
#: The sampling offsets of the compiled steppers as arrays (for ``sample_program``).
_OFFSETS: dict[tuple[float, ...], np.ndarray] = {}

log = logging.getLogger(__name__)


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


class Integrator(StepChecks, ABC):
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
            self._raise_status(SINGULAR, t + h, float("nan"), y)
        y_new = self._check(t + h, y_new, y)
        if np.isfinite(allowed):
            jump = self._energy(y_new) - e_old
            if jump > allowed:
                self._raise_status(ENERGY_JUMP, t + h, jump, y)
        info = np.zeros(4)
        mem = self._osc_memory()
        mem[10] = self._osc_floor(h)
        if fast.oscillation_packed(y_new, mem, info) != 0:
            self._raise_status(OSCILLATION, t + h, float(info[2]), y)
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
            arr, par = fast.pack_arrays(model)
            chk = np.concatenate([self._chk(), np.zeros(3 + 2 * model.ndof)])
            disarm(chk)
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
        arr, par = fast.pack_arrays(CableModel.from_params(CableParams(n_links=2)))
        k = len(self._fast_offsets)
        self._fast_kernel(arr, par, 1e-3, np.zeros((1, k)), np.zeros((1, k)), np.zeros(6),
                          self._chk(), np.zeros(4))
        prog = pack_program(Sine(1.0, 1.0).packed(), Jonswap(1.0, 1.0, n_components=2).packed())
        sample_program(prog, 0.0, 1e-3, np.zeros(k), np.zeros((1, k)), np.zeros((1, k)))
        _WARMED.add(cls)

    def _sample_inputs(self, t0: float, h: float, nsteps: int
                       ) -> tuple[np.ndarray, np.ndarray, float, float]:
        """The inputs of ``nsteps`` compiled steps of h from t0, at ``t_k + offset * h`` with
        ``t_k = t0 + k h`` (exactly the times the Python path uses): arrays ``u``, ``eta`` of
        shape (nsteps, offsets) and their largest magnitudes.

        With the system's input program (:meth:`CableSystem.input_program`) they are evaluated
        compiled (:func:`cable_sim.core.kernel.signals.sample_program`, the same arithmetic as
        the Python signals); otherwise ``system.input_at`` (any callable) is sampled in Python.
        """
        k = len(self._fast_offsets)
        program = getattr(self.system, "input_program", None)
        prog = None if program is None else program()
        if prog is not None:
            offs = _OFFSETS.get(self._fast_offsets)
            if offs is None:
                offs = _OFFSETS.setdefault(self._fast_offsets, np.array(self._fast_offsets, dtype=float))
            u = np.empty((nsteps, k))
            eta = np.empty((nsteps, k))
            u_max, eta_max = sample_program(prog, float(t0), float(h), offs, u, eta)
            return u, eta, u_max, eta_max
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
        return u, eta, float(np.abs(u).max()), float(np.abs(eta).max())

    def _run_fast(self, t0: float, y: np.ndarray, h: float, nsteps: int) -> np.ndarray:
        """``nsteps`` compiled steps of size h from (t0, y); raise on a failed check.

        The inputs are sampled by :meth:`_sample_inputs` (compiled when the system has an input
        program, else in Python) at exactly the times the Python path uses.
        """
        arr, par, chk = self._fast_model()
        u, eta, u_max, eta_max = self._sample_inputs(t0, h, nsteps)
        yc = np.array(y, dtype=float, copy=True)
        if yc.shape != (2 * self.system.model.ndof,):  # the compiled code does not bounds-check
            raise ValueError(
                f"state has shape {yc.shape}; expected ({2 * self.system.model.ndof},) = 2(n+1)"
            )
        self.arm_checks(yc, h, nsteps, u, eta, chk, (u_max, eta_max))
        info = np.zeros(4)
        try:
            status = self._fast_kernel(arr, par, float(h), u, eta, yc, chk, info)
        finally:
            disarm(chk)
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
                   chk: np.ndarray, bounds: tuple[float, float] | None = None) -> None:
        """Set the physical checks of ``chk`` (from :meth:`_fast_model`) for one compiled call
        of ``nsteps`` steps of h from ``y`` with the sampled inputs ``u``, ``eta``: the
        kinetic-energy bound, the per-step energy allowance and the runaway detector's floor.
        Whoever calls :meth:`_fast_kernel` directly must call this first (else those three
        checks are off) and reset ``chk`` afterwards with :func:`_disarm`. ``bounds``: the
        largest |u| and |eta| of the samples when the caller has them already (as
        :meth:`_sample_inputs` returns them)."""
        if bounds is None:
            bounds = (float(np.abs(u).max()), float(np.abs(eta).max()))
        cont = self._budget_for(y, nsteps * h, *bounds)
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
