"""Run one case headless through :class:`cable_sim.scene.simulation.Simulation` and reduce it to a result row.

The case is given as a plain dict (picklable, no file access needed on the worker: the scene's
key/values are already resolved). A failure (bad parameters, blow-up, non-finite tension) gives a
row with ``status = "error"`` and the reason; :func:`run_case` never raises.
"""

from __future__ import annotations

import math
import socket
import time
import traceback
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from .extremes import mpm_rayleigh, upcrossing_peaks
from .fatigue import TNCurve, miner_damage

SECONDS_PER_YEAR = 365.25 * 24 * 3600.0

#: Row columns that hold simulated figures (bit-for-bit reproducible); the others are bookkeeping.
SIMULATED_COLUMNS = (
    "status", "error", "error_time", "n_samples",
    *(f"{e}_{s}" for e in ("fairlead", "anchor")
      for s in ("max", "min", "mean", "std", "mpm", "n_peaks", "damage", "damage_per_year")),
    "touchdown_excursion",
)


def package_version() -> str:
    """Installed cable_sim version (``unknown`` when not installed)."""
    try:
        return metadata.version("cable_sim")
    except metadata.PackageNotFoundError:
        return "unknown"


def case_spec(study: Any, case: Any, mcap_dir: str | None = None) -> dict[str, Any]:
    """The picklable description of one case of a study (see :func:`run_case`).

    ``mcap_dir``: where to record the case as MCAP when the study marks it (``record_mcap``);
    on a multi-machine cluster it must be a path every worker can write (shared file system).
    """
    marked = "all" in study.record_mcap or case.case_id in study.record_mcap
    return {
        "case_id": case.case_id, "index": case.index, "inputs": dict(case.inputs),
        "scene_values": dict(case.scene_values), "scene_hash": case.scene_hash,
        "duration": study.duration, "transient": study.transient,
        "output_interval": study.output_interval, "tn_curve": study.tn_curve.as_dict(),
        "mcap_path": f"{mcap_dir}/{case.case_id}.mcap" if (marked and mcap_dir) else None,
    }


def simulate_tensions(scene_values: dict[str, Any], duration: float, interval: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
    """Fairlead and anchor tension [N] sampled at t = k * interval, k = 0..floor(duration/interval).

    Returns (t, fairlead, anchor, simulation). Raises on failure (the caller turns it into a row).
    """
    from cable_sim.scene.scenes import scene_from_dict
    from cable_sim.scene.simulation import Simulation

    sim = Simulation(scene_from_dict(dict(scene_values)))
    n = int(math.floor(duration / interval + 1e-9))
    t = np.arange(n + 1) * interval
    fair = np.empty(n + 1)
    anch = np.empty(n + 1)
    for k in range(n + 1):
        if k:
            sim.run_until(t[k])
        out = sim.outputs()
        fair[k] = out.fairlead_tension
        anch[k] = float(np.hypot(*out.anchor_force))
        if not (math.isfinite(fair[k]) and math.isfinite(anch[k])):
            from cable_sim.integrate import IntegrationError

            raise IntegrationError(sim.t, "non-finite tension (blow-up)")
    return t, fair, anch, sim


def _stats(prefix: str, x: np.ndarray, tn: TNCurve, area: float, window: float) -> dict[str, Any]:
    mpm, _ = mpm_rayleigh(x)
    dmg = miner_damage(x, tn, area)
    return {
        f"{prefix}_max": float(x.max()), f"{prefix}_min": float(x.min()),
        f"{prefix}_mean": float(x.mean()), f"{prefix}_std": float(x.std()),
        f"{prefix}_mpm": mpm, f"{prefix}_n_peaks": int(upcrossing_peaks(x).size),
        f"{prefix}_damage": dmg, f"{prefix}_damage_per_year": dmg * SECONDS_PER_YEAR / window,
    }


def _record(spec: dict[str, Any]) -> dict[str, Any]:
    """Record the case as MCAP in the node's format (a second, headless run with the recorder)."""
    from cable_sim.analysis.replay import record_headless
    from cable_sim.scene.scenes import scene_from_dict

    try:
        Path(spec["mcap_path"]).parent.mkdir(parents=True, exist_ok=True)
        record_headless(scene_from_dict(dict(spec["scene_values"])), spec["mcap_path"], spec["duration"])
        return {"mcap_path": spec["mcap_path"], "mcap_error": None}
    except Exception as exc:  # noqa: BLE001 - a failed recording is reported in the row
        return {"mcap_path": None, "mcap_error": f"{type(exc).__name__}: {exc}"}


def run_case(spec: dict[str, Any]) -> dict[str, Any]:
    """Simulate one case and return its result row (never raises).

    Parameters
    ----------
    spec : dict
        From :func:`case_spec`: ``case_id``, ``index``, ``inputs``, ``scene_values``, ``scene_hash``,
        ``duration``, ``transient``, ``output_interval``, ``tn_curve``.

    Returns
    -------
    dict
        The inputs, ``status`` (``ok``/``error``), ``error`` and ``error_time``, statistics of
        fairlead/anchor tension after the transient (max, min, mean, std, Rayleigh MPM, number of
        peaks, Miner damage over the window and per year), ``touchdown_excursion`` (nan: the scene
        has no seabed), wall time (of the statistics run), real-time factor, package version, scene
        hash, host; ``mcap_path``/``mcap_error`` when the case is recorded (``spec["mcap_path"]``).
    """
    row: dict[str, Any] = {"case_id": spec["case_id"], "case_index": spec["index"], **spec["inputs"]}
    row.update({"status": "ok", "error": None, "error_time": float("nan")})
    row["n_samples"] = 0
    for c in SIMULATED_COLUMNS[4:]:
        row[c] = float("nan")
    tn = TNCurve(**spec["tn_curve"])
    t0 = time.perf_counter()
    sim = None
    try:
        t, fair, anch, sim = simulate_tensions(spec["scene_values"], spec["duration"],
                                               spec["output_interval"])
        keep = t >= spec["transient"] - 1e-9
        window = float(t[keep][-1] - t[keep][0]) or spec["output_interval"]
        area = tn.nominal_area(sim.scene.params.diameter if np.ndim(sim.scene.params.diameter) == 0
                               else float(np.mean(sim.scene.params.diameter)))
        row["n_samples"] = int(keep.sum())
        row.update(_stats("fairlead", fair[keep], tn, area, window))
        row.update(_stats("anchor", anch[keep], tn, area, window))
    except Exception as exc:  # noqa: BLE001 - a failed case is a row, never a crashed study
        row["status"] = "error"
        row["error"] = f"{type(exc).__name__}: {exc}"
        et = getattr(exc, "t", None)
        row["error_time"] = float(et) if isinstance(et, (int, float)) else float("nan")
        row["traceback"] = traceback.format_exc(limit=4)
    wall = time.perf_counter() - t0
    if spec.get("mcap_path") and row["status"] == "ok":
        row.update(_record(spec))
    row["wall_time"] = wall
    simulated = float(sim.t) if sim is not None else 0.0
    row["sim_time"] = simulated
    row["real_time_factor"] = simulated / wall if wall > 0 else float("nan")
    row["package_version"] = package_version()
    row["scene_hash"] = spec["scene_hash"]
    row["host"] = socket.gethostname()
    return row


__all__ = ["run_case", "case_spec", "simulate_tensions", "SIMULATED_COLUMNS", "package_version"]
