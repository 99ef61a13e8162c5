"""Explicit fixed-step schemes: classical RK4 (order 4) and semi-implicit Euler (order 1).

With the ``fast`` kernel each runs whole compiled, checked steps
(:mod:`cable_sim.integrate.compiled_steppers`).
"""

from __future__ import annotations

import numpy as np

from cable_sim.integrate.base import Integrator
from cable_sim.integrate.compiled_steppers import rk4_run, symplectic_euler_run


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
        return rk4_run(arr, par, h, u, eta, y, chk, info)


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
        return symplectic_euler_run(arr, par, h, u[:, 0], eta[:, 0], y, chk, info)
