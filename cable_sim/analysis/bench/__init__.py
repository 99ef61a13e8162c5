"""Benchmark (issue #5): work-precision, convergence in n, cost in n, MuJoCo side by side.

Run ``cable_sim_bench`` (or ``make bench``); ``--quick`` runs a tiny version (smoke test, CI),
``--full`` runs every scene over its full duration (the paper free fall's 31 s, which the
targets are stated for). Everything is measured in this process; nothing is estimated or copied
from elsewhere.

Modules (one study each, :mod:`.cli` runs them in order): :mod:`.settings` (ladders, bounds,
progress log), :mod:`.runs` (one timed run: scenes, :func:`simulate`, the compiled stepper),
:mod:`.references` (cached reference runs), :mod:`.plan` (what a command line asks for),
:mod:`.workprecision` (the step / tolerance ladders, ``--resume``), :mod:`.discretisation`
(error in n), :mod:`.cost` (cost vs n at the error bound), :mod:`.mujoco_chain` (the chain in
MJCF) and :mod:`.mujoco_compare` (the side-by-side runs), :mod:`.contact_cost` (RTF at <= 1 cm
on the mooring line with the seabed on and off, issue #11), :mod:`.moordyn_input`,
:mod:`.moordyn_run` and :mod:`.moordyn_peer` (MoorDyn v2 as a second peer on the mooring line,
issue #13), :mod:`.targets`, :mod:`.figures` (PNGs), :mod:`.report` (CSV files, summary.md). A
further peer or figure is a further module plus one step in
:func:`cable_sim.analysis.bench.cli.main`.

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
  output interval with its inputs sampled beforehand (``wall``); the sampling of those inputs
  (:meth:`cable_sim.integrate.base.Integrator._sample_inputs`: compiled when the scene's inputs
  have an input program) and the arming of the physical checks, which
  :meth:`cable_sim.integrate.base.Integrator.advance` also does, are timed separately
  (``wall_inputs``; ``rtf_incl_inputs`` includes them). Other schemes are timed around
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
(:mod:`cable_sim.analysis.bench.mujoco_chain`), MuJoCo's RK4 and implicitfast against our rk4,
implicit_euler and rosenbrock2 at the same n, step and duration, in the same process, best of 3
runs each; MuJoCo steps with ``mj_step(m, d, nstep=...)`` per 0.5 s (the cost of a per-step
Python loop is reported beside it).

Seabed cost (``--no-contact`` skips it, ``--contact-n``): see :mod:`.contact_cost`. MoorDyn
(optional, ``pip install moordyn==2.7.2``; ``--no-moordyn`` skips it): see :mod:`.moordyn_peer`.
Both run on ``mooring_line`` for ``--duration`` (default 30 s) in the same invocation.

Results go to ``--out`` (default ``results/bench``): CSVs, PNGs, ``targets.csv`` and
``summary.md``; reference trajectories are cached as ``.npz`` under ``<out>/cache`` (or
``--cache``) keyed by scene, n, duration and reference kind, with a lock file while one is being
computed, so that ``--refs-only`` in a second process can fill the cache alongside. A run cut
short can be completed with ``--resume <workprecision.csv>``: measured rows are taken over (and
marked in the ``source`` column), only missing ones are run. Progress lines (one per run) go to
stderr.

This package is the analysis layer: it may import every layer (core, integrate, scene).
"""

from .cli import main, parse_args
from .cost import best_under, fit_slope
from .mujoco_compare import mujoco_compare
from .references import reference
from .report import make_summary
from .resume import load_resume
from .runs import (
    Run,
    available_integrators,
    compiled_stepper,
    error,
    is_adaptive,
    make_scene,
    midline,
    pick_kernel,
    simulate,
)
from .settings import (
    ERROR_BOUND,
    ERROR_FLOOR,
    N_LIST,
    REF_STEP,
    SAMPLE,
    SCENES,
    STEPS,
    TOLS,
    WP_DURATION,
    log,
)
from .targets import make_targets

__all__ = [
    "ERROR_BOUND", "ERROR_FLOOR", "N_LIST", "REF_STEP", "SAMPLE", "SCENES", "STEPS", "TOLS", "WP_DURATION",
    "Run", "available_integrators", "best_under", "compiled_stepper", "error", "fit_slope", "is_adaptive",
    "load_resume", "log", "main", "make_scene", "make_summary", "make_targets", "midline", "mujoco_compare",
    "parse_args", "pick_kernel", "reference", "simulate",
]
