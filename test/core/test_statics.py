"""The static-equilibrium solver: its result is a rest state, balances the forces, is stable.

References: (1) the dynamics themselves — started from the static solution with no forcing,
the scene's own integrator on either kernel (dense reference; fast, the compiled path
``Simulation`` runs — merged from test_verify_scenes, issue 10) must keep the line still; (2) an independent
potential-energy gradient (``conftest.RefLine``: weights mapped through centre Jacobians, spring
gradients on relative angles) and anchor Jacobian — at equilibrium grad V - Q_ext = J^T lambda on
the free coordinates, with the solver's own lambda; (3) stability — the Hessian of the
reference Lagrangian V - lambda . Phi (central differences of the reference gradient) projected
on the constraint's null space must be positive definite: a rest state that the line leaves at
the slightest disturbance is not a rest state.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RefLine
from scipy.linalg import null_space

from cable_sim.core.dynamics import Inputs
from cable_sim.core.statics import StaticsError, static_equilibrium
from cable_sim.scene.scenes import available_scenes, load_scene

NO_FORCING = {"heave_force_source": "none", "wave_source": "none", "initial_state": "static"}
SCENES = available_scenes()
ANCHORED = [s for s in SCENES if load_scene(s).params.end_condition == "anchored"]


def test_shipped_scenes_are_found() -> None:
    """The scene list the tests below run over holds the shipped scenes (an empty list would
    silently skip them)."""
    assert {"paper_free_fall", "paper_anchored_forced", "mooring_line"} <= set(SCENES), SCENES


def reduced_hessian(ref: RefLine, q: np.ndarray, lam: np.ndarray, anchored: bool,
                    locked: bool) -> np.ndarray:
    """Z^T H Z of V - lambda . Phi on the free coordinates (heave dropped when locked)."""
    s = 1 if locked else 0

    def grad(qq: np.ndarray) -> np.ndarray:
        g = ref.potential_gradient(qq)
        if anchored:
            g = g - ref.end_jacobian(qq).T @ lam
        return g[s:]

    k = q.size - s
    H = np.zeros((k, k))
    h = 1e-6
    for j in range(k):
        e = np.zeros(q.size)
        e[s + j] = h
        H[:, j] = (grad(q + e) - grad(q - e)) / (2 * h)
    H = 0.5 * (H + H.T)
    if not anchored:
        return H
    Z = null_space(ref.end_jacobian(q)[:, s:])
    return Z.T @ H @ Z


def residual(ref: RefLine, q: np.ndarray, lam: np.ndarray, anchored: bool, locked: bool,
             inputs: Inputs) -> float:
    """max |grad V - Q_ext - J^T lambda| over the free coordinates, relative to (wet weight) L."""
    r = ref.potential_gradient(q)
    r[0] -= inputs.heave_force + (ref.km * inputs.wave_elevation if ref.wave else 0.0)
    if anchored:
        r -= ref.end_jacobian(q).T @ lam
    scale = ref.g * (np.abs(ref.mw).sum() + abs(ref.mcw)) * ref.l.sum()
    return float(np.max(np.abs(r[1 if locked else 0:])) / scale)


@pytest.mark.parametrize("kernel", ["dense", "fast"])
@pytest.mark.parametrize("name", SCENES)
def test_static_state_stays_still(name: str, kernel: str) -> None:
    """Started at the static solution with forcing off, the scene's integrator and step (dense or
    fast kernel) keep max |theta_dot| < 1e-6 rad/s and |z_dot| < 1e-6 m/s for 10 s."""
    scene = load_scene(name, NO_FORCING)
    model = scene.model()
    system = scene.system(kernel=kernel, model=model)
    integ = scene.integrator(system)
    y0 = scene.initial_state(model)
    n1 = model.ndof
    tr = integ.integrate(y0, 0.0, 10.0, integ.h)
    w = float(np.max(np.abs(tr.y[:, n1 + 1:])))
    vz = float(np.max(np.abs(tr.y[:, n1])))
    dq = float(np.max(np.abs(tr.y[:, :n1] - y0[:n1])))
    print(f"{name} (n = {model.n}, {kernel}, {integ.name}, h = {integ.h}): max|theta_dot| = {w:.3g} rad/s, "
          f"max|z_dot| = {vz:.3g} m/s, max|q - q0| = {dq:.3g}")
    assert w < 1e-6 and vz < 1e-6


STEADY = {"none": Inputs(), "heave_force": Inputs(heave_force=5000.0),
          "wave": Inputs(wave_elevation=0.5)}


@pytest.mark.parametrize("inputs", list(STEADY))
@pytest.mark.parametrize("name", SCENES)
def test_static_solution_balances_forces_and_is_stable(name: str, inputs: str) -> None:
    """grad V - Q_ext = J^T lambda to 1e-9 of (wet weight) L with the reference gradient, and the
    reduced Hessian of the reference Lagrangian is positive definite; steady inputs included."""
    scene = load_scene(name, NO_FORCING)
    model = scene.model()
    ref = RefLine(scene.params)
    anchored = scene.params.end_condition == "anchored"
    locked = scene.params.heave_locked
    inp = STEADY[inputs]
    if inputs == "heave_force":  # scale the steady force with the line (5 % of its wet weight)
        inp = Inputs(heave_force=0.05 * ref.g * ref.mw.sum())
    q, lam = static_equilibrium(model, inp)
    r = residual(ref, q, lam, anchored, locked, inp)
    ev = np.linalg.eigvalsh(reduced_hessian(ref, q, lam, anchored, locked))
    print(f"{name}, {inputs}: force residual {r:.3g}, smallest reduced-Hessian eigenvalue {ev[0]:.4g}")
    assert r < 1e-9
    assert ev[0] > 0, f"static solution is unstable (eigenvalues {ev[:4]})"


@pytest.mark.parametrize("bending", [True, False], ids=["scene", "no_bending"])
@pytest.mark.parametrize("name", ANCHORED)
def test_static_solver_from_nearby_guesses(name: str, bending: bool) -> None:
    """From initial guesses within 0.02-0.1 rad of the rest state (three shapes), the solver must
    return that rest state or raise StaticsError; returning an unstable stationary point (a link
    flipped by ~3 rad) as "the rest configuration" is a failure."""
    ov = dict(NO_FORCING) if bending else {**NO_FORCING, "joint_springs": False}
    scene = load_scene(name, ov)
    model = scene.model()
    ref = RefLine(scene.params)
    q_s, lam_s = static_equilibrium(model)
    n1 = model.ndof
    shapes = {"sin2pi": np.sin(np.linspace(0, 2 * np.pi, n1)),
              "sinpi": np.sin(np.linspace(0, np.pi, n1)), "ramp": np.linspace(0, 1, n1)}
    bad = []
    for amp in (0.02, 0.05, 0.1):
        for key, shape in shapes.items():
            try:
                q, lam = static_equilibrium(model, q0=q_s + amp * shape)
            except StaticsError:
                continue  # failing loudly is acceptable
            if np.max(np.abs(q - q_s)) > 1e-8:
                ev = np.linalg.eigvalsh(reduced_hessian(ref, q, lam, True, scene.params.heave_locked))
                bad.append(f"guess {amp} x {key}: max|q - q_s| = {np.max(np.abs(q - q_s)):.3g} rad, "
                           f"{int(np.sum(ev < 0))} unstable direction(s), "
                           f"residual {residual(ref, q, lam, True, False, Inputs()):.2g}")
    assert not bad, "static_equilibrium returned other (unstable) stationary points:\n" + "\n".join(bad)


def test_free_end_static_is_vertical_and_carries_the_wet_weight() -> None:
    """Free end, no forcing: the line hangs vertically (all theta = 0) and the heave spring
    carries the wet weight of line and load: k_m z = -g (sum m~_i + m~_c)."""
    scene = load_scene("paper_free_fall", NO_FORCING)
    ref = RefLine(scene.params)
    q, lam = static_equilibrium(scene.model())
    assert np.max(np.abs(q[1:])) < 1e-12 and not lam.any()
    assert q[0] == pytest.approx(-ref.g * (ref.mw.sum() + ref.mcw) / ref.km, rel=1e-9)
