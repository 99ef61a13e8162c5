"""Cost vs n at the error bound: the cheapest run within it per (scene, n), and the fitted slope.

Part of the analysis layer; imports numpy and :mod:`.settings` only.
"""

from __future__ import annotations

import numpy as np

from .settings import ERROR_BOUND


def fit_slope(ns, costs) -> float:
    """Least-squares slope of log(cost) against log(n) (nan for fewer than two points)."""
    if len(ns) < 2:
        return float("nan")
    return float(np.polyfit(np.log(ns), np.log(costs), 1)[0])


def best_under(rows: list[dict], scene: str, n: int, bound: float, integ: str | None = None):
    """Cheapest successful run at (scene, n) with error <= bound (optionally one integrator)."""
    c = [r for r in rows if r["scene"] == scene and r["n"] == n and r["status"] == "ok"
         and r["error_m"] <= bound and (integ is None or r["integrator"] == integ)]
    return min(c, key=lambda r: r["cost"]) if c else None


def cost_rows(wp: list[dict], scenes, integs) -> list[dict]:
    """Rows of cost_vs_n.csv: per scene, integrator (and ``"best"`` of all) and n, the cheapest
    work-precision run within :data:`ERROR_BOUND`."""
    rows: list[dict] = []
    for scene in scenes:
        for integ in [*integs, None]:
            for n in sorted({r["n"] for r in wp if r["scene"] == scene}):
                b = best_under(wp, scene, n, ERROR_BOUND, integ)
                if b is not None:
                    rows.append(dict(scene=scene, integrator=integ or "best", n=n,
                                     duration=b["duration"], cost=b["cost"], rtf=b["rtf"],
                                     rtf_incl_inputs=b["rtf_incl_inputs"], chosen=b["integrator"],
                                     step=b["step"], rtol=b["rtol"], error_m=b["error_m"]))
    return rows


#: n range of the fitted slope (issue #13: n = 40..640).
SLOPE_N = (40, 640)
#: The large-n part of that range, reported beside it: where the cheapest scheme no longer
#: changes with n, the slope says whether the cost per step is linear in n.
LARGE_N_SLOPE_N = (160, 640)


def slopes(rows: list[dict], scenes, n_range: tuple[int, int] = SLOPE_N) -> dict[str, float]:
    """Fitted slope of the best cost vs n (n in ``n_range``, default :data:`SLOPE_N`) per scene."""
    out = {}
    lo, hi = n_range
    for scene in scenes:
        rr = [r for r in rows if r["scene"] == scene and r["integrator"] == "best" and lo <= r["n"] <= hi]
        out[scene] = fit_slope([r["n"] for r in rr], [r["cost"] for r in rr])
    return out
