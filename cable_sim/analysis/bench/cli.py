"""``cable_sim_bench``: the command line and :func:`main`, a short sequence of named steps.

Each step is one study of its own module (work-precision, discretisation, cost, MuJoCo,
targets, figures, report); a new study is a new module and one more step here.

Part of the analysis layer: may import every layer; here the bench modules only.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from .contact_cost import contact_cost, contact_plot, contact_table
from .cost import LARGE_N_SLOPE_N, cost_rows, slopes
from .discretisation import by_scene, discretisation_rows
from .figures import plots
from .moordyn_peer import PeerResult, PeerSettings, moordyn_peer, peer_plot
from .mujoco_best import best_plot, mujoco_best
from .mujoco_compare import mujoco_compare
from .plan import Plan, PlanError, make_plan
from .report import make_summary, write_csv
from .retime import retime
from .settings import (
    BLOCK_WALL,
    ERROR_FLOOR,
    FREE_FALL_ONLY_N,
    N_LIST,
    OPEN_ENDED_DURATION,
    REF_STEP,
    REPEATS,
    SCENES,
    STEPS,
    TOLS,
    WP_DURATION,
    log,
)
from .targets import MORISON_LABEL, make_targets
from .workprecision import run_drag_variant, run_workprecision

DESCRIPTION = ("Benchmark (issues #5, #13): work-precision, convergence in n, cost in n, MuJoCo side by "
               "side, seabed cost, MoorDyn peer; issue #13's targets.")
#: The schemes that can win at large n (ros34prw: at equal steps 1.9-3.7x smaller errors than
#: ros34pw2 on the paper free fall at n = 160, 320; w6s4os: within 1 cm at 33 ms on the anchored
#: scene at n = 640, where ros34pw2 needs 20 ms; radau_iia: the free fall at n = 640 within 1 cm
#: at 0.125 s, at n = 2000 at 50 ms; radau_iia_adaptive: the same with error control).
LARGE_N_INTEGRATORS = ("rk4", "rosenbrock2", "ros34pw2", "ros34prw", "w6s4os", "radau_iia",
                       "radau_iia_adaptive")


def parse_args(argv=None) -> argparse.Namespace:
    """Command-line options."""
    ap = argparse.ArgumentParser(prog="cable_sim_bench", description=DESCRIPTION)
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true",
                      help="tiny run: 2 scenes, n 4 8, 2 s, short ladders (smoke test, CI)")
    mode.add_argument("--full", action="store_true",
                      help="each scene's full duration (paper free fall 31 s; needed for the targets)")
    ap.add_argument("--scenes", nargs="+", default=None, help=f"default {' '.join(SCENES)}")
    ap.add_argument("--n", nargs="+", type=int, default=None,
                    help=f"default {' '.join(map(str, N_LIST))} (n={FREE_FALL_ONLY_N[0]}: free fall only)")
    ap.add_argument("--integrators", nargs="+", default=None,
                    help="default: every integrator make_integrator offers here")
    ap.add_argument("--steps", nargs="+", type=float, default=None,
                    help=f"fixed-step ladder [s], default {' '.join(map(str, STEPS))}")
    ap.add_argument("--tols", nargs="+", type=float, default=None,
                    help=f"adaptive rtol=atol ladder, default {' '.join(map(str, TOLS))}")
    ap.add_argument("--duration", type=float, default=None,
                    help=f"simulated seconds of every run (default {WP_DURATION:g}; "
                         "--full: each scene's own)")
    ap.add_argument("--out", default="results/bench", help="output folder (default results/bench)")
    ap.add_argument("--budget", type=float, default=35.0,
                    help="wall seconds: a run projected (or found) to take longer is skipped, and so "
                         "are the smaller steps/tighter tolerances after it and the same integrator at "
                         "larger n of that scene; after a run longer than half of it the ladder stops "
                         "(default 35: a 31 s run at RTF 1 still fits)")
    ap.add_argument("--dop853-max-n", type=int, default=80,
                    help="largest n with a DOP853 reference (above: rosenbrock2 at --ref-step)")
    ap.add_argument("--ref-step", type=float, default=REF_STEP)
    ap.add_argument("--error-floor", type=float, default=None,
                    help=f"stop refining below this error [m] (default {ERROR_FLOOR:g}; --quick 0)")
    ap.add_argument("--ref-rtol", type=float, default=None,
                    help="DOP853 reference rtol = atol (default 1e-10; --quick 1e-12)")
    ap.add_argument("--mujoco-n", nargs="+", type=int, default=None, help="default 20 80 160")
    ap.add_argument("--mujoco-step", type=float, default=0.002)
    ap.add_argument("--no-mujoco", action="store_true")
    ap.add_argument("--mujoco-best-n", type=int, default=None,
                    help="n of the comparison with each engine at its best scheme and largest step "
                         "within 1 cm (default 80; --quick 6)")
    ap.add_argument("--morison-n", nargs="*", type=int, default=None,
                    help="n of the paper free fall with Morison drag (work-precision rows labelled "
                         f"{MORISON_LABEL}; default 80, --quick 8; none: skipped; with several n in "
                         "40..640 its cost slope is reported beside the paper free fall's)")
    ap.add_argument("--large-n-from", type=int, default=10**9,
                    help="from this n on only --large-n-integrators run (default: no restriction)")
    ap.add_argument("--large-n-integrators", nargs="+", default=list(LARGE_N_INTEGRATORS),
                    help=f"the schemes run from --large-n-from on (default {' '.join(LARGE_N_INTEGRATORS)})")
    ap.add_argument("--realtime-csv", default="results/realtime/jitter_summary_n2000.csv",
                    help="realtime_bench's summary of the node at n = 2000 (target read from it)")
    ap.add_argument("--recorder-csv", default="results/recording/recorder_bench.csv",
                    help="recorder_bench's CSV (its node_overhead row: the recording-overhead target)")
    ap.add_argument("--contact-n", type=int, default=None,
                    help="n of the seabed on/off cost study on mooring_line (default 80; --quick 6)")
    ap.add_argument("--no-contact", action="store_true", help="skip the seabed on/off cost study")
    ap.add_argument("--no-moordyn", action="store_true",
                    help="skip the MoorDyn peer (also skipped, with a message, without moordyn)")
    ap.add_argument("--refs-only", action="store_true",
                    help="only compute the cached references (largest n first; run it alongside the "
                         "main bench to fill the cache on the other core)")
    ap.add_argument("--cache", default=None, help="reference cache folder (default <out>/cache)")
    ap.add_argument("--resume", nargs="+", default=None, metavar="CSV",
                    help="workprecision.csv files of earlier runs of the same configuration: their "
                         "measured rows (ok, failed, over budget) are taken over instead of being run "
                         "again (matched on scene, n, integrator, step/rtol, duration, kernel); the "
                         "rows keep their measurement and say where they came from (column source)")
    ap.add_argument("--repeats", type=int, default=REPEATS,
                    help="timed blocks of each cheap run within 1 cm (the median of their means is "
                         f"its cost; see cable_sim.analysis.bench.retime; default {REPEATS}, 1: "
                         "single timings)")
    ap.add_argument("--block-wall", type=float, default=None,
                    help="wall seconds of back-to-back runs per timed block of the retiming "
                         f"(default {BLOCK_WALL:g}; --quick 0: one run per block)")
    ap.add_argument("--max-wall", type=float, default=math.inf,
                    help="wall seconds after which the remaining work-precision runs are skipped")
    return ap.parse_args(argv)


def fill_reference_cache(plan: Plan) -> None:
    """``--refs-only``: every reference the main run needs, largest n first."""
    for s_, n in sorted(plan.jobs(), key=lambda j: -j[1]):
        try:
            plan.reference(s_, n)
        except RuntimeError as exc:
            log(str(exc))
    if not plan.args.no_mujoco:
        for n in plan.mj_n:
            plan.reference("paper_free_fall", n, drag="none")


def mujoco_step(plan: Plan, disc: list[dict]) -> list[dict]:
    """The MuJoCo comparison (mujoco.csv) and, beside it, the discretisation study of the free fall
    with drag off (its references; added to ``disc`` and discretisation.csv rewritten)."""
    a = plan.args
    if a.no_mujoco:
        return []
    dur = plan.duration("paper_free_fall")
    mj_rows = mujoco_compare(plan.mj_n, a.mujoco_step, dur, plan.cache, a.dop853_max_n, a.ref_step,
                             a.budget, rtol=a.ref_rtol, kernel=plan.kernel)
    write_csv(plan.out / "mujoco.csv", mj_rows)
    # the paper drag's gamma is per link, so with it the physics itself changes with n
    if "paper_free_fall" in plan.scenes and len(plan.mj_n) >= 2:
        off = {n: plan.reference("paper_free_fall", n, drag="none")[0] for n in sorted(plan.mj_n)}
        disc += discretisation_rows("paper_free_fall (drag off)", off, free=True)
        write_csv(plan.out / "discretisation.csv", disc)
    return mj_rows


def morison_step(plan: Plan) -> list[dict]:
    """Issue #13: the paper free fall with Morison drag (work-precision rows, own reference)."""
    a = plan.args
    ns = a.morison_n if a.morison_n is not None else ([8] if a.quick else [80])
    if "paper_free_fall" not in plan.scenes:
        return []
    rows: list[dict] = []
    for n in ns:
        rows += run_drag_variant(plan, "paper_free_fall", n, "morison")
    return rows


def mujoco_best_step(plan: Plan) -> list[dict]:
    """Issue #13: each engine at its best scheme and largest step within 1 cm (mujoco_best.csv)."""
    a = plan.args
    if a.no_mujoco:
        return []
    n = a.mujoco_best_n or (6 if a.quick else 80)
    rows = mujoco_best(n, plan.duration("paper_free_fall"), plan.cache, a.dop853_max_n, a.ref_step,
                       a.budget, plan.steps, plan.integrators_at(n), rtol=a.ref_rtol, kernel=plan.kernel)
    write_csv(plan.out / "mujoco_best.csv", rows)
    return rows


def _study_duration(plan: Plan) -> float:
    """Simulated seconds of the contact and MoorDyn studies on mooring_line: ``--duration``,
    else 30 s (three wave periods after the 10 s ramp)."""
    return plan.args.duration if plan.args.duration is not None else OPEN_ENDED_DURATION


def contact_step(plan: Plan) -> list[dict]:
    """Issue #11 item 6: RTF at <= 1 cm with and without the seabed (contact_cost*.csv, .png)."""
    a = plan.args
    if a.no_contact:
        return []
    n = a.contact_n or (6 if a.quick else 80)
    ladder, chosen = contact_cost(n, _study_duration(plan), plan.cache, plan.integs, plan.steps,
                                  plan.tols, a.budget, rtol=a.ref_rtol, kernel=plan.kernel)
    write_csv(plan.out / "contact_cost_ladder.csv", ladder)
    write_csv(plan.out / "contact_cost.csv", chosen)
    contact_plot(plan.out, chosen)
    return contact_table(chosen)


def moordyn_step(plan: Plan) -> PeerResult:
    """Issue #13: MoorDyn as a second peer on the mooring line (moordyn*.csv, moordyn_tension.png)."""
    a = plan.args
    if a.no_moordyn:
        return PeerResult()
    ps = PeerSettings(duration=_study_duration(plan), budget=a.budget, kernel=plan.kernel)
    if a.quick:
        ps.cs_n, ps.cs_integs, ps.cs_steps, ps.cs_conv = (4, 8), ("rk4",), (0.05, 0.0125), (16, "rk4", 0.005)
        ps.md_segs, ps.md_steps, ps.md_conv = (4, 8), (0.005, 0.002), (16, 0.001)
    ps.cs_integs = tuple(i for i in ps.cs_integs if i in plan.avail)
    try:
        res = moordyn_peer(ps)
    except (RuntimeError, ValueError) as exc:  # a converged run failed / the scene does not map
        log(f"MoorDyn peer skipped: {exc}")
        return PeerResult()
    write_csv(plan.out / "moordyn_ladder.csv", res.ladder)
    write_csv(plan.out / "moordyn.csv", res.summary)
    peer_plot(plan.out, res)
    return res


def main(argv=None) -> int:
    """Entry point of ``cable_sim_bench``."""
    args = parse_args(argv)
    try:
        plan = make_plan(args)
    except PlanError as exc:
        print(f"cable_sim_bench: {exc}", file=sys.stderr)
        return 2
    plan.announce()
    if args.refs_only:
        fill_reference_cache(plan)
        return 0
    wp, refs = run_workprecision(plan)
    write_csv(plan.out / "workprecision.csv", wp)
    wp += morison_step(plan)
    retime(wp, plan.args.budget, kernel=plan.kernel, repeats=plan.args.repeats,
           block_wall=plan.args.block_wall)
    write_csv(plan.out / "workprecision.csv", wp)
    disc = by_scene(plan.scenes, refs)
    write_csv(plan.out / "discretisation.csv", disc)
    variants = tuple(sorted({r["scene"] for r in wp} - set(plan.scenes)))  # e.g. the Morison free fall
    costs = cost_rows(wp, [*plan.scenes, *variants], plan.integs)
    fitted = slopes(costs, plan.scenes)
    variant_slopes = {v: (slopes(costs, [v])[v], slopes(costs, [v], LARGE_N_SLOPE_N)[v]) for v in variants}
    shown_slopes = {**fitted, **{v: s for v, (s, _) in variant_slopes.items()}}  # plot and summary
    write_csv(plan.out / "cost_vs_n.csv", costs)
    mj_rows = mujoco_step(plan, disc)
    mj_best = mujoco_best_step(plan)
    contact = contact_step(plan)
    peer = moordyn_step(plan)
    plots(plan.out, wp, disc, costs, plan.scenes, shown_slopes, extra=variants)
    best_plot(plan.out, mj_best)
    targets = make_targets(wp, mj_best, fitted, contact=contact, peer=peer.summary,
                           realtime_csv=Path(args.realtime_csv), recorder_csv=Path(args.recorder_csv),
                           large_n_slopes=slopes(costs, plan.scenes, LARGE_N_SLOPE_N),
                           variant_slopes=variant_slopes)
    write_csv(plan.out / "targets.csv", targets)
    elapsed = time.perf_counter() - plan.t_start
    summary = make_summary(argv if argv is not None else sys.argv[1:], plan.kernel, plan.why, plan.integs,
                           args, wp, disc, costs, shown_slopes, mj_rows, targets, elapsed,
                           contact=contact, peer=peer.summary, mj_best=mj_best)
    (plan.out / "summary.md").write_text(summary)
    print(summary)
    log(f"done in {elapsed:.0f} s; results in {plan.out}")
    return 0
