"""``--resume``: work-precision rows measured by an earlier invocation, keyed like the runs.

Part of the analysis layer; imports nothing from cable_sim.
"""

from __future__ import annotations

import csv

_RESUMABLE = ("ok", "failed", "skipped: projected", "skipped: over budget")
_INT_COLS = ("n", "nfev", "halved")
_STR_COLS = ("scene", "kernel", "integrator", "kind", "status", "reference", "timing", "source")


def row_key(scene: str, n: int, integ: str, setting: float, duration: float, kernel: str) -> tuple:
    """What identifies a work-precision run (settings rounded to the CSV's 6 digits)."""
    return (scene, int(n), integ, float(f"{setting:.6g}"), float(f"{duration:.6g}"), kernel)


def row_setting(row: dict) -> float:
    """The setting of a work-precision row: its step [s] (fixed) or rtol = atol (adaptive)."""
    return row["rtol"] if row["kind"] == "adaptive" else row["step"]


def load_resume(paths) -> dict[tuple, dict]:
    """Measured rows of earlier ``workprecision.csv`` files, keyed like the runs (see --resume)."""
    rows: dict[tuple, dict] = {}
    for p in paths:
        with open(p, newline="") as f:
            for r in csv.DictReader(f):
                if not r["status"].startswith(_RESUMABLE):
                    continue
                row = {k: (v if k in _STR_COLS else int(v) if k in _INT_COLS
                           else float(v) if v != "" else float("nan")) for k, v in r.items()}
                if row.get("source", "this run") == "this run":
                    row["source"] = str(p)
                rows[row_key(row["scene"], row["n"], row["integrator"], row_setting(row), row["duration"],
                             row["kernel"])] = row
    return rows
