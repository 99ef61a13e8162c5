"""The cheap runs within the error bound timed again: their cost becomes a median of repeats.

A work-precision run is timed once, and a single timing of a run that takes milliseconds moves
by tens of per cent with the machine's load; the cheapest run per (scene, n), the row the
targets and the cost slope read, is then as much the luckiest timing as the cheapest setting.
So after the ladders every successful run within :data:`~.settings.ERROR_BOUND` whose single
timing is within :data:`~.settings.CLOSE` of the cheapest one at its (scene, n) is run again (at most
:data:`MAX_CANDIDATES` of them, cheapest first), round robin so that all of them see the same
machine load, until each has :data:`~.settings.REPEATS` timings; its ``wall`` and ``wall_inputs`` become
their medians (issue #13: "medians of repeated runs"), ``repeats`` their count and
``wall_spread`` the largest over the smallest. A candidate's single timing would have to be
more than ``CLOSE`` times too fast for one left out to be the cheapest by its median.

Part of the analysis layer; imports numpy and the bench modules :mod:`.resume`, :mod:`.runs`,
:mod:`.settings`.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from .resume import row_setting
from .runs import simulate
from .settings import CLOSE, ERROR_BOUND, REPEATS, log

#: Candidates per (scene, n) at most.
MAX_CANDIDATES = 6


def candidates(rows: list[dict], bound: float = ERROR_BOUND, close: float = CLOSE,
               max_candidates: int = MAX_CANDIDATES) -> dict[tuple[str, int], list[dict]]:
    """Per (scene, n) the ok rows with ``error_m <= bound`` and cost within ``close`` of that
    (scene, n)'s cheapest, cheapest first, at most ``max_candidates``."""
    ok: dict[tuple[str, int], list[dict]] = defaultdict(list)
    for r in rows:
        if r["status"] == "ok" and r["error_m"] <= bound:
            ok[(r["scene"], r["n"])].append(r)
    out = {}
    for key, rr in ok.items():
        rr.sort(key=lambda r: r["cost"])
        out[key] = [r for r in rr if r["cost"] <= close * rr[0]["cost"]][:max_candidates]
    return out


def _apply(row: dict, walls: list[float], inputs: list[float]) -> None:
    """The row's timing columns from all its timings (the first is the ladder's, the row's own
    ``wall``; ``us_per_step``, nan for adaptive rows, scales with the wall)."""
    w = float(np.median(walls))
    wi = float(np.median(inputs))
    dur = row["duration"]
    row.update(us_per_step=row["us_per_step"] * w / row["wall"], wall=w, wall_inputs=wi,
               cost=w / dur, rtf=dur / w, rtf_incl_inputs=dur / (w + wi), repeats=len(walls),
               wall_spread=max(walls) / min(walls))


def retime(rows: list[dict], budget: float, kernel: str = "fast", repeats: int = REPEATS,
           bound: float = ERROR_BOUND, run=simulate) -> int:
    """Time the :func:`candidates` of ``rows`` again, in place (see the module docstring);
    ``run`` is :func:`.runs.simulate` (replaceable in tests). A repeat that does not finish
    as the ladder's run did (over ``budget``) leaves that row's single timing. Returns the
    number of rows retimed. Rows not retimed get ``repeats`` = 1 and ``wall_spread`` = 1."""
    for r in rows:
        r.setdefault("repeats", 1)
        r.setdefault("wall_spread", 1.0)
    # per candidate: its row and its timings (wall, inputs); dropped when a repeat fails
    timed = [(r, [r["wall"]], [r["wall_inputs"]]) for rr in candidates(rows, bound).values()
             for r in rr]
    for _ in range(repeats - 1):
        still = []
        for r, walls, inputs in timed:
            base, _, drag = r["scene"].partition("+")
            done = run(base, r["n"], r["integrator"], row_setting(r), r["duration"],
                       budget=budget, drag=drag or None, kernel=kernel)
            if not done.ok:
                log(f"retiming {r['scene']} n={r['n']} {r['integrator']}: {done.status}")
                continue
            walls.append(done.wall)
            inputs.append(done.wall_inputs)
            still.append((r, walls, inputs))
        timed = still
    for r, walls, inputs in timed:
        _apply(r, walls, inputs)
    log(f"retimed {len(timed)} runs within {bound:g} m, {repeats} timings each "
        "(their medians from here on)")
    return len(timed)


__all__ = ["MAX_CANDIDATES", "candidates", "retime"]
