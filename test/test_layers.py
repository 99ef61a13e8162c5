"""The package's shape, read from the code's imports (issue: layers as folders).

- Layers, lowest first: ``core`` < ``integrate`` < ``scene`` < ``ros`` < ``analysis``. A module
  may import modules of its own layer or of a lower one, never of a higher one.
- Nothing below ``ros`` imports rclpy, ROS message packages, matplotlib or mcap.
- No import circle between the package's modules (every import counts, also one inside a function).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "cable_sim"
LAYERS = ("core", "integrate", "scene", "ros", "analysis")
#: Third-party roots the layers below ``ros`` must not import (ROS, plotting, recording).
FORBIDDEN_BELOW_ROS = {"rclpy", "matplotlib", "mcap", "mcap_ros2", "rosbags", "std_msgs", "sensor_msgs",
                       "geometry_msgs", "visualization_msgs", "diagnostic_msgs", "rosgraph_msgs",
                       "std_srvs", "builtin_interfaces"}


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def _imports(name: str, path: Path) -> set[str]:
    """Absolute names of every module ``path`` imports (relative imports resolved)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    here = name.split(".") if is_pkg else name.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            found.add(mod)
            # ``from pkg import submodule`` imports the submodule too
            found.update(f"{mod}.{a.name}" for a in node.names)
    return found


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    return {m: {i for i in _imports(m, p) if i in mods and i != m} for m, p in mods.items()}


def _layer(mod: str) -> int | None:
    parts = mod.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else None


def test_every_module_lives_in_a_layer():
    stray = [m for m in _modules() if m != "cable_sim" and _layer(m) is None]
    assert not stray, f"modules outside the layer folders {LAYERS}: {stray}"


@pytest.mark.parametrize("mod", sorted(_modules()))
def test_imports_point_down(mod):
    own = _layer(mod)
    if own is None:
        return
    up = sorted(i for i in _graph()[mod] if (_layer(i) or 0) > own)
    assert not up, f"{mod} (layer {LAYERS[own]}) imports higher layers: {up}"


@pytest.mark.parametrize("mod", sorted(m for m in _modules() if (_layer(m) or 0) < LAYERS.index("ros")))
def test_no_ros_plotting_or_mcap_below_ros(mod):
    roots = {i.split(".")[0] for i in _imports(mod, _modules()[mod])}
    bad = sorted(roots & FORBIDDEN_BELOW_ROS)
    assert not bad, f"{mod} imports {bad}; only cable_sim.ros / cable_sim.analysis may"


@pytest.mark.parametrize("mod", sorted(_modules()))
def test_every_package_import_resolves(mod):
    """An import of ``cable_sim.X`` names a module of the package (or a name a module defines):
    a stale path left behind by a move fails here, not only when that line runs."""
    mods = _modules()
    missing = []
    for name in sorted(_imports(mod, mods[mod])):
        if not name.startswith("cable_sim") or name in mods:
            continue
        parent = name.rpartition(".")[0]  # ``from pkg.module import name``: a name, not a module
        if parent not in mods:
            missing.append(name)
    assert not missing, f"{mod} imports modules that do not exist: {missing}"


def test_no_import_circle():
    graph = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                cycles.append(stack[stack.index(n):] + [n])
            elif n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)
    assert not cycles, "import circles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_checker_sees_a_circle_and_an_upward_import(tmp_path, monkeypatch):
    """The checks above can fail: a planted circle and an upward import are found."""
    pkg = tmp_path / "cable_sim"
    for layer in ("core", "scene"):
        (pkg / layer).mkdir(parents=True)
        (pkg / layer / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "core" / "a.py").write_text("from cable_sim.core import b\nfrom cable_sim.scene import s\n")
    (pkg / "core" / "b.py").write_text("def f():\n    from . import a\n")
    (pkg / "scene" / "s.py").write_text("import matplotlib\n")
    monkeypatch.setattr(__import__(__name__), "PKG", pkg)
    with pytest.raises(AssertionError, match="circles"):
        test_no_import_circle()
    with pytest.raises(AssertionError, match="higher layers"):
        test_imports_point_down("cable_sim.core.a")
    with pytest.raises(AssertionError, match="matplotlib"):
        test_no_ros_plotting_or_mcap_below_ros("cable_sim.scene.s")
    (pkg / "scene" / "t.py").write_text("from ..params import X\n")
    with pytest.raises(AssertionError, match="do not exist"):
        test_every_package_import_resolves("cable_sim.scene.t")
