"""Issue 11, item 6 (physics part): the default scene (mooring_line: seabed and added mass on)
keeps its chain above the seabed minus 5 cm through 60 s of its wave, at its own settings
(compiled kernel, RK4, 10 ms), while a part of it stays laid on the bed; and the same run without
the seabed would pass through the floor (the issue's bug), so the check has teeth."""

from __future__ import annotations

import numpy as np

from cable_sim.core import dynamics, seabed
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation


def _run(overrides: dict, seconds: float = 60.0) -> tuple[float, float, float]:
    sim = Simulation(load_scene("mooring_line", overrides))
    model, k = sim.model, sim.model.ndof
    lowest, laid_min, laid_max = np.inf, np.inf, 0.0
    for _ in range(int(round(seconds / 0.1))):
        sim.run_until(sim.t + 0.1 + 1e-9)
        q = sim.y[:k]
        lowest = min(lowest, dynamics.joint_positions(model, q)[:, 1].min())
        if model.seabed:
            laid = seabed.seabed_outputs(model, q, sim.y[k:]).laid_length
            laid_min, laid_max = min(laid_min, laid), max(laid_max, laid)
    return lowest, laid_min, laid_max


def test_default_scene_stays_on_top_of_the_seabed() -> None:
    zb = load_scene("mooring_line").params.seabed_z()
    lowest, laid_min, laid_max = _run({})
    print(f"mooring_line 60 s: lowest joint {lowest - zb:+.4f} m from the seabed, laid length "
          f"{laid_min:.1f}..{laid_max:.1f} m")
    assert lowest > zb - 0.05
    assert laid_min > 50.0
    off, _, _ = _run({"seabed": False}, seconds=5.0)
    assert off < zb - 5.0
