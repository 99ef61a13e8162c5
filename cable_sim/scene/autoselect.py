"""Model only what a scene needs: pick the cheapest (n, integrator, step) that meets a tolerance.

Given tolerances on what the scene cares about — the tip (cable end) position [m] and the
fairlead tension [relative to its peak] — :func:`choose` measures, on a short horizon of the
scene itself:

1. the *discretisation* error of each candidate n against a finer-n reference (both solved by
   the adaptive reference integrator, so only the resolution differs), and keeps the smallest n
   whose error is within half of each tolerance;
2. at that n, the *time-integration* error and the wall-clock cost of every fixed-step
   integrator over a ladder of steps against the adaptive reference at the same n, and keeps the
   cheapest (integrator, step) within the other half.

Both halves are measured, not assumed, so the sum meets the tolerance on the horizon measured.
The result says what it chose and why (:attr:`Choice.reason`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from cable_sim.core import dynamics
from cable_sim.integrate import IntegrationError, ScipyIntegrator, make_integrator
from cable_sim.scene.scenes import Scene

DEFAULT_LINKS = (5, 10, 20, 40, 80)
DEFAULT_STEPS = (0.05, 0.02, 0.01, 0.005, 0.002, 0.001)
DEFAULT_INTEGRATORS = ("rk4", "symplectic_euler", "rosenbrock2")


#: Arc-length stations (fractions of L) where line positions are compared.
STATIONS = (0.25, 0.5, 0.75, 1.0)


def stations(model, q: np.ndarray) -> np.ndarray:
    """Positions (len(STATIONS), 2) [m] at fixed fractions of the arc length along the line.

    Resolution-independent (interpolated along the polyline), and meaningful for an anchored
    line too, whose end does not move.
    """
    p = dynamics.joint_positions(model, q)
    s = np.concatenate([[0.0], np.cumsum(model.length)])
    target = np.array(STATIONS) * s[-1]
    return np.stack([np.interp(target, s, p[:, 0]), np.interp(target, s, p[:, 1])], axis=1)


@dataclass
class Metrics:
    """Sampled quantities of interest: time [s], line positions at :data:`STATIONS`
    (k, len(STATIONS), 2) [m] (the last one is the tip) and fairlead tension [N]."""

    t: np.ndarray
    tip: np.ndarray
    tension: np.ndarray

    def error_to(self, ref: Metrics) -> tuple[float, float]:
        """(max position distance over stations and time [m], max tension error relative to
        the reference's peak)."""
        tip = float(np.max(np.linalg.norm(self.tip - ref.tip, axis=-1)))
        peak = max(float(np.max(np.abs(ref.tension))), 1e-12)
        return tip, float(np.max(np.abs(self.tension - ref.tension)) / peak)


@dataclass
class Choice:
    """Result of :func:`choose`.

    Attributes
    ----------
    n_links, integrator, step : int, str, float
        The chosen resolution and time integration.
    tip_error, tension_error : float
        Measured total error estimate (discretisation + time integration) [m], [relative].
    cost : float
        Measured wall time per simulated second [s/s] of the chosen configuration.
    reason : str
        One paragraph saying what was chosen and why.
    table : list of dict
        Every measurement made (for logs and reports).
    """

    n_links: int
    integrator: str
    step: float
    tip_error: float
    tension_error: float
    cost: float
    reason: str
    table: list[dict] = field(default_factory=list)


def sample(scene: Scene, integrator: str, step: float, horizon: float, dt_out: float,
           kernel: str, rtol: float = 1e-9) -> tuple[Metrics, float]:
    """Run ``scene`` and sample tip position and fairlead tension; return (metrics, wall time).

    ``integrator == "reference"`` uses the adaptive DOP853 solver at ``rtol``.
    """
    model = scene.model()
    system = scene.system(kernel=kernel, model=model)
    y = scene.initial_state(model)
    if integrator == "reference":
        integ = ScipyIntegrator(system, "DOP853", rtol=rtol, atol=rtol)
    else:
        integ = make_integrator(integrator, system, step)
    k = int(round(horizon / dt_out))
    ts = np.linspace(0.0, k * dt_out, k + 1)
    tips, tens = np.empty((k + 1, len(STATIONS), 2)), np.empty(k + 1)
    elapsed = 0.0
    n1 = model.ndof
    for i, t in enumerate(ts):
        if i:
            w = time.perf_counter()
            y = integ.advance(ts[i - 1], y, t)
            elapsed += time.perf_counter() - w
        q, qd = y[:n1], y[n1:]
        qdd, lam = system.forward(model, q, qd, system.input_at(t))
        F = dynamics.joint_forces(model, q, qd, qdd, lam)
        tips[i] = stations(model, q)
        tens[i] = np.hypot(*F[0])
    return Metrics(ts, tips, tens), elapsed


def choose(
    scene: Scene,
    tip_tolerance: float,
    tension_tolerance: float,
    horizon: float = 10.0,
    links: tuple[int, ...] = DEFAULT_LINKS,
    steps: tuple[float, ...] = DEFAULT_STEPS,
    integrators: tuple[str, ...] = DEFAULT_INTEGRATORS,
    kernel: str = "fast",
    dt_out: float = 0.1,
) -> Choice:
    """Cheapest (n, integrator, step) whose measured error meets both tolerances.

    Parameters
    ----------
    scene : Scene
    tip_tolerance : float
        Allowed max position error [m] over the horizon, at the tip and at the quarter points of
        the line (:data:`STATIONS`).
    tension_tolerance : float
        Allowed max fairlead-tension error, relative to the peak tension.
    horizon : float
        Simulated time [s] over which errors are measured.
    links, steps, integrators : tuple
        Candidates (links ascending; steps descending).
    kernel : str
        Dynamics kernel used for all runs.

    Raises
    ------
    ValueError
        If no candidate meets the tolerance (the message lists the best errors reached).
    """
    if tip_tolerance <= 0 or tension_tolerance <= 0:
        raise ValueError("tolerances must be > 0")
    links = tuple(sorted(links))
    table: list[dict] = []
    n_ref = 2 * links[-1]
    ref, _ = sample(scene.with_links(n_ref), "reference", 0.0, horizon, dt_out, kernel)
    errors = {}
    for n in links:
        met, _ = sample(scene.with_links(n), "reference", 0.0, horizon, dt_out, kernel)
        errors[n] = met.error_to(ref)
    # The reference (n_ref = 2 N) is not exact either. Convergence in n is (at least) first
    # order, so its own error is at most about the error of N against it: add that to every
    # candidate's measured error (conservative Richardson estimate).
    ref_err = errors[links[-1]]
    chosen_n, disc = None, (np.inf, np.inf)
    for n in links:
        e = (errors[n][0] + ref_err[0], errors[n][1] + ref_err[1]) if n != links[-1] else (
            2 * ref_err[0], 2 * ref_err[1])
        table.append({"stage": "resolution", "n_links": n, "tip_error": e[0], "tension_error": e[1]})
        if chosen_n is None and e[0] <= tip_tolerance / 2 and e[1] <= tension_tolerance / 2:
            chosen_n, disc = n, e
    if chosen_n is None:
        raise ValueError(
            f"no n in {links} meets half the tolerance (estimated against n = {n_ref}): at "
            f"n = {links[-1]} position error {table[-1]['tip_error']:.3g} m, tension error "
            f"{table[-1]['tension_error']:.3g}; add larger n or loosen the tolerance"
        )
    sc = scene.with_links(chosen_n)
    ref_n, _ = sample(sc, "reference", 0.0, horizon, dt_out, kernel)
    best = None
    for name in integrators:
        for h in sorted(steps, reverse=True):
            if dt_out / h != round(dt_out / h):
                continue
            try:
                met, wall = sample(sc, name, h, horizon, dt_out, kernel)
            except IntegrationError as exc:
                table.append({"stage": "time", "integrator": name, "step": h, "failed": str(exc)})
                continue
            e = met.error_to(ref_n)
            cost = wall / horizon
            table.append({"stage": "time", "integrator": name, "step": h, "tip_error": e[0],
                          "tension_error": e[1], "cost": cost})
            if e[0] <= tip_tolerance / 2 and e[1] <= tension_tolerance / 2:
                if best is None or cost < best[3]:
                    best = (name, h, e, cost)
                break  # smaller steps of this integrator only cost more
    if best is None:
        raise ValueError(f"no integrator/step in {integrators} x {steps} meets half the tolerance "
                         f"at n = {chosen_n}")
    name, h, e, cost = best
    reason = (
        f"n = {chosen_n}: smallest n whose estimated resolution error (against n = {n_ref}, "
        f"plus that reference's own error) is within half the tolerance (position "
        f"{disc[0]:.3g} m, tension {disc[1]:.3g}); {name} at h = {h:g} s: cheapest measured "
        f"({cost:.3g} s per simulated s) with time error position {e[0]:.3g} m, tension "
        f"{e[1]:.3g}; horizon {horizon:g} s"
    )
    return Choice(chosen_n, name, h, disc[0] + e[0], disc[1] + e[1], cost, reason, table)
