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
    """Sampled solution: ``t`` shape (k,), ``y`` shape (k, 2(n+1))."""

    t: np.ndarray
    y: np.ndarray


#: Slack below which the anchored end's Schur-matrix conditioning is also checked each step.
CONDITION_CHECK_SLACK = 1e-2

#: Projection tolerance (relative to the line length), as :func:`cable_sim.system.project_constraint`.
_PROJECTION_TOL = 1e-12

#: Integrator classes whose compiled stepper has been compiled/loaded in this process.
_WARMED: set[type] = set()

# status codes of the compiled steppers (cable_sim.fast.STATUS_*)
_NONFINITE, _DRIFT, _TAUT, _SINGULAR, _ILL = 1, 2, 3, 4, 5


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

    # ---- checks ------------------------------------------------------------------------
    def _chk(self) -> np.ndarray:
        """Check parameters for the compiled steppers (see ``fast.check_packed``)."""
        return np.array([self.max_drift, self.taut_slack, _PROJECTION_TOL, self.max_condition,
                         CONDITION_CHECK_SLACK])

    def _raise_status(self, status: int, t: float, value: float, y_last: np.ndarray | None = None) -> None:
        """Raise the :class:`IntegrationError` for a status code; ``y_last`` (the last good
        state) adds the snap-load context when an anchored line was nearly taut."""
        if status == _NONFINITE:
            reason = "state became non-finite (blow-up); reduce the step or use an implicit integrator"
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
        if y_last is not None and status not in (_TAUT, _ILL):
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
        try:
            y_new = self._step(t, y, h)
        except np.linalg.LinAlgError:
            self._raise_status(_SINGULAR, t + h, float("nan"), y)
        y_new = self._check(t + h, y_new, y)
        self.nsteps += 1
        return y_new

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
            pk = (key, arr, par, self._chk())
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
        info = np.zeros(4)
        status = self._fast_kernel(arr, par, float(h), u, eta, yc, chk, info)
        done = nsteps if status == 0 else int(info[1])
        self.nsteps += done
        self.system.nfev += int(info[0]) if self._fast_fevals is None else self._fast_fevals * done
        if status != 0:
            self._raise_status(status, t0 + (done + 1) * h, float(info[2]), yc)
        return yc

    def advance(self, t: float, y: np.ndarray, t_end: float) -> np.ndarray:
        """Advance from t to t_end in equal steps of at most h (one compiled call when
        :attr:`compiled`)."""
        y = self._validate(y)
        n = max(1, int(np.ceil((t_end - t) / self.h - 1e-9)))
        h = (t_end - t) / n
        if self.compiled:
            return self._run_fast(t, y, h, n)
        for k in range(n):
            y = self.step(t + k * h, y, h)
        return y

    def integrate(self, y0: np.ndarray, t0: float, t_end: float, dt_out: float) -> Trajectory:
        """Integrate and sample every ``dt_out`` seconds (including t0 and t_end)."""
        y = self._validate(y0)
        k = max(1, int(round((t_end - t0) / dt_out)))
        ts = np.linspace(t0, t_end, k + 1)
        ys = np.empty((k + 1, y.size))
        ys[0] = y
        for i in range(k):
            y = self.advance(ts[i], y, ts[i + 1])
            ys[i + 1] = y
        return Trajectory(ts, ys)


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
        return self._check(t_end, self._step(t, self._validate(y), t_end - t))

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
