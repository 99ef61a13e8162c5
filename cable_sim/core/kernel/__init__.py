"""The compiled O(n) kernel of the n-link cable: one module per sweep or quantity.

=================  ==========================================================================
``packing``        the model as plain arrays for numba (:func:`pack_arrays`), cached per model
``trig``           cos and sin of the link angles, branch-free (vectorised loops)
``sweeps``         the shared articulated-body pieces: link kinematics and drag, the 2x2
                   articulated inertia, the inward and outward sweeps, the 2x2 end correction
                   (also used by :mod:`cable_sim.integrate.implicit.operator`)
``contact``        seabed contact per link, exact over its length (MODEL.md round-2 terms)
``forward``        forward dynamics (:func:`forward_dynamics`, :func:`fd_packed`; the compiled
                   runs: :func:`~cable_sim.core.kernel.forward.fd_packed_ws`, scratch reused)
``energy``         kinetic and potential energy
``joint_forces``   internal joint forces (Newton recursion from the end)
``anchor``         anchored end: constraint right-hand side, projection, drift, Schur matrix
``checks``         the integrators' compiled per-step checks and their status codes
``startup``        :func:`warmup` (compile before real time starts)
``signals``        the built-in input signals' packed form and the system's input program,
                   evaluated compiled (:func:`~cable_sim.core.kernel.signals.sample_program`)
=================  ==========================================================================

The compiled explicit steppers that use these live in the integrate layer
(:mod:`cable_sim.integrate.compiled_steppers`). This ``__init__`` only re-exports the API used
elsewhere, so ``from cable_sim.core import kernel as fast; fast.forward_dynamics(...)`` works.

Core layer: imports its own modules only (they import numba, numpy and the core's
``dynamics`` (``Inputs``), ``model`` and ``params``).
"""

from __future__ import annotations

from cable_sim.core.kernel.anchor import (
    condition_2x2,
    end_drift_packed,
    project_packed,
    schur_condition,
    schur_packed,
)
from cable_sim.core.kernel.checks import (
    OSC_ACCEL,
    OSC_GROWTH,
    OSC_STEPS,
    STATUS_DRIFT,
    STATUS_ENERGY_JUMP,
    STATUS_ILL_CONDITIONED,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_OSCILLATION,
    STATUS_SINGULAR,
    STATUS_TAUT,
    STATUS_UNSTABLE,
    check_packed,
    oscillation_packed,
)
from cable_sim.core.kernel.energy import energy
from cable_sim.core.kernel.forward import NO_INPUT, Inputs, fd_packed, forward_dynamics, state_derivative
from cable_sim.core.kernel.joint_forces import joint_forces, joint_forces_packed
from cable_sim.core.kernel.packing import pack_arrays
from cable_sim.core.kernel.startup import warmup

__all__ = [
    "Inputs",
    "NO_INPUT",
    "forward_dynamics",
    "state_derivative",
    "joint_forces",
    "energy",
    "warmup",
    "pack_arrays",
    "fd_packed",
    "joint_forces_packed",
    "project_packed",
    "end_drift_packed",
    "schur_packed",
    "condition_2x2",
    "schur_condition",
    "check_packed",
    "oscillation_packed",
    "OSC_ACCEL",
    "OSC_GROWTH",
    "OSC_STEPS",
    "STATUS_OK",
    "STATUS_NONFINITE",
    "STATUS_DRIFT",
    "STATUS_TAUT",
    "STATUS_SINGULAR",
    "STATUS_ILL_CONDITIONED",
    "STATUS_UNSTABLE",
    "STATUS_ENERGY_JUMP",
    "STATUS_OSCILLATION",
]
