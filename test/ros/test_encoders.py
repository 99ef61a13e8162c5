"""The node's template-encoded outputs == the exact serialiser's bytes of the messages the interface's
builders give (cable_sim.ros.messages), for an anchored line on a seabed (touchdown marker added and
deleted), a free-end line, several states and stamps."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("rclpy")

from cable_sim.ros import messages as M  # noqa: E402
from cable_sim.ros.encoders import OutputEncoders  # noqa: E402
from cable_sim.ros.recorder.cdr import serialize  # noqa: E402
from cable_sim.scene.scenes import load_scene  # noqa: E402
from cable_sim.scene.simulation import Simulation  # noqa: E402


@pytest.mark.parametrize("scene", ["mooring_line", "control_experiment"])
def test_encoded_outputs_equal_the_built_messages(scene: str) -> None:
    sim = Simulation(load_scene(scene))
    model = sim.model
    enc = OutputEncoders(model, "map")
    checked_delete = False
    for k, stamp in enumerate((0, 20_000_000, 1_700_000_000_123)):
        out = sim.outputs()
        if k == 2 and model.seabed:  # lift the whole line above the bed: touchdown marker DELETE
            pos = out.joint_positions.copy()
            pos[:, 1] = model.seabed_z + 1.0 + np.abs(pos[:, 1] - pos[:, 1].min())
            out = dataclasses.replace(out, joint_positions=pos)
        sb = M.seabed_contact_values(out, model)
        if sb is not None and k == 2:
            sb = np.array([0.0, float(out.joint_positions[-1, 0]), 0.0, 0.0])
            checked_delete = True
        pos, vel, eff = M.joint_state_arrays(out)
        assert enc.joint_state(pos, vel, eff, stamp) == serialize(M.build_joint_state(out, stamp, "map"))
        assert enc.markers(M.marker_values(out, model, sb), stamp) == serialize(
            M.build_markers(out, model, stamp, "map", seabed=sb))
        assert enc.wrench(-out.fairlead_force, stamp) == serialize(
            M.build_wrench(-out.fairlead_force, stamp, "map"))
        assert enc.line_tension(out.axial_tension) == serialize(M.build_float_array(out.axial_tension))
        if sb is not None:
            assert enc.seabed_contact(sb) == serialize(M.build_seabed_contact(sb))
        sim.run_until(sim.t + 0.5)
    assert checked_delete == bool(model.seabed)
