"""Discretisation error in n: each n's reference run against the finest n's, per scene.

Part of the analysis layer: may import every layer; here scene and the bench modules.
"""

from __future__ import annotations

import numpy as np

from cable_sim.scene.scenes import load_scene

from .runs import Run, midline


def discretisation_rows(label: str, refs: dict[int, Run], free: bool) -> list[dict]:
    """Tip / mid-line position and fairlead tension of each n's reference vs the finest n's."""
    ns = sorted(refs)
    if len(ns) < 2:
        return []
    fine = refs[ns[-1]]
    rows = []
    for n in ns:
        r = refs[n]
        tip = float(np.max(np.linalg.norm(r.pos[:, -1] - fine.pos[:, -1], axis=-1)))
        mid = float(np.max(np.linalg.norm(midline(r.pos) - midline(fine.pos), axis=-1)))
        dten = np.abs(r.tension - fine.tension)
        rows.append(dict(scene=label, n=n, n_fine=ns[-1], duration=r.duration, free_end=free,
                         tip_error_m=tip, midline_error_m=mid, tension_error_N=float(np.nanmax(dten)),
                         tension_rel_error=float(np.nanmax(dten) / np.nanmax(np.abs(fine.tension))),
                         fairlead_tension_max_N=float(np.nanmax(r.tension))))
    return rows


def by_scene(scenes, refs: dict[tuple[str, int], Run]) -> list[dict]:
    """:func:`discretisation_rows` of every scene from the work-precision references."""
    disc: list[dict] = []
    for scene in scenes:
        free = load_scene(scene).params.end_condition == "free"
        disc += discretisation_rows(scene, {n: r for (s_, n), r in refs.items() if s_ == scene}, free)
    return disc
