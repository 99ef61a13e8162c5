"""launch/cable_sim.launch.py, tested without ROS 2's launch packages (not installable here).

(a) it parses and imports only launch/launch_ros names that exist; (b) every executable it names
is a console script of this package (setup.py) or a well-known ROS executable; (c) the files it
refers to are installed (setup.py data_files, and the venv's share/ after ``make venv``); (d) its
arguments and their descriptions are in the README's launch section. Then
``generate_launch_description()`` runs against small stand-ins for launch/launch_ros that record
what they are given, and the recorded node actions are evaluated for given arguments: the node gets
the scene's installed parameter file, robot_state_publisher the output of the installed
``cable_sim_urdf`` on that same file (run here, read back by yourdfpy).
"""

from __future__ import annotations

import ast
import importlib.util
import io
import os
import re
import shlex
import subprocess
import sys
import types
from pathlib import Path

import pytest
import yourdfpy
from ros_util import default_signals

REPO = Path(__file__).resolve().parents[2]
LAUNCH = REPO / "launch" / "cable_sim.launch.py"
#: Executables of other ROS packages the launch file may start.
ROS_EXECUTABLES = {("robot_state_publisher", "robot_state_publisher"), ("foxglove_bridge", "foxglove_bridge")}
#: launch / launch_ros names that exist in ROS 2 Jazzy (the ones the stand-ins provide).
KNOWN_API = {
    "launch": {"LaunchDescription"},
    "launch.actions": {"DeclareLaunchArgument"},
    "launch.conditions": {"IfCondition"},
    "launch.substitutions": {"Command", "LaunchConfiguration"},
    "launch_ros.actions": {"Node"},
    "launch_ros.parameter_descriptions": {"ParameterValue"},
    "launch_ros.substitutions": {"FindPackagePrefix", "FindPackageShare"},
}


def _setup_py() -> ast.Module:
    return ast.parse((REPO / "setup.py").read_text())


def _console_scripts() -> dict[str, str]:
    """name -> module:function of setup.py's console_scripts (read from its syntax tree)."""
    for node in ast.walk(_setup_py()):
        if isinstance(node, ast.Dict):
            for k, v in zip(node.keys, node.values, strict=True):
                if isinstance(k, ast.Constant) and k.value == "console_scripts":
                    return dict(s.split(" = ") for s in ast.literal_eval(v))
    raise AssertionError("setup.py has no console_scripts")


def _data_files() -> dict[str, list[str]]:
    """share destination -> installed repository files, from setup.py's data_files."""
    src = (REPO / "setup.py").read_text()
    out: dict[str, list[str]] = {}
    for dest, pattern in re.findall(r'\(f"share/\{PACKAGE\}([^"]*)", (?:glob\()?\[?"([^"]+)"', src):
        files = sorted(str(p.relative_to(REPO)) for p in REPO.glob(pattern))
        out.setdefault("share/cable_sim" + dest, []).extend(files)
    return out


# ---------------------------------------------------------------- (a) (b) (c) from the source


def test_parses_and_imports_only_known_launch_api() -> None:
    tree = ast.parse(LAUNCH.read_text(), filename=str(LAUNCH))
    funcs = [n.name for n in tree.body if isinstance(n, ast.FunctionDef)]
    assert "generate_launch_description" in funcs
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            names = {a.name for a in node.names}
            assert node.module in KNOWN_API, f"unexpected import from {node.module}"
            assert names <= KNOWN_API[node.module], f"{node.module}: {names - KNOWN_API[node.module]}"
        assert not isinstance(node, ast.Import), "plain imports: only launch/launch_ros names are allowed"


def _node_calls(tree: ast.Module) -> list[dict[str, object]]:
    calls = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "Node":
            calls.append({k.arg: ast.literal_eval(k.value) for k in node.keywords
                          if k.arg in ("package", "executable")})
    return calls


def test_every_executable_is_installed_or_well_known() -> None:
    tree = ast.parse(LAUNCH.read_text())
    calls = _node_calls(tree)
    assert len(calls) == 3
    scripts = _console_scripts()
    for c in calls:
        assert (c["package"] == "cable_sim" and c["executable"] in scripts) or (
            (c["package"], c["executable"]) in ROS_EXECUTABLES), c
    # executables run by path (Command): <prefix>/lib/cable_sim/<console script>
    text = LAUNCH.read_text()
    for exe in re.findall(r'"/lib/cable_sim/([A-Za-z0-9_]+)"', text):
        assert exe in scripts, exe
    assert "cable_sim_urdf" in re.findall(r'"/lib/cable_sim/([A-Za-z0-9_]+)"', text)
    assert scripts["cable_sim_urdf"] == "cable_sim.ros.urdf_cli:main"
    # setup.cfg puts console scripts in lib/cable_sim, where the launch file looks for them
    assert "install_scripts=$base/lib/cable_sim" in (REPO / "setup.cfg").read_text()


def test_files_are_installed_in_share() -> None:
    data = _data_files()
    assert "launch/cable_sim.launch.py" in data["share/cable_sim/launch"]
    default_scene = dict((a[0], a[1]) for a in _arguments_literal())["scene"]
    assert f"config/{default_scene}.yaml" in data["share/cable_sim/config"]
    # and in the venv's install (make venv), where the stand-ins below resolve FindPackageShare
    share = Path(sys.prefix) / "share" / "cable_sim"
    assert (share / "launch" / "cable_sim.launch.py").is_file(), "run make venv"
    assert (share / "config" / f"{default_scene}.yaml").is_file()


def _arguments_literal() -> list[tuple[str, str, str]]:
    tree = ast.parse(LAUNCH.read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", None) == "ARGUMENTS":
            return list(ast.literal_eval(node.value))
    raise AssertionError("no ARGUMENTS table")


# ---------------------------------------------------------------- stand-ins for launch/launch_ros


class _Recorded:
    """Base of the stand-ins: keeps the positional and keyword arguments."""

    def __init__(self, *args, **kwargs) -> None:
        self.args, self.kwargs = args, kwargs

    def __repr__(self) -> str:
        return f"{type(self).__name__}{self.args}{self.kwargs}"


def _stub_modules() -> dict[str, types.ModuleType]:
    mods = {}
    for mod, names in KNOWN_API.items():
        m = types.ModuleType(mod)
        for name in names:
            setattr(m, name, type(name, (_Recorded,), {}))
        mods[mod] = m
    mods["launch_ros"] = types.ModuleType("launch_ros")
    return mods


@pytest.fixture(scope="module")
def description():
    """generate_launch_description() run against the stand-ins (sys.modules restored after)."""
    stubs = _stub_modules()
    saved = {k: sys.modules.get(k) for k in stubs}
    sys.modules.update(stubs)
    try:
        spec = importlib.util.spec_from_file_location("cable_sim_launch_under_test", LAUNCH)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        ld = module.generate_launch_description()
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    assert type(ld).__name__ == "LaunchDescription"
    return ld.args[0]


def _resolve(sub, config: dict[str, str]):
    """Evaluate a recorded substitution as launch would, with the venv as the install prefix."""
    kind = type(sub).__name__
    if isinstance(sub, str):
        return sub
    if isinstance(sub, (list, tuple)):
        return "".join(_resolve(s, config) for s in sub)
    if kind == "LaunchConfiguration":
        return config[sub.args[0]]
    if kind in ("FindPackageShare", "FindPackagePrefix"):
        assert sub.args == ("cable_sim",), sub
        prefix = Path(sys.prefix)
        return str(prefix / "share" / "cable_sim") if kind == "FindPackageShare" else str(prefix)
    if kind == "Command":
        return ("command", _resolve(sub.args[0], config))
    if kind == "ParameterValue":
        return (sub.kwargs["value_type"], _resolve(sub.args[0], config))
    if kind == "IfCondition":
        return _resolve(sub.args[0], config).lower() == "true"
    raise AssertionError(f"unexpected substitution {sub!r}")


def _nodes(description) -> dict[str, _Recorded]:
    return {a.kwargs["executable"]: a for a in description if type(a).__name__ == "Node"}


def _config(description, **given: str) -> dict[str, str]:
    args = [a for a in description if type(a).__name__ == "DeclareLaunchArgument"]
    return {a.args[0]: given.get(a.args[0], a.kwargs["default_value"]) for a in args}


def test_arguments_are_declared_and_documented_in_the_readme(description) -> None:
    args = {a.args[0]: a.kwargs for a in description if type(a).__name__ == "DeclareLaunchArgument"}
    assert set(args) == {"scene", "namespace", "frame_prefix", "record", "use_foxglove", "foxglove_port"}
    assert [(n, k["default_value"], k["description"]) for n, k in args.items()] == _arguments_literal()
    readme = (REPO / "README.md").read_text()
    sections = re.findall(r"^#+ [^\n]*launch[^\n]*$(.*?)(?=^#+ |\Z)", readme, re.S | re.M | re.I)
    assert sections, "README has no section with 'launch' in its heading"
    section = "\n".join(sections)
    for name, kw in args.items():
        row = next((line for line in section.splitlines()
                    if line.startswith("|") and f"`{name}`" in line), None)
        assert row is not None, f"launch argument {name} is not in the README's launch table"
        assert kw["description"] in row, f"{name}: description differs from the launch file's"
        assert f"`{kw['default_value']}`" in row or (kw["default_value"] == "" and "(empty)" in row), name


def test_node_gets_the_scene_file_namespace_and_record(description) -> None:
    cfg = _config(description, scene="paper_free_fall", namespace="leg2", frame_prefix="leg2/",
                  record="false")
    node = _nodes(description)["cable_sim_node"].kwargs
    assert node["package"] == "cable_sim"
    assert _resolve(node["namespace"], cfg) == "leg2"
    params_file, overrides = node["parameters"]
    path = Path(_resolve(params_file, cfg))
    assert path == Path(sys.prefix) / "share" / "cable_sim" / "config" / "paper_free_fall.yaml"
    assert path.is_file()
    assert {k: _resolve(v, cfg) for k, v in overrides.items()} == {
        "record": (bool, "false"), "frame_id": (str, "leg2/world")}
    # defaults: the mooring line, no namespace, frames world...
    cfg0 = _config(description)
    assert Path(_resolve(params_file, cfg0)).name == "mooring_line.yaml"
    assert _resolve(overrides["frame_id"], cfg0) == (str, "world")
    assert _resolve(overrides["record"], cfg0) == (bool, "true")


def test_robot_state_publisher_gets_the_urdf_of_the_same_scene(description) -> None:
    cfg = _config(description, scene="paper_anchored_forced", namespace="leg2", frame_prefix="leg2/")
    nodes = _nodes(description)
    rsp = nodes["robot_state_publisher"].kwargs
    node = nodes["cable_sim_node"].kwargs
    assert _resolve(rsp["namespace"], cfg) == _resolve(node["namespace"], cfg) == "leg2"
    (params,) = rsp["parameters"]
    value_type, (kind, command) = _resolve(params["robot_description"], cfg)
    assert (value_type, kind) == (str, "command")
    assert _resolve(params["frame_prefix"], cfg) == (str, "leg2/")
    argv = shlex.split(command)
    assert argv[0] == os.path.join(sys.prefix, "lib", "cable_sim", "cable_sim_urdf")
    assert argv[1:] == [_resolve(node["parameters"][0], cfg)]
    # the venv installs console scripts in bin/ (a colcon install: lib/cable_sim/): run that one
    exe = Path(sys.executable).parent / "cable_sim_urdf"
    r = subprocess.run([str(exe), *argv[1:]], capture_output=True, text=True, timeout=120,
                       preexec_fn=default_signals, check=False)
    assert r.returncode == 0, r.stderr
    robot = yourdfpy.URDF.load(io.StringIO(r.stdout), build_scene_graph=False, load_meshes=False)
    assert robot.robot.name == "cable_sim_paper_anchored_forced"
    assert len(robot.actuated_joint_names) == 1 + 60


def test_foxglove_bridge_only_when_asked(description) -> None:
    fox = _nodes(description)["foxglove_bridge"].kwargs
    assert _resolve(fox["condition"], _config(description)) is False
    assert _resolve(fox["condition"], _config(description, use_foxglove="true")) is True
    (params,) = fox["parameters"]
    assert _resolve(params["port"], _config(description)) == (int, "8765")
    assert "namespace" not in fox  # one bridge serves every leg
