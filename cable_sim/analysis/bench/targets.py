"""Issue #13's targets: measured value, goal, met or not, detail (rows of targets.csv).

Each row has ``goal`` ``">= x"``, ``"<= x"`` or ``"reported"`` and ``met`` the comparison of
``measured`` with it (:func:`goal_met`; a reported figure is met when it was measured). The
targets of issue #5 (RTF >= 100 at n = 80, 10x MuJoCo at equal steps, RTF >= 1 at n = 2000,
slope <= 1.3) are superseded by these and no longer reported.

Two figures come from their own commands, which ``make bench`` runs before ``cable_sim_bench``,
and are read from their CSVs when present (each row says when its CSV was written): the node's
real-time run at n = 2000 (``realtime_bench``) and the recording overhead in fast mode
(``recorder_bench``).

Part of the analysis layer; imports numpy and the bench modules only.
"""

from __future__ import annotations

import csv
import math
from datetime import UTC, datetime
from pathlib import Path

from .cost import best_under
from .runs import is_adaptive
from .settings import ERROR_BOUND

#: Goals of issue #13.
GOAL_RTF_80 = 2000.0
GOAL_RTF_80_MORISON = 5000.0
GOAL_STEP = {80: 0.05, 640: 0.02}
GOAL_RTF_2000 = 20.0
GOAL_SLOPE = 1.1
GOAL_MUJOCO_RATIO = 50.0
GOAL_OVERRUNS = 0.0
GOAL_RECORD_OVERHEAD = 0.15
#: The duration the paper free-fall targets are stated for [s].
FREE_FALL_FULL = 31.0
#: Row label of the paper free fall with Morison drag in workprecision.csv.
MORISON_LABEL = "paper_free_fall+morison"


def goal_met(measured: float, goal: str) -> bool:
    """``measured`` against ``goal`` (``">= x"``, ``"<= x"``, or ``"reported"``: measured)."""
    if not math.isfinite(measured):
        return False
    if goal == "reported":
        return True
    op, val = goal.split()
    return measured >= float(val) if op == ">=" else measured <= float(val)


def _row(target: str, measured: float, goal: str, detail: str, full: bool = True) -> dict:
    return dict(target=target, measured=measured, goal=goal,
                met=bool(full and goal_met(measured, goal)), detail=detail)


def _setting(b: dict) -> str:
    return f"h={b['step']:g} s" if b["kind"] == "fixed" else f"rtol={b['rtol']:g}"


def _rtf_target(wp: list[dict], scene: str, n: int, goal: float, what: str) -> dict:
    """Best real-time factor of ``scene`` (a workprecision label) at n within the error bound."""
    b = best_under(wp, scene, n, ERROR_BOUND)
    target = f"n={n}, {what}: best real-time factor at <= 1 cm max joint-position error"
    if b is None:
        return _row(target, float("nan"), f">= {goal:g}", f"n={n} not run, or no run within 1 cm")
    full = b["duration"] >= FREE_FALL_FULL - 1e-9
    detail = (f"{b['integrator']} {_setting(b)}, error {b['error_m']:.3g} m over {b['duration']:g} s "
              f"vs {b['reference']}; RTF incl. input sampling {b['rtf_incl_inputs']:.4g}")
    if not full:
        detail += f"; only {b['duration']:g} s simulated (target is over 31 s: run --full)"
    return _row(target, b["rtf"], f">= {goal:g}", detail, full)


def _step_target(wp: list[dict], n: int, goal: float) -> dict:
    """Largest fixed step of the paper free fall (paper drag) at n within the error bound."""
    ok = [r for r in wp if r["scene"] == "paper_free_fall" and r["n"] == n and r["kind"] == "fixed"
          and r["status"] == "ok" and r["error_m"] <= ERROR_BOUND]
    target = f"n={n}, paper drag, free fall: largest step within 1 cm [s]"
    if not ok:
        return _row(target, float("nan"), f">= {goal:g}", f"n={n} not run, or no fixed step within 1 cm")
    b = max(ok, key=lambda r: (r["step"], r["rtf"]))
    ties = sorted({r["integrator"] for r in ok if r["step"] == b["step"]})
    stable = [r for r in wp if r["scene"] == "paper_free_fall" and r["n"] == n and r["kind"] == "fixed"
              and r["status"] == "ok"]
    big = max(stable, key=lambda r: r["step"])
    halved = int(b.get("halved", 0) or 0)
    if halved:  # say that the fixed step was not kept everywhere
        ties = [f"{t} ({halved} step attempts halved where its Newton iteration did not converge)"
                if t == b["integrator"] else t for t in ties]
    detail = (f"{', '.join(ties)} (error {b['error_m']:.3g} m, RTF {b['rtf']:.4g}); largest stable "
              f"step of the ladder {big['step']:g} s ({big['integrator']}, error {big['error_m']:.3g} m)")
    return _row(target, b["step"], f">= {goal:g}", detail + _adaptive_mean_step(wp, n),
                b["duration"] >= FREE_FALL_FULL - 1e-9)


def _adaptive_mean_step(wp: list[dict], n: int) -> str:
    """The adaptive run within 1 cm with the largest mean accepted step (duration / accepted
    steps) at n, as a sentence of the step target's detail ("" without one)."""
    ok = [r for r in wp if r["scene"] == "paper_free_fall" and r["n"] == n and r["kind"] == "adaptive"
          and r["status"] == "ok" and r["error_m"] <= ERROR_BOUND
          and math.isfinite(float(r.get("mean_step", "nan") or "nan"))]
    if not ok:
        return ""
    a = max(ok, key=lambda r: float(r["mean_step"]))
    steps = round(float(a["duration"]) / float(a["mean_step"]))
    return (f"; adaptive: {a['integrator']} rtol={float(a['rtol']):g} within 1 cm "
            f"(error {float(a['error_m']):.3g} m) with a mean step of {float(a['mean_step']):.3g} s "
            f"({steps} accepted steps)")


#: What a drag variant's cost slope, reported in its scene's slope row, shows.
VARIANT_SLOPE_NOTE = {
    MORISON_LABEL: "the same free fall with Morison drag (per unit length, so the same line at "
                   "every n; the paper's drag, a coefficient gamma l^2/4 per link, gives the line a "
                   "total drag falling as 1/n and a per-link stiffness rising with n, so with it the "
                   "problem itself changes with n)",
}


def _variant_detail(scene: str, variants: dict[str, tuple[float, float]]) -> str:
    """The detail's part on the drag variants of ``scene`` (labels ``scene+...``) whose slope
    over n = 40..640 was measured: ``variants[label] = (slope 40..640, slope 160..640)``."""
    out = ""
    for label, (whole, large) in sorted(variants.items()):
        if label.split("+")[0] != scene or not math.isfinite(whole):
            continue
        out += f"; {VARIANT_SLOPE_NOTE.get(label, label)}: {whole:.2f}"
        if math.isfinite(large):
            out += f" (n = 160..640: {large:.2f})"
        out += f", rows {label} in cost_vs_n.csv"
    return out


def _slope_rows(slopes: dict[str, float], large_n: dict[str, float] | None = None,
                variants: dict[str, tuple[float, float]] | None = None) -> list[dict]:
    """One row per scene; ``large_n``: the slope over n = 160..640 alone, in the detail;
    ``variants``: the two slopes of each drag variant measured at several n (label
    ``scene+drag``, e.g. :data:`MORISON_LABEL`), in its scene's detail (not a target)."""
    large_n = large_n or {}
    variants = variants or {}
    return [_row(f"{scene}: slope of cost per simulated s vs n at <= 1 cm, n = 40..640", s,
                 f"<= {GOAL_SLOPE:g}", "log-log least-squares fit of the cheapest run within 1 cm per n"
                 + (f"; over n = 160..640 alone: {large_n[scene]:.2f}"
                    if math.isfinite(large_n.get(scene, float("nan"))) else "")
                 + _variant_detail(scene, variants))
            for scene, s in slopes.items()]


def _mujoco_target(best: list[dict]) -> dict:
    """Our best RTF within 1 cm over MuJoCo's best, n = 80, drag off (:mod:`.mujoco_best`): the
    median per-pair ratio of the two bests timed in interleaved pairs of equal wall windows
    (``paired`` rows: one MuJoCo run against our runs repeated over the same wall time), else,
    without paired rows, the ratio of the two ``best`` rows (each best of its repeats, timed
    apart), which the detail then says."""
    target = ("vs MuJoCo, n=80, drag off, each engine at its best scheme and largest step within "
              "1 cm: ratio of real-time factors")
    ours = next((r for r in best if r["engine"].startswith("cable_sim") and r["role"] == "best"), None)
    mj = next((r for r in best if r["engine"].startswith("mujoco") and r["role"] == "best"), None)
    if ours is None or mj is None:
        return _row(target, float("nan"), f">= {GOAL_MUJOCO_RATIO:g}",
                    "not measured (mujoco missing, --no-mujoco, or no run within 1 cm)")
    ratio = ours["rtf"] / mj["rtf"]
    how = (f"rtol=atol={float(ours['rtol']):g} (mean step {ours['step']:.3g} s)"
           if is_adaptive(ours["integrator"]) else f"h={ours['step']:g} s")
    detail = (f"ours {ours['integrator']} {how} RTF {ours['rtf']:.4g} "
              f"(incl. input sampling {ours['rtf_incl_inputs']:.4g}), error {ours['error_m']:.2g} m; "
              f"{mj['engine']} {mj['integrator']} h={mj['step']:g} s RTF {mj['rtf']:.4g}, error "
              f"{mj['error_m']:.2g} m; n={ours['n']}, {ours['duration']:g} s, best of "
              f"{ours['repeats']}/{mj['repeats']} timings")
    p_ours = next((r for r in best if r["engine"].startswith("cable_sim") and r["role"] == "paired"), None)
    p_mj = next((r for r in best if r["engine"].startswith("mujoco") and r["role"] == "paired"), None)
    if p_ours is None or p_mj is None:
        return _row(target, ratio, f">= {GOAL_MUJOCO_RATIO:g}",
                    f"no paired timings: ratio of the two best-of-repeats RTFs, timed apart; {detail} "
                    "(mujoco_best.csv)")
    counts = [int(m) for m in str(p_ours.get("pair_our_runs") or "").split(";") if m]
    runs = f"{min(counts)} .. {max(counts)} runs of ours" if counts else "runs of ours"
    paired = (f"median of {p_ours['repeats']} interleaved pairs of equal wall windows (each pair: one "
              f"MuJoCo run and {runs} back to back over the same wall time, their mean wall; "
              f"per-pair ratio our RTF / MuJoCo's, "
              f"range {p_ours['pair_ratio_min']:.4g} .. {p_ours['pair_ratio_max']:.4g}; median walls: "
              f"ours RTF {p_ours['rtf']:.4g}, MuJoCo RTF {p_mj['rtf']:.4g}); ladder bests: {detail}, "
              f"ratio {ratio:.4g} (mujoco_best.csv)")
    return _row(target, p_ours["pair_ratio_median"], f">= {GOAL_MUJOCO_RATIO:g}", paired)


def _read_csv(path: Path) -> list[dict]:
    with path.open() as f:
        return list(csv.DictReader(f))


def _written(path: Path) -> str:
    """When ``path`` was last written (UTC), so that a reader sees whether it is this run's."""
    stamp = datetime.fromtimestamp(path.stat().st_mtime, tz=UTC)
    return stamp.strftime("%Y-%m-%d %H:%M UTC")


def realtime_target(path: Path) -> dict:
    """Overruns of the node's real-time run at n = 2000 with recording on (realtime_bench's CSV)."""
    target = "node at n=2000, real time, recording on: overruns over 60 s"
    goal = f"<= {GOAL_OVERRUNS:g}"
    if not path.exists():
        return _row(target, float("nan"), goal, f"not measured in this run ({path} missing)")
    rows = [r for r in _read_csv(path) if r.get("record") == "True" and r.get("n_links") == "2000"]
    if not rows:
        return _row(target, float("nan"), goal,
                    f"not measured in this run (no n=2000 recording row in {path})")
    r = rows[-1]
    secs = float(r["seconds"])
    detail = (f"from {path}, written {_written(path)} (its own command, which make bench runs "
              "before cable_sim_bench: python -m cable_sim.analysis.realtime_bench --seconds 60 "
              f"--record --n-links 2000 --tag n2000, the default scene as shipped): {r['scene']}, "
              f"{r['integrator']} h={float(r['step_s']):g} s, {secs:g} s, {r['ticks']} ticks, RTF "
              f"{float(r['real_time_factor']):.4g}, longest tick {float(r['longest_tick_ms']):.3g} ms")
    return _row(target, float(r["overruns"]), goal, detail, secs >= 60.0 - 1e-9)


def recording_target(path: Path) -> dict:
    """Recording overhead of the node in fast mode (recorder_bench's ``node_overhead`` row)."""
    target = "recording overhead in fast mode (n=80, default rates), fraction of steps/s"
    goal = f"<= {GOAL_RECORD_OVERHEAD:g}"
    if not path.exists():
        return _row(target, float("nan"), goal, f"not measured in this run ({path} missing)")
    rows = [r for r in _read_csv(path) if r.get("kind") == "node_overhead" and r.get("overhead")]
    if not rows:
        return _row(target, float("nan"), goal, f"not measured in this run (no node_overhead row in {path})")
    r = rows[-1]
    spread = (f", median of {r['pairs']} alternated pairs ({float(r['overhead_min']):.3g} .. "
              f"{float(r['overhead_max']):.3g})" if r.get("pairs") else "")
    return _row(target, float(r["overhead"]), goal,
                f"from {path}, written {_written(path)} (its own command, which make bench runs "
                f"before cable_sim_bench: python -m cable_sim.analysis.recorder_bench --repeats "
                f"{r.get('pairs') or '?'}): the node in fast mode, steps/s "
                f"{r.get('mode') or 'record vs no record'}{spread}")


def peer_target(peer: list[dict]) -> dict:
    """MoorDyn's wall time per simulated second over cable_sim's (each within 1 % of its own
    converged fairlead tension)."""
    target = "MoorDyn peer (mooring_line): MoorDyn wall per simulated s / cable_sim's, each within 1 %"
    cs = next((r for r in peer if r["code"].startswith("cable_sim")), None)
    md = next((r for r in peer if r["code"].startswith("moordyn")), None)
    if cs is None or md is None:
        return _row(target, float("nan"), "reported", "not run (--no-moordyn, moordyn missing, or failed)")
    detail = (f"cable_sim {cs['scheme']} n={cs['segments']} h={cs['step']:g} s "
              f"{1e3 * cs['wall_per_sim_s']:.3g} ms per s; {md['code']} {md['scheme']} {md['segments']} "
              f"segments dtM={md['step']:g} s {1e3 * md['wall_per_sim_s']:.3g} ms per s; converged "
              f"answers: static {100 * md['static_rel_diff_vs_cable_sim']:+.2f} %, max "
              f"{100 * md['max_rel_diff_vs_cable_sim']:+.2f} % (moordyn.csv)")
    return _row(target, md["wall_per_sim_s"] / cs["wall_per_sim_s"], "reported", detail)


def contact_target(contact: list[dict]) -> dict:
    """Cost of seabed contact: best RTF without the seabed over the best with it."""
    target = "seabed contact cost (mooring_line): best RTF at <= 1 cm, seabed off / on"
    on = [r for r in contact if math.isfinite(r["rtf_on"])]
    off = [r for r in contact if math.isfinite(r["rtf_off"])]
    if not on or not off:
        return _row(target, float("nan"), "reported", "not run (--no-contact) or nothing within 1 cm")
    bon, boff = max(on, key=lambda r: r["rtf_on"]), max(off, key=lambda r: r["rtf_off"])
    per = [r["rtf_off_over_on"] for r in contact if math.isfinite(r["rtf_off_over_on"])]
    detail = (f"on: {bon['integrator']} {bon['seabed_on']} RTF {bon['rtf_on']:.4g}; off: "
              f"{boff['integrator']} {boff['seabed_off']} RTF {boff['rtf_off']:.4g}; per scheme at its "
              f"own largest step {min(per):.3g}-{max(per):.3g}x (contact_cost.csv)" if per else "")
    return _row(target, boff["rtf_off"] / bon["rtf_on"], "reported", detail)


def make_targets(wp: list[dict], mj_best: list[dict], slopes: dict, contact: list[dict] | None = None,
                 peer: list[dict] | None = None, realtime_csv: Path | None = None,
                 recorder_csv: Path | None = None, large_n_slopes: dict | None = None,
                 variant_slopes: dict | None = None) -> list[dict]:
    """Issue #13's targets, one row each (see the module docstring); ``large_n_slopes``: the
    cost slopes over n = 160..640 alone, reported in the slope rows' detail; ``variant_slopes``:
    the drag variants' two slopes, reported there too (:func:`_slope_rows`)."""
    rows = [_rtf_target(wp, "paper_free_fall", 80, GOAL_RTF_80, "paper drag (paper_free_fall)"),
            _rtf_target(wp, MORISON_LABEL, 80, GOAL_RTF_80_MORISON,
                        "Morison drag (paper_free_fall, drag_model morison)")]
    rows += [_step_target(wp, n, g) for n, g in GOAL_STEP.items()]
    rows.append(_rtf_target(wp, "paper_free_fall", 2000, GOAL_RTF_2000, "paper drag, free fall"))
    rows += _slope_rows(slopes, large_n_slopes, variant_slopes)
    rows.append(_mujoco_target(mj_best))
    rows.append(realtime_target(realtime_csv) if realtime_csv else
                _row("node at n=2000, real time, recording on: overruns over 60 s", float("nan"),
                     f"<= {GOAL_OVERRUNS:g}", "not measured in this run"))
    rows.append(recording_target(recorder_csv) if recorder_csv else
                _row("recording overhead in fast mode (n=80, default rates), fraction of steps/s",
                     float("nan"), f"<= {GOAL_RECORD_OVERHEAD:g}", "not measured in this run"))
    rows.append(peer_target(peer or []))
    rows.append(contact_target(contact or []))
    return rows
