"""Radau IIA (three stages, order 5) on the O(n) operator, fixed step.

Why: the W-methods (:mod:`cable_sim.integrate.implicit.ros34`,
:mod:`~cable_sim.integrate.implicit.w6s4os`) are linearly implicit: one linear solve per stage
with the local operator ``T`` and no iteration, so ``T`` must be close to the Jacobian where
the step is large against the fast modes. On the paper's free fall at n = 640 their largest
step within 1 cm is 5 ms. Radau IIA solves its stage equations to a tolerance instead: ``T``
only has to make the (simplified) Newton iteration converge, and the step is limited by
accuracy, not by how well ``T`` approximates the Jacobian.

Method: Radau IIA with three stages (Hairer & Wanner, *Solving ODEs II*, IV.5, Table 5.6):
collocation at ``c = ((4 - sqrt 6)/10, (4 + sqrt 6)/10, 1)``, order 5, stage order 3,
L-stable (``R(-inf) = 0``), stiffly accurate (the last stage is the new state). The stage
equations are solved by simplified Newton in the eigenbasis of ``A^-1`` with one real and one
complex O(n) solve per iteration (:mod:`cable_sim.integrate.implicit.radau_step`); the
operator is factored once per step, the drag linearised at the predicted velocity ``v + h a``;
at an anchored end the iteration matrix has the anchor's Baumgarte stabilisation too (without
it the iteration diverges in the constraint-violating directions once ``h omega_b`` nears 1,
and most step attempts are halved). With ``h omega_b`` well above 1 the stabilisation is a
stiff component and the observed order drops towards the stage order 3 (test_radau).
A step whose iteration does not converge (the release of a free fall, where the accelerations
reach 1e4 rad/s^2 at n = 640) is redone as two halves, each with its own factorisation, down to
``h / 4096``; the run then fails loudly (``IntegrationError``: "stage equations did not
converge").

Cost per step: one force evaluation and two factorisations (one real, one complex), then per
Newton iteration three force evaluations, one real and one complex O(n) solve.
:class:`RadauIIAAdaptive` (``radau_iia_adaptive``) adds the embedded error estimate (one more
real O(n) solve per step; :mod:`cable_sim.integrate.implicit.radau_adaptive`) and steps
adaptively; a step whose iteration does not converge is then rejected and retried smaller.

Integrate layer: imports numpy, :mod:`cable_sim.core` (dynamics, system),
:mod:`cable_sim.integrate` (adaptive, base, errors, step_control) and the sibling modules
``dense``, ``operator``, ``radau_adaptive`` and ``radau_step``.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core.system import CableSystem
from cable_sim.integrate.adaptive import AdaptiveStepping
from cable_sim.integrate.base import Integrator
from cable_sim.integrate.errors import IntegrationError
from cable_sim.integrate.implicit.dense import _dense_solve, baumgarte_end_motion, dense_operator
from cable_sim.integrate.implicit.operator import geometric_stiffness as _geometric_stiffness
from cable_sim.integrate.implicit.radau_adaptive import _K_EXP, DD, _radau_adaptive_run
from cable_sim.integrate.implicit.radau_step import (
    MAX_HALVINGS,
    NEWTON_CONVERGED,
    NEWTON_FAILED,
    STATUS_NEWTON,
    _radau_fixed_run,
    newton_verdict,
    radau_workspace,
)
from cable_sim.integrate.step_control import err_norm

_S6 = np.sqrt(6.0)
#: Radau IIA (s = 3) coefficients (Hairer & Wanner IV.5, Table 5.6).
A = np.array([
    [(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
    [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
    [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0],
])
#: Stage times (fractions of h).
C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])


def _eigenbasis(a: np.ndarray) -> tuple[float, complex, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``A^-1 = V diag(lambda_1, lambda_2, conj lambda_2) V^-1``: the real eigenvalue, the complex
    one with positive imaginary part, the matching rows of ``V^-1`` (real, complex) and columns
    of ``V`` (real, complex)."""
    lam, vec = np.linalg.eig(np.linalg.inv(a))
    k1 = int(np.argmin(np.abs(lam.imag)))
    k2 = int(np.argmax(lam.imag))
    v1 = vec[:, k1].real / np.max(np.abs(vec[:, k1].real))
    vec = np.column_stack([v1, vec[:, k2], np.conj(vec[:, k2])])
    vinv = np.linalg.inv(vec)
    return (float(lam[k1].real), complex(lam[k2]), np.ascontiguousarray(vinv[0].real),
            np.ascontiguousarray(vinv[1]), np.ascontiguousarray(v1), np.ascontiguousarray(vec[:, 1]))


#: The eigenvalues of ``A^-1`` (real; complex with positive imaginary part), the rows of
#: ``V^-1`` and columns of ``V`` that go with them (see :func:`_eigenbasis`).
LAM1, LAM2, TI1, TI2, V1, V2 = _eigenbasis(A)
#: Where the compiled step samples the inputs: the step's start and the three stage times.
OFFSETS = np.concatenate([[0.0], C])


def _dense_radau_step(system: CableSystem, t: float, y: np.ndarray, h: float, geometric: bool,
                      predict: bool, tol: float, maxit: int, newton: np.ndarray
                      ) -> tuple[np.ndarray | None, int]:
    """One Radau IIA step with the dense ``M``, ``D``, ``K`` and the same Newton iteration as
    the compiled step from the explicit Euler guess (reference for it): the new state (None when
    the iteration does not converge) and the iterations done. ``newton[0]``: the contraction
    estimate carried from step to step (updated)."""
    yn, its, _ = _dense_radau_attempt(system, t, y, h, geometric, predict, tol, maxit, newton)
    return yn, its


def _dense_shifted_solve(model, q: np.ndarray, hg: complex, Mt: np.ndarray, D: np.ndarray,
                         K: np.ndarray, rq: np.ndarray, rv: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """``(I - hg T) (sq, sv) = (rq, rv)`` with the dense operator ``Mt = M + hg D + hg^2 K``
    (the compiled ``radau_step._solve_shifted``)."""
    rk = rq + hg * rv
    sv = rv - _dense_solve(model, q, Mt, hg * (D @ rv) + hg * (K @ rk),
                           baumgarte_end_motion(model, q, hg, rv, rk))
    return rq + hg * sv, sv


def _dense_radau_attempt(system: CableSystem, t: float, y: np.ndarray, h: float, geometric: bool,
                         predict: bool, tol: float, maxit: int, newton: np.ndarray
                         ) -> tuple[np.ndarray | None, int, tuple]:
    """:func:`_dense_radau_step`, and what its error estimate needs: ``(Mt, D, K, Zq, Zv, a_0)``
    (the real shifted operator ``M + hg_1 D + hg_1^2 K`` and its ``D``, ``K``, the stage
    increments, the accelerations at y)."""
    model = system.model
    n1 = model.ndof
    q, v = y[:n1], y[n1:]
    acc, lam = system.accelerations(t, y)
    system.nfev += 1
    kgeo = None
    if geometric:
        kgeo = _geometric_stiffness(model, q, dynamics.joint_forces(model, q, v, acc, lam))
    M, D, K = dense_operator(model, q, v + h * acc if predict else v, kgeo)
    hgs = (h / LAM1, h / LAM2)
    ops = [M + hg * D + hg * hg * K for hg in hgs]  # once per step
    Zq = np.outer(C * h, v)
    Zv = np.outer(C * h, acc)
    scale = tol * float(np.sum(model.length))
    scv = scale + tol * np.max(np.abs(dynamics.joint_velocities(model, q, v)), axis=1)  # per joint
    prev = 0.0
    eta = max(float(newton[0]), 1e-16) ** 0.8
    for it in range(maxit):
        Fq = v + Zv
        Fv = np.empty_like(Zv)
        for i in range(3):
            Fv[i] = system.accelerations(t + C[i] * h, np.concatenate([q + Zq[i], v + Zv[i]]))[0]
            system.nfev += 1
        dW = [_dense_shifted_solve(model, q, hg, Mt, D, K, hg * (ti @ Fq) - ti @ Zq,
                                   hg * (ti @ Fv) - ti @ Zv)
              for ti, hg, Mt in zip((TI1, TI2), hgs, ops, strict=True)]
        dq = np.outer(V1, dW[0][0]) + (2.0 * np.outer(V2, dW[1][0])).real
        dv = np.outer(V1, dW[0][1]) + (2.0 * np.outer(V2, dW[1][1])).real
        Zq += dq
        Zv += dv
        big = _joint_increment_size(model, q, v, dq, dv, scale, scv)
        verdict, eta = newton_verdict(it, big, prev, eta, maxit)
        if verdict == NEWTON_CONVERGED:
            newton[0] = eta
            return np.concatenate([q + Zq[2], v + Zv[2]]), it + 1, (ops[0], D, K, Zq, Zv, acc)
        if verdict == NEWTON_FAILED:
            return None, it + 1, ()
        prev = big
    return None, maxit, ()


def _joint_increment_size(model, q: np.ndarray, v: np.ndarray, dq: np.ndarray, dv: np.ndarray,
                          scale: float, scv: np.ndarray) -> float:
    """The compiled ``radau_step._add_increments``'s size of the stage increments ``dq, dv``
    (3, n+1), from the joints' positions and velocities linearised at (q, v): the largest
    change of a joint-position component over ``scale`` [m] and of a joint-velocity component
    over ``scv`` (``scale`` plus ``tol`` times the joint's largest velocity component, per
    joint)."""
    th, w = q[1:], v[1:]
    c, s, ll = np.cos(th), np.sin(th), model.length
    big = 0.0
    for i in range(3):
        dth, dw = dq[i, 1:], dv[i, 1:]
        dp = np.zeros((model.n + 1, 2))
        dp[1:, 0] = np.cumsum(ll * c * dth)
        dp[1:, 1] = np.cumsum(ll * s * dth)
        dp[:, 1] += dq[i, 0]
        dvj = np.zeros((model.n + 1, 2))
        dvj[1:, 0] = np.cumsum(ll * (c * dw - s * w * dth))
        dvj[1:, 1] = np.cumsum(ll * (s * dw + c * w * dth))
        dvj[:, 1] += dv[i, 0]
        big = max(big, float(np.max(np.abs(dp))) / scale,
                  float(np.max(np.max(np.abs(dvj), axis=1) / scv)))
    return big


def _dense_radau_error(system: CableSystem, y: np.ndarray, h: float, parts: tuple,
                       f: np.ndarray) -> np.ndarray:
    """The error estimate of :mod:`cable_sim.integrate.implicit.radau_adaptive` with the dense
    operator: ``(I - hg_1 T)^-1 (hg_1 f + gamma_0 sum_i d_i Z_i)`` for the step whose
    :func:`_dense_radau_attempt` gave ``parts``, with the slope ``f`` (2(n+1))."""
    Mt, D, K, Zq, Zv, _ = parts
    n1 = system.model.ndof
    hg = h / LAM1
    sq, sv = _dense_shifted_solve(system.model, y[:n1], hg, Mt, D, K,
                                  hg * f[:n1] + (DD @ Zq) / LAM1, hg * f[n1:] + (DD @ Zv) / LAM1)
    return np.concatenate([sq, sv])


class RadauIIA(Integrator):
    """Three-stage Radau IIA with simplified Newton on the local O(n) operator, fixed step.

    Order 5 (stage order 3), L-stable, stiffly accurate; a step whose stage equations do not
    converge is redone in halves (down to h / 4096). See :mod:`cable_sim.integrate.implicit.radau`.

    Parameters
    ----------
    system : CableSystem
    step : float
        h [s].
    newton_tol : float
        The Newton iteration stops when its estimated distance to the solution (the last
        increment times ``theta / (1 - theta)``, ``theta`` its contraction) is at most
        ``newton_tol L`` [m] in every joint-position component and ``newton_tol (L / 1 s +
        |v_j|)`` [m/s] in every joint-velocity component (L the line's length, ``v_j`` the
        joint's velocity; the increments mapped to the joints as the error norm maps an error, see
        :mod:`cable_sim.integrate.implicit.radau_step`); default 1e-7 (24 um on the 240 m paper
        line). Measured on the paper free fall at h = 0.1 s over 31 s (README, "Radau IIA's
        Newton tolerance"): the error at 1e-7 is that at 3e-8 within 1 % at n = 640; at 3e-7
        it grows up to 1.7 times (n = 320).
    newton_maxit : int
        Iterations after which a step counts as not converging (then halved; also earlier when
        the increments stop shrinking or cannot reach the tolerance in time); default 10.
    geometric_stiffness, predict_drag
        See :class:`~cable_sim.integrate.implicit.ros34.Ros34PW2`.
    max_drift, taut_slack, max_condition, compiled
        See :class:`cable_sim.integrate.base.Integrator`.
    """

    name = "radau_iia"
    order = 5
    _fast_offsets = tuple(float(c) for c in OFFSETS)

    def __init__(self, system: CableSystem, step: float = 1e-2, newton_tol: float = 1e-7,
                 newton_maxit: int = 10, geometric_stiffness: bool = True,
                 predict_drag: bool = True, **kwargs) -> None:
        if not (np.isfinite(newton_tol) and 0.0 < newton_tol < 1.0):
            raise ValueError(f"parameter 'newton_tol' = {newton_tol!r} is invalid; allowed: "
                             "finite number in (0, 1)")
        if int(newton_maxit) != newton_maxit or not 2 <= newton_maxit <= 100:
            raise ValueError(f"parameter 'newton_maxit' = {newton_maxit!r} is invalid; allowed: "
                             "integer in [2, 100]")
        self.newton_tol = float(newton_tol)
        self.newton_maxit = int(newton_maxit)
        #: Newton iterations and failed (then halved) step attempts so far.
        self.newton_iterations = 0
        self.newton_failures = 0
        self._newton = np.ones(1)  # the Python path's contraction estimate (see radau_step)
        #: The last compiled run's ``(arr, h, workspace, [hprev, eta], final y)`` while the next
        #: call may continue it (:meth:`_continuation`); None after a failed run.
        self._carried: tuple | None = None
        self.geometric = bool(geometric_stiffness)
        self.predict = bool(predict_drag)
        super().__init__(system, step=step, **kwargs)

    def _warm(self) -> None:
        self._uncounted(super()._warm)

    def _uncounted(self, warm) -> None:
        """Run ``warm`` (the base class's compile-and-run of a 2-link model, once per process)
        without adding its Newton iterations to this integrator's counters."""
        counts = (self.newton_iterations, self.newton_failures, float(self._newton[0]))
        warm()
        self.newton_iterations, self.newton_failures, self._newton[0] = counts

    def _fast_kernel(self, arr, par, h, u, eta, y, chk, info) -> int:
        ext = np.zeros(5)  # info and the Newton counters (see _radau_fixed_run)
        ext[:3] = info[:3]
        ws, carry = self._continuation(arr, h, y)
        status = _radau_fixed_run(arr, par, self.geometric, self.predict, h, u, eta, y, chk, ext,
                                  LAM1, LAM2, TI1, TI2, V1, V2, OFFSETS, self.newton_tol,
                                  self.newton_maxit, ws, carry)
        # the next call continues this one only from its final state, bit for bit
        self._carried = (arr, h, ws, carry, y.copy()) if status == 0 else None
        info[:3] = ext[:3]
        self.newton_iterations += int(ext[3])
        self.newton_failures += int(ext[4])
        return status

    def _continuation(self, arr: np.ndarray, h: float, y: np.ndarray) -> tuple[tuple, np.ndarray]:
        """The workspace and ``[hprev, eta]`` for a compiled run from y (see
        :func:`~cable_sim.integrate.implicit.radau_step._radau_fixed_run`): the last run's, when
        this one continues it (the same packed model, h to 1e-9 relative, y its final state bit
        for bit), so that a run split into calls (the node's one step per call) takes the steps
        of one call: the first guess extrapolated from the previous step, its contraction
        estimate; else fresh ones (explicit Euler guess). As within one call, the first step's
        iteration matrix then uses the previous step's last stage slope for the accelerations
        at y: an input that jumps between two calls (a held topic value) changes that
        linearisation and the first guess only, not what the Newton iteration converges to."""
        last, self._carried = self._carried, None
        if (last is not None and last[0] is arr and abs(last[1] - h) <= 1e-9 * h
                and np.array_equal(last[4], y)):
            return last[2], last[3]
        return radau_workspace(arr.shape[1]), np.array([0.0, 1.0])

    def _step(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """One step of h: halves (recursively, down to h / 2^MAX_HALVINGS) where the stage
        equations do not converge."""
        hmin = h / 2 ** MAX_HALVINGS
        t_end = t + h
        hs = h
        while True:
            yn, its = _dense_radau_step(self.system, t, y, hs, self.geometric, self.predict,
                                        self.newton_tol, self.newton_maxit, self._newton)
            self.newton_iterations += its
            if yn is None:
                self.newton_failures += 1
                if hs <= hmin * (1.0 + 1e-9):
                    raise IntegrationError(t, self._newton_reason(hs))
                hs *= 0.5
                continue
            y = yn
            t += hs
            if t >= t_end - 1e-12 * h:
                return y
            hs = min(2.0 * hs, t_end - t)

    def _newton_reason(self, hs: float) -> str:
        return (f"Radau IIA stage equations did not converge (simplified Newton, at most "
                f"{self.newton_maxit} iterations) even at the substep {hs:.3g} s "
                f"(h / {2 ** MAX_HALVINGS}); the state is most likely diverging (or 'newton_tol' "
                "is below what round-off allows): reduce the step or raise 'newton_maxit'")

    def _raise_status(self, status: int, t: float, value: float, y_last: np.ndarray | None = None) -> None:
        if status == STATUS_NEWTON:
            raise IntegrationError(t, self._newton_reason(value))
        super()._raise_status(status, t, value, y_last)


class RadauIIAAdaptive(AdaptiveStepping, RadauIIA):
    """Three-stage Radau IIA with its embedded order-3 error estimate and a PI step-size
    controller (:mod:`cable_sim.integrate.implicit.radau_adaptive`).

    Order 5, L-stable, see :class:`RadauIIA`. A step whose stage equations do not converge is
    rejected like one whose error is too large. The stepping (output grid, error norm,
    controller, rejection, input interpolation) is that of
    :class:`cable_sim.integrate.adaptive.AdaptiveStepping`.

    Parameters
    ----------
    system : CableSystem
    step : float
        Output interval of :meth:`Integrator.integrate`-style use and of :meth:`step` [s].
    rtol, atol, first_step, max_step, safety, fac_min, fac_max, input_spacing
        See :class:`cable_sim.integrate.adaptive.AdaptiveStepping`.
    newton_tol : float or None
        See :class:`RadauIIA`; default (None) ``min(1e-7, 0.01 tol / L)`` with ``tol`` the smaller
        of ``atol`` and (when nonzero) ``rtol`` and L the line's length [m]: the iteration's
        error at the joints stays well below what the step's error estimate is held to there
        (Hairer's RADAU5 likewise ties its Newton tolerance to ``rtol``). With the fixed-step
        scheme's tolerance alone the free fall at n = 80 stayed 1.8e-4 m off at rtol = 1e-6
        (``make bench``, 2026-12-03 18:57, Newton test then per entry), with a default of
        ``0.01 tol`` 2.5e-6 m (19:34).
    newton_maxit, geometric_stiffness, predict_drag, max_drift, taut_slack, max_condition, compiled
        See :class:`RadauIIA`.
    """

    name = "radau_iia_adaptive"
    order = 5
    k_exp = _K_EXP

    def __init__(self, system: CableSystem, step: float = 1e-2, newton_tol: float | None = None,
                 **kwargs) -> None:
        super().__init__(system, step=step,
                         newton_tol=1e-7 if newton_tol is None else newton_tol, **kwargs)
        if newton_tol is None:  # from the validated tolerances
            tol = min(self.atol, self.rtol) if self.rtol > 0.0 else self.atol
            length = float(np.sum(system.model.length))
            self.newton_tol = min(1e-7, 0.01 * tol / length)

    def _warm(self) -> None:
        self._uncounted(super()._warm)

    def _run_adaptive(self, arr, par, t0, t1, tin0, tdt, u, eta, y, chk, info, ctl) -> int:
        newton = np.array([self._newton[0], 0.0, 0.0])
        status = _radau_adaptive_run(arr, par, self.geometric, self.predict, t0, t1, tin0, tdt, u,
                                     eta, y, chk, info, ctl, LAM1, LAM2, TI1, TI2, V1, V2,
                                     OFFSETS, DD, self.newton_tol, self.newton_maxit, newton)
        self._newton[0] = newton[0]
        self.newton_iterations += int(newton[1])
        self.newton_failures += int(newton[2])
        return status

    def _embedded_step(self, t: float, y: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """One step on the dense operator from the explicit Euler guess: (new state, error
        estimate); a step whose iteration does not converge returns an infinite estimate."""
        yn, its, parts = _dense_radau_attempt(self.system, t, y, h, self.geometric, self.predict,
                                              self.newton_tol, self.newton_maxit, self._newton)
        self.newton_iterations += its
        if yn is None:
            self.newton_failures += 1
            return y, np.full(y.shape, np.inf)
        n1 = self.system.model.ndof
        err = _dense_radau_error(self.system, y, h, parts, np.concatenate([y[n1:], parts[5]]))
        if err_norm(self._fast_model()[0], y, yn, err, self.atol, self.rtol) > 1.0:  # refine
            ye = y + err
            acc = self.system.accelerations(t, ye)[0]
            self.system.nfev += 1
            err = _dense_radau_error(self.system, y, h, parts, np.concatenate([ye[n1:], acc]))
        return yn, err


__all__ = ["A", "C", "LAM1", "LAM2", "OFFSETS", "TI1", "TI2", "V1", "V2", "RadauIIA",
           "RadauIIAAdaptive"]
