"""Issue #2: bad parameters raise ParameterError naming the parameter, the value and the range.

One test per class of mistake. Each checks the exception's attributes and that the message
itself carries all three pieces (a user reads the message, not the attributes).
"""

from __future__ import annotations

import math

import pytest

from cable_sim.core.params import CableParams, ParameterError


def _rejects(kw: dict, name: str, value_text: str, allowed_words: tuple[str, ...]) -> ParameterError:
    with pytest.raises(ParameterError) as ei:
        CableParams(**kw)
    err = ei.value
    msg = str(err)
    assert err.name == name, msg
    assert f"'{name}'" in msg, msg
    assert value_text in msg, msg
    for w in allowed_words:
        assert w in err.allowed and w in msg, msg
    return err


def test_n_links_below_one():
    _rejects({"n_links": 0}, "n_links", "0", ("integer", ">= 1"))
    _rejects({"n_links": -3}, "n_links", "-3", ("integer", ">= 1"))


def test_n_links_not_integer():
    _rejects({"n_links": 2.5}, "n_links", "2.5", ("integer",))
    _rejects({"n_links": "10"}, "n_links", "'10'", ("integer",))
    _rejects({"n_links": True}, "n_links", "True", ("integer",))


@pytest.mark.parametrize("name", ["total_length", "diameter", "line_density", "platform_mass",
                                  "water_density"])
@pytest.mark.parametrize("value", [0.0, -1.5])
def test_non_positive_length_diameter_density(name, value):
    _rejects({name: value}, name, repr(value), ("> 0",))
    if name in ("diameter", "line_density"):  # per-link form names the offending index
        _rejects({"n_links": 2, name: (1.0, value)}, f"{name}[1]", repr(value), ("> 0",))


@pytest.mark.parametrize("name", ["total_length", "joint_stiffness", "anchor_x", "gravity"])
def test_nan(name):
    err = _rejects({name: math.nan}, name, "nan", ("finite",))
    assert math.isnan(err.value)


@pytest.mark.parametrize("name", ["total_length", "heave_stiffness", "anchor_z", "current_speed"])
@pytest.mark.parametrize("value", [math.inf, -math.inf])
def test_inf(name, value):
    _rejects({name: value}, name, repr(value), ("finite",))


@pytest.mark.parametrize("name", ["joint_stiffness", "bending_stiffness", "pin_stiffness",
                                  "heave_stiffness", "joint_damping", "heave_damping"])
def test_negative_stiffness_or_damping(name):
    _rejects({name: -104.7}, name, "-104.7", (">= 0",))


def test_unknown_drag_model():
    _rejects({"drag_model": "quadratic"}, "drag_model", "'quadratic'",
             ("'none'", "'paper'", "'morison'"))


def test_unknown_end_condition():
    _rejects({"end_condition": "fixed"}, "end_condition", "'fixed'",
             ("'free'", "'anchored'", "'paper_anchor'"))


def test_wrong_number_of_per_link_lengths():
    _rejects({"n_links": 3, "link_lengths": (1.0, 2.0)}, "link_lengths", "(1.0, 2.0)",
             ("n_links = 3",))
    _rejects({"n_links": 3, "diameter": (0.01, 0.01, 0.01, 0.01)}, "diameter", "0.01",
             ("n_links = 3",))


def test_non_positive_per_link_length_names_the_index():
    _rejects({"n_links": 3, "link_lengths": (1.0, -2.0, 1.0)}, "link_lengths[1]", "-2.0", ("> 0",))


@pytest.mark.parametrize("name", ["heave_locked", "buoyancy", "joint_springs", "joint_dampers",
                                  "platform_spring", "platform_damper", "wave_coupling"])
@pytest.mark.parametrize("value", [1, "true", None])
def test_non_bool_switch(name, value):
    _rejects({name: value}, name, repr(value), ("true or false",))


def test_anchored_with_no_free_dof():
    # heave free: n + 1 - 2 dof -> n = 1 leaves none
    _rejects({"n_links": 1, "end_condition": "anchored"}, "n_links", "1", ("free degree", ">= 2"))
    # heave locked: n - 2 dof -> n = 2 leaves none
    _rejects({"n_links": 2, "end_condition": "anchored", "heave_locked": True}, "n_links", "2",
             ("free degree", ">= 3"))


def test_good_boundary_values_are_accepted():
    """The limits themselves are legal: the checks are not merely rejecting everything."""
    CableParams(n_links=1)
    CableParams(n_links=2, end_condition="anchored")
    CableParams(n_links=3, end_condition="anchored", heave_locked=True)
    CableParams(joint_stiffness=0.0, pin_stiffness=0.0, heave_damping=0.0, current_speed=-1.0)
    CableParams(n_links=2, link_lengths=(1.0, 2.0))
