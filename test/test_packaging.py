"""Packaging (issue 9, item 4): a plain ``pip install`` gives a node that starts and runs.

A fresh virtual environment gets only the ROS 2 Jazzy wheels (the Makefile's ``ROS_PKGS`` pins),
then ``pip install <copy of the repo>`` *with* its dependencies, exactly as a user would. The
installed ``cable_sim_node`` (started by ``ros_util.start_node`` with that venv's executable) then
runs a short scene in fast clock mode, exits by itself with code 0 and leaves a non-empty MCAP. A
missing ``install_requires`` entry fails here with ``ModuleNotFoundError``.

The node runs the dense kernel here: in a fresh venv the compiled kernel would first be compiled
by numba (about 60 s, a test of numba rather than of the packaging); that the compiled modules
import there (numba, llvmlite declared) is checked on its own.

Slow (pip resolves and installs ~40 wheels, about 40 s).
"""

from __future__ import annotations

import os
import random
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from ros_util import kill_and_reap, popen, start_node

REPO = Path(__file__).resolve().parent.parent


def _ros_pins() -> list[str]:
    """The ``ROS_PKGS`` pins of the Makefile (one source of truth for the ROS wheels)."""
    text = (REPO / "Makefile").read_text().replace("\\\n", " ")
    m = re.search(r"^ROS_PKGS\s*:?=\s*(.+)$", text, re.MULTILINE)
    assert m, "Makefile has no ROS_PKGS line"
    pins = m.group(1).split()
    assert pins and all(p.startswith("ros-jazzy-") for p in pins), pins
    return pins


def _copy_sources(dst: Path) -> Path:
    """Copy what a clone would hold (tracked + untracked, not ignored files): no .venv, no build."""
    listed = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=REPO, capture_output=True, check=True,
    ).stdout.decode().split("\0")
    for rel in filter(None, listed):
        src = REPO / rel
        if src.is_file():
            (dst / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / rel)
    return dst


def _run(cmd: list[str], timeout: float, **kw) -> subprocess.CompletedProcess:
    """Run ``cmd`` to completion (default signals in the child; killed and reaped on timeout)."""
    proc = popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    try:
        out, _ = proc.communicate(timeout=timeout)
        return subprocess.CompletedProcess(cmd, proc.returncode, out, None)
    finally:
        kill_and_reap(proc)


@pytest.mark.timeout(900)
def test_pip_install_into_fresh_venv_runs_node(tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    src = _copy_sources(tmp_path / "src")
    r = _run([sys.executable, "-m", "venv", str(venv)], timeout=120)
    assert r.returncode == 0, r.stdout
    py = str(venv / "bin" / "python")
    pip = [py, "-m", "pip", "install", "-q", "--disable-pip-version-check", "--no-compile"]
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}

    r = _run(pip + _ros_pins(), timeout=600, env=env)
    assert r.returncode == 0, r.stdout[-4000:]
    r = _run(pip + [str(src)], timeout=600, env=env)  # plain install, with dependencies
    assert r.returncode == 0, r.stdout[-4000:]

    # The scene comes from the installed share/ (checks data_files too).
    scene = venv / "share" / "cable_sim" / "config" / "mooring_line.yaml"
    assert scene.is_file(), "config not installed under share/cable_sim/config"
    bag = tmp_path / "x.mcap"
    env.update(AMENT_PREFIX_PATH=str(venv), RMW_IMPLEMENTATION="rmw_fastrtps_cpp",
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(random.randint(110, 200)),
               PATH=f"{venv / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}")
    r = _run([py, "-c", "import cable_sim.core.kernel, cable_sim.integrate.implicit, "
                        "cable_sim.integrate.compiled_steppers"], timeout=300, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stdout[-4000:]
    node = start_node(scene, "kernel:=dense", "clock_mode:=fast", "duration:=1.0", "exit_at_end:=true",
                      f"record_path:={bag}", executable=venv / "bin" / "cable_sim_node", env=env,
                      domain=int(env["ROS_DOMAIN_ID"]), cwd=tmp_path)
    try:
        out, _ = node.communicate(timeout=300)
    finally:
        kill_and_reap(node)
    r = subprocess.CompletedProcess(node.args, node.returncode, out, None)
    assert r.returncode == 0, r.stdout[-4000:]
    assert "ModuleNotFoundError" not in r.stdout
    assert bag.is_file() and bag.stat().st_size > 0, r.stdout[-4000:]
    assert bag.read_bytes()[:8] == b"\x89MCAP0\r\n"
    # the replay tool too (mcap reader, mcap_ros2 decoder, matplotlib)
    png = tmp_path / "t.png"
    r = _run([str(venv / "bin" / "cable_sim_replay"), str(bag), "--tension", str(png)], timeout=300,
             env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stdout[-4000:]
    assert "scene         mooring_line" in r.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
