"""The smooth scene of the observed-order tests (test/integrate/test_integrator_order.py,
test/integrate/test_ros34.py, test_ros34prw.py, test_radau.py): n = 10, Morison drag, released at
60 degrees under a sine heave force, with each end condition; its DOP853 reference (computed once per test
session), the joint-position error the tests compare with, and a scheme's observed order over a
step ladder."""

from __future__ import annotations

from functools import cache

import numpy as np

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.integrate import ScipyIntegrator, make_integrator
from cable_sim.scene.scenes import Scene, load_scene

SMOOTH = dict(
    n_links=10, drag_model="morison", initial_state="angle", initial_angle_deg=60.0,
    heave_force_source="sine", heave_force_amplitude=20000.0, heave_force_period=3.0,
    kernel="fast",
)
ENDS = {
    "free": {},
    "anchored": {"end_condition": "anchored", "initial_state": "static"},
    "paper_anchor": {"end_condition": "paper_anchor", "initial_state": "static"},
}


def order_scene(end: str, **overrides) -> Scene:
    """The smooth scene with end condition ``end`` (a key of :data:`ENDS`) and further scene
    parameters ``overrides`` (e.g. ``drag_model="none"``)."""
    return load_scene("paper_free_fall", {**SMOOTH, **ENDS[end], "anchor_x": 150.0, "anchor_z": -150.0,
                                          **overrides})


def order_case(end: str) -> tuple[Scene, CableModel, np.ndarray]:
    """(scene, model, initial state) of :func:`order_scene`."""
    scene = order_scene(end)
    model = scene.model()
    return scene, model, scene.initial_state(model)


@cache
def dop853_reference(end: str, horizon: float) -> np.ndarray:
    """The state at ``horizon`` s of :func:`order_case` by DOP853 at rtol = atol = 1e-13 (the
    same for every test of a session: treat as read-only)."""
    scene, model, y0 = order_case(end)
    ref = ScipyIntegrator(scene.system(model=model), "DOP853", rtol=1e-13, atol=1e-13)
    return ref.advance(0.0, y0, horizon)


def reference_cases(horizon: float, **overrides) -> dict[str, tuple]:
    """Per end condition: (scene, model, initial state, DOP853 end state at ``horizon`` at
    rtol = atol = 1e-13) of :func:`order_scene` with ``overrides``."""
    out = {}
    for end in ENDS:
        scene = order_scene(end, **overrides)
        model = scene.model()
        y0 = scene.initial_state(model)
        ref = ScipyIntegrator(scene.system(model=model), "DOP853", rtol=1e-13, atol=1e-13)
        out[end] = (scene, model, y0, ref.advance(0.0, y0, horizon))
    return out


def observed_order(name: str, scene: Scene, model: CableModel, y0: np.ndarray, y_ref: np.ndarray,
                   hs: np.ndarray, horizon: float, **kwargs) -> tuple[np.ndarray, float]:
    """Errors of integrator ``name`` (``kwargs`` to :func:`make_integrator`) at ``horizon`` against
    the end state ``y_ref`` (max over the state's entries) for each step of ``hs``, and the slope
    of log(error) against log(h)."""
    errs = []
    for h in hs:
        integ = make_integrator(name, scene.system(model=model), float(h), **kwargs)
        errs.append(float(np.max(np.abs(integ.advance(0.0, y0, horizon) - y_ref))))
    errs = np.array(errs)
    return errs, float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


def max_joint_position_error(model: CableModel, ys, ys_ref) -> float:
    """Largest distance [m] between the joint positions of paired states of ``ys`` and ``ys_ref``."""
    n1 = model.ndof
    return max(float(np.max(np.linalg.norm(dynamics.joint_positions(model, a[:n1])
                                           - dynamics.joint_positions(model, b[:n1]), axis=1)))
               for a, b in zip(ys, ys_ref, strict=True))
