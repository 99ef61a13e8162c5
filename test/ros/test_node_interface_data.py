"""msg_configs/interface.yaml (the interface as data) agrees with the running node.

For every shipped scene, a node in this process must declare exactly the parameters the file
lists (same ROS type, read-only where the file says so, the file's description as the
descriptor's), use the file's defaults for the node settings, and publish / subscribe / serve
exactly the file's topics and services with the file's types (anchor_force only for anchored
ends, seabed_contact only with a seabed, /clock only outside real time).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import rclpy
import yaml
from rclpy.parameter import Parameter
from ros_util import init_context, isolate_ros

from cable_sim.ros.node import CableSimNode

DOMAIN = isolate_ros()
DOC = yaml.safe_load((Path(__file__).resolve().parents[2] / "msg_configs" / "interface.yaml").read_text())
ROS_BUILTIN_PARAMS = {"use_sim_time", "start_type_description_service"}
ROS_BUILTIN_TOPICS = {"/rosout", "/parameter_events"}
TYPES = {Parameter.Type.DOUBLE: "double", Parameter.Type.INTEGER: "integer", Parameter.Type.BOOL: "bool",
         Parameter.Type.STRING: "string", Parameter.Type.DOUBLE_ARRAY: "double_array"}
CASES = [("mooring_line", "realtime"), ("control_experiment", "fast"),
         ("paper_free_fall", "lockstep"), ("paper_anchored_forced", "fast")]


@pytest.fixture(scope="module", params=CASES, ids=[c[0] for c in CASES])
def node(request):
    scene, mode = request.param
    ctx = init_context(DOMAIN)
    n = CableSimNode(context=ctx, parameter_overrides=[
        Parameter("scene", value=scene), Parameter("clock_mode", value=mode),
        Parameter("record", value=False)])
    yield n
    n.close()
    n.destroy_node()
    rclpy.try_shutdown(context=ctx)


def _documented() -> dict[str, tuple[dict, bool]]:
    p = DOC["parameters"]
    out = {k: (v, False) for k, v in p["node"].items()}
    out.update({k: (v, True) for k, v in p["node_read_only"].items()})
    out.update({k: (v, True) for k, v in p["scene"].items()})
    return out


def test_declared_parameters_are_documented_with_type_and_description(node):
    doc = _documented()
    declared = set(node._parameters) - ROS_BUILTIN_PARAMS
    optional = {k for k, (v, _) in doc.items() if "declared" in v}
    assert declared - set(doc) == set(), "declared but not in interface.yaml"
    assert set(doc) - declared - optional == set(), "in interface.yaml but not declared"
    for name in declared:
        entry, read_only = doc[name]
        d = node.describe_parameter(name)
        assert TYPES[Parameter.Type(d.type)] == entry["type"], name
        assert d.read_only == read_only, name
        want = entry["description"]
        if "unit" in entry and name in DOC["parameters"]["scene"]:
            want = f"{want} [{entry['unit']}]"
        assert " ".join(d.description.split()) == " ".join(want.split()), name


def test_node_settings_use_the_documented_defaults(node):
    for name, entry in DOC["parameters"]["node"].items():
        assert node.get_parameter(name).value == entry["default"], name
        d = node.describe_parameter(name)
        r = d.floating_point_range[0]
        assert [r.from_value, r.to_value] == entry["range"], name
    for name in ("control_period", "record_path", "frame_id", "exit_at_end"):
        assert node.get_parameter(name).value == DOC["parameters"]["node_read_only"][name]["default"]


def test_topics_and_services_match(node):
    ns = node.get_namespace()
    pubs = dict(node.get_publisher_names_and_types_by_node(node.get_name(), ns))
    subs = dict(node.get_subscriber_names_and_types_by_node(node.get_name(), ns))
    srvs = dict(node.get_service_names_and_types_by_node(node.get_name(), ns))

    def full(name: str) -> str:
        return name if name.startswith("/") else f"/{name}"

    want_pubs = {full(t["topic"]): [t["type"]] for t in DOC["publications"]}
    if node.sim.model.end == 0:
        want_pubs.pop("/anchor_force")
    if not node.sim.model.seabed:
        want_pubs.pop("/seabed_contact")
    if node.clock_mode == "realtime":
        want_pubs.pop("/clock")
    assert {k: v for k, v in pubs.items() if k not in ROS_BUILTIN_TOPICS} == want_pubs
    assert subs == {full(t["topic"]): [t["type"]] for t in DOC["subscriptions"]}
    own = {k: v for k, v in srvs.items() if not k.startswith(f"/{node.get_name()}/")}
    assert own == {full(s["name"]): [s["type"]] for s in DOC["services"]}
