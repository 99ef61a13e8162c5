"""MuJoCo side by side: the paper free fall with drag off in both engines, same n, step, duration.

MuJoCo's RK4 and implicitfast (the chain of :mod:`.mujoco_chain`, ``mj_step(m, d, nstep=...)``
per 0.5 s) against our schemes (:func:`.runs.simulate`), best of a few repeats each, errors
against our drag-off reference. ``mujoco`` is optional: without it :func:`mujoco_compare` logs
why and returns no rows.

Part of the analysis layer: may import every layer; here core, integrate and the bench modules.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cable_sim.core import dynamics
from cable_sim.integrate.registry import INTEGRATORS

from .mujoco_chain import build, from_mujoco, to_mujoco
from .references import reference
from .runs import error, make_scene, simulate
from .settings import SAMPLE, log

MUJOCO_OURS = ("rk4", "implicit_euler", "rosenbrock2")
SCENE = "paper_free_fall"


@dataclass
class _Case:
    """One n of the comparison: its model, initial state, reference and timing limits."""

    n: int
    step: float
    duration: float
    budget: float
    repeats: int
    model: Any
    y0: np.ndarray
    ref_pos: np.ndarray
    desc: str

    @property
    def nout(self) -> int:
        return int(round(self.duration / SAMPLE))

    @property
    def per(self) -> int:
        """Steps per 0.5 s output interval."""
        return int(round(SAMPLE / self.step))

    def start(self, data) -> None:
        """MuJoCo's state set to our initial state."""
        m = self.model
        data.qpos[:], data.qvel[:] = to_mujoco(self.y0[: m.ndof], self.y0[m.ndof:])


def _time_mujoco(mujoco, mj, data, c: _Case) -> tuple[list[float], str, np.ndarray | None]:
    """(wall times of the repeats, status, joint positions of the first) of ``mj_step`` runs."""
    walls: list[float] = []
    status, pos = "ok", None
    nout, per = c.nout, c.per
    for rep in range(c.repeats):
        c.start(data)
        data.qacc_warmstart[:] = 0.0
        data.time = 0.0
        mujoco.mj_forward(mj, data)
        p = np.empty((nout + 1, c.n + 1, 2))
        p[0] = dynamics.joint_positions(c.model, c.y0[: c.model.ndof])
        wall = 0.0
        for i in range(nout):
            t0 = time.perf_counter()
            mujoco.mj_step(mj, data, nstep=per)
            wall += time.perf_counter() - t0
            q, _ = from_mujoco(data.qpos, data.qvel)
            if not np.all(np.isfinite(q)):
                status = f"failed: blow-up by t={(i + 1) * SAMPLE:g}"
                break
            p[i + 1] = dynamics.joint_positions(c.model, q)
            if i == 0 and wall * nout > c.budget:
                status = (f"skipped: projected {wall * nout:.0f} s ({1e6 * wall / per:.0f} us/step "
                          f"over the first 0.5 s) > budget {c.budget:.0f} s")
                break
        if status != "ok":
            break
        walls.append(wall)
        pos = p if pos is None else pos
        if wall * (rep + 2) > c.budget:
            break  # further repeats would not fit
    return walls, status, pos


def _python_loop_us(mujoco, mj, data, c: _Case) -> float:
    """Microseconds per step of the same steps from a per-step Python loop (one interval)."""
    c.start(data)
    mujoco.mj_forward(mj, data)
    t0 = time.perf_counter()
    for _ in range(c.per):
        mujoco.mj_step(mj, data)
    return 1e6 * (time.perf_counter() - t0) / c.per


def _mujoco_rows(mujoco, c: _Case) -> tuple[list[dict], float]:
    """Rows of MuJoCo's RK4 and implicitfast, and the RK4 wall time (nan when it failed)."""
    rows = []
    mj_rk4_wall = float("nan")
    for integ in ("RK4", "implicitfast"):
        mj, data = build(c.model, c.step, integ)
        walls, status, pos = _time_mujoco(mujoco, mj, data, c)
        loop_us = _python_loop_us(mujoco, mj, data, c)
        ok = status == "ok"
        wall = min(walls) if ok else float("nan")
        if integ == "RK4" and ok:
            mj_rk4_wall = wall
        err = float(np.max(np.linalg.norm(pos - c.ref_pos, axis=-1))) if ok else float("nan")
        rows.append(dict(engine=f"mujoco {mujoco.__version__}", integrator=integ, n=c.n, step=c.step,
                         duration=c.duration, status=status, repeats=len(walls), wall=wall,
                         rtf=c.duration / wall, us_per_step=1e6 * wall / (c.nout * c.per),
                         us_per_step_python_loop=loop_us,
                         speed_vs_mujoco_rk4=mj_rk4_wall / wall,
                         error_m=err, reference=c.desc,
                         timing=f"mj_step(nstep={c.per}) per 0.5 s, best of {len(walls)}"))
        log(f"mujoco {integ} n={c.n} h={c.step:g}: {status} wall {wall:.3f} s (best of {len(walls)}) "
            f"err {err:.3g} m (per-step Python loop: {loop_us:.1f} us/step)")
    return rows, mj_rk4_wall


def _our_row(integ: str, c: _Case, ref, kernel: str, mj_rk4_wall: float) -> dict:
    """Our scheme ``integ`` on the same case, best of the repeats that fit the budget."""
    runs = []
    for _ in range(c.repeats):
        r = simulate(SCENE, c.n, integ, c.step, c.duration, budget=c.budget, drag="none", kernel=kernel)
        runs.append(r)
        if not r.ok or r.wall * (len(runs) + 1) > c.budget:
            break
    r = runs[0]
    if r.ok:
        r.wall = min(x.wall for x in runs)
        r.wall_inputs = min(x.wall_inputs for x in runs)
    nsteps = c.nout * c.per
    log(f"cable_sim {integ} n={c.n} h={c.step:g}: {r.status} wall {r.wall:.3f} s "
        f"(+{r.wall_inputs:.3f} s input sampling; best of {len(runs)})")
    return dict(engine=f"cable_sim ({kernel})", integrator=integ, n=c.n, step=c.step,
                duration=c.duration, status=r.status, repeats=len(runs), wall=r.wall,
                rtf=c.duration / r.wall, us_per_step=1e6 * r.wall / nsteps,
                us_per_step_python_loop=float("nan"),
                speed_vs_mujoco_rk4=mj_rk4_wall / r.wall,
                error_m=error(r, ref) if r.ok else float("nan"), reference=c.desc,
                timing=f"{r.timing}, best of {len(runs)}",
                us_per_step_incl_inputs=1e6 * (r.wall + r.wall_inputs) / nsteps)


def mujoco_compare(n_list, step: float, duration: float, cache: Path, dop853_max_n: int,
                   ref_step: float, budget: float, rtol: float = 1e-10, kernel: str = "fast",
                   ours: tuple[str, ...] = MUJOCO_OURS, repeats: int = 3) -> list[dict]:
    """Paper free fall with drag off: MuJoCo RK4/implicitfast vs ours, same n, step, duration.

    Each engine/integrator runs ``repeats`` times (fewer when that would exceed ``budget``) and
    the shortest wall time counts (the machine is shared; the minimum is the least disturbed).
    """
    try:
        import mujoco
    except ImportError as exc:
        log(f"MuJoCo comparison skipped: mujoco not importable ({exc})")
        return []
    rows = []
    for n in n_list:
        ref, desc, _ = reference(SCENE, n, duration, cache, dop853_max_n, ref_step, drag="none",
                                 rtol=rtol, kernel=kernel)
        sc = make_scene(SCENE, n, "none", kernel)
        model = sc.model()
        c = _Case(n, step, duration, budget, repeats, model, sc.initial_state(model), ref.pos, desc)
        mj_rows, mj_rk4_wall = _mujoco_rows(mujoco, c)
        rows += mj_rows
        rows += [_our_row(integ, c, ref, kernel, mj_rk4_wall) for integ in ours if integ in INTEGRATORS]
    return rows
