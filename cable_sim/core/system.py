"""A cable system: a model bound to a dynamics kernel and an input source.

:class:`CableSystem` is what integrators advance. It owns no state of its own besides the
input source (a function of time, or a value held by the ROS node); the state array is
passed in and returned.

Besides the callable, the input source may carry an *input program*
(:func:`cable_sim.core.kernel.signals.pack_program`): the same inputs as packed coefficients,
which the compiled steppers evaluate without calling back into Python. The program belongs to
the callable it was set with: assigning :attr:`CableSystem.input_at` directly drops it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core.dynamics import NO_INPUT, Inputs
from cable_sim.core.model import CableModel

InputSource = Callable[[float], Inputs]

#: Names of the available forward-dynamics kernels.
KERNELS = ("dense", "fast")


def _kernel(name: str):
    if name == "dense":
        return dynamics.forward_dynamics
    if name == "fast":
        from cable_sim.core import (
            kernel as fast,  # numba; imported lazily so the dense path needs no compiler
        )

        return fast.forward_dynamics
    raise ValueError(f"parameter 'kernel' = {name!r} is invalid; allowed: one of {KERNELS}")


class CableSystem:
    """The right-hand side of y' = f(t, y) for one cable model.

    Parameters
    ----------
    model : CableModel
        Immutable model.
    inputs : callable or Inputs, optional
        ``inputs(t) -> Inputs``, or a constant :class:`Inputs` (held). Default: no input.
    kernel : {"dense", "fast"}
        Dense Cholesky reference or the O(n) compiled kernel.
    program : ndarray, optional
        The inputs as an input program for the compiled steppers (see :meth:`set_inputs`).

    Attributes
    ----------
    nfev : int
        Number of right-hand-side evaluations so far.
    """

    def __init__(
        self,
        model: CableModel,
        inputs: InputSource | Inputs = NO_INPUT,
        kernel: str = "dense",
        program: np.ndarray | None = None,
    ) -> None:
        self.model = model
        self.kernel = kernel
        self.forward = _kernel(kernel)
        self.set_inputs(inputs, program)
        self.nfev = 0

    def set_inputs(self, inputs: InputSource | Inputs, program: np.ndarray | None = None) -> None:
        """Replace the input source (a held :class:`Inputs` or a function of time).

        Parameters
        ----------
        inputs : callable or Inputs
            ``inputs(t) -> Inputs``, or a constant :class:`Inputs` (held).
        program : ndarray, optional
            The same inputs as an input program
            (:func:`cable_sim.core.kernel.signals.pack_program`), for the compiled steppers.
            The caller guarantees that it evaluates to ``inputs(t)``. A held :class:`Inputs`
            gets one automatically on the ``fast`` kernel; without one, the compiled steppers
            sample the callable in Python.
        """
        if isinstance(inputs, Inputs):
            held = inputs
            self.input_at = lambda t: held
            if program is None and self.kernel == "fast":
                from cable_sim.core.kernel.signals import CONSTANT, pack_program, pack_signal

                program = pack_program(pack_signal(CONSTANT, 0.0, 0.0), pack_signal(CONSTANT, 0.0, 0.0),
                                       float(held.heave_force), float(held.wave_elevation))
        else:
            self.input_at = inputs
        self._program = (self.input_at, program)

    def input_program(self) -> np.ndarray | None:
        """The input program set with the current :attr:`input_at`, or None (no program, or
        :attr:`input_at` was replaced since)."""
        owner, program = self._program
        return program if owner is self.input_at else None

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """dy/dt at time t [s] for state y = [q, qd]."""
        self.nfev += 1
        n1 = self.model.ndof
        qdd, _ = self.forward(self.model, y[:n1], y[n1:], self.input_at(t))
        out = np.empty_like(y)
        out[:n1] = y[n1:]
        out[n1:] = qdd
        return out

    def accelerations(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(qdd, anchor_force) at time t for state y."""
        n1 = self.model.ndof
        return self.forward(self.model, y[:n1], y[n1:], self.input_at(t))

    def project(self, y: np.ndarray) -> np.ndarray:
        """Project y onto the anchor constraint (identity for a free end).

        With the ``fast`` kernel the same algorithm runs compiled
        (:func:`cable_sim.core.kernel.project_packed`), as in the compiled steppers.
        """
        if not self.model.constrained:
            return y
        if self.kernel == "fast":
            from cable_sim.core import kernel as fast

            arr, par = fast.pack_arrays(self.model)
            out = np.array(y, dtype=float, copy=True)
            fast.project_packed(arr, par, out, 1e-12)
            return out
        return project_constraint(self.model, y)

    def constraint_drift(self, y: np.ndarray) -> float:
        """|Phi(q)| [m]: distance of the cable end from the anchor (0 for a free end)."""
        if not self.model.constrained:
            return 0.0
        return float(np.linalg.norm(dynamics.constraint_residual(self.model, y[: self.model.ndof])))


def project_constraint(model: CableModel, y: np.ndarray, tol: float = 1e-12) -> np.ndarray:
    """Least-squares projection of positions and velocities onto Phi(q) = 0, Phi_q qd = 0.

    Positions: Gauss-Newton steps dq = -J^T (J J^T)^-1 Phi; velocities: the same projection of
    qd onto the null space of J. O(n).
    """
    n1 = model.ndof
    y = y.copy()
    q, qd = y[:n1], y[n1:]
    s = 1 if model.heave_locked else 0
    for _ in range(5):
        phi = dynamics.constraint_residual(model, q)
        if np.linalg.norm(phi) <= tol * model.params.total_length:
            break
        J = dynamics.constraint_jacobian(model, q)[:, s:]
        q[s:] -= J.T @ np.linalg.solve(J @ J.T, phi)
    J = dynamics.constraint_jacobian(model, q)[:, s:]
    qd[s:] -= J.T @ np.linalg.solve(J @ J.T, J @ qd[s:])
    return y
