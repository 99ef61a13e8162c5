"""The smooth scene of the observed-order tests (test/integrate/test_integrator_order.py,
test/integrate/test_ros34.py): n = 10, Morison drag, released at 60 degrees under a sine heave
force, with each end condition."""

from __future__ import annotations

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


def order_scene(end: str) -> Scene:
    """The smooth scene with end condition ``end`` (a key of :data:`ENDS`)."""
    return load_scene("paper_free_fall", {**SMOOTH, **ENDS[end], "anchor_x": 150.0, "anchor_z": -150.0})
