"""Re-simulation of a recorded run from its recorded inputs, and its difference from the recording.

With the recorded settings (kernel, integrator, step, n) :func:`resimulate` reproduces the
recorded joint states bit for bit; :func:`compare` measures the difference either way.

Part of the analysis layer: may import every layer; here scene (:class:`Simulation`), ros
(:func:`joint_state_arrays`), :mod:`.load` and :mod:`.report`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from cable_sim.ros.messages import joint_state_arrays

from .load import Progress, Run
from .report import rms


@dataclass
class Resim:
    """A re-simulation sampled at the recording's times.

    Attributes
    ----------
    settings : dict
        kernel, integrator, step, n_links used.
    t : ndarray (N,)
        Simulation times of the samples [s] (``k * h`` nearest to each recorded stamp).
    joint_position, joint_velocity, joint_effort : ndarray (N, n+1)
        JointState arrays, computed as the node computes them.
    heave : ndarray (N,)
    tip : ndarray (N, 2)
    fairlead_t : ndarray (M,)
    fairlead : ndarray (M, 2)
        Force the cable exerts on the platform [N].
    steps : int
        Physics steps taken.
    wall : float
        Wall time of the re-simulation [s].
    """

    settings: dict[str, Any]
    t: np.ndarray
    joint_position: np.ndarray
    joint_velocity: np.ndarray
    joint_effort: np.ndarray
    heave: np.ndarray
    tip: np.ndarray
    fairlead_t: np.ndarray
    fairlead: np.ndarray
    steps: int
    wall: float


def _settings(run: Run, links: int | None, integrator: str | None, step: float | None,
              kernel: str | None) -> dict[str, Any]:
    """The given settings, else the recorded ones (``run`` metadata), else the scene's."""
    ri = run.run_info
    return {
        "kernel": kernel or ri.get("kernel") or run.scene.sim["kernel"],
        "integrator": integrator or ri.get("integrator") or run.scene.sim["integrator"],
        "step": float(step) if step is not None else float(ri.get("step", run.step)),
        "n_links": int(links) if links is not None else run.n_links,
    }


def _by_step(**steps: np.ndarray) -> dict[int, list[tuple[str, int]]]:
    """``{k: [(name, i), ...]}``: sample ``i`` of each named array of steps falls on step k."""
    events: dict[int, list[tuple[str, int]]] = {}
    for name, ks in steps.items():
        for i, k in enumerate(ks):
            events.setdefault(int(k), []).append((name, i))
    return events


def resimulate(
    run: Run, *, links: int | None = None, integrator: str | None = None, step: float | None = None,
    kernel: str | None = None, progress: Progress | None = None,
) -> Resim:
    """Run the recorded scene again from its recorded ``applied_inputs``.

    Defaults are the recorded settings (``run`` metadata), which reproduce the recorded joint
    states bit for bit. Samples are taken at the recorded joint-state and fairlead stamps
    (nearest step of the new ``h``).
    """
    from cable_sim.scene.simulation import Simulation

    settings = _settings(run, links, integrator, step, kernel)
    sim = Simulation(run.scene, kernel=settings["kernel"], integrator=settings["integrator"],
                     step=settings["step"], n_links=settings["n_links"])
    h = sim.h
    hns = h * 1e9
    k_js = np.rint(run.t_ns / hns).astype(np.int64)
    fl_ns = np.rint(run.fairlead.t * 1e9).astype(np.int64) if len(run.fairlead) else np.zeros(0, np.int64)
    k_fl = np.rint(fl_ns / hns).astype(np.int64)
    k_end = int(max(k_js.max(initial=0), k_fl.max(initial=0)))
    n = settings["n_links"]
    jp, jv, je = (np.empty((len(k_js), n + 1)) for _ in range(3))
    tip = np.empty((len(k_js), 2))
    fl = np.empty((len(k_fl), 2))
    events = _by_step(js=k_js, fl=k_fl)
    inputs = _by_step(inp=np.rint(run.applied_t_ns / hns).astype(np.int64))
    t0 = time.perf_counter()
    last = time.monotonic()
    sim.reset()
    while True:
        k = sim.k
        # as in the node: the outputs of step k are published before inputs stamped k are applied
        ev = events.get(k)
        if ev:
            out = sim.outputs()
            for kind, i in ev:
                if kind == "js":
                    jp[i], jv[i], je[i] = joint_state_arrays(out)
                    tip[i] = out.joint_positions[-1]
                else:
                    fl[i] = -out.fairlead_force
        for _, i in inputs.get(k, ()):
            sim.set_heave_force(float(run.applied.v[i, 0]))
            sim.set_wave_elevation(float(run.applied.v[i, 1]))
        if k >= k_end:
            break
        sim.step()
        if progress is not None and k % 1000 == 0 and time.monotonic() - last > 2.0:
            last = time.monotonic()
            progress(f"resimulate: t = {sim.t:.2f} / {k_end * h:.2f} s")
    return Resim(settings=settings, t=k_js * h, joint_position=jp, joint_velocity=jv,
                 joint_effort=je, heave=jp[:, 0].copy(), tip=tip, fairlead_t=k_fl * h,
                 fairlead=fl, steps=sim.k, wall=time.perf_counter() - t0)


def compare(run: Run, sim: Resim) -> dict[str, float]:
    """Max and RMS differences re-simulation - recording: heave [m], tip position [m] (distance
    between the recorded and re-simulated end of the cable), fairlead tension [N]; plus
    ``identical_joint_states`` (1.0 when positions and velocities are bitwise equal)."""
    dh = sim.heave - run.heave
    dtip = np.linalg.norm(sim.tip - run.tip, axis=1)
    dT = np.hypot(*sim.fairlead.T) - run.fairlead_tension if len(run.fairlead) else np.zeros(0)
    same = (sim.joint_position.shape == run.joint_position.shape
            and np.array_equal(sim.joint_position, run.joint_position)
            and np.array_equal(sim.joint_velocity, run.joint_velocity))
    return {
        "heave_max": float(np.abs(dh).max()), "heave_rms": rms(dh),
        "tip_max": float(dtip.max()), "tip_rms": rms(dtip),
        "tension_max": float(np.abs(dT).max()) if len(dT) else float("nan"), "tension_rms": rms(dT),
        "identical_joint_states": 1.0 if same else 0.0,
    }
