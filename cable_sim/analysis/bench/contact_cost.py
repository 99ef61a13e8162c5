"""Cost of seabed contact (issue #11 item 6): RTF at <= 1 cm on the mooring line, seabed on vs off.

For every scheme the benchmark runs (:func:`.runs.available_integrators`), on ``mooring_line`` at
n links (default 80), with the scene's seabed on (its default) and off (``seabed: false``), and
the scene's added mass (on, Can 1.0 / Cat 0.0) in both: the largest step (fixed-step schemes) or
loosest tolerance (adaptive ones) of the ladder whose max joint-position error against a tight
reference at the same n and seabed setting (DOP853, rtol = atol = ``rtol``, as
:mod:`.references`) is <= :data:`~.settings.ERROR_BOUND`, and the real-time factor there (the
shortest of ``repeats`` timings, see below). The ladder is walked from the largest step down
and stops at the first run within the bound (a failed or over-bound run moves on to the next
smaller step). The cost of
contact of a scheme is RTF(seabed off) / RTF(seabed on) at each one's own largest step within
1 cm; the chosen runs of both settings are timed again alternately (on, off, on, off, ...) so
that both see the same machine load, and the shortest wall time of each counts.

Rows (``contact_cost_ladder.csv``: every run; ``contact_cost.csv``: the chosen run per scheme and
seabed setting) and a bar chart (``contact_cost.png``).

Part of the analysis layer: may import every layer; here the bench modules only.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .references import reference
from .resume import row_setting
from .runs import error, is_adaptive, simulate
from .settings import ERROR_BOUND, log

SCENE = "mooring_line"
#: Scene overrides of the two cases (added mass stays the scene's: on).
CASES = {"on": {}, "off": {"seabed": False}}


def _ladder(integ: str, n: int, seabed: str, steps, tols, duration: float, budget: float,
            kernel: str, ref, desc: str) -> tuple[list[dict], dict | None]:
    """(every run of the ladder, the chosen row or None) of one scheme and seabed setting."""
    adaptive = is_adaptive(integ)
    settings = list(tols) if adaptive else sorted(steps, reverse=True)
    rows: list[dict] = []
    for s in settings:
        r = simulate(SCENE, n, integ, s, duration, budget=budget, kernel=kernel,
                     overrides=CASES[seabed])
        err = error(r, ref) if r.ok else float("nan")
        row = dict(scene=SCENE, n=n, seabed=seabed, added_mass="on (Can 1.0, Cat 0.0)",
                   integrator=integ, kind="adaptive" if adaptive else "fixed",
                   step=float("nan") if adaptive else s, rtol=s if adaptive else float("nan"),
                   duration=duration, status=r.status, wall=r.wall, rtf=duration / r.wall,
                   error_m=err, within_bound=bool(r.ok and err <= ERROR_BOUND), repeats=1,
                   reference=desc, kernel=kernel, timing=r.timing)
        log(f"contact cost {integ} seabed {seabed} {'rtol' if adaptive else 'h'}={s:g}: {r.status}"
            + (f" err {err:.3g} m RTF {row['rtf']:.1f}" if r.ok else ""))
        rows.append(row)
        if row["within_bound"]:
            return rows, dict(row)
        if r.status.startswith("skipped"):
            break  # smaller steps cost more still
    return rows, None


def _retime(chosen: dict[str, dict], integ: str, n: int, duration: float, budget: float, kernel: str,
            repeats: int) -> None:
    """Time the chosen runs of both seabed settings again, alternating on / off ``repeats`` times
    (both see the same machine load), and keep each one's shortest wall time."""
    walls: dict[str, list[float]] = {k: [r["wall"]] for k, r in chosen.items()}
    for _ in range(repeats - 1):
        for seabed, row in chosen.items():
            if sum(walls[seabed]) * 2 > budget:
                continue
            again = simulate(SCENE, n, integ, row_setting(row), duration, budget=budget, kernel=kernel,
                             overrides=CASES[seabed])
            if again.ok:
                walls[seabed].append(again.wall)
    for seabed, row in chosen.items():
        w = min(walls[seabed])
        row.update(wall=w, rtf=duration / w, repeats=len(walls[seabed]))


def contact_cost(n: int, duration: float, cache: Path, integs, steps, tols, budget: float,
                 rtol: float = 1e-10, kernel: str = "fast", repeats: int = 7
                 ) -> tuple[list[dict], list[dict]]:
    """(every run, chosen rows) of the seabed on/off comparison (see the module docstring).

    The chosen rows carry ``rtf_ratio_off_over_on`` (RTF without the seabed / with it, each at its
    own largest step within the bound; nan when either has none).
    """
    ladder: list[dict] = []
    found: dict[str, dict[str, dict]] = {integ: {} for integ in integs}
    missing: list[dict] = []
    for seabed, ov in CASES.items():
        ref, desc, _ = reference(SCENE, n, duration, cache, dop853_max_n=max(n, 1), ref_step=1e-4,
                                 rtol=rtol, kernel=kernel, overrides=ov or None)
        low = float(np.min(ref.pos[..., 1]))
        log(f"contact cost: reference seabed {seabed}: {desc}, lowest joint z {low:.3f} m")
        for integ in integs:
            rows, best = _ladder(integ, n, seabed, steps, tols, duration, budget, kernel, ref, desc)
            ladder += rows
            if best is None:
                best = dict(rows[-1]) if rows else dict(scene=SCENE, n=n, seabed=seabed, integrator=integ)
                best.update(status=f"none within {ERROR_BOUND:g} m ({best.get('status', 'not run')})",
                            rtf=float("nan"), ref_lowest_z_m=low)
                missing.append(best)
            else:
                best["ref_lowest_z_m"] = low
                found[integ][seabed] = best
    for integ in integs:
        if found[integ]:
            _retime(found[integ], integ, n, duration, budget, kernel, repeats)
    chosen = [r for integ in integs for r in found[integ].values()] + missing
    chosen.sort(key=lambda r: (list(integs).index(r["integrator"]), r["seabed"] != "on"))
    by = {(r["integrator"], r["seabed"]): r for r in chosen}
    for r in chosen:
        on, off = by.get((r["integrator"], "on")), by.get((r["integrator"], "off"))
        ratio = off["rtf"] / on["rtf"] if (on and off) else float("nan")
        r["rtf_ratio_off_over_on"] = ratio if math.isfinite(ratio) else float("nan")
    return ladder, chosen


def contact_table(chosen: list[dict]) -> list[dict]:
    """One row per scheme: the largest step within 1 cm and its RTF with and without the seabed."""
    out = []
    for integ in dict.fromkeys(r["integrator"] for r in chosen):
        on = next((r for r in chosen if r["integrator"] == integ and r["seabed"] == "on"), {})
        off = next((r for r in chosen if r["integrator"] == integ and r["seabed"] == "off"), {})

        def setting(r: dict) -> str:
            if not r or not math.isfinite(r.get("rtf", float("nan"))):
                return "none"
            return f"rtol {r['rtol']:g}" if r["kind"] == "adaptive" else f"h {r['step']:g} s"

        out.append(dict(integrator=integ, seabed_on=setting(on), rtf_on=on.get("rtf", float("nan")),
                        error_on_m=on.get("error_m", float("nan")), seabed_off=setting(off),
                        rtf_off=off.get("rtf", float("nan")),
                        error_off_m=off.get("error_m", float("nan")),
                        rtf_off_over_on=on.get("rtf_ratio_off_over_on", float("nan"))))
    return out


def contact_plot(out: Path, chosen: list[dict]) -> None:
    """contact_cost.png: RTF at the largest step within 1 cm per scheme, seabed on vs off."""
    if not chosen:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = contact_table(chosen)
    x = np.arange(len(table))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.1 * len(table)), 4.2))
    for k, (key, lab, col) in enumerate((("rtf_on", "seabed on", "C0"), ("rtf_off", "seabed off", "C1"))):
        v = np.array([r[key] for r in table], dtype=float)
        ax.bar(x + (k - 0.5) * 0.38, np.where(np.isfinite(v), v, 0.0), 0.38, color=col, label=lab)
        for xi, vi, r in zip(x, v, table, strict=True):
            txt = r["seabed_on" if k == 0 else "seabed_off"]
            ax.text(xi + (k - 0.5) * 0.38, vi if np.isfinite(vi) else 1.0, txt, rotation=90,
                    fontsize=6, ha="center", va="bottom")
    ax.set_yscale("log")
    ax.set_xticks(x, [r["integrator"] for r in table], rotation=30, fontsize=8)
    ax.set_ylabel(f"real-time factor at <= {ERROR_BOUND * 100:g} cm")
    r0 = chosen[0]
    ax.set_title(f"{SCENE}, n = {r0['n']}, {r0.get('duration', float('nan')):g} s, added mass on: "
                 "cost of seabed contact", fontsize=9)
    ax.axhline(1.0, color="r", ls="--", lw=0.8)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "contact_cost.png", dpi=100)
    plt.close(fig)
