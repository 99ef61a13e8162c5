"""Adaptive explicit Runge-Kutta pairs with the joint-mapped error norm: :class:`EmbeddedRK`,
Dormand-Prince 5(4) (:class:`DormandPrince5`) and Tsitouras 5(4) (:class:`Tsitouras5`).

With the ``fast`` kernel every interval is one compiled call
(:func:`cable_sim.integrate.erk_run.erk_adaptive_run`); otherwise the same controller runs on the
Python right-hand side (:class:`cable_sim.integrate.adaptive.AdaptiveStepping`).

Integrate layer: imports numpy, :mod:`.adaptive`, :mod:`.base` and :mod:`.erk_run`.
"""

from __future__ import annotations

import numpy as np

from cable_sim.integrate.adaptive import AdaptiveStepping
from cable_sim.integrate.base import Integrator
from cable_sim.integrate.erk_run import DOPRI5, TSIT5, ErkTableau, erk_adaptive_run


def erk_step(f, t: float, y: np.ndarray, h: float, tab: ErkTableau) -> tuple[np.ndarray, np.ndarray]:
    """One step of the pair ``tab`` with the right-hand side ``f(t, y)``: (propagated solution,
    error estimate ``h sum e_i k_i``). Python reference of the compiled step (no FSAL reuse)."""
    ks = np.empty((tab.b.size, y.size))
    for i in range(tab.b.size):
        ks[i] = f(t + tab.c[i] * h, y + h * (tab.a[i, :i] @ ks[:i]))
    return y + h * (tab.b @ ks), h * (tab.e @ ks)


class EmbeddedRK(AdaptiveStepping, Integrator):
    """An embedded explicit Runge-Kutta pair with the joint-mapped error norm and the PI
    controller of :class:`cable_sim.integrate.adaptive.AdaptiveStepping`; a subclass names its
    pair (:attr:`tableau`), from which its order, the controller's exponent and its stage times
    follow.

    Explicit, so the step is bounded by the stiffest mode too: the controller finds that bound
    through the error estimate (rejections). With a first-same-as-last pair the compiled run
    evaluates ``s - 1`` forces per step on a free line; an anchored line's state is projected
    after each step, so there its first slope is evaluated again (``s`` per step).

    Parameters
    ----------
    system : CableSystem
    step : float
        Output interval [s].
    rtol, atol, first_step, max_step, safety, fac_min, fac_max, input_spacing
        See :class:`cable_sim.integrate.adaptive.AdaptiveStepping` (here ``fac_max`` defaults
        to 5, the common choice for explicit pairs).
    max_drift, taut_slack, max_condition, compiled
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "erk"
    #: The pair (a subclass swaps only this).
    tableau: ErkTableau = DOPRI5

    def __init_subclass__(cls, **kwargs) -> None:
        """Derive a subclass's order, controller exponent and stage times from its pair."""
        super().__init_subclass__(**kwargs)
        cls.order = cls.tableau.order
        cls.k_exp = 1.0 / (cls.tableau.est_order + 1)
        cls._fast_offsets = tuple(float(c) for c in cls.tableau.c)

    def __init__(self, system, step: float = 1e-2, fac_max: float = 5.0, **kwargs) -> None:
        super().__init__(system, step=step, fac_max=fac_max, **kwargs)

    def _run_adaptive(self, arr, par, t0, t1, tin0, tdt, u, eta, y, chk, info, ctl) -> int:
        tb = self.tableau
        return erk_adaptive_run(arr, par, t0, t1, tin0, tdt, u, eta, y, chk, info, ctl, tb.a, tb.b, tb.e,
                                tb.c, tb.fsal, self.k_exp)

    def _embedded_step(self, t: float, y: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        return erk_step(self.system.rhs, t, y, h, self.tableau)

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        return self._embedded_step(t, y, h)[0]


class DormandPrince5(EmbeddedRK):
    """Dormand-Prince 5(4) ("DOPRI5", :data:`cable_sim.integrate.erk_run.DOPRI5`), adaptive,
    explicit: order 5, embedded order 4, seven stages, first-same-as-last. See
    :class:`EmbeddedRK`."""

    name = "dopri5"
    tableau = DOPRI5


class Tsitouras5(EmbeddedRK):
    """Tsitouras 5(4) ("Tsit5", :data:`cable_sim.integrate.erk_run.TSIT5`), adaptive, explicit:
    order 5, embedded order 4, seven stages, first-same-as-last; smaller error coefficients than
    DOPRI5 (on the drag-off paper free fall at n = 80 it meets 1 cm with about 5 % fewer force
    evaluations, README). See :class:`EmbeddedRK`."""

    name = "tsit5"
    tableau = TSIT5


__all__ = ["DormandPrince5", "EmbeddedRK", "Tsitouras5", "erk_step"]
