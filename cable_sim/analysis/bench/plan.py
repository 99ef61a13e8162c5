"""What one ``cable_sim_bench`` invocation runs: the command line resolved into a :class:`Plan`.

Defaults of ``--quick`` and of a full run, the durations per scene, the (scene, n) jobs, the
reference of each job and the output / cache folders.

Part of the analysis layer: may import every layer; here scene and the bench modules.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

from cable_sim.scene.scenes import load_scene

from .references import reference
from .resume import load_resume
from .runs import Run, available_integrators, pick_kernel
from .settings import (
    BLOCK_WALL,
    ERROR_FLOOR,
    FREE_FALL_ONLY_N,
    N_LIST,
    OPEN_ENDED_DURATION,
    SCENES,
    STEPS,
    TOLS,
    WP_DURATION,
    log,
)


class PlanError(ValueError):
    """A command-line value the benchmark cannot run."""


@dataclass
class Plan:
    """The resolved settings of one invocation (``args`` keeps the parsed command line)."""

    args: argparse.Namespace
    kernel: str
    why: str
    avail: list[str]
    integs: list[str]
    scenes: list[str]
    n_list: list[int]
    steps: list[float]
    tols: list[float]
    mj_n: list[int]
    floor: float
    out: Path
    cache: Path
    resumed: dict[tuple, dict]
    t_start: float

    @property
    def deadline(self) -> float:
        """perf_counter time after which work-precision runs are skipped (``--max-wall``)."""
        return self.t_start + self.args.max_wall

    def duration(self, scene: str) -> float:
        """Simulated seconds of every run of ``scene``."""
        if self.args.duration is not None:
            return self.args.duration
        if not self.args.full:
            return WP_DURATION
        d = float(load_scene(scene).sim.get("duration", 0.0) or 0.0)
        return d if d > 0 else OPEN_ENDED_DURATION

    def integrators_at(self, n: int) -> list[str]:
        """The integrators run at n links: from ``--large-n-from`` on only those of
        ``--large-n-integrators`` (the schemes that can win there)."""
        a = self.args
        if n >= a.large_n_from and a.large_n_integrators:
            return [i for i in self.integs if i in a.large_n_integrators]
        return self.integs

    def jobs(self) -> list[tuple[str, int]]:
        """(scene, n) pairs, smallest n first across scenes (so that a --refs-only process, which
        works from the largest n down, has the most time to fill the cache). An n of
        FREE_FALL_ONLY_N runs on the other scenes only when ``--scenes`` names them."""
        explicit = self.args.scenes is not None
        jobs = [(s, n) for s in self.scenes for n in self.n_list
                if explicit or n not in FREE_FALL_ONLY_N or s == "paper_free_fall"]
        return sorted(jobs, key=lambda j: j[1])

    def reference(self, scene: str, n: int, drag: str | None = None) -> tuple[Run, str, float]:
        """The cached reference of (scene, n) (:func:`.references.reference`)."""
        a = self.args
        return reference(scene, n, self.duration(scene), self.cache, a.dop853_max_n, a.ref_step,
                         drag=drag, rtol=a.ref_rtol, kernel=self.kernel)

    def announce(self) -> None:
        """The progress lines that open a run."""
        log(f"kernel {self.kernel}: {self.why}")
        log(f"integrators available: {self.avail}; running {self.integs}")
        log(f"scenes {self.scenes} n {self.n_list} steps {self.steps} tols {self.tols} durations "
            f"{ {s: self.duration(s) for s in self.scenes} } out {self.out}")


def make_plan(args: argparse.Namespace) -> Plan:
    """Resolve the command line (``--quick`` defaults; ``args`` gets the defaults it reports).

    Raises
    ------
    PlanError
        When ``--integrators`` names one not available here, ``--repeats`` is below 1 or
        ``--block-wall`` below 0.
    """
    kernel, why = pick_kernel()
    avail = available_integrators()
    if args.quick:
        scenes = args.scenes or ["paper_free_fall", "paper_anchored_forced"]
        n_list = args.n or [4, 8]
        steps = args.steps or [0.05, 0.025, 0.0125]
        tols = args.tols or [1e-4, 1e-6, 1e-8]
        args.duration = args.duration or 2.0
        mj_n = args.mujoco_n or [6]
        args.ref_rtol = args.ref_rtol or 1e-12
        args.error_floor = 0.0 if args.error_floor is None else args.error_floor
        # its runs take well under a millisecond: one run per retiming block
        args.block_wall = 0.0 if args.block_wall is None else args.block_wall
    else:
        scenes = args.scenes or list(SCENES)
        n_list = args.n or list(N_LIST)
        steps = args.steps or list(STEPS)
        tols = args.tols or list(TOLS)
        mj_n = args.mujoco_n or [20, 80, 160]
    if args.repeats < 1:
        raise PlanError(f"parameter 'repeats' = {args.repeats}; allowed: an integer >= 1")
    args.block_wall = BLOCK_WALL if args.block_wall is None else args.block_wall
    if not args.block_wall >= 0.0:
        raise PlanError(f"parameter 'block_wall' = {args.block_wall}; allowed: seconds >= 0")
    integs = args.integrators or avail
    bad = [i for i in integs if i not in avail]
    if bad:
        raise PlanError(f"parameter 'integrators' has {bad}; allowed: {avail}")
    args.ref_rtol = args.ref_rtol or 1e-10
    floor = ERROR_FLOOR if args.error_floor is None else args.error_floor
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cache = Path(args.cache) if args.cache else out / "cache"
    resumed = load_resume(args.resume or [])
    return Plan(args, kernel, why, avail, integs, scenes, n_list, steps, tols, mj_n, floor, out, cache,
                resumed, time.perf_counter())
