"""The cheap runs within the error bound timed again: their cost becomes a median of repeats.

A work-precision run is timed once, and a single timing of a run that takes milliseconds moves
by tens of per cent with the machine's load and with what ran just before it (a run right
after a different configuration starts with cold caches); the cheapest run per (scene, n), the
row the targets and the cost slope read, is then as much the luckiest timing as the cheapest
setting. So after the ladders every successful run within :data:`~.settings.ERROR_BOUND` whose
single timing is within :data:`~.settings.CLOSE` of the cheapest one at its (scene, n) is timed
again (at most :data:`MAX_CANDIDATES` of them, cheapest first) in :data:`~.settings.REPEATS`
blocks. A block runs the configuration back to back until the walls of its runs add up to
:data:`~.settings.BLOCK_WALL` (at least once; the same rule as the MuJoCo pairs of
:mod:`.mujoco_best`), and its timing is the mean wall of those runs: the cost of the scheme
running continuously, as in a node, rather than of one cold start. The blocks go round robin
over the candidates so that all of them see the same machine load; a row's ``wall`` and
``wall_inputs`` become the medians of its block means (issue #13: "medians of repeated runs"),
``repeats`` the number of blocks, ``block_runs`` the runs in all of them and ``wall_spread``
the largest block mean over the smallest. The ladder's single timing only picks the candidates:
one left out would need a single timing more than ``CLOSE`` times too slow to be the cheapest
by its median.

Part of the analysis layer; imports numpy and the bench modules :mod:`.resume`, :mod:`.runs`,
:mod:`.settings`.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from .resume import row_setting
from .runs import simulate
from .settings import BLOCK_WALL, CLOSE, ERROR_BOUND, REPEATS, log

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


def _apply(row: dict, blocks: list[tuple[float, float, int]]) -> None:
    """The row's timing columns from its blocks, (mean wall, mean input-sampling wall, runs)
    each (``us_per_step``, nan for adaptive rows, scales with the wall)."""
    walls = [b[0] for b in blocks]
    w = float(np.median(walls))
    wi = float(np.median([b[1] for b in blocks]))
    dur = row["duration"]
    row.update(us_per_step=row["us_per_step"] * w / row["wall"], wall=w, wall_inputs=wi,
               cost=w / dur, rtf=dur / w, rtf_incl_inputs=dur / (w + wi), repeats=len(blocks),
               block_runs=sum(b[2] for b in blocks), wall_spread=max(walls) / min(walls))


def _block(row: dict, budget: float, kernel: str, block_wall: float,
           run) -> tuple[float, float, int] | None:
    """One block of ``row``'s configuration: (mean wall, mean input-sampling wall, runs), or
    None when a run does not finish as the ladder's run did."""
    base, _, drag = row["scene"].partition("+")
    walls: list[float] = []
    inputs: list[float] = []
    while not walls or sum(walls) < block_wall:
        done = run(base, row["n"], row["integrator"], row_setting(row), row["duration"],
                   budget=budget, drag=drag or None, kernel=kernel)
        if not done.ok:
            log(f"retiming {row['scene']} n={row['n']} {row['integrator']}: {done.status}")
            return None
        walls.append(done.wall)
        inputs.append(done.wall_inputs)
    return float(np.mean(walls)), float(np.mean(inputs)), len(walls)


def retime(rows: list[dict], budget: float, kernel: str = "fast", repeats: int = REPEATS,
           bound: float = ERROR_BOUND, run=simulate, block_wall: float = BLOCK_WALL) -> int:
    """Time the :func:`candidates` of ``rows`` again in ``repeats`` blocks of at least
    ``block_wall`` [s] each, in place (see the module docstring); ``run`` is
    :func:`.runs.simulate` (replaceable in tests). A run that does not finish as the ladder's
    run did (over ``budget``) leaves that row's single timing. ``repeats`` = 1 leaves every row
    as timed. Returns the number of rows retimed. Rows not retimed get ``repeats`` = 1,
    ``block_runs`` = 0 and ``wall_spread`` = 1."""
    for r in rows:
        r.setdefault("repeats", 1)
        r.setdefault("block_runs", 0)
        r.setdefault("wall_spread", 1.0)
    if repeats <= 1:
        return 0
    # per candidate: its row and its blocks so far; dropped when a run fails
    timed = [(r, []) for rr in candidates(rows, bound).values() for r in rr]
    for _ in range(repeats):
        still = []
        for r, blocks in timed:
            got = _block(r, budget, kernel, block_wall, run)
            if got is not None:
                blocks.append(got)
                still.append((r, blocks))
        timed = still
    for r, blocks in timed:
        _apply(r, blocks)
    log(f"retimed {len(timed)} runs within {bound:g} m: {repeats} blocks of >= {block_wall:g} s "
        "each (the medians of their means from here on)")
    return len(timed)


__all__ = ["MAX_CANDIDATES", "candidates", "retime"]
