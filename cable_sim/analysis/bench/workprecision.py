"""Work-precision study: every integrator over its step / tolerance ladder at every (scene, n).

A ladder stops where refining only costs more: below the error floor, after a run over the
budget, or after a setting that took more than half of it; a scheme over the budget at one n is
skipped at larger n of that scene. A run below the floor that redid step attempts in halves
(``radau_iia`` where its Newton iteration did not converge) does not stop the ladder: a smaller
nominal step that needs fewer halvings can be cheaper. Rows measured by an earlier invocation
(``--resume``) are taken over.

Part of the analysis layer: may import every layer; here the bench modules only.
"""

from __future__ import annotations

import time

from .plan import Plan
from .resume import row_key
from .runs import Run, error, is_adaptive, simulate
from .settings import log


def _row(r: Run, adaptive: bool, ref: Run, desc: str, ref_err: float) -> dict:
    """One row of workprecision.csv."""
    nst = r.nsteps if not adaptive else 0
    s, dur = r.setting, r.duration
    return dict(scene=r.scene, n=r.n, kernel=r.kernel, integrator=r.integrator,
                kind="adaptive" if adaptive else "fixed",
                step=float("nan") if adaptive else s, rtol=s if adaptive else float("nan"),
                duration=dur, status=r.status, wall=r.wall, wall_inputs=r.wall_inputs,
                cost=r.cost, rtf=1.0 / r.cost,
                rtf_incl_inputs=dur / (r.wall + r.wall_inputs),
                us_per_step=1e6 * r.wall / nst if (r.ok and nst) else float("nan"),
                nfev=r.nfev if r.ok else 0, halved=r.halved if r.ok else 0,
                mean_step=dur / r.nsteps if (r.ok and r.nsteps) else float("nan"),
                error_m=error(r, ref) if r.ok else float("nan"),
                reference=desc, ref_err_est=ref_err, timing=r.timing, source="this run")


class _Ladder:
    """One integrator's ladder at one (scene, n): runs, or takes over, one setting at a time."""

    def __init__(self, plan: Plan, scene: str, n: int, integ: str, too_slow: dict[tuple[str, str], int],
                 ref: tuple[Run, str, float], drag: str | None = None) -> None:
        self.plan, self.n, self.integ, self.too_slow = plan, n, integ, too_slow
        self.base, self.drag = scene, drag
        self.scene = f"{scene}+{drag}" if drag else scene  # the rows' label
        self.ref, self.desc, self.ref_err = ref
        self.adaptive = is_adaptive(integ)
        self.dur = plan.duration(scene)
        self.prev_wall = 0.0  # wall time of the previous (cheaper) setting

    def settings(self) -> list[float]:
        """Tolerances (adaptive) or steps, largest first."""
        return self.plan.tols if self.adaptive else sorted(self.plan.steps, reverse=True)

    def resumed(self, s: float) -> tuple[dict | None, bool]:
        """(row taken over from --resume or None, whether the ladder stops there)."""
        row = self.plan.resumed.get(row_key(self.scene, self.n, self.integ, s, self.dur, self.plan.kernel))
        if row is None:
            return None, False
        row = dict(row)
        log(f"{self.scene} n={self.n} {self.integ} {'rtol' if self.adaptive else 'h'}={s:g}: "
            f"{row['status']} (taken from {row['source']})")
        if row["status"].startswith("skipped"):
            self.too_slow.setdefault((self.scene, self.integ), self.n)
            return row, True
        if row["status"] == "ok":
            self.prev_wall = row["wall"] + row["wall_inputs"]
            return row, self._refined_enough(row)
        return row, False

    def _refined_enough(self, row: dict) -> bool:
        """Whether a smaller step or tolerance than this ok row's can only cost more: its error
        is below the floor and it halved no step attempt."""
        return row["error_m"] < self.plan.floor and not row["halved"]

    def _skip(self) -> str | None:
        if time.perf_counter() > self.plan.deadline:
            return "skipped: --max-wall reached"
        if (self.scene, self.integ) in self.too_slow:
            return f"skipped: over the budget already at n={self.too_slow[(self.scene, self.integ)]}"
        if self.prev_wall > self.plan.args.budget / 2:
            return f"skipped: the previous (cheaper) setting took {self.prev_wall:.0f} s"
        return None

    def measured(self, s: float) -> tuple[dict, bool]:
        """(row of a new run at setting ``s``, or of its skipping; whether the ladder stops)."""
        kernel = self.plan.kernel
        skip = self._skip()
        if skip:
            r = Run(self.scene, self.n, self.integ, s, self.dur, kernel=kernel, status=skip)
        else:
            r = simulate(self.base, self.n, self.integ, s, self.dur, budget=self.plan.args.budget,
                         kernel=kernel, drag=self.drag)
            r.scene = self.scene
            if r.status.startswith("skipped"):
                self.too_slow.setdefault((self.scene, self.integ), self.n)
            elif r.ok:
                self.prev_wall = r.wall + r.wall_inputs
        row = _row(r, self.adaptive, self.ref, self.desc, self.ref_err)
        what = f"rtol={s:g}" if self.adaptive else f"h={s:g}"
        log(f"{self.scene} n={self.n} {self.integ} {what}: {r.status}"
            + (f" err {row['error_m']:.3g} m RTF {row['rtf']:.1f}"
               f" (incl. input sampling {row['rtf_incl_inputs']:.1f})" if r.ok else ""))
        stop = ((skip is not None and "max-wall" not in skip)  # the rest of the ladder costs more
                or (r.status.startswith("skipped") and not skip)
                or (r.ok and self._refined_enough(row)))
        return row, stop

    def run(self) -> list[dict]:
        """The ladder's rows, cheapest setting first."""
        rows = []
        for s in self.settings():
            row, stop = self.resumed(s)
            if row is None:
                row, stop = self.measured(s)
            rows.append(row)
            if stop:
                break
        return rows


def run_workprecision(plan: Plan) -> tuple[list[dict], dict[tuple[str, int], Run]]:
    """(rows of workprecision.csv, reference run per (scene, n)); a (scene, n) whose reference
    fails is left out."""
    wp: list[dict] = []
    refs: dict[tuple[str, int], Run] = {}
    too_slow: dict[tuple[str, str], int] = {}  # (scene, integrator) -> n at which it hit the budget
    for scene, n in plan.jobs():
        try:
            ref = plan.reference(scene, n)
        except RuntimeError as exc:
            log(f"{scene} n={n}: {exc}; skipping this n")
            continue
        refs[(scene, n)] = ref[0]
        for integ in plan.integrators_at(n):
            wp += _Ladder(plan, scene, n, integ, too_slow, ref).run()
    return wp, refs


def run_drag_variant(plan: Plan, scene: str, n: int, drag: str) -> list[dict]:
    """Work-precision rows of ``scene`` at n links with ``drag_model`` = ``drag`` (every integrator's
    ladder; rows labelled ``<scene>+<drag>``, reference with the same drag)."""
    try:
        ref = plan.reference(scene, n, drag=drag)
    except RuntimeError as exc:
        log(f"{scene} drag {drag} n={n}: {exc}; skipped")
        return []
    rows: list[dict] = []
    too_slow: dict[tuple[str, str], int] = {}
    for integ in plan.integrators_at(n):
        rows += _Ladder(plan, scene, n, integ, too_slow, ref, drag=drag).run()
    return rows
