"""Helpers for the node tests: isolated ROS domain, node subprocess, spinning until a condition."""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import sys
import time
from pathlib import Path

import rclpy

REPO = Path(__file__).resolve().parent.parent
CONFIG = REPO / "config"


_USED: set[int] = set()


def isolate_ros() -> int:
    """Pick a random ROS domain for a test module and keep discovery on localhost.

    Every module of one pytest process gets its own domain; pass it to :func:`start_node` (the
    environment variable only holds the last module's choice once all modules are collected).
    """
    domain = random.choice([d for d in range(10, 101) if d not in _USED])
    _USED.add(domain)
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)
    os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    return domain


def node_executable() -> str:
    """The installed console script (the venv's bin, next to this interpreter)."""
    exe = Path(sys.executable).parent / "cable_sim_node"
    if exe.exists():
        return str(exe)
    found = shutil.which("cable_sim_node")
    assert found, "cable_sim_node console script is not installed (run `make venv`)"
    return found


def start_node(scene: str, *overrides: str, domain: int | None = None,
               cwd: Path | None = None) -> subprocess.Popen:
    """Start cable_sim_node as a separate process in ROS domain ``domain`` (scene file + -p)."""
    args = [node_executable(), "--ros-args", "--params-file", str(CONFIG / f"{scene}.yaml")]
    for o in overrides:
        args += ["-p", o]
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain if domain is not None else os.environ["ROS_DOMAIN_ID"]),
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    return subprocess.Popen(args, cwd=cwd, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)


def spin_until(executor, cond, timeout: float) -> bool:
    """Spin ``executor`` until ``cond()`` is true or ``timeout`` seconds pass."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.01)
        if cond():
            return True
    return cond()


def stop(proc: subprocess.Popen, sig: int, timeout: float = 20.0) -> tuple[int, str]:
    """Send ``sig`` and return (exit code, output)."""
    proc.send_signal(sig)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
        return -999, out
    return proc.returncode, out


def diag_values(msg) -> dict[str, str]:
    """Key/values of the first status of a DiagnosticArray."""
    return {kv.key: kv.value for kv in msg.status[0].values}


def init_context(domain: int):
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    return ctx
