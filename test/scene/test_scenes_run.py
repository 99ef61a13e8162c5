"""Both paper scenes run end to end (full durations, shipped integrator and step, dense kernel).

References: the second law of thermodynamics for the unforced free-fall scene (dampers and drag
only remove energy: dE/dt <= 0), and the energy balance E(t) - E(0) = int P dt for the forced
anchored scene (P = power of the heave force, dampers, drag and anchor reaction, integrated
with Simpson's rule over the per-step samples). The energy function and the power were checked
against independent references in test_sympy_dynamics / test_energy; here a subsample is also
cross-checked with ``conftest.RefLine``.

Slack for "never increases": 1e-9 of the peak kinetic energy per sample (a sample = one 2 ms
step), far above roundoff (~1e-16 relative) and far below the energy dissipated per step.
"""

from __future__ import annotations

import numpy as np
from conftest import RefLine
from scipy.integrate import cumulative_simpson

from cable_sim.core import dynamics
from cable_sim.scene.scenes import load_scene


def test_free_fall_scene_runs_and_energy_never_increases() -> None:
    """paper_free_fall, 31 s, rk4 at 2 ms: finite throughout, E(t_{k+1}) - E(t_k) <= 1e-9 T_max
    at every step, and a substantial amount of energy is dissipated."""
    scene = load_scene("paper_free_fall", {"kernel": "dense"})
    assert float(scene.sim["duration"]) == 31.0
    model = scene.model()
    system = scene.system(model=model)
    integ = scene.integrator(system)
    assert integ.name == "rk4" and integ.h == 0.002
    tr = integ.integrate(scene.initial_state(model), 0.0, 31.0, integ.h)
    assert tr.y.shape[0] == 15501 and np.all(np.isfinite(tr.y))
    n1 = model.ndof
    E = np.array([dynamics.total_energy(model, y[:n1], y[n1:]) for y in tr.y])
    T = np.array([dynamics.kinetic_energy(model, y[:n1], y[n1:]) for y in tr.y])
    # cross-check the energy on a subsample with the independent reference (datum-free)
    ref = RefLine(scene.params)
    E_ref = np.array([ref.energy(y[:n1], y[n1:]) for y in tr.y[::775]])
    assert np.allclose(E[::775] - E[0], E_ref - E_ref[0], rtol=0, atol=1e-9 * T.max())
    rise = np.diff(E)
    print(f"free fall: T_max = {T.max():.6g} J, E(0) - E(31 s) = {E[0] - E[-1]:.6g} J, largest "
          f"per-step change {rise.max():.3g} J (slack {1e-9 * T.max():.3g} J)")
    assert rise.max() <= 1e-9 * T.max()
    assert E[0] - E[-1] > 1e4  # dissipation is substantial


def test_anchored_forced_scene_runs_with_energy_balance(anchored_scene_run) -> None:
    """paper_anchored_forced, 15.5 s, rk4 at 2 ms: finite throughout, the platform is driven,
    and E(t) - E(0) = int_0^t P dt to 1e-6 of max |W| (Simpson over the 7751 samples)."""
    run = anchored_scene_run
    model, system, t, ys = run["model"], run["system"], run["t"], run["y"]
    assert t[-1] == 15.5 and np.all(np.isfinite(ys))
    n1 = model.ndof
    E = np.array([dynamics.total_energy(model, y[:n1], y[n1:]) for y in ys])
    P = np.empty(t.size)
    for k, (tk, y) in enumerate(zip(t, ys, strict=True)):
        inp = system.input_at(tk)
        _, lam = dynamics.forward_dynamics(model, y[:n1], y[n1:], inp)
        P[k] = sum(dynamics.power(model, y[:n1], y[n1:], inp, lam).values())
    W = cumulative_simpson(P, x=t, initial=0.0)
    err = np.max(np.abs(E - E[0] - W)) / np.max(np.abs(W))
    print(f"anchored forced: max|W| = {np.max(np.abs(W)):.6g} J, balance error {err:.3g}, heave "
          f"range {np.ptp(ys[:, 0]):.3g} m")
    assert np.max(np.abs(W)) > 1e4
    assert err < 1e-6
