"""MuJoCo vs cable_sim, each engine at its best scheme and largest step within the error bound.

Paper free fall with drag off (the chain of :mod:`.mujoco_chain`), at n links: every MuJoCo
integrator (RK4, implicitfast, implicit, Euler) and every fixed-step scheme of ours walks the step
ladder from the largest step down; the first step whose max joint-position error against our
drag-off reference is within :data:`~.settings.ERROR_BOUND` is the scheme's largest step within
the bound (a smaller step of the same scheme only costs more). Our compiled adaptive schemes walk
the tolerance ladder :data:`ADAPTIVE_TOLS` from the loosest down in the same way (their rows:
``rtol`` = atol, ``step`` = the mean step); scipy's adaptive schemes are not run here. That
setting is timed again (best of ``repeats``); per engine the scheme with the highest real-time
factor there is its best.

The issue #13 target is the ratio of the two engines' best real-time factors. The ``best`` rows
alone give a ratio that swings with the machine: on a shared VM the two engines' best-of-3
timings are taken minutes apart, under different load (MuJoCo's RK4 at n = 80 has been timed at
272 to 378 us per step, the ratio at 48x to 57x). So the two best configurations are then timed
again in ``pairs`` interleaved pairs (rows with role ``paired``), with the engine that goes first
alternating between pairs. In each pair MuJoCo's best at its step runs once (the ladder's
``mj_step`` loop, one repeat) and our best scheme at its step (the ladder's
:func:`.runs.simulate` call, full duration) runs back to back as many times as it takes for the
timed walls of our runs to add up to MuJoCo's wall (at least once; the loop stops at the first
run that reaches it); our wall of the pair is the mean of those runs. When our runs go first,
MuJoCo's wall of that pair is not known yet: they fill MuJoCo's wall of the previous pair
(the first pair: the wall of MuJoCo's ``best`` row). Equal windows, because a single run of ours
is short (rk4 at n = 80 over 31 s: ~25 ms against MuJoCo's ~1.2 s): one short run is hit or
missed by a load burst that MuJoCo's long run averages over (one run each gave per-pair ratios
of 35 to 64), while two windows of the same length, back to back, see the same machine state
on average. So the per-pair ratio (our RTF / MuJoCo's = MuJoCo's wall / our mean wall) cancels
most of the load common to both; the target is the median per-pair ratio, and the spread of the
per-pair ratios (``pair_ratio_min`` .. ``pair_ratio_max``) shows how far a single pair can be
trusted. Each ``paired`` row has the median of its engine's per-pair walls (``wall``, ``rtf`` =
duration / that median, ``repeats`` = number of pairs), every per-pair wall in order
(``pair_walls``, ``;``-separated, seconds; ours: the mean of the pair's runs) and the number of
our runs in each pair (``pair_our_runs``, ``;``-separated; the same on both rows).

``mujoco`` is optional: without it :func:`mujoco_best` logs why and returns no rows.

Part of the analysis layer: may import every layer; here the bench modules.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .mujoco_chain import build
from .mujoco_compare import SCENE, _Case, _time_mujoco
from .references import reference
from .runs import error, is_adaptive, make_scene, simulate
from .settings import ERROR_BOUND, SCIPY_ADAPTIVE, log

MUJOCO_INTEGRATORS = ("RK4", "implicitfast", "implicit", "Euler")
#: Tolerance ladder (rtol = atol) of our adaptive schemes, loosest first: 10^(1/8) apart, fine
#: enough that the chosen tolerance is within a factor 1.34 of the loosest within the bound.
ADAPTIVE_TOLS = tuple(float(x) for x in np.geomspace(1e-3, 1e-6, 25))


def _row(engine: str, integ: str, n: int, step: float, duration: float, status: str, walls: list[float],
         err: float, role: str, wall_inputs: float = 0.0, rtol: float = float("nan")) -> dict:
    """One CSV row; ``step``: the fixed step, or an adaptive run's mean step (its tolerance:
    ``rtol`` = atol; nan for a fixed-step scheme)."""
    wall = min(walls) if walls else float("nan")
    return dict(engine=engine, integrator=integ, n=n, step=step, rtol=rtol, duration=duration, role=role,
                status=status, repeats=len(walls), wall=wall, rtf=duration / wall,
                rtf_incl_inputs=duration / (wall + wall_inputs), error_m=err,
                within_bound=bool(status == "ok" and err <= ERROR_BOUND))


def _mujoco_ladder(mujoco, c: _Case, integ: str, steps: list[float], repeats: int) -> list[dict]:
    """One MuJoCo integrator down the ladder; the chosen step timed ``repeats`` times."""
    eng = f"mujoco {mujoco.__version__}"
    rows = []
    for h in sorted(steps, reverse=True):
        c.step, c.repeats = h, 1
        mj, data = build(c.model, h, integ)
        walls, status, pos = _time_mujoco(mujoco, mj, data, c)
        err = float(np.max(np.linalg.norm(pos - c.ref_pos, axis=-1))) if status == "ok" else float("nan")
        if status == "ok" and not np.isfinite(err):
            status = "failed: non-finite positions"
        rows.append(_row(eng, integ, c.n, h, c.duration, status, walls, err, "ladder"))
        log(f"mujoco-best {integ} n={c.n} h={h:g}: {status} err {err:.3g} m RTF {rows[-1]['rtf']:.4g}")
        if status.startswith("skipped"):
            break
        if rows[-1]["within_bound"]:
            c.repeats = repeats
            walls, status, _ = _time_mujoco(mujoco, mj, data, c)
            rows.append(_row(eng, integ, c.n, h, c.duration, status, walls, err, "chosen"))
            break
    return rows


def _setting(row: dict) -> float:
    """What :func:`.runs.simulate` takes for the scheme of our ``row``: rtol = atol or the step."""
    return row["rtol"] if is_adaptive(row["integrator"]) else row["step"]


def _ours_ladder(integ: str, n: int, duration: float, ref, steps: list[float], budget: float,
                 repeats: int, kernel: str) -> list[dict]:
    """One of our schemes down the ladder (fixed step: ``steps``, largest first; adaptive:
    :data:`ADAPTIVE_TOLS`, loosest first); the first setting within the bound timed ``repeats``
    times. An adaptive row's ``step`` is its mean step (duration / accepted steps)."""
    eng = f"cable_sim ({kernel})"
    adaptive = is_adaptive(integ)
    rows = []
    for s in (ADAPTIVE_TOLS if adaptive else sorted(steps, reverse=True)):
        r = simulate(SCENE, n, integ, s, duration, budget=budget, drag="none", kernel=kernel)
        err = error(r, ref) if r.ok else float("nan")
        h = duration / max(1, r.nsteps) if adaptive else s
        rtol = s if adaptive else float("nan")
        rows.append(_row(eng, integ, n, h, duration, r.status, [r.wall] if r.ok else [], err, "ladder",
                         r.wall_inputs, rtol))
        log(f"mujoco-best ours {integ} n={n} {'rtol' if adaptive else 'h'}={s:g}: {r.status} err {err:.3g} m "
            f"RTF {rows[-1]['rtf']:.4g}")
        if r.status.startswith("skipped"):
            break
        if rows[-1]["within_bound"]:
            runs = [r]
            for _ in range(repeats - 1):
                if r.wall * (len(runs) + 1) > budget:
                    break
                runs.append(simulate(SCENE, n, integ, s, duration, budget=budget, drag="none", kernel=kernel))
            ok = [x for x in runs if x.ok]
            rows.append(_row(eng, integ, n, h, duration, "ok", [x.wall for x in ok], err, "chosen",
                             min(x.wall_inputs for x in ok), rtol))
            break
    return rows


def _best(rows: list[dict], prefix: str) -> list[dict]:
    chosen = [r for r in rows if r["role"] == "chosen" and r["engine"].startswith(prefix)
              and r["status"] == "ok" and np.isfinite(r["rtf"])]
    if not chosen:
        return []
    return [{**max(chosen, key=lambda r: r["rtf"]), "role": "best"}]


def _paired(mujoco, c: _Case, ours: dict, mj: dict, pairs: int, kernel: str) -> list[dict]:
    """The two engines' best configurations timed in ``pairs`` interleaved pairs (ours first in
    even pairs, MuJoCo first in odd ones), our runs repeated in each pair until their walls add
    up to MuJoCo's wall of the pair (of the previous pair, or of its ``best`` row, when ours go
    first): one ``paired`` row per engine with the median per-pair wall, every per-pair wall
    (``pair_walls``; ours: the mean of the pair's runs), the number of our runs per pair
    (``pair_our_runs``) and the per-pair ratios' median, min and max. A pair in which any run
    fails is dropped; no complete pair: no rows."""
    c.step, c.repeats = mj["step"], 1
    mj_model, data = build(c.model, mj["step"], mj["integrator"])

    def mujoco_once() -> float | None:
        w, status, _ = _time_mujoco(mujoco, mj_model, data, c)
        return w[0] if status == "ok" and w else None

    def ours_window(window: float) -> list[tuple[float, float]] | None:
        """(wall, input-sampling wall) of our runs, back to back until their walls reach
        ``window`` (at least one run); None if one fails."""
        runs: list[tuple[float, float]] = []
        total = 0.0
        while not runs or total < window:
            r = simulate(SCENE, c.n, ours["integrator"], _setting(ours), c.duration, budget=c.budget,
                         drag="none", kernel=kernel)
            if not r.ok:
                return None
            runs.append((r.wall, r.wall_inputs))
            total += r.wall
        return runs

    walls_ours: list[float] = []
    inputs_ours: list[float] = []
    runs_ours: list[int] = []
    walls_mj: list[float] = []
    last_mj = float(mj["wall"])  # MuJoCo's latest wall: the window of ours when ours go first
    for k in range(pairs):
        if k % 2 == 0:
            got = ours_window(last_mj)
            mj_wall = mujoco_once() if got is not None else None
        else:
            mj_wall = mujoco_once()
            got = ours_window(mj_wall) if mj_wall is not None else None
        if mj_wall is not None:
            last_mj = mj_wall
        if got is None or mj_wall is None:
            log(f"mujoco-best pair {k + 1}/{pairs} dropped: a run failed")
            continue
        walls_ours.append(float(np.mean([w for w, _ in got])))
        inputs_ours.append(float(np.mean([i for _, i in got])))
        runs_ours.append(len(got))
        walls_mj.append(mj_wall)
        log(f"mujoco-best pair {k + 1}/{pairs}: ours {walls_ours[-1]:.4g} s (mean of {runs_ours[-1]}), "
            f"MuJoCo {walls_mj[-1]:.4g} s, ratio {walls_mj[-1] / walls_ours[-1]:.4g}")
    if not walls_ours:
        return []
    # our RTF / MuJoCo's in the same pair = MuJoCo's wall / our mean wall
    ratios = np.array(walls_mj) / np.array(walls_ours)
    spread = dict(pair_ratio_median=float(np.median(ratios)), pair_ratio_min=float(ratios.min()),
                  pair_ratio_max=float(ratios.max()))
    our_runs = ";".join(str(m) for m in runs_ours)
    rows = []
    for best, walls, inputs in ((ours, walls_ours, inputs_ours), (mj, walls_mj, [0.0] * len(walls_mj))):
        wall = float(np.median(walls))
        rows.append({**best, "role": "paired", "repeats": len(walls), "wall": wall,
                     "rtf": best["duration"] / wall,
                     "rtf_incl_inputs": best["duration"] / (wall + float(np.median(inputs))),
                     **spread, "pair_walls": ";".join(f"{w:.9g}" for w in walls),
                     "pair_our_runs": our_runs})
    return rows


def mujoco_best(n: int, duration: float, cache: Path, dop853_max_n: int, ref_step: float, budget: float,
                steps: list[float], ours: list[str], rtol: float = 1e-10, kernel: str = "fast",
                repeats: int = 3, pairs: int = 7) -> list[dict]:
    """Rows of mujoco_best.csv: every ladder run (role ``ladder``), each scheme's largest step
    within the bound timed again (``chosen``), each engine's best (``best``) and the two bests
    timed again in ``pairs`` interleaved pairs (``paired``, one row per engine; none when
    ``pairs`` is 0 or an engine has no best)."""
    try:
        import mujoco
    except ImportError as exc:
        log(f"MuJoCo best-scheme comparison skipped: mujoco not importable ({exc})")
        return []
    ref, desc, _ = reference(SCENE, n, duration, cache, dop853_max_n, ref_step, drag="none", rtol=rtol,
                             kernel=kernel)
    sc = make_scene(SCENE, n, "none", kernel)
    model = sc.model()
    c = _Case(n, steps[0], duration, budget, 1, model, sc.initial_state(model), ref.pos, desc)
    rows: list[dict] = []
    for integ in MUJOCO_INTEGRATORS:
        rows += _mujoco_ladder(mujoco, c, integ, steps, repeats)
    for integ in ours:
        if integ not in SCIPY_ADAPTIVE:  # scipy's run the right-hand side in Python: not contenders
            rows += _ours_ladder(integ, n, duration, ref, steps, budget, repeats, kernel)
    for r in rows:
        r["reference"] = desc
    best = _best(rows, "cable_sim") + _best(rows, "mujoco")
    if len(best) == 2 and pairs > 0:
        best += _paired(mujoco, c, best[0], best[1], pairs, kernel)
    return rows + best


def best_plot(out: Path, rows: list[dict]) -> None:
    """mujoco_best.png: real-time factor against error over each scheme's ladder, both engines
    (solid: cable_sim, dashed: MuJoCo), the error bound and each engine's best marked."""
    ok = [r for r in rows if r["status"] == "ok" and np.isfinite(r["error_m"]) and r["role"] == "ladder"]
    if not ok:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for i, (eng, integ) in enumerate(dict.fromkeys((r["engine"], r["integrator"]) for r in ok)):
        rr = sorted([r for r in ok if r["engine"] == eng and r["integrator"] == integ],
                    key=lambda r: r["step"])
        ls = "--" if eng.startswith("mujoco") else "-"
        ax.loglog([max(r["error_m"], 1e-12) for r in rr], [r["rtf"] for r in rr], ls, marker="o", ms=3,
                  color=f"C{i}", label=f"{eng.split()[0]} {integ}")
    for r in rows:
        if r["role"] == "best":
            ax.plot(max(r["error_m"], 1e-12), r["rtf"], "k*", ms=12)
    ax.axvline(ERROR_BOUND, color="k", lw=0.8, ls=":")
    n = ok[0]["n"]
    ax.set_xlabel("max joint-position error [m] (vs our drag-off reference)")
    ax.set_ylabel("real-time factor")
    ax.set_title(f"paper free fall, drag off, n={n}: step ladders (star: each engine's best within 1 cm)",
                 fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "mujoco_best.png", dpi=100)
    plt.close(fig)
