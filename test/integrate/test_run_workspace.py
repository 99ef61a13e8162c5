"""The compiled runs reuse their scratch from step to step: a run of N steps in one compiled call
must end where N one-step calls (fresh scratch each) end, for every compiled scheme on a free
line (paper drag), an anchored line on a seabed (Morison drag, added mass) and the paper's
heavy-load anchor emulation."""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.scene.scenes import load_scene

SCENES = {
    "free_paper": ("paper_free_fall", {"n_links": 9}),
    "moored_seabed": ("mooring_line", {"n_links": 9}),
    "heavy_load": ("paper_anchored_forced", {"n_links": 9, "end_condition": "paper_anchor"}),
}
SCHEMES = {"rk4": 2e-4, "symplectic_euler": 1e-4, "implicit_euler": 5e-3, "rosenbrock2": 5e-3,
           "ros34pw2": 1e-2}
STEPS = 12


@pytest.mark.parametrize("scheme", sorted(SCHEMES))
@pytest.mark.parametrize("scene", sorted(SCENES))
def test_one_call_equals_single_steps(scene: str, scheme: str) -> None:
    name, over = SCENES[scene]
    sc = load_scene(name, over)
    h = SCHEMES[scheme]
    y0 = sc.initial_state()
    n1 = y0.size // 2
    y0[n1 + 1:] += 0.05 * np.sin(np.arange(n1 - 1))  # set it moving (from rest when static)
    whole = sc.integrator(sc.system(), scheme, h)
    assert whole.compiled
    y_run = whole.advance(0.0, y0, STEPS * h)
    assert whole.nsteps == STEPS
    single = sc.integrator(sc.system(), scheme, h)
    y = y0
    for k in range(STEPS):
        y = single.step(k * h, y, h)
    scale = np.linalg.norm(y_run)
    assert np.linalg.norm(y - y_run) <= 1e-12 * scale
    assert np.linalg.norm(y_run - y0) > 1e-9 * scale  # the state moved
