"""Figures of a recorded run: configuration frames (paper Figs. 9/10) and tension / heave series.

Also the helpers the GIF (:mod:`.gif`) shares: :func:`frame_indices`, :func:`pyplot`,
:func:`draw_scene`. Part of the analysis layer: may import every layer; here numpy, matplotlib
(lazily) and :mod:`.load`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .load import Run


def frame_indices(run: Run, interval: float | None) -> np.ndarray:
    """Joint-state samples nearest to every ``interval`` seconds of the run (default: the scene's
    ``frame_interval``, else 1 s).

    Raises
    ------
    ValueError
        When ``interval`` is not > 0.
    """
    if interval is None:
        interval = float(run.scene.extra.get("frame_interval", 1.0))
    if interval <= 0:
        raise ValueError(f"frame interval {interval!r}: must be > 0 [s]")
    targets = np.arange(run.t[0], run.t[-1] + 1e-9, interval)
    idx = np.unique(np.clip(np.searchsorted(run.t, targets - 1e-9), 0, len(run.t) - 1))
    return idx


def pyplot():
    """``matplotlib.pyplot`` on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def draw_scene(ax, run: Run) -> None:
    """The anchor (if any) and the still water line."""
    m = run.scene.model()
    if m.end != 0:
        ax.plot(*m.anchor, marker="^", color="k", ms=9, ls="none", label="anchor")
    ax.axhline(0.0, color="tab:blue", lw=0.8, alpha=0.5)


def _save(plt, fig, out: str | Path) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_frames(run: Run, out: str | Path, interval: float | None = None, title: str | None = None) -> Path:
    """The cable's configuration every ``interval`` seconds, one x-z figure (paper Figs. 9/10).

    The platform (fairlead) is drawn at the top of each polyline; equal aspect.
    """
    plt = pyplot()
    idx = frame_indices(run, interval)
    fig, ax = plt.subplots(figsize=(7.5, 7.0))
    cmap = plt.get_cmap("viridis")
    for j, i in enumerate(idx):
        c = cmap(j / max(1, len(idx) - 1))
        p = run.polyline[i]
        ax.plot(p[:, 0], p[:, 1], "-", color=c, lw=1.0)
        ax.plot(p[0, 0], p[0, 1], "s", color=c, ms=5)
    draw_scene(ax, run)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    step = float(np.median(np.diff(run.t[idx]))) if len(idx) > 1 else 0.0
    ax.set_title(title or f"{run.scene.name}: {len(idx)} frames every {step:g} s, "
                 f"t = {run.t[idx[0]]:g}..{run.t[idx[-1]]:g} s (platform ■ at top)")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(run.t[idx[0]], run.t[idx[-1]]))
    fig.colorbar(sm, ax=ax, label="t [s]", shrink=0.8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return _save(plt, fig, out)


def plot_tension(run: Run, out: str | Path, title: str | None = None) -> Path:
    """Fairlead tension (and anchor force) and platform heave against time."""
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    if len(run.fairlead):
        a1.plot(run.fairlead.t, run.fairlead_tension / 1e3, label="fairlead |F| (cable on platform)")
    if len(run.anchor):
        a1.plot(run.anchor.t, np.hypot(*run.anchor.v.T) / 1e3, label="anchor |F|", alpha=0.8)
    a1.set_ylabel("tension [kN]")
    a1.legend(loc="best")
    a1.grid(True, alpha=0.3)
    a2.plot(run.t, run.heave, color="tab:green")
    a2.set_ylabel("heave z_m [m]")
    a2.set_xlabel("t [s]")
    a2.grid(True, alpha=0.3)
    a1.set_title(title or f"{run.scene.name}: fairlead tension and platform heave")
    fig.tight_layout()
    return _save(plt, fig, out)
