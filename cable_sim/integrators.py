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

Fixed-step schemes here: :class:`RK4` (order 4, explicit; stability limited by the stiffest
joint/drag mode), :class:`SemiImplicitEuler` (order 1, symplectic for the conservative part).
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
    """

    name: str = "base"
    order: int = 0
    adaptive: bool = False

    def __init__(self, system: CableSystem, step: float = 1e-3, max_drift: float = 1e-2) -> None:
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"parameter 'step' = {step!r} is invalid; allowed: finite number > 0")
        self.system = system
        self.h = float(step)
        self.max_drift = max_drift
        self.nsteps = 0

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

    def _check(self, t: float, y: np.ndarray) -> np.ndarray:
        if not np.all(np.isfinite(y)):
            raise IntegrationError(t, "state became non-finite (blow-up); reduce the step or "
                                      "use an implicit integrator")
        if self.system.model.constrained:
            y = self.system.project(y)
            drift = self.system.constraint_drift(y)
            if drift > self.max_drift:
                raise IntegrationError(t, f"anchor constraint drift {drift:.3g} m > {self.max_drift} m")
        return y

    @abstractmethod
    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """One step of size h from (t, y); return the new state (subclass implements)."""

    def step(self, t: float, y: np.ndarray, h: float | None = None) -> np.ndarray:
        """Advance one step of size ``h`` (default: the configured step) and check the result."""
        h = self.h if h is None else h
        y_new = self._check(t + h, self._step(t, y, h))
        self.nsteps += 1
        return y_new

    def advance(self, t: float, y: np.ndarray, t_end: float) -> np.ndarray:
        """Advance from t to t_end with steps of at most h (the last one shortened)."""
        y = self._validate(y)
        n = max(1, int(np.ceil((t_end - t) / self.h - 1e-9)))
        h = (t_end - t) / n
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


class SemiImplicitEuler(Integrator):
    """Symplectic (semi-implicit) Euler: qd' = qd + h qdd(q, qd); q' = q + h qd'. Order 1;
    symplectic for the conservative part, so no secular energy growth without damping."""

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
    ) -> None:
        super().__init__(system, step=step, max_drift=max_drift)
        self.method = method
        self.name = f"scipy_{method.lower()}"
        self.order = {"DOP853": 8, "RK45": 5, "RK23": 3, "Radau": 5, "BDF": 5, "LSODA": 5}.get(method, 0)
        self.rtol, self.atol = rtol, atol

    def _solve(self, y0: np.ndarray, t0: float, t_end: float, t_eval: np.ndarray | None):
        sol = solve_ivp(
            self.system.rhs, (t0, t_end), y0, method=self.method, rtol=self.rtol, atol=self.atol,
            t_eval=t_eval,
        )
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
