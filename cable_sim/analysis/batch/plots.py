"""Study plots (matplotlib, Agg): max-tension heat map over (Hs, Tp), exceedance curves, damage shares."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def heatmap(rows: list[dict[str, Any]], path: Path, end: str = "fairlead") -> Path | None:
    """Mean over seeds of the max tension on the (wave_hs, wave_tp) grid; None without both keys."""
    ok = [r for r in rows if r.get("status") == "ok" and r.get("wave_hs") is not None
          and r.get("wave_tp") is not None]
    if not ok:
        return None
    hs = sorted({float(r["wave_hs"]) for r in ok})
    tp = sorted({float(r["wave_tp"]) for r in ok})
    grid = np.full((len(hs), len(tp)), np.nan)
    for i, h in enumerate(hs):
        for j, t in enumerate(tp):
            v = [r[f"{end}_max"] for r in ok if float(r["wave_hs"]) == h and float(r["wave_tp"]) == t]
            if v:
                grid[i, j] = np.mean(v) / 1e3
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5, 4))
    im = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis")
    ax.set_xticks(range(len(tp)), [f"{t:g}" for t in tp])
    ax.set_yticks(range(len(hs)), [f"{h:g}" for h in hs])
    for i in range(len(hs)):
        for j in range(len(tp)):
            if np.isfinite(grid[i, j]):
                ax.text(j, i, f"{grid[i, j]:.0f}", ha="center", va="center", color="w", fontsize=8)
    ax.set_xlabel("Tp [s]")
    ax.set_ylabel("Hs [m]")
    ax.set_title(f"max {end} tension [kN] (mean over seeds)")
    fig.colorbar(im, ax=ax, label="kN")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def exceedance(rows: list[dict[str, Any]], keys: list[str], path: Path, end: str = "fairlead") -> Path | None:
    """Empirical exceedance of the per-case maxima, one curve per sea state (seeds pooled)."""
    ok = [r for r in rows if r.get("status") == "ok"]
    if not ok:
        return None
    groups: dict[tuple, list[float]] = {}
    for r in ok:
        groups.setdefault(tuple(r.get(k) for k in keys), []).append(r[f"{end}_max"] / 1e3)
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    for k, v in sorted(groups.items(), key=lambda kv: str(kv[0])):
        x = np.sort(v)
        p = 1.0 - (np.arange(1, x.size + 1) - 0.5) / x.size  # Hazen plotting position
        ax.semilogy(x, p, "o-", label=", ".join(f"{a}={b}" for a, b in zip(keys, k, strict=False)) or "all")
    ax.set_xlabel(f"max {end} tension over a case [kN]")
    ax.set_ylabel("exceedance probability")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def damage_contributions(rows: list[dict[str, Any]], keys: list[str], path: Path,
                         end: str = "fairlead") -> Path | None:
    """Share of the total annual damage per sea state (equal occurrence assumed, seeds averaged)."""
    ok = [r for r in rows if r.get("status") == "ok"]
    if not ok:
        return None
    groups: dict[tuple, list[float]] = {}
    for r in ok:
        groups.setdefault(tuple(r.get(k) for k in keys), []).append(r[f"{end}_damage_per_year"])
    labels = [", ".join(f"{a}={b}" for a, b in zip(keys, k, strict=False)) or "all" for k in groups]
    d = np.array([np.mean(v) for v in groups.values()])
    share = d / d.sum() if d.sum() > 0 else d
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 0.4 * len(labels) + 1.5))
    ax.barh(range(len(labels)), 100 * share)
    ax.set_yticks(range(len(labels)), labels, fontsize=7)
    ax.set_xlabel(f"share of {end} fatigue damage [%] (equal occurrence)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_plots(rows: list[dict[str, Any]], keys: list[str], out: Path) -> list[Path]:
    """All study plots into ``out``; returns the files written."""
    out.mkdir(parents=True, exist_ok=True)
    made = [heatmap(rows, out / "max_tension_heatmap.png"),
            exceedance(rows, keys, out / "exceedance.png"),
            damage_contributions(rows, keys, out / "damage_contributions.png")]
    return [p for p in made if p is not None]


__all__ = ["heatmap", "exceedance", "damage_contributions", "write_plots"]
