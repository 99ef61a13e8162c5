"""One benchmark run: the scene at n links, one integrator at one step / tolerance, timed.

:func:`simulate` returns a :class:`Run` (joint positions and fairlead tension every
:data:`~.settings.SAMPLE` s, wall times, status); :func:`compiled_stepper` times a compiled
scheme's whole-interval stepper apart from its input sampling; :func:`error` is the
work-precision error against a reference run. Also what is available at run time
(:func:`pick_kernel`, :func:`available_integrators`).

Part of the analysis layer: may import every layer; here core, integrate and scene.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from cable_sim.core import dynamics
from cable_sim.integrate import IntegrationError, make_integrator
from cable_sim.integrate.checks import disarm
from cable_sim.integrate.registry import INTEGRATORS
from cable_sim.scene.scenes import Scene, load_scene
from cable_sim.scene.simulation import Simulation

from .settings import SAMPLE, SCIPY_ADAPTIVE


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
    #: Step attempts redone in halves (Radau IIA where its Newton iteration did not converge).
    halved: int = 0
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


def make_scene(name: str, n: int, drag: str | None = None, kernel: str = "fast",
               overrides: dict | None = None) -> Scene:
    """The scene at n links (EI and per-length properties fixed) on the given kernel, with
    further scene ``overrides`` (e.g. ``{"seabed": False}``)."""
    ov: dict[str, object] = {"kernel": kernel, **(overrides or {})}
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

    Does what :meth:`Integrator.advance` does on the compiled path (same steps, the same input
    sampling, :meth:`Integrator._sample_inputs`: compiled when the scene's inputs have an input
    program, same checks and errors), but samples the inputs and arms the physical checks before
    starting the clock of the compiled call, so that the two costs are measured apart.
    """
    if not (getattr(integ, "compiled", False) and hasattr(integ, "_fast_kernel")
            and hasattr(integ, "_fast_model") and getattr(integ, "_fast_offsets", ())):
        return None
    arr, par, chk = integ._fast_model()

    def advance(t0: float, y: np.ndarray, t1: float) -> tuple[np.ndarray, float, float]:
        ns = max(1, int(np.ceil((t1 - t0) / integ.h - 1e-9)))
        h = (t1 - t0) / ns
        w0 = time.perf_counter()
        u, eta, u_max, eta_max = integ._sample_inputs(t0, h, ns)
        yc = np.array(y, dtype=float, copy=True)
        info = np.zeros(4)
        integ.arm_checks(yc, h, ns, u, eta, chk, (u_max, eta_max))  # as advance()
        w1 = time.perf_counter()
        try:
            status = integ._fast_kernel(arr, par, float(h), u, eta, yc, chk, info)
        finally:
            disarm(chk)
        w2 = time.perf_counter()
        done = ns if status == 0 else int(info[1])
        integ.nsteps += done
        # force evaluations as Integrator._run_fast counts them (a scheme without a fixed count,
        # e.g. Radau IIA's Newton iteration, counts them in info[0])
        fixed = getattr(integ, "_fast_fevals", None)
        integ.system.nfev += int(info[0]) if fixed is None else fixed * done
        if status != 0:
            integ._raise_status(status, t0 + (done + 1) * h, float(info[2]), yc)
        return yc, w2 - w1, w1 - w0

    return advance


def adaptive_stepper(integ) -> Callable | None:
    """``advance(t0, y, t1) -> (y1, wall_stepping, wall_inputs)`` through an adaptive scheme's
    compiled run (:class:`cable_sim.integrate.adaptive.AdaptiveStepping`), or None when it has
    none (scipy's schemes, dense kernel): as :func:`compiled_stepper`, what
    :meth:`AdaptiveStepping.advance` does, with the input sampling and the arming of the checks
    timed apart from the compiled run."""
    if not (getattr(integ, "compiled", False) and hasattr(integ, "_run_adaptive")):
        return None

    def advance(t0: float, y: np.ndarray, t1: float) -> tuple[np.ndarray, float, float]:
        w0 = time.perf_counter()
        y, dt, u, eta = integ._begin(t0, y, t1)
        arr, par, chk, yc, info = integ._arm_adaptive(t0, y, t1, u, eta)
        w1 = time.perf_counter()
        try:
            status = integ._run_adaptive(arr, par, float(t0), float(t1), float(t0), float(dt), u, eta,
                                         yc, chk, info, integ._ctl)
        finally:
            disarm(chk)
        w2 = time.perf_counter()
        return integ._finish_adaptive(status, t1 - t0, info, chk, yc), w2 - w1, w1 - w0

    return advance


def _run_adaptive(run: Run, sc: Scene, t: np.ndarray, budget: float, compiled_timing: bool = True
                  ) -> tuple[Simulation, np.ndarray] | None:
    """One adaptive run at rtol = atol = ``run.setting``: our compiled schemes timed per 0.5 s
    interval as the fixed-step ones (:func:`adaptive_stepper`), scipy's as one ``solve_ivp``
    call; None when it failed or ran over ``budget`` (``run.status`` says which)."""
    nout = len(t) - 1
    sim = Simulation(sc, kernel=run.kernel, integrator="rk4", step=SAMPLE)
    integ = make_integrator(run.integrator, sim.system, SAMPLE, rtol=run.setting, atol=run.setting)
    stepper = adaptive_stepper(integ) if compiled_timing else None
    if stepper is not None:
        return _run_intervals(run, sim, integ, stepper, t, budget,
                              "compiled adaptive run, one call per 0.5 s, inputs sampled apart")
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
        return None
    except IntegrationError as exc:
        run.status = f"failed at t={exc.t:.4g}: {exc.reason.split(';')[0]}"
        return None
    run.wall = time.perf_counter() - t0
    run.nfev = sys_.nfev
    run.nsteps = int(getattr(integ, "nsteps", 0) or 0)  # accepted steps (0: not counted, scipy)
    sys_.rhs = rhs
    return sim, traj.y


def _run_fixed(run: Run, sc: Scene, t: np.ndarray, budget: float, compiled_timing: bool
               ) -> tuple[Simulation, np.ndarray] | None:
    """Steps of ``run.setting`` s, timed per 0.5 s interval; None when it failed or was projected
    over ``budget`` after the first interval (``run.status`` says which)."""
    sim = Simulation(sc, kernel=run.kernel, integrator=run.integrator, step=run.setting)
    integ = sim.integrator
    stepper = compiled_stepper(integ) if compiled_timing else None
    done = _run_intervals(run, sim, integ, stepper, t, budget,
                          "compiled stepper, one call per 0.5 s, inputs sampled apart")
    if done is not None:
        run.nsteps = (len(t) - 1) * max(1, int(np.ceil(SAMPLE / integ.h - 1e-9)))
    return done


def _run_intervals(run: Run, sim: Simulation, integ, stepper: Callable | None, t: np.ndarray,
                   budget: float, timing: str) -> tuple[Simulation, np.ndarray] | None:
    """``integ`` over the sample intervals of ``t``, each through ``stepper`` (``timing`` names
    it) or :meth:`Integrator.advance`; sets ``run.wall``, ``run.wall_inputs``, ``run.nfev``
    (counted by the system) and ``run.nsteps`` (the integrator's count); None when a step failed
    or the run was projected over ``budget`` after the first interval."""
    nout = len(t) - 1
    run.timing = timing if stepper else "Integrator.advance per 0.5 s"
    nfev0, nsteps0 = sim.system.nfev, integ.nsteps
    halved0 = getattr(integ, "newton_failures", 0)
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
            return None
        wall += w
        wall_in += wi
        ys[i + 1] = y
        if i == 0 and (wall + wall_in) * nout > budget:
            run.status = f"skipped: projected {(wall + wall_in) * nout:.0f} s > budget {budget:.0f} s"
            return None
    run.wall, run.wall_inputs = wall, wall_in
    run.nsteps = integ.nsteps - nsteps0
    run.nfev = sim.system.nfev - nfev0
    run.halved = getattr(integ, "newton_failures", 0) - halved0
    return sim, ys


def simulate(scene_name: str, n: int, integrator: str, setting: float, duration: float,
             budget: float = math.inf, drag: str | None = None, kernel: str = "fast",
             compiled_timing: bool = True, overrides: dict | None = None) -> Run:
    """Run one configuration (``setting``: step [s] or rtol = atol); ``budget`` [s wall] aborts
    a run projected (fixed step) or found (adaptive) to take longer. ``compiled_timing=False``
    times :meth:`Integrator.advance` as a whole instead of the compiled stepper; ``overrides``
    are further scene parameters (:func:`make_scene`)."""
    run = Run(scene_name, n, integrator, setting, duration, kernel=kernel)
    sc = make_scene(scene_name, n, drag, kernel, overrides)
    nout = int(round(duration / SAMPLE))
    t = np.arange(nout + 1) * SAMPLE
    if is_adaptive(integrator):
        done = _run_adaptive(run, sc, t, budget, compiled_timing)
    else:
        done = _run_fixed(run, sc, t, budget, compiled_timing)
    if done is None:
        return run
    sim, ys = done
    run.t = t
    run.pos, run.tension = _outputs(sim, t, ys)
    return run


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
