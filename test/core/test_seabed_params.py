"""Issue 11, bad input: seabed and added-mass parameters are validated with errors that name the
parameter, the value and the allowed range; switched-off terms leave the model as it was."""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core import dynamics
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams, ParameterError

ANCHORED = dict(end_condition="anchored", anchor_x=100.0, anchor_z=-100.0, n_links=10)


@pytest.mark.parametrize("kw,name,value", [
    (dict(ANCHORED, seabed=True, seabed_depth=5.0), "seabed_depth", 5.0),  # above the fairlead
    (dict(ANCHORED, seabed=True, seabed_depth=-120.0), "anchor_z", -100.0),  # anchor above the bed
    (dict(ANCHORED, seabed=True, seabed_stiffness=-1.0e4), "seabed_stiffness", -1.0e4),
    (dict(ANCHORED, seabed=True, seabed_damping=-1.0), "seabed_damping", -1.0),
    (dict(ANCHORED, seabed=True, seabed_friction_axial=-0.1), "seabed_friction_axial", -0.1),
    (dict(ANCHORED, seabed=True, seabed_friction_speed=0.0), "seabed_friction_speed", 0.0),
    (dict(seabed=True), "seabed_depth", None),  # a free end needs a depth
    (dict(added_mass_cn=-1.0), "added_mass_cn", -1.0),
    (dict(seabed="yes"), "seabed", "yes"),
])
def test_bad_seabed_input_names_parameter_value_and_range(kw, name, value) -> None:
    with pytest.raises(ParameterError) as err:
        CableParams(**kw)
    assert err.value.name == name and err.value.value == value
    msg = str(err.value)
    assert name in msg and repr(value) in msg and "allowed" in msg


def test_seabed_defaults_to_anchor_depth_and_terms_are_listed() -> None:
    m = CableModel.from_params(CableParams(**ANCHORED, seabed=True, added_mass=True))
    assert m.seabed_z == -100.0
    assert {"seabed", "added_mass"} <= set(m.terms())
    assert "seabed_friction" not in m.terms()
    off = CableModel.from_params(CableParams(**ANCHORED))
    assert not {"seabed", "added_mass"} & set(off.terms())


def test_switched_off_terms_change_nothing() -> None:
    """Seabed and added mass off (the default), however their other parameters are set: the
    dense dynamics are bit-identical to a line without those parameters."""
    rng = np.random.default_rng(0)
    base = CableModel.from_params(CableParams(**ANCHORED, drag_model="morison"))
    other = CableModel.from_params(CableParams(**ANCHORED, drag_model="morison", seabed_depth=-100.0,
                                               seabed_stiffness=3e6, added_mass_cn=2.0))
    q, qd = rng.normal(size=11), rng.normal(size=11)
    a0, l0 = dynamics.forward_dynamics(base, q, qd)
    a1, l1 = dynamics.forward_dynamics(other, q, qd)
    assert np.array_equal(a0, a1) and np.array_equal(l0, l1)
    assert dynamics.total_energy(base, q, qd) == dynamics.total_energy(other, q, qd)
