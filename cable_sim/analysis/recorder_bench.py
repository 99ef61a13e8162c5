"""Benchmark: what recording costs the simulation loop (``python -m cable_sim.analysis.recorder_bench``).

Runs the node's publish loop without the node (:func:`cable_sim.analysis.replay.headless.record_headless`:
simulation + every message the node publishes, built as real ROS messages, published with real
rclpy publishers in an isolated localhost domain) with recording off and on
(:class:`cable_sim.ros.recorder.RunRecorder`, zstd chunks, fsync every second), at n = 80 by
default, and reports:

- loop throughput [physics steps / s] and simulated seconds per wall second: messages built
  only; built and published with real rclpy publishers; published and recorded; published and
  recorded from one serialisation (`write(..., serialized=data)`, `publisher.publish(data)`);
- the caller's cost of :meth:`RunRecorder.write` per message type (serialise + enqueue), median
  / 99th percentile / max [us];
- the background writer's sustained rate [messages / s, MB / s] and the compression ratio;
- the node itself (:class:`cable_sim.ros.node.CableSimNode` in this process, ``clock_mode`` fast, its
  default output rates): simulated seconds per wall second with recording off and on, alternated,
  and the recording overhead (issue 13's figure: 1 - on / off), with the node's tick split.

Writes ``recorder_bench.csv`` and ``recorder_bench.png`` under ``results/recording/``.
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from cable_sim.analysis.replay.headless import record_headless
from cable_sim.ros.messages import (
    build_diagnostics,
    build_float_array,
    build_joint_state,
    build_markers,
    build_wrench,
)
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

RATES = {
    # name: (joint_state_rate, marker_rate, tension_rate, diagnostics_rate) [Hz]
    "node defaults (50/10/50/1 Hz)": (50.0, 10.0, 50.0, 1.0),
    "every step": (1e9, 10.0, 1e9, 1.0),
}


MODES = {
    # name: (publish with rclpy, record, serialise once and publish/record the same bytes)
    "build only": (False, False, False),
    "publish": (True, False, False),
    "publish + record": (True, True, False),
    "publish + record, serialised once": (True, True, True),
}


class Publishers:
    """Real rclpy publishers (isolated domain, localhost) for every topic the loop publishes."""

    def __init__(self) -> None:
        import random

        os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(150, 200)))
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        import rclpy
        from rclpy.context import Context

        self.ctx = Context()
        rclpy.init(context=self.ctx)
        self.node = rclpy.create_node("recorder_bench", context=self.ctx)
        self.pubs: dict[str, Any] = {}

    def publish(self, topic: str, msg: Any) -> None:
        p = self.pubs.get(topic)
        if p is None:
            if isinstance(msg, bytes):
                raise RuntimeError("first message on a topic must be a message (to know its type)")
            p = self.pubs[topic] = self.node.create_publisher(type(msg), topic, 10)
        p.publish(msg)

    def warm(self, scene) -> None:
        """Create every publisher (with messages) before any byte-only run."""
        record_headless(scene, None, 0.1, publish=self.publish)

    def close(self) -> None:
        import rclpy

        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def loop_throughput(scene, duration: float, rates: tuple[float, float, float, float], mode: str,
                    tmpdir: Path, pubs: Publishers) -> dict:
    """One headless run; returns steps/s, sim-time factor and recorder stats."""
    do_pub, record, once = MODES[mode]
    path = tmpdir / "bench.mcap" if record else None
    js, mk, tn, dg = rates
    t0 = time.perf_counter()
    st = record_headless(scene, path, duration, joint_state_rate=js, marker_rate=mk, tension_rate=tn,
                         diagnostics_rate=dg, publish=pubs.publish if do_pub else None,
                         serialize_once=once)
    wall = time.perf_counter() - t0
    size = path.stat().st_size if path is not None else 0
    if path is not None:
        path.unlink()
    return {"steps_per_s": st["steps"] / wall, "realtime_factor": duration / wall, "wall": wall,
            "messages": sum(st["published"].values()), "written": st["messages_written"],
            "dropped": st["messages_dropped"], "file_bytes": size}


def write_costs(scene, n_msgs: int, tmpdir: Path) -> list[dict]:
    """Caller cost of RunRecorder.write per message type [us]."""
    from cable_sim.ros.recorder import RunRecorder, serialize

    sim = Simulation(scene)
    sim.run_until(1.0)
    out = sim.outputs()
    msgs = {
        f"JointState ({sim.model.n + 1} joints)": ("/joint_states", build_joint_state(out, 0)),
        f"MarkerArray ({sim.model.n + 1} points)": ("/cable_markers", build_markers(out, sim.model, 0)),
        "WrenchStamped": ("/fairlead_tension", build_wrench(-out.fairlead_force, 0)),
        f"Float64MultiArray ({sim.model.n})": ("/line_tension", build_float_array(out.axial_tension)),
        "DiagnosticArray (8 values)": ("/diagnostics", build_diagnostics(
            {f"k{i}": repr(float(i)) for i in range(8)}, 0)),
    }
    rows = []
    for name, (topic, msg) in msgs.items():
        path = tmpdir / "cost.mcap"
        rec = RunRecorder(path, max_queue=n_msgs + 10)
        dts = np.empty(n_msgs)
        for i in range(n_msgs):
            t = time.perf_counter()
            rec.write(topic, msg, i)
            dts[i] = time.perf_counter() - t
            if i % 50 == 49:  # give the writer thread the GIL, as a real loop would
                time.sleep(0.001)
        t_close = time.perf_counter()
        rec.close()
        drain = time.perf_counter() - t_close
        ser = np.empty(200)
        for i in range(200):
            t = time.perf_counter()
            serialize(msg)
            ser[i] = time.perf_counter() - t
        size = len(serialize(msg))
        rows.append({"message": name, "bytes": size,
                     "write_median_us": float(np.median(dts) * 1e6),
                     "write_p99_us": float(np.percentile(dts, 99) * 1e6),
                     "write_max_us": float(dts.max() * 1e6),
                     "serialize_median_us": float(np.median(ser) * 1e6),
                     "written": rec.stats["messages_written"], "dropped": rec.stats["messages_dropped"],
                     "close_s": drain,
                     "compression_ratio": n_msgs * size / max(1, path.stat().st_size)})
        path.unlink()
    return rows


def writer_rate(scene, n_msgs: int, tmpdir: Path) -> dict:
    """Messages/s and MB/s the background writer alone sustains (JointState bytes pre-serialised,
    so the caller's share is only the enqueue)."""
    from cable_sim.ros.recorder import RunRecorder, serialize

    sim = Simulation(scene)
    data = serialize(build_joint_state(sim.outputs(), 0))
    path = tmpdir / "rate.mcap"
    rec = RunRecorder(path, max_queue=n_msgs + 10)
    t0 = time.perf_counter()
    for i in range(n_msgs):
        rec.write_serialized("/joint_states", "sensor_msgs/msg/JointState", data, i)
    rec.close()
    wall = time.perf_counter() - t0
    size = path.stat().st_size
    path.unlink()
    return {"messages_per_s": n_msgs / wall, "raw_MB_per_s": n_msgs * len(data) / wall / 1e6,
            "file_MB": size / 1e6}


def node_fast_mode(scene: str, n_links: int, seconds: float, record: bool, tmpdir: Path) -> dict:
    """The node in fast clock mode for ``seconds`` of wall time: steps/s and the tick split."""
    from cable_sim.analysis.in_process_node import in_process_node

    path = tmpdir / "node_fast.mcap"
    with in_process_node(scene=scene, clock_mode="fast", n_links=n_links, record=record,
                         record_path=str(path)) as (node, ex):
        for _ in range(20):  # start-up (compilation, first outputs) outside the timing
            ex.spin_once(timeout_sec=0.01)
        k0, w0 = node.sim.k, time.perf_counter()
        node.run.profile.reset()
        while time.perf_counter() - w0 < seconds:
            ex.spin_once(timeout_sec=0.01)
        wall, steps = time.perf_counter() - w0, node.sim.k - k0
        split = node.run.profile.split_us()
        ticks = node.run.profile.ticks
    if path.exists():
        path.unlink()
    return {"steps_per_s": steps / wall, "realtime_factor": steps * node.h / wall, "ticks": ticks,
            **{f"split_{k}_us_per_step": v * ticks / max(steps, 1) for k, v in split.items()}}


def node_overhead(scene: str, n_links: int, seconds: float, repeats: int, tmpdir: Path) -> list[dict]:
    """Recording off / on in ``repeats`` pairs, the run that goes first alternating between pairs
    (off, on; on, off; ...: a second run that is slower or faster for having come second, after a
    node was torn down or a file written, weighs on both sides alike): median rows and the
    overhead row (median, smallest and largest of the per-pair overheads)."""
    runs: dict[bool, list[dict]] = {False: [], True: []}
    for k in range(repeats):
        for record in ((False, True) if k % 2 == 0 else (True, False)):
            runs[record].append(node_fast_mode(scene, n_links, seconds, record, tmpdir))
    rows = []
    for record, rr in runs.items():
        med = {k: statistics.median(r[k] for r in rr) for k in rr[0]}
        rows.append({"kind": "node_fast", "mode": "record" if record else "no record", **med})
    # per alternated pair (the two runs of a pair see the same machine load): the overhead is the
    # median of the pairs' overheads; the spread says how much the load moved it
    pairs = [1.0 - on["steps_per_s"] / off["steps_per_s"]
             for off, on in zip(runs[False], runs[True], strict=True)]
    rows.append({"kind": "node_overhead", "mode": "record vs no record",
                 "overhead": statistics.median(pairs), "overhead_min": min(pairs),
                 "overhead_max": max(pairs), "pairs": len(pairs)})
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and write CSV + PNG."""
    ap = argparse.ArgumentParser(prog="python -m cable_sim.analysis.recorder_bench",
                                 description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--scene", default="mooring_line")
    ap.add_argument("--links", type=int, default=80)
    ap.add_argument("--duration", type=float, default=20.0, help="simulated seconds per run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--node-seconds", type=float, default=10.0,
                    help="wall seconds per node run in fast mode (0: skip the node)")
    ap.add_argument("--out", default="results/recording")
    a = ap.parse_args(argv)
    scene = load_scene(a.scene, {"n_links": a.links})
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    Simulation(scene).run_until(0.05)  # compile / warm caches outside the timings
    rows = []
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        record_headless(scene, None, 0.2)
        print(f"scene {a.scene}, n = {a.links}, h = {scene.sim['step']} s, kernel {scene.sim['kernel']}, "
              f"{a.duration} s simulated per run, median of {a.repeats} (cpu count {os.cpu_count()})")
        pubs = Publishers()
        pubs.warm(scene)
        print(f"{'publish rates':30s} {'mode':34s} {'steps/s':>8s} {'x real time':>11s} "
              f"{'messages':>9s} {'dropped':>8s} {'file MB':>8s}")
        try:
            for rname, rates in RATES.items():
                for mode in MODES:
                    runs = [loop_throughput(scene, a.duration, rates, mode, tmp, pubs)
                            for _ in range(a.repeats)]
                    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
                    row = {"kind": "loop", "rates": rname, "mode": mode, **med}
                    rows.append(row)
                    print(f"{rname:30s} {mode:34s} {med['steps_per_s']:8.0f} {med['realtime_factor']:11.1f} "
                          f"{med['messages']:9.0f} {med['dropped']:8.0f} {med['file_bytes'] / 1e6:8.2f}")
                base = next(r["steps_per_s"] for r in rows[-4:] if r["mode"] == "publish")
                for r in rows[-2:]:
                    print(f"{'':30s} {r['mode']}: {100 * (1 - r['steps_per_s'] / base):.1f} % "
                          "below 'publish'")
        finally:
            pubs.close()
        print("\ncaller cost of RunRecorder.write (serialise + enqueue), 2000 messages each:")
        print(f"{'message':32s} {'bytes':>7s} {'median us':>10s} {'p99 us':>8s} {'max us':>8s} "
              f"{'serialise us':>13s} {'zstd ratio':>10s}")
        for c in write_costs(scene, 2000, tmp):
            rows.append({"kind": "write", **c})
            print(f"{c['message']:32s} {c['bytes']:7d} {c['write_median_us']:10.1f} {c['write_p99_us']:8.1f} "
                  f"{c['write_max_us']:8.1f} {c['serialize_median_us']:13.1f} {c['compression_ratio']:10.1f}")
        if a.node_seconds > 0:
            print(f"\nthe node in fast clock mode ({a.scene}, n = {a.links}, default output rates), "
                  f"{a.node_seconds:g} s of wall per run, recording off/on alternated, "
                  f"median of {a.repeats} each:")
            node_rows = node_overhead(a.scene, a.links, a.node_seconds, a.repeats, tmp)
            rows += node_rows
            for r in node_rows[:2]:
                split = ", ".join(f"{k[6:-15]} {v:.1f}" for k, v in r.items() if k.startswith("split_"))
                print(f"  {r['mode']:10s} {r['steps_per_s']:8.0f} steps/s  x{r['realtime_factor']:.1f} "
                      f"real time; us per step: {split}")
            ov = node_rows[2]
            print(f"  recording overhead: {100 * ov['overhead']:.1f} % fewer steps/s (median of "
                  f"{ov['pairs']} alternated pairs; {100 * ov['overhead_min']:.1f} .. "
                  f"{100 * ov['overhead_max']:.1f} %)")
        wr = writer_rate(scene, 20000, tmp)
        rows.append({"kind": "writer", **wr})
        print(f"\nbackground writer: {wr['messages_per_s']:.0f} JointState/s "
              f"({wr['raw_MB_per_s']:.1f} MB/s of CDR, {wr['file_MB']:.2f} MB file for 20000 messages)")
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(out / "recorder_bench.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    _plot(rows, out / "recorder_bench.png", a)
    print(f"\nwrote {out / 'recorder_bench.csv'} and {out / 'recorder_bench.png'}")
    return 0


def _plot(rows: list[dict], path: Path, a: argparse.Namespace) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    loops = [r for r in rows if r["kind"] == "loop"]
    writes = [r for r in rows if r["kind"] == "write"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 4.8))
    names = list(dict.fromkeys(r["rates"] for r in loops))
    x = np.arange(len(names))
    width = 0.8 / len(MODES)
    for j, mode in enumerate(MODES):
        v = [next(r["steps_per_s"] for r in loops if r["rates"] == n and r["mode"] == mode) for n in names]
        bars = a1.bar(x + (j - (len(MODES) - 1) / 2) * width, v, width, label=mode)
        a1.bar_label(bars, fmt="%.0f", fontsize=7)
    a1.set_xticks(x, names)
    a1.set_ylabel("physics steps / s (incl. building + publishing messages)")
    a1.set_title(f"loop throughput, {a.scene} n = {a.links}")
    a1.legend(fontsize=8)
    y = np.arange(len(writes))
    a2.barh(y, [r["write_median_us"] for r in writes], label="write() median")
    a2.barh(y, [r["serialize_median_us"] for r in writes], height=0.4, label="serialise only")
    a2.set_yticks(y, [r["message"] for r in writes])
    a2.set_xlabel("us per message (caller side)")
    a2.set_title("RunRecorder.write cost")
    a2.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
