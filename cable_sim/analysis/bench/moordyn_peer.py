"""MoorDyn 2.7 as a second peer on the anchored mooring line (issue #13), in the same run.

Both codes simulate ``mooring_line`` (seabed on, Morison drag, added mass on) for ``duration``
seconds with the same fairlead heave: cable_sim's own buoy heave under the scene's wave, taken
from cable_sim's converged run and prescribed to MoorDyn's coupled fairlead
(:mod:`.moordyn_run`; the line mapped by :mod:`.moordyn_input`, EA large). The fairlead tension
(force magnitude at the fairlead, every :data:`~.settings.SAMPLE` s from t = 0, the static
state included) is compared with each code's *own* converged answer (cable_sim: ``cs_conv``
links, rk4 at a small step; MoorDyn: ``md_conv`` segments at a small dtM); the error of a run is
``max_t |T(t) - T_conv(t)| / max_t T_conv``.

For each code the segment counts are walked upwards. A count is tried only when the code's
time-converged run at that count (cable_sim: :data:`CS_FINE`; MoorDyn: dtM = :data:`MD_FINE`) is
within :data:`TENSION_BOUND` of the converged answer: the discretisation in n must be good
enough on its own (a coarse n whose time error happens to cancel its discretisation error at
some step is not taken for converged). At a count that is, each scheme walks its steps
downwards, and the first within the bound is accepted; the first count with an accepted run
ends the walk (more segments cost more at a smaller step). Each code is reported at its
cheapest accepted run: segment count, step, wall time per simulated second (the shortest of
``repeats`` timings, taken alternately for the two codes so that both see the same machine
load). Wall time: cable_sim's
time stepping including its input sampling (:func:`.runs.simulate`'s ``wall + wall_inputs``),
MoorDyn's ``Step`` calls including their Python call overhead (100 calls per simulated second).
The two converged answers are compared (static, mean and max fairlead tension and the whole
history).

``moordyn`` is optional: without it :func:`moordyn_peer` logs why and returns nothing.

Part of the analysis layer: may import every layer; here scene and the bench modules.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .moordyn_input import EA_DEFAULT, line_from_scene
from .moordyn_run import MoorDynRun, moordyn_version, run_moordyn
from .runs import is_adaptive, make_scene, simulate
from .settings import SAMPLE, log

SCENE = "mooring_line"
#: A run is converged enough when its fairlead tension is within this of its code's converged one.
TENSION_BOUND = 0.01
CS_N = (10, 20, 40, 60, 80, 120, 160)
CS_INTEGS = ("rk4", "rosenbrock2", "ros34pw2")
CS_STEPS = (0.5, 0.25, 0.1, 0.05, 0.025, 0.0125, 0.005, 0.0025, 0.001)
CS_CONV = (320, "rk4", 0.001)
#: cable_sim's time-converged run at each n: (scheme, step).
CS_FINE = ("rk4", 0.005)
MD_SEGS = (10, 20, 40, 60, 80, 120, 160)
#: MoorDyn's default scheme (its explicit RK2); the steps bracket its stability limit at each n.
MD_SCHEMES = ("RK2",)
MD_STEPS = (0.01, 0.005, 0.002, 0.0015, 0.001, 0.00075, 0.0005, 0.0003, 0.0002)
MD_CONV = (320, 0.0002)
#: MoorDyn's time-converged run at each n: dtM [s] (its first scheme).
MD_FINE = 0.0002
#: Timings of each code's chosen run (alternating between the codes; the shortest counts).
REPEATS = 5


@dataclass
class PeerSettings:
    """What the peer comparison runs (defaults: the module constants)."""

    duration: float = 30.0
    budget: float = 35.0
    kernel: str = "fast"
    cs_n: tuple = CS_N
    cs_integs: tuple = CS_INTEGS
    cs_steps: tuple = CS_STEPS
    cs_conv: tuple = CS_CONV
    md_segs: tuple = MD_SEGS
    md_schemes: tuple = MD_SCHEMES
    md_steps: tuple = MD_STEPS
    md_conv: tuple = MD_CONV
    cs_fine: tuple = CS_FINE
    md_fine: float = MD_FINE
    ea: float = EA_DEFAULT
    repeats: int = REPEATS


@dataclass
class PeerResult:
    """Rows of moordyn_ladder.csv (every run) and moordyn.csv (per code), and the histories."""

    ladder: list[dict] = field(default_factory=list)
    summary: list[dict] = field(default_factory=list)
    histories: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


def tension_error(ten: np.ndarray, conv: np.ndarray) -> float:
    """max_t |T - T_conv| / max_t |T_conv| (nan when the lengths differ or T is not finite)."""
    if ten.shape != conv.shape or not np.all(np.isfinite(ten)):
        return float("nan")
    return float(np.max(np.abs(ten - conv)) / np.max(np.abs(conv)))


def _row(code: str, scheme: str, n: int, step: float, duration: float, status: str, wall: float,
         ten: np.ndarray, conv: np.ndarray, setup_wall: float = float("nan")) -> dict:
    ok = status == "ok"
    err = tension_error(ten, conv) if ok else float("nan")
    return dict(code=code, scheme=scheme, segments=n, step=step, duration=duration, status=status,
                wall=wall, wall_per_sim_s=wall / duration if ok else float("nan"),
                rtf=duration / wall if ok else float("nan"), setup_wall=setup_wall,
                tension_rel_error=err, within_bound=bool(ok and err <= TENSION_BOUND),
                static_tension_N=float(ten[0]) if ok else float("nan"),
                mean_tension_N=float(np.mean(ten)) if ok else float("nan"),
                max_tension_N=float(np.max(ten)) if ok else float("nan"))


def _walk(runner, fine, ns, steps, log_name: str) -> list[dict]:
    """The ladder of one scheme: ``runner(n, step) -> row``; ``fine(n) -> row`` is the code's
    time-converged run at n (shared by its schemes). See the module docstring."""
    rows: list[dict] = []
    for n in ns:
        f = fine(n)
        if not f["within_bound"]:
            continue  # n itself is too coarse: no step can be trusted to be within the bound
        for h in sorted(steps, reverse=True):
            row = runner(n, h)
            row["role"] = "ladder"
            row["accepted"] = bool(row["within_bound"])
            rows.append(row)
            log(f"moordyn peer: {log_name} n={n} step={h:g}: {row['status']}"
                + (f" tension err {row['tension_rel_error']:.3g}, {row['wall_per_sim_s']:.4g} "
                   "wall s / sim s" if row["status"] == "ok" else ""))
            if row["accepted"] or row["status"].startswith("skipped"):
                break
        if any(r["accepted"] for r in rows):
            break
    return rows


def _fine(runner, step: float, log_name: str) -> Callable[[int], dict]:
    """``fine(n)``: the row of ``runner(n, step)`` (memoised), marked as the time-converged run."""
    done: dict[int, dict] = {}

    def fine(n: int) -> dict:
        if n not in done:
            row = runner(n, step)
            row.update(role="time-converged", accepted=False)
            done[n] = row
            log(f"moordyn peer: {log_name} n={n} time-converged (step {step:g}): {row['status']}"
                + (f" tension err {row['tension_rel_error']:.3g}" if row["status"] == "ok" else ""))
        return done[n]

    fine.done = done  # type: ignore[attr-defined]
    return fine


def _cable_sim(ps: PeerSettings, conv: np.ndarray) -> list[dict]:
    def run(n: int, h: float, integ: str) -> dict:
        r = simulate(SCENE, n, integ, h, ps.duration, budget=ps.budget, kernel=ps.kernel)
        return _row("cable_sim", integ, n, h, ps.duration, r.status, r.wall + r.wall_inputs,
                    r.tension, conv)

    fine = _fine(lambda n, h: run(n, h, ps.cs_fine[0]), ps.cs_fine[1], "cable_sim")
    rows: list[dict] = []
    for integ in ps.cs_integs:
        if not is_adaptive(integ):
            rows += _walk(lambda n, h, integ=integ: run(n, h, integ), fine, ps.cs_n, ps.cs_steps,
                          f"cable_sim {integ}")
    return [*fine.done.values(), *rows]


def _moordyn(ps: PeerSettings, line, heave, conv: np.ndarray, version: str) -> list[dict]:
    def run(n: int, h: float, scheme: str) -> dict:
        r = run_moordyn(line, n, h, ps.duration, heave, SAMPLE, ps.budget, scheme)
        return _row(f"moordyn {version}", scheme, n, h, ps.duration, r.status, r.wall, r.tension,
                    conv, r.setup_wall)

    fine = _fine(lambda n, h: run(n, h, ps.md_schemes[0]), ps.md_fine, "moordyn")
    rows: list[dict] = []
    for scheme in ps.md_schemes:
        rows += _walk(lambda n, h, scheme=scheme: run(n, h, scheme), fine, ps.md_segs, ps.md_steps,
                      f"moordyn {scheme}")
    return [*fine.done.values(), *rows]


def _best(rows: list[dict]) -> dict | None:
    ok = [r for r in rows if r.get("accepted")]
    return min(ok, key=lambda r: r["wall"]) if ok else None


def _summary(code: str, rows: list[dict], conv_desc: str, conv_ten: np.ndarray,
             other_ten: np.ndarray) -> dict:
    b = _best(rows)
    diff_hist = float(np.max(np.abs(conv_ten - other_ten)) / np.max(other_ten))
    return dict(code=code, scheme=b["scheme"] if b else "none", segments=b["segments"] if b else -1,
                step=b["step"] if b else float("nan"),
                wall_per_sim_s=b["wall_per_sim_s"] if b else float("nan"),
                rtf=b["rtf"] if b else float("nan"),
                tension_rel_error=b["tension_rel_error"] if b else float("nan"),
                converged=conv_desc, conv_static_tension_N=float(conv_ten[0]),
                conv_mean_tension_N=float(np.mean(conv_ten)), conv_max_tension_N=float(np.max(conv_ten)),
                conv_min_tension_N=float(np.min(conv_ten)),
                static_rel_diff_vs_cable_sim=float(conv_ten[0] / other_ten[0] - 1.0),
                mean_rel_diff_vs_cable_sim=float(np.mean(conv_ten) / np.mean(other_ten) - 1.0),
                max_rel_diff_vs_cable_sim=float(np.max(conv_ten) / np.max(other_ten) - 1.0),
                history_rel_diff_vs_cable_sim=diff_hist)


def moordyn_peer(ps: PeerSettings) -> PeerResult:
    """The comparison (see the module docstring); empty without ``moordyn``.

    Raises
    ------
    RuntimeError
        When a converged run fails (the comparison has nothing to compare with).
    """
    version = moordyn_version()
    if version is None:
        log("MoorDyn peer skipped: moordyn not importable (optional: pip install moordyn==2.7.2, "
            "or pip install .[bench])")
        return PeerResult()
    from scipy.interpolate import CubicSpline

    n_c, integ_c, h_c = ps.cs_conv
    cs = simulate(SCENE, n_c, integ_c, h_c, ps.duration, kernel=ps.kernel)
    if not cs.ok:
        raise RuntimeError(f"cable_sim converged run (n={n_c}, {integ_c}, h={h_c:g}) failed: {cs.status}")
    heave = CubicSpline(cs.t, cs.pos[:, 0, 1])
    line = line_from_scene(make_scene(SCENE, n_c, kernel=ps.kernel), float(cs.pos[0, 0, 1]), ps.ea)
    nseg_c, dt_c = ps.md_conv
    md: MoorDynRun = run_moordyn(line, nseg_c, dt_c, ps.duration, heave, SAMPLE, float("inf"),
                                 ps.md_schemes[0])
    if not md.ok:
        raise RuntimeError(f"MoorDyn converged run ({nseg_c} segments, dtM={dt_c:g}) failed: {md.status}")
    log(f"moordyn peer: converged cable_sim n={n_c} {integ_c} h={h_c:g}: static {cs.tension[0]:.0f} N; "
        f"MoorDyn {version} {nseg_c} segments dtM={dt_c:g}: static {md.tension[0]:.0f} N")
    res = PeerResult()
    res.histories = {f"cable_sim n={n_c} {integ_c} h={h_c:g}": (cs.t, cs.tension),
                     f"MoorDyn {version} {nseg_c} seg {ps.md_schemes[0]} dtM={dt_c:g}": (md.t, md.tension)}
    cs_rows = _cable_sim(ps, cs.tension)
    md_rows = _moordyn(ps, line, heave, md.tension, version)
    res.ladder = cs_rows + md_rows
    stretch = float(np.max(md.tension)) / line.ea
    res.summary = [
        _summary("cable_sim", cs_rows, f"n={n_c} {integ_c} h={h_c:g} s (inextensible links)",
                 cs.tension, cs.tension),
        _summary(f"moordyn {version}", md_rows,
                 f"{nseg_c} segments {ps.md_schemes[0]} dtM={dt_c:g} s (EA {line.ea:.3g} N: "
                 f"max stretch {100 * stretch:.3f} %)", md.tension, cs.tension),
    ]
    _retime_chosen(res, ps, line, heave, cs_rows, md_rows, cs.t)
    return res


def _rerun(b: dict, ps: PeerSettings, line, heave) -> tuple[float, np.ndarray]:
    """(wall time, tension history) of a chosen run done again."""
    if b["code"] == "cable_sim":
        r = simulate(SCENE, b["segments"], b["scheme"], b["step"], ps.duration, kernel=ps.kernel)
        wall = r.wall + r.wall_inputs
    else:
        r = run_moordyn(line, b["segments"], b["step"], ps.duration, heave, SAMPLE, float("inf"),
                        b["scheme"])
        wall = r.wall
    return (wall if r.ok else float("inf")), r.tension


def _retime_chosen(res: PeerResult, ps: PeerSettings, line, heave, cs_rows, md_rows, t) -> None:
    """Each code's chosen run timed ``ps.repeats - 1`` more times, alternating between the codes
    (both see the same machine load); the shortest wall time goes into the summary row."""
    chosen = [(i, b) for i, b in enumerate((_best(cs_rows), _best(md_rows))) if b is not None]
    walls = {i: [b["wall"]] for i, b in chosen}
    hist = {}
    for k in range(max(ps.repeats - 1, 1)):
        for i, b in chosen:
            w, ten = _rerun(b, ps, line, heave)
            if k == 0:
                hist[i] = ten
            if ps.repeats > 1:
                walls[i].append(w)
    for i, b in chosen:
        w = min(walls[i])
        res.summary[i].update(wall_per_sim_s=w / ps.duration, rtf=ps.duration / w, repeats=len(walls[i]))
        code = "cable_sim" if i == 0 else "MoorDyn"
        res.histories[f"{code} chosen: {b['segments']} seg {b['scheme']} step {b['step']:g}"] = (t, hist[i])


def peer_plot(out, res: PeerResult) -> None:
    """moordyn_tension.png: fairlead tension histories (converged and chosen runs) of both codes."""
    if not res.histories:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    items = list(res.histories.items())
    base_t, base = items[0][1]
    for i, (label, (t, ten)) in enumerate(items):
        ls = "-" if i < 2 else "--"
        axes[0].plot(t, ten / 1e3, ls, color=f"C{i}", label=label, lw=1.2)
        if ten.shape == base.shape:
            axes[1].plot(t, 100 * (ten - base) / np.max(base), ls, color=f"C{i}", lw=1.0)
    axes[0].set_ylabel("fairlead tension [kN]")
    axes[0].legend(fontsize=7)
    axes[1].set_ylabel("difference to converged cable_sim\n[% of its max]")
    axes[1].axhline(100 * TENSION_BOUND, color="k", ls=":", lw=0.8)
    axes[1].axhline(-100 * TENSION_BOUND, color="k", ls=":", lw=0.8)
    axes[1].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{SCENE}: fairlead tension, cable_sim vs MoorDyn (same fairlead heave)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "moordyn_tension.png", dpi=100)
    plt.close(fig)
