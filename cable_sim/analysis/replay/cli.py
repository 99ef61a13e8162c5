"""``cable_sim_replay``: summary, plots, CSV, re-simulation and recovery of a recorded run.

Part of the analysis layer: may import every layer; here ros (recovery, lazily), scene and the
replay modules.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from cable_sim.scene.scenes import load_scene

from .gif import animate
from .headless import record_headless
from .load import LOADABLE, Run, load_run
from .plots import plot_frames, plot_tension
from .report import export_csv, summary
from .resim import compare, resimulate


def _progress(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="cable_sim_replay",
        description="Inspect, plot, export and re-simulate a cable_sim recording (MCAP).")
    ap.add_argument("bag", nargs="?", help="recorded .mcap file")
    ap.add_argument("--recover", nargs=2, metavar=("BAD", "FIXED"),
                    help="rewrite a truncated recording (after SIGKILL) as a complete file")
    ap.add_argument("--record-headless", metavar="SCENE",
                    help="first simulate SCENE without ROS and record it to BAG")
    ap.add_argument("--duration", type=float, help="with --record-headless: seconds (default: scene)")
    ap.add_argument("--frames", metavar="PNG", help="configuration frames figure (x-z)")
    ap.add_argument("--frame-interval", type=float, help="seconds between frames (default: scene)")
    ap.add_argument("--tension", metavar="PNG", help="fairlead tension and heave time series")
    ap.add_argument("--gif", metavar="GIF", help="animated GIF")
    ap.add_argument("--gif-interval", type=float,
                    help="seconds of the run between GIF frames (default: real time at --gif-fps, "
                         "subsampled to fit --gif-seconds)")
    ap.add_argument("--gif-seconds", type=float, default=10.0,
                    help="longest GIF [s]: at most gif-seconds * gif-fps frames (default 10)")
    ap.add_argument("--gif-fps", type=float, default=10.0, help="GIF frames per second (default 10)")
    ap.add_argument("--csv", metavar="CSV", help="export time series as CSV")
    ap.add_argument("--resim", action="store_true", help="re-simulate from the recorded inputs")
    ap.add_argument("--links", type=int, help="re-simulate with N links")
    ap.add_argument("--integrator", help="re-simulate with this integrator")
    ap.add_argument("--step", type=float, help="re-simulate with this step h [s]")
    ap.add_argument("--kernel", help="re-simulate with this kernel (dense/fast)")
    ap.add_argument("--quiet", action="store_true", help="no summary")
    return ap


def _recover(bad: str, fixed: str) -> None:
    from cable_sim.ros.recorder import recover

    info = recover(bad, fixed, progress=_progress)
    state = f"input was truncated: {info['error']}" if info["truncated"] else "input was complete"
    print(f"recovered {info['messages']} messages on {info['channels']} channels, "
          f"{info['metadata']} metadata records -> {fixed} ({state})")


def _record(ap: argparse.ArgumentParser, scene_name: str, duration: float | None, bag: str) -> None:
    scene = load_scene(scene_name)
    dur = duration if duration is not None else float(scene.sim["duration"])
    if not dur > 0:
        ap.error("--duration must be > 0 (the scene has no duration)")
    st = record_headless(scene, bag, dur, progress=_progress)
    print(f"recorded {st['messages_written']} messages ({st['bytes_written']} bytes) to {bag}",
          file=sys.stderr)


def _wants_resim(a: argparse.Namespace) -> bool:
    return a.resim or any(v is not None for v in (a.links, a.integrator, a.step, a.kernel))


def _topics(a: argparse.Namespace) -> set[str]:
    """Decode only what the requested outputs use (joint states are always read)."""
    topics = {"joint_states"}
    if not a.quiet:
        topics |= {"fairlead_tension", "diagnostics", "seabed_contact"}
    if a.tension:
        topics |= {"fairlead_tension", "anchor_force"}
    if a.csv or _wants_resim(a):
        topics = set(LOADABLE)
    return topics


def _outputs(run: Run, a: argparse.Namespace) -> None:
    if not a.quiet:
        print(summary(run))
    if a.frames:
        print(f"wrote {plot_frames(run, a.frames, a.frame_interval)}")
    if a.tension:
        print(f"wrote {plot_tension(run, a.tension)}")
    if a.gif:
        gif = animate(run, a.gif, interval=a.gif_interval, fps=a.gif_fps, seconds=a.gif_seconds,
                      progress=_progress)
        print(f"wrote {gif}")
    if a.csv:
        print(f"wrote {export_csv(run, a.csv)}")


def _resim(run: Run, a: argparse.Namespace) -> None:
    rs = resimulate(run, links=a.links, integrator=a.integrator, step=a.step, kernel=a.kernel,
                    progress=_progress)
    d = compare(run, rs)
    s = rs.settings
    print(f"re-simulation (n = {s['n_links']}, {s['integrator']}, h = {s['step']:g} s, kernel "
          f"{s['kernel']}; {rs.steps} steps in {rs.wall:.2f} s) minus recording:")
    print(f"  heave            max {d['heave_max']:.3e} m   RMS {d['heave_rms']:.3e} m")
    print(f"  tip position     max {d['tip_max']:.3e} m   RMS {d['tip_rms']:.3e} m")
    print(f"  fairlead tension max {d['tension_max']:.3e} N   RMS {d['tension_rms']:.3e} N")
    print("  joint states bitwise identical: " + ("yes" if d["identical_joint_states"] else "no"))


def main(argv: list[str] | None = None) -> int:
    """``cable_sim_replay``: summary, plots, CSV, re-simulation, recovery of a recorded run."""
    ap = _parser()
    a = ap.parse_args(argv)
    if a.recover:
        _recover(*a.recover)
        if not a.bag:
            return 0
    if not a.bag:
        ap.error("a recorded .mcap file is required")
    if a.record_headless:
        _record(ap, a.record_headless, a.duration, a.bag)
    for name in ("gif_seconds", "gif_fps", "gif_interval"):
        v = getattr(a, name)
        if v is not None and not (np.isfinite(v) and v > 0):
            ap.error(f"--{name.replace('_', '-')} {v!r}: must be > 0")
    run = load_run(a.bag, progress=_progress, topics=_topics(a))
    _outputs(run, a)
    if _wants_resim(a):
        _resim(run, a)
    return 0
