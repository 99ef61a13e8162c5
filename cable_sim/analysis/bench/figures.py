"""The benchmark's PNGs: work-precision per scene, discretisation error vs n, cost vs n.

Part of the analysis layer: may import every layer; here numpy, matplotlib (lazily) and
:mod:`.settings`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .settings import ERROR_BOUND


def _workprecision(plt, out: Path, wp: list[dict], scene: str, colours: dict[str, str]) -> None:
    """workprecision_<scene>.png: a panel per n, a line per integrator."""
    rows = [r for r in wp if r["scene"] == scene and r["status"] == "ok"]
    if not rows:
        return
    ns = sorted({r["n"] for r in rows})
    ncol = min(4, len(ns))
    nrow = int(math.ceil(len(ns) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), sharey=True,
                             squeeze=False)
    for ax, n in zip(axes.flat, ns, strict=False):
        for integ, colour in colours.items():
            rr = sorted([r for r in rows if r["integrator"] == integ and r["n"] == n],
                        key=lambda r: r["cost"])
            if rr:
                ax.loglog([r["cost"] for r in rr], [max(r["error_m"], 1e-12) for r in rr],
                          "o-", ms=3, color=colour, label=integ)
        ax.axhline(ERROR_BOUND, color="k", ls=":", lw=1)
        ax.axvline(0.01, color="r", ls=":", lw=1)
        ax.axvline(1.0, color="r", ls="--", lw=0.8)
        ax.set_title(f"n = {n}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes.flat[len(ns):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("wall s per simulated s")
    for ax in axes[:, 0]:
        ax.set_ylabel("max joint-position error [m]")
    axes.flat[0].legend(fontsize=7)
    dur = rows[0]["duration"]
    fig.suptitle(f"{scene} ({dur:g} s simulated, kernel {rows[0]['kernel']}): work-precision "
                 "(dotted: 1 cm and RTF 100; dashed: RTF 1)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / f"workprecision_{scene}.png", dpi=100)
    plt.close(fig)


def _discretisation(plt, out: Path, disc: list[dict]) -> None:
    """error_vs_n.png: position and fairlead tension differences against the finest n."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for i, scene in enumerate(dict.fromkeys(r["scene"] for r in disc)):
        rr = [r for r in disc if r["scene"] == scene and r["n"] != r["n_fine"]]
        if rr:
            lab = f"{scene} (vs n={rr[0]['n_fine']})"
            key, what = ("tip_error_m", "tip") if rr[0]["free_end"] else ("midline_error_m", "mid-line")
            axes[0].loglog([r["n"] for r in rr], [r[key] for r in rr], "o-", color=f"C{i}",
                           label=f"{lab}, {what}")
            axes[1].loglog([r["n"] for r in rr], [r["tension_rel_error"] for r in rr], "s-",
                           color=f"C{i}", label=lab)
    axes[0].set_ylabel("max position difference [m]")
    axes[0].set_title("tip (free end) / mid-line point (anchored)", fontsize=9)
    axes[1].set_title("fairlead tension", fontsize=9)
    axes[1].set_ylabel("max fairlead tension difference / max tension")
    for ax in axes:
        ax.set_xlabel("n links")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("discretisation error in n (reference runs; EI, mass per length fixed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "error_vs_n.png", dpi=100)
    plt.close(fig)


def _cost(plt, out: Path, cost_rows: list[dict], scenes, slopes: dict[str, float]) -> None:
    """cost_vs_n.png: the cheapest run within the bound per n, with the fitted slope (n >= 40)."""
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for i, scene in enumerate(scenes):
        rr = sorted([r for r in cost_rows if r["scene"] == scene and r["integrator"] == "best"],
                    key=lambda r: r["n"])
        if rr:
            ns = np.array([r["n"] for r in rr], dtype=float)
            cs = np.array([r["cost"] for r in rr])
            s = slopes.get(scene, float("nan"))
            ax.loglog(ns, cs, "o-", color=f"C{i}", label=f"{scene} (fitted slope n>=40: {s:.2f})")
            big = ns >= 40
            if np.isfinite(s) and big.sum() >= 2:
                c = np.polyfit(np.log(ns[big]), np.log(cs[big]), 1)
                ax.loglog(ns[big], np.exp(np.polyval(c, np.log(ns[big]))), ":", color=f"C{i}")
    ax.axhline(1.0, color="r", ls="--", lw=0.8)
    ax.axhline(0.01, color="r", ls=":", lw=0.8)
    ax.set_xlabel("n links")
    ax.set_ylabel(f"wall s per simulated s at error <= {ERROR_BOUND * 100:g} cm")
    ax.set_title("cost vs n (cheapest integrator/step within the bound)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "cost_vs_n.png", dpi=100)
    plt.close(fig)


def plots(out: Path, wp: list[dict], disc: list[dict], cost_rows: list[dict], scenes, slopes,
          extra: tuple[str, ...] = ()) -> None:
    """Work-precision per scene (a panel per n, a line per integrator), error vs n, cost vs n;
    ``extra``: further row labels of ``wp`` (e.g. a drag variant), with a work-precision plot and,
    where ``cost_rows`` has them, a line in the cost plot (``slopes`` may have theirs)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    integs_all = list(dict.fromkeys(r["integrator"] for r in wp))
    colours = {k: f"C{i}" for i, k in enumerate(integs_all)}
    for scene in [*scenes, *extra]:
        _workprecision(plt, out, wp, scene, colours)
    if disc:
        _discretisation(plt, out, disc)
    if cost_rows:
        _cost(plt, out, cost_rows, [*scenes, *extra], slopes)
