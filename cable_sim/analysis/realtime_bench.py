"""Real-time tick jitter of the node: ``python -m cable_sim.analysis.realtime_bench [--seconds 30]``.

Runs :class:`cable_sim.ros.node.CableSimNode` in this process in real-time mode on a scene (optionally
at another n, integrator or step), records the wall time of every timer tick, and reports the tick
interval p50/p99/max, the deviation from the nominal period, the step cost, the overruns and where a
tick's time goes (physics, derived outputs, messages, publishing, recording, other: the node's
:class:`cable_sim.ros.timing.TickProfile`). Writes CSV + PNG under ``results/realtime/``. Figures are
measured, not asserted (speed lives in benchmarks).
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="mooring_line")
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--record", action="store_true", help="record to MCAP while measuring")
    ap.add_argument("--n-links", type=int, default=None, help="override the scene's n")
    ap.add_argument("--integrator", default=None, help="override the scene's integrator")
    ap.add_argument("--step", type=float, default=None, help="override the scene's step [s]")
    ap.add_argument("--tag", default="", help="suffix of the output files (e.g. n2000)")
    ap.add_argument("--out", default="results/realtime")
    a = ap.parse_args(argv)
    from cable_sim.analysis.in_process_node import in_process_node

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    tag = f"_{a.tag}" if a.tag else ""
    overrides = {"scene": a.scene, "clock_mode": "realtime", "record": a.record,
                 "record_path": str(out / f"bench{tag}.mcap")}
    for key, value in (("n_links", a.n_links), ("integrator", a.integrator), ("step", a.step)):
        if value is not None:
            overrides[key] = value
    with in_process_node(**overrides) as (node, ex):
        t_end = time.monotonic() + a.seconds
        while time.monotonic() < t_end:
            ex.spin_once(timeout_sec=0.05)
        diag = node.diagnostics_values()
        ticks = np.array(node.tick_times)
        profile = node.run.profile
        split = profile.split_us()
    intervals = np.diff(ticks) * 1e3
    period = node.tick_period * 1e3
    dev = intervals - period
    stats = {
        "scene": a.scene, "seconds": a.seconds, "record": a.record, "n_links": node.sim.model.n,
        "step_s": node.h, "tick_period_ms": period, "ticks": len(intervals),
        "interval_p50_ms": float(np.percentile(intervals, 50)),
        "interval_p99_ms": float(np.percentile(intervals, 99)),
        "interval_max_ms": float(intervals.max()),
        "abs_dev_p50_ms": float(np.percentile(np.abs(dev), 50)),
        "abs_dev_p99_ms": float(np.percentile(np.abs(dev), 99)),
        "step_cost_us": float(diag["step_cost_us"]),
        "real_time_factor": float(diag["real_time_factor"]),
        "overruns": int(diag["overruns"]),
        "integrator": node.sim.integrator.name,
        "longest_tick_ms": 1e3 * profile.longest_tick,
        **{f"tick_{k}_us": v for k, v in split.items()},
    }
    for k, v in stats.items():
        print(f"{k:18s} {v}")
    with open(out / f"jitter_summary{tag}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(stats))
        w.writeheader()
        w.writerow(stats)
    np.savetxt(out / f"tick_intervals_ms{tag}.csv", intervals, fmt="%.4f", header="tick_interval_ms")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 3.5))
    ax[0].plot(intervals, lw=0.5)
    ax[0].axhline(period, color="k", ls="--", lw=0.8)
    ax[0].set(xlabel="tick", ylabel="interval [ms]", title=f"{a.scene}: timer tick intervals")
    ax[1].hist(intervals, bins=100, log=True)
    ax[1].set(xlabel="interval [ms]", ylabel="count",
              title=f"p50 {stats['interval_p50_ms']:.2f}, p99 {stats['interval_p99_ms']:.2f}, "
                    f"max {stats['interval_max_ms']:.2f} ms")
    parts = list(split)
    ax[2].barh(parts, [split[p] / 1e3 for p in parts])
    ax[2].set(xlabel="mean wall time per tick [ms]",
              title=f"tick split, n = {node.sim.model.n} ({node.sim.integrator.name}, h = {node.h:g} s)")
    fig.tight_layout()
    fig.savefig(out / f"tick_jitter{tag}.png", dpi=110)
    print(f"wrote {out / f'jitter_summary{tag}.csv'}, {out / f'tick_jitter{tag}.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
