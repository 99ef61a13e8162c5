"""The benchmark's fixed settings (scenes, n, step and tolerance ladders, bounds) and its log.

Part of the analysis layer; imports nothing from cable_sim (every bench module may import it).
"""

from __future__ import annotations

import sys
import time

SCENES = ("paper_free_fall", "paper_anchored_forced", "mooring_line")
N_LIST = (10, 20, 40, 80, 160, 320, 640, 2000)
#: n only run on the free-fall scene (unless ``--n`` asks for it explicitly).
FREE_FALL_ONLY_N = (2000,)
#: Steps per 0.5 s output interval of the fixed-step ladder: dense between 1 and 15 (0.5 s ..
#: 33 ms), where the largest step within 1 cm of the paper and Morison scenes lies at n <= 160.
STEPS_PER_SAMPLE = (1, 2, 4, 5, 6, 7, 8, 9, 10, 12, 13, 15, 20, 25, 40, 50, 100, 200, 250, 500, 1000)
#: Step ladder of the fixed-step schemes [s]; every step divides the 0.5 s output interval.
STEPS = tuple(0.5 / k for k in STEPS_PER_SAMPLE)
#: Tolerance ladder (rtol = atol) of the adaptive schemes.
TOLS = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 1e-6, 1e-7, 1e-8)
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
#: Timed blocks of each cheap run within the bound, the median of whose means is its cost
#: (:mod:`.retime`).
REPEATS = 5
#: A retiming block runs its configuration back to back until their walls add up to this [s]
#: (:mod:`.retime`).
BLOCK_WALL = 0.2
#: A run within the bound is timed again when its single cost is at most this times the
#: cheapest one's at its (scene, n) (:mod:`.retime`).
CLOSE = 1.5
#: Below this error a smaller step / tighter tolerance is not run: 1e-3 of the bound [m].
ERROR_FLOOR = 1e-5


def log(msg: str) -> None:
    """Progress line on stderr."""
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)
