"""Reference runs of the benchmark, cached as ``.npz`` (shared with a ``--refs-only`` process).

DOP853 at a tight tolerance up to ``dop853_max_n`` links, rosenbrock2 at a small step above (its
own error estimated from h vs 2h). A lock file names the process computing a reference, so a
second bench process waits for it instead of computing it again.

Part of the analysis layer: may import every layer; here integrate and :mod:`.runs`.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from cable_sim.integrate.registry import INTEGRATORS

from .runs import Run, error, simulate
from .settings import log


def reference(scene: str, n: int, duration: float, cache: Path, dop853_max_n: int,
              ref_step: float, drag: str | None = None, rtol: float = 1e-10,
              kernel: str = "fast", overrides: dict | None = None) -> tuple[Run, str, float]:
    """(reference run, description, estimated own error [m]), cached as npz; ``overrides`` are
    further scene parameters (part of the cache key)."""
    kind = "dop853" if n <= dop853_max_n else "rosenbrock2"
    if kind == "rosenbrock2" and "rosenbrock2" not in INTEGRATORS:
        kind = "dop853"  # no implicit schemes: the explicit reference, however slow
    tag = f"{scene}_n{n}_T{duration:g}_{kind}" + (f"_rtol{rtol:g}" if kind == "dop853" else f"_h{ref_step:g}")
    tag += f"_drag-{drag}" if drag else ""
    tag += "".join(f"_{k}-{v}" for k, v in sorted((overrides or {}).items()))
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
        return _compute_reference(scene, n, duration, kind, tag, path, ref_step, drag, rtol, kernel,
                                  overrides)
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


def _compute_reference(scene, n, duration, kind, tag, path, ref_step, drag, rtol, kernel, overrides):
    ov = dict(drag=drag, kernel=kernel, overrides=overrides)
    if kind == "dop853":
        run = simulate(scene, n, "dop853", rtol, duration, **ov)
        desc, err_est = f"DOP853 rtol=atol={rtol:g}", float("nan")
    else:
        run = simulate(scene, n, "rosenbrock2", ref_step, duration, **ov)
        coarse = simulate(scene, n, "rosenbrock2", 2 * ref_step, duration, **ov)
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
