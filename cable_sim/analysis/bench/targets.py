"""The issue's targets: measured value, goal, met or not, detail (rows of targets.csv).

Part of the analysis layer; imports numpy and the bench modules only.
"""

from __future__ import annotations

import numpy as np

from .cost import best_under
from .settings import ERROR_BOUND

#: Target thresholds (issue #5).
TARGET_RTF_80 = 100.0
TARGET_MUJOCO_RATIO = 10.0
TARGET_RTF_2000 = 1.0
TARGET_SLOPE = 1.3
#: The duration the paper free-fall targets are stated for [s].
FREE_FALL_FULL = 31.0

_MUJOCO_TARGET = "paper free fall n=80 (drag off in both), same step: speed of our rk4 / MuJoCo RK4"


def _full_enough(row: dict) -> bool:
    return row["duration"] >= FREE_FALL_FULL - 1e-9


def _rtf_target(wp: list[dict], n: int, goal: float) -> dict:
    """Real-time factor of the paper free fall at n links within the error bound."""
    b = best_under(wp, "paper_free_fall", n, ERROR_BOUND)
    if b is None:
        detail = f"n={n} not run, or no run within 1 cm"
        met = False
    else:
        detail = (f"{b['integrator']} " + (f"h={b['step']:g} s" if b["kind"] == "fixed" else
                                           f"rtol={b['rtol']:g}")
                  + f", error {b['error_m']:.3g} m over {b['duration']:g} s vs {b['reference']}; "
                  f"RTF incl. Python input sampling {b['rtf_incl_inputs']:.3g}")
        met = b["rtf"] >= goal and _full_enough(b)
        if not _full_enough(b):
            detail += f"; only {b['duration']:g} s simulated (target is over 31 s: run --full)"
    return dict(target=f"paper free fall n={n}: real-time factor at <= 1 cm max joint-position "
                       "error", measured=b["rtf"] if b else float("nan"), goal=f">= {goal:g}",
                met=met, detail=detail)


def _mujoco_target(mj_rows: list[dict]) -> dict:
    """Speed of our rk4 over MuJoCo's RK4 at n = 80, same step."""
    mj = {(r["engine"].split()[0], r["integrator"], r["n"]): r for r in mj_rows}
    ref = mj.get(("mujoco", "RK4", 80))
    ours = mj.get(("cable_sim", "rk4", 80))
    if ref and ours and ref["status"] == "ok" and ours["status"] == "ok":
        ratio = ref["wall"] / ours["wall"]
        return dict(target=_MUJOCO_TARGET, measured=ratio,
                    goal=f">= {TARGET_MUJOCO_RATIO:g}", met=ratio >= TARGET_MUJOCO_RATIO,
                    detail=f"h={ref['step']:g} s, {ref['duration']:g} s simulated, same "
                           f"process, best of {ref['repeats']}; errors ours "
                           f"{ours['error_m']:.2g} m, MuJoCo {ref['error_m']:.2g} m")
    return dict(target=_MUJOCO_TARGET, measured=float("nan"),
                goal=f">= {TARGET_MUJOCO_RATIO:g}", met=False,
                detail="not measured (mujoco missing, n=80 not run, or a run failed)")


def make_targets(wp: list[dict], mj_rows: list[dict], slopes: dict) -> list[dict]:
    """The issue's targets: measured value, goal, met, detail (one row each)."""
    rows = [_rtf_target(wp, 80, TARGET_RTF_80), _mujoco_target(mj_rows),
            _rtf_target(wp, 2000, TARGET_RTF_2000)]
    for scene, s in slopes.items():
        rows.append(dict(target=f"{scene}: slope of cost per simulated s vs n at <= 1 cm (n >= 40)",
                         measured=s, goal=f"<= {TARGET_SLOPE:g}",
                         met=bool(np.isfinite(s) and s <= TARGET_SLOPE),
                         detail="log-log least-squares fit of the cheapest run within 1 cm per n"))
    return rows
