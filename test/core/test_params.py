"""Bad parameters raise :class:`ParameterError` naming the parameter, the value and the range
(merged from test_params and test_verify_params, issue 10).

Reference: the allowed ranges stated in MODEL.md / the CableParams docstring (n integer >= 1;
lengths, masses, diameters, densities > 0; stiffnesses and dampings >= 0; everything finite;
drag model, end condition and stiffness mode from their lists; per-link arrays of length n;
switches true/false). One test per class of bad value; each checks the exception type, its
``name``/``value``/``allowed`` attributes and that the message itself contains the name, the
value and the range (a user reads the message, not the attributes).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cable_sim.core.params import CableParams, ParameterError
from cable_sim.scene.scenes import load_scene


def expect_error(kwargs: dict, name: str, allowed_words: tuple[str, ...], shown: str | None = None):
    """Construct CableParams(**kwargs); require a ParameterError about ``name``.

    The message must contain the parameter name, the value (``shown``, default repr of the value
    given for ``name``) and every word of ``allowed_words`` (the allowed range).
    """
    with pytest.raises(ParameterError) as info:
        CableParams(**kwargs)
    err = info.value
    msg = str(err)
    assert isinstance(err, ValueError)
    assert err.name == name, msg
    assert f"'{name}'" in msg, msg
    if shown is None:
        shown = repr(kwargs[name.split("[")[0]])
    assert shown in msg, msg
    assert "allowed" in msg, msg
    for w in allowed_words:
        assert w in msg and w in err.allowed, (w, msg)
    return err


@pytest.mark.parametrize("n", [0, -1, -60])
def test_n_links_below_one(n: int) -> None:
    """n < 1 is refused with the range 'integer >= 1'."""
    expect_error({"n_links": n}, "n_links", ("integer", ">= 1"))


@pytest.mark.parametrize("n", [2.5, 3.0, "3", True, None, float("nan")])
def test_n_links_not_an_integer(n) -> None:
    """Non-integer n (float, string, bool, None, NaN) is refused, not silently truncated."""
    expect_error({"n_links": n}, "n_links", ("integer", ">= 1"))


def test_n_links_numpy_integer_accepted() -> None:
    """A numpy integer is an integer (ROS/YAML loaders may produce one)."""
    assert CableParams(n_links=np.int64(4)).n_links == 4


@pytest.mark.parametrize(
    "name, value",
    [
        ("total_length", 0.0), ("total_length", -240.0),
        ("platform_mass", 0.0), ("platform_mass", -6000.0),
        ("mass_per_length", 0.0), ("mass_per_length", -1.0),
        ("diameter", 0.0), ("diameter", -0.01),
        ("line_density", 0.0), ("line_density", -7850.0),
        ("water_density", 0.0), ("water_density", -1025.0),
    ],
)
def test_non_positive_length_mass_diameter_density(name: str, value: float) -> None:
    """Lengths, masses, diameters and densities must be > 0."""
    expect_error({name: value}, name, ("> 0",))


@pytest.mark.parametrize("name, value", [("link_lengths", -2.0), ("diameter", 0.0),
                                         ("diameter", -1.5), ("line_density", 0.0),
                                         ("line_density", -1.5)])
def test_non_positive_entry_in_per_link_array(name: str, value: float) -> None:
    """An entry of a per-link array is named with its index."""
    err = expect_error({"n_links": 3, name: (1.0, value, 1.0)}, f"{name}[1]", ("> 0",),
                       shown=repr(value))
    assert err.value == value


@pytest.mark.parametrize(
    "name",
    ["total_length", "diameter", "line_density", "joint_stiffness", "heave_damping", "gravity",
     "water_density", "platform_mass", "current_speed", "anchor_x", "anchor_z", "load_mass",
     "drag_cn", "constraint_stiffness"],
)
def test_nan(name: str) -> None:
    """NaN is refused for every real parameter ('finite')."""
    err = expect_error({name: float("nan")}, name, ("finite",), shown="nan")
    assert math.isnan(err.value)


@pytest.mark.parametrize(
    "name, value",
    [("total_length", math.inf), ("joint_damping", math.inf), ("current_speed", -math.inf),
     ("anchor_z", -math.inf), ("heave_stiffness", math.inf), ("paper_anchor_mass", math.inf),
     ("total_length", -math.inf), ("heave_stiffness", -math.inf), ("anchor_z", math.inf),
     ("current_speed", math.inf)],
)
def test_inf(name: str, value: float) -> None:
    """+-Inf is refused ('finite')."""
    expect_error({name: value}, name, ("finite",), shown="inf")


@pytest.mark.parametrize(
    "name",
    ["joint_stiffness", "joint_damping", "bending_stiffness", "bending_damping", "pin_stiffness",
     "pin_damping", "heave_stiffness", "heave_damping", "paper_drag_gamma", "drag_cn", "drag_ct",
     "load_mass", "load_volume", "gravity"],
)
def test_negative_stiffness_damping_and_other_non_negative(name: str) -> None:
    """Stiffnesses, dampings, drag coefficients, load mass/volume, g must be >= 0."""
    expect_error({name: -1.5}, name, (">= 0",))


@pytest.mark.parametrize(
    "name, value, options",
    [
        ("drag_model", "morrison", ("'none'", "'paper'", "'morison'")),
        ("drag_model", "", ("'none'", "'paper'", "'morison'")),
        ("end_condition", "fixed", ("'free'", "'anchored'", "'paper_anchor'")),
        ("end_condition", None, ("'free'", "'anchored'", "'paper_anchor'")),
        ("stiffness_mode", "EI", ("'per_joint'", "'bending'")),
    ],
)
def test_unknown_choice(name: str, value, options) -> None:
    """Unknown drag model / end condition / stiffness mode lists the allowed choices."""
    expect_error({name: value}, name, ("one of", *options))


@pytest.mark.parametrize(
    "name, value",
    [("diameter", (0.01, 0.01)), ("line_density", [7850.0] * 5), ("link_lengths", (1.0,) * 4),
     ("link_lengths", (1.0, 2.0)), ("diameter", (0.01,) * 4)],
)
def test_wrong_per_link_array_length(name: str, value) -> None:
    """A per-link array for n = 3 must have 3 entries; the message states n."""
    expect_error({"n_links": 3, name: value}, name, ("n_links = 3",))


@pytest.mark.parametrize("value", [1, "true", None, 0.0, "yes", "False"])
@pytest.mark.parametrize("name", ["buoyancy", "heave_locked", "joint_springs", "joint_dampers",
                                  "platform_spring", "platform_damper", "wave_coupling"])
def test_non_bool_switch(name: str, value) -> None:
    """Switches must be real booleans (no truthiness of 1, "true", "False", None)."""
    expect_error({name: value}, name, ("true or false",))


def test_numpy_bool_switch_accepted() -> None:
    """numpy booleans are booleans."""
    assert CableParams(buoyancy=np.bool_(False)).buoyancy is False


def test_anchored_without_free_dof() -> None:
    """An anchored line needs a free degree of freedom (n >= 2, or >= 3 with the top locked)."""
    expect_error({"n_links": 1, "end_condition": "anchored"}, "n_links", ("free degree", ">= 2"))
    expect_error({"n_links": 2, "end_condition": "anchored", "heave_locked": True}, "n_links",
                 ("free degree", ">= 3"))


def test_good_boundary_values_are_accepted() -> None:
    """The limits themselves are legal: the checks are not merely rejecting everything."""
    CableParams(n_links=1)
    CableParams(n_links=2, end_condition="anchored")
    CableParams(n_links=3, end_condition="anchored", heave_locked=True)
    CableParams(joint_stiffness=0.0, pin_stiffness=0.0, heave_damping=0.0, current_speed=-1.0)
    CableParams(n_links=2, link_lengths=(1.0, 2.0))


def test_scene_file_values_are_validated() -> None:
    """A bad value reaching the parameters through a scene file is refused the same way."""
    with pytest.raises(ParameterError, match=r"'n_links' = 0 .*integer >= 1"):
        load_scene("paper_free_fall", {"n_links": 0})
    with pytest.raises(ParameterError, match=r"'diameter' = -0.01 .*> 0"):
        load_scene("paper_free_fall", {"diameter": -0.01})
    with pytest.raises(ParameterError, match=r"'step'"):
        load_scene("paper_free_fall", {"step": 0.0})


def test_valid_defaults_and_replace_revalidate() -> None:
    """The defaults are valid, and replace() validates the changed copy."""
    p = CableParams()
    assert p.n_links == 60 and p.drag_model == "paper"
    with pytest.raises(ParameterError, match="gravity"):
        p.replace(gravity=-9.81)
