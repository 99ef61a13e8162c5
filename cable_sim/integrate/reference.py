"""The adaptive reference: scipy's ``solve_ivp`` (DOP853, RK45, Radau) behind the contract."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from cable_sim.core.system import CableSystem
from cable_sim.integrate.base import Integrator, Trajectory
from cable_sim.integrate.errors import SINGULAR, IntegrationError


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
            self._raise_status(SINGULAR, t0, float("nan"))
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
