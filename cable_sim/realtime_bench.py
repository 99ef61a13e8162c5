"""Benchmark: how well the node keeps real time (``python -m cable_sim.realtime_bench``).

Runs :class:`cable_sim.node.CableSimNode` in ``realtime`` clock mode in this process, spun the
way ``cable_sim_node`` spins it (one single-threaded executor), on a scene (default: the
default scene, ``mooring_line``, with its default rates and recording on), while a listener in a
separate process subscribes to ``joint_states`` as a consumer would. It measures, per timer
tick of the node:

- the tick interval and its deviation from the nominal tick period (timer jitter);
- the tick's work (physics steps, outputs, publishing, recording) [us];
- the lag of simulated time behind wall time at the end of the tick [ms];

and, at the listener, the inter-arrival time of ``joint_states`` and the age of each state
when it arrives (arrival wall time minus the wall time its simulated time corresponds to).
It prints p50 / p99 / max of each, the real-time tracking over the run (simulated time / wall
time) and the node's overrun counter, and writes ``realtime_bench.csv`` (one row per tick),
``realtime_bench_arrivals.csv`` (one row per received joint state), ``realtime_bench.txt``
(the printed figures) and ``realtime_bench.png`` under ``results/realtime/``.

Both processes use CLOCK_MONOTONIC (``time.monotonic``), which is system-wide on Linux, so
arrival times and the node's tick times are on one time axis.
"""

from __future__ import annotations

import argparse
import csv
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

OUT_DIR = Path("results/realtime")


# ----------------------------------------------------------------------------- listener process
def listen(out: Path, seconds: float) -> None:
    """Subscribe to ``joint_states`` for ``seconds``; save (arrival monotonic time, stamp) rows."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node("realtime_bench_listener")
    rows: list[tuple[float, float]] = []

    def on_js(m: JointState) -> None:
        rows.append((time.monotonic(), m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec))

    node.create_subscription(JointState, "joint_states", on_js, 50)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    end = time.monotonic() + seconds
    try:
        while time.monotonic() < end and rclpy.ok():
            ex.spin_once(timeout_sec=0.05)
    finally:
        np.save(out, np.array(rows, dtype=float).reshape(-1, 2))
        node.destroy_node()
        rclpy.try_shutdown()


# ----------------------------------------------------------------------------- the measured node
def _instrumented_node_class():
    from .node import CableSimNode

    class InstrumentedNode(CableSimNode):
        """The node, with each real-time tick timed (the timer calls this override)."""

        def __init__(self, **kwargs: Any) -> None:
            self.tick_log: list[tuple[float, float, float, int]] = []
            super().__init__(**kwargs)

        def _tick_realtime(self) -> None:
            t0 = time.monotonic()
            k0 = self.sim.k
            super()._tick_realtime()
            t1 = time.monotonic()
            wall0, sim0 = self.sim_wall_base
            lag = (sim0 + (t1 - wall0)) - self.sim.t
            self.tick_log.append((t0, t1 - t0, lag, self.sim.k - k0))

    return InstrumentedNode


def _percentiles(x: np.ndarray) -> tuple[float, float, float]:
    if x.size == 0:
        return (float("nan"),) * 3
    return float(np.percentile(x, 50)), float(np.percentile(x, 99)), float(np.max(x))


def run(scene: str, seconds: float, overrides: list[str], out_dir: Path, record: bool) -> dict[str, Any]:
    """Run the node in real time for ``seconds`` with a listener; return the measured figures."""
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 200)))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)
    os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from .scenes import scene_path

    tmp = Path(tempfile.mkdtemp(prefix="realtime_bench_"))
    arrivals_file = tmp / "arrivals.npy"
    listener = subprocess.Popen(
        [sys.executable, "-m", "cable_sim.realtime_bench", "--listen", str(arrivals_file),
         "--seconds", str(seconds + 15.0)], env=dict(os.environ))
    args = ["--ros-args", "--params-file", str(scene_path(scene)), "-p", "clock_mode:=realtime",
            "-p", f"record:={'true' if record else 'false'}",
            "-p", f"record_path:={tmp / 'bench.mcap'}"]
    for o in overrides:
        args += ["-p", o]
    rclpy.init(args=args)
    node = _instrumented_node_class()()
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    try:
        # wait for the listener to be connected, then measure from a reset (t = 0 at a known time)
        t_wait = time.monotonic() + 30.0
        while node.pub_js.get_subscription_count() == 0 and time.monotonic() < t_wait:
            ex.spin_once(timeout_sec=0.05)
        from std_srvs.srv import Trigger

        node._on_reset(Trigger.Request(), Trigger.Response())
        node.tick_log.clear()
        node.overruns = 0
        start = time.monotonic()
        while time.monotonic() - start < seconds:
            ex.spin_once(timeout_sec=0.05)
        wall = time.monotonic() - start
        sim_t = node.sim.t
        overruns = node.overruns
        diag = node.diagnostics_values()
        info = {
            "scene": node.sim.scene.name, "n": node.sim.model.n, "h": node.h,
            "kernel": node.sim.kernel, "integrator": node.sim.integrator.name,
            "tick_period": node.tick_period, "js_rate": node.get_parameter("joint_state_rate").value,
            "record": record,
        }
        ticks = np.array(node.tick_log, dtype=float).reshape(-1, 4)
    finally:
        node.close()
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    try:
        listener.wait(timeout=seconds + 30.0)
    except subprocess.TimeoutExpired:
        listener.kill()
    arrivals = np.load(arrivals_file) if arrivals_file.exists() else np.zeros((0, 2))
    arrivals = arrivals[(arrivals[:, 0] >= start) & (arrivals[:, 0] <= start + wall)]

    P = info["tick_period"]
    interval = np.diff(ticks[:, 0])
    res: dict[str, Any] = dict(info)
    res.update({
        "wall": wall, "sim_time": sim_t, "tracking": sim_t / wall, "overruns": overruns,
        "ticks": int(ticks.shape[0]), "steps_per_tick_max": int(ticks[:, 3].max()) if ticks.size else 0,
        "interval_ms": _percentiles(1e3 * interval),
        "jitter_us": _percentiles(1e6 * np.abs(interval - P)),
        "work_us": _percentiles(1e6 * ticks[:, 1]),
        "lag_ms": _percentiles(1e3 * np.abs(ticks[:, 2])),
        "step_cost_us": float(diag["step_cost_us"]),
    })
    if arrivals.shape[0] > 2:
        ia = np.diff(arrivals[:, 0])
        age = arrivals[:, 0] - (start + arrivals[:, 1])
        res["arrivals"] = int(arrivals.shape[0])
        res["arrival_rate"] = (arrivals.shape[0] - 1) / (arrivals[-1, 0] - arrivals[0, 0])
        res["interarrival_ms"] = _percentiles(1e3 * ia)
        res["age_ms"] = _percentiles(1e3 * age)
    _write(res, ticks, arrivals, start, out_dir)
    return res


def _report(r: dict[str, Any]) -> str:
    def row(name: str, v: tuple[float, float, float], unit: str) -> str:
        return f"{name:<44} {v[0]:>10.3f} {v[1]:>10.3f} {v[2]:>10.3f}  {unit}"

    lines = [
        f"scene {r['scene']}, n = {r['n']}, h = {r['h']:g} s, {r['integrator']}, kernel {r['kernel']}, "
        f"tick period {1e3 * r['tick_period']:g} ms, joint_states {r['js_rate']:g} Hz, "
        f"recording {'on' if r['record'] else 'off'}, cpu count {os.cpu_count()}",
        f"wall {r['wall']:.3f} s, simulated {r['sim_time']:.3f} s: sim/wall = {r['tracking']:.5f} "
        f"({100 * (r['tracking'] - 1):+.3f} %), overruns {r['overruns']} of {r['ticks']} ticks, "
        f"mean physics step {r['step_cost_us']:.1f} us",
        f"{'':<44} {'p50':>10} {'p99':>10} {'max':>10}",
        row("tick interval", r["interval_ms"], "ms"),
        row("tick jitter |interval - period|", r["jitter_us"], "us"),
        row("tick work (steps + outputs + record)", r["work_us"], "us"),
        row("sim time behind wall time after a tick", r["lag_ms"], "ms"),
    ]
    if "arrivals" in r:
        lines += [
            row("joint_states inter-arrival (listener)", r["interarrival_ms"], "ms"),
            row("joint_states age at arrival", r["age_ms"], "ms"),
            f"listener received {r['arrivals']} joint states: {r['arrival_rate']:.3f} Hz",
        ]
    return "\n".join(lines)


def _write(r: dict[str, Any], ticks: np.ndarray, arrivals: np.ndarray, start: float, out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / "realtime_bench.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["wall_s", "interval_ms", "work_us", "lag_ms", "steps"])
        prev = None
        for t, work, lag, steps in ticks:
            w.writerow([f"{t - start:.6f}", "" if prev is None else f"{1e3 * (t - prev):.4f}",
                        f"{1e6 * work:.1f}", f"{1e3 * lag:.4f}", int(steps)])
            prev = t
    with open(out_dir / "realtime_bench_arrivals.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["arrival_wall_s", "stamp_s"])
        for a, s in arrivals:
            w.writerow([f"{a - start:.6f}", f"{s:.6f}"])
    (out_dir / "realtime_bench.txt").write_text(_report(r) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(11, 7))
    t = ticks[1:, 0] - start
    ax[0, 0].plot(t, 1e3 * np.diff(ticks[:, 0]), ".", ms=2)
    ax[0, 0].axhline(1e3 * r["tick_period"], color="k", lw=0.8)
    ax[0, 0].set(xlabel="wall time [s]", ylabel="tick interval [ms]", title="timer ticks")
    ax[0, 1].plot(ticks[:, 0] - start, 1e6 * ticks[:, 1], ".", ms=2)
    ax[0, 1].set(xlabel="wall time [s]", ylabel="tick work [us]", title="work per tick")
    ax[1, 0].plot(ticks[:, 0] - start, 1e3 * ticks[:, 2], ".", ms=2)
    ax[1, 0].set(xlabel="wall time [s]", ylabel="wall - sim time after tick [ms]",
                 title=f"tracking: sim/wall = {r['tracking']:.5f}, overruns {r['overruns']}")
    if arrivals.shape[0] > 2:
        ia = 1e3 * np.diff(arrivals[:, 0])
        ax[1, 1].hist(ia, bins=80, log=True)
        ax[1, 1].set(xlabel="joint_states inter-arrival at listener [ms]", ylabel="count",
                     title=f"listener: {r['arrival_rate']:.2f} Hz")
    fig.suptitle(f"real-time run: {r['scene']}, n = {r['n']}, h = {r['h']:g} s, "
                 f"{r['wall']:.0f} s wall")
    fig.tight_layout()
    fig.savefig(out_dir / "realtime_bench.png", dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m cable_sim.realtime_bench [--scene S] [--seconds 30] [-p k:=v]``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="mooring_line", help="scene name or YAML path")
    ap.add_argument("--seconds", type=float, default=30.0, help="wall seconds to run")
    ap.add_argument("-p", dest="overrides", action="append", default=[],
                    help="node parameter override name:=value (repeatable)")
    ap.add_argument("--no-record", action="store_true", help="run with record:=false")
    ap.add_argument("--out", type=Path, default=OUT_DIR, help="output directory")
    ap.add_argument("--listen", type=Path, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.listen is not None:
        listen(a.listen, a.seconds)
        return 0
    r = run(a.scene, a.seconds, a.overrides, a.out, record=not a.no_record)
    print(_report(r))
    print(f"wrote {a.out}/realtime_bench.csv, realtime_bench_arrivals.csv, realtime_bench.txt, "
          "realtime_bench.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
