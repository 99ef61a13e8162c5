"""Every integrator by name: the one registry the scenes, the node and the benchmark use."""

from __future__ import annotations

from cable_sim.core.system import CableSystem
from cable_sim.integrate.base import Integrator
from cable_sim.integrate.explicit import RK4, SemiImplicitEuler
from cable_sim.integrate.explicit_adaptive import DormandPrince5, Tsitouras5
from cable_sim.integrate.implicit import INTEGRATORS as IMPLICIT_INTEGRATORS
from cable_sim.integrate.reference import ScipyIntegrator

#: Registry of integrator names -> classes (the node and the benchmark pick from here).
INTEGRATORS: dict[str, type[Integrator]] = {
    "rk4": RK4,
    "symplectic_euler": SemiImplicitEuler,
    "dopri5": DormandPrince5,
    "tsit5": Tsitouras5,
    "dop853": ScipyIntegrator,
    **IMPLICIT_INTEGRATORS,
}


def make_integrator(name: str, system: CableSystem, step: float, **kwargs) -> Integrator:
    """Build an integrator by name (``rk4``, ``symplectic_euler``, ``dopri5``, ``tsit5``, ``dop853``,
    ``radau``, and the implicit schemes of :mod:`cable_sim.integrate.implicit`)."""
    if name in ("dop853", "radau", "rk45"):
        method = {"dop853": "DOP853", "radau": "Radau", "rk45": "RK45"}[name]
        return ScipyIntegrator(system, method=method, step=step, **kwargs)
    registry = INTEGRATORS
    if name not in registry:
        allowed = sorted(set(registry) | {"dop853", "radau", "rk45"})
        raise ValueError(f"parameter 'integrator' = {name!r} is invalid; allowed: one of {allowed}")
    return registry[name](system, step=step, **kwargs)
