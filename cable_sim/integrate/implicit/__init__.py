"""Linearly implicit integrators for stiff cables, O(n) per step.

Why: with the paper's drag (and at large n with any drag) the explicit schemes are limited by
*stability*, not accuracy (MODEL.md, "Numerical character"). The stiff forces are local:

* joint springs and dampers act on each joint's relative angle;
* the heave spring and damper act on the platform;
* drag is body-local: the paper's drag depends on link i's own angular velocity, Morison drag
  on the velocity of link i's centre;
* the (static) tension stiffness of a hanging chain is diagonal in absolute angles.

A linearly implicit step solves with the operator ``M~ = M + hg D + hg^2 K`` (MuJoCo's
``M + hD + h^2K``) where ``D = -dQ/dqd`` and ``K = -dQ/dq`` are restricted to those local terms
and ``hg`` is the scheme's ``gamma h``. In mechanical terms ``M~`` is the mass matrix of a
modified chain: every joint gets an "armature" ``beta_i = hg c_i + hg^2 k_i`` on its relative
angle, the platform an extra mass ``hg c_m + hg^2 k_m``, every link an extra rotational inertia
``hg 2 gamma_i l_i^2/4 |theta_dot_i| + hg^2 kappa_i`` (paper drag, tension stiffness) and an
anisotropic extra mass ``hg G_i`` at its centre, ``G_i = 2 c_n |v.t| t t^T + 2 c_t |v.e| e e^T``
(the Jacobian of the Morison force, v the centre velocity relative to the water), and, where
the seabed pushes on a link, a vertical-only mass of density ``hg c_b + hg^2 k_b`` over the
pushed part of the link (the contact force's Jacobian, see
:mod:`cable_sim.integrate.implicit.operator`). Because the
armature couples a link's rotation to its parent's, the articulated inertia seen at a pin is
3x3 (couple + force against parent rotation + pin acceleration) instead of the 2x2 of
:mod:`cable_sim.core.kernel`; the recursion is otherwise the same and stays O(n) (see
:func:`cable_sim.integrate.implicit.op_factor._op_factor`). The anchored end is handled by the
same Schur complement with the modified operator (two unit-force solves), the paper's 8e8 kg
load by the same Woodbury form as in :mod:`cable_sim.core.kernel`; after each step the base
class projects onto the constraint.

The geometric (tension) stiffness ``kappa_i = max(0, l_i T_i)`` uses the mean axial tension of
link i at the start of the step (from the Newton recursion of the joint forces). For a hanging
chain at rest it is exactly the gravity stiffness ``g mu~_i l_i cos(theta_i)``; in motion it is
an approximation, which a W-method allows (the schemes keep their order for any ``K``, ``D``).

Schemes (:data:`INTEGRATORS`):

* :class:`LinearlyImplicitEuler` (``implicit_euler``): order 1, one force evaluation and one
  O(n) solve per step. ``v' = v + h a*``, ``q' = q + h v'`` with
  ``M~ a* = f - hK v``: for the local stiff terms it is the implicit Euler step (L-stable,
  strongly damping), for the rest symplectic Euler. Stable at steps far above the explicit
  limit, but first order: its numerical damping of fast physical modes is O(h).
* :class:`Rosenbrock2` (``rosenbrock2``): the two-stage L-stable Rosenbrock W-method ROS2
  (Verwer, Spee, Blom & Hundsdorfer 1999), order 2 for *any* approximation of the Jacobian,
  so order 2 with the local ``K``, ``D`` above; two force evaluations, one operator
  factorisation and two O(n) solves per step. ``gamma = 1 - 1/sqrt(2)`` by default (smaller
  error constant; ``1 + 1/sqrt(2)`` is the original's choice), both L-stable for the part in
  ``W``; the explicit remainder (velocity-product couplings) is integrated like Heun's method.

* :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2` (``ros34pw2``): the four-stage
  Rosenbrock W-method ROS34PW2 (Rang & Angermann 2005), order 3 for any ``W`` (so with the local
  ``K``, ``D``), L-stable, stiffly accurate; four force evaluations, one factorisation and four
  O(n) solves per step. :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2Adaptive`
  (``ros34pw2_adaptive``, ``rtol``/``atol`` on the joint positions and velocities): the same with
  its embedded order-2 estimate and a PI step controller, stepping adaptively between fixed
  output times.
* :class:`~cable_sim.integrate.implicit.ros34prw.Ros34PRw` (``ros34prw``) and
  :class:`~cable_sim.integrate.implicit.ros34prw.Ros34PRwAdaptive` (``ros34prw_adaptive``): the
  four-stage W-method ROS34PRw (Rang 2015) on the same compiled step with its own tableau:
  order 3 for any ``W``, L-stable, stiffly accurate, the same ``gamma`` (same operator); its
  embedded solution is of order 2 only with the exact Jacobian (W-order 1).
* :class:`~cable_sim.integrate.implicit.w6s4os.W6S4OS` (``w6s4os``): a six-stage W-method of
  order 4 for any ``W`` on the same compiled step, fixed step only (no embedded solution);
  ``R(-inf) = 0`` but only A(89.5 deg)-stable. Six force evaluations and six O(n) solves per
  step; the largest steps within 1 cm at moderate n.
* :class:`~cable_sim.integrate.implicit.radau.RadauIIA` (``radau_iia``): three-stage Radau IIA,
  order 5, L-stable, stiffly accurate, *fully* implicit: its stage equations are solved by
  simplified Newton with the same local operator (one real and one complex O(n) solve per
  iteration, :mod:`~cable_sim.integrate.implicit.radau_step`), so the operator only has to make
  the iteration converge; a step whose iteration does not converge is redone in halves. Fixed
  step; the largest steps within 1 cm at large n (the W-methods' step there is bounded by how
  far the local operator is from the Jacobian).
  :class:`~cable_sim.integrate.implicit.radau.RadauIIAAdaptive` (``radau_iia_adaptive``): the
  same with Hairer & Wanner's embedded order-3 estimate and the PI step controller
  (:mod:`~cable_sim.integrate.implicit.radau_adaptive`).

All have a compiled fast path (system kernel ``"fast"``: the whole step, its checks and the
projection run in numba; :meth:`advance` runs many steps in one call) and a dense fallback
(kernel ``"dense"``: the same scheme with the dense matrices ``M``, ``D``, ``K``, used as the
reference the O(n) solve is tested against).

Modules: ``operator`` (the O(n) operator ``M + hg D + hg^2 K``: its theory and Python API; its
compiled parts one per module: ``op_layout``, ``op_terms``, ``op_factor``, ``op_solve``,
``op_product``), ``run``
(the compiled stepping loop), ``schemes`` (the integrator classes), ``ros34`` (ROS34PW2, fixed
and adaptive: its theory, dense reference step and integrator classes; its parts one per
module: ``ros_tableau`` (a W-method's coefficients in both forms, ROS34PW2's), ``ros_step`` (the
compiled step and fixed-step run, parametrised by the tableau), ``ros_adaptive`` (error norm, PI
controller, compiled adaptive run)), ``ros34prw`` (ROS34PRw, the same loops with another
tableau), ``w6s4os`` (W6S4OS, the same step with a six-stage tableau), ``radau`` (Radau IIA:
coefficients, dense reference step, integrator classes) with ``radau_step`` (its compiled step and
fixed-step run) and ``radau_adaptive`` (its error estimate and compiled adaptive run),
``dense`` (the dense reference operator and solve).

Integrate layer: this ``__init__`` re-exports its modules' public API; they import numba,
numpy, :mod:`cable_sim.core` and :mod:`cable_sim.integrate.base`.
"""

from __future__ import annotations

from cable_sim.integrate.implicit import dense
from cable_sim.integrate.implicit.dense import dense_operator
from cable_sim.integrate.implicit.operator import (
    geometric_stiffness,
    operator_product,
    operator_solve,
    operator_solve_pair,
)
from cable_sim.integrate.implicit.radau import RadauIIA, RadauIIAAdaptive
from cable_sim.integrate.implicit.ros34 import Ros34PW2, Ros34PW2Adaptive
from cable_sim.integrate.implicit.ros34prw import Ros34PRw, Ros34PRwAdaptive
from cable_sim.integrate.implicit.schemes import INTEGRATORS, LinearlyImplicitEuler, Rosenbrock2
from cable_sim.integrate.implicit.w6s4os import W6S4OS

__all__ = [
    "INTEGRATORS",
    "LinearlyImplicitEuler",
    "Rosenbrock2",
    "Ros34PW2",
    "Ros34PW2Adaptive",
    "Ros34PRw",
    "Ros34PRwAdaptive",
    "W6S4OS",
    "RadauIIA",
    "RadauIIAAdaptive",
    "operator_solve",
    "operator_solve_pair",
    "operator_product",
    "dense_operator",
    "geometric_stiffness",
    "dense",
]
