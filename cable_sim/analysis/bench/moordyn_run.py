"""One timed MoorDyn v2 run of the scene's line with a prescribed fairlead heave.

:func:`run_moordyn` writes the input file (:mod:`.moordyn_input`), lets MoorDyn find its initial
conditions (its stationary solver at dtM = :data:`IC_DT`; timed apart as ``setup_wall``), sets
the run's dtM, then drives the coupled fairlead through a given heave z(t) and records the
magnitude of the force the line exerts on it every ``sample`` seconds. The fairlead moves along
the piecewise-linear interpolant of z(t) between coupling instants (MoorDyn extrapolates a coupled
point linearly from the position and velocity it is given, so the velocity passed is the secant
over the coupling step: the path is continuous). Only the ``moordyn.Step`` calls are timed.

``moordyn`` is optional (bench extra); :func:`moordyn_version` is None without it.

Part of the analysis layer: may import every layer; here the bench modules only.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata

import numpy as np

from .moordyn_input import MoorDynLine, input_text

#: Coupling interval of the Step calls [s] (MoorDyn sub-steps it with its own dtM).
COUPLING = 0.01
#: dtM of MoorDyn's initial-condition solver [s]; the run's own dtM is set after it (with a dtM of
#: 0.2 ms the solver stopped early at 10 and 20 segments: static fairlead tension 90 kN instead of
#: 154 kN; with 5 ms it failed at 320 segments; 1 ms gives the same static state at 10..320).
IC_DT = 1e-3
#: A fairlead force above this [N] is a blow-up, not a tension.
IMPLAUSIBLE_FORCE = 1e9


def moordyn_version() -> str | None:
    """Version of the installed ``moordyn`` package, None when it is not importable."""
    try:
        import moordyn  # noqa: F401
    except ImportError:
        return None
    try:
        return metadata.version("moordyn")
    except metadata.PackageNotFoundError:
        return "unknown"


@dataclass
class MoorDynRun:
    """A MoorDyn trajectory: fairlead force magnitude every ``sample`` s from t = 0."""

    nseg: int
    dt: float
    duration: float
    tscheme: str
    status: str = "ok"
    wall: float = float("nan")
    setup_wall: float = float("nan")
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tension: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def ok(self) -> bool:
        """The run reached the end."""
        return self.status == "ok"


@contextlib.contextmanager
def _quiet():
    """File descriptors 1 and 2 to /dev/null (MoorDyn prints its input parsing and its
    initial-condition iterations from C++)."""
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def run_moordyn(line: MoorDynLine, nseg: int, dt: float, duration: float,
                heave: Callable[[np.ndarray], np.ndarray], sample: float = 0.5,
                budget: float = float("inf"), tscheme: str = "RK2",
                coupling: float = COUPLING) -> MoorDynRun:
    """MoorDyn with ``nseg`` segments and internal step ``dt`` [s], the fairlead at x = 0 moving
    to cable_sim's z = ``heave(t)`` [m]; ``budget`` [s wall] aborts a run projected to take
    longer after its first simulated second."""
    import moordyn

    run = MoorDynRun(nseg, dt, duration, tscheme)
    nout = int(round(duration / sample))
    per = int(round(sample / coupling))
    tc = np.arange(nout * per + 1) * coupling
    zc = np.array([line.to_moordyn_z(float(z)) for z in heave(tc)])
    x0 = [line.fairlead[0], line.fairlead[1], float(zc[0])]
    ten = np.full(nout + 1, np.nan)
    with tempfile.TemporaryDirectory(prefix="cable_sim_moordyn_") as tmp:
        path = os.path.join(tmp, "line.txt")
        with open(path, "w") as f:
            f.write(input_text(line, nseg, IC_DT, tscheme))
        t0 = time.perf_counter()
        with _quiet():
            system = moordyn.Create(path)
            moordyn.SetVerbosity(system, moordyn.LEVEL_NONE)
            err = moordyn.Init(system, x0, [0.0, 0.0, 0.0])
            moordyn.SetDt(system, dt)
        run.setup_wall = time.perf_counter() - t0
        try:
            if err != 0:
                run.status = f"failed: moordyn.Init returned {err}"
                return run
            ten[0] = np.linalg.norm(moordyn.Step(system, x0, [0.0, 0.0, 0.0], 0.0, 0.0))
            wall = 0.0
            k = 0
            for i in range(nout):
                for _ in range(per):
                    x = [x0[0], x0[1], float(zc[k])]
                    v = [0.0, 0.0, float((zc[k + 1] - zc[k]) / coupling)]
                    w0 = time.perf_counter()
                    force = moordyn.Step(system, x, v, float(tc[k]), coupling)
                    wall += time.perf_counter() - w0
                    k += 1
                ten[i + 1] = np.linalg.norm(force)
                if not (np.isfinite(ten[i + 1]) and ten[i + 1] < IMPLAUSIBLE_FORCE):
                    run.status = f"failed at t={(i + 1) * sample:g}: fairlead force {ten[i + 1]:.3g} N"
                    return run
                if i == 1 and wall * nout / 2 > budget:
                    run.status = f"skipped: projected {wall * nout / 2:.0f} s > budget {budget:.0f} s"
                    return run
        except RuntimeError as exc:  # MoorDyn raises on NaN states and other errors
            run.status = f"failed: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
            return run
        finally:
            with _quiet():
                moordyn.Close(system)
    run.wall = wall
    run.t = np.arange(nout + 1) * sample
    run.tension = ten
    return run
