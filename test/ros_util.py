"""Helpers for the node tests: isolated ROS domain, node subprocess, spinning until a condition.

Every process a test starts goes through :func:`popen` (or :func:`start_node`, which uses it):

- the child starts with the default SIGINT/SIGTERM dispositions and an empty signal mask, even
  when pytest itself runs with SIGINT ignored (a background job of a non-interactive shell, e.g.
  ``(trap '' INT; make test)``): SIG_IGN is inherited across exec, and a Python child that starts
  with SIGINT ignored installs no KeyboardInterrupt handler, so a test's SIGINT would do nothing;
- on Linux the child gets SIGKILL when the pytest process dies (``PR_SET_PDEATHSIG``), so not
  even a killed test run leaves it behind. Linux ties this to the *thread* that started the
  child: a process started from a helper thread is killed when that thread ends, so such a
  thread must wait for its process (see test_recorder_clash);
- it is registered, and :func:`reap_all` kills and reaps whatever is still running: the autouse
  fixtures in ``conftest.py`` call it after every test (for the processes that test started;
  a module-scoped fixture's node lives on for its module and stops in its own ``finally``) and
  at the end of the session (for everything). :func:`node_process` is the context-manager form
  for one node.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import rclpy
import yaml

REPO = Path(__file__).resolve().parent.parent
CONFIG = REPO / "config"


_USED: set[int] = set()


def isolate_ros() -> int:
    """Pick a random ROS domain for a test module and keep discovery on localhost.

    Every module of one pytest process gets its own domain; pass it to :func:`start_node` (the
    environment variable only holds the last module's choice once all modules are collected).
    Under pytest-xdist, worker k of N draws only domains d with d % N == k, so two workers never
    share one (each worker collects every module: 91 domains suffice for up to 4 workers).
    """
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")  # "gw0", "gw1", ... (unset: no xdist)
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    k = int(worker[2:]) if worker.startswith("gw") else 0
    free = [d for d in range(10, 101) if d % count == k % count and d not in _USED]
    if not free:
        raise RuntimeError(f"no free ROS domain for worker {worker or 'main'} of {count}: "
                           "run the suite on at most 4 pytest-xdist workers")
    domain = random.choice(free)
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


_LIVE: list[subprocess.Popen] = []
_PR_SET_PDEATHSIG = 1
try:  # resolved before any fork: the child only calls the function
    _prctl = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True).prctl
except (OSError, AttributeError):  # not Linux / no prctl: the per-test reaping still applies
    _prctl = None


def default_signals() -> None:
    """``preexec_fn``: default SIGINT/SIGTERM, nothing blocked, SIGKILL if the parent dies."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_SETMASK, set())
    if _prctl is not None:
        _prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)


def popen(args: list[str], **kwargs) -> subprocess.Popen:
    """``subprocess.Popen`` with :func:`default_signals` in the child, registered for :func:`reap_all`."""
    proc = subprocess.Popen(args, preexec_fn=default_signals, **kwargs)
    _LIVE.append(proc)
    return proc


def kill_and_reap(proc: subprocess.Popen, timeout: float = 10.0) -> None:
    """SIGKILL ``proc`` if it still runs, wait for it and close its pipes (never raises)."""
    with contextlib.suppress(ProcessLookupError, OSError):
        if proc.poll() is None:
            proc.kill()
    with contextlib.suppress(subprocess.TimeoutExpired, OSError, ValueError):
        proc.communicate(timeout=timeout)  # reaps, and drains the pipes so the child can exit
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=timeout)
    for f in (proc.stdin, proc.stdout, proc.stderr):
        if f is not None:
            with contextlib.suppress(OSError, ValueError):
                f.close()


def started() -> int:
    """How many processes :func:`popen` has registered so far (pass to :func:`reap_all`)."""
    return len(_LIVE)


def reap_all(since: int = 0) -> list[int]:
    """Kill and reap the processes :func:`popen` registered after the first ``since`` ones (all by
    default); return the pids that were still running."""
    alive = []
    while len(_LIVE) > since:
        proc = _LIVE.pop()
        if proc.poll() is None:
            alive.append(proc.pid)
        kill_and_reap(proc)
    return alive


def node_args(scene: str | os.PathLike[str], *overrides: str, ros_args: Sequence[str] = (),
              executable: str | os.PathLike[str] | None = None) -> list[str]:
    """Command line of the node for a scene plus ``-p`` overrides and further ROS arguments.

    Parameters
    ----------
    scene : str or PathLike
        A shipped scene name (``config/<scene>.yaml``) or the path of a parameter file.
    *overrides : str
        ``name:=value`` items, each passed as ``-p name:=value``.
    ros_args : sequence of str
        Further ROS arguments after the parameters, e.g. ``("-r", "__ns:=/leg1")``.
    executable : str or PathLike, optional
        The node's executable (default: the installed console script, :func:`node_executable`),
        e.g. another virtual environment's ``bin/cable_sim_node``.
    """
    is_path = isinstance(scene, os.PathLike) or os.sep in str(scene)
    params = Path(scene) if is_path else CONFIG / f"{scene}.yaml"
    args = [str(executable or node_executable()), "--ros-args", "--params-file", str(params)]
    for o in overrides:
        args += ["-p", o]
    return args + list(ros_args)


def node_code_path() -> dict[str, str]:
    """``PYTHONPATH`` that makes a node started from this venv's console script import the same
    ``cable_sim`` as this test process (the source tree under ``python -m pytest``; ``make test``
    keeps the installed copy equal to it). Node and tests then run the same files, and numba,
    whose cache is keyed by the source file, compiles each kernel once per run instead of once
    for the tree and once more for the installed copy (about a minute on a fresh clone)."""
    import cable_sim

    root = str(Path(cable_sim.__file__).resolve().parent.parent)
    rest = os.environ.get("PYTHONPATH", "")
    return {"PYTHONPATH": root + (os.pathsep + rest if rest else "")}


def node_env(domain: int | None = None, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: this process's environment plus :func:`node_code_path`) with ROS
    domain ``domain`` (default: the current one) and discovery on localhost only."""
    base = dict(os.environ, **node_code_path()) if base is None else base
    return dict(base, ROS_DOMAIN_ID=str(domain if domain is not None else os.environ["ROS_DOMAIN_ID"]),
                ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")


#: (scene, overrides choosing kernels) whose kernels this process has compiled or loaded.
_WARMED: set[tuple[str, tuple[tuple[str, str], ...]]] = set()
#: Node parameters that decide which compiled kernels a run needs.
_KERNEL_KEYS = ("integrator", "kernel", "position_tolerance", "tension_tolerance",
                "tolerance_horizon")


def warm_node_kernels(scene: str | os.PathLike[str], *overrides: str) -> None:
    """Compile in this process (or load from the on-disk cache) the kernels a node started for
    ``scene`` with ``overrides`` needs, once per process and configuration.

    The node imports the same files as this process (:func:`node_code_path`), so it shares the
    cache and then loads them in about a second instead of compiling them for a minute while
    its test waits a fixed time for its first message (with a cold cache and two workers, the
    60 s waits of test_robot_description failed). A scene the test process cannot build (a
    fault test's bad file) is left to the node, which reports it.
    """
    from cable_sim.scene.scenes import load_scene
    from cable_sim.scene.simulation import Simulation

    chosen = {}
    for item in overrides:
        name, _, value = item.partition(":=")
        if name in _KERNEL_KEYS:
            chosen[name] = value
    key = (str(scene), tuple(sorted(chosen.items())))
    if key in _WARMED:
        return
    _WARMED.add(key)
    try:
        values = {k: yaml.safe_load(v) for k, v in chosen.items()}
        Simulation(load_scene(scene, values)).warm_up()
    except Exception:  # noqa: BLE001 - the node reports a scene it cannot build itself
        return


def start_node(scene: str | os.PathLike[str], *overrides: str, domain: int | None = None,
               cwd: Path | None = None, ros_args: Sequence[str] = (),
               executable: str | os.PathLike[str] | None = None,
               env: Mapping[str, str] | None = None) -> subprocess.Popen:
    """Start cable_sim_node as a separate process in ROS domain ``domain`` (scene file + -p).

    ``ros_args`` are further ROS arguments (a namespace: ``("-r", "__ns:=/leg1")``);
    ``executable`` another node executable than the installed console script; ``env`` the
    environment to start from instead of this process's (the domain and localhost discovery are
    set on top); ``cwd`` the working directory (relative recording paths land there).
    Output (stdout and stderr) is piped as text. The process is killed and reaped after the test
    at the latest (:func:`reap_all`); use :func:`node_process` to bound it to a block.
    The node's kernels are compiled in this process first (:func:`warm_node_kernels`) unless
    another executable or environment is given.
    """
    if executable is None and env is None:
        warm_node_kernels(scene, *overrides)
    return popen(node_args(scene, *overrides, ros_args=ros_args, executable=executable), cwd=cwd,
                 env=node_env(domain, env), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


@contextlib.contextmanager
def node_process(scene: str | os.PathLike[str], *overrides: str, domain: int | None = None,
                 cwd: Path | None = None, **kwargs) -> Iterator[subprocess.Popen]:
    """:func:`start_node` (same arguments) as a context manager: the node is killed and reaped on
    leaving the block."""
    proc = start_node(scene, *overrides, domain=domain, cwd=cwd, **kwargs)
    try:
        yield proc
    finally:
        kill_and_reap(proc)


def run_to_end(scene: str | os.PathLike[str], *overrides: str, domain: int | None = None,
               cwd: Path | None = None, timeout: float = 120.0) -> str:
    """Run the node to the end of its scene (pass ``duration:=...`` and ``exit_at_end:=true``):
    its output; fails unless it exits 0 within ``timeout`` s; killed and reaped whatever happens."""
    with node_process(scene, *overrides, domain=domain, cwd=cwd) as proc:
        out, _ = proc.communicate(timeout=timeout)
        assert proc.returncode == 0, out[-3000:]
    return out


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
