"""Animated GIF of a recorded run, bounded in length (:func:`gif_frame_indices`, :func:`animate`).

Part of the analysis layer: may import every layer; here numpy, matplotlib (lazily),
:mod:`.load` and :mod:`.plots`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .load import Progress, Run, Tenths
from .plots import draw_scene, frame_indices, pyplot


def gif_frame_indices(run: Run, seconds: float = 10.0, fps: float = 10.0,
                      interval: float | None = None) -> np.ndarray:
    """Joint-state samples shown in a GIF of at most ``seconds * fps`` frames.

    Without ``interval``, a short run plays in real time (one frame every ``1 / fps`` s of
    simulation time) and a longer one is subsampled evenly to fit in ``seconds``. With
    ``interval`` [s], one frame every ``interval`` s, also subsampled evenly if that gives more
    than ``seconds * fps`` frames.

    Raises
    ------
    ValueError
        When ``seconds``, ``fps`` or ``interval`` is not > 0.
    """
    if not (np.isfinite(seconds) and seconds > 0):
        raise ValueError(f"gif seconds {seconds!r}: must be > 0 [s]")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"gif fps {fps!r}: must be > 0 [frames/s]")
    max_frames = max(1, int(seconds * fps + 1e-9))
    if interval is None:
        span = float(run.t[-1] - run.t[0])
        interval = max(1.0 / fps, span / max(1, max_frames - 1)) if span > 0 else 1.0 / fps
    idx = frame_indices(run, interval)
    if len(idx) > max_frames:
        idx = np.unique(idx[np.round(np.linspace(0, len(idx) - 1, max_frames)).astype(int)])
    return idx


def animate(run: Run, out: str | Path, interval: float | None = None, fps: float = 10.0,
            seconds: float = 10.0, progress: Progress | None = None) -> Path:
    """Animated GIF of the cable: at most ``seconds * fps`` frames played at ``fps``.

    Frames are chosen by :func:`gif_frame_indices` (a long run is subsampled to fit in
    ``seconds``); ``progress`` gets a line at every 10 % of the frames rendered.
    """
    plt = pyplot()
    from matplotlib.animation import PillowWriter

    idx = gif_frame_indices(run, seconds, fps, interval)
    fig, ax = plt.subplots(figsize=(6, 5.5))
    allp = run.polyline[idx]
    pad = 5.0
    ax.set_xlim(allp[..., 0].min() - pad, allp[..., 0].max() + pad)
    ax.set_ylim(allp[..., 1].min() - pad, max(allp[..., 1].max(), 0.0) + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    draw_scene(ax, run)
    (line,) = ax.plot([], [], "-o", ms=2, lw=1.2)
    (plat,) = ax.plot([], [], "s", ms=8, color="tab:red")
    txt = ax.set_title("")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = PillowWriter(fps=fps)
    n_frames = len(idx)
    if progress is not None:
        every = float(np.median(np.diff(run.t[idx]))) if n_frames > 1 else 0.0
        progress(f"{out.name}: rendering {n_frames} frames (one every {every:.3g} s of the run, "
                 f"{n_frames / fps:.3g} s at {fps:g} fps)")
    tick = Tenths(progress, n_frames, lambda j: f"{out.name}: frame {j}/{n_frames}")
    with writer.saving(fig, str(out), dpi=80):
        for i in idx:
            p = run.polyline[i]
            line.set_data(p[:, 0], p[:, 1])
            plat.set_data([p[0, 0]], [p[0, 1]])
            txt.set_text(f"{run.scene.name}  t = {run.t[i]:.2f} s")
            writer.grab_frame()
            tick()
    plt.close(fig)
    return out
