"""A running simulation: scene -> model -> integrator, with held inputs and derived outputs.

:class:`Simulation` is the one place where time advances. The ROS node, the replay tool and
the benchmark all drive it the same way, so a replay with the same settings and the same
inputs reproduces a run bit for bit:

- time is ``t = k * h`` (step index times step, never accumulated);
- the input over a step is ``signal(t) + held`` where ``signal`` is the scene's built-in source
  (a pure function of time) and ``held`` the last value set by :meth:`set_heave_force` /
  :meth:`set_wave_elevation` (zero-order hold from a topic), applied from the next step on.

On the ``fast`` kernel the same inputs are also handed to the system as an input program
(:mod:`cable_sim.core.kernel.signals`; the held values are written into it as they change), so
the compiled steppers evaluate them without calling back into Python.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core.dynamics import Inputs
from cable_sim.core.energy_bounds import kinetic_lower_bound
from cable_sim.core.inputs import make_signal
from cable_sim.core.kernel.signals import HELD_ETA, HELD_U, pack_program
from cable_sim.core.model import CableModel
from cable_sim.integrate import IntegrationError
from cable_sim.scene.scenes import Scene

#: Fraction of the line length below which an anchored line counts as pulled taut.
TAUT_SLACK = 1e-3


@dataclass
class Outputs:
    """Everything published about the current state (SI units).

    Attributes
    ----------
    t : float
        Simulation time [s].
    q, qd, qdd : ndarray (n+1,)
        Generalised positions, velocities, accelerations.
    joint_positions : ndarray (n+1, 2)
        (x, z) of the fairlead and every joint [m].
    joint_forces : ndarray (n+1, 2)
        Force at each joint [N] (see :func:`cable_sim.core.dynamics.joint_forces`).
    axial_tension : ndarray (n,)
        Tension at the top of each link [N].
    fairlead_force : ndarray (2,)
        Force the platform exerts on the cable [N] (its magnitude is the fairlead tension).
    anchor_force : ndarray (2,)
        Force the anchor exerts on the cable [N] (zero for a free end).
    joint_torques : ndarray (n,)
        Spring + damper torque in each joint [N m] (JointState effort).
    energy : float
        Total mechanical energy [J].
    constraint_drift : float
        |p_n - anchor| [m].
    slack : float
        1 - |fairlead - anchor| / L for an anchored line (near 0: taut, snap risk), else nan.
    inputs : Inputs
        The inputs applied over the last step.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    joint_positions: np.ndarray
    joint_forces: np.ndarray
    axial_tension: np.ndarray
    fairlead_force: np.ndarray
    anchor_force: np.ndarray
    joint_torques: np.ndarray
    energy: float
    constraint_drift: float
    slack: float
    inputs: Inputs

    @property
    def fairlead_tension(self) -> float:
        """|F_0| [N]."""
        return float(np.hypot(*self.fairlead_force))


def _energy_fn(kernel: str):
    if kernel == "fast":
        from cable_sim.core import kernel as fast

        def energy(model: CableModel, q: np.ndarray, qd: np.ndarray) -> float:
            T, V = fast.energy(model, q, qd)
            return float(T + V)

        return energy
    return dynamics.total_energy


def _joint_forces_fn(kernel: str):
    """Joint forces of the kernel: the O(n) compiled Newton recursion, or the dense reference."""
    if kernel == "fast":
        from cable_sim.core.kernel.joint_forces import joint_forces

        return joint_forces
    return dynamics.joint_forces


class Simulation:
    """A scene being simulated.

    Parameters
    ----------
    scene : Scene
        The scene (physics, integrator, inputs, initial state).
    kernel, integrator : str, optional
        Override the scene's kernel (``dense``/``fast``) and integrator name.
    step : float, optional
        Override the physics step h [s].
    n_links : int, optional
        Simulate the scene at another resolution.

    When the scene sets ``position_tolerance`` and ``tension_tolerance`` (> 0) and no override
    is given, n, integrator and step are chosen by :func:`cable_sim.scene.autoselect.choose`; the
    choice and its reason are kept in :attr:`choice`.

    Attributes
    ----------
    k : int
        Number of steps taken; ``t = k * h``.
    y : ndarray
        Current state [q, qd].
    choice : cable_sim.scene.autoselect.Choice or None
        The automatic choice, when the scene asked for a tolerance.
    """

    def __init__(
        self,
        scene: Scene,
        kernel: str | None = None,
        integrator: str | None = None,
        step: float | None = None,
        n_links: int | None = None,
    ) -> None:
        self.choice = None
        tol_pos = float(scene.sim.get("position_tolerance", 0.0))
        tol_ten = float(scene.sim.get("tension_tolerance", 0.0))
        if n_links is None and integrator is None and step is None and tol_pos > 0 and tol_ten > 0:
            from cable_sim.scene.autoselect import choose

            self.choice = choose(scene, tol_pos, tol_ten,
                                 horizon=float(scene.sim.get("tolerance_horizon", 10.0)),
                                 kernel=kernel or scene.sim["kernel"])
            n_links, integrator, step = (self.choice.n_links, self.choice.integrator,
                                         self.choice.step)
        if n_links is not None and n_links != scene.params.n_links:
            scene = scene.with_links(n_links)
        self.scene = scene
        self.model = scene.model()
        self.kernel = kernel or scene.sim["kernel"]
        self.system = scene.system(kernel=self.kernel, model=self.model)
        self.integrator = scene.integrator(self.system, name=integrator, step=step)
        self.h = self.integrator.h
        cfg = {**scene.sim, **scene.extra}
        self._heave_signal = make_signal(scene.sim["heave_force_source"], "heave_force", cfg)
        self._wave_signal = make_signal(scene.sim["wave_source"], "wave", cfg)
        self._program: np.ndarray | None = None  # the inputs packed for the compiled steppers
        self._held_u = self._held_eta = 0.0
        if self.kernel == "fast":
            self._program = pack_program(self._heave_signal.packed(), self._wave_signal.packed())
        self.system.set_inputs(self.inputs_at, self._program)
        self._energy = _energy_fn(self.kernel)
        self._joint_forces = _joint_forces_fn(self.kernel)
        self.y0 = scene.initial_state(self.model)
        self.reset()

    @property
    def t(self) -> float:
        """Simulation time [s] = k h."""
        return self.k * self.h

    def reset(self) -> None:
        """Back to the scene's initial state at t = 0, held inputs zero."""
        self.k = 0
        self.y = self.y0.copy()
        self.held_heave_force = 0.0
        self.held_wave_elevation = 0.0
        self.integrator.reset_energy_budget(self.y)

    def warm_up(self) -> None:
        """Compile (or load from the on-disk kernel cache) every compiled kernel a run of this
        simulation calls -- forward dynamics, energy, joint forces and the integrator's stepper --
        without advancing it, so that the first real step is not a compile.

        The first call after an install or an upgrade compiles (about a minute for the default
        scene on a 2-core machine, most of it the stepper); later processes load the kernels from
        the cache in about a second. Nothing to do on the dense kernel.
        """
        if self.kernel != "fast":
            return
        from cable_sim.core.kernel.startup import warmup

        warmup()
        steps = self.integrator.nsteps
        self.integrator.step(0.0, self.y.copy())
        self.integrator.nsteps = steps

    @property
    def held_heave_force(self) -> float:
        """The held (topic) heave force [N] added to the built-in source."""
        return self._held_u

    @held_heave_force.setter
    def held_heave_force(self, value: float) -> None:
        self._held_u = float(value)
        if self._program is not None:
            self._program[HELD_U] = self._held_u

    @property
    def held_wave_elevation(self) -> float:
        """The held (topic) wave elevation [m] added to the built-in source."""
        return self._held_eta

    @held_wave_elevation.setter
    def held_wave_elevation(self, value: float) -> None:
        self._held_eta = float(value)
        if self._program is not None:
            self._program[HELD_ETA] = self._held_eta

    def set_heave_force(self, value: float) -> None:
        """Hold a heave force [N] (added to the built-in source) from the next step on."""
        self.held_heave_force = float(value)

    def set_wave_elevation(self, value: float) -> None:
        """Hold a wave elevation [m] (added to the built-in source) from the next step on."""
        self.held_wave_elevation = float(value)

    def inputs_at(self, t: float) -> Inputs:
        """Inputs at time t: built-in source plus held topic value."""
        return Inputs(
            self._heave_signal(t) + self._held_u,
            self._wave_signal(t) + self._held_eta,
        )

    def step(self) -> None:
        """Advance one physics step.

        Raises
        ------
        IntegrationError
            On blow-up or constraint drift; the state is left at the last good step.
        """
        y_new = self.integrator.step(self.t, self.y, self.h)
        self.y = y_new
        self.k += 1

    def run_until(self, t_end: float) -> int:
        """Step while the next step ends at or before ``t_end``; return the number of steps."""
        n = 0
        while (self.k + 1) * self.h <= t_end + 1e-12 * max(1.0, t_end):
            self.step()
            n += 1
        return n

    def outputs(self) -> Outputs:
        """Derived quantities of the current state (tensions, energy, positions...).

        Raises
        ------
        IntegrationError
            When the state or a derived quantity is not finite, or the state's kinetic energy
            exceeds the integrator's physical bound (numerical instability): nothing
            implausible is returned.
        """
        m = self.model
        q, qd = self.y[: m.ndof], self.y[m.ndof:]
        if not np.all(np.isfinite(self.y)):
            raise IntegrationError(self.t, "numerical instability: the state is not finite")
        tlb = kinetic_lower_bound(m, self.y)
        bound = self.integrator.kinetic_energy_bound
        if tlb > bound:
            raise IntegrationError(
                self.t, f"numerical instability: kinetic energy {tlb:.3g} J exceeds the physical "
                f"bound {bound:.3g} J; reduce the step or use an implicit scheme")
        inputs = self.inputs_at(self.t)
        try:
            qdd, lam = self.system.forward(m, q, qd, inputs)
        except np.linalg.LinAlgError as exc:
            if m.end == 0:
                raise IntegrationError(
                    self.t, f"singular dynamics on a free-end line (numerical instability?): {exc}"
                ) from exc
            raise IntegrationError(self.t, f"singular dynamics (line pulled straight?): {exc}") from exc
        F = self._joint_forces(m, q, qd, qdd, lam)
        torques = (m.joint_k * dynamics.relative_angles(q[1:])
                   + m.joint_c * dynamics.relative_angles(qd[1:]))
        pos = dynamics.joint_positions(m, q)
        if not (np.all(np.isfinite(qdd)) and np.all(np.isfinite(F))
                and (lam is None or np.all(np.isfinite(lam)))):
            raise IntegrationError(self.t, "numerical instability: non-finite accelerations or "
                                   "joint forces from a finite state")
        # math.hypot, not np.linalg.norm: a BLAS dot releases the GIL, and each release hands it
        # to a waiting thread (the recorder's writer) or wakes it for nothing (see README, recording)
        drift = math.hypot(*(pos[-1] - m.anchor)) if m.constrained else 0.0
        slack = float("nan")
        if m.end != 0:
            slack = 1.0 - math.hypot(*(pos[0] - m.anchor)) / float(m.length.sum())
        return Outputs(
            t=self.t, q=q.copy(), qd=qd.copy(), qdd=qdd, joint_positions=pos, joint_forces=F,
            axial_tension=dynamics.axial_tension(m, q, F), fairlead_force=F[0].copy(),
            anchor_force=lam if m.constrained else (-F[-1] if m.end == 2 else np.zeros(2)),
            joint_torques=torques, energy=self._energy(m, q, qd), constraint_drift=drift,
            slack=slack, inputs=inputs,
        )

    def health(self, out: Outputs) -> list[str]:
        """Problems worth a warning (empty when healthy): taut line, drift, non-finite output."""
        problems = []
        if np.isfinite(out.slack) and out.slack < TAUT_SLACK:
            problems.append(f"line nearly taut (slack {out.slack:.2e} < {TAUT_SLACK}): snap-load risk")
        if out.constraint_drift > 1e-3:
            problems.append(f"anchor constraint drift {out.constraint_drift:.3g} m > 1 mm")
        if not (np.all(np.isfinite(out.axial_tension)) and np.isfinite(out.energy)):
            problems.append("non-finite outputs")
        return problems


__all__ = ["Simulation", "Outputs", "IntegrationError"]
