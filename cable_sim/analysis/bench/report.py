"""The benchmark's text outputs: CSV files and the markdown summary for the README (summary.md).

Part of the analysis layer; imports numpy, the standard library and :mod:`.settings` only.
"""

from __future__ import annotations

import csv
import os
import platform
from pathlib import Path

import numpy as np

from .settings import CLOSE


def write_csv(path: Path, rows: list[dict]) -> None:
    """``rows`` as CSV (columns in order of first appearance; floats to 6 digits); none: no file."""
    if not rows:
        return
    keys = list(rows[0].keys())
    for r in rows[1:]:
        keys += [k for k in r if k not in keys]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def _fmt(v, digits: int = 3) -> str:
    if isinstance(v, float):
        return "n/a" if not np.isfinite(v) else f"{v:.{digits}g}"
    return str(v)


def _table(rows: list[dict], keys: list[str], digits: int = 3) -> str:
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(_fmt(r.get(k, ""), digits) for k in keys) + " |")
    return "\n".join(lines)


def _header(argv, kernel, why, integs, args, wp, elapsed) -> list[str]:
    cpu = platform.processor() or platform.machine()
    durs = sorted({(r["scene"], r["duration"]) for r in wp})
    return [
        "## Benchmark (issue #13 targets; studies of issues #5, #11, #13)",
        "",
        f"Measured by `cable_sim_bench {' '.join(argv)}` on {cpu}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, kernel `{kernel}` ({why}); {elapsed:.0f} s wall for this "
        "invocation. "
        f"Integrators: {', '.join(integs)}. Simulated durations: "
        + ", ".join(f"{sc} {d:g} s" for sc, d in durs) + ". "
        "Cost = wall time of the time stepping per simulated second, RTF = 1 / cost (compiled "
        "schemes: one compiled call per 0.5 s with the inputs sampled beforehand; the input sampling "
        "and check arming that `Integrator.advance` adds per call is in `rtf_incl_inputs`; scipy "
        "schemes: one `solve_ivp` call). Error = max over joints and 0.5 s samples of the joint-position "
        "distance to a reference at the same n "
        f"(DOP853 rtol=atol={args.ref_rtol:g} for n <= {args.dop853_max_n}, else rosenbrock2 at h = "
        f"{args.ref_step:g} s with its error estimated from h vs 2h). Each run is timed once; a "
        "single timing moves by tens of per cent with the machine's load, so every run within 1 cm "
        f"whose timing is within {CLOSE:g}x of the cheapest at its (scene, n) is timed again "
        f"in {args.repeats} blocks (round robin), each running it back to back until the runs' "
        f"walls add up to {args.block_wall:g} s (at least one run), and its cost is the median "
        "of the block means "
        "(columns `repeats` = blocks, `block_runs` = runs in all, `wall_spread` = largest / "
        "smallest block mean; `retime.py`): the cost per n, the slopes and the per-n targets "
        "read these medians.",
        "",
    ]


def _targets_section(targets: list[dict], args) -> list[str]:
    s = ["### Targets (issue #13)", "",
         "Each target of issue #13 with its measured value and whether it is met (`goal` `reported`: "
         "no goal, met = measured). Issue #5's targets (RTF >= 100 at n = 80, 10x MuJoCo at equal "
         "steps, RTF >= 1 at n = 2000, slope <= 1.3) are superseded by these and no longer listed. "
         "The node's real-time run and the recording overhead are their own commands, which "
         "`make bench` runs first, on a machine not yet loaded by the ladders: their rows are "
         "read from those commands' CSVs (`--realtime-csv`, `--recorder-csv`; each row says when "
         "its CSV was written).", "",
         _table(targets, ["target", "measured", "goal", "met", "detail"], digits=4), ""]
    lim = getattr(args, "large_n_from", 10**9)
    if lim < 10**9:
        s += [f"From n = {lim} on only {', '.join(args.large_n_integrators)} were run (the schemes "
              "cheapest within 1 cm at the largest n below it, see the cost table), to keep the "
              "invocation within its time.", ""]
    return s


def _mujoco_best_section(rows: list[dict]) -> list[str]:
    chosen = [r for r in rows if r["role"] in ("chosen", "best")]
    if not chosen:
        return []
    return ["### MuJoCo vs cable_sim, each at its best scheme and largest step within 1 cm", "",
            "Paper free fall, drag off in both. Every MuJoCo integrator (RK4, implicitfast, implicit, "
            "Euler; `mj_step(nstep=...)` per 0.5 s) and every fixed-step scheme of ours walks the step "
            "ladder from the largest step down; the first step within 1 cm of our drag-off reference "
            "(max joint-position error) is that scheme's largest step within 1 cm (`chosen`, timed "
            "again: best of `repeats`); per engine the fastest `chosen` row is `best`. The two `best` "
            "configurations are then timed again in interleaved pairs, alternating which engine goes "
            "first (`paired` rows of mujoco_best.csv); in each pair one MuJoCo run is matched by our "
            "runs repeated back to back over the same wall time (their count: `pair_our_runs`; our "
            "wall: their mean): the target's ratio is the median per-pair ratio, as two equal windows "
            "back to back see the same machine load on average. Every ladder "
            "run: mujoco_best.csv; plot: mujoco_best.png.", "",
            _table(chosen, ["engine", "integrator", "n", "step", "role", "repeats", "rtf",
                            "rtf_incl_inputs", "error_m"], digits=4), ""]


def _mujoco_section(mj_rows: list[dict]) -> list[str]:
    if not mj_rows:
        return []
    return ["### MuJoCo side by side at equal steps (paper free fall, drag OFF in both models)", "",
            "Same chain in MJCF (`cable_sim/analysis/bench/mujoco_chain.py`: slide joint + heave "
            "spring/damper + "
            "gravcomp for the platform, hinges with the same stiffness/damping on the relative "
            "angles, rod inertia m l^2/12, point load, buoyancy as constant `xfrc_applied`; drag "
            "omitted, it has no MuJoCo counterpart without a per-step Python callback). MuJoCo "
            "runs `mj_step(m, d, nstep=...)` per 0.5 s (no per-step Python loop; what such a loop "
            "costs is in `us_per_step_python_loop`); ours one compiled call per 0.5 s. "
            "`speed_vs_mujoco_rk4` = MuJoCo RK4 wall time / this row's wall time, same n, step "
            "and duration, measured in the same process. Error vs our reference with drag off.", "",
            _table(mj_rows, ["engine", "integrator", "n", "step", "status", "rtf", "us_per_step",
                             "us_per_step_python_loop", "speed_vs_mujoco_rk4", "error_m"]), ""]


def _cost_section(cost_rows: list[dict], slopes: dict) -> list[str]:
    best = [r for r in cost_rows if r["integrator"] == "best"]
    if not best:
        return []
    return ["### Cheapest run within 1 cm, per scene and n", "",
            _table(best, ["scene", "n", "duration", "chosen", "step", "rtol", "rtf", "rtf_incl_inputs",
                          "error_m"]), "",
            "Fitted slopes of cost vs n (n = 40..640): "
            + ", ".join(f"{k} {_fmt(v, 4)}" for k, v in slopes.items()), ""]


def _discretisation_section(disc: list[dict]) -> list[str]:
    if not disc:
        return []
    return ["### Discretisation error in n (reference runs vs the finest n)", "",
            "Scene.with_links holds EI, bending damping and the per-length properties fixed, but the "
            "paper drag's gamma_i is a per-link constant (its torque gamma l^2/4 thetadot^2 summed "
            "over the links scales like 1/n): with the paper drag the line's physics changes with n, "
            "and the paper scenes' differences in n measure that as much as discretisation. The "
            "'(drag off)' rows are the same free fall without drag (the MuJoCo comparison's "
            "references).", "",
            _table(disc, ["scene", "n", "n_fine", "duration", "tip_error_m", "midline_error_m",
                          "tension_rel_error"]), ""]


def _contact_section(contact: list[dict]) -> list[str]:
    if not contact:
        return []
    return ["### Cost of seabed contact (mooring_line, issue #11 item 6)", "",
            "Per scheme: the largest step (fixed-step) or loosest tolerance (adaptive) of the ladder "
            "whose max joint-position error against DOP853 (rtol = atol = 1e-10, same n and seabed "
            "setting) is <= 1 cm, and the real-time factor there (shortest of 7 timings taken "
            "alternately with the seabed on and off), with the scene's seabed "
            "on and off in the same invocation; added mass on (the scene's Can 1.0, Cat 0.0) in both. "
            "`rtf_off_over_on` > 1: contact costs that factor. Every run: contact_cost_ladder.csv; "
            "plot: contact_cost.png.", "",
            _table(contact, ["integrator", "seabed_on", "rtf_on", "error_on_m", "seabed_off", "rtf_off",
                             "error_off_m", "rtf_off_over_on"]), ""]


def _peer_section(peer: list[dict]) -> list[str]:
    if not peer:
        return []
    return ["### MoorDyn as a second peer (mooring_line, issue #13)", "",
            "Same line in MoorDyn v2 (`cable_sim/analysis/bench/moordyn_input.py`: mass, diameter, "
            "Morison drag and added mass, seabed per area = cable_sim's per length / d, EI; EA large, "
            "line lowered 20 m below MoorDyn's free surface), its fairlead driven through cable_sim's "
            "converged buoy heave under the scene's wave. Each code at the cheapest segment count and "
            "step whose fairlead tension history is within 1 % (max over t of |T - T_conv| / max "
            "T_conv) of its own converged run, among the segment counts whose time-converged run is "
            "within 1 % on its own (rows with role time-converged in moordyn_ladder.csv); wall time "
            "per simulated second: the shortest of 5 timings "
            "taken alternately for the two codes (cable_sim: compiled stepping plus its input sampling; "
            "MoorDyn: its `Step` calls, 100 per simulated second); `*_rel_diff_vs_cable_sim`: the "
            "converged MoorDyn answer against the converged cable_sim one. Every run: "
            "moordyn_ladder.csv; plot: moordyn_tension.png.", "",
            _table(peer, ["code", "scheme", "segments", "step", "wall_per_sim_s", "rtf", "tension_rel_error",
                          "conv_static_tension_N", "conv_mean_tension_N", "conv_max_tension_N"], digits=4),
            "", _table(peer[1:], ["code", "converged", "static_rel_diff_vs_cable_sim",
                                  "mean_rel_diff_vs_cable_sim", "max_rel_diff_vs_cable_sim",
                                  "history_rel_diff_vs_cable_sim"]), ""]


def _footer(wp: list[dict]) -> list[str]:
    s = []
    nres = sum(1 for r in wp if r.get("source", "this run") != "this run")
    if nres:
        srcs = sorted({r["source"] for r in wp if r.get("source", "this run") != "this run"})
        s += [f"{nres} of the work-precision rows were measured by an earlier invocation with the same "
              f"settings and taken over with `--resume` ({', '.join(srcs)}; column `source`).", ""]
    nfail = sum(1 for r in wp if r["status"].startswith("failed"))
    nskip = sum(1 for r in wp if r["status"].startswith("skipped"))
    s += [f"Work-precision runs: {len(wp)} ({nfail} failed (blow-up or check), {nskip} skipped by the "
          "per-run budget or --max-wall; see workprecision.csv). Plots: workprecision_<scene>.png, "
          "error_vs_n.png, cost_vs_n.png.", ""]
    return s


def make_summary(argv, kernel, why, integs, args, wp, disc, cost_rows, slopes, mj_rows, targets,
                 elapsed, contact: list[dict] | None = None, peer: list[dict] | None = None,
                 mj_best: list[dict] | None = None) -> str:
    """The markdown snippet for the README (also printed); ``contact``, ``peer`` and ``mj_best``
    are the rows of the seabed-cost, MoorDyn and MuJoCo best-scheme studies (none: no section)."""
    s = _header(argv, kernel, why, integs, args, wp, elapsed)
    s += _targets_section(targets, args)
    s += _mujoco_best_section(mj_best or [])
    s += _mujoco_section(mj_rows)
    s += _contact_section(contact or [])
    s += _peer_section(peer or [])
    s += _cost_section(cost_rows, slopes)
    s += _discretisation_section(disc)
    s += _footer(wp)
    return "\n".join(s)
