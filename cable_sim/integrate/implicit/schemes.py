"""The linearly implicit schemes: :class:`LinearlyImplicitEuler` and :class:`Rosenbrock2`, with
their compiled fast path (:func:`cable_sim.integrate.implicit.run._implicit_run`) and dense
fallback (:mod:`cable_sim.integrate.implicit.dense`); :data:`INTEGRATORS` by name.

Integrate layer: imports numpy, :mod:`cable_sim.core` (dynamics, system),
:mod:`cable_sim.integrate.base` and the sibling modules ``dense``, ``operator``, ``run``,
``ros34`` (ROS34PW2), ``ros34prw`` (ROS34PRw), ``w6s4os`` (W6S4OS) and ``radau`` (Radau IIA),
registered here.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core.system import CableSystem
from cable_sim.integrate.base import Integrator
from cable_sim.integrate.implicit.dense import _dense_solve, dense_operator
from cable_sim.integrate.implicit.operator import geometric_stiffness
from cable_sim.integrate.implicit.radau import RadauIIA, RadauIIAAdaptive
from cable_sim.integrate.implicit.ros34 import Ros34PW2, Ros34PW2Adaptive
from cable_sim.integrate.implicit.ros34prw import Ros34PRw, Ros34PRwAdaptive
from cable_sim.integrate.implicit.run import _implicit_run
from cable_sim.integrate.implicit.w6s4os import W6S4OS


class _LinearlyImplicit(Integrator):
    """Shared machinery: compiled fast path, dense fallback, batched :meth:`advance`."""

    scheme = 0
    stages = 1

    def __init__(
        self,
        system: CableSystem,
        step: float = 1e-2,
        gamma: float = 1.0,
        geometric_stiffness: bool = True,
        **kwargs,
    ) -> None:
        if not (np.isfinite(gamma) and gamma > 0):
            raise ValueError(f"parameter 'gamma' = {gamma!r} is invalid; allowed: finite number > 0")
        self.gamma = float(gamma)
        self.geometric = bool(geometric_stiffness)
        super().__init__(system, step=step, **kwargs)

    # ---- fast path ---------------------------------------------------------------------
    def _fast_kernel(self, arr, par, h, u, eta, y, chk, info) -> int:
        return _implicit_run(arr, par, self.scheme, self.gamma, self.geometric, h, u, eta, y,
                             chk, info)

    # ---- dense fallback ----------------------------------------------------------------
    def _dense_step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        sys_ = self.system
        model = sys_.model
        n1 = model.ndof
        q, v = y[:n1], y[n1:]
        hg = self.gamma * h
        a1, lam = sys_.accelerations(t, y)
        sys_.nfev += 1
        kgeo = None
        if self.geometric:
            F = dynamics.joint_forces(model, q, v, a1, lam)
            kgeo = geometric_stiffness(model, q, F)
        M, D, K = dense_operator(model, q, v, kgeo)
        Mt = M + hg * D + hg * hg * K

        def solve(rd: np.ndarray, rk: np.ndarray) -> np.ndarray:
            return _dense_solve(model, q, Mt, hg * (D @ rd) + hg * (K @ rk))

        k1v = a1 - solve(a1, v + hg * a1)
        if self.stages == 1:
            vn = v + h * k1v
            return np.concatenate([q + h * vn, vn])
        k1q = v + hg * k1v
        y2 = np.concatenate([q + h * k1q, v + h * k1v])
        a2, _ = sys_.accelerations(t + h, y2)
        sys_.nfev += 1
        rq = y2[n1:] - 2.0 * k1q
        rv = a2 - 2.0 * k1v
        k2v = rv - solve(rv, rq + hg * rv)
        k2q = rq + hg * k2v
        return np.concatenate([q + 1.5 * h * k1q + 0.5 * h * k2q, v + 1.5 * h * k1v + 0.5 * h * k2v])

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        return self._dense_step(t, y, h)


class LinearlyImplicitEuler(_LinearlyImplicit):
    """Linearly implicit Euler with the local O(n) operator ``M + hD + h^2K``.

    Order 1. One force evaluation and one O(n) solve per step:
    ``(M + hD + h^2K) a* = f(q, v) - hK v``, ``v' = v + h a*``, ``q' = q + h v'``. For the terms
    in ``D`` and ``K`` (joint springs/dampers, heave spring/damper, paper or Morison drag,
    tension stiffness, the seabed's contact spring and damper over the part of each link in
    the bed now or at ``q + h v``) it is implicit Euler: L-stable, no step limit from them, but it damps
    fast physical modes by O(h). For the rest it is symplectic Euler (stable for
    ``h omega < 2``). MuJoCo's "implicitfast" is the same idea.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    geometric_stiffness : bool
        Include the tension stiffness in ``K`` (default True).
    max_drift, taut_slack, max_condition : float
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "implicit_euler"
    order = 1
    scheme = 0
    stages = 1
    _fast_offsets = (0.0,)

    def __init__(self, system: CableSystem, step: float = 1e-2, geometric_stiffness: bool = True,
                 **kwargs) -> None:
        super().__init__(system, step=step, gamma=1.0, geometric_stiffness=geometric_stiffness,
                         **kwargs)


class Rosenbrock2(_LinearlyImplicit):
    """Two-stage Rosenbrock W-method ROS2 with the local O(n) operator.

    Order 2 for any approximation ``W`` of the Jacobian (a W-method), hence order 2 with the
    local ``D``, ``K``. With ``hg = gamma h`` and ``S(r) = (M + hg D + hg^2 K)^-1 r``::

        k1v = a(t, q, v) - S(hg D a + hg K (v + hg a)),     k1q = v + hg k1v
        (q2, v2) = (q, v) + h (k1q, k1v)
        rq = v2 - 2 k1q,  rv = a(t + h, q2, v2) - 2 k1v
        k2v = rv - S(hg D rv + hg K (rq + hg rv)),          k2q = rq + hg k2v
        (q', v') = (q, v) + 1.5 h (k1q, k1v) + 0.5 h (k2q, k2v)

    Stability: L-stable for the part in ``W`` (stability function
    ``(1 + (1 - 2 gamma) z) / (1 - gamma z)^2``, A-stable for gamma >= 1/4); the velocity-product
    remainder is treated like Heun's method. Two force evaluations, one O(n) factorisation
    and two O(n) solves per step.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    gamma : float
        ``1 - 1/sqrt(2)`` (default, smaller error constant) or ``1 + 1/sqrt(2)`` (Verwer et al.).
    geometric_stiffness : bool
        Include the tension stiffness in ``K`` (default True).
    max_drift, taut_slack, max_condition : float
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "rosenbrock2"
    order = 2
    scheme = 1
    stages = 2
    _fast_offsets = (0.0, 1.0)

    def __init__(self, system: CableSystem, step: float = 1e-2, gamma: float = 1.0 - 1.0 / np.sqrt(2.0),
                 geometric_stiffness: bool = True, **kwargs) -> None:
        super().__init__(system, step=step, gamma=gamma, geometric_stiffness=geometric_stiffness,
                         **kwargs)


#: Implicit integrators by name (merged into :func:`cable_sim.integrate.registry.make_integrator`).
INTEGRATORS: dict[str, type[Integrator]] = {
    "implicit_euler": LinearlyImplicitEuler,
    "rosenbrock2": Rosenbrock2,
    "ros34pw2": Ros34PW2,
    "ros34pw2_adaptive": Ros34PW2Adaptive,
    "ros34prw": Ros34PRw,
    "ros34prw_adaptive": Ros34PRwAdaptive,
    "w6s4os": W6S4OS,
    "radau_iia": RadauIIA,
    "radau_iia_adaptive": RadauIIAAdaptive,
}
