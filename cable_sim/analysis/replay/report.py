"""A run's numbers: the summary (:func:`summary_values`, :func:`summary`) and the CSV export.

Part of the analysis layer: may import every layer; here numpy and :mod:`.load` only.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

from .load import Run


def rms(x: np.ndarray) -> float:
    """Root mean square (nan for no samples)."""
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def seabed_values(run: Run) -> dict[str, Any]:
    """Ranges of the recorded ``seabed_contact`` values (empty dict when there are none).

    ``touchdown_x_min``/``max`` [m] and ``touchdown_excursion`` (max - min) [m],
    ``touchdown_arc_min``/``max`` [m] (arc length from the anchor), ``laid_length_min``/``max``
    [m], ``seabed_reaction_max`` [N], ``seabed_samples`` and ``seabed_contact_samples`` (those
    with a laid length > 0). Samples without contact count with the published convention
    (touchdown at the anchor, laid length 0).
    """
    v = run.seabed.v
    if not len(v):
        return {}
    td_arc, td_x, laid, reaction = v[:, 0], v[:, 1], v[:, 2], v[:, 3]
    return {
        "touchdown_x_min": float(td_x.min()), "touchdown_x_max": float(td_x.max()),
        "touchdown_excursion": float(td_x.max() - td_x.min()),
        "touchdown_arc_min": float(td_arc.min()), "touchdown_arc_max": float(td_arc.max()),
        "laid_length_min": float(laid.min()), "laid_length_max": float(laid.max()),
        "seabed_reaction_max": float(reaction.max()),
        "seabed_samples": int(len(v)), "seabed_contact_samples": int(np.count_nonzero(laid > 0.0)),
    }


def summary_values(run: Run) -> dict[str, Any]:
    """The numbers :func:`summary` prints (with :func:`seabed_values` when the run recorded
    ``seabed_contact``)."""
    ten = run.fairlead_tension
    tip0 = run.tip[0]
    exc = np.linalg.norm(run.tip - tip0, axis=1)
    rtf = run.diagnostic("real", "time", "factor") or run.diagnostic("rtf")
    rej = run.diagnostic("rejected")
    ovr = run.diagnostic("overrun")
    return {
        "scene": run.scene.name,
        "n_links": run.n_links,
        "kernel": run.run_info.get("kernel", ""),
        "integrator": run.run_info.get("integrator", ""),
        "step": run.step,
        "clock_mode": run.run_info.get("clock_mode", ""),
        "duration": float(run.t[-1] - run.t[0]) if len(run.t) else 0.0,
        "t_end": float(run.t[-1]),
        "real_time_factor": float(rtf.v[-1]) if rtf is not None and len(rtf) else float("nan"),
        "fairlead_tension_max": float(ten.max()) if len(ten) else float("nan"),
        "fairlead_tension_rms": rms(ten),
        "tip_excursion_max": float(exc.max()),
        "joint_excursion_max": float(np.linalg.norm(run.polyline - run.polyline[:1], axis=2).max()),
        "rejected_inputs": int(rej.v[-1]) if rej is not None and len(rej) else 0,
        "overruns": int(ovr.v[-1]) if ovr is not None and len(ovr) else 0,
        "messages": dict(run.counts),
        **seabed_values(run),
    }


def summary(run: Run) -> str:
    """Human-readable summary of a run."""
    s = summary_values(run)
    # the node's counters arrive with /diagnostics (1 Hz by default, the first after a second):
    # a shorter run has none
    diagnosed = bool(run.diagnostics)
    lines = [
        f"file          {run.path}",
        f"scene         {s['scene']} (n = {s['n_links']}, {s['integrator']}, h = {s['step']:g} s, "
        f"kernel {s['kernel']}, clock {s['clock_mode']})",
        f"duration      {s['duration']:.3f} s simulated (t = {run.t[0]:.3f} .. {s['t_end']:.3f} s)",
        f"real-time     {s['real_time_factor']:.3g} x (last reported)" if diagnosed else
        "real-time     n/a (no diagnostics recorded: the run ended before the first)",
        f"fairlead T    max {s['fairlead_tension_max']:.6g} N, RMS {s['fairlead_tension_rms']:.6g} N",
        f"tip excursion max {s['tip_excursion_max']:.4g} m from its initial position "
        f"(any joint: {s['joint_excursion_max']:.4g} m)",
        f"rejected      {s['rejected_inputs']} inputs" if diagnosed else "rejected      n/a",
        f"overruns      {s['overruns']}" if diagnosed else "overruns      n/a",
    ]
    if "touchdown_x_min" in s:
        lines += [
            f"touchdown     x {s['touchdown_x_min']:.6g} .. {s['touchdown_x_max']:.6g} m (excursion "
            f"{s['touchdown_excursion']:.4g} m); arc length from the anchor {s['touchdown_arc_min']:.6g} "
            f".. {s['touchdown_arc_max']:.6g} m",
            f"laid length   {s['laid_length_min']:.6g} .. {s['laid_length_max']:.6g} m (line on the bed in "
            f"{s['seabed_contact_samples']} of {s['seabed_samples']} samples; seabed reaction max "
            f"{s['seabed_reaction_max']:.6g} N)",
        ]
    lines.append("messages      " + ", ".join(f"{k} {v}" for k, v in sorted(s["messages"].items())))
    return "\n".join(lines)


def export_csv(run: Run, out: str | Path) -> Path:
    """One row per joint-state sample: t, heave, tip x/z, fairlead force and tension, held
    inputs, absolute angles.

    Fairlead values are linearly interpolated onto the joint-state times when the two topics
    were published at different times (exact when they share stamps).
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    t = run.t
    if len(run.fairlead):
        fx = np.interp(t, run.fairlead.t, run.fairlead.v[:, 0])
        fz = np.interp(t, run.fairlead.t, run.fairlead.v[:, 1])
    else:
        fx = fz = np.full(len(t), np.nan)
    held = np.zeros((len(t), 2))
    if len(run.applied):
        j = np.searchsorted(run.applied_t_ns, run.t_ns, side="right") - 1
        ok = j >= 0
        held[ok] = run.applied.v[j[ok]]
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", "heave", "tip_x", "tip_z", "fairlead_fx", "fairlead_fz", "fairlead_tension",
                    "held_heave_force", "held_wave_elevation"]
                   + [f"theta_{i + 1}" for i in range(run.n_links)])
        for i in range(len(t)):
            w.writerow([repr(float(t[i])), repr(float(run.heave[i])), repr(float(run.tip[i, 0])),
                        repr(float(run.tip[i, 1])), repr(float(fx[i])), repr(float(fz[i])),
                        repr(float(np.hypot(fx[i], fz[i]))), repr(float(held[i, 0])),
                        repr(float(held[i, 1]))] + [repr(float(a)) for a in run.angles[i]])
    return out
