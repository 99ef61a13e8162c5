"""Memory soak of the node: ``python -m cable_sim.analysis.soak_bench --minutes 60 --record``.

Starts the installed ``cable_sim_node`` as a subprocess on a scene (default ``mooring_line``)
in real time, optionally recording to MCAP, drives ``heave_force`` inputs on its topic at a
fixed rate, samples the node's resident set size (``VmRSS`` of ``/proc/<pid>/status``) and its
diagnostics every ``--interval`` seconds, and writes

- ``<out>/soak_rss.csv``: elapsed [s], RSS [MB], simulated time, real-time factor, recorder
  messages written / dropped, heave inputs sent;
- ``<out>/soak_rss.png``: RSS against time with the fitted line;
- ``<out>/soak_summary.json``: growth after warm-up (least-squares line through the samples
  after ``--warmup`` minutes, MB/hour), final MCAP size and whether it reads completely.

A benchmark, not a CI test. The node gets default SIGINT/SIGTERM handling, is stopped with
SIGINT at the end and killed if it does not exit; it is always reaped.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np


def rss_mb(pid: int) -> float:
    """Resident set size of process ``pid`` [MB] from ``/proc/<pid>/status`` (nan if gone)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return math.nan


def growth_rate(t_s: np.ndarray, rss: np.ndarray, warmup_s: float) -> tuple[float, float, int]:
    """Least-squares slope of RSS after ``warmup_s``: (MB/hour, intercept MB, samples used).

    Returns nan for the slope with fewer than 3 samples after the warm-up.
    """
    keep = (t_s >= warmup_s) & np.isfinite(rss)
    if keep.sum() < 3:
        return math.nan, math.nan, int(keep.sum())
    slope, icpt = np.polyfit(t_s[keep], rss[keep], 1)
    return float(slope * 3600.0), float(icpt), int(keep.sum())


def check_mcap(path: Path) -> dict[str, Any]:
    """Size of an MCAP file and whether it reads completely (summary + every message)."""
    from mcap.reader import make_reader

    out: dict[str, Any] = {"path": str(path), "exists": path.exists()}
    if not path.exists():
        return out
    out["size_mb"] = path.stat().st_size / 1e6
    try:
        with open(path, "rb") as f:
            r = make_reader(f)
            summary = r.get_summary()
            n = sum(1 for _ in r.iter_messages())
        out["summary_messages"] = int(summary.statistics.message_count) if summary else -1
        out["messages_read"] = n
        out["readable"] = summary is not None and n == out["summary_messages"]
    except Exception as exc:  # noqa: BLE001 - report, do not crash the benchmark
        out["readable"] = False
        out["error"] = repr(exc)
    return out


def _default_signals() -> None:  # runs in the child before exec
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:  # the node gets SIGTERM if the benchmark dies without its finally (SIGKILL)
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass


def _raise_interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv: list[str] | None = None) -> int:
    """Run the soak (see the module docstring); returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=60.0, help="soak length [min] (> 0)")
    ap.add_argument("--record", action="store_true", help="record the run to MCAP")
    ap.add_argument("--scene", default="mooring_line")
    ap.add_argument("--out", default="results/soak", help="output folder")
    ap.add_argument("--interval", type=float, default=10.0, help="RSS sampling interval [s] (> 0)")
    ap.add_argument("--warmup", type=float, default=2.0, help="minutes excluded from the fit (>= 0)")
    ap.add_argument("--input-rate", type=float, default=100.0, help="heave_force messages per s (> 0)")
    ap.add_argument("--amplitude", type=float, default=2.0e5, help="heave force amplitude [N]")
    a = ap.parse_args(argv)
    for name, v, ok, rng in (("--minutes", a.minutes, a.minutes > 0, "> 0"),
                             ("--interval", a.interval, a.interval > 0, "> 0"),
                             ("--warmup", a.warmup, a.warmup >= 0, ">= 0"),
                             ("--input-rate", a.input_rate, a.input_rate > 0, "> 0")):
        if not ok:
            ap.error(f"{name} = {v}: allowed {rng}")

    # SIGINT/SIGTERM stop the soak through the finally below (node stopped and reaped), also
    # when started as a background job with SIGINT ignored
    signal.signal(signal.SIGINT, _raise_interrupt)
    signal.signal(signal.SIGTERM, _raise_interrupt)
    domain = random.randint(181, 232)
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)
    os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Float64

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    mcap_path = out / "soak.mcap"
    if a.record and mcap_path.exists():
        mcap_path.unlink()  # the recorder never overwrites: clear the previous soak's file
    exe = Path(sys.executable).parent / "cable_sim_node"
    cmd = [str(exe), "--ros-args", "-p", f"scene:={a.scene}", "-p", "clock_mode:=realtime",
           "-p", f"record:={'true' if a.record else 'false'}", "-p", f"record_path:={mcap_path}"]
    log_path = out / "soak_node.log"
    rows: list[dict[str, Any]] = []
    diag: dict[str, str] = {}
    sent = 0
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, preexec_fn=_default_signals,
                                env=dict(os.environ, PYTHONUNBUFFERED="1"))
    print(f"soak: node pid {proc.pid}, domain {domain}, {a.minutes:g} min, record={a.record}, "
          f"log {log_path}", flush=True)
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node("soak_driver", context=ctx)
    pub = node.create_publisher(Float64, "heave_force", 10)

    def on_diag(m: DiagnosticArray) -> None:
        diag.clear()
        diag.update({kv.key: kv.value for kv in m.status[0].values})

    node.create_subscription(DiagnosticArray, "diagnostics", on_diag, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    code = 0
    try:
        t0 = time.monotonic()
        end = t0 + 60.0 * a.minutes
        next_sample = t0
        next_input = t0
        dt_in = 1.0 / a.input_rate
        while True:
            now = time.monotonic()
            if proc.poll() is not None:
                print(f"soak: node exited early with code {proc.returncode} (see {log_path})", flush=True)
                code = 1
                break
            if now >= next_input:
                pub.publish(Float64(data=a.amplitude * math.sin(2 * math.pi * (now - t0) / 8.0)))
                sent += 1
                next_input += dt_in
                if now - next_input > 1.0:  # fell behind (machine busy): do not burst
                    next_input = now + dt_in
            if now >= next_sample:
                row = {"elapsed_s": round(now - t0, 3), "rss_mb": rss_mb(proc.pid),
                       "sim_time_s": float(diag.get("sim_time", "nan")),
                       "real_time_factor": float(diag.get("real_time_factor", "nan")),
                       "recorder_written": int(diag.get("recorder_messages_written", -1)),
                       "recorder_dropped": int(diag.get("recorder_messages_dropped", -1)),
                       "heave_inputs_sent": sent}
                rows.append(row)
                print("soak: " + ", ".join(f"{k}={v}" for k, v in row.items()), flush=True)
                next_sample += a.interval
            if now >= end:
                break
            ex.spin_once(timeout_sec=max(0.0, min(next_input, next_sample, end) - time.monotonic()))
    except KeyboardInterrupt as exc:
        print(f"soak: interrupted ({exc}) after {len(rows)} samples", flush=True)
        code = 130
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
        proc.wait()
    node_code = proc.returncode
    report = _write_results(out, rows, a, sent, node_code, mcap_path if a.record else None)
    print(json.dumps(report, indent=2), flush=True)
    return code or (1 if node_code != 0 else 0)


def _write_results(out: Path, rows: list[dict[str, Any]], a: argparse.Namespace, sent: int,
                   node_code: int | None, mcap_path: Path | None) -> dict[str, Any]:
    """Write the CSV, the plot and the summary JSON; return the summary."""
    with open(out / "soak_rss.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["elapsed_s", "rss_mb"])
        w.writeheader()
        w.writerows(rows)
    t = np.array([r["elapsed_s"] for r in rows], dtype=float)
    rss = np.array([r["rss_mb"] for r in rows], dtype=float)
    rate, icpt, used = growth_rate(t, rss, 60.0 * a.warmup)
    after = rss[t >= 60.0 * a.warmup] if len(t) else np.array([])
    report: dict[str, Any] = {
        "minutes": a.minutes, "record": a.record, "scene": a.scene, "samples": len(rows),
        "warmup_min": a.warmup, "fit_samples": used, "growth_mb_per_hour": rate,
        "rss_first_mb": float(rss[0]) if len(rss) else math.nan,
        "rss_after_warmup_min_mb": float(after.min()) if len(after) else math.nan,
        "rss_after_warmup_max_mb": float(after.max()) if len(after) else math.nan,
        "rss_final_mb": float(rss[-1]) if len(rss) else math.nan,
        "heave_inputs_sent": sent, "node_exit_code": node_code,
        "last_real_time_factor": rows[-1]["real_time_factor"] if rows else math.nan,
        "recorder_dropped": rows[-1]["recorder_dropped"] if rows else -1,
    }
    if mcap_path is not None:
        report["mcap"] = check_mcap(mcap_path)
    with open(out / "soak_summary.json", "w") as f:
        json.dump(report, f, indent=2)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 4.5))
        ax.plot(t / 60.0, rss, ".-", lw=1, label="node VmRSS")
        if math.isfinite(rate):
            tf = t[t >= 60.0 * a.warmup]
            ax.plot(tf / 60.0, icpt + rate / 3600.0 * tf, "r--",
                    label=f"fit after {a.warmup:g} min: {rate:+.2f} MB/h")
        ax.axvline(a.warmup, color="0.6", lw=0.8)
        ax.set_xlabel("elapsed [min]")
        ax.set_ylabel("RSS [MB]")
        ax.set_title(f"cable_sim_node soak: {a.scene}, real time, record={a.record}, "
                     f"{sent} heave inputs")
        ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(out / "soak_rss.png", dpi=110)
        plt.close(fig)
    except ImportError as exc:  # pragma: no cover - matplotlib is a dependency
        print(f"soak: no plot ({exc})", file=sys.stderr)
    print(f"soak: RSS growth after {a.warmup:g} min warm-up: {rate:+.3f} MB/hour "
          f"({used} samples); final RSS {report['rss_final_mb']:.1f} MB", flush=True)
    if mcap_path is not None:
        m = report["mcap"]
        print(f"soak: MCAP {m.get('path')}: {m.get('size_mb', float('nan')):.1f} MB, "
              f"readable={m.get('readable')}, messages={m.get('messages_read')}", flush=True)
    return report


if __name__ == "__main__":
    sys.exit(main())
