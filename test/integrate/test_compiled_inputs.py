"""Compiled input sampling: a Simulation's built-in inputs evaluated inside numba.

The compiled RK4 run whose inputs come from the system's input program must equal the Python
path (``compiled=False``: Python RK4, inputs from the Python callable) of the same scene up to
round-off accumulation and must not call the Python signal at all; its energy budget must be
the one the compiled path had with Python sampling (the checks stay as strict).
"""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core import inputs as signals_py
from cable_sim.core.dynamics import Inputs
from cable_sim.core.system import CableSystem
from cable_sim.integrate.explicit import RK4
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

#: Other code path, same arithmetic: state difference from round-off accumulation only.
REL = 1e-9

CASES = {
    # paper Fig. 10 scene: sine heave force 25 kN, anchored; n = 12 for speed
    "sine_heave": ("paper_anchored_forced", {"n_links": 12, "heave_force_ramp": 1.0}, 0.002, "Sine"),
    # mooring line with seabed contact, JONSWAP waves at the heave spring, with a start ramp
    "jonswap_wave": ("mooring_line", {"n_links": 10, "wave_source": "jonswap", "wave_hs": 3.0,
                                      "wave_tp": 8.0, "wave_ramp": 2.0}, 0.01, "Jonswap"),
}


class _Counter:
    def __init__(self, monkeypatch: pytest.MonkeyPatch, cls_name: str) -> None:
        cls = getattr(signals_py, cls_name)
        orig = cls.__call__
        self.calls = 0

        def counted(sig, t):
            self.calls += 1
            return orig(sig, t)

        monkeypatch.setattr(cls, "__call__", counted)


def _python_twin(sim: Simulation) -> RK4:
    """The same system (same inputs, held values), stepped by the Python RK4."""
    integ = RK4(sim.system, step=sim.h, compiled=False)
    assert not integ.compiled
    return integ


@pytest.mark.parametrize("case", sorted(CASES))
def test_compiled_inputs_equal_the_python_path(case: str, monkeypatch: pytest.MonkeyPatch) -> None:
    name, ov, h, cls_name = CASES[case]
    sim = Simulation(load_scene(name, ov), integrator="rk4", step=h)
    assert sim.integrator.compiled and sim.system.input_program() is not None
    assert (sim._heave_signal if cls_name == "Sine" else sim._wave_signal).ramp > 0
    counter = _Counter(monkeypatch, cls_name)
    y0 = sim.y.copy()
    # the compiled path: single steps (the node), a held input from step 50, then one advance
    # over 3 s (a fixed-step run: one compiled call)
    for k in range(100):
        if k == 50:
            sim.set_heave_force(800.0)
            sim.set_wave_elevation(-0.2)
        sim.step()
    y_c = sim.integrator.advance(sim.t, sim.y, sim.t + 3.0)
    assert counter.calls == 0  # no Python signal call in a compiled step
    # the Python path on the same system, same held values at the same steps
    sim.set_heave_force(0.0)
    sim.set_wave_elevation(0.0)
    py = _python_twin(sim)
    py.reset_energy_budget(y0)
    y = y0
    for k in range(100):
        if k == 50:
            sim.set_heave_force(800.0)
            sim.set_wave_elevation(-0.2)
        y = py.step(k * h, y, h)
    y_p = py.advance(100 * h, y, 100 * h + 3.0)
    assert counter.calls > 0
    scale = np.max(np.abs(y_p))
    assert np.max(np.abs(y_c - y_p)) <= REL * scale
    assert py.nsteps == sim.integrator.nsteps
    # the inputs really drive the run (not a trivially quiet state)
    assert np.max(np.abs(y_c - y0)) > 1e-3 * scale


def test_budget_equals_python_sampling_over_a_call() -> None:
    """arm_checks gets the same largest |u|, |eta| as from the Python samples, so the energy
    budget of a run is that of the compiled path sampling in Python (before input programs)."""
    scene = load_scene("mooring_line", {"n_links": 8, "wave_source": "jonswap", "wave_ramp": 1.0,
                                        "heave_force_source": "sine", "heave_force_amplitude": 5e3})
    sims = [Simulation(scene, integrator="rk4", step=0.01) for _ in range(2)]
    f = sims[1].system.input_at
    sims[1].system.input_at = lambda t: f(t)  # no program: Python sampling
    assert sims[1].system.input_program() is None
    ys = []
    for sim in sims:
        y = sim.y
        for t0, t1 in ((0.0, 0.01), (0.01, 0.5), (0.5, 4.0), (4.0, 4.02)):
            y = sim.integrator.advance(t0, y, t1)
        ys.append(y)
    assert np.max(np.abs(ys[0] - ys[1])) <= REL * np.max(np.abs(ys[1]))
    assert sims[0].integrator.kinetic_energy_bound == pytest.approx(
        sims[1].integrator.kinetic_energy_bound, rel=1e-12)
    sim = sims[0]
    integ = sim.integrator
    for t0, n in ((0.0, 1), (0.37, 250), (12.0, 3)):
        u, eta, umax, emax = integ._sample_inputs(t0, 0.01, n)
        f = sim.inputs_at
        tt = (t0 + np.arange(n)[:, None] * 0.01) + np.array(integ._fast_offsets)[None, :] * 0.01
        ins = [[f(float(t)) for t in row] for row in tt]
        u_py = np.array([[i.heave_force for i in r] for r in ins])
        eta_py = np.array([[i.wave_elevation for i in r] for r in ins])
        assert np.max(np.abs(eta - eta_py)) <= 1e-12 * 3.0 and np.max(np.abs(u - u_py)) <= 1e-12 * 5e3
        assert emax == pytest.approx(np.abs(eta_py).max(), rel=1e-12)
        assert umax == np.abs(u).max()


def test_program_follows_the_callable() -> None:
    sim = Simulation(load_scene("paper_anchored_forced", {"n_links": 4}))
    system = sim.system
    assert system.input_program() is not None
    # a caller that swaps the callable (e.g. to freeze the inputs) drops the program
    saved = system.input_at
    system.input_at = lambda t: Inputs(1.0, 0.0)
    assert system.input_program() is None
    system.input_at = saved
    assert system.input_program() is not None
    # an arbitrary callable has none; a held Inputs on the fast kernel gets one
    assert CableSystem(sim.model, lambda t: Inputs(), "fast").input_program() is None
    held = CableSystem(sim.model, Inputs(123.0, -0.5), "fast")
    integ = RK4(held, step=0.002)
    u, eta, umax, emax = integ._sample_inputs(0.3, 0.002, 4)
    assert np.all(u == 123.0) and np.all(eta == -0.5) and (umax, emax) == (123.0, 0.5)
    # the dense kernel needs no compiled program
    assert CableSystem(sim.model, Inputs(1.0, 0.0), "dense").input_program() is None
    # held values written through the Simulation reach the program
    sim.set_heave_force(-42.0)
    sim.held_wave_elevation = 0.25
    u, eta, _, _ = sim.integrator._sample_inputs(0.0, sim.h, 1)
    assert u[0, 0] == pytest.approx(-42.0, abs=1e-12) and eta[0, 0] == 0.25
