"""Time integration: the :class:`Integrator` contract (:mod:`.base`, its acceptance checks in
:mod:`.checks`, failures in :mod:`.errors`), explicit schemes (:mod:`.explicit`; adaptive:
:mod:`.explicit_adaptive` on :mod:`.adaptive` and :mod:`.step_control`), linearly implicit
schemes on the O(n) operator (:mod:`.implicit`), the adaptive scipy reference
(:mod:`.reference`) and one registry by name (:mod:`.registry`).

May import :mod:`cable_sim.core`; never rclpy, matplotlib or mcap. Modules inside this package
import each other's modules directly, never this ``__init__``.
"""

from cable_sim.integrate.base import Integrator, Trajectory
from cable_sim.integrate.errors import IntegrationError
from cable_sim.integrate.explicit import RK4, SemiImplicitEuler
from cable_sim.integrate.explicit_adaptive import DormandPrince5
from cable_sim.integrate.reference import ScipyIntegrator
from cable_sim.integrate.registry import INTEGRATORS, make_integrator

__all__ = ["INTEGRATORS", "RK4", "DormandPrince5", "IntegrationError", "Integrator", "ScipyIntegrator",
           "SemiImplicitEuler", "Trajectory", "make_integrator"]
