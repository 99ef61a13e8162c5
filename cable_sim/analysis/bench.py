"""Benchmark (issue #5): work-precision, convergence in n, cost in n, MuJoCo side by side.

Run ``cable_sim_bench`` (or ``make bench``); ``--quick`` runs a tiny version (smoke test, CI),
``--full`` runs every scene over its full duration (the paper free fall's 31 s, which the
targets are stated for). Everything is measured in this process; nothing is estimated or copied
from elsewhere.

Definitions
-----------
- *kernel*: ``fast`` (the O(n) numba kernel) when :mod:`cable_sim.core.kernel` imports, else ``dense``
  (printed at start and written to every CSV row).
- *integrators*: every name :func:`cable_sim.integrate.registry.make_integrator` offers at run time
  (``rk4``, ``symplectic_euler``, ``dop853``, ``radau`` and whatever
  :data:`cable_sim.integrate.implicit.INTEGRATORS` adds). Fixed-step schemes run over a ladder of steps
  (each dividing the 0.5 s sample interval), adaptive ones over a ladder of tolerances
  (rtol = atol).
- *error*: max over output samples (every 0.5 s, including t = 0 and the end) and over the
  fairlead and every joint of the Euclidean distance between a run's joint positions
  (:func:`cable_sim.core.dynamics.joint_positions`) and a reference run's at the same n [m].
- *reference*: DOP853, rtol = atol = 1e-10 (``dop853``) when n <= ``--dop853-max-n``; above that
  the explicit reference is too slow (the joint spring/damper modes make the problem stiff,
  stiffer as n grows), so the reference is ``rosenbrock2`` at a step ``--ref-step`` (default
  1e-4 s, :data:`REF_STEP`), and its own error is estimated as the distance to the same
  scheme at twice that step divided by 3 (order 2), reported in the CSV (``ref_err_est``).
- *cost*: wall time of the time stepping per simulated second; RTF = 1 / cost. A scheme with a
  compiled whole-interval stepper (kernel ``fast``) is timed as one compiled call per 0.5 s
  output interval with its inputs sampled beforehand (``wall``); the Python sampling of those
  inputs, which :meth:`cable_sim.integrate.base.Integrator.advance` also does, is timed separately
  (``wall_inputs``; ``rtf_incl_inputs`` includes it). Other schemes are timed around
  ``advance`` (fixed step, no compiled path) or around one ``solve_ivp`` call (adaptive, Python
  right-hand side). Outputs are computed outside the timed region.
- *discretisation error in n*: fairlead tension and tip (last joint) position of each n's
  reference against the finest n's reference (:meth:`cable_sim.scene.scenes.Scene.with_links` holds EI
  and per-length properties fixed).

Durations: by default every work-precision run covers :data:`WP_DURATION` = 10 s of simulated
time (shortened, to keep large-n references affordable); ``--full`` uses each scene's own
duration (31 s, 15.5 s; ``mooring_line`` has none and gets 30 s); ``--duration`` sets one for
all. The duration is a column of every CSV. The targets about the paper free fall are stated
"over the 31 s" and are only reported as met for runs of at least 31 s.

MuJoCo (optional, ``pip install mujoco``): the paper free fall with drag off in both engines
(:mod:`cable_sim.analysis.mujoco_chain`), MuJoCo's RK4 and implicitfast against our rk4, implicit_euler
and rosenbrock2 at the same n, step and duration, in the same process, best of 3 runs each;
MuJoCo steps with ``mj_step(m, d, nstep=...)`` per 0.5 s (the cost of a per-step Python loop is
reported beside it).

Results go to ``--out`` (default ``results/bench``): CSVs, PNGs, ``targets.csv`` and
``summary.md``; reference trajectories are cached as ``.npz`` under ``<out>/cache`` (or
``--cache``) keyed by scene, n, duration and reference kind, with a lock file while one is being
computed, so that ``--refs-only`` in a second process can fill the cache alongside. A run cut
short can be completed with ``--resume <workprecision.csv>``: measured rows are taken over (and
marked in the ``source`` column), only missing ones are run. Progress lines (one per run) go to
stderr.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cable_sim.core import dynamics
from cable_sim.integrate import IntegrationError, make_integrator
from cable_sim.integrate.checks import disarm
from cable_sim.integrate.registry import INTEGRATORS
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

SCENES = ("paper_free_fall", "paper_anchored_forced", "mooring_line")
N_LIST = (10, 20, 40, 80, 160, 320, 640, 2000)
#: n only run on the free-fall scene (unless ``--n`` asks for it explicitly).
FREE_FALL_ONLY_N = (2000,)
#: Step ladder of the fixed-step schemes [s]; every step divides the 0.5 s output interval.
STEPS = (0.5, 0.25, 0.1, 0.05, 0.025, 0.0125, 0.01, 0.005, 0.0025, 0.002, 0.001, 0.0005)
#: Tolerance ladder (rtol = atol) of the adaptive schemes.
TOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
#: Names :func:`make_integrator` maps to ``scipy.integrate.solve_ivp`` (adaptive).
SCIPY_ADAPTIVE = ("dop853", "radau", "rk45")
#: Output sample interval [s].
SAMPLE = 0.5
#: Default simulated duration of a work-precision run without ``--full`` [s].
WP_DURATION = 10.0
#: Duration used by ``--full`` for a scene without its own (``duration: 0``) [s].
OPEN_ENDED_DURATION = 30.0
#: Error bound of the targets [m].
ERROR_BOUND = 0.01
#: Default reference step of the rosenbrock2 reference (large n) [s].
REF_STEP = 1e-4
#: Below this error a smaller step / tighter tolerance is not run: 1e-3 of the bound [m].
ERROR_FLOOR = 1e-5
#: Target thresholds (issue #5).
TARGET_RTF_80 = 100.0
TARGET_MUJOCO_RATIO = 10.0
TARGET_RTF_2000 = 1.0
TARGET_SLOPE = 1.3
#: The duration the paper free-fall targets are stated for [s].
FREE_FALL_FULL = 31.0


def log(msg: str) -> None:
    """Progress line on stderr."""
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------------
# what is available at run time
def pick_kernel() -> tuple[str, str]:
    """``("fast", why)`` when :mod:`cable_sim.core.kernel` imports, else ``("dense", why)``."""
    try:
        from cable_sim.core import kernel as fast  # noqa: F401
    except Exception as exc:  # noqa: BLE001 - ImportError, or numba failing to compile/load
        return "dense", f"cable_sim.core.kernel not importable ({type(exc).__name__}: {exc})"
    return "fast", "cable_sim.core.kernel imported (O(n) numba kernel)"


def available_integrators() -> list[str]:
    """Every integrator name :func:`make_integrator` accepts here (``rk45`` left out: DOP853
    covers the explicit adaptive family), fixed-step schemes first."""
    names = list(dict.fromkeys([*INTEGRATORS, "dop853", "radau"]))
    return sorted(names, key=lambda s: (is_adaptive(s), names.index(s)))


def is_adaptive(name: str) -> bool:
    """True for a tolerance-controlled scheme (scipy's, or a registered ``adaptive`` class)."""
    if name in SCIPY_ADAPTIVE:
        return True
    return bool(getattr(INTEGRATORS.get(name), "adaptive", False))


# ---------------------------------------------------------------------------------------------
# one run
@dataclass
class Run:
    """One simulated trajectory, sampled every :data:`SAMPLE` seconds.

    ``setting`` is the step h [s] of a fixed-step scheme or rtol = atol of an adaptive one.
    """

    scene: str
    n: int
    integrator: str
    setting: float
    duration: float
    kernel: str = "fast"
    status: str = "ok"
    wall: float = float("nan")
    wall_inputs: float = 0.0
    nsteps: int = 0
    nfev: int = 0
    timing: str = ""
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pos: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 2)))
    tension: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def ok(self) -> bool:
        """The run reached the end."""
        return self.status == "ok"

    @property
    def cost(self) -> float:
        """Wall seconds of time stepping per simulated second."""
        return self.wall / self.duration


class _OverBudget(Exception):
    def __init__(self, t: float) -> None:
        self.t = t


def make_scene(name: str, n: int, drag: str | None = None, kernel: str = "fast"):
    """The scene at n links (EI and per-length properties fixed) on the given kernel."""
    ov: dict[str, object] = {"kernel": kernel}
    if drag is not None:
        ov["drag_model"] = drag
    sc = load_scene(name, ov)
    return sc.with_links(n) if n != sc.params.n_links else sc


def _outputs(sim: Simulation, t: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    m = sim.model
    pos = np.empty((len(t), m.n + 1, 2))
    ten = np.full(len(t), np.nan)
    for i, (ti, y) in enumerate(zip(t, ys, strict=True)):
        pos[i] = dynamics.joint_positions(m, y[: m.ndof])
        sim.y = np.array(y)
        sim.k = int(round(ti / sim.h))
        try:
            ten[i] = sim.outputs().fairlead_tension
        except IntegrationError:
            pass
    return pos, ten


def compiled_stepper(integ) -> Callable | None:
    """``advance(t0, y, t1) -> (y1, wall_stepping, wall_inputs)`` through the integrator's
    compiled whole-interval stepper, or None when it has none (dense kernel, adaptive scheme).

    Does what :meth:`Integrator.advance` does on the compiled path (same steps, same input
    sampling times, same checks and errors), but samples the inputs and arms the physical checks
    before starting the clock of the compiled call, so that the two costs are measured apart.
    """
    if not (getattr(integ, "compiled", False) and hasattr(integ, "_fast_kernel")
            and hasattr(integ, "_fast_model") and getattr(integ, "_fast_offsets", ())):
        return None
    arr, par, chk = integ._fast_model()
    offs = tuple(integ._fast_offsets)
    f = integ.system.input_at

    def advance(t0: float, y: np.ndarray, t1: float) -> tuple[np.ndarray, float, float]:
        ns = max(1, int(np.ceil((t1 - t0) / integ.h - 1e-9)))
        h = (t1 - t0) / ns
        w0 = time.perf_counter()
        oh = [o * h for o in offs]
        if ns == 1:
            ins = [f(t0 + o) for o in oh]
        else:
            tk = t0 + np.arange(ns, dtype=float) * h
            ins = [f(float(tt) + o) for tt in tk for o in oh]
        u = np.array([i.heave_force for i in ins]).reshape(ns, len(offs))
        eta = np.array([i.wave_elevation for i in ins]).reshape(ns, len(offs))
        yc = np.array(y, dtype=float, copy=True)
        info = np.zeros(4)
        integ.arm_checks(yc, h, ns, u, eta, chk)  # the physical blow-up checks, as advance()
        w1 = time.perf_counter()
        try:
            status = integ._fast_kernel(arr, par, float(h), u, eta, yc, chk, info)
        finally:
            disarm(chk)
        w2 = time.perf_counter()
        done = ns if status == 0 else int(info[1])
        integ.nsteps += done
        if status != 0:
            integ._raise_status(status, t0 + (done + 1) * h, float(info[2]), yc)
        return yc, w2 - w1, w1 - w0

    return advance


def simulate(scene_name: str, n: int, integrator: str, setting: float, duration: float,
             budget: float = math.inf, drag: str | None = None, kernel: str = "fast",
             compiled_timing: bool = True) -> Run:
    """Run one configuration (``setting``: step [s] or rtol = atol); ``budget`` [s wall] aborts
    a run projected (fixed step) or found (adaptive) to take longer. ``compiled_timing=False``
    times :meth:`Integrator.advance` as a whole instead of the compiled stepper."""
    run = Run(scene_name, n, integrator, setting, duration, kernel=kernel)
    sc = make_scene(scene_name, n, drag, kernel)
    nout = int(round(duration / SAMPLE))
    t = np.arange(nout + 1) * SAMPLE
    if is_adaptive(integrator):
        sim = Simulation(sc, kernel=kernel, integrator="rk4", step=SAMPLE)
        integ = make_integrator(integrator, sim.system, SAMPLE, rtol=setting, atol=setting)
        sys_ = sim.system
        rhs = sys_.rhs
        deadline = time.perf_counter() + budget

        def guarded(tt: float, yy: np.ndarray) -> np.ndarray:
            if time.perf_counter() > deadline:
                raise _OverBudget(tt)
            return rhs(tt, yy)

        sys_.rhs = guarded
        sys_.nfev = 0
        run.timing = "one solve_ivp call (Python right-hand side)"
        t0 = time.perf_counter()
        try:
            traj = integ.integrate(sim.y0, 0.0, nout * SAMPLE, SAMPLE)
        except _OverBudget as exc:
            run.status = f"skipped: over budget {budget:.0f} s at t={exc.t:.3g}"
            return run
        except IntegrationError as exc:
            run.status = f"failed at t={exc.t:.4g}: {exc.reason.split(';')[0]}"
            return run
        run.wall = time.perf_counter() - t0
        run.nfev = sys_.nfev
        sys_.rhs = rhs
        ys = traj.y
    else:
        sim = Simulation(sc, kernel=kernel, integrator=integrator, step=setting)
        integ = sim.integrator
        stepper = compiled_stepper(integ) if compiled_timing else None
        run.timing = ("compiled stepper, one call per 0.5 s, inputs sampled apart" if stepper
                      else "Integrator.advance per 0.5 s")
        nfev0 = sim.system.nfev
        ys = np.empty((nout + 1, sim.y0.size))
        ys[0] = y = sim.y0
        wall = wall_in = 0.0
        for i in range(nout):
            try:
                if stepper is not None:
                    y, w, wi = stepper(t[i], y, t[i + 1])
                else:
                    t0 = time.perf_counter()
                    y = integ.advance(t[i], y, t[i + 1])
                    w, wi = time.perf_counter() - t0, 0.0
            except IntegrationError as exc:
                run.status = f"failed at t={exc.t:.4g}: {exc.reason.split(';')[0]}"
                return run
            wall += w
            wall_in += wi
            ys[i + 1] = y
            if i == 0 and (wall + wall_in) * nout > budget:
                run.status = f"skipped: projected {(wall + wall_in) * nout:.0f} s > budget {budget:.0f} s"
                return run
        run.wall, run.wall_inputs = wall, wall_in
        run.nsteps = nout * max(1, int(np.ceil(SAMPLE / integ.h - 1e-9)))
        run.nfev = sim.system.nfev - nfev0 if stepper is None else run.nsteps * _fevals(integ)
    run.t = t
    run.pos, run.tension = _outputs(sim, t, ys)
    return run


def _fevals(integ) -> int:
    """Force evaluations per step of a compiled scheme (its declared count, else its stages)."""
    k = getattr(integ, "_fast_fevals", None)
    if k:
        return int(k)
    return int(getattr(integ, "stages", len(getattr(integ, "_fast_offsets", ())) or 1))


def midline(pos: np.ndarray) -> np.ndarray:
    """Position of the point half-way along the (uniform-link) line, per sample: joint n/2, or the
    middle of link (n+1)/2 for odd n. ``pos`` has shape (samples, n+1, 2)."""
    n = pos.shape[1] - 1
    if n % 2 == 0:
        return pos[:, n // 2]
    return 0.5 * (pos[:, n // 2] + pos[:, n // 2 + 1])


def error(run: Run, ref: Run) -> float:
    """Max joint-position distance [m] over samples and joints."""
    return float(np.max(np.linalg.norm(run.pos - ref.pos, axis=-1)))


# ---------------------------------------------------------------------------------------------
# references (cached)
def reference(scene: str, n: int, duration: float, cache: Path, dop853_max_n: int,
              ref_step: float, drag: str | None = None, rtol: float = 1e-10,
              kernel: str = "fast") -> tuple[Run, str, float]:
    """(reference run, description, estimated own error [m]), cached as npz."""
    kind = "dop853" if n <= dop853_max_n else "rosenbrock2"
    if kind == "rosenbrock2" and "rosenbrock2" not in INTEGRATORS:
        kind = "dop853"  # no implicit schemes: the explicit reference, however slow
    tag = f"{scene}_n{n}_T{duration:g}_{kind}" + (f"_rtol{rtol:g}" if kind == "dop853" else f"_h{ref_step:g}")
    tag += f"_drag-{drag}" if drag else ""
    path = cache / f"ref_{tag}.npz"
    lock = path.with_suffix(".lock")
    while not path.exists() and _locked_by_other(lock):
        time.sleep(2.0)  # another bench process (e.g. --refs-only) is computing this reference
    if path.exists():
        z = np.load(path)
        run = Run(scene, n, kind, float(z["step"]), duration, wall=float(z["wall"]), t=z["t"],
                  pos=z["pos"], tension=z["tension"])
        return run, str(z["desc"]), float(z["err_est"])
    log(f"reference {tag} ...")
    cache.mkdir(parents=True, exist_ok=True)
    lock.write_text(str(os.getpid()))
    try:
        return _compute_reference(scene, n, duration, kind, tag, path, ref_step, drag, rtol, kernel)
    finally:
        lock.unlink(missing_ok=True)


def _locked_by_other(lock: Path) -> bool:
    """True while ``lock`` names another live process."""
    try:
        pid = int(lock.read_text())
    except (OSError, ValueError):
        return False
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _compute_reference(scene, n, duration, kind, tag, path, ref_step, drag, rtol, kernel):
    if kind == "dop853":
        run = simulate(scene, n, "dop853", rtol, duration, drag=drag, kernel=kernel)
        desc, err_est = f"DOP853 rtol=atol={rtol:g}", float("nan")
    else:
        run = simulate(scene, n, "rosenbrock2", ref_step, duration, drag=drag, kernel=kernel)
        coarse = simulate(scene, n, "rosenbrock2", 2 * ref_step, duration, drag=drag, kernel=kernel)
        err_est = error(run, coarse) / 3.0 if (run.ok and coarse.ok) else float("nan")
        desc = f"rosenbrock2 h={ref_step:g} s (own error est. |h - 2h|/3 = {err_est:.2g} m)"
    if not run.ok:
        raise RuntimeError(f"reference {tag} failed: {run.status}")
    tmp = path.with_name(path.stem + f".{os.getpid()}.tmp.npz")
    np.savez(tmp, t=run.t, pos=run.pos, tension=run.tension, step=run.setting, wall=run.wall,
             desc=desc, err_est=err_est)
    os.replace(tmp, path)  # atomic: a --refs-only process may fill the same cache concurrently
    log(f"reference {tag}: {run.wall:.1f} s wall, {desc}")
    return run, desc, err_est


# ---------------------------------------------------------------------------------------------
# MuJoCo side by side
MUJOCO_OURS = ("rk4", "implicit_euler", "rosenbrock2")


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
    from cable_sim.analysis import mujoco_chain

    rows = []
    scene = "paper_free_fall"
    nout = int(round(duration / SAMPLE))
    per = int(round(SAMPLE / step))
    for n in n_list:
        ref, desc, _ = reference(scene, n, duration, cache, dop853_max_n, ref_step, drag="none",
                                 rtol=rtol, kernel=kernel)
        sc = make_scene(scene, n, "none", kernel)
        model = sc.model()
        y0 = sc.initial_state(model)
        mj_rk4_wall = float("nan")
        for integ in ("RK4", "implicitfast"):
            mj, data = mujoco_chain.build(model, step, integ)
            walls, status, pos = [], "ok", None
            for rep in range(repeats):
                data.qpos[:], data.qvel[:] = mujoco_chain.to_mujoco(y0[: model.ndof], y0[model.ndof:])
                data.qacc_warmstart[:] = 0.0
                data.time = 0.0
                mujoco.mj_forward(mj, data)
                p = np.empty((nout + 1, n + 1, 2))
                p[0] = dynamics.joint_positions(model, y0[: model.ndof])
                wall = 0.0
                for i in range(nout):
                    t0 = time.perf_counter()
                    mujoco.mj_step(mj, data, nstep=per)
                    wall += time.perf_counter() - t0
                    q, _ = mujoco_chain.from_mujoco(data.qpos, data.qvel)
                    if not np.all(np.isfinite(q)):
                        status = f"failed: blow-up by t={(i + 1) * SAMPLE:g}"
                        break
                    p[i + 1] = dynamics.joint_positions(model, q)
                    if i == 0 and wall * nout > budget:
                        status = (f"skipped: projected {wall * nout:.0f} s ({1e6 * wall / per:.0f} us/step "
                                  f"over the first 0.5 s) > budget {budget:.0f} s")
                        break
                if status != "ok":
                    break
                walls.append(wall)
                pos = p if pos is None else pos
                if wall * (rep + 2) > budget:
                    break  # further repeats would not fit
            # the same steps from a per-step Python loop, to show what it would add (1 interval)
            data.qpos[:], data.qvel[:] = mujoco_chain.to_mujoco(y0[: model.ndof], y0[model.ndof:])
            mujoco.mj_forward(mj, data)
            t0 = time.perf_counter()
            for _ in range(per):
                mujoco.mj_step(mj, data)
            loop_us = 1e6 * (time.perf_counter() - t0) / per
            ok = status == "ok"
            wall = min(walls) if ok else float("nan")
            if integ == "RK4" and ok:
                mj_rk4_wall = wall
            err = float(np.max(np.linalg.norm(pos - ref.pos, axis=-1))) if ok else float("nan")
            rows.append(dict(engine=f"mujoco {mujoco.__version__}", integrator=integ, n=n, step=step,
                             duration=duration, status=status, repeats=len(walls), wall=wall,
                             rtf=duration / wall, us_per_step=1e6 * wall / (nout * per),
                             us_per_step_python_loop=loop_us,
                             speed_vs_mujoco_rk4=mj_rk4_wall / wall,
                             error_m=err, reference=desc,
                             timing=f"mj_step(nstep={per}) per 0.5 s, best of {len(walls)}"))
            log(f"mujoco {integ} n={n} h={step:g}: {status} wall {wall:.3f} s (best of {len(walls)}) "
                f"err {err:.3g} m (per-step Python loop: {loop_us:.1f} us/step)")
        for integ in ours:
            if integ not in INTEGRATORS:
                continue
            runs = []
            for _ in range(repeats):
                r = simulate(scene, n, integ, step, duration, budget=budget, drag="none", kernel=kernel)
                runs.append(r)
                if not r.ok or r.wall * (len(runs) + 1) > budget:
                    break
            r = runs[0]
            if r.ok:
                r.wall = min(x.wall for x in runs)
                r.wall_inputs = min(x.wall_inputs for x in runs)
            rows.append(dict(engine=f"cable_sim ({kernel})", integrator=integ, n=n, step=step,
                             duration=duration, status=r.status, repeats=len(runs), wall=r.wall,
                             rtf=duration / r.wall, us_per_step=1e6 * r.wall / (nout * per),
                             us_per_step_python_loop=float("nan"),
                             speed_vs_mujoco_rk4=mj_rk4_wall / r.wall,
                             error_m=error(r, ref) if r.ok else float("nan"), reference=desc,
                             timing=f"{r.timing}, best of {len(runs)}",
                             us_per_step_incl_inputs=1e6 * (r.wall + r.wall_inputs) / (nout * per)))
            log(f"cable_sim {integ} n={n} h={step:g}: {r.status} wall {r.wall:.3f} s "
                f"(+{r.wall_inputs:.3f} s input sampling; best of {len(runs)})")
    return rows


# ---------------------------------------------------------------------------------------------
def _write_csv(path: Path, rows: list[dict]) -> None:
    if not rows:
        return
    keys = list(rows[0].keys())
    for r in rows[1:]:
        keys += [k for k in r if k not in keys]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


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


def plots(out: Path, wp: list[dict], disc: list[dict], cost_rows: list[dict], scenes, slopes) -> None:
    """Work-precision per scene (a panel per n, a line per integrator), error vs n, cost vs n."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    integs_all = list(dict.fromkeys(r["integrator"] for r in wp))
    colours = {k: f"C{i}" for i, k in enumerate(integs_all)}
    for scene in scenes:
        rows = [r for r in wp if r["scene"] == scene and r["status"] == "ok"]
        if not rows:
            continue
        ns = sorted({r["n"] for r in rows})
        ncol = min(4, len(ns))
        nrow = int(math.ceil(len(ns) / ncol))
        fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), sharey=True,
                                 squeeze=False)
        for ax, n in zip(axes.flat, ns, strict=False):
            for integ in integs_all:
                rr = sorted([r for r in rows if r["integrator"] == integ and r["n"] == n],
                            key=lambda r: r["cost"])
                if rr:
                    ax.loglog([r["cost"] for r in rr], [max(r["error_m"], 1e-12) for r in rr],
                              "o-", ms=3, color=colours[integ], label=integ)
            ax.axhline(ERROR_BOUND, color="k", ls=":", lw=1)
            ax.axvline(0.01, color="r", ls=":", lw=1)
            ax.axvline(1.0, color="r", ls="--", lw=0.8)
            ax.set_title(f"n = {n}", fontsize=9)
            ax.grid(True, which="both", alpha=0.3)
        for ax in axes.flat[len(ns):]:
            ax.set_visible(False)
        for ax in axes[-1]:
            ax.set_xlabel("wall s per simulated s")
        for ax in axes[:, 0]:
            ax.set_ylabel("max joint-position error [m]")
        axes.flat[0].legend(fontsize=7)
        dur = rows[0]["duration"]
        fig.suptitle(f"{scene} ({dur:g} s simulated, kernel {rows[0]['kernel']}): work-precision "
                     "(dotted: 1 cm and RTF 100; dashed: RTF 1)", fontsize=10)
        fig.tight_layout()
        fig.savefig(out / f"workprecision_{scene}.png", dpi=100)
        plt.close(fig)
    if disc:
        fig, axes = plt.subplots(1, 2, figsize=(10, 4))
        for i, scene in enumerate(dict.fromkeys(r["scene"] for r in disc)):
            rr = [r for r in disc if r["scene"] == scene and r["n"] != r["n_fine"]]
            if rr:
                lab = f"{scene} (vs n={rr[0]['n_fine']})"
                key, what = ("tip_error_m", "tip") if rr[0]["free_end"] else ("midline_error_m", "mid-line")
                axes[0].loglog([r["n"] for r in rr], [r[key] for r in rr], "o-", color=f"C{i}",
                               label=f"{lab}, {what}")
                axes[1].loglog([r["n"] for r in rr], [r["tension_rel_error"] for r in rr], "s-",
                               color=f"C{i}", label=lab)
        axes[0].set_ylabel("max position difference [m]")
        axes[0].set_title("tip (free end) / mid-line point (anchored)", fontsize=9)
        axes[1].set_title("fairlead tension", fontsize=9)
        axes[1].set_ylabel("max fairlead tension difference / max tension")
        for ax in axes:
            ax.set_xlabel("n links")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle("discretisation error in n (reference runs; EI, mass per length fixed)", fontsize=10)
        fig.tight_layout()
        fig.savefig(out / "error_vs_n.png", dpi=100)
        plt.close(fig)
    if cost_rows:
        fig, ax = plt.subplots(figsize=(6.5, 4.2))
        for i, scene in enumerate(scenes):
            rr = sorted([r for r in cost_rows if r["scene"] == scene and r["integrator"] == "best"],
                        key=lambda r: r["n"])
            if rr:
                ns = np.array([r["n"] for r in rr], dtype=float)
                cs = np.array([r["cost"] for r in rr])
                s = slopes.get(scene, float("nan"))
                ax.loglog(ns, cs, "o-", color=f"C{i}", label=f"{scene} (fitted slope n>=40: {s:.2f})")
                big = ns >= 40
                if np.isfinite(s) and big.sum() >= 2:
                    c = np.polyfit(np.log(ns[big]), np.log(cs[big]), 1)
                    ax.loglog(ns[big], np.exp(np.polyval(c, np.log(ns[big]))), ":", color=f"C{i}")
        ax.axhline(1.0, color="r", ls="--", lw=0.8)
        ax.axhline(0.01, color="r", ls=":", lw=0.8)
        ax.set_xlabel("n links")
        ax.set_ylabel(f"wall s per simulated s at error <= {ERROR_BOUND * 100:g} cm")
        ax.set_title("cost vs n (cheapest integrator/step within the bound)", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "cost_vs_n.png", dpi=100)
        plt.close(fig)


def parse_args(argv=None) -> argparse.Namespace:
    """Command-line options."""
    ap = argparse.ArgumentParser(prog="cable_sim_bench", description=__doc__.split("\n")[0])
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
    ap.add_argument("--refs-only", action="store_true",
                    help="only compute the cached references (largest n first; run it alongside the "
                         "main bench to fill the cache on the other core)")
    ap.add_argument("--cache", default=None, help="reference cache folder (default <out>/cache)")
    ap.add_argument("--resume", nargs="+", default=None, metavar="CSV",
                    help="workprecision.csv files of earlier runs of the same configuration: their "
                         "measured rows (ok, failed, over budget) are taken over instead of being run "
                         "again (matched on scene, n, integrator, step/rtol, duration, kernel); the "
                         "rows keep their measurement and say where they came from (column source)")
    ap.add_argument("--max-wall", type=float, default=math.inf,
                    help="wall seconds after which the remaining work-precision runs are skipped")
    return ap.parse_args(argv)


def _duration(scene: str, args) -> float:
    if args.duration is not None:
        return args.duration
    if not args.full:
        return WP_DURATION
    d = float(load_scene(scene).sim.get("duration", 0.0) or 0.0)
    return d if d > 0 else OPEN_ENDED_DURATION


def _jobs(scenes, n_list, explicit_n: bool) -> list[tuple[str, int]]:
    """(scene, n) pairs, smallest n first across scenes (so that a --refs-only process, which
    works from the largest n down, has the most time to fill the cache)."""
    jobs = [(s, n) for s in scenes for n in n_list
            if explicit_n or n not in FREE_FALL_ONLY_N or s == "paper_free_fall"]
    return sorted(jobs, key=lambda j: j[1])


def main(argv=None) -> int:
    """Entry point of ``cable_sim_bench``."""
    args = parse_args(argv)
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
    else:
        scenes = args.scenes or list(SCENES)
        n_list = args.n or list(N_LIST)
        steps = args.steps or list(STEPS)
        tols = args.tols or list(TOLS)
        mj_n = args.mujoco_n or [20, 80, 160]
    integs = args.integrators or avail
    bad = [i for i in integs if i not in avail]
    if bad:
        print(f"cable_sim_bench: parameter 'integrators' has {bad}; allowed: {avail}", file=sys.stderr)
        return 2
    args.ref_rtol = args.ref_rtol or 1e-10
    floor = ERROR_FLOOR if args.error_floor is None else args.error_floor
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cache = Path(args.cache) if args.cache else out / "cache"
    resumed = load_resume(args.resume or [])
    t_start = time.perf_counter()
    log(f"kernel {kernel}: {why}")
    log(f"integrators available: {avail}; running {integs}")
    log(f"scenes {scenes} n {n_list} steps {steps} tols {tols} durations "
        f"{ {s: _duration(s, args) for s in scenes} } out {out}")
    jobs = _jobs(scenes, n_list, args.n is not None)
    if args.refs_only:
        for s_, n in sorted(jobs, key=lambda j: -j[1]):
            try:
                reference(s_, n, _duration(s_, args), cache, args.dop853_max_n, args.ref_step,
                          rtol=args.ref_rtol, kernel=kernel)
            except RuntimeError as exc:
                log(str(exc))
        if not args.no_mujoco:
            for n in mj_n:
                reference("paper_free_fall", n, _duration("paper_free_fall", args), cache,
                          args.dop853_max_n, args.ref_step, drag="none", rtol=args.ref_rtol, kernel=kernel)
        return 0
    deadline = t_start + args.max_wall

    wp: list[dict] = []
    refs: dict[tuple[str, int], Run] = {}
    too_slow: dict[tuple[str, str], int] = {}  # (scene, integrator) -> n at which it hit the budget
    for scene, n in jobs:
        dur = _duration(scene, args)
        try:
            ref, desc, ref_err = reference(scene, n, dur, cache, args.dop853_max_n, args.ref_step,
                                           rtol=args.ref_rtol, kernel=kernel)
        except RuntimeError as exc:
            log(f"{scene} n={n}: {exc}; skipping this n")
            continue
        refs[(scene, n)] = ref
        for integ in integs:
            adaptive = is_adaptive(integ)
            ladder = tols if adaptive else sorted(steps, reverse=True)
            prev_wall = 0.0
            for s in ladder:
                skip = None
                key = _row_key(scene, n, integ, s, dur, kernel)
                if key in resumed:
                    row = dict(resumed[key])
                    wp.append(row)
                    log(f"{scene} n={n} {integ} {'rtol' if adaptive else 'h'}={s:g}: {row['status']} "
                        f"(taken from {row['source']})")
                    if row["status"].startswith("skipped"):
                        too_slow.setdefault((scene, integ), n)
                        break
                    if row["status"] == "ok":
                        prev_wall = row["wall"] + row["wall_inputs"]
                        if row["error_m"] < floor:
                            break
                    continue
                if time.perf_counter() > deadline:
                    skip = "skipped: --max-wall reached"
                elif (scene, integ) in too_slow:
                    skip = f"skipped: over the budget already at n={too_slow[(scene, integ)]}"
                elif prev_wall > args.budget / 2:
                    skip = f"skipped: the previous (cheaper) setting took {prev_wall:.0f} s"
                if skip:
                    r = Run(scene, n, integ, s, dur, kernel=kernel, status=skip)
                else:
                    r = simulate(scene, n, integ, s, dur, budget=args.budget, kernel=kernel)
                    if r.status.startswith("skipped"):
                        too_slow.setdefault((scene, integ), n)
                    elif r.ok:
                        prev_wall = r.wall + r.wall_inputs
                nst = r.nsteps if not adaptive else 0
                row = dict(scene=scene, n=n, kernel=kernel, integrator=integ,
                           kind="adaptive" if adaptive else "fixed",
                           step=float("nan") if adaptive else s, rtol=s if adaptive else float("nan"),
                           duration=dur, status=r.status, wall=r.wall, wall_inputs=r.wall_inputs,
                           cost=r.cost, rtf=1.0 / r.cost,
                           rtf_incl_inputs=dur / (r.wall + r.wall_inputs),
                           us_per_step=1e6 * r.wall / nst if (r.ok and nst) else float("nan"),
                           nfev=r.nfev if r.ok else 0,
                           error_m=error(r, ref) if r.ok else float("nan"),
                           reference=desc, ref_err_est=ref_err, timing=r.timing, source="this run")
                wp.append(row)
                what = f"rtol={s:g}" if adaptive else f"h={s:g}"
                log(f"{scene} n={n} {integ} {what}: {r.status}"
                    + (f" err {row['error_m']:.3g} m RTF {row['rtf']:.1f}"
                       f" (incl. input sampling {row['rtf_incl_inputs']:.1f})" if r.ok else ""))
                if skip and "max-wall" not in skip:
                    break  # the rest of the ladder costs more
                if r.status.startswith("skipped") and not skip:
                    break
                if r.ok and row["error_m"] < floor:
                    break
    _write_csv(out / "workprecision.csv", wp)

    # discretisation error in n (references vs the finest n's reference)
    disc: list[dict] = []
    for scene in scenes:
        free = load_scene(scene).params.end_condition == "free"
        disc += _disc_rows(scene, {n: r for (s_, n), r in refs.items() if s_ == scene}, free)
    _write_csv(out / "discretisation.csv", disc)

    # cost vs n at the error bound
    cost_rows: list[dict] = []
    for scene in scenes:
        for integ in [*integs, None]:
            for n in sorted({r["n"] for r in wp if r["scene"] == scene}):
                b = best_under(wp, scene, n, ERROR_BOUND, integ)
                if b is not None:
                    cost_rows.append(dict(scene=scene, integrator=integ or "best", n=n,
                                          duration=b["duration"], cost=b["cost"], rtf=b["rtf"],
                                          rtf_incl_inputs=b["rtf_incl_inputs"], chosen=b["integrator"],
                                          step=b["step"], rtol=b["rtol"], error_m=b["error_m"]))
    slopes = {}
    for scene in scenes:
        rr = [r for r in cost_rows if r["scene"] == scene and r["integrator"] == "best" and r["n"] >= 40]
        slopes[scene] = fit_slope([r["n"] for r in rr], [r["cost"] for r in rr])
    _write_csv(out / "cost_vs_n.csv", cost_rows)

    mj_rows: list[dict] = []
    if not args.no_mujoco:
        mj_rows = mujoco_compare(mj_n, args.mujoco_step, _duration("paper_free_fall", args), cache,
                                 args.dop853_max_n, args.ref_step, args.budget, rtol=args.ref_rtol,
                                 kernel=kernel)
        _write_csv(out / "mujoco.csv", mj_rows)
        # the same convergence study on the free fall with drag off (the MuJoCo references): the
        # paper drag's gamma is per link, so with it the physics itself changes with n
        if "paper_free_fall" in scenes and len(mj_n) >= 2:
            dur = _duration("paper_free_fall", args)
            off = {n: reference("paper_free_fall", n, dur, cache, args.dop853_max_n, args.ref_step,
                                drag="none", rtol=args.ref_rtol, kernel=kernel)[0] for n in sorted(mj_n)}
            disc += _disc_rows("paper_free_fall (drag off)", off, free=True)
            _write_csv(out / "discretisation.csv", disc)

    plots(out, wp, disc, cost_rows, scenes, slopes)
    targets = make_targets(wp, mj_rows, slopes)
    _write_csv(out / "targets.csv", targets)
    elapsed = time.perf_counter() - t_start
    summary = make_summary(argv if argv is not None else sys.argv[1:], kernel, why, integs, args,
                           wp, disc, cost_rows, slopes, mj_rows, targets, elapsed)
    (out / "summary.md").write_text(summary)
    print(summary)
    log(f"done in {elapsed:.0f} s; results in {out}")
    return 0


def _disc_rows(label: str, refs: dict[int, Run], free: bool) -> list[dict]:
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


def _row_key(scene: str, n: int, integ: str, setting: float, duration: float, kernel: str) -> tuple:
    return (scene, int(n), integ, float(f"{setting:.6g}"), float(f"{duration:.6g}"), kernel)


_RESUMABLE = ("ok", "failed", "skipped: projected", "skipped: over budget")
_INT_COLS = ("n", "nfev")
_STR_COLS = ("scene", "kernel", "integrator", "kind", "status", "reference", "timing", "source")


def load_resume(paths) -> dict[tuple, dict]:
    """Measured rows of earlier ``workprecision.csv`` files, keyed like the runs (see --resume)."""
    rows: dict[tuple, dict] = {}
    for p in paths:
        with open(p, newline="") as f:
            for r in csv.DictReader(f):
                if not r["status"].startswith(_RESUMABLE):
                    continue
                row = {k: (v if k in _STR_COLS else int(v) if k in _INT_COLS
                           else float(v) if v != "" else float("nan")) for k, v in r.items()}
                if row.get("source", "this run") == "this run":
                    row["source"] = str(p)
                setting = row["rtol"] if row["kind"] == "adaptive" else row["step"]
                rows[_row_key(row["scene"], row["n"], row["integrator"], setting, row["duration"],
                              row["kernel"])] = row
    return rows


def _full_enough(row: dict) -> bool:
    return row["duration"] >= FREE_FALL_FULL - 1e-9


def make_targets(wp: list[dict], mj_rows: list[dict], slopes: dict) -> list[dict]:
    """The issue's targets: measured value, goal, met, detail (one row each)."""
    rows = []
    for n, goal in ((80, TARGET_RTF_80), (2000, TARGET_RTF_2000)):
        b = best_under(wp, "paper_free_fall", n, ERROR_BOUND)
        if b is None:
            detail = f"n={n} not run, or no run within 1 cm"
            met = False
        else:
            detail = (f"{b['integrator']} " + (f"h={b['step']:g} s" if b["kind"] == "fixed" else
                                               f"rtol={b['rtol']:g}")
                      + f", error {b['error_m']:.3g} m over {b['duration']:g} s vs {b['reference']}; "
                      f"RTF incl. Python input sampling {b['rtf_incl_inputs']:.3g}")
            met = b["rtf"] >= goal and _full_enough(b)
            if not _full_enough(b):
                detail += f"; only {b['duration']:g} s simulated (target is over 31 s: run --full)"
        rows.append(dict(target=f"paper free fall n={n}: real-time factor at <= 1 cm max joint-position "
                                "error", measured=b["rtf"] if b else float("nan"), goal=f">= {goal:g}",
                         met=met, detail=detail))
        if n == 80:
            mj = {(r["engine"].split()[0], r["integrator"], r["n"]): r for r in mj_rows}
            ref = mj.get(("mujoco", "RK4", 80))
            ours = mj.get(("cable_sim", "rk4", 80))
            if ref and ours and ref["status"] == "ok" and ours["status"] == "ok":
                ratio = ref["wall"] / ours["wall"]
                rows.append(dict(target="paper free fall n=80 (drag off in both), same step: speed of our "
                                        "rk4 / MuJoCo RK4", measured=ratio,
                                 goal=f">= {TARGET_MUJOCO_RATIO:g}", met=ratio >= TARGET_MUJOCO_RATIO,
                                 detail=f"h={ref['step']:g} s, {ref['duration']:g} s simulated, same "
                                        f"process, best of {ref['repeats']}; errors ours "
                                        f"{ours['error_m']:.2g} m, MuJoCo {ref['error_m']:.2g} m"))
            else:
                rows.append(dict(target="paper free fall n=80 (drag off in both), same step: speed of our "
                                        "rk4 / MuJoCo RK4", measured=float("nan"),
                                 goal=f">= {TARGET_MUJOCO_RATIO:g}", met=False,
                                 detail="not measured (mujoco missing, n=80 not run, or a run failed)"))
    for scene, s in slopes.items():
        rows.append(dict(target=f"{scene}: slope of cost per simulated s vs n at <= 1 cm (n >= 40)",
                         measured=s, goal=f"<= {TARGET_SLOPE:g}",
                         met=bool(np.isfinite(s) and s <= TARGET_SLOPE),
                         detail="log-log least-squares fit of the cheapest run within 1 cm per n"))
    return rows


def _fmt(v, digits: int = 3) -> str:
    if isinstance(v, float):
        return "n/a" if not np.isfinite(v) else f"{v:.{digits}g}"
    return str(v)


def _table(rows: list[dict], keys: list[str], digits: int = 3) -> str:
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(_fmt(r.get(k, ""), digits) for k in keys) + " |")
    return "\n".join(lines)


def make_summary(argv, kernel, why, integs, args, wp, disc, cost_rows, slopes, mj_rows, targets,
                 elapsed) -> str:
    """The markdown snippet for the README (also printed)."""
    cpu = platform.processor() or platform.machine()
    durs = sorted({(r["scene"], r["duration"]) for r in wp})
    s = [
        "## Benchmark (issue #5)",
        "",
        f"Measured by `cable_sim_bench {' '.join(argv)}` on {cpu}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, kernel `{kernel}` ({why}); {elapsed:.0f} s wall for this "
        "invocation. "
        f"Integrators: {', '.join(integs)}. Simulated durations: "
        + ", ".join(f"{sc} {d:g} s" for sc, d in durs) + ". "
        "Cost = wall time of the time stepping per simulated second, RTF = 1 / cost (compiled "
        "schemes: one compiled call per 0.5 s with the inputs sampled beforehand; the Python input "
        "sampling that `Integrator.advance` adds is in `rtf_incl_inputs`; scipy schemes: one "
        "`solve_ivp` call). Error = max over joints and 0.5 s samples of the joint-position "
        "distance to a reference at the same n "
        f"(DOP853 rtol=atol={args.ref_rtol:g} for n <= {args.dop853_max_n}, else rosenbrock2 at h = "
        f"{args.ref_step:g} s with its error estimated from h vs 2h). Single runs on a shared machine "
        "(other jobs were running): timings carry noise of tens of per cent.",
        "",
        "### Targets",
        "",
        _table(targets, ["target", "measured", "goal", "met", "detail"], digits=4),
        "",
    ]
    if mj_rows:
        s += ["### MuJoCo side by side (paper free fall, drag OFF in both models)", "",
              "Same chain in MJCF (`cable_sim/analysis/mujoco_chain.py`: slide joint + heave spring/damper + "
              "gravcomp for the platform, hinges with the same stiffness/damping on the relative "
              "angles, rod inertia m l^2/12, point load, buoyancy as constant `xfrc_applied`; drag "
              "omitted, it has no MuJoCo counterpart without a per-step Python callback). MuJoCo "
              "runs `mj_step(m, d, nstep=...)` per 0.5 s (no per-step Python loop; what such a loop "
              "costs is in `us_per_step_python_loop`); ours one compiled call per 0.5 s. "
              "`speed_vs_mujoco_rk4` = MuJoCo RK4 wall time / this row's wall time, same n, step "
              "and duration, measured in the same process. Error vs our reference with drag off.", "",
              _table(mj_rows, ["engine", "integrator", "n", "step", "status", "rtf", "us_per_step",
                               "us_per_step_python_loop", "speed_vs_mujoco_rk4", "error_m"]), ""]
    best = [r for r in cost_rows if r["integrator"] == "best"]
    if best:
        s += ["### Cheapest run within 1 cm, per scene and n", "",
              _table(best, ["scene", "n", "duration", "chosen", "step", "rtol", "rtf", "rtf_incl_inputs",
                            "error_m"]), "",
              "Fitted slopes of cost vs n (n >= 40): "
              + ", ".join(f"{k} {_fmt(v, 4)}" for k, v in slopes.items()), ""]
    if disc:
        s += ["### Discretisation error in n (reference runs vs the finest n)", "",
              "Scene.with_links holds EI, bending damping and the per-length properties fixed, but the "
              "paper drag's gamma_i is a per-link constant (its torque gamma l^2/4 thetadot^2 summed "
              "over the links scales like 1/n): with the paper drag the line's physics changes with n, "
              "and the paper scenes' differences in n measure that as much as discretisation. The "
              "'(drag off)' rows are the same free fall without drag (the MuJoCo comparison's "
              "references).", "",
              _table(disc, ["scene", "n", "n_fine", "duration", "tip_error_m", "midline_error_m",
                            "tension_rel_error"]), ""]
    nres = sum(1 for r in wp if r.get("source", "this run") != "this run")
    if nres:
        srcs = sorted({r["source"] for r in wp if r.get("source", "this run") != "this run"})
        s += [f"{nres} of the work-precision rows were measured by an earlier invocation with the same "
              f"settings and taken over with `--resume` ({', '.join(srcs)}; column `source`).", ""]
    nfail = sum(1 for r in wp if r["status"].startswith("failed"))
    nskip = sum(1 for r in wp if r["status"].startswith("skipped"))
    s += [f"Work-precision runs: {len(wp)} ({nfail} failed (blow-up or check), {nskip} skipped by the "
          "per-run budget or --max-wall; see workprecision.csv). Plots: workprecision_<scene>.png, "
          "error_vs_n.png, cost_vs_n.png.", ""]
    return "\n".join(s)


if __name__ == "__main__":
    raise SystemExit(main())
